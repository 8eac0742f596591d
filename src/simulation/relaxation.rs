//! The grain-by-grain strategy (the thesis's 'Grain') on the same equations as the global
//! solver: one block per grain (its 3x3 system of eq. 19, or 2x2 with fixed rotations) and
//! one per stress-controlled wall, built from the same contact laws and local contact blocks,
//! swept in index order by [`crate::solver::relaxation::relax`]. Contacts are made and lost
//! between passes by the same topology update as for Newton.

use super::equations::{IncrementEquations, CHATTER};
use super::newton_step::TopologyChange;
use super::{LoadStep, Simulation, REACH_REBUILD};
use crate::assembly::{contact_block, LocalBlock};
use crate::contact::kinematics;
use crate::geometry::{Pair, Side};
use crate::solver::newton::NewtonOutcome;
use crate::solver::relaxation::{self, BlockEquations, BlockSystem, RelaxationSettings, Slip};
use crate::solver::stats::secs;
use crate::solver::Equations;
use crate::state::IncrementReport;
use crate::NumericError;
use std::time::Instant;

/// Share of the half skin a grain may move from where the friends lists were made: past
/// [`REACH_REBUILD`], so the topology update then makes the lists anew.
const REACH: f64 = 0.9;

impl Simulation {
    /// One increment by relaxation: passes of sweeps until the residual meets the tolerance
    /// or the increment's `sweeps` (`n_i`) are spent. A pass stops where a gap closes (or a
    /// grain nears the edge of its friends lists), and the contact is made before the next;
    /// contacts are lost and bonds broken at the end, and if that changes the forces while
    /// sweeps are left, the sweeps go on. Then the increment is taken as it stands, as in the
    /// thesis: its residual is reported, never a failure.
    pub(super) fn relax_step(
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

    /// Relative residual of the increment's equations at `u`.
    fn residual_at(&mut self, step: &LoadStep, u: &[f64]) -> Result<f64, NumericError> {
        let mut residual = vec![0.0; u.len()];
        let mut eq = self.equations(step);
        eq.evaluate(u, &mut residual, None)?;
        Ok(eq.residual_norm(&residual).0)
    }

    /// One pass of at most `sweeps` sweeps from `u`.
    fn relax(
        &mut self,
        step: &LoadStep,
        u: &mut [f64],
        sweeps: usize,
    ) -> Result<NewtonOutcome, NumericError> {
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

impl Equations for GrainByGrain<'_> {
    fn evaluate(
        &mut self,
        u: &[f64],
        residual: &mut [f64],
        tangent: Option<&mut [f64]>,
    ) -> Result<(), NumericError> {
        self.eq.evaluate(u, residual, tangent)
    }
    fn residual_norm(&self, residual: &[f64]) -> (f64, usize, f64) {
        self.eq.residual_norm(residual)
    }
    fn step_norm(&self, du: &[f64]) -> f64 {
        self.eq.step_norm(du)
    }
    fn unit_stiffness(&self, dof: usize) -> f64 {
        self.eq.unit_stiffness(dof)
    }
    fn stiffness_hint(&self) -> f64 {
        self.eq.stiffness_hint()
    }
    fn set_far(&mut self, far: bool) {
        self.eq.set_far(far)
    }
    fn closing_fraction(&mut self, u: &[f64], du: &[f64]) -> f64 {
        self.eq.closing_fraction(u, du)
    }
    fn close_gaps(&mut self, u: &[f64]) -> Option<usize> {
        self.eq.close_gaps(u)
    }
}

impl BlockEquations for GrainByGrain<'_> {
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
                -k.radius_a,
                k.tangent[0],
                k.tangent[1],
                -k.radius_b,
            ];
            let mut shear = [0.0; 3];
            for (entry, feeds) in map.feeds.iter().enumerate() {
                for &(slot, weight) in feeds.iter().flatten() {
                    if let Some(l) = local(map.dofs[slot]) {
                        shear[l] += weight * bt[entry];
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
