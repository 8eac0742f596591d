//! A result file read back: its scene, the state after each written increment and the
//! report of each, as the objects a running simulation gives; `/history` as numpy columns.

use crate::convert::{array1, table};
use crate::scene::Scene;
use crate::state::{Report, State};
use crate::{input_error, to_py};
use grainstat::output::hdf5_file::{read_history, read_increments, read_mechanism, read_state};
use grainstat::output::plot::plot;
use grainstat::output::{History, RunHeader};
use grainstat::run::SceneInput;
use pyo3::exceptions::PyKeyError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::{Path, PathBuf};

/// A result file (HDF5) that `grainstat run` or a `Simulation` wrote, read back.
///
/// `Results(path)`; `increments` lists the increments written whole, `state(k)` and
/// `report(k)` give the state and report of one as a `Simulation` gives them, `history`
/// the `/history` table as numpy columns (docs/hdf5-layout.md).
#[pyclass(frozen, module = "grainstat")]
pub struct Results {
    path: PathBuf,
    header: RunHeader,
    increments: Vec<usize>,
    history: History,
}

#[pymethods]
impl Results {
    #[new]
    fn new(py: Python<'_>, path: PathBuf) -> PyResult<Results> {
        py.detach(|| {
            let increments = read_increments(&path)?;
            // The header comes with a state; every file whole enough to read has increment 0
            // or a later one.
            let first = increments.first().copied().unwrap_or(0);
            let (header, _) = read_state(&path, first)?;
            let history = read_history(&path)?;
            Ok(Results {
                path,
                header,
                increments,
                history,
            })
        })
        .map_err(to_py)
    }

    /// The file's path.
    #[getter]
    fn path(&self) -> PathBuf {
        self.path.clone()
    }

    /// The increments written whole, in order.
    #[getter]
    fn increments(&self) -> Vec<usize> {
        self.increments.clone()
    }

    /// The scene the run was made with (its files relative to the result file's folder).
    #[getter]
    fn scene(&self) -> PyResult<Scene> {
        let base = self.path.parent().unwrap_or(Path::new("."));
        let file = self.path.display().to_string();
        let input = SceneInput::parse(&self.header.scene_text, &file, base).map_err(input_error)?;
        Ok(Scene { input })
    }

    /// The solver settings the run was made with (TOML).
    #[getter]
    fn solver_toml(&self) -> &str {
        &self.header.solver_text
    }

    /// The walls' names, in scene order.
    #[getter]
    fn wall_names(&self) -> Vec<String> {
        self.header.walls.iter().map(|w| w.name.clone()).collect()
    }

    /// The membranes' names.
    #[getter]
    fn membrane_names(&self) -> Vec<String> {
        self.header
            .membranes
            .iter()
            .map(|m| m.name.clone())
            .collect()
    }

    /// The regions' names.
    #[getter]
    fn region_names(&self) -> Vec<String> {
        self.header.regions.iter().map(|r| r.name.clone()).collect()
    }

    /// What the run said of the failure it ended with where it found no equilibrium near
    /// (`/failure`; None: none).
    #[getter]
    fn failure(&self) -> PyResult<Option<String>> {
        let mechanism = read_mechanism(&self.path).map_err(to_py)?;
        Ok(mechanism.map(|m| m.description))
    }

    /// The state after increment `increment` (default: the last written).
    #[pyo3(signature = (increment = None))]
    fn state(&self, py: Python<'_>, increment: Option<usize>) -> PyResult<State> {
        let k = self.written(increment)?;
        let (_, state) = py.detach(|| read_state(&self.path, k)).map_err(to_py)?;
        State::of(py, state)
    }

    /// The report of increment `increment` (default: the last written), from its `/history`
    /// row: its `energy.stored_change` is NaN (not in the file).
    #[pyo3(signature = (increment = None))]
    fn report(&self, py: Python<'_>, increment: Option<usize>) -> PyResult<Report> {
        let k = self.written(increment)?;
        let rows = self.history.int("increment");
        let row = rows
            .iter()
            .position(|&r| r == k as i64)
            .ok_or_else(|| PyKeyError::new_err(format!("increment {k} has no /history row")))?;
        Report::of_history(py, &self.history, row)
    }

    /// The reports of every increment written, in order (see `report`).
    fn reports(&self, py: Python<'_>) -> PyResult<Vec<Report>> {
        (0..self.history.len())
            .map(|row| Report::of_history(py, &self.history, row))
            .collect()
    }

    /// The `/history` table: one numpy array per column, one row per increment written
    /// (n,); the per-wall, per-membrane and per-region columns (n, W), (n, M), (n, R).
    /// Units and meanings: docs/hdf5-layout.md.
    #[getter]
    fn history<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let h = &self.history;
        let columns = PyDict::new(py);
        for (name, values) in &h.ints {
            columns.set_item(*name, array1(py, values.clone()))?;
        }
        for (name, values) in &h.floats {
            columns.set_item(*name, array1(py, values.clone()))?;
        }
        let (walls, membranes) = (self.header.walls.len(), self.header.membranes.len());
        for (name, rows) in &h.walls {
            columns.set_item(*name, table(py, name, rows, walls)?)?;
        }
        let pressure = table(py, "membrane_pressure", &h.membrane_pressure, membranes)?;
        columns.set_item("membrane_pressure", pressure)?;
        for (name, rows) in &h.regions {
            columns.set_item(*name, table(py, name, rows, self.header.regions.len())?)?;
        }
        Ok(columns)
    }

    /// Draw the file's pictures as `grainstat plot` does (into `output_dir`, default
    /// NAME-plots beside the file; the grains at `increment`, default the last) and return
    /// the files written.
    #[pyo3(signature = (output_dir = None, increment = None))]
    fn plot(
        &self,
        py: Python<'_>,
        output_dir: Option<PathBuf>,
        increment: Option<usize>,
    ) -> PyResult<Vec<PathBuf>> {
        py.detach(|| plot(&self.path, output_dir.as_deref(), increment))
            .map_err(to_py)
    }

    fn __repr__(&self) -> String {
        format!(
            "Results(path={:?}, scene={:?}, {} increments written)",
            self.path,
            self.header.scene_name,
            self.increments.len()
        )
    }
}

impl Results {
    /// Increment `increment`, which must be written whole; by default the last.
    fn written(&self, increment: Option<usize>) -> PyResult<usize> {
        let last = self.increments.last().copied();
        match increment {
            None => last.ok_or_else(|| PyKeyError::new_err("no increment is written whole")),
            Some(k) if self.increments.binary_search(&k).is_ok() => Ok(k),
            Some(k) => Err(PyKeyError::new_err(format!(
                "increment {k} is not written whole in {}",
                self.path.display()
            ))),
        }
    }
}
