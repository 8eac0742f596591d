//! Running a simulation: a scene read with where it came from; a run begun or resumed with
//! its result file as `grainstat run` does it; the run advanced one increment at a time with
//! its bookkeeping ([`Stepper`]: the state written every `every` increments and at the end,
//! on failure the last converged state written before the error) or to the end
//! ([`run_to_end`]); a sample prepared as `grainstat generate` does it; the line each
//! increment prints and the run's summary.

use crate::geometry::WallControl;
use crate::output::hdf5_file::read_history;
use crate::output::{Mechanism, ResultFile, RunHeader};
use crate::sample::prepare::{prepare, PrepareSpec, Prepared};
use crate::scene::{build_grains, load_scene, load_solver, parse_scene, Scene};
use crate::simulation::{MaterialModel, Simulation};
use crate::solver::stats::secs;
use crate::solver::{SolverConfig, Strategy};
use crate::state::{IncrementReport, PeakState};
use crate::{Error, InputError, NumericError};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A fresh simulation of the scene read from `scene_path`: from a sample's prepared
/// equilibrium when the scene keeps its walls, else from its grains (files relative to the
/// scene's folder).
pub fn start(scene: &Scene, scene_path: &Path, config: SolverConfig) -> Result<Simulation, Error> {
    let base = scene_path.parent().unwrap_or(Path::new("."));
    start_in(scene, base, &scene_path.display().to_string(), config)
}

/// [`start`] with the files the scene names relative to `base`, its problems reported against
/// `scene_file`.
fn start_in(
    scene: &Scene,
    base: &Path,
    scene_file: &str,
    config: SolverConfig,
) -> Result<Simulation, Error> {
    Ok(match (&scene.grains.sample, &scene.grains.walls) {
        // The prepared equilibrium itself: walls kept, contacts with their history.
        (Some(sample), Some(_)) => {
            let sample = crate::sample::read_sample(base.join(sample))?;
            Simulation::from_sample(scene, sample, config, scene_file)?
        }
        _ => {
            let grains = build_grains(&scene.grains, base, scene_file)?;
            Simulation::new(scene, grains, config, scene_file)?
        }
    })
}

/// A scene with where it came from: the text it was read from (stored with the results), the
/// name its problems are reported against, and the folder the files it names are relative to.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneInput {
    /// The scene, checked.
    pub scene: Scene,
    /// Its TOML text.
    pub text: String,
    /// The file its problems are reported against.
    pub file: String,
    /// The folder the files it names (samples, grain CSV) are relative to.
    pub base: PathBuf,
}

impl SceneInput {
    /// The scene file at `path`; the files it names are relative to its folder.
    pub fn load(path: &Path) -> Result<SceneInput, InputError> {
        let (scene, text) = load_scene(path)?;
        Ok(SceneInput {
            scene,
            text,
            file: path.display().to_string(),
            base: path.parent().unwrap_or(Path::new(".")).to_path_buf(),
        })
    }

    /// A scene given as TOML text, its problems reported against `file`, the files it names
    /// relative to `base`.
    pub fn parse(text: &str, file: &str, base: &Path) -> Result<SceneInput, InputError> {
        Ok(SceneInput {
            scene: parse_scene(text, file)?,
            text: text.to_string(),
            file: file.to_string(),
            base: base.to_path_buf(),
        })
    }

    /// A fresh simulation of the scene's load program (see [`start`]).
    pub fn start(&self, config: SolverConfig) -> Result<Simulation, Error> {
        self.require_load_program()?;
        start_in(&self.scene, &self.base, &self.file, config)
    }

    /// A new run as `grainstat run` begins one: the simulation, and its result file at
    /// `output` (default: the scene's `output.file`, else `results/NAME.h5`) with the state
    /// before loading written as increment 0.
    pub fn begin_run(
        &self,
        config: SolverConfig,
        solver_text: &str,
        output: Option<PathBuf>,
    ) -> Result<(Simulation, ResultFile), Error> {
        let sim = self.start(config)?;
        let out = output
            .or_else(|| self.scene.output.file.as_ref().map(PathBuf::from))
            .unwrap_or_else(|| PathBuf::from(format!("results/{}.h5", self.scene.name)));
        let mut file = ResultFile::create(&out, &header(&sim, &self.text, solver_text))?;
        file.write_increment(&sim.state, &initial_report(&sim), &sim.stats)?;
        Ok((sim, file))
    }

    /// The run in the result file `path` taken up at its last complete increment, as
    /// `grainstat run --resume` does: the scene must be the one the file was made with.
    pub fn resume_run(
        &self,
        config: SolverConfig,
        path: &Path,
    ) -> Result<(Simulation, ResultFile), Error> {
        self.require_load_program()?;
        let (sim, file, _) = resume_run(Some(self), config, path)?;
        Ok((sim, file))
    }

    /// A sample prepared as the scene's `[sample]` section says (`grainstat generate`);
    /// `progress` sees each growth step and the number of steps.
    pub fn prepare_sample(
        &self,
        config: &SolverConfig,
        progress: impl FnMut(usize, usize),
    ) -> Result<Prepared, Error> {
        let Some(spec) = &self.scene.sample else {
            return Err(InputError::new(
                &self.file,
                "the scene has no `[sample]` section to say what to prepare",
            )
            .at_key("sample")
            .into());
        };
        let spec = PrepareSpec {
            shape: spec.region,
            aspect: spec.aspect(),
            grains: spec.grains,
            distribution: spec.distribution,
            seed: spec.seed,
            friction: spec.friction,
            stress: spec.stress,
            start_fraction: spec.start_fraction,
            solid_fraction: spec.solid_fraction,
            depth: self.scene.material.depth,
        };
        let material = MaterialModel::from_scene(&self.scene);
        prepare(&spec, &material, config, &self.file, progress)
    }

    /// A scene that prepares a sample has no load program to run.
    fn require_load_program(&self) -> Result<(), InputError> {
        match self.scene.sample {
            Some(_) => Err(InputError::new(
                &self.file,
                "this scene prepares a sample: run `grainstat generate` on it, then start a \
                 test scene from the sample with `[grains] sample = \"SAMPLE.h5\"`",
            )
            .at_key("sample")),
            None => Ok(()),
        }
    }
}

/// The run in the result file `path` taken up at its last complete increment, with the scene
/// `scene`, which must be the one the file was made with, or (`None`) with the scene stored
/// in the file; and that scene.
pub fn resume_run(
    scene: Option<&SceneInput>,
    config: SolverConfig,
    path: &Path,
) -> Result<(Simulation, ResultFile, Scene), Error> {
    let (file, head, state) = ResultFile::open_for_resume(path)?;
    let stored = parse_scene(&head.scene_text, &path.display().to_string())?;
    if let Some(input) = scene.filter(|input| input.scene != stored) {
        return Err(InputError::new(
            &input.file,
            format!(
                "this scene differs from the one {} was made with; resume with the same scene",
                path.display()
            ),
        )
        .into());
    }
    let sim = Simulation::resume(&stored, state, head.depth, config)?;
    Ok((sim, file, stored))
}

/// Solver settings from a file, or the defaults; with the TOML they were read from (the
/// defaults written out), which is stored with the results.
pub fn solver_settings(path: Option<&Path>) -> Result<(SolverConfig, String), Error> {
    match path {
        Some(p) => Ok(load_solver(p)?),
        None => {
            let config = SolverConfig::default();
            let text = toml::to_string(&config).map_err(|e| Error::io("solver settings", e))?;
            Ok((config, text))
        }
    }
}

/// The static data of a simulation's result file.
pub fn header(sim: &Simulation, scene_text: &str, solver_text: &str) -> RunHeader {
    RunHeader {
        scene_name: sim.name.clone(),
        scene_text: scene_text.to_string(),
        solver_text: solver_text.to_string(),
        version: env!("CARGO_PKG_VERSION").to_string(),
        depth: sim.depth,
        radius: sim.state.grains.radius.clone(),
        walls: RunHeader::walls_of(&sim.state.walls),
        fixed_rotations: sim.material.fixed_rotations,
        law: format!("{:?}", sim.material.law).to_lowercase(),
        membranes: sim.state.membranes.clone(),
        regions: sim.regions.clone(),
    }
}

/// The report of the state as it stands (increment 0 of a fresh run).
pub fn initial_report(sim: &Simulation) -> IncrementReport {
    IncrementReport {
        increment: sim.state.increment,
        stage: sim.state.stage,
        measurements: sim.measure(),
        ..Default::default()
    }
}

/// How a run that did not stop on an error ended.
#[derive(Debug, Clone, PartialEq)]
pub enum RunEnd {
    /// The whole load program was applied.
    Finished,
    /// The sample failed in a stage loaded until failure ([`crate::scene::Stage::until_failure`]).
    Failed(Failure),
}

/// Why a sample counts as failed.
#[derive(Debug, Clone, PartialEq)]
pub enum FailureCause {
    /// The increment found no equilibrium: the solver's error.
    NoEquilibrium(NumericError),
    /// The first cluster broke out in a stage that ends there: the cylinder test's
    /// functional failure ([`crate::scene::Stage::until_breakout`]).
    Breakout(NumericError),
    /// The force on a pushed wall fell below a fraction of its peak
    /// ([`crate::scene::Stage::failure_drop`]).
    LoadDrop {
        /// The wall.
        wall: String,
        /// Its largest force in the stage (N).
        peak: f64,
        /// Its force now (N).
        force: f64,
    },
}

impl std::fmt::Display for FailureCause {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FailureCause::NoEquilibrium(error) | FailureCause::Breakout(error) => {
                write!(f, "{error}")
            }
            FailureCause::LoadDrop { wall, peak, force } => write!(
                f,
                "the force on `{wall}` fell to {force:.4e} N from its peak of {peak:.4e} N"
            ),
        }
    }
}

/// Where a sample failed: the increment that found no equilibrium (or showed the load drop),
/// and the loads it carried.
#[derive(Debug, Clone, PartialEq)]
pub struct Failure {
    /// The increment (1-based) that did not converge or showed the drop.
    pub increment: usize,
    /// Name of its stage.
    pub stage: String,
    /// Why.
    pub cause: FailureCause,
    /// The last increment converged in full (0: none).
    pub last_increment: usize,
    /// The highest loads carried in equilibrium, by name (Pa): each membrane's pressure and
    /// each stress-controlled wall's stress, as the last converged (sub-)step left them. Parts
    /// of the failing increment that converged before it was cut further count.
    pub carried: Vec<(String, f64)>,
}

impl Failure {
    /// The loads carried, as `name 1.2345e6 Pa` joined by commas.
    pub fn loads(&self) -> String {
        self.carried
            .iter()
            .map(|(name, v)| format!("{name} {v:.4e} Pa"))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let what = match self.cause {
            FailureCause::Breakout(_) => "reached functional failure, its first breakout,",
            _ => "failed",
        };
        write!(
            f,
            "the sample {what} in increment {} (stage '{}'): {}",
            self.increment, self.stage, self.cause
        )?;
        // A test under displacement control alone carries no applied stresses.
        if !self.carried.is_empty() {
            write!(f, "; loads carried in equilibrium: {}", self.loads())?;
        }
        write!(f, " (last complete increment {})", self.last_increment)
    }
}

/// Run the load program to its end, or, in a stage loaded until failure, to the increment
/// that finds no equilibrium or shows its `failure_drop`: [`Stepper::step`] until the run
/// ends. `on_increment` sees every converged increment, after it is written.
pub fn run_to_end(
    sim: &mut Simulation,
    mut file: Option<&mut ResultFile>,
    every: usize,
    mut on_increment: impl FnMut(&Simulation, &IncrementReport),
) -> Result<RunEnd, Error> {
    let mut stepper = Stepper::new(sim, file.as_deref(), every)?;
    while !sim.is_finished() {
        let stepped = stepper.step(sim, file.as_deref_mut())?;
        if let Some(report) = &stepped.report {
            on_increment(sim, report);
        }
        if let Some(failure) = stepped.failure {
            return Ok(RunEnd::Failed(failure));
        }
    }
    Ok(RunEnd::Finished)
}

/// What one step of a run did.
#[derive(Debug, Clone, PartialEq)]
pub struct Stepped {
    /// The increment's report, where it converged.
    pub report: Option<IncrementReport>,
    /// The failure the run ends with, where it ends in one.
    pub failure: Option<Failure>,
}

/// A run advanced one increment at a time, with what it keeps between increments. The state
/// is written to the file after every `every`-th increment, at the end of every stage and
/// after the last increment; the numeric factorisation is refreshed at the same points (file
/// or not), so a run resumed from a written increment repeats the same arithmetic. In a
/// stage loaded until failure the peaks are counted over the stage's increments in the file
/// too, so that a resumed run remembers them. A failed increment writes the last converged
/// increment if it is not on file yet; it is an error unless its stage is loaded until
/// failure.
#[derive(Debug)]
pub struct Stepper {
    every: usize,
    /// The report of the last increment not on file yet.
    unwritten: Option<IncrementReport>,
    peaks: PeakForces,
    /// The peak of the increments not written since the last row: the next row carries it.
    pending: Option<PeakState>,
}

impl Stepper {
    /// The stepper of a run starting where `sim` stands, written to `file`.
    pub fn new(
        sim: &Simulation,
        file: Option<&ResultFile>,
        every: usize,
    ) -> Result<Stepper, Error> {
        Ok(Stepper {
            every: every.max(1),
            unwritten: None,
            peaks: match file {
                Some(f) => PeakForces::written(f.path(), sim.state.stage)?,
                None => PeakForces::default(),
            },
            pending: None,
        })
    }

    /// Run the next increment and keep its books (see [`Stepper`]). The simulation must not
    /// be finished.
    pub fn step(
        &mut self,
        sim: &mut Simulation,
        mut file: Option<&mut ResultFile>,
    ) -> Result<Stepped, Error> {
        sim.drop_floor = self.peaks.floors(sim);
        let mut report = match sim.run_increment() {
            Ok(report) => report,
            Err(err) => return self.failed(sim, file, err),
        };
        if let Some(before) = self.pending.take() {
            report.keep_peak(before);
        }
        // Every stage's end is written too: a test's estimate starts from it.
        let stage_end = sim.state.stage_increment == 0;
        if report.increment % self.every == 0 || stage_end || sim.is_finished() {
            sim.refresh_workspace()?;
            if let Some(f) = file.as_deref_mut() {
                let start = Instant::now();
                f.write_increment(&sim.state, &report, &sim.stats)?;
                sim.stats.timers.output += secs(start);
            }
            self.unwritten = None;
        } else {
            self.pending = Some(report.peak_or_end(&sim.state.walls));
            self.unwritten = Some(report.clone());
        }
        let mut failure = None;
        if let Some(cause) = self.peaks.drop(sim, &report) {
            if let (Some(f), Some(last)) = (file, self.unwritten.take()) {
                f.write_increment(&sim.state, &last, &sim.stats)?;
            }
            failure = Some(self::failure(sim, cause, (report.increment, report.stage)));
        }
        Ok(Stepped {
            report: Some(report),
            failure,
        })
    }

    /// After an increment that failed with `err`: keep what was computed, then the failure
    /// the run ends with, or the error.
    fn failed(
        &mut self,
        sim: &mut Simulation,
        file: Option<&mut ResultFile>,
        err: NumericError,
    ) -> Result<Stepped, Error> {
        // The last converged state, if it is not on file yet (the summary goes with it), else
        // the summary of the work spent.
        if let Some(f) = file {
            // Its state is the one the failing increment started from, which the halves of
            // it that converged have moved the simulation's past.
            match (self.unwritten.take(), &sim.failed_from) {
                (Some(last), Some(state)) => f.write_increment(state, &last, &sim.stats)?,
                _ => f.write_summary(&sim.stats)?,
            }
            // No equilibrium near: the mechanism, as the descent carried it. At a breakout
            // that ends the test, the cluster is among the breakouts, and nothing is carried
            // on as a whole.
            let carried_on = match &err {
                NumericError::NoEquilibrium { grains, .. } => Some(grains.clone()),
                NumericError::BrokeOut { .. } => Some(Vec::new()),
                _ => None,
            };
            if let Some(grains) = carried_on {
                let state = &sim.state;
                f.write_mechanism(&Mechanism {
                    increment: state.increment + 1,
                    description: err.to_string(),
                    grains,
                    position: state.grains.position.clone(),
                    displacement: sim.descent(),
                    membrane_pressure: state.membranes.iter().map(|m| m.pressure).collect(),
                    wall_stress: state.walls.walls.iter().map(|w| w.stress).collect(),
                    peak: sim.peak_within.clone(),
                    breakouts: state.breakouts.clone(),
                })?;
            }
        }
        let stage = &sim.stages[sim.state.stage];
        // The minimisation names the failure (grains carried on while the potential falls);
        // where it only stops short of the tolerance, the solver gave up.
        let no_equilibrium = matches!(err, NumericError::NoEquilibrium { .. });
        let cause = match err {
            NumericError::BrokeOut { .. } => FailureCause::Breakout(err),
            _ if stage.until_failure && no_equilibrium => FailureCause::NoEquilibrium(err),
            _ => return Err(err.into()),
        };
        let at = (sim.state.increment + 1, sim.state.stage);
        Ok(Stepped {
            report: None,
            failure: Some(failure(sim, cause, at)),
        })
    }
}

/// The largest force on each wall in the current stage, for [`FailureCause::LoadDrop`].
#[derive(Debug, Default)]
struct PeakForces {
    stage: usize,
    peak: Vec<f64>,
}

impl PeakForces {
    /// The peaks of stage `stage` over its increments written to the result file `path`.
    fn written(path: &Path, stage: usize) -> Result<PeakForces, Error> {
        let history = read_history(path)?;
        let forces = history.wall("wall_normal_force");
        let mut peak = Vec::new();
        for (r, (&s, &k)) in history
            .int("stage")
            .iter()
            .zip(history.int("stage_increment"))
            .enumerate()
        {
            // The stage's start (stage increment 0) is not one of its increments.
            if s as usize == stage && k > 0 {
                peak.resize(forces[r].len(), 0.0);
                for (p, f) in peak.iter_mut().zip(&forces[r]) {
                    *p = f64::max(*p, *f);
                }
            }
        }
        Ok(PeakForces { stage, peak })
    }

    /// The load drop that `report` shows, if its stage watches for one.
    fn drop(&mut self, sim: &Simulation, report: &IncrementReport) -> Option<FailureCause> {
        let fraction = watched_drop(sim, report.stage)?;
        let force = &report.measurements.wall_normal_force;
        if self.stage != report.stage || self.peak.len() != force.len() {
            *self = PeakForces {
                stage: report.stage,
                peak: vec![0.0; force.len()],
            };
        }
        let walls = &sim.state.walls.walls;
        for (w, wall) in walls.iter().enumerate() {
            if !pushed(sim, report.stage, w) {
                continue;
            }
            self.peak[w] = self.peak[w].max(force[w]);
            if force[w] < fraction * self.peak[w] {
                return Some(FailureCause::LoadDrop {
                    wall: wall.name.clone(),
                    peak: self.peak[w],
                    force: force[w],
                });
            }
        }
        None
    }

    /// Each wall's force below which the next increment shows the load drop: its stage's
    /// `failure_drop` times the wall's peak so far in the stage, for the walls it pushes; zero
    /// for the others, and for all at a stage's first increment.
    fn floors(&self, sim: &Simulation) -> Vec<f64> {
        let stage = sim.state.stage;
        let walls = sim.state.walls.len();
        match watched_drop(sim, stage) {
            Some(fraction) if self.stage == stage && self.peak.len() == walls => (0..walls)
                .map(|w| match pushed(sim, stage, w) {
                    true => fraction * self.peak[w],
                    false => 0.0,
                })
                .collect(),
            _ => vec![0.0; walls],
        }
    }
}

/// One line per increment: solver effort, contacts, and the wall and macro stresses.
pub fn log_line(sim: &Simulation, r: &IncrementReport) -> String {
    let m = &r.measurements;
    let walls: Vec<String> = sim
        .state
        .walls
        .walls
        .iter()
        .zip(&m.wall_stress)
        .map(|(w, s)| format!("{} {:.4e}", w.name, s))
        .collect();
    // The last residuals show the rate of convergence.
    let tail = &sim.last_residuals[sim.last_residuals.len().saturating_sub(5)..];
    let residuals: Vec<String> = tail.iter().map(|v| format!("{v:.1e}")).collect();
    format!(
        "inc {:>5} stage {}: {} it, {} pass, {} cuts, residuals [{}], {} negative \
         pivots; contacts {} \
         (+{} -{}), broken {}; walls [{}] Pa; macro xx {:.4e} yy {:.4e} xy {:.2e} Pa; \
         energy: work {:.4e} J, imbalance {:.1e}",
        r.increment,
        r.stage,
        r.newton_iterations,
        r.topology_passes,
        r.cuts,
        residuals.join(" "),
        r.negative_pivots
            .map_or_else(|| "uncounted".to_string(), |n| n.to_string()),
        m.grain_contacts + m.wall_contacts,
        r.contacts_made,
        r.contacts_lost,
        m.broken_bonds,
        walls.join(", "),
        m.macro_stress[0][0],
        m.macro_stress[1][1],
        m.macro_stress[0][1],
        r.energy.work,
        r.energy.imbalance(),
    )
}

/// The run's timers and counters.
pub fn summary(sim: &Simulation) -> String {
    let t = &sim.stats.timers;
    let c = &sim.stats.counters;
    format!(
        "time [s]: detection {:.3}, return map {:.3}, assembly {:.3}, symbolic {:.3}, \
         factorisation {:.3}, solve {:.3}, topology {:.3}, output {:.3}\n\
         counts: {} increments, {} {}, {} symbolic and {} numeric \
         factorisations, {} solves, {} passes, \
         {} friends rebuilds, contacts +{} -{}, {} bonds broken, {} cuts",
        t.detection,
        t.return_map,
        t.assembly,
        t.symbolic,
        t.factorisation,
        t.solve,
        t.topology,
        t.output,
        c.increments,
        c.newton_iterations,
        match sim.config.strategy {
            Strategy::Minimise => "Newton iterations",
            Strategy::Relaxation => "sweeps",
        },
        c.symbolic_factorisations,
        c.numeric_factorisations,
        c.solves,
        c.topology_passes,
        c.friends_rebuilds,
        c.contacts_made,
        c.contacts_lost,
        c.bonds_broken,
        c.cuts
    )
}

/// The `failure_drop` of stage `stage`, where it is loaded until failure.
fn watched_drop(sim: &Simulation, stage: usize) -> Option<f64> {
    let stage = sim.stages.get(stage)?;
    stage.failure_drop.filter(|_| stage.until_failure)
}

/// Whether stage `stage` pushes wall `w`: displacement-controlled and moved.
fn pushed(sim: &Simulation, stage: usize, w: usize) -> bool {
    sim.state.walls.walls[w].control == WallControl::Displacement
        && sim.stages[stage].normal_move[w] != 0.0
}

/// The failure in `(increment, stage)`, with the loads of the simulation's committed state.
fn failure(sim: &Simulation, cause: FailureCause, (increment, stage): (usize, usize)) -> Failure {
    let state = &sim.state;
    let membranes = state.membranes.iter().map(|m| (m.name.clone(), m.pressure));
    let walls = state
        .walls
        .walls
        .iter()
        .filter(|w| w.control == WallControl::Stress)
        .map(|w| (w.name.clone(), w.stress));
    Failure {
        increment,
        stage: sim.stages[stage].name.clone(),
        cause,
        last_increment: state.increment,
        carried: membranes.chain(walls).collect(),
    }
}
