//! The grainstat library from Python (the module `grainstat._grainstat`, which the package
//! `grainstat` re-exports): scenes from files, TOML text or dicts; samples prepared; runs
//! stepped one increment at a time or to the end through the library's own
//! [`grainstat::run::Stepper`], with the same HDF5 output and resume as `grainstat run`;
//! states, measurements and reports as numpy arrays; result files read back into the same
//! objects. Errors are Python exceptions with the message the command line prints.

mod convert;
mod results;
mod scene;
mod simulation;
mod state;

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

create_exception!(
    _grainstat,
    GrainstatError,
    PyException,
    "Every error grainstat raises; its message is the one the command line prints."
);
create_exception!(
    _grainstat,
    InputError,
    GrainstatError,
    "Bad input (a scene, solver settings, a sample or result file): the attributes `file`, \
     `line` and `key` say where, `message` what is wrong (exit status 2 of the command line)."
);
create_exception!(
    _grainstat,
    NumericError,
    GrainstatError,
    "The solver failed (exit status 3 of the command line); the last converged state has been \
     written to the result file."
);
create_exception!(
    _grainstat,
    FileError,
    GrainstatError,
    "Reading or writing a file failed (exit status 4 of the command line)."
);

/// The Python exception of a grainstat error, with the command line's message.
pub(crate) fn to_py(err: grainstat::Error) -> PyErr {
    match err {
        grainstat::Error::Input(e) => input_error(e),
        grainstat::Error::Numeric(e) => NumericError::new_err(e.to_string()),
        e @ grainstat::Error::Io { .. } => FileError::new_err(e.to_string()),
    }
}

/// An [`InputError`] exception carrying where the problem is as attributes.
pub(crate) fn input_error(e: grainstat::InputError) -> PyErr {
    let err = InputError::new_err(e.to_string());
    Python::attach(|py| {
        let value = err.value(py);
        // Setting attributes on a fresh exception instance cannot fail.
        let _ = value.setattr("file", &e.file);
        let _ = value.setattr("line", e.line);
        let _ = value.setattr("key", &e.key);
        let _ = value.setattr("message", &e.message);
    });
    err
}

/// Exact quasi-static discrete element analysis of granular materials in 2D.
#[pymodule]
fn _grainstat(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("GrainstatError", py.get_type::<GrainstatError>())?;
    m.add("InputError", py.get_type::<InputError>())?;
    m.add("NumericError", py.get_type::<NumericError>())?;
    m.add("FileError", py.get_type::<FileError>())?;
    m.add_class::<scene::Scene>()?;
    m.add_class::<simulation::Simulation>()?;
    m.add_class::<state::State>()?;
    m.add_class::<state::Grains>()?;
    m.add_class::<state::Contacts>()?;
    m.add_class::<state::Walls>()?;
    m.add_class::<state::Measurements>()?;
    m.add_class::<state::Energy>()?;
    m.add_class::<state::Report>()?;
    m.add_class::<simulation::Sample>()?;
    m.add_class::<results::Results>()?;
    m.add_function(wrap_pyfunction!(scene::default_solver, m)?)?;
    m.add_function(wrap_pyfunction!(simulation::generate, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
