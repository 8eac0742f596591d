//! One grain moved to its exact equilibrium with everything else held: the nonlinear
//! elimination the minimisation applies to the grain its global step leaves worst (method
//! note, "One load increment").
//!
//! A grain whose contacts sit on the edge of sticking, sliding or touching (wedged between
//! two grains at the friction angle, resting on a contact that barely touches, rolling) is
//! where the lagged friction and the global Newton step converge slowest or cycle. Alone, the
//! grain has three unknowns and a handful of contacts, so its equilibrium under the true law
//! (each friction limit following its own normal force, not lagged) can be found exactly:
//! each contact is given a state (apart, sticking, sliding either way), Newton solves the
//! grain's three equations with the states held, and the states must then be the ones the
//! law gives there. The states tried first are those the grain had when last balanced, then
//! those the law gives where it is; failing those, every assignment one or two changes away,
//! the smallest move among them. More changes than two are left to the global steps.

use crate::contact::{ContactLaw, ContactParams};

/// A contact's state in the local solve.
const APART: u8 = 0;
const STICK: u8 = 1;
const SLIDE_FORWARD: u8 = 2;
const SLIDE_BACKWARD: u8 = 3;

/// State changes from the first guesses the search goes to at most.
const MAX_CHANGES: usize = 2;

/// Contacts of one grain the search takes at most (4^7 assignments).
pub const MAX_CONTACTS: usize = 7;

/// Singular values of the grain's tangent below this share of the largest count as zero in
/// its least-squares step.
const SINGULAR: f64 = 1e-12;

/// One contact of the grain, as the grain's move `d = (dx, dy, dphi)` changes it.
pub struct LocalContact {
    /// Overlap where the grain is now (m).
    pub overlap: f64,
    /// Shear displacement of the increment where the grain is now (m).
    pub shear: f64,
    /// For a curved contact (another grain, a circle): the branch vector now, the sign with
    /// which the grain's move adds to it, and +1 where the overlap falls as the branch
    /// lengthens (-1 inside a ring). `None` for a straight wall, whose normal is fixed.
    pub branch: Option<([f64; 2], f64, f64)>,
    /// `d(overlap)/dd` now.
    pub bn: [f64; 3],
    /// `d(shear)/dd`: the shear follows the move to first order.
    pub bt: [f64; 3],
    /// Committed shear force at the start of the increment (N).
    pub force0: f64,
    pub params: ContactParams,
    pub bonded: bool,
}

impl LocalContact {
    /// Overlap at the move `d`, its gradient, and the gradient's derivative on the
    /// translations (the normal turns as the branch does).
    fn overlap_at(&self, d: &[f64; 3]) -> (f64, [f64; 3], [[f64; 2]; 2]) {
        let Some((b0, side, sigma)) = self.branch else {
            return (self.overlap + dot(&self.bn, d), self.bn, [[0.0; 2]; 2]);
        };
        let b = [b0[0] + side * d[0], b0[1] + side * d[1]];
        let (len, len0) = (b[0].hypot(b[1]), b0[0].hypot(b0[1]));
        let e = [b[0] / len, b[1] / len];
        let mut turn = [[0.0; 2]; 2];
        for (p, row) in turn.iter_mut().enumerate() {
            for (q, v) in row.iter_mut().enumerate() {
                let identity = if p == q { 1.0 } else { 0.0 };
                *v = -sigma * (identity - e[p] * e[q]) / len;
            }
        }
        (
            self.overlap - sigma * (len - len0),
            [-sigma * side * e[0], -sigma * side * e[1], 0.0],
            turn,
        )
    }

    fn shear_at(&self, d: &[f64; 3]) -> f64 {
        self.shear + dot(&self.bt, d)
    }

    /// Whether it can take a state other than sticking.
    fn can_change(&self) -> bool {
        !self.bonded && self.params.friction.is_finite()
    }

    /// The state the law gives at overlap `n` and shear `s`.
    fn state(&self, law: &dyn ContactLaw, n: f64, s: f64) -> u8 {
        if n <= 0.0 && !self.bonded {
            return APART;
        }
        let normal = law.normal(&self.params, n, self.bonded).0;
        let trial = self.force0 + law.shear_stiffness(&self.params, n).0 * s;
        let limit = self.params.friction * normal;
        if !self.can_change() || trial.abs() <= limit {
            STICK
        } else if trial > 0.0 {
            SLIDE_FORWARD
        } else {
            SLIDE_BACKWARD
        }
    }
}

/// One grain's equilibrium with everything else held.
pub struct GrainBalance<'a> {
    pub law: &'a dyn ContactLaw,
    /// What pushes the grain besides its contacts (membranes, the loads' share).
    pub external: [f64; 3],
    /// Unknowns of the grain: 2 with rotations fixed, else 3.
    pub unknowns: usize,
    /// Force below which the grain's residual counts as zero (N).
    pub tolerance: f64,
    pub radius: f64,
    /// Contacts that touch, are bonded, or nearly touch.
    pub near: Vec<LocalContact>,
    /// The others, which must stay apart.
    pub far: Vec<LocalContact>,
}

impl GrainBalance<'_> {
    /// The move to the nearest equilibrium, and its contacts' states, trying `hint` first.
    pub fn nearest(&self, hint: &[u8]) -> Option<([f64; 3], Vec<u8>)> {
        let m = self.near.len();
        if m == 0 || m > MAX_CONTACTS {
            return None;
        }
        let now: Vec<u8> = (self.near.iter())
            .map(|c| c.state(self.law, c.overlap, c.shear))
            .collect();
        let first = [hint, &now[..]]
            .into_iter()
            .filter(|states| states.len() == m)
            .find_map(|states| self.solve(states).map(|d| (d, states.to_vec())));
        if first.is_some() {
            return first;
        }
        let size = |d: &[f64; 3]| d[0] * d[0] + d[1] * d[1] + (self.radius * d[2]).powi(2);
        let mut states = vec![0u8; m];
        for changes in 1..=m.min(MAX_CHANGES) {
            let mut best: Option<([f64; 3], Vec<u8>)> = None;
            'assignments: for code in 0..4usize.pow(m as u32) {
                let mut rest = code;
                for (state, contact) in states.iter_mut().zip(&self.near) {
                    *state = (rest % 4) as u8;
                    rest /= 4;
                    if *state != STICK && !contact.can_change() {
                        continue 'assignments;
                    }
                }
                if states.iter().zip(&now).filter(|(a, b)| a != b).count() != changes {
                    continue;
                }
                if let Some(d) = self.solve(&states) {
                    if best.as_ref().is_none_or(|(b, _)| size(&d) < size(b)) {
                        best = Some((d, states.clone()));
                    }
                }
            }
            if best.is_some() {
                return best;
            }
        }
        None
    }

    /// The grain's residual at the move `d` with its contacts held in `states`, and `-dR/dd`.
    fn residual(&self, d: &[f64; 3], states: &[u8]) -> ([f64; 3], [[f64; 3]; 3]) {
        let mut r = self.external;
        let mut k = [[0.0; 3]; 3];
        for (c, &state) in self.near.iter().zip(states) {
            let (n, bn, turn) = c.overlap_at(d);
            let s = c.shear_at(d);
            let (normal, dn) = if state == APART {
                (0.0, 0.0)
            } else {
                self.law.normal(&c.params, n, c.bonded)
            };
            let f = c.params.friction;
            let (shear, ds_dn, ds_ds) = match state {
                STICK => {
                    let (ks, dks) = self.law.shear_stiffness(&c.params, n);
                    (c.force0 + ks * s, dks * s, ks)
                }
                SLIDE_FORWARD => (f * normal, f * dn, 0.0),
                SLIDE_BACKWARD => (-f * normal, -f * dn, 0.0),
                _ => (0.0, 0.0, 0.0),
            };
            for i in 0..3 {
                r[i] -= normal * bn[i] + shear * c.bt[i];
                for j in 0..3 {
                    k[i][j] +=
                        dn * bn[i] * bn[j] + ds_dn * c.bt[i] * bn[j] + ds_ds * c.bt[i] * c.bt[j];
                }
            }
            for p in 0..2 {
                for q in 0..2 {
                    k[p][q] += normal * turn[p][q];
                }
            }
        }
        (r, k)
    }

    /// Newton on the grain's equations with the states held; the move if it converges to
    /// where the law gives those states and no far contact closes.
    fn solve(&self, states: &[u8]) -> Option<[f64; 3]> {
        let n = self.unknowns;
        let mut d = [0.0; 3];
        for _ in 0..30 {
            let (r, k) = self.residual(&d, states);
            if r[..n].iter().all(|v| v.abs() <= self.tolerance) {
                let holds = (self.near.iter().zip(states))
                    .all(|(c, &s)| c.state(self.law, c.overlap_at(&d).0, c.shear_at(&d)) == s);
                let apart = self.far.iter().all(|c| c.overlap_at(&d).0 <= 0.0);
                return (holds && apart).then_some(d);
            }
            let a = nalgebra::Matrix3::from_fn(|i, j| match (i < n && j < n, i == j) {
                (true, _) => k[i][j],
                (false, true) => 1.0,
                (false, false) => 0.0,
            });
            let b = nalgebra::Vector3::new(r[0], r[1], if n == 3 { r[2] } else { 0.0 });
            // Where no contact sticks, nothing holds the rotation: its column is zero. The
            // step is then the least-squares one of least size, which leaves the rotation be
            // and still asks the moments to balance (two contacts at the friction angle
            // balance only with equal normal forces).
            let step = match a.lu().solve(&b) {
                Some(step) => step,
                None => {
                    let svd = a.svd(true, true);
                    let floor = SINGULAR * svd.singular_values.max();
                    svd.solve(&b, floor).ok()?
                }
            };
            for i in 0..n {
                d[i] += step[i];
            }
            if !d.iter().all(|v| v.is_finite()) || d[0].hypot(d[1]) > self.radius {
                return None;
            }
        }
        None
    }
}

fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::LinearCohesive;

    /// A grain with its rotation fixed on a straight wall below it, just touching, pushed
    /// down by 1 N and sideways by `push`.
    fn on_wall(push: f64) -> GrainBalance<'static> {
        let params = ContactParams {
            stiffness: 1e6,
            kappa: 0.8,
            friction: 0.5,
            strength: 0.0,
        };
        GrainBalance {
            law: &LinearCohesive,
            external: [push, -1.0, 0.0],
            unknowns: 2,
            tolerance: 1e-13,
            radius: 1e-3,
            near: vec![LocalContact {
                overlap: 0.0,
                shear: 0.0,
                branch: None,
                bn: [0.0, -1.0, 0.0],
                bt: [1.0, 0.0, -1e-3],
                force0: 0.0,
                params,
                bonded: false,
            }],
            far: Vec::new(),
        }
    }

    /// A grain free to turn, pushed up by 1 N into a slot between two straight walls whose
    /// normals lean 45 degrees either side of the push: both contacts slide, in opposite
    /// directions, and nothing holds the rotation.
    fn in_slot() -> GrainBalance<'static> {
        let params = ContactParams {
            stiffness: 1e6,
            kappa: 0.8,
            friction: 0.5,
            strength: 0.0,
        };
        let (s, r) = (std::f64::consts::FRAC_1_SQRT_2, 1e-3);
        let wall = |side: f64| LocalContact {
            overlap: 0.0,
            shear: 0.0,
            branch: None,
            bn: [side * s, s, 0.0],
            bt: [s, -side * s, -r],
            force0: 0.0,
            params,
            bonded: false,
        };
        GrainBalance {
            law: &LinearCohesive,
            external: [0.0, 1.0, 0.0],
            unknowns: 3,
            tolerance: 1e-13,
            radius: r,
            near: vec![wall(1.0), wall(-1.0)],
            far: Vec::new(),
        }
    }

    #[test]
    fn a_grain_sliding_on_all_its_contacts_balances_without_turning() {
        let (d, states) = in_slot().nearest(&[]).expect("an equilibrium");
        assert_eq!(states, vec![SLIDE_BACKWARD, SLIDE_FORWARD]);
        // Equal normal forces N with shears f N against the push: 2 N (cos + f sin) = 1 N,
        // and N = k n with the overlap n = dy cos 45.
        let normal = 1.0 / (2.0 * std::f64::consts::FRAC_1_SQRT_2 * 1.5);
        let dy = normal / 1e6 / std::f64::consts::FRAC_1_SQRT_2;
        assert!(d[0].abs() < 1e-15 && d[2].abs() < 1e-12, "{d:?}");
        assert!((d[1] - dy).abs() < 1e-12 * dy.max(1e-6), "{d:?}");
    }

    #[test]
    fn a_grain_pushed_within_the_friction_limit_sticks_where_its_forces_balance() {
        let balance = on_wall(0.1);
        // The hint (sliding) and the state where the grain is (apart) do not hold; one change
        // away, sticking does.
        let (d, states) = balance.nearest(&[SLIDE_FORWARD]).expect("an equilibrium");
        assert_eq!(states, vec![STICK]);
        // N = k n = 1 N, F_s = kappa k dx = 0.1 N against the push.
        assert!((d[1] + 1e-6).abs() < 1e-15, "{d:?}");
        assert!((d[0] - 0.1 / 0.8e6).abs() < 1e-15, "{d:?}");
    }

    #[test]
    fn a_grain_pushed_past_the_friction_limit_has_no_equilibrium_near() {
        // 0.8 N sideways against at most f N = 0.5 N.
        assert!(on_wall(0.8).nearest(&[]).is_none());
    }
}
