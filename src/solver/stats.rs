//! Per-stage timers and counters: speed is visible from the first run.

use std::time::{Duration, Instant};

/// Wall-clock seconds spent in each stage of the increment pipeline.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StageTimers {
    /// Friends lists (cell grid) and contact detection.
    pub detection: f64,
    /// Contact laws: kinematics and return map.
    pub return_map: f64,
    /// Scattering residual and tangent into the pattern.
    pub assembly: f64,
    /// Symbolic factorisations.
    pub symbolic: f64,
    /// Numeric factorisations.
    pub factorisation: f64,
    /// Triangular solves.
    pub solve: f64,
    /// Contacts made, lost and engaged, bonds broken.
    pub topology: f64,
    /// Writing results.
    pub output: f64,
}

/// Counts of the work done.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    /// Load increments converged.
    pub increments: usize,
    /// Newton iterations of the minimisation, or sweeps of the relaxation.
    pub newton_iterations: usize,
    /// Symbolic factorisations (one per pattern).
    pub symbolic_factorisations: usize,
    /// Numeric factorisations.
    pub numeric_factorisations: usize,
    /// Linear solves.
    pub solves: usize,
    /// Passes (see [`crate::state::IncrementReport::topology_passes`]).
    pub topology_passes: usize,
    /// Friends-list rebuilds after the first lists.
    pub friends_rebuilds: usize,
    /// Contacts made.
    pub contacts_made: usize,
    /// Contacts lost.
    pub contacts_lost: usize,
    /// Bonds broken.
    pub bonds_broken: usize,
    /// Increment halvings.
    pub cuts: usize,
}

/// Timers and counters of a run.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SolverStats {
    /// Seconds per stage.
    pub timers: StageTimers,
    /// Work counts.
    pub counters: Counters,
}

/// Seconds since `since`: `let t = Instant::now(); ...; timers.solve += secs(t)`.
pub fn secs(since: Instant) -> f64 {
    Duration::as_secs_f64(&since.elapsed())
}
