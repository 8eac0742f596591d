//! The minimisation on Hertz samples: a handful of iterations per increment, one symbolic
//! factorisation per pattern, and samples with rattlers or without friction solve without a
//! singular-matrix failure.

use grainstat::samples;
use grainstat::scene::{build_grains, Scene};
use grainstat::simulation::Simulation;
use grainstat::solver::SolverConfig;
use std::path::Path;

fn simulation(scene: &Scene, config: SolverConfig) -> Simulation {
    let grains = build_grains(&scene.grains, Path::new("."), "patch").unwrap();
    Simulation::new(scene, grains, config, "patch").unwrap()
}

fn tight() -> SolverConfig {
    SolverConfig {
        tolerance: 1e-12,
        ..SolverConfig::default()
    }
}

/// A Hertz patch from first touch to 2 bar, to a tolerance near round-off: once the first two
/// increments have brought it from just touching to 1 bar, each increment takes a handful of
/// iterations (5 to 7 measured).
#[test]
fn the_minimisation_takes_a_handful_of_iterations_per_increment_on_a_hertz_sample() {
    let scene = samples::hertz_patch(12, 10, 1, 0.6, 0.03, 0);
    // Without the stability indicator, whose system with the walls freed has a symbolic
    // factorisation of its own.
    let config = SolverConfig {
        stability_indicator: false,
        ..tight()
    };
    let mut sim = simulation(&scene, config);
    let mut iterations = Vec::new();
    while !sim.is_finished() {
        let report = sim.run_increment().unwrap();
        let h = &sim.last_residuals;
        let printed: Vec<String> = h.iter().map(|r| format!("{r:.1e}")).collect();
        eprintln!(
            "increment {}: {} iterations, residuals {}",
            report.increment,
            report.newton_iterations,
            printed.join(" ")
        );
        if report.increment > 2 {
            iterations.push(report.newton_iterations);
        }
    }
    let most = iterations.iter().copied().max().unwrap_or(0);
    assert!(most <= 8, "iterations per increment {iterations:?}");

    // One symbolic factorisation for the first pattern and one per rebuild of the friends
    // lists, reused by every numeric one.
    let c = sim.stats.counters;
    assert_eq!(c.symbolic_factorisations, 1 + c.friends_rebuilds);
    assert!(c.numeric_factorisations > 10 * c.symbolic_factorisations);
}

#[test]
fn a_sample_with_rattlers_solves_and_its_rattlers_stay_put() {
    let scene = samples::hertz_patch(12, 10, 1, 0.6, 0.03, 25);
    let mut sim = simulation(&scene, SolverConfig::default());
    let rattlers: Vec<usize> = (0..sim.state.grains.len())
        .filter(|&i| sim.state.grains.radius[i] < 0.9e-4)
        .collect();
    assert!(rattlers.len() >= 4, "the sample has rattlers");
    let start: Vec<[f64; 2]> = rattlers
        .iter()
        .map(|&i| sim.state.grains.position[i])
        .collect();
    while !sim.is_finished() {
        sim.run_increment().unwrap();
    }
    for (k, &i) in rattlers.iter().enumerate() {
        let touches = sim
            .state
            .contacts
            .contacts
            .iter()
            .any(|c| c.pair.b == i || c.pair.a == grainstat::geometry::Side::Grain(i));
        if !touches {
            assert_eq!(sim.state.grains.position[i], start[k], "rattler {i} moved");
        }
    }
}

#[test]
fn a_frictionless_sample_solves() {
    let scene = samples::hertz_patch(12, 10, 1, 0.0, 0.0, 0);
    for config in [SolverConfig::default(), tight()] {
        let mut sim = simulation(&scene, config);
        while !sim.is_finished() {
            let report = sim.run_increment().unwrap();
            assert!(report.residual <= 1e-8);
        }
        let sliding = sim
            .state
            .contacts
            .contacts
            .iter()
            .all(|c| c.response.shear_force == 0.0);
        assert!(sliding, "no contact carries shear without friction");
    }
}
