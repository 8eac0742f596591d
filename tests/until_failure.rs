//! A stage loaded until failure (`until_failure = true`) ends the run at the increment that
//! finds no equilibrium, as a success that says where and at which loads; in any other
//! stage that increment stays an error.

use grainstat::run::{run_to_end, FailureCause, RunEnd};
use grainstat::scene::build_grains;
use grainstat::simulation::Simulation;
use grainstat::solver::SolverConfig;
use grainstat::{samples, Error, NumericError};
use std::path::Path;

/// The small crystal's biaxial program with a solver that cannot converge: one Newton
/// iteration in one pass towards an unreachable tolerance, no cut-back.
fn run(until_failure: bool) -> (Result<RunEnd, Error>, Simulation) {
    let mut scene = samples::crystal_biaxial(5, 6, 1e6, 3e6);
    for stage in &mut scene.stages {
        stage.until_failure = until_failure;
    }
    let config = SolverConfig {
        tolerance: 1e-30,
        displacement_tolerance: 0.0,
        max_iterations: 1,
        max_topology_passes: 1,
        max_cuts: 0,
        ..SolverConfig::default()
    };
    let grains = build_grains(&scene.grains, Path::new("."), "t").unwrap();
    let mut sim = Simulation::new(&scene, grains, config, "t").unwrap();
    let end = run_to_end(&mut sim, None, 1, |_, _| {});
    (end, sim)
}

#[test]
fn a_stage_loaded_until_failure_ends_there_as_a_success() {
    let (end, sim) = run(true);
    let failure = match end {
        Ok(RunEnd::Failed(failure)) => failure,
        other => panic!("expected the sample's failure, got {other:?}"),
    };
    assert_eq!(failure.increment, 1);
    assert_eq!(failure.last_increment, 0);
    assert_eq!(failure.stage, sim.stages[0].name);
    assert!(matches!(
        failure.cause,
        FailureCause::NoEquilibrium(NumericError::NotConverged { .. })
    ));
    // The loads carried: the stress-controlled walls as they started.
    assert!(!failure.carried.is_empty());
    for (name, stress) in &failure.carried {
        let wall = sim.state.walls.walls.iter().find(|w| &w.name == name);
        assert_eq!(wall.map(|w| w.stress), Some(*stress), "{name}");
    }
    let said = failure.to_string();
    assert!(said.contains("increment 1"), "{said}");
}

#[test]
fn elsewhere_an_increment_that_does_not_converge_is_an_error() {
    let (end, _) = run(false);
    assert!(
        matches!(end, Err(Error::Numeric(NumericError::NotConverged { .. }))),
        "{end:?}"
    );
}
