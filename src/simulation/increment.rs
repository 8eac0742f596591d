//! One load increment by the global solver (method note, "One load increment"): every
//! friends-list pair engaged as a contact, the incremental potential minimised from the
//! predictor (or from the committed state where that is nearer equilibrium), the friends
//! lists made anew wherever a step reaches their edge, bonds broken one at a time with the
//! grains settled anew after each, then the commit.

use super::bonds::{bracketing_cuts, first_crossing};
use super::{anchors, EnergyBalance, LoadStep, Simulation, CHAIN_CHANGES};
use crate::contact::{ContactSet, Lag};
use crate::solver::minimise::{self, MinimiseSettings, Potential, SystemMatrix};
use crate::state::{IncrementReport, KeptState, PeakState, Shared};
use crate::NumericError;
use std::sync::Arc;

/// Passes of one minimisation that stop at the edge of the friends lists, at most. A grain
/// that keeps going is caught long before by the runaway test (a diameter is a few passes).
const MAX_PASSES: usize = 200;

/// Share of the load within which a limit load is bracketed (method note, step 4): a step
/// that finds no equilibrium near is halved until it changes the load by at most this much.
pub(super) const BRACKET: f64 = 0.005;

/// Halvings of one increment, at most, in bracketing a limit load. A limit load of zero (a
/// grain with nothing to hold it) is never bracketed as a share of the load: it is reported
/// with the share its last step changed the load by.
const BRACKET_CUTS: u32 = 16;

/// Most of the sample's grains the clusters that break out in one increment may hold: more
/// is the sample failing as a whole.
pub(super) const BREAKOUT_SHARE: f64 = 0.1;

/// Share of its radius a grain moved in a descent that found no equilibrium near by which it
/// counts as carried with the grains that ran away.
const MECHANISM_MOVE: f64 = 1.0;

/// Which part of its increment a (sub-)step is: where it starts and how much of the
/// increment it is, both as shares of the increment.
#[derive(Debug, Clone, Copy)]
struct Part {
    from: f64,
    share: f64,
    /// Halvings that made it.
    depth: u32,
    /// Of those, halvings of a step whose minimisation did not converge.
    stalls: u32,
}

/// What solving a (sub-)step found, short of an error.
enum Solved {
    /// Its equilibrium, with the bonds broken in it, committed.
    Committed,
    /// Its first equilibrium has a bond past its strength, and the step is wider than
    /// [`BRACKET`]: not committed, so that its parts find the load at which the bond
    /// breaks. `crossing` is the share of the step at which the first bond reaches its
    /// strength, interpolated linearly between the step's start and its end.
    BondPastStrength { crossing: f64 },
}

impl Simulation {
    /// Solve the increment and commit it. Where its minimisation does not reach equilibrium,
    /// the increment is not trusted as one step: its load path is followed in halves. A
    /// step's equilibrium is near the last one only for a small enough step, and the halves
    /// follow the path the load takes, which decides between the equilibria a large step
    /// can jump to (a grain wedged between two that close on it sticks from first touch).
    /// A stall is halved down to `max_cuts` times, and if it still stalls the increment is
    /// left unsolved. No equilibrium near is halved until the step changes the load by at
    /// most [`BRACKET`], which brackets the limit load: the halves commit as they converge, so
    /// the state is left at the highest load found in equilibrium. A step whose equilibrium
    /// has a bond past its strength is cut where a linear prediction puts the bond at its
    /// strength ([`bracketing_cuts`]), so the bond breaks within [`BRACKET`] of the load that
    /// breaks it, most often in two parts rather than the halvings of a bisection. `start`
    /// is the state the increment started from.
    pub(super) fn minimise_step(
        &mut self,
        step: &LoadStep,
        start: &KeptState,
        report: &mut IncrementReport,
    ) -> Result<(), NumericError> {
        let whole = Part {
            from: 0.0,
            share: 1.0,
            depth: 0,
            stalls: 0,
        };
        let result = self.follow_path(step, whole, start, report);
        if let Err(NumericError::NotConverged { .. }) = result {
            // The solver gave up: the increment is not solved, whatever halves converged.
            self.state = start.state();
            self.rebuild_workspace()?;
        }
        result
    }

    /// Solve `step`, part `part` of the increment; halve it where it does not converge or finds
    /// no equilibrium near, and cut it at the predicted break where it breaks a bond, while
    /// wider than [`BRACKET`] (see [`Simulation::minimise_step`]).
    fn follow_path(
        &mut self,
        step: &LoadStep,
        part: Part,
        start: &KeptState,
        report: &mut IncrementReport,
    ) -> Result<(), NumericError> {
        let load_change = self.load_change(step, part);
        let wide = part.depth < BRACKET_CUTS && load_change > BRACKET;
        let mut error = match self.solve_part(step, part.share, wide, start, report) {
            Ok(Solved::Committed) => return Ok(()),
            Ok(Solved::BondPastStrength { crossing }) => {
                let cuts = bracketing_cuts(crossing, BRACKET / load_change);
                return self.follow_parts(step, part, &cuts, false, start, report);
            }
            Err(e) => e,
        };
        let halve = match error {
            NumericError::NotConverged { .. } => part.stalls < self.config.max_cuts,
            NumericError::NoEquilibrium { .. } => wide,
            _ => false,
        };
        if !halve {
            match &mut error {
                NumericError::NotConverged { cuts, .. } => *cuts = part.depth,
                NumericError::NoEquilibrium {
                    load_change: at, ..
                }
                | NumericError::BrokeOut {
                    load_change: at, ..
                } => *at = load_change,
                _ => {}
            }
            return Err(error);
        }
        let stalled = matches!(error, NumericError::NotConverged { .. });
        self.follow_parts(step, part, &[0.5], stalled, start, report)
    }

    /// Follow `step`, part `part` of the increment, in parts that end at the shares `cuts` of
    /// it (increasing, between 0 and 1) and at its end; `stalled` when it is cut because its
    /// minimisation did not converge.
    fn follow_parts(
        &mut self,
        step: &LoadStep,
        part: Part,
        cuts: &[f64],
        stalled: bool,
        start: &KeptState,
        report: &mut IncrementReport,
    ) -> Result<(), NumericError> {
        report.cuts += 1;
        self.stats.counters.cuts += 1;
        let (mut stress, mut pressure) = self.held_loads();
        let (mut rest, mut from) = (step.clone(), 0.0);
        let piece = |from: f64, to: f64| Part {
            from: part.from + from * part.share,
            share: (to - from) * part.share,
            depth: part.depth + 1,
            stalls: part.stalls + u32::from(stalled),
        };
        for &cut in cuts {
            let (first, after) = rest.split((cut - from) / (1.0 - from), &stress, &pressure);
            self.follow_path(&first, piece(from, cut), start, report)?;
            (stress, pressure) = (first.stress, first.pressure);
            (rest, from) = (after, cut);
        }
        self.follow_path(&rest, piece(from, 1.0), start, report)
    }

    /// Each grain's displacement in the last descent, from the state it started at: after an
    /// error of no equilibrium near, how the descent carried the mechanism away from the
    /// highest load found in equilibrium.
    pub fn descent(&self) -> Vec<[f64; 2]> {
        self.q.displacement.clone()
    }

    /// Whether `cluster`, which no equilibrium near holds, breaks out of the sample in a stage
    /// that takes breakouts out: with the clusters already broken out in this increment, at
    /// most [`BREAKOUT_SHARE`] of the grains the sample had at its start. More is the sample
    /// failing as a whole, in one piece or in many.
    pub(super) fn breaks_out(&self, cluster: &[usize]) -> bool {
        let increment = self.state.increment + 1;
        let broken_out: usize = (self.state.breakouts.iter())
            .filter(|b| b.increment == increment)
            .map(|b| b.grains.len())
            .sum();
        let at_start = self.state.grains.in_sample().count() + broken_out;
        self.stages[self.state.stage].breakouts
            && !cluster.is_empty()
            && (cluster.len() + broken_out) as f64 <= BREAKOUT_SHARE * at_start as f64
    }

    /// The grains the descent that found no equilibrium near carries with `runaway`: those
    /// moved by more than [`MECHANISM_MOVE`] of their radius in it, joined to a runaway grain
    /// through contacts that touch or are bonded where it stopped. In increasing order.
    fn mechanism(&self, runaway: &[usize]) -> Vec<usize> {
        let grains = &self.state.grains;
        let moved = |g: usize| {
            let d = self.q.displacement[g];
            d[0].hypot(d[1]) > MECHANISM_MOVE * grains.radius[g]
        };
        let mut neighbours = vec![Vec::new(); grains.len()];
        for c in (self.state.contacts.contacts.iter()).filter(|c| c.bonded || c.overlap > 0.0) {
            if let crate::geometry::Side::Grain(a) = c.pair.a {
                neighbours[a].push(c.pair.b);
                neighbours[c.pair.b].push(a);
            }
        }
        let mut inside = vec![false; grains.len()];
        let mut queue: Vec<usize> = runaway.to_vec();
        for &g in runaway {
            inside[g] = true;
        }
        while let Some(g) = queue.pop() {
            for &h in &neighbours[g] {
                if !inside[h] && moved(h) {
                    inside[h] = true;
                    queue.push(h);
                }
            }
        }
        (0..grains.len()).filter(|&g| inside[g]).collect()
    }

    /// How much `step`, part `part` of the increment, changes the load, as a share of the
    /// load at its end: the largest over the stresses and pressures it changes and over the
    /// walls the stage moves (their move over the stage so far).
    fn load_change(&self, step: &LoadStep, part: Part) -> f64 {
        let stage = &self.stages[self.state.stage];
        let done =
            (self.state.stage_increment as f64 + part.from + part.share) / stage.increments as f64;
        let share = |change: f64, level: f64| {
            if change == 0.0 {
                0.0
            } else {
                (change / level).abs()
            }
        };
        let walls = self.state.walls.walls.iter().enumerate();
        let stresses = walls.map(|(w, wall)| {
            share(step.stress[w] - wall.stress, step.stress[w])
                .max(share(step.normal_move[w], done * stage.normal_move[w]))
                .max(share(step.slide[w], done * stage.slide[w]))
        });
        let pressures = (self.state.membranes.iter().zip(&step.pressure))
            .map(|(m, &p)| share(p - m.pressure, p));
        stresses.chain(pressures).fold(0.0, f64::max)
    }

    /// Keep the committed state as the increment's peak if its macro deviator is the highest
    /// found in the increment so far.
    fn keep_if_peak(&mut self) {
        let here = PeakState::of(&self.state.walls, &self.measure());
        if self
            .peak_within
            .as_ref()
            .is_none_or(|p| here.deviator() > p.deviator())
        {
            self.peak_within = Some(here);
        }
    }

    /// Minimise the potential of `step`, `share` of the increment, break overloaded bonds one
    /// at a time, and commit. On failure the committed state is left as it was: the contacts
    /// of the increment's `start` where the part starts from them, else its own.
    fn solve_part(
        &mut self,
        step: &LoadStep,
        share: f64,
        wide: bool,
        start: &KeptState,
        report: &mut IncrementReport,
    ) -> Result<Solved, NumericError> {
        let own;
        let committed = if start.contacts().holds(&self.state.contacts) {
            start.contacts()
        } else {
            own = self.state.contacts.committed();
            &own
        };
        let energy = self.energy;
        let (taken_out, breakouts) = (
            self.state.grains.taken_out.clone(),
            self.state.breakouts.len(),
        );
        let result = self.solve_with_breaks(step, share, wide, report);
        match result {
            Ok(None) => {
                let restored = committed.restore();
                let crossing = first_crossing(&restored, &self.state.contacts);
                self.state.contacts = restored.into();
                self.energy = energy;
                self.restore_friends()?;
                Ok(Solved::BondPastStrength { crossing })
            }
            Ok(Some(u)) => {
                report.negative_pivots = self.negative_pivots(step, &u);
                let contacts = &mut self.state.contacts.contacts;
                contacts.retain(|c| c.bonded || c.overlap > 0.0);
                let before = &committed.contacts;
                let made = contacts
                    .iter()
                    .filter(|c| before.binary_search_by(|d| d.pair.cmp(&c.pair)).is_err())
                    .count();
                let kept = contacts.len() - made;
                report.contacts_made += made;
                report.contacts_lost += before.len() - kept;
                self.stats.counters.contacts_made += made;
                self.stats.counters.contacts_lost += before.len() - kept;
                self.commit(step, &u);
                self.index_pairs()?;
                // The predictor is kept per whole increment: a half step predicts half of it.
                self.state.last_step = u.iter().map(|v| v / share).collect();
                self.take_out_detached(report)?;
                if share < 1.0 {
                    self.keep_if_peak();
                }
                Ok(Solved::Committed)
            }
            Err(e) => {
                // The clusters that broke out in the step stay out: their breakouts are
                // established at its load, whatever else the step could not solve.
                let clusters: Vec<Vec<usize>> = (self.state.breakouts.drain(breakouts..))
                    .map(|b| b.grains)
                    .collect();
                self.state.grains.taken_out = taken_out;
                self.state.contacts = committed.restore().into();
                self.energy = energy;
                if clusters.is_empty() {
                    self.restore_friends()?;
                } else {
                    for cluster in &clusters {
                        self.remove_cluster(cluster);
                    }
                    self.rebuild_workspace()?;
                }
                Err(e)
            }
        }
    }

    /// The step's equilibrium from the predictor, then, while a bond is past its strength,
    /// the most overloaded one broken and the equilibrium found anew from there: a cascade
    /// at the step's load. Where the solver gives up on the cascade after it has taken a
    /// wall's force below its [`Simulation::drop_floor`] (the stage's `failure_drop`), the
    /// first equilibrium that did is the step's, bonds past their strength and all: the
    /// brittle failure is established there, and the rubble the cascade goes on to leave
    /// need not be solved for. Nothing (and nothing broken) where the step is `wide` and its
    /// first equilibrium has a bond past its strength: the bond is broken at the load that
    /// breaks it, found within [`BRACKET`], not at the end of a step past it, so that
    /// failure loads do not depend on the increment size (method note, step 5).
    fn solve_with_breaks(
        &mut self,
        step: &LoadStep,
        share: f64,
        wide: bool,
        report: &mut IncrementReport,
    ) -> Result<Option<Vec<f64>>, NumericError> {
        self.start_step();
        self.start_newton()?;
        self.engage_pairs();
        let result = self.solve_engaged(step, share, wide, report);
        self.loose.clear();
        result
    }

    /// [`Simulation::solve_with_breaks`] once the pairs are engaged: each minimisation with
    /// the grains that touch nothing where it starts left out as loose (see [`super::loose`]).
    fn solve_engaged(
        &mut self,
        step: &LoadStep,
        share: f64,
        wide: bool,
        report: &mut IncrementReport,
    ) -> Result<Option<Vec<f64>>, NumericError> {
        self.loose = self.find_loose();
        let mut u = self.start_point(step, share)?;
        // Where a minimisation that a cluster broke out of starts again: the step's start,
        // then its last equilibrium.
        let mut restart = u.clone();
        // The cascade's first equilibrium that dropped the load, kept while the cascade goes
        // on: where it cannot be followed to its end, the failure stands there.
        let mut dropped: Option<Dropped> = None;
        self.minimise_breaking_out(step, &mut u, &mut restart, wide, &mut dropped, report)?;
        if wide
            && self
                .state
                .contacts
                .contacts
                .iter()
                .any(|c| c.bond_overload().is_some())
        {
            return Ok(None);
        }
        while self.break_most_overloaded_bond() {
            report.bonds_broken += 1;
            restart.copy_from_slice(&u);
            self.loose = self.find_loose();
            let result =
                self.minimise_breaking_out(step, &mut u, &mut restart, wide, &mut dropped, report);
            match (result, dropped.take()) {
                (Ok(()), kept) => dropped = kept,
                (Err(NumericError::NotConverged { .. }), Some(d)) => {
                    (self.state.contacts, self.energy) = (d.contacts, d.energy);
                    (report.bonds_broken, report.residual) = (d.bonds_broken, d.residual);
                    self.last_residuals = d.residuals;
                    self.renew_lists(step, &d.u)?;
                    return Ok(Some(d.u));
                }
                (Err(e), _) => return Err(e),
            }
            if dropped.is_none() && self.load_dropped(step, &u) {
                dropped = Some(Dropped {
                    u: u.clone(),
                    contacts: self.state.contacts.clone(),
                    energy: self.energy,
                    bonds_broken: report.bonds_broken,
                    residual: report.residual,
                    residuals: self.last_residuals.clone(),
                });
            }
        }
        Ok(Some(u))
    }

    /// Minimise from `u` to equilibrium. Where no equilibrium near holds a cluster that breaks
    /// out of the sample (thesis 4.4.2) in a step that is not `wide` (its load bracketed), the
    /// cluster is taken out where it broke out and the minimisation starts again from
    /// `restart`, the step's last equilibrium or its start, with the bonds broken so far left
    /// broken: the breakout is one event of the step, and the step goes on past it; in a
    /// stage that ends at its first breakout, the step ends there instead. A
    /// cascade's equilibrium kept in `dropped` had the cluster in it, and goes.
    fn minimise_breaking_out(
        &mut self,
        step: &LoadStep,
        u: &mut [f64],
        restart: &mut [f64],
        wide: bool,
        dropped: &mut Option<Dropped>,
        report: &mut IncrementReport,
    ) -> Result<(), NumericError> {
        loop {
            match self.minimise(step, u, report) {
                Err(NumericError::NoEquilibrium { grains, .. })
                    if !wide && self.breaks_out(&grains) =>
                {
                    let breakout = self.remove_cluster(&grains);
                    report.bonds_broken += breakout.bonds_broken;
                    if self.stages[self.state.stage].until_breakout && !breakout.debris {
                        return Err(NumericError::BrokeOut {
                            increment: self.state.increment + 1,
                            grains: breakout.grains,
                            load_change: 0.0,
                        });
                    }
                    *dropped = None;
                    let per = self.dofs.per_grain;
                    for &g in &breakout.grains {
                        restart[g * per..(g + 1) * per].fill(0.0);
                        self.carriers[g] = false;
                    }
                    u.copy_from_slice(restart);
                    self.loose.clear();
                    self.dofs = super::dof_map(&self.state, self.material.fixed_rotations);
                    let grains = &self.state.grains;
                    if self.anchors.iter().any(|a| grains.taken_out[a.grain]) {
                        self.anchors =
                            anchors(grains, &self.state.walls, &self.state.contacts.contacts);
                    }
                    self.renew_lists(step, u)?;
                }
                result => return result,
            }
        }
    }

    /// Whether the equilibrium at `u` takes a wall's force below its [`Simulation::drop_floor`].
    fn load_dropped(&mut self, step: &LoadStep, u: &[f64]) -> bool {
        if self.drop_floor.iter().all(|&floor| floor <= 0.0) {
            return false;
        }
        // Measured as it would be committed, then put back.
        let (state, energy, q) = (self.state.clone(), self.energy, self.q.clone());
        self.commit(step, u);
        let force = self.measure().wall_normal_force;
        (self.state, self.energy, self.q) = (state, energy, q);
        force
            .iter()
            .zip(&self.drop_floor)
            .any(|(f, floor)| f < floor)
    }

    /// Where the minimisation starts, with the friends lists reaching it: the predictor where
    /// it is nearer equilibrium than the committed state, else the committed state. The last
    /// increment's displacements extrapolate its smooth part well, but a grain that snapped
    /// through in it would be thrown on by as much again, into its neighbours.
    pub(super) fn start_point(
        &mut self,
        step: &LoadStep,
        share: f64,
    ) -> Result<Vec<f64>, NumericError> {
        let mut start = self.predictor(share);
        let at_rest = vec![0.0; start.len()];
        if start != at_rest {
            // The committed state first, while the lists are still made around it.
            let rest_merit = self.merit_at(step, &at_rest)?;
            self.renew_lists_if_far(step, &start)?;
            if self.merit_at(step, &start)? > rest_merit {
                start = at_rest;
            }
        }
        self.renew_lists_if_far(step, &start)?;
        self.fresh_lag();
        Ok(start)
    }

    /// `|R|_2 / F_ref` at `u`, the lag taken there.
    fn merit_at(&mut self, step: &LoadStep, u: &[f64]) -> Result<f64, NumericError> {
        self.fresh_lag();
        let mut residual = vec![0.0; u.len()];
        let mut eq = self.equations(step);
        eq.evaluate(u, &mut residual, None, true)?;
        let merit = eq.residual_norm(&residual).2;
        let timers = eq.timers;
        self.add_timers(timers);
        Ok(merit)
    }

    /// The lag starts afresh in every increment, as it does in a resumed run.
    pub(super) fn fresh_lag(&mut self) {
        for c in &mut self.state.contacts.contacts {
            c.lag = Lag::default();
        }
    }

    /// The last increment's displacements, `share` of them for a step that is that share of
    /// an increment, when it was a step of the same stage on the same unknowns (the step is
    /// the same), else nothing moved.
    fn predictor(&self, share: f64) -> Vec<f64> {
        let last = &self.state.last_step;
        if self.state.stage_increment > 0 && last.len() == self.dofs.len {
            last.iter().map(|v| v * share).collect()
        } else {
            vec![0.0; self.dofs.len]
        }
    }

    /// Minimise from `u` to equilibrium, making the friends lists (or the pattern of the
    /// membranes' chains) anew each time a step reaches their edge.
    fn minimise(
        &mut self,
        step: &LoadStep,
        u: &mut [f64],
        report: &mut IncrementReport,
    ) -> Result<(), NumericError> {
        let start_factor = minimise::start_factor(self.state.grains.len());
        let mut settings = MinimiseSettings {
            tolerance: self.config.tolerance,
            lambda_min: self.config.lambda_min,
            max_iterations: self.config.max_iterations,
            lambda_start: start_factor,
        };
        // Chain changes are counted over the passes: a chain that flips between two grains
        // makes a pattern that couples one and not the other, and would end every pass.
        let (mut chain_changes, mut worst_grain) = (0, 0);
        for _ in 0..MAX_PASSES {
            let pattern = Arc::clone(&self.pattern);
            let mut values = std::mem::take(&mut self.values);
            let mut stats = self.stats;
            let mut linear = std::mem::take(&mut self.linear);
            let mut work = std::mem::take(&mut self.minimise_work);
            let mut eq = self.equations(step);
            eq.chain_changes = chain_changes;
            eq.chains_held = chain_changes >= CHAIN_CHANGES;
            let result = minimise::minimise(
                &mut eq,
                SystemMatrix {
                    symbolic: &pattern.symbolic,
                    values: &mut values,
                    diagonal: &pattern.diagonal,
                },
                &mut linear,
                u,
                &settings,
                &mut work,
                &mut stats,
            );
            let timers = eq.timers;
            chain_changes = eq.chain_changes;
            self.take_back(stats, timers, values);
            self.linear = linear;
            self.minimise_work = work;
            let outcome = result?;
            settings.lambda_start = if outcome.at_reach {
                outcome.lambda
            } else {
                start_factor
            };
            report.newton_iterations += outcome.iterations;
            report.residual = outcome.residual;
            worst_grain = outcome.worst_grain;
            report.topology_passes += 1;
            self.stats.counters.topology_passes += 1;
            self.last_residuals.clone_from(&outcome.history);
            if outcome.converged && self.loose.contains(&true) {
                // The grains that carry load are in equilibrium: the loose ones are placed
                // among them where they are now, and the next pass confirms it with them
                // taken in, or goes on with those that could not be placed so.
                let failed = self.equations(step).place_loose(u);
                if failed.is_empty() {
                    self.loose.clear();
                }
                self.renew_lists_if_far(step, u)?;
                continue;
            }
            if outcome.converged {
                return Ok(());
            }
            if outcome.changed {
                continue;
            }
            if !outcome.runaway.is_empty() {
                return Err(NumericError::NoEquilibrium {
                    increment: self.state.increment + 1,
                    residual: outcome.residual,
                    grains: self.mechanism(&outcome.runaway),
                    load_change: 0.0,
                });
            }
            if !outcome.at_reach {
                return Err(NumericError::NotConverged {
                    increment: self.state.increment + 1,
                    residual: outcome.residual,
                    worst_grain: outcome.worst_grain,
                    cuts: 0,
                });
            }
            self.renew_lists(step, u)?;
        }
        Err(NumericError::NotConverged {
            increment: self.state.increment + 1,
            residual: report.residual,
            worst_grain,
            cuts: 0,
        })
    }
}

/// A cascade's equilibrium that dropped the load (see [`Simulation::drop_floor`]): the
/// displacements, the contacts and the energy spent there, the bonds broken by then, and
/// the residual the minimisation reached there with its history.
struct Dropped {
    u: Vec<f64>,
    contacts: Shared<ContactSet>,
    energy: EnergyBalance,
    bonds_broken: usize,
    residual: f64,
    residuals: Vec<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::samples;
    use crate::scene::build_grains;
    use crate::solver::{Potential, SolverConfig, Strategy};
    use rand::{Rng, SeedableRng};
    use std::path::Path;

    /// The minimisation's potential against its residual: along a random direction `v` from
    /// a random `u` (lag held), the central difference of the contacts' energy less the
    /// loads' work is `-R . v`, to within the rotation of the contact frames over the step.
    #[test]
    fn residual_is_the_gradient_of_the_potential() {
        let scene = samples::hertz_patch(6, 5, 1, 0.3, 0.1, 0);
        let grains = build_grains(&scene.grains, Path::new("."), "t").unwrap();
        let config = SolverConfig {
            strategy: Strategy::Minimise,
            ..SolverConfig::default()
        };
        let mut sim = Simulation::new(&scene, grains, config, "t").unwrap();
        let step = sim.next_load_step();
        sim.start_step();
        sim.start_newton().unwrap();
        sim.engage_pairs();
        let (n, r) = (sim.dofs.len, sim.r_mean);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let scale = |k: usize| {
            if k < 3 * sim.state.grains.len() && k % 3 == 2 {
                1.0
            } else {
                r
            }
        };
        let u: Vec<f64> = (0..n)
            .map(|k| 2e-4 * scale(k) * (rng.random::<f64>() - 0.5))
            .collect();
        let v: Vec<f64> = (0..n)
            .map(|k| scale(k) * (rng.random::<f64>() - 0.5))
            .collect();
        let mut eq = sim.equations(&step);
        let mut residual = vec![0.0; n];
        eq.evaluate(&u, &mut residual, None, true).unwrap();
        let slope: f64 = -residual.iter().zip(&v).map(|(a, b)| a * b).sum::<f64>();
        let h = 1e-6;
        let mut at = |sign: f64| {
            let w: Vec<f64> = u.iter().zip(&v).map(|(a, b)| a + sign * h * b).collect();
            let mut rw = vec![0.0; n];
            let energy = eq.evaluate(&w, &mut rw, None, false).unwrap();
            (energy, eq.loads().to_vec(), w)
        };
        let (e_plus, loads_plus, w_plus) = at(1.0);
        let (e_minus, loads_minus, w_minus) = at(-1.0);
        // The loads' work from w- to w+, exact for loads affine in u.
        let work: f64 = (0..n)
            .map(|k| 0.5 * (loads_plus[k] + loads_minus[k]) * (w_plus[k] - w_minus[k]))
            .sum();
        let fd = (e_plus - e_minus - work) / (2.0 * h);
        assert!(
            (fd - slope).abs() <= 1e-3 * slope.abs(),
            "dPi/dv by differences {fd:e}, -R.v {slope:e}"
        );
    }
}
