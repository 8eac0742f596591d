//! The equilibrium equations of one load increment: residual `R = f_ext + f_contact` on every
//! unknown, and the tangent `K = -dR/du`, assembled into the fixed pattern.

use super::anchors::Anchor;
use super::potential::{ClosingScratch, RotationScratch};
use super::LoadStep;
use crate::assembly::{contact_block, frame_turn_force, BlockTangent, DofMap, PairMap, Pattern};
use crate::contact::{kinematics, Configuration, Contact, ContactLaw, Kinematics, Response};
use crate::geometry::{
    rotate, Chain, ChainWatch, FriendSet, GrainSet, Membrane, MembraneShape, Pair, Side, WallSet,
};
use crate::parallel;
use crate::solver::stats::{secs, StageTimers};
use crate::NumericError;
use std::time::Instant;

/// Everything one evaluation reads, and the contacts it updates (their trial responses).
pub struct IncrementEquations<'a> {
    /// Committed grains (start of the increment).
    pub grains: &'a GrainSet,
    /// Committed walls.
    pub walls: &'a WallSet,
    /// Contacts: history read, trial response written.
    pub contacts: &'a mut Vec<Contact>,
    /// Friend-pair index of each contact (its block in the pattern), increasing.
    pub pair_index: &'a mut Vec<usize>,
    /// The friends lists: no step takes a grain so far that a pair outside them could touch.
    pub friends: &'a FriendSet,
    /// The wall program of this step.
    pub step: &'a LoadStep,
    /// Membranes (their pressures come from the step).
    pub membranes: &'a [Membrane],
    /// Each membrane's chain: found anew at a refreeze, as the grains roll.
    pub chains: &'a mut Vec<Chain>,
    /// Whether the chains stay as they are from now on: a grain on the membrane probe's line
    /// can flip them from refreeze to refreeze (see [`super::CHAIN_CHANGES`]).
    pub chains_held: bool,
    /// The chains last found: a refreeze where no grain has moved far enough since to change
    /// them takes them as they are.
    pub chain_watch: &'a mut ChainWatch,
    /// The grains the membranes may lie on ([`super::membrane_carriers`]).
    pub carriers: &'a [bool],
    /// Springs on the rigid-body motions no wall holds.
    pub anchors: &'a [Anchor],
    /// Grains left out of the minimisation as loose (they touched nothing where it started):
    /// held where they are, their contacts carrying nothing, and moved only out of the way of
    /// the others ([`IncrementEquations::place_loose`]). Empty when none is.
    pub loose: &'a mut Vec<bool>,
    /// Relaxation: pairs whose contact opened in tension earlier in this increment, sorted.
    /// Made again, such a contact carries nothing while apart, but keeps its stiffness in the
    /// tangent: an equilibrium that needs it to pull then has it just touching, where a
    /// contact that pulled would open and close again from pass to pass.
    pub reopened: &'a [Pair],
    /// Unknowns.
    pub dofs: &'a DofMap,
    /// Pattern and slot maps.
    pub pattern: &'a Pattern,
    /// The contact law.
    pub law: &'a dyn ContactLaw,
    /// Whether the tangent must be symmetric (for the Cholesky): off only for the consistent
    /// tangent of the semi-smooth steps.
    pub symmetric: bool,
    /// Depth `D` (m).
    pub depth: f64,
    /// Mean radius (m): scales moments and rotations in the norms.
    pub r_mean: f64,
    /// Current configuration (workspace).
    pub q: &'a mut Configuration,
    /// Contact kinematics (workspace).
    pub kin: &'a mut Vec<Kinematics>,
    /// Time spent in the return map and in assembly by this set of equations.
    pub timers: StageTimers,
    /// Force scale of the last evaluation.
    pub f_ref: f64,
    /// Contact stiffness to regularise with when the tangent has none.
    pub stiffness_hint: f64,
    /// Relaxation: whether the sweeps are far from the answer (soft tangents get a floor).
    pub far: bool,
    /// Wall load per grain touching a loaded wall (N): the force scale before contacts carry.
    pub load_scale: f64,
    /// Whether the contacts respond as in the minimisation of the increment: friction with
    /// its normal force and shear stiffness lagged ([`crate::contact::Lag`]), every pair of
    /// the friends lists a contact that carries only while it touches or is bonded.
    pub lagged: bool,
    /// Whether this evaluation refreezes the lag (and the membranes' chains) first.
    pub refreeze: bool,
    /// Whether the tangent is the projected, positive semi-definite Hessian: geometric terms
    /// that soften (a compressed contact's rotating normal, the shear's, a pressure's) left
    /// out.
    pub projected: bool,
    /// The loads of the last evaluation: walls, membranes and the springs on free motions.
    pub loads: Vec<f64>,
    /// Whether a refreeze found a membrane chain the pattern does not couple.
    pub stale_pattern: bool,
    /// Chain changes found by refreezes; past [`super::CHAIN_CHANGES`] the chains are held.
    pub chain_changes: usize,
    /// Whether a lagged evaluation gives the consistent tangent of the true residual: a
    /// sliding contact's friction following its normal force, unsymmetric.
    pub consistent: bool,
    /// Stored energy of the contacts at the last evaluation (J).
    pub energy: f64,
    /// What the true residual had beyond the exact gradient at the last refreeze, held as a
    /// load until the next (a lagged, non-conservative part, like a follower load's).
    pub frame_correction: Vec<f64>,
    /// Buffers the grains' rotation balance keeps between calls.
    pub rotation_scratch: RotationScratch,
    /// Buffers the closing fraction of a step keeps between calls.
    pub closing_scratch: ClosingScratch,
}

impl IncrementEquations<'_> {
    /// Wall lines, positions and rotations for increment displacements `u` (walls first: a
    /// glued grain goes where its wall takes it).
    pub fn configure(&mut self, u: &[f64]) {
        for w in 0..self.walls.len() {
            self.configure_wall(w, u);
        }
        for i in 0..self.grains.len() {
            self.configure_grain(i, u);
        }
    }

    /// Grain `i`'s position and rotation for increment displacements `u`: its own, or, glued,
    /// its wall's: the wall's slide and its turn about its pivot carry it, and the normal
    /// moves of the walls it follows ([`crate::assembly::Glue`]) with their weights.
    pub fn configure_grain(&mut self, i: usize, u: &[f64]) {
        let per = self.dofs.per_grain;
        let (d, rotation) = match self.dofs.glue[i] {
            Some(glue) => {
                let wall = &self.walls.walls[glue.wall];
                let (s, t, turn) = (
                    self.step.slide[glue.wall],
                    wall.tangent(),
                    self.step.turn[glue.wall],
                );
                let (o, g, p) = (
                    self.grains.origin[i],
                    self.grains.displacement[i],
                    wall.pivot_at(wall.position),
                );
                let from_pivot = [(o[0] - p[0]) + g[0], (o[1] - p[1]) + g[1]];
                let turned = rotate(from_pivot, turn);
                let mut d = [
                    s * t[0] + (turned[0] - from_pivot[0]),
                    s * t[1] + (turned[1] - from_pivot[1]),
                ];
                for &(w, v) in glue.follows.iter().flatten() {
                    let m = self.normal_move(w, u);
                    d = [d[0] + m * v[0], d[1] + m * v[1]];
                }
                (d, turn)
            }
            None => {
                let b = i * per;
                ([u[b], u[b + 1]], if per == 3 { u[b + 2] } else { 0.0 })
            }
        };
        let p = self.grains.position[i];
        self.q.position[i] = [p[0] + d[0], p[1] + d[1]];
        self.q.displacement[i] = d;
        self.q.rotation[i] = rotation;
    }

    /// Wall `w`'s move into the sample in this step: its own unknown, or the step's move.
    fn normal_move(&self, w: usize, u: &[f64]) -> f64 {
        match self.dofs.wall[w] {
            Some(dof) => u[dof],
            None => self.step.normal_move[w],
        }
    }

    /// How straight wall `w` moves in this step for increment displacements `u`: the
    /// translation of its line (along its starting normal and tangent), then the turn about
    /// its pivot so moved.
    fn wall_motion(&self, w: usize, u: &[f64]) -> ([f64; 2], f64) {
        let wall = &self.walls.walls[w];
        let (normal_move, s, t) = (self.normal_move(w, u), self.step.slide[w], wall.tangent());
        (
            [
                normal_move * wall.normal[0] + s * t[0],
                normal_move * wall.normal[1] + s * t[1],
            ],
            self.step.turn[w],
        )
    }

    /// Wall `w`'s line for increment displacements `u` (its own unknown, or the step's move).
    pub fn configure_wall(&mut self, w: usize, u: &[f64]) {
        let wall = &self.walls.walls[w];
        let normal_move = self.normal_move(w, u);
        self.q.wall_line[w] = wall.surface(wall.position + normal_move);
        self.q.wall_position[w] = wall.position + normal_move;
        // A growing circle's centre stays, a moving plug's goes along its direction; a line
        // moves along its normal and along itself, and turns.
        (self.q.wall_displacement[w], self.q.wall_turn[w]) = match wall.circle {
            Some(c) => (
                c.moves.map_or([0.0; 2], |m| m.map(|v| normal_move * v)),
                0.0,
            ),
            None => self.wall_motion(w, u),
        };
    }

    /// Kinematics and the return map of every contact, in the configuration last set by
    /// [`IncrementEquations::configure`]: each contact on its own, shared over the threads.
    pub fn update_contacts(&mut self) -> Result<(), NumericError> {
        let start = Instant::now();
        let (mut contacts, mut kin) = (std::mem::take(self.contacts), std::mem::take(self.kin));
        parallel::map_mut_into(&mut contacts, &mut kin, |c| self.respond_to(c));
        (*self.contacts, *self.kin) = (contacts, kin);
        self.timers.return_map += secs(start);
        self.contacts.iter().try_for_each(finite)
    }

    /// Whether the contact of `pair` is part of a wall's glue: a glued grain's contact with
    /// its wall or with another grain glued to the same wall. The wall sets where such grains
    /// go (it stretches with the box, see [`crate::assembly::Glue`]), so the contact carries
    /// nothing that changes: a chain of glued grains along a side that the top's move
    /// compressed would otherwise carry load past the sample.
    pub fn is_glue(&self, pair: Pair) -> bool {
        self.dofs.glues(pair)
    }

    /// Kinematics and the return map of contact `idx` in the current configuration.
    pub fn respond(&mut self, idx: usize) -> Result<Kinematics, NumericError> {
        let mut contacts = std::mem::take(self.contacts);
        let k = self.respond_to(&mut contacts[idx]);
        *self.contacts = contacts;
        finite(&self.contacts[idx]).map(|_| k)
    }

    /// Whether `pair` touches a grain left out as loose.
    pub fn touches_loose(&self, pair: Pair) -> bool {
        !self.loose.is_empty()
            && (self.loose[pair.b] || matches!(pair.a, Side::Grain(a) if self.loose[a]))
    }

    /// Kinematics and the return map of contact `c` in the current configuration (a glue
    /// contact keeps the response it was glued with; one with a loose grain carries nothing).
    fn respond_to(&self, c: &mut Contact) -> Kinematics {
        let k = kinematics(c.pair, self.grains, self.walls, self.q);
        if self.is_glue(c.pair) {
            return k;
        }
        if self.touches_loose(c.pair) {
            c.overlap = k.overlap;
            c.response = Response::default();
            c.energy = 0.0;
            return k;
        }
        if self.lagged {
            self.respond_lagged(c, &k);
            return k;
        }
        c.overlap = k.overlap;
        c.shear_increment = k.shear_increment - c.shear_offset;
        c.response = self.law.respond(
            &c.params,
            c.bonded,
            c.overlap,
            c.shear_force0,
            c.shear_increment,
        );
        if c.overlap < 0.0 && !c.bonded && self.reopened.binary_search(&c.pair).is_ok() {
            (c.response.normal_force, c.response.shear_force) = (0.0, 0.0);
        }
        let scale = self.f_ref.max(self.load_scale);
        if self.far && c.response.normal_force < 1e-3 * scale {
            // Far from the answer, a contact that carries (almost) nothing yet gets the
            // stiffness it will have when it carries its share.
            let floor = self.law.tangent_floor(&c.params, scale);
            let r = &mut c.response;
            r.dfn_dn = r.dfn_dn.max(floor);
            if !r.sliding {
                r.dfs_ds = r.dfs_ds.max(c.params.kappa * floor);
            }
        }
        k
    }

    /// Membrane pressures on the chains' grains, and their tangent: a segment `e` from `a` to
    /// `b` pushes both with `p D / 2` times `R e` (`R` the quarter turn), so
    /// `K_aa = K_ba = p D / 2 R` and `K_ab = K_bb = -p D / 2 R`. Over a closed chain that
    /// is symmetric; a symmetric solver takes each segment's symmetric part.
    pub(super) fn membrane_loads(&self, residual: &mut [f64], tangent: Option<&mut [f64]>) {
        // The pressure's stiffness is indefinite: a projected Hessian leaves it out.
        let mut tangent = tangent.filter(|_| !self.projected);
        let quarter = [[0.0, -1.0], [1.0, 0.0]];
        for (m, membrane) in self.membranes.iter().enumerate() {
            let chain = &self.chains[m];
            let pd = self.step.pressure[m] * self.depth;
            let add = |row: usize, col: usize, k: [[f64; 2]; 2], t: &mut Option<&mut [f64]>| {
                if let Some(t) = t.as_deref_mut() {
                    let (r, c) = (self.dofs.grain(row), self.dofs.grain(col));
                    for (i, k_row) in k.iter().enumerate() {
                        for (j, k_ij) in k_row.iter().enumerate() {
                            if let Some(slot) = self.pattern.slot(r + i, c + j) {
                                t[slot] += k_ij;
                            }
                        }
                    }
                }
            };
            let scaled = |s: f64, k: [[f64; 2]; 2]| k.map(|row| row.map(|v| s * v));
            for (g, f) in chain.loads(membrane.shape, &self.q.position, pd) {
                let d = self.dofs.grain(g);
                residual[d] += f[0];
                residual[d + 1] += f[1];
            }
            for (a, b) in chain.links() {
                // The symmetric part of a segment's block keeps only K_ab = -c R, K_ba = c R.
                let c = scaled(0.5 * pd, quarter);
                let minus = scaled(-1.0, c);
                add(a, b, minus, &mut tangent);
                add(b, a, c, &mut tangent);
                if !self.symmetric {
                    add(a, a, c, &mut tangent);
                    add(b, b, minus, &mut tangent);
                }
            }
            // A side's end pieces: the first grain carries the side from its start, the last
            // to its end, inward.
            if let (MembraneShape::Side { outward }, Some(&first), Some(&last)) =
                (membrane.shape, chain.grains.first(), chain.grains.last())
            {
                let along = chain.along;
                for (g, sign) in [(first, 1.0), (last, -1.0)] {
                    // d(length)/dx = sign * along; K = -dR/dx = sign pD outward along^T.
                    let mut k = [[0.0; 2]; 2];
                    for i in 0..2 {
                        for j in 0..2 {
                            k[i][j] = if self.symmetric {
                                0.5 * sign * pd * (outward[i] * along[j] + along[i] * outward[j])
                            } else {
                                sign * pd * outward[i] * along[j]
                            };
                        }
                    }
                    add(g, g, k, &mut tangent);
                }
            }
        }
    }

    /// `R(u)` into `residual` and, when given, the tangent into `tangent`: the walls' loads,
    /// every contact's force and stiffness, then the membranes' loads and the springs. When
    /// lagged, the loads alone are kept in [`IncrementEquations::loads`] too.
    pub fn evaluate_at(
        &mut self,
        u: &[f64],
        residual: &mut [f64],
        mut tangent: Option<&mut [f64]>,
    ) -> Result<(), NumericError> {
        residual.iter_mut().for_each(|r| *r = 0.0);
        if let Some(t) = tangent.as_deref_mut() {
            t.iter_mut().for_each(|v| *v = 0.0);
        }
        self.configure(u);
        if self.refreeze {
            self.refreeze_chains();
        }
        let sum_ext = self.wall_loads(residual, tangent.as_deref_mut());
        // The force scale before contacts carry: the wall loads shared over the grains that
        // touch the loaded walls.
        let loaded = self
            .contacts
            .iter()
            .filter(|c| !self.lagged || Self::engaged(c))
            .filter(|c| matches!(c.pair.a, Side::Wall(w) if self.dofs.wall[w].is_some()))
            .count()
            .max(1) as f64;
        self.load_scale = sum_ext / loaded;
        self.update_contacts()?;
        let start = Instant::now();
        // Glue contacts carry nothing that changes (see `is_glue`): they count nowhere but
        // among the engaged.
        let (mut sum_fn, mut energy, mut engaged) = (0.0, 0.0, 0usize);
        for c in self.contacts.iter() {
            engaged += usize::from(Self::engaged(c) && !self.touches_loose(c.pair));
            if !self.is_glue(c.pair) {
                sum_fn += c.response.normal_force.abs();
                energy += c.energy;
            }
        }
        self.energy = energy;
        // Each contact's block added in the contacts' order, on the threads' shares of the
        // unknowns; the map of a glue contact, or of one whose block is zero, is empty.
        let (walls, dofs, kin, contacts) = (self.walls, self.dofs, &*self.kin, &*self.contacts);
        let tangent_kind = tangent.is_some().then(|| self.block_tangent());
        // In the lagged problem the shear forces push as the exact gradient of the potential;
        // what the true residual has beyond that is taken at each refreeze and held as a load
        // until the next (a lagged non-conservative part, like a follower load's), so that the
        // line search and the residual agree and a refrozen residual is the true one.
        let exact = self.lagged && !self.consistent;
        let map_of = |i: usize| {
            let c = &contacts[i];
            if c.response.is_zero() || dofs.glues(c.pair) {
                PairMap::default()
            } else {
                dofs.pair_map(c.pair, push_direction(walls, c.pair, &kin[i]))
            }
        };
        // On a refreeze the frame turn's force is taken in the same pass (a second force).
        let turn = exact && self.refreeze;
        let mut correction = std::mem::take(&mut self.frame_correction);
        if turn {
            correction.clear();
            correction.resize(residual.len(), 0.0);
        }
        self.pattern.scatter(
            self.pair_index,
            map_of,
            |i, map, out| {
                let (k, r) = (&kin[i], &contacts[i].response);
                contact_block(k, r, map, tangent_kind, exact, out);
                if turn {
                    frame_turn_force(k, r, map, out);
                }
            },
            residual,
            turn.then_some(&mut correction[..]),
            tangent.as_deref_mut(),
        );
        self.frame_correction = correction;
        self.membrane_loads(residual, tangent.as_deref_mut());
        self.anchor_springs(u, residual, tangent.as_deref_mut());
        self.glue_springs(u, residual, tangent.as_deref_mut());
        self.hold_loose(residual, tangent);
        if self.lagged {
            let mut loads = std::mem::take(&mut self.loads);
            loads.clear();
            loads.resize(residual.len(), 0.0);
            self.wall_loads(&mut loads, None);
            self.membrane_loads(&mut loads, None);
            self.anchor_springs(u, &mut loads, None);
            self.glue_springs(u, &mut loads, None);
            if exact {
                for ((l, r), c) in loads
                    .iter_mut()
                    .zip(residual.iter_mut())
                    .zip(&self.frame_correction)
                {
                    *l += c;
                    *r += c;
                }
            }
            self.loads = loads;
        }
        // Force scale: the mean contact force (of those that touch, when every pair of the
        // friends lists is a contact), or, while contacts carry (almost) nothing, the wall
        // loads shared over the grains touching the loaded walls.
        let counted = if self.lagged {
            engaged
        } else {
            self.contacts.len()
        };
        self.f_ref = (sum_fn / counted.max(1) as f64).max(self.load_scale);
        if let Some(bad) = residual.iter().position(|r| !r.is_finite()) {
            return Err(NumericError::NotFinite {
                what: "residual",
                place: match self.dofs.owner(bad) {
                    Some(g) => format!("grain {g}"),
                    None => format!("wall unknown {bad}"),
                },
            });
        }
        self.timers.assembly += secs(start);
        Ok(())
    }

    /// The stress-controlled walls' loads, `stress * length * depth` into the sample, the
    /// length following the walls that bound it (a follower load), and their tangent.
    /// Returns the sum of their magnitudes.
    fn wall_loads(&self, residual: &mut [f64], mut tangent: Option<&mut [f64]>) -> f64 {
        let mut sum = 0.0;
        for (w, wall) in self.walls.walls.iter().enumerate() {
            let Some(dof) = self.dofs.wall[w] else {
                continue;
            };
            let sigma = self.step.stress[w];
            let load = sigma * self.wall_length(w) * self.depth;
            residual[dof] += load;
            sum += load.abs();
            match (tangent.as_deref_mut(), wall.length, wall.circle) {
                // A circle's circumference follows its own radius: dL/ds = 2 pi sign. A
                // projected Hessian keeps it only where it stiffens.
                (Some(t), None, Some(c)) => {
                    let k = -sigma * self.depth * 2.0 * std::f64::consts::PI * c.sign();
                    if !self.projected || k > 0.0 {
                        t[self.pattern.diagonal[dof]] += k;
                    }
                }
                // dL/d(position of a span wall) = -1, so K = -dR/du = sigma * D: the only
                // unsymmetric term of the walls, left out of a symmetric tangent.
                (Some(t), None, None) if !self.symmetric => {
                    for &(_, _, slot) in self.pattern.couplings.iter().filter(|c| c.0 == dof) {
                        t[slot] += sigma * self.depth;
                    }
                }
                _ => {}
            }
        }
        sum
    }

    /// A glued grain's own unknowns: springs of a contact's stiffness hold them at zero.
    fn glue_springs(&self, u: &[f64], residual: &mut [f64], mut tangent: Option<&mut [f64]>) {
        let held = (0..self.dofs.grains).filter(|&g| self.dofs.grain_held(g));
        for dof in held.flat_map(|g| self.dofs.grain(g)..self.dofs.grain(g) + self.dofs.per_grain) {
            let k = self.stiffness_hint * self.unit_stiffness(dof);
            residual[dof] -= k * u[dof];
            if let Some(t) = tangent.as_deref_mut() {
                t[self.pattern.diagonal[dof]] += k;
            }
        }
    }

    /// A loose grain's unknowns stay where they are: nothing pushes them, and a stiffness on
    /// the diagonal keeps their rows regular.
    fn hold_loose(&self, residual: &mut [f64], mut tangent: Option<&mut [f64]>) {
        if self.loose.is_empty() {
            return;
        }
        let held = (0..self.dofs.grains).filter(|&g| self.loose[g]);
        for dof in held.flat_map(|g| self.dofs.grain(g)..self.dofs.grain(g) + self.dofs.per_grain) {
            residual[dof] = 0.0;
            if let Some(t) = tangent.as_deref_mut() {
                t[self.pattern.diagonal[dof]] += self.stiffness_hint * self.unit_stiffness(dof);
            }
        }
    }

    /// Which tangent each contact's block gives.
    pub fn block_tangent(&self) -> BlockTangent {
        match (self.symmetric, self.projected) {
            (_, true) => BlockTangent::Projected,
            (true, false) => BlockTangent::Symmetric,
            (false, false) => BlockTangent::Consistent,
        }
    }

    /// The anchors' springs, `k d d^T` on the grain's move in the increment.
    fn anchor_springs(&self, u: &[f64], residual: &mut [f64], mut tangent: Option<&mut [f64]>) {
        for anchor in self.anchors {
            let (g, d) = (self.dofs.grain(anchor.grain), anchor.direction);
            let stretch = u[g] * d[0] + u[g + 1] * d[1];
            for i in 0..2 {
                residual[g + i] -= self.stiffness_hint * stretch * d[i];
                if let Some(t) = tangent.as_deref_mut() {
                    for j in 0..2 {
                        if let Some(slot) = self.pattern.slot(g + i, g + j) {
                            t[slot] += self.stiffness_hint * d[i] * d[j];
                        }
                    }
                }
            }
        }
    }

    /// The direction a wall's unknown moves its side of contact `idx` along (see
    /// [`crate::geometry::Wall::push_direction`]); unused for a grain pair.
    pub(super) fn push_direction(&self, pair: Pair, idx: usize) -> [f64; 2] {
        push_direction(self.walls, pair, &self.kin[idx])
    }

    /// Current loaded length of wall `w`: fixed, a circle's circumference, or the gap between
    /// the walls that bound it.
    pub(super) fn wall_length(&self, w: usize) -> f64 {
        let wall = &self.walls.walls[w];
        match (wall.length, wall.circle) {
            (Some(l), _) => l,
            (None, Some(_)) => 2.0 * std::f64::consts::PI * self.q.wall_line[w],
            (None, None) => match self.walls.span_walls(w) {
                Some((a, b)) => -(self.q.wall_line[a] + self.q.wall_line[b]),
                // Between membranes: the sample's extent along the wall.
                None => self.grains.extent_along(&self.q.position, wall.tangent()),
            },
        }
    }
}

/// The direction a wall's unknown moves side `a` of `pair` along (see
/// [`crate::geometry::Wall::push_direction`]); the normal for a grain pair, where it is unused.
fn push_direction(walls: &WallSet, pair: Pair, kin: &Kinematics) -> [f64; 2] {
    match pair.a {
        Side::Wall(w) => walls.walls[w].push_direction(kin.normal),
        Side::Grain(_) => kin.normal,
    }
}

/// An error naming contact `c` if its forces are not finite.
fn finite(c: &Contact) -> Result<(), NumericError> {
    if c.response.normal_force.is_finite() && c.response.shear_force.is_finite() {
        Ok(())
    } else {
        Err(NumericError::NotFinite {
            what: "contact force",
            place: format!("contact {:?}-{}", c.pair.a, c.pair.b),
        })
    }
}

/// Overlap, in mean radii, within which a contact keeps its state (made or lost).
pub const CHATTER: f64 = 1e-12;

/// Overlap, in mean radii, at which a semi-smooth step that closes a gap stops: small, so
/// the contact enters the next step's tangent about where its surfaces touched.
pub(super) const CLOSING_OVERLAP: f64 = 1e-6;

/// Share of the half skin a grain may move from where the friends lists were made before a
/// step stops for them to be made anew.
pub(super) const REACH: f64 = 0.9;

impl IncrementEquations<'_> {
    /// Convergence measure of a residual: `(|R|_inf / F_ref, worst grain, |R|_2 / F_ref)`,
    /// moments divided by the mean radius.
    pub fn residual_norm(&self, residual: &[f64]) -> (f64, usize, f64) {
        let per = self.dofs.per_grain;
        let scale = if self.f_ref > 0.0 { self.f_ref } else { 1.0 };
        let (mut inf, mut worst, mut sq) = (0.0f64, 0usize, 0.0);
        for (k, r) in residual.iter().enumerate() {
            let v = match self.dofs.owner(k) {
                Some(_) if per == 3 && k % 3 == 2 => r.abs() / self.r_mean,
                _ => r.abs(),
            } / scale;
            sq += v * v;
            if v > inf {
                inf = v;
                worst = self.dofs.owner(k).unwrap_or(worst);
            }
        }
        (inf, worst, sq.sqrt())
    }

    /// How the stiffness of each unknown scales: 1 for a translation, `r^2` for a rotation.
    pub fn unit_stiffness(&self, dof: usize) -> f64 {
        match self.dofs.owner(dof) {
            Some(_) if self.dofs.per_grain == 3 && dof % 3 == 2 => self.r_mean * self.r_mean,
            _ => 1.0,
        }
    }
}
