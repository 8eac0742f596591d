//! The membranes' chains kept while their grains move too little to change them. A chain is
//! found by a sequence of discrete choices of the probe ([`Membrane::chain`]): the outermost
//! grain it starts from, which grains near each pivot lie within its reach, which of those it
//! turns least to reach, and where a side ends. Each choice is a comparison of lengths or of
//! turns that stood some margin from going the other way. A move of two grains relative to
//! each other by `s` changes the distance between them by at most `s` and the turn of the
//! probe from one to the other by at most a bound that grows with `s` ([`TurnHold::error`]).
//! While every margin exceeds its change, the probe would make the same choices and find the
//! same chain, which is then taken as it was without rolling the probe again: the same chain
//! to the last bit (a side's extent, which moves with every grain, is measured anew).

use super::membrane::{estimated_turn, exact_turn, extent, wrap, Roll, Rolled};
use super::{Chain, Membrane, MembraneShape, SQUARED_DOUBT};
use crate::memory::HeapBytes;
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::ops::Range;

/// Room (rad) left for rounding in a comparison of turns: far above it (about 1e-8 where the
/// probe only grazes a grain).
const TURN_SLACK: f64 = 1e-7;

/// Room for rounding in a comparison of lengths, as a share of the probe's radius.
const LENGTH_SLACK: f64 = 1e-9;

/// Within this pseudo-angle of the chosen grain's, or of a whole turn, a grain's turn is
/// measured exactly; further, its pseudo-angle bounds its gap from below (a pseudo-angle
/// grows by at most one a radian).
const NEAR_PSEUDO: f64 = 0.25;

/// `|acos x - acos y| <= ACOS_HOLDER sqrt|x - y|` on `[-1, 1]` (`pi / sqrt 2` and a little).
const ACOS_HOLDER: f64 = 2.23;

/// Each membrane's chain, found anew only where grains moved far enough since the last to
/// change a choice of the probe.
#[derive(Debug, Clone, Default)]
pub struct ChainWatch {
    /// The chains last found, and what they were found on.
    chains: Vec<Chain>,
    holds: Vec<ChainHold>,
    position: Vec<[f64; 2]>,
    radius: Vec<f64>,
    carrying: Vec<bool>,
    taken_out: Vec<bool>,
}

impl ChainWatch {
    /// Each membrane's chain on grains at `position`, as [`super::chains`] finds it.
    pub fn chains(
        &mut self,
        membranes: &[Membrane],
        position: &[[f64; 2]],
        radius: &[f64],
        carrying: &[bool],
        taken_out: &[bool],
    ) -> Vec<Chain> {
        if self.still_found(membranes.len(), position, radius, carrying, taken_out) {
            return (self.chains.iter().zip(membranes))
                .map(|(chain, m)| {
                    let mut chain = chain.clone();
                    if let MembraneShape::Side { .. } = m.shape {
                        chain.extent = extent(position, radius, taken_out, chain.along);
                    }
                    chain
                })
                .collect();
        }
        let (chains, holds): (Vec<Chain>, Vec<ChainHold>) = membranes
            .iter()
            .map(|m| {
                let (chain, hold) = m.roll(position, radius, carrying, taken_out, true);
                (chain, hold.expect("a hold was asked for"))
            })
            .unzip();
        self.chains.clone_from(&chains);
        self.holds = holds;
        copy(&mut self.position, position);
        copy(&mut self.radius, radius);
        copy(&mut self.carrying, carrying);
        copy(&mut self.taken_out, taken_out);
        chains
    }

    /// The bytes it holds on the heap.
    pub(crate) fn heap_bytes(&self) -> usize {
        let chains: usize = self.chains.iter().map(|c| c.grains.heap_bytes()).sum();
        let holds: usize = (self.holds.iter())
            .map(|h| {
                h.start.rivals.heap_bytes()
                    + h.lengths.heap_bytes()
                    + h.pivots.heap_bytes()
                    + h.turns.heap_bytes()
            })
            .sum();
        chains
            + self.chains.heap_bytes()
            + holds
            + self.holds.heap_bytes()
            + self.position.heap_bytes()
            + self.radius.heap_bytes()
            + self.carrying.heap_bytes()
            + self.taken_out.heap_bytes()
    }

    /// Whether the chains last found are those the probe would find now: the same grains
    /// may carry, and none has moved far enough to change a choice.
    fn still_found(
        &self,
        count: usize,
        position: &[[f64; 2]],
        radius: &[f64],
        carrying: &[bool],
        taken_out: &[bool],
    ) -> bool {
        if self.chains.len() != count
            || self.position.len() != position.len()
            || carrying != self.carrying
            || taken_out != self.taken_out
            || radius != self.radius
        {
            return false;
        }
        let moves = Moves {
            now: position,
            then: &self.position,
        };
        let anywhere = (0..position.len())
            .filter(|&g| carrying[g])
            .map(|g| {
                let (p, q) = (position[g], self.position[g]);
                (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)
            })
            .fold(0.0, |most: f64, m| {
                if most.is_nan() || m.is_nan() {
                    f64::NAN
                } else {
                    most.max(m)
                }
            })
            .sqrt();
        self.holds
            .iter()
            .all(|h| h.holds(&moves, &self.radius, anywhere))
    }
}

/// `from` into `into`, in the storage it has.
fn copy<T: Clone>(into: &mut Vec<T>, from: &[T]) {
    into.clear();
    into.extend_from_slice(from);
}

/// The grains' moves since a chain was found.
struct Moves<'a> {
    now: &'a [[f64; 2]],
    then: &'a [[f64; 2]],
}

impl Moves<'_> {
    /// Of grain `g` (m).
    fn of(&self, g: usize) -> f64 {
        let (p, q) = (self.now[g], self.then[g]);
        length(p[0] - q[0], p[1] - q[1])
    }

    /// Of grain `j` relative to grain `i` (m).
    fn between(&self, i: usize, j: usize) -> f64 {
        self.squared_between(i, j).sqrt()
    }

    /// The square of [`Moves::between`].
    fn squared_between(&self, i: usize, j: usize) -> f64 {
        let (pi, qi, pj, qj) = (self.now[i], self.then[i], self.now[j], self.then[j]);
        let (x, y) = (
            (pj[0] - qj[0]) - (pi[0] - qi[0]),
            (pj[1] - qj[1]) - (pi[1] - qi[1]),
        );
        x * x + y * y
    }
}

/// The length of `(x, y)`, without `hypot`'s care for overflow: a move is far from it.
fn length(x: f64, y: f64) -> f64 {
    (x * x + y * y).sqrt()
}

/// The grain a chain starts from: the one that reaches furthest (out along a side's normal,
/// or from a ring's centre), and the grains that come near it.
#[derive(Debug, Clone)]
pub(super) struct Start {
    grain: usize,
    shape: MembraneShape,
    /// The grains that reach within a mean radius of it.
    rivals: Vec<usize>,
    /// The mean radius: any other grain reaches less by at least this.
    others: f64,
    /// A ring's: its distance from the centre, from which the probe's first direction is
    /// taken; none on a side.
    from_centre: Option<f64>,
}

impl Default for Start {
    fn default() -> Start {
        Start {
            grain: 0,
            shape: MembraneShape::Ring { center: [0.0; 2] },
            rivals: Vec::new(),
            others: 0.0,
            from_centre: None,
        }
    }
}

impl Start {
    /// The start `grain` of a chain of shape `shape` among the grains at `position` that may
    /// carry (`carrying`).
    pub(super) fn among(
        grain: usize,
        shape: MembraneShape,
        position: &[[f64; 2]],
        radius: &[f64],
        carrying: &[bool],
        r_mean: f64,
    ) -> Start {
        let p = position[grain];
        let from_centre = match shape {
            MembraneShape::Side { .. } => None,
            MembraneShape::Ring { center } => Some(length(p[0] - center[0], p[1] - center[1])),
        };
        let mut start = Start {
            grain,
            shape,
            rivals: Vec::new(),
            others: r_mean,
            from_centre,
        };
        let furthest = start.reach(grain, position, radius);
        start.rivals = (0..position.len())
            .filter(|&k| carrying[k] && k != grain)
            .filter(|&k| furthest - start.reach(k, position, radius) < r_mean)
            .collect();
        start
    }

    /// How far grain `k` reaches (m).
    fn reach(&self, k: usize, position: &[[f64; 2]], radius: &[f64]) -> f64 {
        let p = position[k];
        match self.shape {
            MembraneShape::Side { outward } => p[0] * outward[0] + p[1] * outward[1] + radius[k],
            MembraneShape::Ring { center } => {
                length(p[0] - center[0], p[1] - center[1]) + radius[k]
            }
        }
    }

    /// Whether it is still the start after the grains' `moves`, none longer than `anywhere`:
    /// it reaches further than each rival, measured anew, and no other grain has come a mean
    /// radius nearer.
    fn holds(&self, moves: &Moves, radius: &[f64], anywhere: f64, slack: f64) -> bool {
        let furthest = self.reach(self.grain, moves.now, radius);
        2.0 * anywhere + slack < self.others
            && (self.rivals.iter()).all(|&k| self.reach(k, moves.now, radius) + slack < furthest)
    }
}

/// The choices of the probe that found one chain, each with how far it stood from going the
/// other way.
#[derive(Debug, Clone, Default)]
pub(super) struct ChainHold {
    start: Start,
    /// How far beyond every pivot's reach the grains not measured lie, at least (m).
    beyond: f64,
    /// Room for rounding in a comparison of lengths (m).
    slack: f64,
    /// Pairs of grains `(i, j, margin)` whose distance changes a choice where it changes by
    /// `margin`: the chosen grain's against the probe's reach, and a grain's that may come
    /// within reach of a pivot that reached none.
    lengths: Vec<(usize, usize, f64)>,
    pivots: Vec<PivotHold>,
    turns: Vec<TurnHold>,
}

/// One roll of the probe about a grain.
#[derive(Debug, Clone)]
struct PivotHold {
    /// Where the direction the probe started from came from.
    incoming: Incoming,
    /// The grain rolled onto (its `gap` is its turn), none where nothing was within reach.
    chosen: Option<TurnHold>,
    /// On a side, how far (rad) the probe's direction at the chosen grain stood from the
    /// side's end, and from the half turn where that direction wraps.
    end: f64,
    /// The other grains near, in `turns`.
    others: Range<usize>,
    /// Half the least margin of the others' turns from the chosen grain's and from a whole
    /// turn, less the room for rounding: while the chosen grain's turn and the incoming
    /// direction change by less, each other grain within its allowance keeps its order.
    chosen_budget: f64,
    incoming_budget: f64,
}

/// Where the direction a roll starts from came from.
#[derive(Debug, Clone, Copy)]
enum Incoming {
    /// A side's outward normal: fixed.
    Fixed,
    /// A ring's start grain, seen from the centre.
    Centre,
    /// Where the roll before left the probe: `a` from that roll's pivot `pivot`, `b` from
    /// this one's, `grain`.
    Roll {
        pivot: usize,
        grain: usize,
        a: f64,
        b: f64,
    },
}

/// A grain near a pivot: the margins of the probe's turn to it (to where it would come
/// within reach, for one beyond), and what bounds how much that turn changes.
#[derive(Debug, Clone, Copy)]
struct TurnHold {
    pivot: usize,
    grain: usize,
    /// How much more (rad) the probe turns to reach it than to reach the chosen grain, at
    /// least (for the chosen grain, its turn).
    gap: f64,
    /// How much less than a whole turn its turn is, at least.
    to_whole: f64,
    /// Its distance from the pivot (m) and the cosine `c` of the angle `beta` of
    /// [`exact_turn`]; `|dc/dd| <= k0 + k1 / d^2`.
    d: f64,
    c: f64,
    k0: f64,
    k1: f64,
    /// The square of the move relative to the pivot (m^2) that changes its turn by at most
    /// half its least margin ([`TurnHold::allowed`]).
    allowed: f64,
}

impl TurnHold {
    /// `grain`, `b` from the probe's centre where it touches, `d` from the centre of `pivot`,
    /// which is `a` from it.
    #[allow(clippy::too_many_arguments)]
    fn new(
        pivot: usize,
        grain: usize,
        gap: f64,
        to_whole: f64,
        a: f64,
        b: f64,
        d: f64,
    ) -> TurnHold {
        TurnHold {
            pivot,
            grain,
            gap,
            to_whole,
            d,
            c: (a * a + d * d - b * b) / (2.0 * a * d),
            k0: 0.5 / a,
            k1: (a * a - b * b).abs() / (2.0 * a),
            allowed: -1.0,
        }
        .with_allowance()
    }

    /// With `allowed` set: the largest move, within half the distance, for which either of
    /// two closed bounds on [`TurnHold::error`] stays within half the turn's least margin,
    /// less the room for rounding. Both bound the direction's change by `pi/2 m / d` and
    /// `|dc/dd|` by `k = k0 + 4 k1 / d^2`; one bounds `beta`'s change by the slope of `acos`
    /// where `dc` keeps `|c|` at most halfway to 1, linear in the move; the other by its
    /// Hoelder bound, `ACOS_HOLDER sqrt(k m)`, which holds everywhere.
    fn with_allowance(mut self) -> TurnHold {
        let budget = 0.5 * self.gap.min(self.to_whole) - TURN_SLACK;
        if budget <= 0.0 {
            return self;
        }
        let turning = FRAC_PI_2 / self.d;
        let k = self.k0 + 4.0 * self.k1 / (self.d * self.d);
        let linear = if self.c.abs() < 1.0 {
            let edge = 0.5 * (1.0 + self.c.abs());
            let slope = 1.0 / (1.0 - edge * edge).sqrt();
            (budget / (turning + k * slope)).min((1.0 - self.c.abs()) / (2.0 * k))
        } else {
            0.0
        };
        // turning x^2 + ACOS_HOLDER sqrt(k) x = budget, for x = sqrt(m).
        let b = ACOS_HOLDER * k.sqrt();
        let x = (-b + (b * b + 4.0 * turning * budget).sqrt()) / (2.0 * turning);
        let allowed = linear.max(x * x).min(0.5 * self.d);
        self.allowed = allowed * allowed;
        self
    }

    /// At most how much (rad) the turn to this grain changes when it moves by at most
    /// `moved` (m) relative to the pivot: the direction between their centres turns, and the
    /// angle `beta` changes with their distance (its cosine clamped to 1 beyond the reach).
    fn error(&self, moved: f64) -> f64 {
        let d = self.d - moved;
        if d <= 0.0 {
            return f64::INFINITY;
        }
        let dc = moved * (self.k0 + self.k1 / (d * d));
        let edge = self.c.abs() + dc;
        let by_slope = if edge < 1.0 {
            dc / (1.0 - edge * edge).sqrt()
        } else {
            f64::INFINITY
        };
        direction_change(moved, self.d) + by_slope.min(ACOS_HOLDER * dc.sqrt())
    }
}

/// At most how much (rad) the direction of a vector `length` long turns when its ends move by
/// `moved` relative to each other: `asin(moved / length) <= pi/2 moved / length`.
fn direction_change(moved: f64, length: f64) -> f64 {
    if moved < length {
        FRAC_PI_2 * moved / length
    } else {
        PI
    }
}

impl ChainHold {
    /// The hold of the chain found by the rolls `rolled` of `roll` from `start`.
    pub(super) fn found_on(rolled: &[Rolled], roll: &Roll, start: Start) -> ChainHold {
        // Grains further from every pivot than its reach by this are not measured: no move
        // that changes a length by less brings them within reach.
        let beyond = 0.5 * roll.widest;
        let mut hold = ChainHold {
            start,
            beyond,
            slack: LENGTH_SLACK * roll.probe,
            ..Default::default()
        };
        let mut before: Option<Incoming> = None;
        let mut near: Vec<(f64, usize, f64, f64)> = Vec::new();
        for r in rolled {
            let (i, p, a) = (
                r.pivot,
                roll.position[r.pivot],
                roll.radius[r.pivot] + roll.probe,
            );
            let facing = [r.angle.cos(), r.angle.sin()];
            near.clear();
            let window = (a + roll.widest) * (1.0 + SQUARED_DOUBT) + beyond;
            for j in roll.grid.within(p, window) {
                if j == i || !roll.carrying[j] {
                    continue;
                }
                let (q, b) = (roll.position[j], roll.radius[j] + roll.probe);
                let branch = [q[0] - p[0], q[1] - p[1]];
                let d2 = branch[0] * branch[0] + branch[1] * branch[1];
                let d = d2.sqrt();
                let (reach, inner) = (a + b, (a - b).abs());
                if d <= inner {
                    // Within the probe's inner reach: it stays there.
                    hold.lengths.push((i, j, inner - d));
                } else if d < reach + beyond {
                    let estimate = estimated_turn(branch, d2, a, b, facing, r.sense);
                    near.push((estimate, j, d, b));
                }
            }
            let incoming = match (r.first, r.facing) {
                (true, Some(_)) => Incoming::Fixed,
                (true, None) => Incoming::Centre,
                // A roll after one that found nothing is not made.
                (false, _) => before.unwrap_or(Incoming::Centre),
            };
            let Some((chosen, turn)) = r.found else {
                // Nothing within reach: every grain near stays out of it.
                for &(_, j, d, b) in &near {
                    hold.lengths.push((i, j, d - a - b));
                }
                hold.pivots.push(PivotHold {
                    incoming,
                    chosen: None,
                    end: f64::INFINITY,
                    others: 0..0,
                    chosen_budget: 0.0,
                    incoming_budget: 0.0,
                });
                before = None;
                continue;
            };
            let Some(&(chosen_estimate, _, d, b)) = near.iter().find(|x| x.1 == chosen) else {
                // The pivot and this measure part at the very edge of the reach.
                hold.lengths.push((i, chosen, 0.0));
                break;
            };
            // The chosen grain stays within reach.
            hold.lengths
                .push((i, chosen, (a + b - d).min(d - (a - b).abs())));
            let first = hold.turns.len();
            for &(estimate, j, d, b) in near.iter().filter(|x| x.1 != chosen) {
                let exact = estimate - chosen_estimate < NEAR_PSEUDO
                    || !(NEAR_PSEUDO..=4.0 - NEAR_PSEUDO).contains(&estimate);
                let (gap, to_whole) = if exact {
                    let t = exact_turn(p, a, roll.position[j], b, r.angle, r.sense);
                    (t - turn, TAU - t)
                } else {
                    (
                        estimate - chosen_estimate - TURN_SLACK,
                        4.0 - estimate - TURN_SLACK,
                    )
                };
                hold.turns.push(TurnHold::new(i, j, gap, to_whole, a, b, d));
            }
            let end = r.facing.map_or(f64::INFINITY, |f| {
                let v = wrap(r.angle + r.sense * turn - f);
                (r.sense * v - FRAC_PI_2).abs().min(PI - v.abs())
            });
            let others = &hold.turns[first..];
            let half_least = |margin: &dyn Fn(&TurnHold) -> f64| {
                0.5 * others.iter().map(margin).fold(f64::INFINITY, f64::min) - TURN_SLACK
            };
            hold.pivots.push(PivotHold {
                incoming,
                chosen: Some(TurnHold::new(i, chosen, turn, TAU - turn, a, b, d)),
                end,
                others: first..hold.turns.len(),
                chosen_budget: half_least(&|t| t.gap),
                incoming_budget: half_least(&|t| t.to_whole),
            });
            before = Some(Incoming::Roll {
                pivot: i,
                grain: chosen,
                a,
                b,
            });
        }
        hold
    }

    /// Whether the probe makes every choice as it did after the grains' `moves`, none of
    /// which is longer than `anywhere`.
    fn holds(&self, moves: &Moves, radius: &[f64], anywhere: f64) -> bool {
        // Each test is written to fail on a move that is not a number.
        let within = |moved: f64, margin: f64| moved + self.slack < margin;
        if !within(2.0 * anywhere, self.beyond)
            || !self.start.holds(moves, radius, anywhere, self.slack)
            || !(self.lengths.iter()).all(|&(i, j, m)| within(moves.between(i, j), m))
        {
            return false;
        }
        // The bound on the change of the turn to the grain the roll before chose.
        let mut before = 0.0;
        for pivot in &self.pivots {
            let incoming = match pivot.incoming {
                Incoming::Fixed => 0.0,
                Incoming::Centre => {
                    let distance = self.start.from_centre.unwrap_or(0.0);
                    direction_change(moves.of(self.start.grain), distance)
                }
                Incoming::Roll { pivot, grain, a, b } => {
                    direction_change(moves.between(pivot, grain) + a * before, b)
                }
            };
            let Some(chosen) = pivot.chosen else {
                continue;
            };
            let e = chosen.error(moves.between(chosen.pivot, chosen.grain));
            let clear = |margin: f64, change: f64| margin - change > TURN_SLACK;
            if !(clear(chosen.gap, e + incoming)
                && clear(chosen.to_whole, e + incoming)
                && clear(pivot.end, e))
            {
                return false;
            }
            let quick = e <= pivot.chosen_budget && incoming <= pivot.incoming_budget;
            for other in &self.turns[pivot.others.clone()] {
                let moved = moves.squared_between(other.pivot, other.grain);
                if quick && moved <= other.allowed {
                    continue;
                }
                let e_other = other.error(moved.sqrt());
                if !(clear(other.gap, e_other + e) && clear(other.to_whole, e_other + incoming)) {
                    return false;
                }
            }
            before = e;
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// Grains of mixed sizes on a jittered square lattice, `n` by `n`, 2.2 apart.
    fn packing(rng: &mut impl Rng, n: usize) -> (Vec<[f64; 2]>, Vec<f64>) {
        let mut position = Vec::new();
        for i in 0..n {
            for j in 0..n {
                let jitter = [rng.random_range(-0.4..0.4), rng.random_range(-0.4..0.4)];
                position.push([2.2 * j as f64 + jitter[0], 2.2 * i as f64 + jitter[1]]);
            }
        }
        let radius = (0..position.len())
            .map(|_| rng.random_range(0.5..1.2))
            .collect();
        (position, radius)
    }

    /// A grain's allowance keeps its turn's change within half its least margin, less the
    /// room for rounding, for grains within the reach and beyond it.
    #[test]
    fn the_allowance_keeps_the_turn_within_its_budget() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        for _ in 0..10_000 {
            let (a, b) = (rng.random_range(0.5..3.0), rng.random_range(0.5..3.0));
            let (inner, reach) = (f64::abs(a - b), a + b);
            let d = rng.random_range(inner..reach + 0.5) + 1e-9;
            let (gap, to_whole) = (
                10f64.powf(rng.random_range(-6.0..0.5)),
                rng.random_range(0.0..TAU),
            );
            let t = TurnHold::new(0, 1, gap, to_whole, a, b, d);
            if t.allowed > 0.0 {
                let budget = 0.5 * gap.min(to_whole) - TURN_SLACK;
                assert!(t.error(t.allowed.sqrt()) <= budget * (1.0 + 1e-12), "{t:?}");
            }
        }
    }

    /// A chain kept after the grains move is the chain the probe finds where they are. On
    /// random packings, for a ring and two sides, each probe moves the grains along one
    /// pattern (every grain its own way, one grain, a strain, one grain of the ring's two
    /// outermost), ever further until the chains are no longer kept; where they last were, the
    /// probe finds them anew. A bound that promised too much would be found out at that edge.
    #[test]
    fn a_kept_chain_is_the_one_found_anew() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        let membrane = |shape| Membrane {
            name: "m".into(),
            shape,
            pressure: 1.0,
        };
        for _ in 0..30 {
            let n = rng.random_range(4..9);
            let (mut position, radius) = packing(&mut rng, n);
            let centre = [1.1 * (n - 1) as f64; 2];
            let membranes = [
                membrane(MembraneShape::Ring { center: centre }),
                membrane(MembraneShape::Side {
                    outward: [-1.0, 0.0],
                }),
                membrane(MembraneShape::Side {
                    outward: [0.6, 0.8],
                }),
            ];
            let carrying: Vec<bool> = (0..position.len()).map(|_| rng.random_bool(0.9)).collect();
            let taken_out = vec![false; position.len()];
            let from_centre = |p: [f64; 2]| length(p[0] - centre[0], p[1] - centre[1]);
            let reach = |p: &[[f64; 2]], g: usize| from_centre(p[g]) + radius[g];
            // A grain of the ring brought to reach nearly as far as the outermost.
            let outermost = (0..position.len())
                .filter(|&g| carrying[g])
                .max_by(|&a, &b| reach(&position, a).total_cmp(&reach(&position, b)))
                .expect("grains");
            let rival = (0..position.len())
                .filter(|&g| carrying[g] && g != outermost)
                .max_by(|&a, &b| reach(&position, a).total_cmp(&reach(&position, b)))
                .expect("grains");
            let out = reach(&position, outermost) - reach(&position, rival) - 1e-4;
            let p = position[rival];
            let scale = 1.0 + out / from_centre(p);
            position[rival] = [
                centre[0] + scale * (p[0] - centre[0]),
                centre[1] + scale * (p[1] - centre[1]),
            ];
            let mut watch = ChainWatch::default();
            watch.chains(&membranes, &position, &radius, &carrying, &taken_out);
            for _ in 0..40 {
                let field: Vec<[f64; 2]> = match rng.random_range(0..4) {
                    0 => (position.iter())
                        .map(|_| [rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)])
                        .collect(),
                    kind @ (1 | 2) => {
                        let g = if kind == 1 {
                            rng.random_range(0..position.len())
                        } else {
                            [outermost, rival][rng.random_range(0..2)]
                        };
                        let turn: f64 = rng.random_range(0.0..TAU);
                        (0..position.len())
                            .map(|k| {
                                if k == g {
                                    [turn.cos(), turn.sin()]
                                } else {
                                    [0.0; 2]
                                }
                            })
                            .collect()
                    }
                    _ => (position.iter())
                        .map(|p| [-(p[0] - centre[0]), 0.5 * (p[1] - centre[1])])
                        .collect(),
                };
                let moved = |size: f64| -> Vec<[f64; 2]> {
                    (position.iter().zip(&field))
                        .map(|(p, f)| [p[0] + size * f[0], p[1] + size * f[1]])
                        .collect()
                };
                let kept = |size: f64| {
                    watch.still_found(
                        membranes.len(),
                        &moved(size),
                        &radius,
                        &carrying,
                        &taken_out,
                    )
                };
                // The edge, in the logarithm of the move, between kept and not.
                let (mut lo, mut hi) = (-14.0f64, 1.0f64);
                if !kept(10f64.powf(lo)) {
                    continue;
                }
                for _ in 0..40 {
                    let mid = 0.5 * (lo + hi);
                    if kept(10f64.powf(mid)) {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                let at = moved(10f64.powf(lo));
                for (m, chain) in membranes.iter().zip(&watch.chains) {
                    let fresh = m.chain(&at, &radius, &carrying, &taken_out);
                    assert_eq!(fresh.grains, chain.grains, "kept after a move of 1e{lo}");
                }
            }
        }
    }
}
