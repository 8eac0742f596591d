//! Scenes from a file, TOML text or a dict, and solver settings from a file or a dict of
//! overrides: checked as the command line checks them, problems raised with file, key and
//! line.

use crate::convert::toml_table;
use crate::{input_error, to_py};
use grainstat::run::{solver_settings, SceneInput};
use grainstat::scene::parse_solver;
use grainstat::solver::SolverConfig;
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use std::path::{Path, PathBuf};

/// A scene (the TOML file `grainstat run` and `grainstat generate` read), checked.
///
/// Make one with `Scene.from_file(path)`, `Scene.from_toml(text)` or `Scene.from_dict(d)`;
/// a problem raises `InputError` naming the file, the key and the line. `to_dict()` gives
/// the scene as a dict to change and make a new scene from (a parameter sweep).
#[pyclass(frozen, module = "grainstat")]
pub struct Scene {
    pub(crate) input: SceneInput,
}

#[pymethods]
impl Scene {
    /// The scene file at `path`; the files it names (samples, grain CSV) are relative to
    /// its folder.
    #[staticmethod]
    #[pyo3(text_signature = "(path)")]
    fn from_file(path: PathBuf) -> PyResult<Scene> {
        let input = SceneInput::load(&path).map_err(input_error)?;
        Ok(Scene { input })
    }

    /// A scene given as TOML text. `base_dir` is the folder the files it names are relative
    /// to; `name` is what errors call it.
    #[staticmethod]
    #[pyo3(signature = (text, base_dir = PathBuf::from("."), name = "<string>"))]
    fn from_toml(text: &str, base_dir: PathBuf, name: &str) -> PyResult<Scene> {
        let input = SceneInput::parse(text, name, &base_dir).map_err(input_error)?;
        Ok(Scene { input })
    }

    /// A scene given as a dict of the TOML file's tables and keys (as `to_dict()` gives
    /// it). It is written out as TOML and checked as a file is: errors name the key and its
    /// line in that text (`toml`). `base_dir` is the folder the files it names are relative
    /// to.
    #[staticmethod]
    #[pyo3(signature = (scene, base_dir = PathBuf::from("."), name = "<dict>"))]
    fn from_dict(scene: &Bound<'_, PyDict>, base_dir: PathBuf, name: &str) -> PyResult<Scene> {
        let text = toml_text(scene)?;
        let input = SceneInput::parse(&text, name, &base_dir).map_err(input_error)?;
        Ok(Scene { input })
    }

    /// The scene as a dict of its tables and keys (read from its TOML text).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        py.import("tomllib")?
            .call_method1("loads", (self.input.text.as_str(),))
    }

    /// The scene's `name`.
    #[getter]
    fn name(&self) -> &str {
        &self.input.scene.name
    }

    /// The TOML text the scene was read from (stored with the results).
    #[getter]
    fn toml(&self) -> &str {
        &self.input.text
    }

    /// The file problems are reported against.
    #[getter]
    fn file(&self) -> &str {
        &self.input.file
    }

    /// The folder the files the scene names are relative to.
    #[getter]
    fn base_dir(&self) -> PathBuf {
        self.input.base.clone()
    }

    /// Whether the scene prepares a sample (a `[sample]` section, for `generate`) rather
    /// than running a load program.
    #[getter]
    fn is_sample(&self) -> bool {
        self.input.scene.sample.is_some()
    }

    /// The load program's stages as `(name, increments)`.
    #[getter]
    fn stages(&self) -> Vec<(String, usize)> {
        let stages = self.input.scene.stages.iter();
        stages.map(|s| (s.name.clone(), s.increments)).collect()
    }

    /// Increments of the whole load program.
    #[getter]
    fn total_increments(&self) -> usize {
        self.input.scene.stages.iter().map(|s| s.increments).sum()
    }

    fn __repr__(&self) -> String {
        format!(
            "Scene(name={:?}, file={:?}, {} stages)",
            self.input.scene.name,
            self.input.file,
            self.input.scene.stages.len()
        )
    }
}

impl Scene {
    /// A scene from what a Python call was given: a `Scene`, a path to a scene file, or a
    /// dict.
    pub(crate) fn from_any(scene: &Bound<'_, PyAny>) -> PyResult<SceneInput> {
        if let Ok(s) = scene.cast::<Scene>() {
            return Ok(s.get().input.clone());
        }
        if let Ok(dict) = scene.cast::<PyDict>() {
            return Ok(Scene::from_dict(dict, PathBuf::from("."), "<dict>")?.input);
        }
        match scene.extract::<PathBuf>() {
            Ok(path) => Ok(Scene::from_file(path)?.input),
            Err(_) => Err(PyTypeError::new_err(
                "scene must be a Scene, a path to a scene file or a dict",
            )),
        }
    }
}

/// A dict as TOML text.
fn toml_text(dict: &Bound<'_, PyDict>) -> PyResult<String> {
    let table = toml_table(dict, "")?;
    toml::to_string(&table).map_err(|e| PyTypeError::new_err(e.to_string()))
}

/// Solver settings and their TOML text from what a Python call was given: `None` for the
/// defaults, a path to a solver file (as `--solver`), or a dict of keys that replace the
/// defaults' (written out as TOML and checked as a file is: errors name the key and line).
pub(crate) fn solver_from_any(
    solver: Option<&Bound<'_, PyAny>>,
) -> PyResult<(SolverConfig, String)> {
    let Some(solver) = solver.filter(|s| !s.is_none()) else {
        return solver_settings(None).map_err(to_py);
    };
    if let Ok(dict) = solver.cast::<PyDict>() {
        let (_, defaults) = solver_settings(None).map_err(to_py)?;
        let mut table: toml::Table = defaults
            .parse()
            .map_err(|e: toml::de::Error| PyTypeError::new_err(e.to_string()))?;
        table.extend(toml_table(dict, "")?);
        let text = toml::to_string(&table).map_err(|e| PyTypeError::new_err(e.to_string()))?;
        let config = parse_solver(&text, "<solver dict>").map_err(input_error)?;
        return Ok((config, text));
    }
    if solver.is_instance_of::<PyString>() || solver.hasattr("__fspath__")? {
        let path: PathBuf = solver.extract()?;
        return solver_settings(Some(Path::new(&path))).map_err(to_py);
    }
    Err(PyTypeError::new_err(
        "solver must be None, a path to a solver file or a dict of settings",
    ))
}

/// The default solver settings as a dict (`solvers/minimise.toml`): the keys a `solver`
/// dict may set.
#[pyfunction]
pub fn default_solver(py: Python<'_>) -> PyResult<Bound<'_, PyAny>> {
    let (_, text) = solver_settings(None).map_err(to_py)?;
    py.import("tomllib")?.call_method1("loads", (text,))
}
