//! A stage loaded until failure (`until_failure = true`) ends the run at the increment that
//! finds no equilibrium near, or whose bond cascade drops a pushed wall's force below the
//! stage's `failure_drop`, as a success that says where and at which loads; in any other
//! stage that increment stays an error, and so does, in any stage, an increment the solver
//! gave up on.

mod common;

use grainstat::output::{read_state, ResultFile};
use grainstat::run::{self, run_to_end, FailureCause, RunEnd};
use grainstat::scene::{build_grains, parse_scene, Scene};
use grainstat::simulation::Simulation;
use grainstat::solver::SolverConfig;
use grainstat::state::State;
use grainstat::{samples, Error, NumericError};
use std::path::Path;

/// Run `scene` to its end with `config`, every stage loaded until failure or none.
fn run(
    mut scene: Scene,
    config: SolverConfig,
    until_failure: bool,
) -> (Result<RunEnd, Error>, Simulation) {
    for stage in &mut scene.stages {
        stage.until_failure = until_failure;
    }
    let grains = build_grains(&scene.grains, Path::new("."), "t").unwrap();
    let mut sim = Simulation::new(&scene, grains, config, "t").unwrap();
    let end = run_to_end(&mut sim, None, 1, |_, _| {});
    (end, sim)
}

/// A disc under a stress-controlled wall with nothing beneath, the wall's stress raised from
/// 1 to 2 bar: no equilibrium near at any load.
fn falling_disc() -> Scene {
    let text = common::FALLING_DISC
        .replace("length = 2e-4", "length = 2e-4\nstress = 1e5")
        .replace("stress = { top = 1e5 }", "stress = { top = 2e5 }");
    parse_scene(&text, "falling-disc").unwrap()
}

/// The small crystal's biaxial program with a solver that cannot converge: one iteration
/// towards an unreachable tolerance, no halving.
fn starved(until_failure: bool) -> (Result<RunEnd, Error>, Simulation) {
    let config = SolverConfig {
        tolerance: 1e-30,
        max_iterations: 1,
        max_cuts: 0,
        ..SolverConfig::default()
    };
    run(
        samples::crystal_biaxial(5, 6, 1e6, 3e6),
        config,
        until_failure,
    )
}

#[test]
fn a_stage_loaded_until_failure_ends_there_as_a_success() {
    let (end, sim) = run(falling_disc(), SolverConfig::default(), true);
    let failure = match end {
        Ok(RunEnd::Failed(failure)) => failure,
        other => panic!("expected the sample's failure, got {other:?}"),
    };
    assert_eq!(failure.increment, 1);
    assert_eq!(failure.last_increment, 0);
    assert_eq!(failure.stage, sim.stages[0].name);
    assert!(matches!(
        failure.cause,
        FailureCause::NoEquilibrium(NumericError::NoEquilibrium { .. })
    ));
    // The loads carried: the stress-controlled wall as it started.
    assert!(!failure.carried.is_empty());
    for (name, stress) in &failure.carried {
        let wall = sim.state.walls.walls.iter().find(|w| &w.name == name);
        assert_eq!(wall.map(|w| w.stress), Some(*stress), "{name}");
    }
    let said = failure.to_string();
    assert!(said.contains("increment 1"), "{said}");
}

#[test]
fn elsewhere_no_equilibrium_near_is_an_error() {
    let (end, _) = run(falling_disc(), SolverConfig::default(), false);
    assert!(
        matches!(end, Err(Error::Numeric(NumericError::NoEquilibrium { .. }))),
        "{end:?}"
    );
}

#[test]
fn an_increment_the_solver_gives_up_on_is_an_error_in_any_stage() {
    for until_failure in [false, true] {
        let (end, _) = starved(until_failure);
        assert!(
            matches!(end, Err(Error::Numeric(NumericError::NotConverged { .. }))),
            "until failure {until_failure}: {end:?}"
        );
    }
}

/// The cemented crystal of 21 rows of 8 with its long rows at the bottom and top
/// (`common::crystal_to_failure`) pushed down under displacement control until it fails,
/// watching for its top's force to fall below `failure_drop` of its peak. Past the peak its bonds break in a cascade at one wall
/// displacement, through which the top's force falls gradually (measured: to 0.77 of its
/// peak 38 bonds in); followed on, the cascade leaves rubble in which the solver gives up
/// (measured: "did not converge" after 14 halvings, as it still does with
/// `failure_drop = 0.5`, a drop the cascade has not reached by then). The failure stands at
/// the cascade's first equilibrium past the drop, and the test ends there.
#[test]
fn a_bond_cascade_that_drops_the_load_ends_the_test_there() {
    let mut scene = common::crystal_to_failure(20, false);
    scene.stages[1].failure_drop = Some(0.8);
    let (end, sim) = run(scene, SolverConfig::default(), true);
    let failure = match end {
        Ok(RunEnd::Failed(failure)) => failure,
        other => panic!("expected the crystal's brittle failure, got {other:?}"),
    };
    let FailureCause::LoadDrop { wall, peak, force } = &failure.cause else {
        panic!("expected the load drop, got {}", failure.cause);
    };
    assert_eq!(wall, "top");
    assert!(*force < 0.8 * peak, "{force} N against a peak of {peak} N");
    // The drop is the cascade's: bonds broke in the failing increment, which is written.
    assert_eq!(failure.last_increment, failure.increment);
    let broken = &sim.state.contacts.broken_bonds;
    let in_it = broken.iter().filter(|b| b.increment == failure.increment);
    assert!(in_it.count() > 10, "{failure}");
}

/// A run that writes every fifth increment and fails leaves its last complete increment on
/// file as it was computed, though the failing increment committed the halves of its step
/// that converged: the small cemented annulus under a ring membrane raised in 20-MPa steps
/// fails in increment 12 (measured: at 236 MPa, the halves bracketing it), and increment 11,
/// not a write point, is written when the run ends, as it was, not as the halves left it.
#[test]
fn the_last_complete_increment_is_written_as_it_was_computed() {
    let dir = tempfile::tempdir().unwrap();
    let mut sim = common::annulus_to_failure(20);
    let path = dir.path().join("annulus.h5");
    let mut file = ResultFile::create(&path, &run::header(&sim, "", "")).unwrap();
    file.write_increment(&sim.state, &run::initial_report(&sim), &sim.stats)
        .unwrap();
    let mut computed: Vec<State> = Vec::new();
    let end = run_to_end(&mut sim, Some(&mut file), 5, |sim, _| {
        computed.push(sim.state.clone())
    });
    let failure = match end {
        Ok(RunEnd::Failed(failure)) => failure,
        other => panic!("expected the annulus to fail, got {other:?}"),
    };
    drop(file);
    let last = failure.last_increment;
    assert!(last % 5 != 0, "increment {last} is a write point");
    assert_ne!(
        sim.state,
        computed[last - 1],
        "the failing increment committed no half"
    );
    let (_, written) = read_state(&path, last).unwrap();
    // The friction's lag and the energy of the last evaluation are the increment's own,
    // taken afresh in the next: not on file.
    let mut expected = computed[last - 1].clone();
    for c in &mut expected.contacts.contacts {
        (c.lag, c.energy) = (Default::default(), 0.0);
    }
    assert_eq!(written, expected);
}
