//! Solver settings: how a scene is solved, read from a file under `solvers/`. Plain data with
//! documented defaults; [`SolverConfig::validate`] says what is out of range.

use super::linear::FillOrdering;
use serde::{Deserialize, Serialize};

/// How the equilibrium of an increment is found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Strategy {
    /// The global solver (the default): the increment as the minimisation of its incremental
    /// potential over all unknowns (the method note's "One load increment"), every
    /// friends-list pair a contact at every iterate, friction as a potential with its normal
    /// force lagged, projected Newton with a Cholesky and an Armijo line search on the
    /// potential, bonds broken one at a time, the load path followed in halves where an
    /// increment does not converge. `"newton"` reads as this too: it is projected Newton,
    /// and solver files written for the global Newton it replaced keep working.
    #[serde(alias = "newton")]
    Minimise,
    /// The thesis's grain-by-grain relaxation: each grain's equilibrium with its neighbours
    /// held fixed (eq. 19), grain after grain, `sweeps` times per increment.
    Relaxation,
}

/// Settings of the global Newton solver the minimisation replaced: a solver file that still
/// sets one is refused, and told so.
pub const REMOVED_SOLVER_KEYS: [&str; 8] = [
    "linear",
    "slip_tangent",
    "displacement_tolerance",
    "line_search",
    "max_topology_passes",
    "settle_after_cuts",
    "settle_steps",
    "settle_tolerance",
];

/// How a scene is solved.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SolverConfig {
    /// Solution strategy. Default: the minimisation.
    #[serde(default = "default_strategy")]
    pub strategy: Strategy,
    /// Relaxation: sweeps over all grains per increment (the thesis's `n_i`, 20 in its
    /// tests); fewer when `tolerance` is met first. Default 20.
    #[serde(default = "default_sweeps")]
    pub sweeps: usize,
    /// Relaxation: the longest step one grain makes in one visit, in mean radii (the
    /// thesis's 'truncate'); a longer one is cut to it and finished in later sweeps.
    /// Default 0.05.
    #[serde(default = "default_truncate")]
    pub truncate: f64,
    /// Equilibrium tolerance: `|R|_inf <= tolerance * F_ref`, `F_ref` the mean contact force.
    /// Default 1e-8.
    #[serde(default = "default_tolerance")]
    pub tolerance: f64,
    /// Newton iterations of the minimisation allowed per pass (a pass ends where a step
    /// reaches the edge of the friends lists). Default 1000: near a limit load the descent is slow before it runs away.
    #[serde(default = "default_max_iterations")]
    pub max_iterations: usize,
    /// Times a step that does not converge may be halved on the way along the increment's
    /// load path before the run stops. Default 8.
    #[serde(default = "default_max_cuts")]
    pub max_cuts: u32,
    /// Friends-list skin, in mean radii. Default 0.5.
    #[serde(default = "default_skin")]
    pub skin: f64,
    /// Smallest Levenberg-Marquardt factor: `K + lambda diag(K)`; it keeps rattlers and free
    /// rotations regular without changing the converged answer. Default 1e-10.
    #[serde(default = "default_lambda_min")]
    pub lambda_min: f64,
    /// Count the negative pivots of an `L D L^T` of the symmetric tangent at each converged
    /// increment (the stability indicator): one more numeric factorisation per increment, in
    /// the minimisation's pattern and analysis, which the next increment's first step solves
    /// with where the tangent is positive definite (until the state is written). Default on.
    #[serde(default = "yes")]
    pub stability_indicator: bool,
    /// The Cholesky's fill-reducing ordering: `"amd"` (faer's approximate minimum degree),
    /// `"metis"` (METIS's nested dissection), or `"auto"`: AMD below 90,000 unknowns
    /// (30,000 grains), METIS from there, the faster on each side as measured. Default `"auto"`.
    #[serde(default)]
    pub ordering: FillOrdering,
}

fn default_strategy() -> Strategy {
    Strategy::Minimise
}
fn default_sweeps() -> usize {
    20
}
fn default_truncate() -> f64 {
    0.05
}
fn default_tolerance() -> f64 {
    1e-8
}
fn default_max_iterations() -> usize {
    1000
}
fn yes() -> bool {
    true
}
fn default_max_cuts() -> u32 {
    8
}
fn default_skin() -> f64 {
    0.5
}
fn default_lambda_min() -> f64 {
    1e-10
}

impl Default for SolverConfig {
    fn default() -> Self {
        toml::from_str("").expect("defaults parse")
    }
}

impl SolverConfig {
    /// Out-of-range settings, as (key, message) pairs.
    pub fn validate(&self) -> Vec<(String, String)> {
        let mut bad = Vec::new();
        let mut positive = |key: &str, v: f64| {
            if !(v.is_finite() && v > 0.0) {
                bad.push((
                    key.to_string(),
                    format!("must be a finite number > 0, not {v}"),
                ));
            }
        };
        positive("tolerance", self.tolerance);
        positive("skin", self.skin);
        positive("lambda_min", self.lambda_min);
        positive("truncate", self.truncate);
        if self.sweeps == 0 {
            bad.push(("sweeps".into(), "must be at least 1".into()));
        }
        if self.max_iterations == 0 {
            bad.push(("max_iterations".into(), "must be at least 1".into()));
        }
        bad
    }
}
