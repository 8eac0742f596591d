//! Running a simulation to the end of its load program: write the state every `every`
//! increments (and the last), report each increment, and on failure write the last converged
//! state before returning the error.

use crate::output::{ResultFile, RunHeader};
use crate::scene::{build_grains, Scene};
use crate::simulation::Simulation;
use crate::solver::stats::secs;
use crate::solver::SolverConfig;
use crate::state::IncrementReport;
use crate::Error;
use std::path::Path;
use std::time::Instant;

/// A fresh simulation of the scene read from `scene_path`: from a sample's prepared
/// equilibrium when the scene keeps its walls, else from its grains (files relative to the
/// scene's folder).
pub fn start(scene: &Scene, scene_path: &Path, config: SolverConfig) -> Result<Simulation, Error> {
    let scene_file = scene_path.display().to_string();
    let base = scene_path.parent().unwrap_or(Path::new("."));
    Ok(match (&scene.grains.sample, &scene.grains.walls) {
        // The prepared equilibrium itself: walls kept, contacts with their history.
        (Some(sample), Some(_)) => {
            let sample = crate::sample::read_sample(base.join(sample))?;
            Simulation::from_sample(scene, sample, config, &scene_file)?
        }
        _ => {
            let grains = build_grains(&scene.grains, base, &scene_file)?;
            Simulation::new(scene, grains, config, &scene_file)?
        }
    })
}

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
                // Keep what was computed: the last converged state, if it is not on file yet
                // (the summary goes with it), else the summary of the work spent.
                if let Some(f) = file.as_deref_mut() {
                    match unwritten.take() {
                        Some(last) => f.write_increment(&sim.state, &last, &sim.stats)?,
                        None => f.write_summary(&sim.stats)?,
                    }
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
                sim.stats.timers.output += secs(start);
            }
            unwritten = None;
        } else {
            unwritten = Some(report);
        }
    }
    Ok(())
}
