//! Solution strategies: the minimisation of each increment's potential over all unknowns
//! (projected Newton with a sparse Cholesky, faer) and the thesis's grain-by-grain
//! relaxation; their settings, statistics and the linear-solver wrapper.

pub mod config;
pub mod krylov;
pub mod linear;
pub mod minimise;
pub mod relaxation;
pub mod stats;

pub use config::{SolverConfig, Strategy};
pub use linear::{FillOrdering, LinearSolver};
pub use minimise::{MinimiseOutcome, MinimiseSettings, Potential};
pub use stats::{Counters, SolverStats, StageTimers};
