//! Membranes: flexible boundaries that carry a pressure onto the outermost grains and follow
//! them as they move (the rubber membranes of the unconfined biaxial test, the outer boundary
//! of the cylinder test). A membrane is the chain of outermost grains, found anew at the start
//! of an increment and in every topology pass. Its pressure acts on the polyline through their
//! centres, each segment `e` carrying `p D |e|` along its inward normal, half to each end.
//! The load enters the global equations directly (no servo), with its tangent.

use super::chain_watch::{ChainHold, Start};
use super::{surely_longer, surely_shorter, CellGrid, SQUARED_DOUBT};
use std::cell::RefCell;
use std::f64::consts::TAU;

/// Which boundary a membrane covers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MembraneShape {
    /// The side of the sample facing `outward` (a unit vector), from one end of the sample to
    /// the other along the side; end pieces reach the sample's extent, so the whole side
    /// carries `p * extent * D`.
    Side {
        /// Unit vector pointing out of the sample through this side.
        outward: [f64; 2],
    },
    /// All around the sample, about `center` (the outer boundary of an annulus).
    Ring {
        /// Centre the chain goes around.
        center: [f64; 2],
    },
}

/// A membrane and its current chain.
#[derive(Debug, Clone, PartialEq)]
pub struct Membrane {
    /// Name used by the load program.
    pub name: String,
    /// Which boundary.
    pub shape: MembraneShape,
    /// Pressure (Pa), compression positive.
    pub pressure: f64,
}

/// The chain of a membrane: grains in order with the sample on the left, and whether it
/// closes on itself.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Chain {
    /// Grains along the membrane.
    pub grains: Vec<usize>,
    /// Whether the last grain links back to the first.
    pub closed: bool,
    /// For a side: the direction along it (sample on the left) and the sample's extent along
    /// it, `[lo, hi]` (m). The end pieces from `lo` to the first grain and from the last grain
    /// to `hi` load the end grains, so the side carries `p (hi - lo) D` in all.
    pub along: [f64; 2],
    /// See `along`.
    pub extent: [f64; 2],
}

impl Chain {
    /// Consecutive grain pairs of the chain.
    pub fn links(&self) -> Vec<(usize, usize)> {
        self.segments()
            .map(|(k, l)| (self.grains[k], self.grains[l]))
            .collect()
    }

    /// Consecutive places `(k, k + 1)` in the chain, and the closing one of a closed chain.
    fn segments(&self) -> impl Iterator<Item = (usize, usize)> {
        let n = self.grains.len();
        let closing = (self.closed && n > 2).then_some((n - 1, 0));
        (1..n).map(|k| (k - 1, k)).chain(closing)
    }
}

/// Radius of the probe that finds a membrane's grains, in mean grain radii: the membrane
/// bridges any pocket between surface grains that the probe does not fit into.
const PROBE_RADII: f64 = 2.0;

/// Each membrane's chain on grains at `position` with `radius`, over the grains that may
/// carry it (`carrying`) and those not `taken_out` (see [`Membrane::chain`]).
pub fn chains(
    membranes: &[Membrane],
    position: &[[f64; 2]],
    radius: &[f64],
    carrying: &[bool],
    taken_out: &[bool],
) -> Vec<Chain> {
    membranes
        .iter()
        .map(|m| m.chain(position, radius, carrying, taken_out))
        .collect()
}

impl Membrane {
    /// The grains a membrane lies on: those a probe disc touches as it rolls around the outside
    /// of the sample ("ball pivoting"), in order, sample on the left. A side starts from its
    /// outermost grain and rolls both ways until the probe turns past the side's ends; a ring
    /// rolls all the way round. The chain follows the grains as they are now, so it is found
    /// anew whenever they move, pockets and bulges included. The probe passes through the
    /// grains that may not carry the membrane (`carrying[i]` false): loose grains with no
    /// support to push against, which a pressure would only push into the sample until they
    /// met one, a motion with no equilibrium on the way. A side reaches as far as the grains
    /// of the sample do, those `taken_out` of it left out (they never carry either).
    pub fn chain(
        &self,
        position: &[[f64; 2]],
        radius: &[f64],
        carrying: &[bool],
        taken_out: &[bool],
    ) -> Chain {
        self.roll(position, radius, carrying, taken_out, false).0
    }

    /// [`Membrane::chain`], and with `hold` how far its grains may move before the probe
    /// could find another ([`ChainHold`]).
    pub(super) fn roll(
        &self,
        position: &[[f64; 2]],
        radius: &[f64],
        carrying: &[bool],
        taken_out: &[bool],
        hold: bool,
    ) -> (Chain, Option<ChainHold>) {
        if !carrying.iter().any(|&c| c) {
            let none = hold.then(ChainHold::default);
            return (Chain::default(), none);
        }
        let r_mean = radius.iter().sum::<f64>() / radius.len() as f64;
        let roll = Roll::new(position, radius, carrying, PROBE_RADII * r_mean);
        let dot = |u: [f64; 2], v: [f64; 2]| u[0] * v[0] + u[1] * v[1];
        // The last of the grains that reach furthest.
        let outermost = |reach: &dyn Fn(usize) -> f64| {
            (0..position.len())
                .filter(|&i| carrying[i])
                .map(|i| (reach(i), i))
                .max_by(|a, b| a.0.total_cmp(&b.0))
                .expect("grains")
                .1
        };
        // With a hold, the grains that reach nearly as far, as a hold needs them.
        let rivals = |start: usize| {
            hold.then(|| Start::among(start, self.shape, position, radius, carrying, r_mean))
        };
        let (chain, start) = match self.shape {
            MembraneShape::Side { outward } => {
                // Along the side: the outward normal turned 90 degrees anticlockwise keeps the
                // sample on the left.
                let along = [-outward[1], outward[0]];
                let reach = |i: usize| dot(position[i], outward) + radius[i];
                let start = outermost(&reach);
                let facing = outward[1].atan2(outward[0]);
                let mut grains = roll.side(start, facing, -1.0);
                grains.reverse();
                grains.extend(roll.side(start, facing, 1.0).into_iter().skip(1));
                let chain = Chain {
                    grains,
                    closed: false,
                    along,
                    extent: extent(position, radius, taken_out, along),
                };
                (chain, rivals(start))
            }
            MembraneShape::Ring { center } => {
                let offset = |i: usize| [position[i][0] - center[0], position[i][1] - center[1]];
                let reach = |i: usize| offset(i)[0].hypot(offset(i)[1]) + radius[i];
                let start = outermost(&reach);
                let facing = offset(start)[1].atan2(offset(start)[0]);
                let chain = Chain {
                    grains: roll.ring(start, facing),
                    closed: true,
                    along: [0.0; 2],
                    extent: [0.0; 2],
                };
                (chain, rivals(start))
            }
        };
        let hold = start.map(|start| ChainHold::found_on(&roll.rolled.borrow(), &roll, start));
        (chain, hold)
    }
}

/// The sample's extent `[lo, hi]` (m) along a side's direction `along`, over the grains not
/// `taken_out`.
pub(super) fn extent(
    position: &[[f64; 2]],
    radius: &[f64],
    taken_out: &[bool],
    along: [f64; 2],
) -> [f64; 2] {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let kept = position.iter().zip(radius).zip(taken_out);
    for ((p, r), _) in kept.filter(|(_, &out)| !out) {
        let at = p[0] * along[0] + p[1] * along[1];
        lo = lo.min(at - r);
        hi = hi.max(at + r);
    }
    [lo, hi]
}

impl Chain {
    /// The membrane's force on each grain of the chain, at `position`, for pressure times
    /// depth `pressure_depth`: each segment's `p D` times the segment turned a quarter turn
    /// (into the sample), half to each end; on a side, the end pieces from the side's ends to
    /// the first and last grain push those grains inward.
    pub fn loads(
        &self,
        shape: MembraneShape,
        position: &[[f64; 2]],
        pressure_depth: f64,
    ) -> Vec<(usize, [f64; 2])> {
        let mut loads: Vec<(usize, [f64; 2])> =
            self.grains.iter().map(|&g| (g, [0.0; 2])).collect();
        let count = loads.len();
        for (k, next) in self.segments() {
            let f = segment_force(
                position[self.grains[k]],
                position[self.grains[next]],
                pressure_depth,
            );
            for at in [k, next] {
                loads[at].1[0] += f[0];
                loads[at].1[1] += f[1];
            }
        }
        if let (MembraneShape::Side { outward }, Some(first), Some(last)) =
            (shape, self.grains.first(), self.grains.last())
        {
            let proj =
                |g: &usize| position[*g][0] * self.along[0] + position[*g][1] * self.along[1];
            let ends = [
                (0, proj(first) - self.extent[0]),
                (count - 1, self.extent[1] - proj(last)),
            ];
            for (at, length) in ends {
                loads[at].1[0] -= pressure_depth * length * outward[0];
                loads[at].1[1] -= pressure_depth * length * outward[1];
            }
        }
        loads
    }
}

/// A probe disc of radius `probe` rolling around the outside of the grains.
pub(super) struct Roll<'a> {
    pub(super) position: &'a [[f64; 2]],
    pub(super) radius: &'a [f64],
    /// Grains the probe rests on; it passes through the others.
    pub(super) carrying: &'a [bool],
    pub(super) probe: f64,
    /// The largest grain's radius and the probe's: a grain is within the probe's reach of a
    /// pivot `r_i + probe` from it when its centre is within `r_i + widest` of the pivot's.
    pub(super) widest: f64,
    /// Cells `widest` across: a pivot's reach spans at most five of them, which holds fewer
    /// grains out of reach than three of twice the width.
    pub(super) grid: CellGrid,
    /// The grains within the probe's reach of the pivot, with their estimated turns.
    reached: RefCell<Vec<(f64, usize)>>,
    /// Every roll about a grain made so far, in order.
    rolled: RefCell<Vec<Rolled>>,
}

/// One roll of the probe about a grain ([`Roll::pivot`]) and what it found.
#[derive(Debug, Clone, Copy)]
pub(super) struct Rolled {
    /// The grain rolled about, the direction the probe started from and the sense.
    pub(super) pivot: usize,
    pub(super) angle: f64,
    pub(super) sense: f64,
    /// The grain the probe rolled onto and its turn; none within reach.
    pub(super) found: Option<(usize, f64)>,
    /// On a side, the direction it faces: the roll ends where the probe would turn more than
    /// a quarter turn from it.
    pub(super) facing: Option<f64>,
    /// Whether the roll starts the chain, from the outermost grain.
    pub(super) first: bool,
}

impl<'a> Roll<'a> {
    fn new(
        position: &'a [[f64; 2]],
        radius: &'a [f64],
        carrying: &'a [bool],
        probe: f64,
    ) -> Roll<'a> {
        let widest = radius.iter().cloned().fold(0.0, f64::max) + probe;
        Roll {
            position,
            radius,
            carrying,
            probe,
            widest,
            grid: CellGrid::new(position, widest),
            reached: RefCell::default(),
            rolled: RefCell::default(),
        }
    }

    /// The grains from `start` on a side, the probe rolling from the direction `facing`
    /// (anticlockwise for `sense` 1, clockwise for -1) until it would turn more than a quarter
    /// turn away from `facing`, round the side's end.
    fn side(&self, start: usize, facing: f64, sense: f64) -> Vec<usize> {
        let quarter = 0.5 * std::f64::consts::PI;
        let (mut grains, mut pivot, mut angle) = (vec![start], start, facing);
        while let Some((next, turn, landed)) =
            self.rolled(pivot, angle, sense, Some(facing), pivot == start)
        {
            if sense * wrap(angle + sense * turn - facing) > quarter || grains.contains(&next) {
                break;
            }
            grains.push(next);
            (pivot, angle) = (next, landed);
        }
        grains
    }

    /// The closed chain around all grains, from `start` anticlockwise; when the probe comes
    /// round to a link it has rolled over before, the chain closes there.
    fn ring(&self, start: usize, facing: f64) -> Vec<usize> {
        let (mut grains, mut pivot, mut angle) = (vec![start], start, facing);
        let mut links = std::collections::HashSet::new();
        while let Some((next, _, landed)) = self.rolled(pivot, angle, 1.0, None, pivot == start) {
            if next == start {
                break;
            }
            if !links.insert((pivot, next)) {
                // A loop that does not pass through the start: keep the loop alone.
                let first = grains.iter().position(|&g| g == next).expect("visited");
                grains.drain(..first);
                break;
            }
            grains.push(next);
            (pivot, angle) = (next, landed);
        }
        grains
    }

    /// [`Roll::pivot`], recorded in `rolled`.
    fn rolled(
        &self,
        i: usize,
        angle: f64,
        sense: f64,
        facing: Option<f64>,
        first: bool,
    ) -> Option<(usize, f64, f64)> {
        let found = self.pivot(i, angle, sense);
        self.rolled.borrow_mut().push(Rolled {
            pivot: i,
            angle,
            sense,
            found: found.map(|(j, turn, _)| (j, turn)),
            facing,
            first,
        });
        found
    }

    /// Roll the probe, resting on grain `i` in the direction `angle`, about `i` in the given
    /// sense until it touches another grain: that grain, the turn (rad) and the probe's
    /// direction seen from the new grain. `None` when nothing is within reach.
    ///
    /// The turn to each grain within reach is first estimated without trigonometry (the
    /// pseudo-angle of the probe's centre where it touches that grain); the exact turn,
    /// [`exact_turn`], is taken only for the grains whose estimate is within [`SCREEN`] of the
    /// least, or of a whole turn, so the grain found is the one the exact turns alone pick.
    fn pivot(&self, i: usize, angle: f64, sense: f64) -> Option<(usize, f64, f64)> {
        let (p, a) = (self.position[i], self.radius[i] + self.probe);
        let facing = [angle.cos(), angle.sin()];
        let mut reached = self.reached.borrow_mut();
        reached.clear();
        // A hair wider than the reach, so that rounding at a cell's edge loses no grain.
        let window = (a + self.widest) * (1.0 + SQUARED_DOUBT);
        for j in self.grid.within(p, window) {
            let q = self.position[j];
            let b = self.radius[j] + self.probe;
            let branch = [q[0] - p[0], q[1] - p[1]];
            // Most grains near are out of the probe's reach, which needs no square root.
            let (reach, inner) = (a + b, (a - b).abs());
            if j == i || !self.carrying[j] || surely_longer(branch, reach) {
                continue;
            }
            let d2 = branch[0] * branch[0] + branch[1] * branch[1];
            let clearly_within =
                surely_shorter(branch, reach) && d2 > (1.0 + SQUARED_DOUBT) * inner * inner;
            if !clearly_within {
                let d = branch[0].hypot(branch[1]);
                if d >= reach || d <= inner {
                    continue;
                }
            }
            reached.push((estimated_turn(branch, d2, a, b, facing, sense), j));
        }
        let away_from_whole = |t: f64| (SCREEN..=4.0 - SCREEN).contains(&t);
        let least = reached
            .iter()
            .map(|&(t, _)| t)
            .filter(|&t| away_from_whole(t))
            .fold(f64::INFINITY, f64::min);
        let mut best: Option<(f64, usize)> = None;
        for &(t, j) in reached.iter() {
            if t > least + SCREEN && away_from_whole(t) {
                continue;
            }
            let (q, b) = (self.position[j], self.radius[j] + self.probe);
            let turn = exact_turn(p, a, q, b, angle, sense);
            if best.is_none_or(|(t, k)| turn < t || (turn == t && j < k)) {
                best = Some((turn, j));
            }
        }
        let (turn, j) = best?;
        let at = angle + sense * turn;
        let centre = [p[0] + a * at.cos(), p[1] + a * at.sin()];
        let q = self.position[j];
        Some((j, turn, (centre[1] - q[1]).atan2(centre[0] - q[0])))
    }
}

/// The turn the probe rolls from the direction `facing` (a unit vector) about a pivot, `a` from
/// its centre, before it comes `b` from the centre of a grain `branch` from the pivot's
/// (`d2` its squared length), as a pseudo-angle ([`pseudo_angle`]): without trigonometry. For
/// a grain beyond the reach, the turn at which it would come within it.
pub(super) fn estimated_turn(
    branch: [f64; 2],
    d2: f64,
    a: f64,
    b: f64,
    facing: [f64; 2],
    sense: f64,
) -> f64 {
    // The probe's centre where it touches the grain, from the pivot: `a` along the direction
    // `alpha - sense beta` of `exact_turn`.
    let along = (a * a + d2 - b * b) / (2.0 * d2);
    let across = sense * (a * a / d2 - along * along).max(0.0).sqrt();
    let centre = [
        along * branch[0] + across * branch[1],
        along * branch[1] - across * branch[0],
    ];
    let cos = facing[0] * centre[0] + facing[1] * centre[1];
    let sin = sense * (facing[0] * centre[1] - facing[1] * centre[0]);
    pseudo_angle(sin, cos)
}

/// How close, in pseudo-angle ([`pseudo_angle`]; at least as much in radians), an estimated
/// turn must come to the least, or to a whole turn, for its exact turn to be taken: far above
/// the rounding of either (about 1e-8 rad where the probe only grazes a grain).
const SCREEN: f64 = 1e-6;

/// The turn (rad, in `[0, 2 pi)`) the probe's centre, `a` from the pivot's centre `p`, rolls
/// about `p` from the direction `angle`, in `sense`, before it comes `b` from the centre `q`
/// of another grain (the probe's radius plus that grain's), which is within its reach.
pub(super) fn exact_turn(p: [f64; 2], a: f64, q: [f64; 2], b: f64, angle: f64, sense: f64) -> f64 {
    let d = (q[0] - p[0]).hypot(q[1] - p[1]);
    // The probe touches `q` at angles alpha -+ beta about `p`; rolling in `sense` it meets
    // the first of these.
    let alpha = (q[1] - p[1]).atan2(q[0] - p[0]);
    let beta = ((a * a + d * d - b * b) / (2.0 * a * d))
        .clamp(-1.0, 1.0)
        .acos();
    (sense * (alpha - sense * beta - angle)).rem_euclid(TAU)
}

/// A measure of the angle of `(cos, sin)` from 0 to 4 that grows with it (a quarter turn
/// for each unit, at a rate between 1/2 and 1 per radian): the "diamond angle".
fn pseudo_angle(sin: f64, cos: f64) -> f64 {
    match (sin >= 0.0, cos >= 0.0) {
        (true, true) => sin / (cos + sin),
        (true, false) => 1.0 - cos / (sin - cos),
        (false, false) => 2.0 - sin / (-cos - sin),
        (false, true) => 3.0 + cos / (cos - sin),
    }
}

/// An angle brought into (-pi, pi].
pub(super) fn wrap(angle: f64) -> f64 {
    let a = angle.rem_euclid(TAU);
    if a > std::f64::consts::PI {
        a - TAU
    } else {
        a
    }
}

/// The force of one membrane segment from `a` to `b` on each of its ends, with the sample on
/// the left: `p D / 2` times the segment turned 90 degrees anticlockwise.
fn segment_force(a: [f64; 2], b: [f64; 2], pressure_depth: f64) -> [f64; 2] {
    let e = [b[0] - a[0], b[1] - a[1]];
    [-0.5 * pressure_depth * e[1], 0.5 * pressure_depth * e[0]]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Equal grains on a square lattice, `n` by `n`, touching.
    fn square(n: usize) -> (Vec<[f64; 2]>, Vec<f64>) {
        let mut position = Vec::new();
        for i in 0..n {
            for j in 0..n {
                position.push([2.0 * j as f64, 2.0 * i as f64]);
            }
        }
        let radius = vec![1.0; position.len()];
        (position, radius)
    }

    fn membrane(shape: MembraneShape) -> Membrane {
        Membrane {
            name: "m".into(),
            shape,
            pressure: 1.0,
        }
    }

    #[test]
    fn a_side_lies_on_the_outer_column_in_order() {
        let (position, radius) = square(5);
        let left = membrane(MembraneShape::Side {
            outward: [-1.0, 0.0],
        });
        let chain = left.chain(
            &position,
            &radius,
            &vec![true; radius.len()],
            &vec![false; radius.len()],
        );
        // Left column, walked downwards (sample on the left of the walk).
        assert_eq!(chain.grains, vec![20, 15, 10, 5, 0]);
        assert_eq!(chain.extent, [-9.0, 1.0]);
        // Each grain pushed inward; the side carries p times its extent.
        let loads = chain.loads(left.shape, &position, 1.0);
        let total: f64 = loads.iter().map(|(_, f)| f[0]).sum();
        assert!((total - 10.0).abs() < 1e-12, "{total}");
        assert!(loads.iter().all(|(_, f)| f[0] > 0.0 && f[1].abs() < 1e-12));
    }

    #[test]
    fn a_grain_standing_out_joins_the_side_and_a_narrow_pocket_is_bridged() {
        let (mut position, radius) = square(5);
        // Grain 10 (left column, middle) pushed out; grain 5 pulled in by half a radius.
        position[10][0] -= 0.8;
        position[5][0] += 0.5;
        let left = membrane(MembraneShape::Side {
            outward: [-1.0, 0.0],
        });
        let chain = left.chain(
            &position,
            &radius,
            &vec![true; radius.len()],
            &vec![false; radius.len()],
        );
        assert!(chain.grains.contains(&10));
        // The probe (two radii) does not reach between 10 and 0 to touch 5.
        assert!(!chain.grains.contains(&5), "{:?}", chain.grains);
    }

    #[test]
    fn the_probe_passes_over_a_grain_that_may_not_carry() {
        let (position, radius) = square(6);
        let ring = membrane(MembraneShape::Ring { center: [5.0, 5.0] });
        // Grain 2 on the bottom edge is loose: the chain bridges it, onto its neighbours.
        let mut carrying = vec![true; radius.len()];
        carrying[2] = false;
        let chain = ring.chain(&position, &radius, &carrying, &vec![false; radius.len()]);
        assert!(!chain.grains.contains(&2), "{:?}", chain.grains);
        let at = chain.grains.iter().position(|&g| g == 1).expect("grain 1");
        assert_eq!(chain.grains[(at + 1) % chain.grains.len()], 3);
    }

    /// The screened pivot finds what the exact turns of every grain within reach pick, on
    /// random packings of mixed sizes, from random directions, both ways round.
    #[test]
    fn the_screened_pivot_is_the_exact_one() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        for _ in 0..200 {
            let n = rng.random_range(2..60);
            let position: Vec<[f64; 2]> = (0..n)
                .map(|_| [rng.random_range(0.0..12.0), rng.random_range(0.0..12.0)])
                .collect();
            let radius: Vec<f64> = (0..n).map(|_| rng.random_range(0.3..1.5)).collect();
            let carrying: Vec<bool> = (0..n).map(|_| rng.random_bool(0.9)).collect();
            let r_mean = radius.iter().sum::<f64>() / n as f64;
            let probe = PROBE_RADII * r_mean;
            let roll = Roll::new(&position, &radius, &carrying, probe);
            for _ in 0..20 {
                let i = rng.random_range(0..n);
                let angle = rng.random_range(-4.0..4.0);
                let sense = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
                let a = radius[i] + probe;
                let mut best: Option<(f64, usize)> = None;
                for j in (0..n).filter(|&j| j != i && carrying[j]) {
                    let b = radius[j] + probe;
                    let d =
                        (position[j][0] - position[i][0]).hypot(position[j][1] - position[i][1]);
                    if d >= a + b || d <= (a - b).abs() {
                        continue;
                    }
                    let turn = exact_turn(position[i], a, position[j], b, angle, sense);
                    if best.is_none_or(|(t, k)| turn < t || (turn == t && j < k)) {
                        best = Some((turn, j));
                    }
                }
                let found = roll.pivot(i, angle, sense);
                assert_eq!(found.map(|f| (f.1, f.0)), best, "grain {i} of {n}");
            }
        }
    }

    #[test]
    fn a_ring_goes_round_anticlockwise_and_pushes_inward() {
        let (position, radius) = square(6);
        let ring = membrane(MembraneShape::Ring { center: [5.0, 5.0] });
        let chain = ring.chain(
            &position,
            &radius,
            &vec![true; radius.len()],
            &vec![false; radius.len()],
        );
        // The 20 grains of the outer square, once each.
        assert_eq!(chain.grains.len(), 20);
        let mut sorted = chain.grains.clone();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), 20);
        let corners: Vec<[f64; 2]> = chain.grains.iter().map(|&g| position[g]).collect();
        assert!(
            crate::geometry::polygon_area(&corners) > 0.0,
            "anticlockwise"
        );
        let loads = chain.loads(ring.shape, &position, 1.0);
        let (mut fx, mut fy) = (0.0, 0.0);
        for (g, f) in &loads {
            let out = [position[*g][0] - 5.0, position[*g][1] - 5.0];
            assert!(
                f[0] * out[0] + f[1] * out[1] < 0.0,
                "grain {g} pushed inward"
            );
            fx += f[0];
            fy += f[1];
        }
        assert!(fx.abs() < 1e-12 && fy.abs() < 1e-12);
    }
}
