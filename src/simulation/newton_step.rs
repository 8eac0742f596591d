//! One load increment by the Newton of topology passes (`strategy = "newton"`): Newton on a
//! fixed contact set, the topology updated between passes, halving the step where that
//! fails and settling by explicit dynamics after enough halvings.

use super::{energy, equations, LoadStep, Simulation, CHAIN_CHANGES, REACH_REBUILD};
use crate::contact::{kinematics, BrokenBond, Contact, ContactSet, SlipTangent};
use crate::solver::dynamic::{self, SettleSettings};
use crate::solver::newton::{self, NewtonOutcome, NewtonSettings, SystemMatrix};
use crate::solver::stats::secs;
use crate::solver::{LinearKind, LinearSolver, Strategy};
use crate::state::IncrementReport;
use crate::NumericError;
use std::sync::Arc;
use std::time::Instant;

/// Share of its starting residual a pass must end below, when it ran out of iterations, to
/// go on as another pass.
const PROGRESS: f64 = 0.5;

/// Bounds of the trust radius a Newton pass starts with, in mean radii.
const MAX_INITIAL_TRUST: f64 = 1e-2;
const MIN_INITIAL_TRUST: f64 = 1e-6;

/// Topology passes that stop for the friends lists to be made anew, allowed per pass that
/// ends on a solve.
const REACHES_PER_PASS: usize = 10;

/// What one topology pass changed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(super) struct TopologyChange {
    pub(super) made: usize,
    pub(super) lost: usize,
    pub(super) broken: usize,
    /// Contacts that opened in tension and were made again within the increment.
    pub(super) remade: usize,
    /// Membranes whose chain of grains changed.
    pub(super) chains: usize,
}

impl TopologyChange {
    pub(super) fn any(&self) -> bool {
        self.made + self.lost + self.broken + self.chains > 0
    }
}

impl Simulation {
    /// Solve a step and commit it; on failure restore the history and solve it as two halves,
    /// down to `max_cuts` halvings.
    pub(super) fn advance(
        &mut self,
        step: &LoadStep,
        depth: u32,
        report: &mut IncrementReport,
    ) -> Result<(), NumericError> {
        let backup = self.state.contacts.clone();
        let energy = self.energy;
        let mut result = self.solve_step(step, report, false);
        if result.is_err() && depth >= self.config.settle_after_cuts {
            // No equilibrium near the last one: settle, then solve again.
            self.state.contacts = backup.clone();
            self.energy = energy;
            self.restore_friends()?;
            report.settled += 1;
            result = self.solve_step(step, report, true);
        }
        match result {
            Ok((u, change)) => {
                report.negative_pivots = self.negative_pivots(step, &u);
                report.contacts_made += change.made;
                report.contacts_lost += change.lost;
                report.bonds_broken += change.broken;
                report.contacts_remade += change.remade;
                self.commit(step, &u);
                Ok(())
            }
            Err(mut err) => {
                self.state.contacts = backup;
                self.energy = energy;
                self.restore_friends()?;
                if depth >= self.config.max_cuts {
                    if let NumericError::NotConverged { cuts, .. } = &mut err {
                        *cuts = depth;
                    }
                    return Err(err);
                }
                report.cuts += 1;
                self.stats.counters.cuts += 1;
                let stress: Vec<f64> = self.state.walls.walls.iter().map(|w| w.stress).collect();
                let pressure: Vec<f64> = self.state.membranes.iter().map(|m| m.pressure).collect();
                let (first, second) = step.halves(&stress, &pressure);
                self.advance(&first, depth + 1, report)?;
                self.advance(&second, depth + 1, report)
            }
        }
    }

    /// Newton passes until the contact topology stops changing; when told to `settle`, after
    /// explicit damped dynamics has brought the grains near rest under the step's loads.
    ///
    /// With the symmetric tangent (Cholesky, elasto-plastic slip) a pass that runs out of
    /// iterations hands the rest of the increment to the consistent tangent (LU). The
    /// elasto-plastic tangent leaves out how a sliding contact's friction follows its normal
    /// force; where that is what holds a grain (one squeezed between two contacts it slides
    /// on, carrying next to nothing), Newton then converges only linearly, by a few percent
    /// per iteration (measured on the freed cylinder). The answer is the same either way.
    fn solve_step(
        &mut self,
        step: &LoadStep,
        report: &mut IncrementReport,
        settle: bool,
    ) -> Result<(Vec<f64>, TopologyChange), NumericError> {
        self.start_step();
        if self.config.strategy == Strategy::Relaxation {
            // Grain by grain, each block is solved with its neighbours held, so nothing need
            // hold the sample as a whole; an anchor would carry the load the sweeps have not
            // yet passed through the sample, out of sight of the residual.
            self.anchors.clear();
            return self.relax_step(step, report);
        }
        self.start_newton()?;
        let mut u = vec![0.0; self.dofs.len];
        let mut total = TopologyChange::default();
        if settle {
            // Passes of settling, each until rest or until the friends lists must be made
            // anew; contacts are made between them, lost ones are left to Newton.
            for _ in 0..REACHES_PER_PASS * self.config.max_topology_passes {
                let outcome = self.settle(step, &mut u)?;
                report.topology_passes += 1;
                self.stats.counters.topology_passes += 1;
                let change = self.update_topology(step, &u, false)?;
                total.made += change.made + outcome.contacts_made;
                self.stats.counters.contacts_made += outcome.contacts_made;
                if !outcome.at_reach {
                    break;
                }
            }
        }
        // Passes that end on a Newton solve count against the chatter cap; those that stop
        // for new friends lists are bounded by how far grains can travel.
        let (mut passes, mut reaches, mut chain_changes) = (0, 0, 0);
        while passes < self.config.max_topology_passes
            && reaches < REACHES_PER_PASS * self.config.max_topology_passes
        {
            let outcome = self.newton(step, &mut u)?;
            self.trust = Some(outcome.trust);
            report.newton_iterations += outcome.iterations;
            report.residual = outcome.residual;
            if outcome.iterations > 0 {
                self.last_residuals.clone_from(&outcome.history);
            }
            report.topology_passes += 1;
            self.stats.counters.topology_passes += 1;
            if outcome.at_reach {
                reaches += 1;
            } else {
                passes += 1;
            }
            // Contacts made and lost: after convergence, and also when Newton stalls or stops
            // for new lists, since a loaded grain that has lost its support cannot be in
            // equilibrium until it meets its next neighbour. Newton itself made those whose
            // gaps its steps closed.
            let change = self.update_topology(step, &u, outcome.converged)?;
            if outcome.converged && change.chains > 0 {
                chain_changes += 1;
                self.chains_held = chain_changes >= CHAIN_CHANGES;
            }
            self.stats.counters.contacts_made += outcome.contacts_made;
            total.made += change.made + outcome.contacts_made;
            total.lost += change.lost;
            total.broken += change.broken;
            // A pass that ran out of iterations while |R| still fell goes on as another; with
            // the symmetric tangent, the next one has the consistent tangent.
            let switched = !outcome.converged
                && !outcome.at_reach
                && outcome.iterations >= self.config.max_iterations
                && self.switch_to_consistent();
            let progressing = switched
                || outcome
                    .history
                    .first()
                    .is_some_and(|&r0| outcome.residual < PROGRESS * r0);
            match (outcome.converged, change.any()) {
                (true, false) => {
                    total.remade = self.remade.len();
                    return Ok((u, total));
                }
                (false, false)
                    if !progressing && outcome.contacts_made == 0 && !outcome.at_reach =>
                {
                    return Err(NumericError::NotConverged {
                        increment: self.state.increment + 1,
                        residual: outcome.residual,
                        worst_grain: outcome.worst_grain,
                        cuts: 0,
                    })
                }
                _ => {}
            }
        }
        // The contact set keeps flipping between passes (chatter): cut the increment.
        Err(NumericError::NotConverged {
            increment: self.state.increment + 1,
            residual: report.residual,
            worst_grain: 0,
            cuts: 0,
        })
    }

    /// Solve the rest of the increment with the consistent tangent, if the scene's solver is
    /// the symmetric one and has not switched yet. Returns whether it switched.
    fn switch_to_consistent(&mut self) -> bool {
        if self.consistent || self.config.linear != LinearKind::Cholesky {
            return false;
        }
        self.consistent = true;
        if let Some(lu) = &mut self.lu {
            lu.invalidate();
        }
        true
    }

    fn newton(
        &mut self,
        step: &LoadStep,
        u: &mut [f64],
    ) -> Result<newton::NewtonOutcome, NumericError> {
        let settings = NewtonSettings {
            tolerance: self.config.tolerance,
            displacement_tolerance: self.config.displacement_tolerance,
            max_iterations: self.config.max_iterations,
            line_search: self.config.line_search,
            lambda_min: self.config.lambda_min,
            reuse_factorisation: self.material.is_linear(),
            max_step: 0.5 * self.config.skin,
            initial_trust: self.trust.unwrap_or_else(|| self.initial_trust()),
        };
        // The pattern is shared, not copied: the equations read its slots while the matrix
        // is factorised in it.
        let pattern = Arc::clone(&self.pattern);
        let mut values = std::mem::take(&mut self.values);
        let mut stats = self.stats;
        // The scene's solver, or the LU one of the consistent tangent (analysed when first
        // needed on this pattern).
        let lu = self.consistent && self.config.linear != LinearKind::Lu;
        if lu && self.lu.is_none() {
            let mut solver = LinearSolver::new(LinearKind::Lu);
            solver
                .analyse(&pattern.symbolic, &mut stats)
                .map_err(|e| NumericError::Singular { detail: e.0 })?;
            self.lu = Some(solver);
        }
        let mut linear = match (lu, self.lu.take()) {
            (true, Some(solver)) => solver,
            (_, kept) => {
                self.lu = kept;
                std::mem::replace(&mut self.linear, LinearSolver::new(self.config.linear))
            }
        };
        let mut eq = self.equations(step);
        let result = newton::solve(
            &mut eq,
            SystemMatrix {
                symbolic: &pattern.symbolic,
                values: &mut values,
                diagonal: &pattern.diagonal,
            },
            &mut linear,
            u,
            &settings,
            &mut stats,
        );
        let timers = eq.timers;
        self.take_back(stats, timers, values);
        if linear.kind() == self.config.linear {
            self.linear = linear;
        } else {
            self.lu = Some(linear);
        }
        result
    }

    /// Explicit damped dynamics on the step's equations from `u` (see [`crate::solver::dynamic`]).
    fn settle(&mut self, step: &LoadStep, u: &mut [f64]) -> Result<NewtonOutcome, NumericError> {
        let settings = SettleSettings {
            tolerance: self.config.settle_tolerance,
            steps: self.config.settle_steps,
            max_step: 0.05 * self.config.skin,
        };
        let pattern = Arc::clone(&self.pattern);
        let mut values = std::mem::take(&mut self.values);
        let mut stats = self.stats;
        let mut eq = self.equations(step);
        eq.unilateral = true;
        eq.slip_tangent = SlipTangent::Elastic;
        let result = dynamic::settle(
            &mut eq,
            SystemMatrix {
                symbolic: &pattern.symbolic,
                values: &mut values,
                diagonal: &pattern.diagonal,
            },
            u,
            &settings,
            &mut stats,
        );
        let timers = eq.timers;
        self.take_back(stats, timers, values);
        result
    }

    /// The trust radius the first Newton pass of an increment starts with, in mean radii: the
    /// mean overlap of the contacts, so that a first step changes no contact force by much
    /// more than the mean force, however stiff the material (at most 1e-2, at least 1e-6).
    /// Later passes go on with the radius the last one ended with.
    fn initial_trust(&self) -> f64 {
        ContactSet::mean_overlap(&self.state.contacts.contacts).map_or(MAX_INITIAL_TRUST, |d| {
            (d / self.r_mean).clamp(MIN_INITIAL_TRUST, MAX_INITIAL_TRUST)
        })
    }

    /// After Newton converged: break overloaded bonds, drop contacts that opened, rebuild the
    /// friends lists if something moved too far, and make the contacts that closed. After a
    /// stalled pass only contacts are made: what opens at an iterate that is not an
    /// equilibrium may close again.
    pub(super) fn update_topology(
        &mut self,
        step: &LoadStep,
        u: &[f64],
        converged: bool,
    ) -> Result<TopologyChange, NumericError> {
        // Responses at the converged iterate (a rejected line-search trial may be in place).
        let mut eq = self.equations(step);
        eq.configure(u);
        eq.update_contacts()?;
        self.stats.timers.return_map += eq.timers.return_map;
        let start = Instant::now();
        // Contacts Newton made again where its steps closed their gaps.
        self.note_remade();
        let mut change = TopologyChange::default();
        let increment = self.state.increment + 1;
        // Contacts are lost below -chatter and made above +chatter: at rest, overlaps at the
        // round-off level would otherwise flip contacts on and off from pass to pass. A
        // linear contact kept in between carries at most k * chatter, a Hertz one nothing.
        let chatter = equations::CHATTER * self.r_mean;
        let set = &mut self.state.contacts;
        for c in set.contacts.iter_mut().filter(|_| converged) {
            if let Some(mode) = c.bond_failure() {
                self.energy.bonds_released += energy::bond_energy(self.law.as_ref(), c);
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
            let kept = !converged || c.bonded || c.overlap >= -chatter;
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
        self.note_remade();
        self.index_pairs()?;
        // Membranes: on the grains that are outermost now.
        if !self.chains_held {
            change.chains = self.refresh_chains(true)?;
        }
        self.stats.counters.contacts_made += change.made;
        self.stats.counters.contacts_lost += change.lost;
        self.stats.counters.bonds_broken += change.broken;
        self.stats.timers.topology += secs(start);
        Ok(change)
    }

    /// Note the contacts in the set that opened in tension earlier in the increment.
    fn note_remade(&mut self) {
        for c in &self.state.contacts.contacts {
            if self.reopened.binary_search(&c.pair).is_ok() {
                if let Err(at) = self.remade.binary_search(&c.pair) {
                    self.remade.insert(at, c.pair);
                }
            }
        }
    }
}
