//! Solution strategies: global Newton over all unknowns with a sparse direct solver
//! (faer Cholesky or LU), and the thesis's grain-by-grain relaxation; their settings,
//! statistics and the linear-solver wrapper.

pub mod config;
pub mod dynamic;
pub mod krylov;
pub mod linear;
pub mod newton;
pub mod relaxation;
pub mod stats;

pub use config::{LinearKind, SolverConfig, Strategy};
pub use linear::LinearSolver;
pub use newton::{Equations, NewtonOutcome, NewtonSettings};
pub use stats::{Counters, SolverStats, StageTimers};
