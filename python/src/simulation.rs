//! A run from Python: begun or resumed as `grainstat run` does it, stepped one increment at
//! a time through the library's [`Stepper`] (the same code path as `grainstat run`), the GIL
//! released while an increment is solved; and a sample prepared as `grainstat generate`
//! prepares it.

use crate::scene::{solver_from_any, Scene};
use crate::state::{Measurements, Report, State};
use crate::to_py;
use grainstat::output::ResultFile;
use grainstat::run::{log_line, resume_run, summary, Stepped, Stepper};
use grainstat::sample::{write_csv, write_sample};
use grainstat::Error;
use pyo3::exceptions::{PyRuntimeError, PyTypeError};
use pyo3::prelude::*;
use pyo3::types::PyBool;
use std::path::PathBuf;

/// A run of a scene's load program.
///
/// `Simulation(scene, solver=None, output=None, every=None, threads=1)` begins one as
/// `grainstat run` does: `scene` is a `Scene`, a path to a scene file or a dict; `solver` is
/// None (the defaults), a path to a solver file (as `--solver`) or a dict of settings that
/// replace the defaults' (`default_solver()` lists them); `output` is the HDF5 result file
/// (None: the scene's `output.file`, else `results/NAME.h5`; False: no file), written with
/// the state before loading as increment 0 and then as `grainstat run` writes it (every
/// `every`-th increment, default the scene's `output.every`, each stage's end and the last);
/// `threads` is the number of worker threads (the results do not depend on it).
/// `Simulation.resume(path)` takes up a run from its result file.
///
/// `step()` solves one increment, `run()` the rest of the load program; `state` and
/// `measure()` read where it stands. While an increment is solved the GIL is released.
#[pyclass(module = "grainstat")]
pub struct Simulation {
    sim: grainstat::simulation::Simulation,
    file: Option<ResultFile>,
    stepper: Stepper,
    pool: rayon::ThreadPool,
    /// Why the run is over before its load program's end: its failure, or the error an
    /// increment raised.
    ended: Option<String>,
    /// The failure the run ended with, in a stage loaded until failure.
    failure: Option<String>,
}

/// A pool of `threads` worker threads (at least one).
fn thread_pool(threads: usize) -> PyResult<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.max(1))
        .build()
        .map_err(|e| PyRuntimeError::new_err(format!("thread pool: {e}")))
}

/// Where a run writes: None for the default, False for no file, else a path.
enum Output {
    Default,
    Nowhere,
    At(PathBuf),
}

fn output_of(output: Option<&Bound<'_, PyAny>>) -> PyResult<Output> {
    match output {
        None => Ok(Output::Default),
        Some(o) if o.is_none() => Ok(Output::Default),
        Some(o) if o.is_instance_of::<PyBool>() => match o.extract::<bool>()? {
            false => Ok(Output::Nowhere),
            true => Err(PyTypeError::new_err(
                "output must be None (the default file), False (no file) or a path",
            )),
        },
        Some(o) => Ok(Output::At(o.extract()?)),
    }
}

impl Simulation {
    fn of(
        sim: grainstat::simulation::Simulation,
        file: Option<ResultFile>,
        every: usize,
        pool: rayon::ThreadPool,
    ) -> PyResult<Simulation> {
        let stepper = Stepper::new(&sim, file.as_ref(), every).map_err(to_py)?;
        Ok(Simulation {
            sim,
            file,
            stepper,
            pool,
            ended: None,
            failure: None,
        })
    }

    /// One increment, the GIL released; the Rust report where it converged.
    fn step_once(&mut self, py: Python<'_>) -> PyResult<Option<grainstat::state::IncrementReport>> {
        if let Some(why) = &self.ended {
            return Err(PyRuntimeError::new_err(format!("the run is over: {why}")));
        }
        if self.sim.is_finished() {
            return Err(PyRuntimeError::new_err(
                "the run is over: its load program is done",
            ));
        }
        let (sim, file, stepper) = (&mut self.sim, &mut self.file, &mut self.stepper);
        let pool = &self.pool;
        let stepped = py.detach(|| pool.install(|| stepper.step(sim, file.as_mut())));
        match stepped {
            Ok(Stepped { report, failure }) => {
                if let Some(failure) = failure {
                    let text = failure.to_string();
                    self.ended = Some(text.clone());
                    self.failure = Some(text);
                }
                Ok(report)
            }
            Err(err) => {
                self.ended = Some(err.to_string());
                Err(to_py(err))
            }
        }
    }
}

#[pymethods]
impl Simulation {
    #[new]
    #[pyo3(signature = (scene, solver = None, output = None, every = None, threads = 1))]
    fn new(
        py: Python<'_>,
        scene: &Bound<'_, PyAny>,
        solver: Option<&Bound<'_, PyAny>>,
        output: Option<&Bound<'_, PyAny>>,
        every: Option<usize>,
        threads: usize,
    ) -> PyResult<Simulation> {
        let input = Scene::from_any(scene)?;
        let (config, solver_text) = solver_from_any(solver)?;
        let output = output_of(output)?;
        let pool = thread_pool(threads)?;
        let every = every.unwrap_or(input.scene.output.every);
        let begun = py.detach(|| {
            pool.install(|| match output {
                Output::Nowhere => Ok((input.start(config)?, None)),
                Output::Default => input
                    .begin_run(config, &solver_text, None)
                    .map(|(s, f)| (s, Some(f))),
                Output::At(path) => input
                    .begin_run(config, &solver_text, Some(path))
                    .map(|(s, f)| (s, Some(f))),
            })
        });
        let (sim, file) = begun.map_err(to_py)?;
        Simulation::of(sim, file, every, pool)
    }

    /// Take up the run in the result file `path` at its last complete increment, as
    /// `grainstat run --resume` does, and write on into it. `scene` (a `Scene`, path or
    /// dict) must be the one the file was made with; None takes the scene stored in the
    /// file. `solver`, `every` and `threads` are as for `Simulation(...)` (`every` defaults
    /// to the scene's `output.every`).
    #[staticmethod]
    #[pyo3(signature = (path, scene = None, solver = None, every = None, threads = 1))]
    fn resume(
        py: Python<'_>,
        path: PathBuf,
        scene: Option<&Bound<'_, PyAny>>,
        solver: Option<&Bound<'_, PyAny>>,
        every: Option<usize>,
        threads: usize,
    ) -> PyResult<Simulation> {
        let input = scene.map(Scene::from_any).transpose()?;
        let (config, _) = solver_from_any(solver)?;
        let pool = thread_pool(threads)?;
        let resumed = py.detach(|| pool.install(|| resume_run(input.as_ref(), config, &path)));
        let (sim, file, scene) = resumed.map_err(to_py)?;
        let every = every.unwrap_or(scene.output.every);
        Simulation::of(sim, Some(file), every, pool)
    }

    /// Solve the next increment and write it to the result file when it is due. Returns
    /// its report; None where the increment found the sample's failure in a stage loaded
    /// until failure (see `failure`). A solver failure raises `NumericError` after the last
    /// converged state is written; the run is then over.
    fn step(&mut self, py: Python<'_>) -> PyResult<Option<Report>> {
        self.step_once(py)?
            .map(|report| Report::of(py, report))
            .transpose()
    }

    /// Solve the rest of the load program, increment by increment as `step()` does, and
    /// return the failure the run ended with (None: the load program was done).
    ///
    /// `progress`: None shows a tqdm bar when tqdm is installed, True requires it, False
    /// shows none. `on_increment` is called with each increment's report. `log` prints the
    /// line `grainstat run` prints for each increment to standard error.
    #[pyo3(signature = (progress = None, on_increment = None, log = false))]
    fn run(
        &mut self,
        py: Python<'_>,
        progress: Option<bool>,
        on_increment: Option<Bound<'_, PyAny>>,
        log: bool,
    ) -> PyResult<Option<String>> {
        let bar = match progress {
            Some(false) => None,
            Some(true) => Some(py.import("tqdm")?),
            None => py.import("tqdm").ok(),
        };
        let bar = match bar {
            Some(tqdm) => {
                let kwargs = pyo3::types::PyDict::new(py);
                kwargs.set_item("total", self.sim.total_increments())?;
                kwargs.set_item("initial", self.sim.state.increment)?;
                kwargs.set_item("unit", "increment")?;
                kwargs.set_item("desc", &self.sim.name)?;
                Some(tqdm.getattr("tqdm")?.call((), Some(&kwargs))?)
            }
            None => None,
        };
        let result = self.run_with(py, bar.as_ref(), on_increment.as_ref(), log);
        if let Some(bar) = bar {
            bar.call_method0("close")?;
        }
        result?;
        Ok(self.failure.clone())
    }

    /// Load wall `wall` (its name) to `stress` [Pa] in the next increment, in place of its
    /// stage's target, and hold it there for the rest of the stage: a load path written in
    /// Python. The wall must be under stress control (`state.walls.control`) in the current
    /// stage, from its start.
    fn set_wall_stress(&mut self, wall: &str, stress: f64) -> PyResult<()> {
        self.sim
            .set_wall_stress(wall, stress)
            .map_err(crate::input_error)
    }

    /// The measurements of the state as it stands: wall forces and stresses, the macro
    /// stress, contact counts, rotations, regions.
    fn measure(&self, py: Python<'_>) -> PyResult<Measurements> {
        let m = py.detach(|| self.pool.install(|| self.sim.measure()));
        Ok(Measurements::of(py, m))
    }

    /// The run's timers and counters, as `grainstat run` prints them at its end.
    fn summary(&self) -> String {
        summary(&self.sim)
    }

    /// Write what is left to write and close the result file (the simulation can be read but
    /// not stepped on). Also at the end of a `with` block.
    fn close(&mut self) {
        if self.file.take().is_some() && self.ended.is_none() && !self.sim.is_finished() {
            self.ended = Some("its result file was closed".into());
        }
    }

    fn __enter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    #[pyo3(signature = (*_args))]
    fn __exit__(&mut self, _args: &Bound<'_, pyo3::types::PyTuple>) {
        self.close();
    }

    /// A copy of the state as it stands (grains, contacts, walls, membranes): it does not
    /// change when the simulation steps on.
    #[getter]
    fn state(&self, py: Python<'_>) -> PyResult<State> {
        State::of(py, self.sim.state.clone())
    }

    /// The scene's name.
    #[getter]
    fn name(&self) -> &str {
        &self.sim.name
    }

    /// Load increments completed.
    #[getter]
    fn increment(&self) -> usize {
        self.sim.state.increment
    }

    /// The current stage's index (the number of stages once the load program is done).
    #[getter]
    fn stage(&self) -> usize {
        self.sim.state.stage
    }

    /// The current stage's name (None once the load program is done).
    #[getter]
    fn stage_name(&self) -> Option<String> {
        let stage = self.sim.stages.get(self.sim.state.stage);
        stage.map(|s| s.name.clone())
    }

    /// Increments of the whole load program.
    #[getter]
    fn total_increments(&self) -> usize {
        self.sim.total_increments()
    }

    /// Whether the run is over: its load program done, or ended by a failure or an error.
    #[getter]
    fn finished(&self) -> bool {
        self.sim.is_finished() || self.ended.is_some()
    }

    /// The failure the run ended with in a stage loaded until failure, as `grainstat run`
    /// prints it (None: no failure).
    #[getter]
    fn failure(&self) -> Option<String> {
        self.failure.clone()
    }

    /// The result file (None: none is written).
    #[getter]
    fn output(&self) -> Option<PathBuf> {
        self.file.as_ref().map(|f| f.path().to_path_buf())
    }

    /// The walls' names, in scene order (the order of every per-wall array).
    #[getter]
    fn wall_names(&self) -> Vec<String> {
        let walls = &self.sim.state.walls.walls;
        walls.iter().map(|w| w.name.clone()).collect()
    }

    fn __repr__(&self) -> String {
        format!(
            "Simulation(name={:?}, increment={}/{}, {} grains)",
            self.sim.name,
            self.sim.state.increment,
            self.sim.total_increments(),
            self.sim.state.grains.len()
        )
    }
}

impl Simulation {
    /// The loop of `run`: increments until the run is over, Ctrl-C heard between them.
    fn run_with(
        &mut self,
        py: Python<'_>,
        bar: Option<&Bound<'_, PyAny>>,
        on_increment: Option<&Bound<'_, PyAny>>,
        log: bool,
    ) -> PyResult<()> {
        while !self.finished() {
            py.check_signals()?;
            let Some(report) = self.step_once(py)? else {
                continue;
            };
            if log {
                eprintln!("{}", log_line(&self.sim, &report));
            }
            if let Some(bar) = bar {
                bar.call_method1("update", (1,))?;
                let contacts = self.sim.state.contacts.len();
                let postfix = format!("residual {:.1e}, {contacts} contacts", report.residual);
                bar.call_method1("set_postfix_str", (postfix,))?;
            }
            if let Some(callback) = on_increment {
                callback.call1((Report::of(py, report)?,))?;
            }
        }
        Ok(())
    }
}

/// A sample prepared by `generate`: its grains in equilibrium at the target stress.
#[pyclass(frozen, module = "grainstat")]
pub struct Sample {
    /// The sample file written.
    #[pyo3(get)]
    path: PathBuf,
    /// The state at the end of the preparation (walls where they ended).
    #[pyo3(get)]
    state: Py<State>,
    /// Its measurements (contacts per grain exclude wall contacts).
    #[pyo3(get)]
    measurements: Py<Measurements>,
    /// Growth steps taken.
    #[pyo3(get)]
    growth_steps: usize,
    /// Relative residual of the final equilibrium.
    #[pyo3(get)]
    residual: f64,
    /// Grains in the sample.
    #[pyo3(get)]
    grains: usize,
}

#[pymethods]
impl Sample {
    fn __repr__(&self) -> String {
        format!(
            "Sample(path={:?}, {} grains, residual {:.1e})",
            self.path, self.grains, self.residual
        )
    }
}

/// Prepare a sample as the scene's `[sample]` section says and write it to `output` (HDF5),
/// as `grainstat generate` does; also as `x,y,r` CSV to `csv`. `scene` is a `Scene`, a path
/// or a dict; `solver` as for `Simulation`. `progress` as for `Simulation.run` (a tqdm bar of
/// the growth steps). The GIL is released while it works.
#[pyfunction]
#[pyo3(signature = (scene, output, solver = None, csv = None, threads = 1, progress = None))]
pub fn generate(
    py: Python<'_>,
    scene: &Bound<'_, PyAny>,
    output: PathBuf,
    solver: Option<&Bound<'_, PyAny>>,
    csv: Option<PathBuf>,
    threads: usize,
    progress: Option<bool>,
) -> PyResult<Sample> {
    let input = Scene::from_any(scene)?;
    let (config, _) = solver_from_any(solver)?;
    let pool = thread_pool(threads)?;
    let tqdm = match progress {
        Some(false) => None,
        Some(true) => Some(py.import("tqdm")?),
        None => py.import("tqdm").ok(),
    };
    let bar: Option<Py<PyAny>> = match tqdm {
        Some(t) => {
            let kwargs = pyo3::types::PyDict::new(py);
            kwargs.set_item("desc", "growing")?;
            kwargs.set_item("unit", "step")?;
            Some(t.getattr("tqdm")?.call((), Some(&kwargs))?.unbind())
        }
        None => None,
    };
    let prepared = py.detach(|| {
        pool.install(|| -> Result<_, Error> {
            // The bar is drawn again at each hundredth of the steps, not at every step.
            let mut drawn = None;
            let prepared = input.prepare_sample(&config, |step, steps| {
                let share = 100 * step / steps.max(1);
                if let (Some(bar), true) = (&bar, drawn != Some(share)) {
                    drawn = Some(share);
                    Python::attach(|py| {
                        let bar = bar.bind(py);
                        // A progress bar that fails to draw stops nothing.
                        let _ = bar.setattr("total", steps);
                        let _ = bar.setattr("n", step);
                        let _ = bar.call_method0("refresh");
                    });
                }
            })?;
            write_sample(&output, &prepared.sample)?;
            if let Some(csv) = &csv {
                write_csv(csv, &prepared.sample.grains)?;
            }
            Ok(prepared)
        })
    });
    if let Some(bar) = &bar {
        bar.bind(py).call_method0("close")?;
    }
    let prepared = prepared.map_err(to_py)?;
    Ok(Sample {
        grains: prepared.sample.grains.len(),
        path: output,
        state: Py::new(py, State::of(py, prepared.state)?)?,
        measurements: Py::new(py, Measurements::of(py, prepared.measurements))?,
        growth_steps: prepared.growth.steps,
        residual: prepared.residual,
    })
}
