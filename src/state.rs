//! The state of a run: exactly what is written to HDF5 after each increment and read back to
//! resume. Everything else (factorisations, buffers, the pattern) is workspace, rebuilt from it.

use crate::contact::ContactSet;
use crate::geometry::{GrainSet, WallSet};
use crate::measure::Measurements;

/// Where a run stands: committed positions, wall states, contact history, and the place in
/// the load program.
#[derive(Debug, Clone, PartialEq)]
pub struct State {
    /// Load increments completed so far.
    pub increment: usize,
    /// Index of the current stage of the load program.
    pub stage: usize,
    /// Increments completed within the current stage.
    pub stage_increment: usize,
    /// Grains at the last converged increment.
    pub grains: GrainSet,
    /// Walls at the last converged increment (positions, slides, applied stresses).
    pub walls: WallSet,
    /// Contacts and their committed history; bonds broken so far.
    pub contacts: ContactSet,
    /// Grain centres when the friends lists were last made: rebuilding the lists from them
    /// gives the same pattern, so a resumed run repeats the uninterrupted one exactly.
    pub friends_reference: Vec<[f64; 2]>,
    /// Wall positions (normal, along) when the friends lists were last made.
    pub friends_wall_reference: Vec<[f64; 2]>,
}

/// What one converged increment reports: the state's measurements and how the solver did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct IncrementReport {
    /// The increment (1-based).
    pub increment: usize,
    /// The stage it belongs to.
    pub stage: usize,
    /// Macro measurements of the converged state.
    pub measurements: Measurements,
    /// Final relative residual `|R|_inf / F_ref`.
    pub residual: f64,
    /// Newton iterations over all topology passes and sub-steps.
    pub newton_iterations: usize,
    /// Topology passes.
    pub topology_passes: usize,
    /// Times the increment was halved.
    pub cuts: u32,
    /// Contacts made in this increment.
    pub contacts_made: usize,
    /// Contacts lost in this increment.
    pub contacts_lost: usize,
    /// Bonds broken in this increment.
    pub bonds_broken: usize,
}
