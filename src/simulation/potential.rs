//! The increment's equations as the potential the minimisation lowers (method note, "One
//! load increment"): each contact's response with its friction lagged, the membranes' chains
//! refrozen with it, and what the minimiser asks of the potential besides its value and
//! gradient: the reach of the friends lists, a closing pair, each grain's moment balance, the
//! consistent tangent of the semi-smooth steps, and the grains that ran away.

use super::equations::{IncrementEquations, CLOSING_OVERLAP, REACH};
use super::grain_balance::{GrainBalance, LocalContact};
use crate::contact::{friction, kinematics, Contact, Kinematics, Response};
use crate::geometry::{surely_shorter, Side};
use crate::solver::minimise::Potential;
use crate::NumericError;

/// Share of the force scale whose Hertz stiffness a touching contact's Hessian gets at least:
/// small enough that a contact carrying more than the tolerance has its own.
const FLOOR_FORCE: f64 = 1e-8;

/// Refreezes of one minimisation, over all its passes, that may change a membrane's chain
/// before the chains are held as they are: a grain on the probe's line has no equilibrium in or out of the chain
/// (loaded, it is pushed inside and left out; unloaded, it springs back and is taken in).
/// Held, the chain loads that grain or passes over it as the last change decided.
pub const CHAIN_CHANGES: usize = 5;

/// Gap, in mean radii, within which a pair apart takes part in a grain's own balance (it may
/// close); pairs farther apart must stay apart.
const NEAR_GAP: f64 = 1e-3;

/// Share of the force scale below which a grain's own balance counts as exact.
const BALANCED: f64 = 1e-13;

/// Bodies a grain touches or is bonded to at most for it to count as loosely held: a
/// rattler touched, a grain wedged between two or three others.
const LOOSE_CONTACTS: usize = 3;

/// One contact's shear force in [`Potential::balance_rotations`] as a function of the shear
/// made, `clamp(trial - stiffness s, -limit, limit)`, and the grains it turns (`b`, and `a`
/// unless it is a wall: then [`NO_GRAIN`]), in 32 bits as the pattern's indices are.
#[derive(Debug, Clone, Copy)]
struct Shear {
    trial: f64,
    stiffness: f64,
    limit: f64,
    grains: [u32; 2],
    /// The shear force's arms about the grains, in the same order.
    levers: (f64, f64),
}

/// A [`Shear`]'s second grain where its contact is with a wall.
const NO_GRAIN: u32 = u32::MAX;

impl Shear {
    /// The grains it turns.
    fn turned(&self) -> impl Iterator<Item = usize> + '_ {
        (self.grains.iter())
            .filter(|&&g| g != NO_GRAIN)
            .map(|&g| g as usize)
    }
}

/// What [`Potential::balance_rotations`] keeps between calls, so that it allocates nothing:
/// the contacts' shears, each grain's contacts, those of the grain it turns, and the turns
/// at which they start or stop sliding.
#[derive(Debug, Default)]
pub struct RotationScratch {
    shears: Vec<Shear>,
    first: Vec<u32>,
    members: Vec<u32>,
    turning: Vec<(f64, f64, f64, f64)>,
    kinks: Vec<f64>,
}

/// What [`Potential::closing`] keeps between calls, so that it allocates nothing: the
/// contacts apart with their overlaps at the start of the step, and where the step ends.
#[derive(Debug, Default)]
pub struct ClosingScratch {
    apart: Vec<(usize, f64)>,
    end: Vec<f64>,
}

impl IncrementEquations<'_> {
    /// The response of contact `c` in the minimisation (method note, step 2): the normal
    /// force from the overlap, the friction from the lagged potential, and the contact's
    /// potential. A refreeze first takes the lag from here: the shear stiffness, the Coulomb
    /// limit `f N`, and, for a pair apart at the start of the increment, the shear made before
    /// its surfaces touched on the straight way from there to here.
    pub(super) fn respond_lagged(&self, c: &mut Contact, k: &Kinematics) {
        let n = k.overlap;
        c.overlap = n;
        // Unbonded, a contact apart carries nothing.
        let (normal_force, mut dfn_dn) = if n > 0.0 || c.bonded {
            self.law.normal(&c.params, n, c.bonded)
        } else {
            (0.0, 0.0)
        };
        if self.refreeze {
            let lag = &mut c.lag;
            lag.unloading = lag.overlap > 0.0 && n <= 0.5 * lag.overlap;
            lag.overlap = n;
            lag.shear_stiffness = self.law.shear_stiffness(&c.params, n).0;
            // A pair apart at the start of the increment, found touching for the first time,
            // sticks until the next refreeze: on the load path its shear and normal force grow
            // together from zero at first touch, and a limit lagged from where it carried
            // nothing would let it slide without friction (a grain that two neighbours close
            // on would slide out of the wedge they make instead of being held in it). Only
            // the first touch: a pair that opens and closes again on the way has a limit of
            // its own by then. A frictionless contact has no stick to give.
            let first_touch = c.start_overlap < 0.0
                && !c.bonded
                && !lag.made
                && n > 0.0
                && c.params.friction > 0.0;
            lag.made |= first_touch;
            // Glue (infinite friction) sticks while the pair touches; apart it is `f N` with
            // `N = 0` like any other limit, nothing. Given an infinite limit there it would
            // hold the grain by a shear spring to a wall it does not touch until the next
            // refreeze, which then lets it go: the bend test's grain 207, 0.2 radii from the
            // glued support, moved 4% of the way to its equilibrium per refreeze.
            let glued = c.params.friction.is_infinite();
            lag.limit = if c.bonded || first_touch || (glued && n > 0.0) {
                f64::INFINITY
            } else if glued {
                0.0
            } else {
                lag.refrozen_limit(c.params.friction * normal_force.max(0.0))
            };
            // Taken once, where the contact is first found touching: taken anew at every
            // refreeze it would follow the iterate, and the lag would converge only linearly.
            if c.start_overlap < 0.0 && !c.bonded && !(lag.touched && n > 0.0) {
                lag.touched = n > 0.0;
                c.shear_offset = if n > 0.0 {
                    k.shear_increment * c.start_overlap / (c.start_overlap - n)
                } else {
                    k.shear_increment
                };
            }
        }
        let unloading = if self.consistent {
            let lag = &mut c.lag;
            let fell = lag.newton_overlap > 0.0 && n <= 0.5 * lag.newton_overlap;
            lag.newton_overlap = n;
            fell
        } else {
            c.lag.unloading
        };
        if unloading && n > 0.0 {
            dfn_dn = normal_force / n;
        }
        let tangent = dfn_dn;
        // A contact that (almost) only touches has (almost) no stiffness: a step from it
        // would drive its grains deep into each other. Its Hessian gets at least the
        // stiffness it has carrying a negligible share of the force scale.
        let floor_force = FLOOR_FORCE * self.f_ref.max(self.load_scale);
        let floor = if n > 0.0
            && self
                .law
                .floor_may_bind(&c.params, normal_force, c.lag.shear_stiffness, floor_force)
        {
            self.law.tangent_floor(&c.params, floor_force)
        } else {
            0.0
        };
        dfn_dn = dfn_dn.max(floor);
        c.shear_increment = k.shear_increment - c.shear_offset;
        let shear = friction(
            c.shear_force0,
            c.lag.shear_stiffness,
            c.lag.limit,
            c.shear_increment,
        );
        c.response = if self.consistent {
            // The derivative of the refrozen response: a sliding contact's limit `f N`
            // follows its normal force, a sticking one's `k_s` its overlap.
            let dks_dn = self.law.shear_stiffness(&c.params, n).1;
            Response {
                normal_force,
                shear_force: shear.force,
                sliding: shear.sliding,
                dfn_dn: tangent,
                dfs_dn: if !shear.sliding {
                    dks_dn * c.shear_increment
                } else if c.lag.limit > 0.0 {
                    shear.force.signum() * c.params.friction * tangent
                } else {
                    0.0
                },
                dfs_ds: shear.stiffness,
            }
        } else {
            Response {
                normal_force,
                shear_force: shear.force,
                sliding: shear.sliding,
                dfn_dn,
                dfs_dn: 0.0,
                dfs_ds: if shear.sliding {
                    0.0
                } else {
                    shear.stiffness.max(c.params.kappa * floor)
                },
            }
        };
        c.energy = self.law.normal_energy(&c.params, n, c.bonded) + shear.energy;
    }

    /// Whether contact `c` carries or can carry: it touches, or it is bonded.
    pub(super) fn engaged(c: &Contact) -> bool {
        c.bonded || c.overlap > 0.0
    }

    /// At a refreeze, each membrane's chain on the grains where they are now, unless the
    /// chains are held; a chain the pattern does not couple is noted and not taken.
    pub(super) fn refreeze_chains(&mut self) {
        if self.membranes.is_empty() || self.chains_held {
            return;
        }
        let chains = self.chain_watch.chains(
            self.membranes,
            &self.q.position,
            &self.grains.radius,
            self.carriers,
            &self.grains.taken_out,
        );
        let changed = chains
            .iter()
            .zip(self.chains.iter())
            .any(|(a, b)| a.grains != b.grains);
        if changed {
            self.chain_changes += 1;
            if !self.pattern.couples(self.dofs, &chains) {
                self.stale_pattern = true;
                return;
            }
            self.chains_held = self.chain_changes >= CHAIN_CHANGES;
        }
        *self.chains = chains;
    }
}

impl Potential for IncrementEquations<'_> {
    fn evaluate(
        &mut self,
        u: &[f64],
        residual: &mut [f64],
        tangent: Option<&mut [f64]>,
        refreeze: bool,
    ) -> Result<f64, NumericError> {
        self.refreeze = refreeze;
        let result = self.evaluate_at(u, residual, tangent);
        self.refreeze = false;
        result.map(|()| self.energy)
    }

    fn loads(&self) -> &[f64] {
        &self.loads
    }

    fn residual_norm(&self, residual: &[f64]) -> (f64, usize, f64) {
        IncrementEquations::residual_norm(self, residual)
    }

    fn unit_stiffness(&self, dof: usize) -> f64 {
        IncrementEquations::unit_stiffness(self, dof)
    }

    fn stiffness_hint(&self) -> f64 {
        self.stiffness_hint
    }

    fn rotation_of(&self, dof: usize) -> Option<[usize; 2]> {
        match self.dofs.owner(dof) {
            Some(g) if self.dofs.per_grain == 3 && dof % 3 == 2 => {
                let b = self.dofs.grain(g);
                Some([b, b + 1])
            }
            _ => None,
        }
    }

    fn reach(&mut self, u: &[f64], du: &[f64]) -> f64 {
        // By the triangle inequality on each grain's and wall's move from where the lists
        // were made.
        self.configure(u);
        let reach = REACH * 0.5 * self.friends.skin;
        let share = |moved: f64, step: f64| {
            if moved + step > reach {
                ((reach - moved) / step).max(0.0)
            } else {
                1.0
            }
        };
        let mut fraction = 1.0f64;
        let per = self.dofs.per_grain;
        for (i, p) in self.q.position.iter().enumerate() {
            let q = self.friends.reference[i];
            let (moved, step) = ([p[0] - q[0], p[1] - q[1]], [du[i * per], du[i * per + 1]]);
            // Most grains stay well within reach, which needs no square root.
            if surely_shorter(moved, 0.5 * reach) && surely_shorter(step, 0.5 * reach) {
                continue;
            }
            fraction = fraction.min(share(moved[0].hypot(moved[1]), step[0].hypot(step[1])));
        }
        for (w, dof) in self.dofs.wall.iter().enumerate() {
            if let Some(dof) = *dof {
                let moved = (self.q.wall_position[w] - self.friends.wall_reference[w][0]).abs();
                fraction = fraction.min(share(moved, du[dof].abs()));
            }
        }
        fraction
    }

    fn consistent_tangent(
        &mut self,
        u: &[f64],
        residual: &mut [f64],
        tangent: &mut [f64],
    ) -> Result<(), NumericError> {
        let (symmetric, projected) = (self.symmetric, self.projected);
        (
            self.symmetric,
            self.projected,
            self.consistent,
            self.refreeze,
        ) = (false, false, true, true);
        let result = self.evaluate_at(u, residual, Some(tangent));
        (
            self.symmetric,
            self.projected,
            self.consistent,
            self.refreeze,
        ) = (symmetric, projected, false, false);
        result
    }

    fn closing(&mut self, u: &[f64], du: &[f64]) -> f64 {
        // The overlap of two grains lies above the straight line between its values at the
        // ends of the step (distance is convex), so stopping where that line reaches the
        // closing overlap leaves at least that much.
        let closing = CLOSING_OVERLAP * self.r_mean;
        self.configure(u);
        let ClosingScratch { mut apart, mut end } = std::mem::take(&mut self.closing_scratch);
        apart.clear();
        apart.extend(
            (self.contacts.iter().enumerate())
                .filter(|(_, c)| !c.bonded && !self.touches_loose(c.pair))
                .map(|(i, c)| {
                    (
                        i,
                        kinematics(c.pair, self.grains, self.walls, self.q).overlap,
                    )
                })
                .filter(|&(_, overlap)| overlap < closing),
        );
        end.clear();
        end.extend(u.iter().zip(du).map(|(a, b)| a + b));
        self.configure(&end);
        let mut fraction = 1.0f64;
        for &(i, overlap0) in &apart {
            let pair = self.contacts[i].pair;
            let overlap1 = kinematics(pair, self.grains, self.walls, self.q).overlap;
            if overlap1 > closing {
                fraction = fraction.min((closing - overlap0) / (overlap1 - overlap0));
            }
        }
        self.closing_scratch = ClosingScratch { apart, end };
        fraction
    }

    fn place_loose(&mut self, u: &mut [f64]) -> bool {
        self.loose.contains(&true) && !IncrementEquations::place_loose(self, u).is_empty()
    }

    fn needs_new_pattern(&self) -> bool {
        self.stale_pattern
    }

    fn balance_rotations(&mut self, u: &mut [f64]) {
        if !self.dofs.rotations() {
            return;
        }
        self.configure(u);
        // Each contact's shear force as a function of the shear made: `clamp(a - k s, -L, L)`
        // with `a` its trial force now, and the grains it turns.
        let RotationScratch {
            mut shears,
            mut first,
            mut members,
            mut turning,
            mut kinks,
        } = std::mem::take(&mut self.rotation_scratch);
        shears.clear();
        first.clear();
        first.resize(self.grains.len() + 1, 0);
        for c in self.contacts.iter() {
            if self.is_glue(c.pair)
                || self.touches_loose(c.pair)
                || !(c.bonded || c.lag.limit > 0.0)
            {
                continue;
            }
            let k = kinematics(c.pair, self.grains, self.walls, self.q);
            let s = k.shear_increment - c.shear_offset;
            let a = match c.pair.a {
                Side::Grain(a) => a as u32,
                Side::Wall(_) => NO_GRAIN,
            };
            let shear = Shear {
                trial: c.shear_force0 + c.lag.shear_stiffness * s,
                stiffness: c.lag.shear_stiffness,
                limit: c.lag.limit,
                grains: [c.pair.b as u32, a],
                levers: (k.lever_b, k.lever_a),
            };
            for g in shear.turned() {
                first[g + 1] += 1;
            }
            shears.push(shear);
        }
        // Each grain's contacts, in the contacts' order: `members[first[g]..first[g + 1]]`
        // (counted above, each grain's start moved along as its contacts are placed).
        let n = self.grains.len();
        for g in 0..n {
            first[g + 1] += first[g];
        }
        members.clear();
        members.resize(first[n] as usize, 0);
        for (at, c) in shears.iter().enumerate() {
            for g in c.turned() {
                members[first[g] as usize] = at as u32;
                first[g] += 1;
            }
        }
        first.copy_within(0..n, 1);
        first[0] = 0;
        for g in 0..n {
            let list = &members[first[g] as usize..first[g + 1] as usize];
            if list.is_empty() || self.dofs.glue[g].is_some() {
                continue;
            }
            // The moment on the grain turned by `d`: each contact's shear falls by `l d`, `l`
            // its arm about the grain. Its contacts' trial force, `k l`, `l` and limit side by
            // side, as it is evaluated often.
            let lever = |c: &Shear| {
                if c.grains[0] as usize == g {
                    c.levers.0
                } else {
                    c.levers.1
                }
            };
            turning.clear();
            turning.extend(list.iter().map(|&i| {
                let c = &shears[i as usize];
                let l = lever(c);
                (c.trial, c.stiffness * l, l, c.limit)
            }));
            let moment = |d: f64| -> f64 {
                turning
                    .iter()
                    .map(|&(trial, kl, l, limit)| l * (trial - kl * d).clamp(-limit, limit))
                    .sum()
            };
            let now = moment(0.0);
            if now == 0.0 {
                continue;
            }
            // A bracket from the contacts' stick windows, widened until the moment changes
            // sign; none where the grain rolls freely (every contact slides the same way).
            let width = list
                .iter()
                .map(|&i| {
                    let c = &shears[i as usize];
                    if c.stiffness > 0.0 && c.limit.is_finite() {
                        (c.trial.abs() + c.limit) / (c.stiffness * lever(c))
                    } else {
                        0.0
                    }
                })
                .fold(0.0, f64::max);
            if width == 0.0 {
                continue;
            }
            let far = now.signum() * 2.0 * width;
            if moment(far).signum() == now.signum() {
                continue;
            }
            // The moment is linear between the turns where a contact starts or stops
            // sliding: walk them from here towards `far` to the one past which its sign
            // changes, and solve the line before it.
            kinks.clear();
            kinks.extend(
                (turning.iter())
                    .filter(|&&(_, kl, _, limit)| kl != 0.0 && limit.is_finite())
                    .flat_map(|&(trial, kl, _, limit)| [(trial - limit) / kl, (trial + limit) / kl])
                    .filter(|&d| d * far > 0.0 && d.abs() < far.abs()),
            );
            kinks.push(far);
            kinks.sort_by(|a, b| a.abs().total_cmp(&b.abs()));
            let (mut before, mut m_before) = (0.0, now);
            let mut d = far;
            for &kink in kinks.iter() {
                let m = moment(kink);
                if m.signum() != now.signum() {
                    d = before + (kink - before) * m_before / (m_before - m);
                    break;
                }
                (before, m_before) = (kink, m);
            }
            u[self.dofs.grain(g) + 2] += d;
            for &i in list {
                let c = &mut shears[i as usize];
                c.trial -= c.stiffness * lever(c) * d;
            }
        }
        self.rotation_scratch = RotationScratch {
            shears,
            first,
            members,
            turning,
            kinks,
        };
    }

    fn balance_grain(
        &mut self,
        u: &mut [f64],
        residual: &[f64],
        grain: usize,
        hint: &mut Vec<u8>,
    ) -> bool {
        let g = grain;
        let loose = self.loose.get(g) == Some(&true);
        if loose || self.dofs.grain_held(g) || self.anchors.iter().any(|a| a.grain == g) {
            return false;
        }
        self.configure(u);
        let (base, unknowns) = (self.dofs.grain(g), self.dofs.per_grain);
        let mut balance = GrainBalance {
            law: self.law,
            external: [0.0; 3],
            unknowns,
            tolerance: BALANCED * self.f_ref,
            radius: self.grains.radius[g],
            near: Vec::new(),
            far: Vec::new(),
        };
        balance.external[..unknowns].copy_from_slice(&residual[base..base + unknowns]);
        // The contacts' gradients on the grain's unknowns: `B_n` and `B_t` of
        // `contact_block` where the grain is side `a` or `b`.
        let on_grain = |k: &Kinematics, side_a: bool| {
            let (n, t) = (k.normal, k.tangent);
            if side_a {
                ([n[0], n[1], 0.0], [-t[0], -t[1], -k.lever_a])
            } else {
                ([-n[0], -n[1], 0.0], [t[0], t[1], -k.lever_b])
            }
        };
        for (c, evaluated) in self.contacts.iter().zip(self.kin.iter()) {
            let side_a = matches!(c.pair.a, Side::Grain(a) if a == g);
            if !(c.pair.b == g || side_a) || self.is_glue(c.pair) {
                continue;
            }
            // The residual less this contact's force at the evaluation leaves what else
            // pushes the grain.
            let (bn, bt) = on_grain(evaluated, side_a);
            for i in 0..3 {
                balance.external[i] +=
                    c.response.normal_force * bn[i] + c.response.shear_force * bt[i];
            }
            let k = kinematics(c.pair, self.grains, self.walls, self.q);
            let (bn, bt) = on_grain(&k, side_a);
            let branch = (!k.flat).then(|| {
                let b0 = [k.normal[0] * k.distance, k.normal[1] * k.distance];
                (b0, if side_a { -1.0 } else { 1.0 }, k.distance.signum())
            });
            let local = LocalContact {
                overlap: k.overlap,
                shear: k.shear_increment - c.shear_offset,
                branch,
                bn,
                bt,
                force0: c.shear_force0,
                params: c.params,
                bonded: c.bonded,
            };
            if c.bonded || k.overlap > -NEAR_GAP * self.r_mean {
                balance.near.push(local);
            } else {
                balance.far.push(local);
            }
        }
        let Some((d, states)) = balance.nearest(hint) else {
            hint.clear();
            return false;
        };
        *hint = states;
        for (x, dx) in u[base..base + unknowns].iter_mut().zip(d) {
            *x += dx;
        }
        true
    }

    fn loose_neighbours(&self, grain: usize) -> Vec<usize> {
        let grains_of = |c: &Contact| {
            let a = match c.pair.a {
                Side::Grain(a) => Some(a),
                Side::Wall(_) => None,
            };
            (a, c.pair.b)
        };
        let mut neighbours: Vec<(usize, usize)> = (self.contacts.iter())
            .filter(|c| !c.bonded && c.overlap > 0.0 && !self.touches_loose(c.pair))
            .filter_map(|c| match grains_of(c) {
                (Some(a), b) if a == grain => Some((b, 0)),
                (Some(a), b) if b == grain => Some((a, 0)),
                _ => None,
            })
            .collect();
        if neighbours.is_empty() {
            return Vec::new();
        }
        for c in (self.contacts.iter()).filter(|c| Self::engaged(c)) {
            let (a, b) = grains_of(c);
            for (g, held) in &mut neighbours {
                if a == Some(*g) || b == *g {
                    *held += 1;
                }
            }
        }
        (neighbours.into_iter())
            .filter(|&(_, held)| held <= LOOSE_CONTACTS)
            .map(|(g, _)| g)
            .collect()
    }

    fn runaway(&self, _u: &[f64]) -> Vec<usize> {
        (0..self.grains.len())
            .filter(|&i| {
                let (d, diameter) = (self.q.displacement[i], 2.0 * self.grains.radius[i]);
                !surely_shorter(d, diameter) && d[0].hypot(d[1]) > diameter
            })
            .collect()
    }
}
