//! The grain-by-grain strategy (the thesis's 'Grain') on the same equations as the global
//! solver: one block per grain (its 3x3 system of eq. 19, or 2x2 with fixed rotations) and
//! one per stress-controlled wall, built from the same contact laws and local contact blocks,
//! swept in index order by [`crate::solver::relaxation::relax`]. Contacts are made and lost
//! between passes by a topology update of its own.

use super::equations::{IncrementEquations, CHATTER};
use super::{LoadStep, Simulation, REACH_REBUILD};
use crate::assembly::{contact_block, LocalBlock};
use crate::contact::{kinematics, BrokenBond, Contact};
use crate::geometry::{Pair, Side};
use crate::solver::relaxation::{
    self, BlockEquations, BlockSystem, RelaxationOutcome, RelaxationSettings, Slip,
};
use crate::solver::stats::secs;
use crate::state::IncrementReport;
use crate::NumericError;
use std::time::Instant;

/// Share of the half skin a grain may move from where the friends lists were made: past
/// [`REACH_REBUILD`], so the topology update then makes the lists anew.
const REACH: f64 = 0.9;

/// What one topology pass changed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
struct TopologyChange {
    made: usize,
    lost: usize,
    broken: usize,
    /// Membranes whose chain of grains changed.
    chains: usize,
}

impl TopologyChange {
    fn any(&self) -> bool {
        self.made + self.lost + self.broken + self.chains > 0
    }
}

impl Simulation {
    /// Solve a step by relaxation and commit it. Where that fails (a residual that is not
    /// finite), the history is restored and the step solved as two halves, down to
    /// `max_cuts` halvings.
    pub(super) fn relax_increment(
        &mut self,
        step: &LoadStep,
        depth: u32,
        report: &mut IncrementReport,
    ) -> Result<(), NumericError> {
        let backup = self.state.contacts.clone();
        let energy = self.energy;
        self.start_step();
        // Grain by grain, each block is solved with its neighbours held, so nothing need
        // hold the sample as a whole; an anchor would carry the load the sweeps have not
        // yet passed through the sample, out of sight of the residual.
        self.anchors.clear();
        match self.relax_step(step, report) {
            Ok((u, change)) => {
                report.negative_pivots = self.negative_pivots(step, &u);
                report.contacts_made += change.made;
                report.contacts_lost += change.lost;
                report.bonds_broken += change.broken;
                self.commit(step, &u);
                Ok(())
            }
            Err(err) => {
                self.state.contacts = backup;
                self.energy = energy;
                self.restore_friends()?;
                if depth >= self.config.max_cuts {
                    return Err(err);
                }
                report.cuts += 1;
                self.stats.counters.cuts += 1;
                let (stress, pressure) = self.held_loads();
                let (first, second) = step.split(0.5, &stress, &pressure);
                self.relax_increment(&first, depth + 1, report)?;
                self.relax_increment(&second, depth + 1, report)
            }
        }
    }

    /// One increment by relaxation: passes of sweeps until the residual meets the tolerance
    /// or the increment's `sweeps` (`n_i`) are spent. A pass stops where a gap closes (or a
    /// grain nears the edge of its friends lists), and the contact is made before the next;
    /// contacts are lost and bonds broken at the end, and if that changes the forces while
    /// sweeps are left, the sweeps go on. Then the increment is taken as it stands, as in the
    /// thesis: its residual is reported, never a failure.
    fn relax_step(
        &mut self,
        step: &LoadStep,
        report: &mut IncrementReport,
    ) -> Result<(Vec<f64>, TopologyChange), NumericError> {
        let mut u = vec![0.0; self.dofs.len];
        let mut total = TopologyChange::default();
        self.refresh_chains(false)?;
        let mut left = self.config.sweeps;
        loop {
            let outcome = self.relax(step, &mut u, left)?;
            left -= outcome.iterations.min(left);
            report.newton_iterations += outcome.iterations;
            report.residual = outcome.residual;
            report.topology_passes += 1;
            self.stats.counters.topology_passes += 1;
            if outcome.iterations > 0 {
                self.last_residuals.clone_from(&outcome.history);
            }
            // Contacts made where gaps closed; lost and broken only once the sweeps stop,
            // so a contact near zero overlap does not flip from pass to pass.
            let settled = left == 0 || !outcome.at_reach;
            let change = self.update_topology(step, &u, settled)?;
            total.made += change.made;
            total.lost += change.lost;
            total.broken += change.broken;
            if left == 0 || (settled && !change.any()) {
                if change.any() {
                    // The increment as it stands, with the contacts just made and lost.
                    report.residual = self.residual_at(step, &u)?;
                }
                return Ok((u, total));
            }
        }
    }

    /// After the sweeps stopped (`settled`): break overloaded bonds and drop contacts that
    /// opened (before then, what opens may close again). After any pass: rebuild the friends
    /// lists if something moved too far, and make the contacts that closed.
    fn update_topology(
        &mut self,
        step: &LoadStep,
        u: &[f64],
        settled: bool,
    ) -> Result<TopologyChange, NumericError> {
        // Responses where the sweeps left the grains.
        let mut eq = self.equations(step);
        eq.configure(u);
        eq.update_contacts()?;
        self.stats.timers.return_map += eq.timers.return_map;
        let start = Instant::now();
        let mut change = TopologyChange::default();
        let increment = self.state.increment + 1;
        // Contacts are lost below -chatter and made above +chatter: at rest, overlaps at the
        // round-off level would otherwise flip contacts on and off from pass to pass. A
        // linear contact kept in between carries at most k * chatter, a Hertz one nothing.
        let chatter = CHATTER * self.r_mean;
        let set = &mut *self.state.contacts;
        for c in set.contacts.iter_mut().filter(|_| settled) {
            if let Some(mode) = c.bond_failure() {
                self.energy.bonds_released += super::energy::bond_energy(self.law.as_ref(), c);
                c.bonded = false;
                c.broken = true;
                set.broken_bonds.push(BrokenBond {
                    pair: c.pair,
                    increment,
                    mode,
                });
                change.broken += 1;
            }
        }
        let before = set.contacts.len();
        let reopened = &mut self.reopened;
        set.contacts.retain(|c| {
            let kept = !settled || c.bonded || c.overlap >= -chatter;
            if !kept {
                if let Err(at) = reopened.binary_search(&c.pair) {
                    reopened.insert(at, c.pair);
                }
            }
            kept
        });
        change.lost = before - set.contacts.len();

        // Friends lists: rebuilt around the current positions once anything moved half the skin.
        let wall_position: Vec<f64> = (0..self.state.walls.len())
            .map(|w| {
                self.state.walls.walls[w].position
                    + match self.dofs.wall[w] {
                        Some(dof) => u[dof],
                        None => step.normal_move[w],
                    }
            })
            .collect();
        self.stats.timers.topology += secs(start);
        // After a step that stopped short of the lists' reach, or anything further.
        let reach = 0.5 * self.friends.skin * REACH_REBUILD;
        let wall_turn: Vec<f64> = (self.state.walls.walls.iter().zip(&step.turn))
            .map(|(w, t)| w.turn + t)
            .collect();
        if self
            .friends
            .drift(&self.q.position, &wall_position, &wall_turn)
            > reach
        {
            // Copies of grains and walls where they are now, made only for a rebuild.
            let mut current = self.state.grains.clone();
            current.position.clone_from(&self.q.position);
            let mut walls_now = self.state.walls.clone();
            for (w, wall) in walls_now.walls.iter_mut().enumerate() {
                wall.position = wall_position[w];
                wall.slide += step.slide[w];
                wall.turn = wall_turn[w];
            }
            self.rebuild_friends(&current, &walls_now)?;
        }
        let start = Instant::now();

        // Contacts made: friend pairs that now overlap.
        let mut merged = Vec::with_capacity(self.state.contacts.contacts.len());
        let mut existing = std::mem::take(&mut self.state.contacts.contacts)
            .into_iter()
            .peekable();
        for &pair in &self.friends.pairs {
            if existing.peek().is_some_and(|c| c.pair == pair) {
                merged.push(existing.next().expect("peeked"));
                continue;
            }
            let k = kinematics(pair, &self.state.grains, &self.state.walls, &self.q);
            if k.overlap > chatter {
                let params = self
                    .material
                    .params(pair, &self.state.grains, &self.state.walls);
                let mut c = Contact::new(pair, params, false);
                c.shear_offset = k.shear_increment;
                merged.push(c);
                change.made += 1;
            }
        }
        // Contacts outside the lists cannot happen (they are rebuilt before anything moves far
        // enough), but a bond stretched past the skin would be one: keep it all the same.
        merged.extend(existing);
        merged.sort_by_key(|c| c.pair);
        self.state.contacts.contacts = merged;
        self.index_pairs()?;
        // Membranes: on the grains that are outermost now.
        change.chains = self.refresh_chains(true)?;
        self.stats.counters.contacts_made += change.made;
        self.stats.counters.contacts_lost += change.lost;
        self.stats.counters.bonds_broken += change.broken;
        self.stats.timers.topology += secs(start);
        Ok(change)
    }

    /// Relative residual of the increment's equations at `u`.
    fn residual_at(&mut self, step: &LoadStep, u: &[f64]) -> Result<f64, NumericError> {
        let mut residual = vec![0.0; u.len()];
        let mut eq = self.equations(step);
        eq.evaluate_at(u, &mut residual, None)?;
        Ok(eq.residual_norm(&residual).0)
    }

    /// One pass of at most `sweeps` sweeps from `u`.
    fn relax(
        &mut self,
        step: &LoadStep,
        u: &mut [f64],
        sweeps: usize,
    ) -> Result<RelaxationOutcome, NumericError> {
        let settings = RelaxationSettings {
            tolerance: self.config.tolerance,
            sweeps,
            truncate: self.config.truncate,
        };
        let mut stats = self.stats;
        let mut blocks = GrainByGrain::new(self.equations(step));
        let result = relaxation::relax(&mut blocks, u, &settings, &mut stats);
        let timers = blocks.eq.timers;
        self.stats = stats;
        self.add_timers(timers);
        result
    }
}

/// The equations of an increment cut into blocks: each grain, then each stress-controlled
/// wall, with the contacts that touch it and the friend pairs that may close on it.
struct GrainByGrain<'a> {
    eq: IncrementEquations<'a>,
    /// Wall of each wall block (after the grain blocks).
    wall_of_block: Vec<usize>,
    /// Contacts touching each block.
    contacts_of: Vec<Vec<usize>>,
    /// Friend pairs of each block not in contact, watched for closing.
    apart_of: Vec<Vec<Pair>>,
    /// Membrane loads on every unknown, from where the grains were when the sweep began:
    /// a membrane's push on a grain follows its chain neighbours, so it is updated once a sweep.
    membrane_force: Vec<f64>,
}

impl<'a> GrainByGrain<'a> {
    fn new(eq: IncrementEquations<'a>) -> Self {
        let grains = eq.grains.len();
        let wall_of_block: Vec<usize> = (0..eq.walls.len())
            .filter(|&w| eq.dofs.wall[w].is_some())
            .collect();
        let mut block_of_wall = vec![None; eq.walls.len()];
        for (k, &w) in wall_of_block.iter().enumerate() {
            block_of_wall[w] = Some(grains + k);
        }
        let blocks = grains + wall_of_block.len();
        let sides = |pair: Pair| {
            let a = match pair.a {
                Side::Grain(a) => Some(a),
                Side::Wall(w) => block_of_wall[w],
            };
            [a, Some(pair.b)]
        };
        let mut contacts_of = vec![Vec::new(); blocks];
        for (idx, c) in eq.contacts.iter().enumerate() {
            for block in sides(c.pair).into_iter().flatten() {
                contacts_of[block].push(idx);
            }
        }
        let mut apart_of = vec![Vec::new(); blocks];
        let mut in_contact = eq.pair_index.iter().peekable();
        for (k, &pair) in eq.friends.pairs.iter().enumerate() {
            if in_contact.next_if(|&&p| p == k).is_some() {
                continue;
            }
            for block in sides(pair).into_iter().flatten() {
                apart_of[block].push(pair);
            }
        }
        let membrane_force = vec![0.0; eq.dofs.len];
        GrainByGrain {
            eq,
            wall_of_block,
            contacts_of,
            apart_of,
            membrane_force,
        }
    }

    /// The grain a block moves, or `None` for a wall block.
    fn grain(&self, block: usize) -> Option<usize> {
        (block < self.eq.grains.len()).then_some(block)
    }

    /// How far block `block` has moved from where the friends lists were made (m).
    fn moved(&self, block: usize) -> f64 {
        match self.grain(block) {
            Some(i) => {
                let (p, r) = (self.eq.q.position[i], self.eq.friends.reference[i]);
                (p[0] - r[0]).hypot(p[1] - r[1])
            }
            None => {
                let w = self.wall_of_block[block - self.eq.grains.len()];
                (self.eq.q.wall_position[w] - self.eq.friends.wall_reference[w][0]).abs()
            }
        }
    }
}

impl BlockEquations for GrainByGrain<'_> {
    fn evaluate(&mut self, u: &[f64], residual: &mut [f64]) -> Result<(), NumericError> {
        self.eq.evaluate_at(u, residual, None)
    }

    fn residual_norm(&self, residual: &[f64]) -> (f64, usize, f64) {
        self.eq.residual_norm(residual)
    }

    fn unit_stiffness(&self, dof: usize) -> f64 {
        self.eq.unit_stiffness(dof)
    }

    fn set_far(&mut self, far: bool) {
        self.eq.far = far;
    }

    fn blocks(&self) -> usize {
        self.contacts_of.len()
    }

    fn begin_sweep(&mut self, u: &[f64]) -> Result<(), NumericError> {
        self.eq.configure(u);
        if !self.eq.membranes.is_empty() {
            self.membrane_force.iter_mut().for_each(|f| *f = 0.0);
            self.eq.membrane_loads(&mut self.membrane_force, None);
        }
        Ok(())
    }

    fn block_system(&mut self, block: usize, system: &mut BlockSystem) -> Result<(), NumericError> {
        let start = Instant::now();
        let dofs = self.eq.dofs;
        match self.grain(block) {
            Some(i) => {
                system.reset(dofs.grain(i), dofs.per_grain);
                for k in 0..system.len {
                    system.residual[k] = self.membrane_force[dofs.grain(i) + k];
                }
                // The anchors' springs on this grain's move.
                for anchor in self.eq.anchors.iter().filter(|a| a.grain == i) {
                    let (d, x) = (anchor.direction, self.eq.q.displacement[i]);
                    let stretch = x[0] * d[0] + x[1] * d[1];
                    let k = self.eq.stiffness_hint;
                    for a in 0..2 {
                        system.residual[a] -= k * stretch * d[a];
                        for b in 0..2 {
                            system.stiffness[a][b] += k * d[a] * d[b];
                        }
                    }
                }
            }
            None => {
                // A stress-controlled wall: pushed by stress * length * depth.
                let w = self.wall_of_block[block - self.eq.grains.len()];
                let dof = dofs.wall[w].expect("a wall block has an unknown");
                let sigma = self.eq.step.stress[w];
                system.reset(dof, 1);
                system.residual[0] = sigma * self.eq.wall_length(w) * self.eq.depth;
                let wall = &self.eq.walls.walls[w];
                if let (None, Some(c)) = (wall.length, wall.circle) {
                    system.stiffness[0][0] -=
                        sigma * self.eq.depth * 2.0 * std::f64::consts::PI * c.sign();
                }
            }
        }
        let (own, len) = (system.dofs, system.len);
        let local = |dof: usize| (0..len).find(|&k| own[k] == dof);
        for &idx in &self.contacts_of[block] {
            let k = self.eq.respond(idx)?;
            self.eq.kin[idx] = k;
            let c = &self.eq.contacts[idx];
            let map = dofs.pair_map(c.pair, self.eq.push_direction(c.pair, idx));
            let mut contact = LocalBlock::default();
            let tangent = Some(self.eq.block_tangent());
            contact_block(&k, &c.response, &map, tangent, false, &mut contact);
            // A sliding contact carrying a shear force: its shear displacement along the
            // block's unknowns (the rows of B_t = [-t, -r_a, t, -r_b] that feed them).
            let slip = c.response.sliding && c.response.shear_force != 0.0;
            let bt = [
                -k.tangent[0],
                -k.tangent[1],
                -k.lever_a,
                k.tangent[0],
                k.tangent[1],
                -k.lever_b,
            ];
            let mut shear = [0.0; 3];
            for (entry, push) in bt.iter().enumerate() {
                for (slot, weight) in map.feeds_of(entry) {
                    if let Some(l) = local(map.dofs[slot]) {
                        shear[l] += weight * push;
                    }
                }
            }
            if slip {
                system.slips.push(Slip {
                    shear,
                    stiffness: self.eq.law.shear_stiffness(&c.params, c.overlap).0,
                    sense: c.response.shear_force.signum(),
                });
            }
            for a in 0..map.len {
                let Some(la) = local(map.dofs[a]) else {
                    continue;
                };
                system.residual[la] += contact.force[a];
                for b in 0..map.len {
                    if let Some(lb) = local(map.dofs[b]) {
                        system.stiffness[la][lb] += contact.stiffness[a][b];
                    }
                }
            }
        }
        self.eq.timers.assembly += secs(start);
        Ok(())
    }

    fn move_block(&mut self, block: usize, u: &[f64]) -> bool {
        match self.grain(block) {
            Some(i) => self.eq.configure_grain(i, u),
            None => {
                let w = self.wall_of_block[block - self.eq.grains.len()];
                self.eq.configure_wall(w, u);
            }
        }
        let chatter = CHATTER * self.eq.r_mean;
        let closed = self.apart_of[block].iter().any(|&pair| {
            kinematics(pair, self.eq.grains, self.eq.walls, self.eq.q).overlap > chatter
        });
        let stale = self.moved(block) > REACH_REBUILD * 0.5 * self.eq.friends.skin;
        closed || stale
    }

    fn step_length(&self, system: &BlockSystem, du: &[f64; 3]) -> f64 {
        let r = self.eq.r_mean;
        match system.len {
            1 => du[0].abs() / r,
            2 => du[0].hypot(du[1]) / r,
            _ => (du[0].hypot(du[1]) / r).max(du[2].abs()),
        }
    }

    fn reach_left(&self, block: usize) -> f64 {
        (REACH * 0.5 * self.eq.friends.skin - self.moved(block)) / self.eq.r_mean
    }
}
