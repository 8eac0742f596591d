//! Running a simulation to the end of its load program: write the state every `every`
//! increments (and the last), report each increment, and on failure write the last converged
//! state before returning the error.

use crate::output::{ResultFile, RunHeader};
use crate::simulation::Simulation;
use crate::solver::stats::secs;
use crate::state::IncrementReport;
use crate::Error;
use std::time::Instant;

/// The static data of a simulation's result file.
pub fn header(sim: &Simulation, scene_text: &str, solver_text: &str) -> RunHeader {
    RunHeader {
        scene_name: sim.name.clone(),
        scene_text: scene_text.to_string(),
        solver_text: solver_text.to_string(),
        version: env!("CARGO_PKG_VERSION").to_string(),
        depth: sim.depth,
        radius: sim.state.grains.radius.clone(),
        walls: RunHeader::walls_of(&sim.state.walls),
        fixed_rotations: sim.material.fixed_rotations,
        law: format!("{:?}", sim.material.law).to_lowercase(),
        membranes: sim.state.membranes.clone(),
    }
}

/// The report of the state as it stands (increment 0 of a fresh run).
pub fn initial_report(sim: &Simulation) -> IncrementReport {
    IncrementReport {
        increment: sim.state.increment,
        stage: sim.state.stage,
        measurements: sim.measure(),
        ..Default::default()
    }
}

/// Run the load program to its end. The state is written to `file` after every `every`-th
/// increment and after the last one; the numeric factorisation is refreshed at the same
/// points (file or not), so a run resumed from a written increment repeats the same
/// arithmetic. `on_increment` sees every converged increment.
pub fn run_to_end(
    sim: &mut Simulation,
    mut file: Option<&mut ResultFile>,
    every: usize,
    mut on_increment: impl FnMut(&Simulation, &IncrementReport),
) -> Result<(), Error> {
    let mut unwritten: Option<IncrementReport> = None;
    while !sim.is_finished() {
        let report = match sim.run_increment() {
            Ok(report) => report,
            Err(err) => {
                // Keep what was computed: the last converged state, if it is not on file yet.
                if let (Some(f), Some(last)) = (file.as_deref_mut(), unwritten.take()) {
                    f.write_increment(&sim.state, &last, &sim.stats)?;
                }
                if let Some(f) = file.as_deref_mut() {
                    f.write_summary(&sim.stats)?;
                }
                return Err(err.into());
            }
        };
        on_increment(sim, &report);
        if report.increment % every.max(1) == 0 || sim.is_finished() {
            sim.refresh_factorisation();
            if let Some(f) = file.as_deref_mut() {
                let start = Instant::now();
                f.write_increment(&sim.state, &report, &sim.stats)?;
                f.write_summary(&sim.stats)?;
                sim.stats.timers.output += secs(start);
            }
            unwritten = None;
        } else {
            unwritten = Some(report);
        }
    }
    Ok(())
}
