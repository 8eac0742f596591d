//! The minimisation's potential handed out on its own, for timing its evaluations
//! (`benches/minimise.rs`).

use super::Simulation;
use crate::assembly::Pattern;
use crate::contact::Lag;
use crate::solver::minimise::Potential;
use crate::NumericError;
use std::sync::Arc;

impl Simulation {
    /// `f` of the potential the next increment's minimisation lowers, as its first iteration
    /// meets it (every friends-list pair engaged, the lag fresh), and of its pattern. The
    /// simulation is left ready for that increment.
    pub fn with_next_potential<R>(
        &mut self,
        f: impl FnOnce(&mut dyn Potential, &Pattern) -> R,
    ) -> Result<R, NumericError> {
        self.apply_stage_controls()?;
        self.apply_glue()?;
        let step = self.next_load_step();
        self.start_step();
        self.start_newton()?;
        self.engage_pairs();
        for c in &mut self.state.contacts.contacts {
            c.lag = Lag::default();
        }
        let pattern = Arc::clone(&self.pattern);
        let mut eq = self.equations(&step);
        Ok(f(&mut eq, &pattern))
    }
}
