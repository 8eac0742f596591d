//! A simulation: a scene turned into grains, walls, contacts and a load program, advanced one
//! load increment at a time by the global solver (the minimisation of the increment's
//! potential) or by grain-by-grain relaxation.

mod anchors;
mod bonds;
mod breakout;
mod energy;
mod equations;
mod grain_balance;
mod increment;
mod lists;
mod load_step;
mod loose;
mod potential;
mod probe;
mod relaxation;
mod setup;
mod stability;

pub use anchors::{anchors, membrane_carriers, Anchor};
pub use energy::EnergyBalance;
pub use equations::IncrementEquations;
pub use load_step::LoadStep;
pub use potential::CHAIN_CHANGES;
pub use setup::{initial_contacts, MaterialModel, StageProgram};

use crate::assembly::{DofMap, Pattern};
use crate::contact::{Configuration, ContactLaw, ContactSet, Kinematics};
use crate::geometry::{
    chains, Chain, ChainWatch, FriendSet, GrainSet, Pair, Side, WallControl, WallSet,
};
use crate::measure::{measure, Measurements, MembraneBoundary, Region};
use crate::memory::HeapBytes;
use crate::solver::minimise::{MinimiseWork, Potential};
use crate::solver::stats::{secs, StageTimers};
use crate::solver::{LinearSolver, SolverConfig, SolverStats, Strategy};
use crate::state::{IncrementReport, KeptState, PeakState, State};
use crate::NumericError;
use std::sync::Arc;
use std::time::Instant;

/// A running simulation: its state, its settings, and the workspace of the solver.
pub struct Simulation {
    /// Scene name.
    pub name: String,
    /// How it is solved.
    pub config: SolverConfig,
    /// Contact properties of the material and the walls.
    pub material: MaterialModel,
    /// Depth `D` (m).
    pub depth: f64,
    /// The load program.
    pub stages: Vec<StageProgram>,
    /// Committed state.
    pub state: State,
    /// Timers and counters.
    pub stats: SolverStats,
    /// Residual history of the last solve (relative residuals, one per iteration or sweep).
    pub last_residuals: Vec<f64>,
    /// Regions whose stress is measured (the scene's `[[regions]]`).
    pub regions: Vec<Region>,
    /// The part of the increment being solved (or of the last, where it found no equilibrium
    /// near) found in equilibrium with the highest macro deviator, short of its end.
    pub peak_within: Option<PeakState>,
    /// Where the last increment failed, the state it started from: the last complete
    /// increment's, which `state` may have moved past (the halves that converged are
    /// committed). `None` after an increment that converged.
    pub failed_from: Option<State>,
    /// Each wall's force below which the load has dropped in this stage: its `failure_drop`
    /// times the wall's peak so far, set by the run before each increment (zero, or empty,
    /// where none is watched). A bond cascade's first equilibrium below it is kept, and is
    /// the step's where the solver gives up on the cascade after it: the sample's brittle
    /// failure at the cascade's load.
    pub drop_floor: Vec<f64>,
    /// The stress each wall takes in the next increment where it was set between increments
    /// ([`Simulation::set_wall_stress`]) in place of its stage's step; empty where none was.
    stress_next: Vec<Option<f64>>,
    law: Box<dyn ContactLaw>,
    r_mean: f64,
    dofs: DofMap,
    friends: FriendSet,
    pattern: Arc<Pattern>,
    values: Vec<f64>,
    linear: LinearSolver,
    q: Configuration,
    kin: Vec<Kinematics>,
    pair_index: Vec<usize>,
    /// Each membrane's chain for the current increment.
    chains: Vec<Chain>,
    /// The chains last found, kept while their grains move too little to change them.
    chain_watch: ChainWatch,
    /// The grains the membranes may lie on in the current increment.
    carriers: Vec<bool>,
    /// Springs on the rigid-body motions the walls leave free.
    anchors: Vec<Anchor>,
    /// The grains the minimisation leaves out as loose (see [`loose`]); empty outside a
    /// minimisation.
    loose: Vec<bool>,
    /// Pairs whose contact the relaxation lost in this increment, sorted: made again, they
    /// push but do not pull (see [`IncrementEquations::reopened`]).
    reopened: Vec<Pair>,
    /// The minimisation's work vectors, kept from one minimisation to the next.
    minimise_work: MinimiseWork,
    /// The energy the increment being solved dissipated by sliding and released by breaking
    /// bonds, so far.
    energy: EnergyBalance,
}

/// Share of the half skin past which the friends lists are made anew: below the share a
/// step may reach (0.9), so a step that stopped there finds new lists.
const REACH_REBUILD: f64 = 0.8;

/// Change of a side's extent, in mean radii, that counts as a new chain: its end pieces then
/// carry a load that differs from the one solved for by more than the tolerance allows.
const EXTENT_CHANGE: f64 = 1e-10;

impl Simulation {
    /// A simulation from a committed state (a fresh one from [`Simulation::new`], or one read back to
    /// resume). The workspace is rebuilt: friends lists from the state's reference positions
    /// holding the committed contacts, the membranes' chains of the committed state: the
    /// workspace the interrupted run had when it wrote the state
    /// ([`Simulation::refresh_workspace`]).
    pub fn from_state(
        name: String,
        config: SolverConfig,
        material: MaterialModel,
        depth: f64,
        stages: Vec<StageProgram>,
        state: State,
    ) -> Result<Simulation, NumericError> {
        let law = material.law();
        let r_mean = state.grains.mean_radius();
        let dofs = dof_map(&state, material.fixed_rotations);
        let friends = resumed_friends(&state, config.skin * r_mean);
        let (carriers, chains) = committed_chains(&state);
        let links: Vec<(usize, usize)> = chains.iter().flat_map(Chain::links).collect();
        let pattern = Arc::new(Pattern::build(&friends, &dofs, &state.walls, &links));
        let mut sim = Simulation {
            name,
            linear: LinearSolver::in_order(config.ordering),
            config,
            material,
            depth,
            stages,
            stats: SolverStats::default(),
            last_residuals: Vec::new(),
            regions: Vec::new(),
            peak_within: None,
            failed_from: None,
            drop_floor: Vec::new(),
            stress_next: Vec::new(),
            law,
            r_mean,
            q: Configuration::at_rest(&state.grains, &state.walls),
            kin: Vec::new(),
            pair_index: Vec::new(),
            chains,
            chain_watch: ChainWatch::default(),
            carriers,
            anchors: anchors(&state.grains, &state.walls, &state.contacts.contacts),
            loose: Vec::new(),
            reopened: Vec::new(),
            minimise_work: MinimiseWork::default(),
            energy: EnergyBalance::default(),
            values: vec![0.0; pattern.nnz()],
            pattern,
            friends,
            dofs,
            state,
        };
        sim.analyse_pattern()?;
        Ok(sim)
    }

    /// Whether every stage of the load program is done.
    pub fn is_finished(&self) -> bool {
        self.state.stage >= self.stages.len()
    }

    /// Total increments of the load program.
    pub fn total_increments(&self) -> usize {
        self.stages.iter().map(|s| s.increments).sum()
    }

    /// Mean grain radius (m).
    pub fn mean_radius(&self) -> f64 {
        self.r_mean
    }

    /// The unknowns of this scene.
    pub fn dofs(&self) -> &DofMap {
        &self.dofs
    }

    /// Values the Cholesky factor of the current pattern holds: its fill.
    pub fn factor_entries(&self) -> usize {
        self.linear.factor_entries()
    }

    /// The bytes the simulation holds now, by part, from the lengths of what it holds (the
    /// vectors' capacities times their elements' sizes). Copies of the state held elsewhere
    /// (an increment's start, the result file's writer) and faer's scratch are not counted.
    pub fn memory_by_part(&self) -> Vec<(&'static str, usize)> {
        let (g, c) = (&*self.state.grains, &*self.state.contacts);
        let grains = [
            g.position.heap_bytes(),
            g.origin.heap_bytes(),
            g.displacement.heap_bytes(),
            g.rotation.heap_bytes(),
            g.radius.heap_bytes(),
            g.taken_out.heap_bytes(),
            self.state.friends_reference.heap_bytes(),
            self.state.last_step.heap_bytes(),
        ];
        let contacts = c.contacts.heap_bytes() + c.broken_bonds.heap_bytes();
        let kinematics = self.kin.heap_bytes() + self.pair_index.heap_bytes();
        let f = &self.friends;
        let friends = f.pairs.heap_bytes() + f.reference.heap_bytes() + f.held.heap_bytes();
        let (structure, slots) = self.pattern.heap_bytes();
        let (analysis, factor) = self.linear.heap_bytes();
        let q = &self.q;
        let chains: usize = self.chains.iter().map(|c| c.grains.heap_bytes()).sum();
        let rest = self.dofs.glue.heap_bytes()
            + self.dofs.taken_out.heap_bytes()
            + q.position.heap_bytes()
            + q.displacement.heap_bytes()
            + q.rotation.heap_bytes()
            + self.carriers.heap_bytes()
            + self.loose.heap_bytes()
            + self.anchors.heap_bytes()
            + chains
            + self.chain_watch.heap_bytes();
        vec![
            ("grains (the state's)", grains.iter().sum()),
            ("contacts and broken bonds (the state's)", contacts),
            ("contacts' kinematics and pair index", kinematics),
            ("friends lists", friends),
            ("pattern: structure", structure),
            ("pattern: each pair's value slots", slots),
            ("Hessian's values", self.values.heap_bytes()),
            ("Cholesky analysis", analysis),
            ("factor's values", factor),
            ("minimisation's vectors", self.minimise_work.heap_bytes()),
            ("unknowns' map, configuration, chains", rest),
        ]
    }

    /// Make the workspace the one a run resumed from the committed state starts with
    /// ([`Simulation::from_state`]), and drop the numeric factorisation. Called when the state
    /// is written, so that a run resumed from there repeats the same arithmetic. The running
    /// lists may still hold pairs that were contacts when they were made, and the pattern the
    /// links of earlier membrane chains; a resumed run has neither, and a pattern one entry
    /// apart factorises in another order: the two runs would part by round-off, and a cascade
    /// of bond breaks would go another way.
    pub fn refresh_workspace(&mut self) -> Result<(), NumericError> {
        let start = Instant::now();
        let state = &self.state;
        // A resumed run's lists are these unless they hold a pair that is no longer a contact
        // or a wall has turned since they were made (they are made with the walls' turn now).
        let turned =
            (state.walls.walls.iter().zip(&self.friends.wall_turn)).any(|(w, &t)| w.turn != t);
        let contacts = pairs_of(&state.contacts);
        let lost = (self.friends.held.iter()).any(|p| contacts.binary_search(p).is_err());
        let (carriers, chains) = committed_chains(state);
        let links: Vec<(usize, usize)> = chains.iter().flat_map(Chain::links).collect();
        let renew = turned || lost || links != self.pattern.chain_links;
        if turned || lost {
            self.friends = resumed_friends(state, self.config.skin * self.r_mean);
        }
        (self.carriers, self.chains) = (carriers, chains);
        self.linear.invalidate();
        self.stats.timers.detection += secs(start);
        if renew {
            self.install_pattern()
        } else {
            Ok(())
        }
    }

    /// One load increment, as the pipeline reads: apply the increment, then solve it (the
    /// minimisation of its potential, its load path followed in halves where it does not
    /// converge; or relaxation), commit, measure. Where it fails, the state it started from
    /// is kept in [`Simulation::failed_from`].
    pub fn run_increment(&mut self) -> Result<IncrementReport, NumericError> {
        let start = KeptState::of(&self.state);
        self.failed_from = None;
        let result = self.solve_increment(&start);
        if result.is_err() {
            self.failed_from = Some(start.state());
        }
        result
    }

    /// The increment from `committed`, the state it starts from (see
    /// [`Simulation::run_increment`]).
    fn solve_increment(&mut self, committed: &KeptState) -> Result<IncrementReport, NumericError> {
        let mut report = IncrementReport {
            increment: self.state.increment + 1,
            stage: self.state.stage,
            ..Default::default()
        };
        // The walls' controls and glue of this stage, then the increment: the wall moves and
        // stresses of the next step of the stage.
        self.apply_stage_controls()?;
        self.apply_glue()?;
        let step = self.next_load_step();
        let start = self.boundary_forces();
        self.energy = EnergyBalance::default();
        self.peak_within = None;
        // Solve: the minimisation with bonds broken one at a time; or grain by grain.
        match self.config.strategy {
            Strategy::Minimise => self.minimise_step(&step, committed, &mut report)?,
            Strategy::Relaxation => self.relax_increment(&step, 0, &mut report)?,
        }
        let end = self.boundary_forces();
        report.energy = EnergyBalance {
            work: start.work_to(&end),
            stored: end.stored(),
            stored_change: end.stored() - start.stored(),
            ..self.energy
        };
        // Advance the load program.
        self.stress_next.clear();
        self.state.increment += 1;
        self.state.stage_increment += 1;
        if self.state.stage_increment == self.stages[self.state.stage].increments {
            self.state.stage += 1;
            self.state.stage_increment = 0;
        }
        self.stats.counters.increments += 1;
        // Measure.
        report.measurements = self.measure();
        if let Some(peak) = self.peak_within.take() {
            report.keep_peak(peak);
        }
        Ok(report)
    }

    /// Give each wall the control the current stage asks for. A wall turned to stress control
    /// at the start of a stage takes the stress the grains put on it, so the stage starts in
    /// equilibrium; met again in the middle of a stage (a resumed run, whose walls come with
    /// the scene's first controls), it keeps the applied stress read back with it. The
    /// unknowns change, so the pattern and its factorisation are made anew.
    fn apply_stage_controls(&mut self) -> Result<(), NumericError> {
        let control = &self.stages[self.state.stage].control;
        let walls = &self.state.walls.walls;
        if control.is_empty() || walls.iter().zip(control).all(|(w, c)| w.control == *c) {
            return Ok(());
        }
        let measured = self.measure().wall_stress;
        let at_start = self.state.stage_increment == 0;
        for ((wall, &c), stress) in self.state.walls.walls.iter_mut().zip(control).zip(measured) {
            if wall.control != c && c == WallControl::Stress && at_start {
                wall.stress = stress;
            }
            wall.control = c;
        }
        self.dofs = dof_map(&self.state, self.material.fixed_rotations);
        self.linear.invalidate();
        self.install_pattern()
    }

    /// At the start of a stage that glues walls: every grain then touching one of them (and
    /// glued to none yet) is glued to it, its contact with the wall bonded. From then on the
    /// grain moves with the wall as a part of it (see [`DofMap`]): the thesis's simple shear
    /// box, whose grains may neither slide nor roll on the walls (3.3.4). Tying the grain's
    /// motion to the wall's is the exact form of that condition: infinite friction alone
    /// leaves a grain free to roll about its contact point, and a bond with a spring against
    /// rolling would let it turn by its moment over that spring's stiffness. A resumed run
    /// finds the glue in the bonds it reads back, and meeting the stage's start again glues
    /// the same grains.
    fn apply_glue(&mut self) -> Result<(), NumericError> {
        let glue = &self.stages[self.state.stage].glue;
        if self.state.stage_increment != 0 || !glue.contains(&true) {
            return Ok(());
        }
        let mut glued = self.state.contacts.glued(self.state.grains.len());
        for c in &mut self.state.contacts.contacts {
            if let Side::Wall(w) = c.pair.a {
                if glue[w] && c.overlap >= 0.0 && glued[c.pair.b].is_none() {
                    c.bonded = true;
                    glued[c.pair.b] = Some(w);
                }
            }
        }
        self.dofs = dof_map(&self.state, self.material.fixed_rotations);
        self.linear.invalidate();
        self.install_pattern()
    }

    /// The next increment of the current stage: equal wall moves, stresses moving in equal
    /// steps from where they are to the stage's targets, and equal steps of shear strain: the
    /// walls across a sheared wall turn by the step (clockwise for a positive strain), and the
    /// sheared wall slides by its distance from the wall facing it times the change of
    /// `tan gamma`, so its corners stay on them (as far as that distance stays the same).
    fn next_load_step(&self) -> LoadStep {
        let stage = &self.stages[self.state.stage];
        let left = (stage.increments - self.state.stage_increment) as f64;
        let n = stage.increments as f64;
        let walls = &self.state.walls;
        let mut slide: Vec<f64> = stage.slide.iter().map(|m| m / n).collect();
        let mut turn = vec![0.0; walls.len()];
        for (w, &gamma) in stage.shear_strain.iter().enumerate() {
            let (Some((a, b)), Some(facing)) = (walls.span_walls(w), walls.facing(w)) else {
                continue;
            };
            let step = gamma / n;
            let before = -walls.walls[a].turn;
            turn[a] -= step;
            turn[b] -= step;
            slide[w] += walls.gap(w, facing) * ((before + step).tan() - before.tan());
        }
        LoadStep {
            normal_move: stage.normal_move.iter().map(|m| m / n).collect(),
            slide,
            turn,
            stress: walls
                .walls
                .iter()
                .zip(&stage.stress)
                .enumerate()
                .map(|(i, (w, target))| {
                    match (self.stress_next.get(i).copied().flatten(), target) {
                        (Some(set), _) => set,
                        (None, Some(t)) => w.stress + (t - w.stress) / left,
                        (None, None) => w.stress,
                    }
                })
                .collect(),
            pressure: self
                .state
                .membranes
                .iter()
                .zip(&stage.pressure)
                .map(|(m, target)| match target {
                    Some(t) => m.pressure + (t - m.pressure) / left,
                    None => m.pressure,
                })
                .collect(),
        }
    }

    /// What every solve of a step starts from: no contact reopened yet, and the carriers of
    /// the committed state.
    fn start_step(&mut self) {
        self.reopened.clear();
        self.carriers = membrane_carriers(&self.state.grains, &self.state.contacts.contacts);
    }

    /// What the global solve of a step adds: anchors on the committed contacts, and the
    /// membranes on the grains that are outermost in the committed state.
    fn start_newton(&mut self) -> Result<(), NumericError> {
        self.anchors = anchors(
            &self.state.grains,
            &self.state.walls,
            &self.state.contacts.contacts,
        );
        self.refresh_chains(false)?;
        Ok(())
    }

    fn equations<'a>(&'a mut self, step: &'a LoadStep) -> IncrementEquations<'a> {
        // Glued grains follow their walls with the weights of this step.
        self.dofs
            .follow(&self.state.grains, &self.state.walls, &step.turn);
        IncrementEquations {
            grains: &self.state.grains,
            walls: &self.state.walls,
            contacts: &mut self.state.contacts.contacts,
            pair_index: &mut self.pair_index,
            friends: &self.friends,
            step,
            membranes: &self.state.membranes,
            chains: &mut self.chains,
            chains_held: false,
            chain_watch: &mut self.chain_watch,
            carriers: &self.carriers,
            anchors: &self.anchors,
            loose: &mut self.loose,
            reopened: &self.reopened,
            dofs: &self.dofs,
            pattern: &self.pattern,
            law: self.law.as_ref(),
            symmetric: true,
            depth: self.depth,
            r_mean: self.r_mean,
            q: &mut self.q,
            kin: &mut self.kin,
            timers: StageTimers::default(),
            f_ref: 0.0,
            stiffness_hint: self.material.stiffness_hint(self.r_mean),
            far: false,
            load_scale: 0.0,
            lagged: self.config.strategy == Strategy::Minimise,
            frame_correction: Vec::new(),
            rotation_scratch: Default::default(),
            closing_scratch: Default::default(),
            refreeze: false,
            projected: self.config.strategy == Strategy::Minimise,
            loads: Vec::new(),
            stale_pattern: false,
            chain_changes: 0,
            consistent: false,
            energy: 0.0,
        }
    }

    /// Take back the counters and the value buffer a solve worked on, with the time its
    /// equations spent in the return map and the assembly.
    fn take_back(&mut self, stats: SolverStats, timers: StageTimers, values: Vec<f64>) {
        self.stats = stats;
        self.add_timers(timers);
        self.values = values;
    }

    /// Add the time equations spent in the return map and the assembly to the run's.
    fn add_timers(&mut self, timers: StageTimers) {
        self.stats.timers.return_map += timers.return_map;
        self.stats.timers.assembly += timers.assembly;
    }

    /// Friends lists around the given positions, and the pattern and symbolic factorisation
    /// that go with them.
    fn rebuild_friends(&mut self, grains: &GrainSet, walls: &WallSet) -> Result<(), NumericError> {
        let kept = pairs_of(&self.state.contacts);
        self.make_friends(grains, walls, &kept);
        self.install_pattern()
    }

    /// The friends lists made anew around the given positions, holding the pairs `kept`
    /// whatever their distance, with the positions they were made at (for a resumed run).
    fn make_friends(&mut self, grains: &GrainSet, walls: &WallSet, kept: &[Pair]) {
        let start = Instant::now();
        let friends = friends_around(grains, walls, self.config.skin * self.r_mean, kept);
        self.state.friends_reference.clone_from(&friends.reference);
        self.state
            .friends_wall_reference
            .clone_from(&friends.wall_reference);
        self.friends = friends;
        self.stats.counters.friends_rebuilds += 1;
        self.stats.timers.detection += secs(start);
    }

    /// The pattern of the friends lists and membrane links, with its value buffer and its
    /// symbolic factorisation. A pattern of the same entries as the last keeps its analysis,
    /// which the entries alone decide: lists made anew around grains that moved little, and a
    /// chain whose new links are friends pairs already, most often leave the entries as they
    /// were.
    fn install_pattern(&mut self) -> Result<(), NumericError> {
        // The old pattern's values go first, so that the two patterns' are not held at once.
        self.values = Vec::new();
        let links: Vec<(usize, usize)> = self.chains.iter().flat_map(Chain::links).collect();
        let pattern = Pattern::build(&self.friends, &self.dofs, &self.state.walls, &links);
        let (old, new) = (&self.pattern.symbolic, &pattern.symbolic);
        let same = self.linear.is_analysed()
            && old.nrows() == new.nrows()
            && old.col_ptr() == new.col_ptr()
            && old.row_idx() == new.row_idx();
        self.pattern = Arc::new(pattern);
        self.values = vec![0.0; self.pattern.nnz()];
        if same {
            // The analysis stays, and so does the factor, of a matrix on the same unknowns:
            // the tangent the stability indicator left for the next first step among them.
            self.index_pairs()
        } else {
            self.analyse_pattern()
        }
    }

    /// Each membrane's chain on the grains where they are at the current iterate (or, when
    /// not `at_iterate`, in the committed state); a chain linking grains the pattern does not
    /// link yet needs a new pattern. Returns how many chains changed.
    fn refresh_chains(&mut self, at_iterate: bool) -> Result<usize, NumericError> {
        if self.state.membranes.is_empty() {
            return Ok(0);
        }
        let position = if at_iterate {
            &self.q.position
        } else {
            &self.state.grains.position
        };
        let chains = self.chain_watch.chains(
            &self.state.membranes,
            position,
            &self.state.grains.radius,
            &self.carriers,
            &self.state.grains.taken_out,
        );
        // A chain changes with its grains, or with the sample's extent along a side, which
        // sets the load of its end pieces.
        let moved = |a: [f64; 2], b: [f64; 2]| {
            (a[0] - b[0]).abs().max((a[1] - b[1]).abs()) > EXTENT_CHANGE * self.r_mean
        };
        let changed = chains
            .iter()
            .zip(&self.chains)
            .filter(|(new, old)| new.grains != old.grains || moved(new.extent, old.extent))
            .count();
        self.chains = chains;
        if !self.pattern.couples(&self.dofs, &self.chains) {
            self.install_pattern()?;
        }
        Ok(changed)
    }

    /// Symbolic factorisation of the pattern, and each contact's block in it.
    fn analyse_pattern(&mut self) -> Result<(), NumericError> {
        self.linear
            .analyse(&self.pattern.symbolic, &mut self.stats)
            .map_err(|e| NumericError::Singular { detail: e.0 })?;
        self.index_pairs()
    }

    /// After a failed attempt: the friends lists must still hold every restored contact.
    fn restore_friends(&mut self) -> Result<(), NumericError> {
        if self.index_pairs().is_err()
            || self.friends.is_stale(
                &self.state.grains.position,
                &self
                    .state
                    .walls
                    .walls
                    .iter()
                    .map(|w| w.position)
                    .collect::<Vec<_>>(),
                &self
                    .state
                    .walls
                    .walls
                    .iter()
                    .map(|w| w.turn)
                    .collect::<Vec<_>>(),
            )
        {
            let (g, w) = (self.state.grains.clone(), self.state.walls.clone());
            self.rebuild_friends(&g, &w)?;
        }
        Ok(())
    }

    /// Each contact's index in the friends lists (its block of the pattern).
    fn index_pairs(&mut self) -> Result<(), NumericError> {
        self.pair_index.clear();
        for c in &self.state.contacts.contacts {
            match self.friends.pairs.binary_search(&c.pair) {
                Ok(p) => self.pair_index.push(p),
                Err(_) => {
                    return Err(NumericError::NotFinite {
                        what: "friends list",
                        place: format!("contact {:?}-{} outside the lists", c.pair.a, c.pair.b),
                    })
                }
            }
        }
        Ok(())
    }

    /// Make the converged step the committed state.
    fn commit(&mut self, step: &LoadStep, u: &[f64]) {
        self.equations(step).configure(u);
        let grains = &mut self.state.grains;
        grains.displace(&self.q.displacement);
        for (r, dr) in grains.rotation.iter_mut().zip(&self.q.rotation) {
            *r += dr;
        }
        for (w, wall) in self.state.walls.walls.iter_mut().enumerate() {
            wall.position += match self.dofs.wall[w] {
                Some(dof) => u[dof],
                None => step.normal_move[w],
            };
            wall.slide += step.slide[w];
            wall.turn += step.turn[w];
            if wall.control == WallControl::Stress {
                wall.stress = step.stress[w];
            }
        }
        for (m, p) in self.state.membranes.iter_mut().zip(&step.pressure) {
            m.pressure = *p;
        }
        let law = self.law.as_ref();
        self.energy.dissipated += (self.state.contacts.contacts.iter())
            .map(|c| energy::dissipated(law, c))
            .sum::<f64>();
        self.state.contacts.commit();
        self.q = Configuration::at_rest(&self.state.grains, &self.state.walls);
    }

    /// Measurements of the committed state.
    pub fn measure(&self) -> Measurements {
        measure(
            &self.state.grains,
            &self.state.walls,
            &self.state.contacts,
            MembraneBoundary {
                membranes: &self.state.membranes,
                chains: &self.chains,
            },
            self.depth,
            &self.regions,
        )
    }

    /// The stresses on the walls and the pressures on the membranes that the committed state
    /// carries: where a part of a step starts its loads from.
    pub(super) fn held_loads(&self) -> (Vec<f64>, Vec<f64>) {
        (
            self.state.walls.walls.iter().map(|w| w.stress).collect(),
            self.state.membranes.iter().map(|m| m.pressure).collect(),
        )
    }

    /// Largest force or moment imbalance of any grain, relative to the mean contact force, in
    /// the committed state (moments divided by the mean radius).
    pub fn equilibrium_error(&mut self) -> (f64, usize) {
        let (stress, pressure) = self.held_loads();
        let step = LoadStep {
            normal_move: vec![0.0; self.state.walls.len()],
            slide: vec![0.0; self.state.walls.len()],
            turn: vec![0.0; self.state.walls.len()],
            stress,
            pressure,
        };
        let u = vec![0.0; self.dofs.len];
        let mut r = vec![0.0; self.dofs.len];
        let mut eq = self.equations(&step);
        // The minimisation's contacts respond with the lag refrozen where they are: the true
        // law (the lag left by the last solve, or none in a state read back or just made).
        let refreeze = eq.lagged;
        if Potential::evaluate(&mut eq, &u, &mut r, None, refreeze).is_err() {
            return (f64::INFINITY, 0);
        }
        let (rel, worst, _) = eq.residual_norm(&r);
        // Evaluation overwrote the trial responses with the committed ones: same values.
        (rel, worst)
    }
}

/// The unknowns of `state`: its walls' controls, its glued grains and those taken out.
fn dof_map(state: &State, fixed_rotations: bool) -> DofMap {
    let n = state.grains.len();
    let glued = state.contacts.glued(n);
    DofMap::new(
        n,
        fixed_rotations,
        &state.walls,
        &glued,
        &state.grains.taken_out,
    )
}

/// The pairs of the contacts of `set`.
fn pairs_of(set: &ContactSet) -> Vec<Pair> {
    set.contacts.iter().map(|c| c.pair).collect()
}

/// The friends lists a run resumed from `state` starts with: made where the grains and walls
/// were when they were last made (`friends_reference`), holding every committed contact.
fn resumed_friends(state: &State, skin: f64) -> FriendSet {
    let mut at_reference = state.grains.clone();
    at_reference.position.clone_from(&state.friends_reference);
    let mut walls_at_reference = state.walls.clone();
    for (w, r) in walls_at_reference
        .walls
        .iter_mut()
        .zip(&state.friends_wall_reference)
    {
        w.position = r[0];
        w.slide = r[1];
    }
    friends_around(
        &at_reference,
        &walls_at_reference,
        skin,
        &pairs_of(&state.contacts),
    )
}

/// The grains the membranes may lie on in the committed state, and the chains on them.
fn committed_chains(state: &State) -> (Vec<bool>, Vec<Chain>) {
    let carriers = membrane_carriers(&state.grains, &state.contacts.contacts);
    let chains = chains(
        &state.membranes,
        &state.grains.position,
        &state.grains.radius,
        &carriers,
        &state.grains.taken_out,
    );
    (carriers, chains)
}

/// Friends lists around the given positions that also hold every pair of `required`:
/// contacts cannot be outside the lists in practice (the lists are rebuilt before anything
/// moves half the skin), but a bond stretched past the skin would be.
fn friends_around(grains: &GrainSet, walls: &WallSet, skin: f64, required: &[Pair]) -> FriendSet {
    let mut friends = FriendSet::build(grains, walls, skin);
    let mut missing: Vec<_> = required
        .iter()
        .copied()
        .filter(|p| friends.pairs.binary_search(p).is_err())
        .collect();
    if !missing.is_empty() {
        friends.held.clone_from(&missing);
        friends.pairs.append(&mut missing);
        friends.pairs.sort();
    }
    friends
}

#[cfg(test)]
mod tests;
