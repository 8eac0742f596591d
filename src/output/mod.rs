//! Output of a run. The result file is HDF5 ([`hdf5_file`]): the run's static data once,
//! then one group per written increment, a `/history` table for curves and a `/summary` of
//! the solver's timers and counters. The layout is documented for Python users in
//! `docs/hdf5-layout.md`. From a result file: the curves as CSV ([`curves`]), pictures as
//! SVG and PNG ([`plot`]) and XDMF for ParaView ([`xdmf`]).

pub mod curves;
pub(crate) mod h5;
pub mod hdf5_file;
pub mod plot;
pub mod xdmf;

pub use hdf5_file::{
    info, read_history, read_increments, read_mechanism, read_state, read_summary, History,
    Mechanism, ResultFile, RunHeader, WallHeader,
};
