//! Solution strategies: global Newton over all unknowns with a sparse direct solver
//! (faer Cholesky or LU), with its settings, statistics and linear-solver wrapper.

pub mod config;
pub mod linear;
pub mod newton;
pub mod stats;

pub use config::{LinearKind, SolverConfig};
pub use linear::LinearSolver;
pub use newton::{Equations, NewtonOutcome, NewtonSettings};
pub use stats::{Counters, SolverStats, StageTimers};
