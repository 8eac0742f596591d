//! Loose grains: those that touch nothing where a minimisation starts (a rattler in its
//! pore), left out of it, and moved only where a step would put another grain into them.
//!
//! A loose grain's equilibrium is any place where it overlaps nothing: its contacts then
//! carry no force, and so it pushes nothing. Solved with the grains that carry load, it
//! only spoils their steps: the Hessian holds no stiffness for the pairs it is about to
//! touch, so a step drives a neighbour into it, the next pushes it off into another, and
//! every such event cuts the whole step. So the minimisation runs over the grains that
//! carry load, the loose ones held where they are, their contacts carrying nothing; after
//! each step each loose grain that now overlaps something is moved the least way that
//! leaves it overlapping nothing (a small quadratic programme in its two translations). At
//! the end every grain is in equilibrium, the loose ones with no force at all, which the
//! minimisation confirms with them taken in. A loose grain that cannot be placed so, because
//! the grains around it have closed on it, carries load after all: it joins the others where
//! its overlaps balance, and the minimisation goes on from there.
//!
//! A loose grain gives way without friction: at no force its contacts have none, and it
//! slides along them to wherever the grains pressing it leave room. So two bodies closing on
//! it from sides less than twice the friction angle from opposite, which would wedge it
//! (Coulomb), let it out where the wedge opens. Wedged by that rule instead, a grain that
//! a step makes both overlap at once is caught where smaller steps let it slip out along the
//! first: the cracks of `tests/bend.rs` then came 5% of the push later in 100 steps than in
//! 200. Given way, the answer holds whatever the increment size.
//!
//! It gives way by at most its radius in an increment. Its pairs are linearised where it is,
//! and two bodies closing on it from sides nearly opposite put its least way out far along
//! the wedge, where they no longer say where the grains are: left there, the unconfined
//! sandstone test's grain 506 sat half a radius deep in two grains it had not touched, and
//! the run ended on a "failure" of that one grain. A grain that would go further is taken in
//! where it was, and the minimisation finds where it goes.

use super::{IncrementEquations, Simulation};
use crate::contact::{kinematics, Configuration, Contact};
use crate::geometry::Side;

/// Gap, in mean radii, a loose grain is left at from what it was moved off: apart, so that
/// round-off on its overlap makes no force.
const CLEARANCE: f64 = 1e-10;

/// Gap, in mean radii, a grain must keep from every other and every wall to be loose: a
/// grain just touching (a crystal's, to round-off) is part of the packing.
const LOOSE_GAP: f64 = 1e-12;

/// Projections of a placement, each on the geometry where the last left the grain.
const PLACEMENT_ROUNDS: usize = 4;

impl Simulation {
    /// The grains that touch nothing where the contacts are now, each apart from everything
    /// by [`LOOSE_GAP`] at least, and that nothing else holds: no bond, no membrane's chain,
    /// glue or anchor. Empty when there are none.
    pub(super) fn find_loose(&self) -> Vec<bool> {
        let n = self.state.grains.len();
        let mut loose: Vec<bool> = (0..n)
            .map(|g| !self.state.grains.taken_out[g] && self.dofs.glue[g].is_none())
            .collect();
        for g in self.chains.iter().flat_map(|chain| chain.grains.iter()) {
            loose[*g] = false;
        }
        for a in &self.anchors {
            loose[a.grain] = false;
        }
        // Overlaps where the committed state has the grains (a fresh simulation's contacts
        // have none yet).
        let (grains, walls) = (&self.state.grains, &self.state.walls);
        let rest = Configuration::at_rest(grains, walls);
        let gap = LOOSE_GAP * self.mean_radius();
        let touching =
            |c: &&Contact| c.bonded || kinematics(c.pair, grains, walls, &rest).overlap > -gap;
        for c in self.state.contacts.contacts.iter().filter(touching) {
            loose[c.pair.b] = false;
            if let Side::Grain(a) = c.pair.a {
                loose[a] = false;
            }
        }
        if loose.contains(&true) {
            loose
        } else {
            Vec::new()
        }
    }
}

impl IncrementEquations<'_> {
    /// Move each loose grain at `u`, one after the other, the least way that leaves it
    /// overlapping no grain or wall (the loose ones placed before it where they were put).
    /// Returns the grains that could not be placed so: closed in, they carry load, and are
    /// loose no more. One that the placement would take further than its radius from where
    /// the increment started it is left where it was.
    pub fn place_loose(&mut self, u: &mut [f64]) -> Vec<usize> {
        // Each loose grain's contacts: (grain, contact), by grain.
        let mut of_loose: Vec<(usize, usize)> = Vec::new();
        for (i, c) in self.contacts.iter().enumerate() {
            if self.loose[c.pair.b] {
                of_loose.push((c.pair.b, i));
            }
            if let Side::Grain(a) = c.pair.a {
                if self.loose[a] {
                    of_loose.push((a, i));
                }
            }
        }
        of_loose.sort_unstable();
        self.configure(u);
        let clearance = CLEARANCE * self.r_mean;
        let mut failed = Vec::new();
        let loose: Vec<usize> = (0..self.grains.len()).filter(|&g| self.loose[g]).collect();
        for g in loose {
            let from = of_loose.partition_point(|&(h, _)| h < g);
            let to = of_loose.partition_point(|&(h, _)| h <= g);
            let contacts: Vec<usize> = of_loose[from..to].iter().map(|&(_, i)| i).collect();
            let base = self.dofs.grain(g);
            let before = [u[base], u[base + 1]];
            let mut placed = false;
            for round in 0..=PLACEMENT_ROUNDS {
                // Each pair as `a . d <= b`: its overlap after the move `d`, to first order,
                // at most minus the clearance.
                let constraints: Vec<([f64; 2], f64)> = (contacts.iter())
                    .map(|&i| {
                        let pair = self.contacts[i].pair;
                        let k = kinematics(pair, self.grains, self.walls, self.q);
                        let sign = if pair.b == g { -1.0 } else { 1.0 };
                        (
                            [sign * k.normal[0], sign * k.normal[1]],
                            -clearance - k.overlap,
                        )
                    })
                    .collect();
                if constraints.iter().all(|&(_, b)| b >= -clearance) {
                    placed = true;
                    break;
                }
                if round == PLACEMENT_ROUNDS {
                    break;
                }
                // The grain gives way to what presses it, touching the others with no force
                // if it must. Where no way out is left it carries load, and goes to where its
                // overlaps balance, each pair pressing with the same stiffness: the nearest
                // its own equilibrium is.
                let Some(d) = least_move(&constraints) else {
                    let d = balanced_move(&constraints);
                    u[base] += d[0];
                    u[base + 1] += d[1];
                    self.configure_grain(g, u);
                    break;
                };
                u[base] += d[0];
                u[base + 1] += d[1];
                self.configure_grain(g, u);
            }
            let moved = self.q.displacement[g];
            if moved[0].hypot(moved[1]) > self.grains.radius[g] {
                // Too far for the pairs linearised where it was: taken in where it was.
                (u[base], u[base + 1]) = (before[0], before[1]);
                self.configure_grain(g, u);
                failed.push(g);
            } else if !placed {
                failed.push(g);
            }
        }
        for &g in &failed {
            self.loose[g] = false;
        }
        failed
    }
}

/// The shortest `d` with `a . d <= b` for every constraint `(a, b)` (`a` unit vectors), or
/// none where they leave no room. The shortest lies where at most two of them hold with
/// equality, so it is the shortest of those points that keep all.
fn least_move(constraints: &[([f64; 2], f64)]) -> Option<[f64; 2]> {
    let slack = 1e-12 * constraints.iter().map(|c| c.1.abs()).fold(0.0, f64::max);
    let keeps = |d: [f64; 2]| {
        constraints
            .iter()
            .all(|(a, b)| a[0] * d[0] + a[1] * d[1] <= b + slack)
    };
    let mut best: Option<[f64; 2]> = None;
    let mut consider = |d: [f64; 2]| {
        let shorter = best.is_none_or(|e| d[0].hypot(d[1]) < e[0].hypot(e[1]));
        if shorter && keeps(d) {
            best = Some(d);
        }
    };
    consider([0.0, 0.0]);
    for (i, &(a, b)) in constraints.iter().enumerate() {
        if b < 0.0 {
            consider([b * a[0], b * a[1]]);
        }
        for &(c, e) in &constraints[i + 1..] {
            let det = a[0] * c[1] - a[1] * c[0];
            if det.abs() < 1e-9 {
                continue;
            }
            consider([(b * c[1] - a[1] * e) / det, (a[0] * e - b * c[0]) / det]);
        }
    }
    best
}

/// The move `d` that balances the overlaps `a_j . d - b_j` a grain would have, taken as
/// springs of one stiffness that push while they overlap: Newton on the pairs that press, a
/// few rounds.
fn balanced_move(constraints: &[([f64; 2], f64)]) -> [f64; 2] {
    let mut d = [0.0; 2];
    for _ in 0..8 {
        let (mut k, mut r) = ([[0.0; 2]; 2], [0.0; 2]);
        for (a, b) in constraints {
            let excess = a[0] * d[0] + a[1] * d[1] - b;
            if excess > 0.0 {
                for i in 0..2 {
                    r[i] -= excess * a[i];
                    for j in 0..2 {
                        k[i][j] += a[i] * a[j];
                    }
                }
            }
        }
        // Pairs that all press along one line leave the other direction free: a touch of
        // stiffness there keeps the move in the pressed direction alone.
        let trace = k[0][0] + k[1][1];
        if trace == 0.0 {
            break;
        }
        for (i, row) in k.iter_mut().enumerate() {
            row[i] += 1e-9 * trace;
        }
        let det = k[0][0] * k[1][1] - k[0][1] * k[1][0];
        let step = [
            (k[1][1] * r[0] - k[0][1] * r[1]) / det,
            (k[0][0] * r[1] - k[1][0] * r[0]) / det,
        ];
        d = [d[0] + step[0], d[1] + step[1]];
        if step[0].hypot(step[1]) <= 1e-12 * d[0].hypot(d[1]) {
            break;
        }
    }
    d
}

#[cfg(test)]
mod tests {
    use super::least_move;

    #[test]
    fn a_grain_pushed_from_one_side_moves_along_the_push() {
        // Overlapping by 1 along +x: moved by 1 the other way.
        let d = least_move(&[([1.0, 0.0], -1.0)]).unwrap();
        assert!((d[0] + 1.0).abs() < 1e-15 && d[1].abs() < 1e-15);
    }

    #[test]
    fn a_grain_in_a_corner_moves_out_of_both() {
        let s = std::f64::consts::FRAC_1_SQRT_2;
        // Two neighbours at +-45 degrees below, each overlapping by 1: up by sqrt 2.
        let d = least_move(&[([s, -s], -1.0), ([-s, -s], -1.0)]).unwrap();
        assert!(
            d[0].abs() < 1e-12 && (d[1] - 2f64.sqrt()).abs() < 1e-12,
            "{d:?}"
        );
    }

    #[test]
    fn a_grain_squeezed_from_both_sides_cannot_be_placed() {
        assert!(least_move(&[([1.0, 0.0], -1.0), ([-1.0, 0.0], -1.0)]).is_none());
    }

    #[test]
    fn a_grain_squeezed_evenly_from_both_sides_stays_between_them() {
        let d = super::balanced_move(&[([1.0, 0.0], -1.0), ([-1.0, 0.0], -1.0)]);
        assert!(d[0].abs() < 1e-15 && d[1].abs() < 1e-15, "{d:?}");
        // Pressed 3 from the right and 1 from the left: 1 to the left, 2 each.
        let d = super::balanced_move(&[([1.0, 0.0], -3.0), ([-1.0, 0.0], -1.0)]);
        assert!((d[0] + 1.0).abs() < 1e-12 && d[1].abs() < 1e-15, "{d:?}");
    }

    #[test]
    fn a_grain_that_overlaps_nothing_stays() {
        assert_eq!(least_move(&[([1.0, 0.0], 0.5)]), Some([0.0, 0.0]));
    }
}
