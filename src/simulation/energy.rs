//! The energy balance of an increment (method note, "Energy check"): the work of the walls
//! and membranes on the grains against the change of the energy stored in the contacts, the
//! energy friction dissipated, and the energy the bonds that broke held.
//!
//! The work is the trapezoid rule over the increment: each wall's force and moment on the
//! grains (and each membrane's loads) at its start and end, times how far the wall (and each
//! grain) moved. It is exact where the forces follow the displacements linearly (linear
//! contacts that stick); where contacts slide, close, open or break within the increment the
//! path between its ends is not known, and the imbalance holds that as well as the solver's
//! own error.

use super::Simulation;
use crate::contact::{kinematics, Configuration, Contact, ContactLaw};
use crate::geometry::Side;

/// The terms of one increment's energy balance (J).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct EnergyBalance {
    /// Work of the walls and membranes on the grains.
    pub work: f64,
    /// Energy stored in the contacts at the end of the increment.
    pub stored: f64,
    /// Change of the stored energy over the increment.
    pub stored_change: f64,
    /// Energy dissipated by sliding: each contact's shear force times its slip.
    pub dissipated: f64,
    /// Energy the bonds that broke held when they broke.
    pub bonds_released: f64,
    /// Energy the contacts of grains taken out of the sample stored (a breakout, see
    /// [`Simulation::take_out`]): carried away with them.
    pub taken_out: f64,
}

impl EnergyBalance {
    /// `work - stored_change - dissipated - bonds_released - taken_out`, relative to the
    /// largest term.
    pub fn imbalance(&self) -> f64 {
        let scale = [
            self.work,
            self.stored_change,
            self.dissipated,
            self.bonds_released,
            self.taken_out,
        ]
        .iter()
        .fold(0.0f64, |m, v| m.max(v.abs()));
        let rest =
            self.work - self.stored_change - self.dissipated - self.bonds_released - self.taken_out;
        if scale > 0.0 {
            rest / scale
        } else {
            0.0
        }
    }
}

/// What the work of an increment is taken from, in a committed state: where the walls and
/// grains are, and the forces the walls and membranes put on the grains.
#[derive(Debug, Clone)]
pub(super) struct BoundaryForces {
    /// Each wall's surface point that moves with it (a line's pivot, a circle's centre), its
    /// turn, and a circle's radius.
    wall_place: Vec<([f64; 2], f64, f64)>,
    /// Each wall's resultant force on the grains (N).
    wall_force: Vec<[f64; 2]>,
    /// Each line's moment on the grains about its pivot; each circle's force on the grains
    /// along the radius from its centre (N m; N).
    wall_moment: Vec<f64>,
    /// The membranes' loads on each grain, and on a grain glued to a wall what the glue
    /// holds it with: the force and moment that balance its other contacts (N, N m).
    held: Vec<[f64; 3]>,
    /// Grain centres and rotations (m, rad).
    position: Vec<[f64; 2]>,
    rotation: Vec<f64>,
    /// Energy stored in the contacts (J).
    stored: f64,
}

impl BoundaryForces {
    /// The work on the grains from `self` to `end`, by the trapezoid rule.
    pub(super) fn work_to(&self, end: &BoundaryForces) -> f64 {
        let mut work = 0.0;
        for w in 0..self.wall_force.len() {
            let (p0, turn0, radius0) = self.wall_place[w];
            let (p1, turn1, radius1) = end.wall_place[w];
            let (f0, f1) = (self.wall_force[w], end.wall_force[w]);
            work += 0.5 * ((f0[0] + f1[0]) * (p1[0] - p0[0]) + (f0[1] + f1[1]) * (p1[1] - p0[1]));
            let turn_or_growth = (turn1 - turn0) + (radius1 - radius0);
            work += 0.5 * (self.wall_moment[w] + end.wall_moment[w]) * turn_or_growth;
        }
        for (g, (x0, x1)) in self.position.iter().zip(&end.position).enumerate() {
            let (f0, f1) = (self.held[g], end.held[g]);
            let turn = end.rotation[g] - self.rotation[g];
            work += 0.5
                * ((f0[0] + f1[0]) * (x1[0] - x0[0])
                    + (f0[1] + f1[1]) * (x1[1] - x0[1])
                    + (f0[2] + f1[2]) * turn);
        }
        work
    }

    /// Energy stored in the contacts (J).
    pub(super) fn stored(&self) -> f64 {
        self.stored
    }
}

/// The energy contact `c` stores in its committed state: its normal energy and its shear
/// spring's `F_s^2 / 2 k_s`.
pub(super) fn stored_energy(law: &dyn ContactLaw, c: &Contact) -> f64 {
    let normal = if c.bonded || c.overlap > 0.0 {
        law.normal_energy(&c.params, c.overlap, c.bonded)
    } else {
        0.0
    };
    let ks = law.shear_stiffness(&c.params, c.overlap).0;
    let shear = if ks > 0.0 {
        0.5 * c.shear_force0 * c.shear_force0 / ks
    } else {
        0.0
    };
    normal + shear
}

/// The energy contact `c` dissipates by sliding in the increment it is about to commit: its
/// shear force times its slip, the shear made less the shear its spring took.
pub(super) fn dissipated(law: &dyn ContactLaw, c: &Contact) -> f64 {
    let ks = law.shear_stiffness(&c.params, c.overlap).0;
    if ks <= 0.0 {
        return 0.0;
    }
    let force = c.response.shear_force;
    let slip = c.shear_increment - (force - c.shear_force0) / ks;
    force * slip
}

/// The energy contact `c`'s bond holds where it is: its stored energy bonded less its stored
/// energy with the bond broken (no tension, the shear force within the friction limit).
pub(super) fn bond_energy(law: &dyn ContactLaw, c: &Contact) -> f64 {
    let n = c.overlap;
    let bonded = law.normal_energy(&c.params, n, true);
    let unbonded = if n > 0.0 {
        law.normal_energy(&c.params, n, false)
    } else {
        0.0
    };
    let ks = law.shear_stiffness(&c.params, n).0;
    let shear = c.response.shear_force;
    let limit = c.params.friction * law.normal(&c.params, n, false).0.max(0.0);
    let after = shear.clamp(-limit, limit);
    let released_shear = if ks > 0.0 {
        0.5 * (shear * shear - after * after) / ks
    } else {
        0.0
    };
    bonded - unbonded + released_shear
}

impl Simulation {
    /// The forces of the walls and membranes on the grains, and the stored energy, in the
    /// committed state.
    pub(super) fn boundary_forces(&self) -> BoundaryForces {
        let (grains, walls) = (&self.state.grains, &self.state.walls);
        let rest = Configuration::at_rest(grains, walls);
        let nw = walls.len();
        let wall_place: Vec<_> = (walls.walls.iter())
            .map(|w| match &w.circle {
                Some(c) => (c.center_at(w.position), 0.0, c.radius_at(w.position)),
                None => (w.pivot_at(w.position), w.turn, 0.0),
            })
            .collect();
        let mut wall_force = vec![[0.0; 2]; nw];
        let mut wall_moment = vec![0.0; nw];
        let mut stored = 0.0;
        let glued = self.state.contacts.glued(grains.len());
        // On a glued grain, the force and moment of its contacts other than the glue's.
        let mut others = vec![[0.0; 3]; grains.len()];
        for c in &self.state.contacts.contacts {
            stored += stored_energy(self.law.as_ref(), c);
            if !(c.bonded || c.overlap > 0.0) {
                continue;
            }
            // The force on grain `b`: `F_n n - F_s t`; its moment `F_s r_b`, and `F_s r_a` on
            // side `a` (see `assembly::local`).
            let k = kinematics(c.pair, grains, walls, &rest);
            let normal = self.law.normal(&c.params, c.overlap, c.bonded).0;
            let (n, t) = (k.normal, k.tangent);
            let f = [
                normal * n[0] - c.shear_force0 * t[0],
                normal * n[1] - c.shear_force0 * t[1],
            ];
            let b = c.pair.b;
            let glue = match c.pair.a {
                Side::Grain(a) => {
                    if glued[a].is_some() {
                        let o = &mut others[a];
                        (o[0], o[1], o[2]) =
                            (o[0] - f[0], o[1] - f[1], o[2] + c.shear_force0 * k.lever_a);
                    }
                    false
                }
                Side::Wall(w) => glued[b] == Some(w),
            };
            if glued[b].is_some() && !glue {
                let o = &mut others[b];
                (o[0], o[1], o[2]) = (o[0] + f[0], o[1] + f[1], o[2] + c.shear_force0 * k.lever_b);
            }
            let Side::Wall(w) = c.pair.a else {
                continue;
            };
            if glue {
                continue;
            }
            wall_force[w][0] += f[0];
            wall_force[w][1] += f[1];
            let x = grains.position[c.pair.b];
            let (centre, _, _) = wall_place[w];
            wall_moment[w] += if walls.walls[w].circle.is_some() {
                // Along the radius from the centre: the surface moves that way as it grows.
                let d = [x[0] - centre[0], x[1] - centre[1]];
                let len = d[0].hypot(d[1]);
                (f[0] * d[0] + f[1] * d[1]) / len
            } else {
                // About the pivot, at the contact point on the line.
                let r = k.lever_b;
                let p = [x[0] - r * n[0] - centre[0], x[1] - r * n[1] - centre[1]];
                p[0] * f[1] - p[1] * f[0]
            };
        }
        let mut held: Vec<[f64; 3]> = (others.iter().zip(&glued))
            .map(|(o, g)| match g {
                Some(_) => [-o[0], -o[1], -o[2]],
                None => [0.0; 3],
            })
            .collect();
        for (membrane, chain) in self.state.membranes.iter().zip(&self.chains) {
            let pd = membrane.pressure * self.depth;
            for (g, f) in chain.loads(membrane.shape, &grains.position, pd) {
                held[g][0] += f[0];
                held[g][1] += f[1];
            }
        }
        BoundaryForces {
            wall_place,
            wall_force,
            wall_moment,
            held,
            position: grains.position.clone(),
            rotation: grains.rotation.clone(),
            stored,
        }
    }
}
