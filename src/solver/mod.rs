//! Solution strategies: global Newton over all unknowns with a sparse direct solver
//! (faer Cholesky or LU), the minimisation of each increment's potential (projected Newton
//! with a Cholesky, in progress), and the thesis's grain-by-grain relaxation; their
//! settings, statistics and the linear-solver wrapper.

pub mod config;
pub mod dynamic;
pub mod krylov;
pub mod linear;
pub mod minimise;
pub mod newton;
pub mod relaxation;
pub mod stats;

pub use config::{LinearKind, SolverConfig, Strategy};
pub use linear::LinearSolver;
pub use minimise::{MinimiseOutcome, MinimiseSettings, Potential};
pub use newton::{Equations, NewtonOutcome, NewtonSettings};
pub use stats::{Counters, SolverStats, StageTimers};
