//! Failure loads that do not depend on the increment size (method note, steps 4 and 5): a
//! step that finds no equilibrium near, or breaks a bond, is halved until it changes the load
//! by at most 0.5%, so the load a test fails at is bracketed, not read off the grid of its
//! increments, and a test's peak is read where the halves found it.

mod common;

use grainstat::estimate::{estimate, Peak};
use grainstat::output::curves::Curves;
use grainstat::output::{read_history, read_state, ResultFile};
use grainstat::run::{self, run_to_end, RunEnd};
use grainstat::scene::build_grains;
use grainstat::simulation::Simulation;
use grainstat::solver::SolverConfig;
use std::path::Path;

/// The small cemented annulus raised in `steps` equal steps until it fails
/// ([`common::annulus_to_failure`]): the highest pressure it carried in equilibrium.
fn failure_pressure(steps: usize) -> f64 {
    let mut sim = common::annulus_to_failure(steps);
    let failure = match run_to_end(&mut sim, None, 1, |_, _| {}) {
        Ok(RunEnd::Failed(failure)) => failure,
        other => panic!("{steps} steps: expected the annulus to fail, got {other:?}"),
    };
    let carried = failure.carried.iter().find(|(name, _)| name == "outer");
    carried.expect("the membrane's pressure").1
}

/// In steps of 20 and 10 MPa the annulus fails at the same pressure to within 2%: the
/// highest pressures on the two grids below it are 221 and 231 MPa, 4.3% apart, so the
/// failure found between grid points is what agrees (measured: 236.00 and 236.62 MPa).
#[test]
fn the_cylinder_fails_at_the_same_pressure_when_the_step_is_halved() {
    let coarse = failure_pressure(20);
    let fine = failure_pressure(40);
    for p in [coarse, fine] {
        let on_grid = |step: f64| ((p - 1e6) / step - ((p - 1e6) / step).round()).abs() < 1e-9;
        assert!(
            !on_grid(2e7) && !on_grid(1e7),
            "{p:e} Pa is a point of the grids"
        );
    }
    assert!(
        (coarse / fine - 1.0).abs() < 0.02,
        "{coarse:e} against {fine:e} Pa"
    );
}

/// A hexagonal crystal of 164 cemented grains (21 rows of 8), isotropic at 10 bar, then
/// pushed down by 8% of its height in `steps` equal steps until it fails (the
/// `examples/crystal-failure.toml` test at a quarter of its size): the peak of the last
/// stage as `grainstat plot` estimates it.
fn crystal_peak(steps: usize) -> Peak {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::crystal_to_failure(steps, true);
    let grains = build_grains(&scene.grains, Path::new("."), "crystal").unwrap();
    let mut sim = Simulation::new(&scene, grains, SolverConfig::default(), "crystal").unwrap();
    let path = dir.path().join("crystal.h5");
    let mut file = ResultFile::create(&path, &run::header(&sim, "", "")).unwrap();
    file.write_increment(&sim.state, &run::initial_report(&sim), &sim.stats)
        .unwrap();
    match run_to_end(&mut sim, Some(&mut file), 1, |_, _| {}) {
        Ok(RunEnd::Failed(_)) => {}
        other => panic!("{steps} steps: expected the crystal to fail, got {other:?}"),
    }
    drop(file);
    let history = read_history(&path).unwrap();
    let (header, _) = read_state(&path, sim.state.increment).unwrap();
    let curves = Curves::new(&header, &history);
    estimate(&header, &history, &curves).unwrap().peak.unwrap()
}

/// In 20 and in 40 steps the crystal's peak is the same to within 2% (measured: 513.1 MPa
/// at 6.6% axial strain in both). Its peak is where a bond first breaks in the increment that
/// fails: read at the increments' ends alone it was 497.1 and 511.7 MPa, 2.9% apart, and a
/// lower bound.
#[test]
fn the_peak_of_a_brittle_crystal_does_not_depend_on_the_increment_size() {
    let coarse = crystal_peak(20);
    let fine = crystal_peak(40);
    for peak in [coarse, fine] {
        assert!(peak.reached, "{peak:?}");
    }
    let (a, b) = (coarse.axial_stress, fine.axial_stress);
    assert!((a / b - 1.0).abs() < 0.02, "{a:e} against {b:e} Pa");
}
