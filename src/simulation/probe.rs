//! The minimisation's potential and first matrix handed out on their own, for timing its
//! evaluations and factorisations (`benches/minimise.rs`, `examples/factorisation.rs`).

use super::{LoadStep, Simulation};
use crate::assembly::Pattern;
use crate::solver::minimise::{self, Potential};
use crate::{Error, InputError};
use std::sync::Arc;

impl Simulation {
    /// `f` of the potential the next increment's minimisation lowers, as its first iteration
    /// meets it (every friends-list pair engaged, the lag fresh), and of its pattern. The
    /// simulation is left ready for that increment.
    pub fn with_next_potential<R>(
        &mut self,
        f: impl FnOnce(&mut dyn Potential, &Pattern) -> R,
    ) -> Result<R, Error> {
        let step = self.start_next_increment()?;
        self.fresh_lag();
        let pattern = Arc::clone(&self.pattern);
        let mut eq = self.equations(&step);
        Ok(f(&mut eq, &pattern))
    }

    /// The matrix the next increment's minimisation factorises first, on the simulation's
    /// pattern: the projected Hessian of its potential at its starting point, regularised as
    /// the minimisation regularises it with `lambda` (at least the scene's `lambda_min`).
    /// For timing the factorisations of a sample's own matrix (`examples/factorisation.rs`);
    /// the simulation is left ready for that increment.
    pub fn next_tangent(&mut self, lambda: f64) -> Result<(Arc<Pattern>, Vec<f64>), Error> {
        let step = self.start_next_increment()?;
        let u = self.start_point(&step, 1.0)?;
        let pattern = Arc::clone(&self.pattern);
        let lambda = lambda.max(self.config.lambda_min);
        let mut residual = vec![0.0; self.dofs.len];
        let mut values = vec![0.0; pattern.nnz()];
        let mut shift = vec![0.0; self.dofs.len];
        let mut eq = self.equations(&step);
        Potential::evaluate(&mut eq, &u, &mut residual, Some(&mut values), true)?;
        minimise::regularise(&eq, &values, &pattern.diagonal, lambda, &mut shift);
        for (&slot, add) in pattern.diagonal.iter().zip(&shift) {
            values[slot] += add;
        }
        Ok((pattern, values))
    }

    /// The next increment's controls, glue and load step applied, every friends-list pair
    /// engaged: where its minimisation starts.
    /// A simulation whose load program is done has none: that is refused.
    fn start_next_increment(&mut self) -> Result<LoadStep, Error> {
        if self.is_finished() {
            return Err(InputError::new(
                &self.name,
                "the load program is done: no increment follows to start",
            )
            .at_key("stages")
            .into());
        }
        self.apply_stage_controls()?;
        self.apply_glue()?;
        let step = self.next_load_step();
        self.start_step();
        self.start_newton()?;
        self.engage_pairs();
        Ok(step)
    }
}
