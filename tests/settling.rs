//! Settling by explicit dynamics: an increment that Newton cannot solve from the last
//! equilibrium is run as damped dynamics until the grains are near rest, and Newton then
//! finishes it. On a frictionless Hertz sample, whose equilibrium does not depend on the
//! path, the answer must be the one Newton finds when it is given all the iterations it
//! needs.

use grainstat::samples;
use grainstat::scene::{build_grains, Scene};
use grainstat::simulation::Simulation;
use grainstat::solver::SolverConfig;
use std::path::Path;

fn simulation(scene: &Scene, config: SolverConfig) -> Simulation {
    let grains = build_grains(&scene.grains, Path::new("."), "patch").unwrap();
    Simulation::new(scene, grains, config, "patch").unwrap()
}

#[test]
fn a_settled_increment_ends_in_the_equilibrium_newton_finds() {
    let scene = samples::hertz_patch(12, 10, 1, 0.0, 0.05, 0);
    let tight = SolverConfig {
        tolerance: 1e-10,
        displacement_tolerance: 1e-10,
        ..SolverConfig::default()
    };
    // Newton allowed too few iterations to get anywhere from first touch, and no halving.
    let starved = SolverConfig {
        max_iterations: 2,
        max_cuts: 0,
        ..tight.clone()
    };
    let mut without = simulation(
        &scene,
        SolverConfig {
            settle_after_cuts: 1,
            ..starved.clone()
        },
    );
    assert!(without.run_increment().is_err(), "the starved Newton fails");

    let mut reference = simulation(&scene, tight);
    let mut settled = simulation(&scene, starved);
    for _ in 0..2 {
        let r = reference.run_increment().unwrap();
        let s = settled.run_increment().unwrap();
        assert!(s.settled > 0, "increment {} was settled", s.increment);
        assert!(s.residual <= 1e-10, "residual {}", s.residual);
        let worst = reference
            .state
            .grains
            .position
            .iter()
            .zip(&settled.state.grains.position)
            .map(|(a, b)| (a[0] - b[0]).hypot(a[1] - b[1]))
            .fold(0.0, f64::max);
        assert!(
            worst < 1e-8 * 1e-4,
            "increment {}: grains {worst} m apart",
            r.increment
        );
    }
    assert!(settled.stats.counters.settling_steps > 0);
}
