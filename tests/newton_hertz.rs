//! Newton on Hertz samples: the consistent tangent converges quadratically, the symbolic
//! factorisation is made once per pattern, and samples with rattlers or without friction
//! solve without a singular-matrix failure.

use grainstat::contact::SlipTangent;
use grainstat::samples;
use grainstat::scene::{build_grains, Scene};
use grainstat::simulation::Simulation;
use grainstat::solver::{LinearKind, SolverConfig};
use std::path::Path;

fn simulation(scene: &Scene, config: SolverConfig) -> Simulation {
    let grains = build_grains(&scene.grains, Path::new("."), "patch").unwrap();
    Simulation::new(scene, grains, config, "patch").unwrap()
}

fn tight(linear: LinearKind, slip_tangent: SlipTangent) -> SolverConfig {
    SolverConfig {
        linear,
        slip_tangent,
        tolerance: 1e-12,
        displacement_tolerance: 1e-12,
        ..SolverConfig::default()
    }
}

#[test]
fn newton_converges_quadratically_on_a_hertz_sample() {
    let scene = samples::hertz_patch(12, 10, 1, 0.6, 0.03, 0);
    let mut sim = simulation(&scene, tight(LinearKind::Lu, SlipTangent::Consistent));
    let mut rates = Vec::new();
    while !sim.is_finished() {
        let report = sim.run_increment().unwrap();
        let h = &sim.last_residuals;
        let printed: Vec<String> = h.iter().map(|r| format!("{r:.1e}")).collect();
        eprintln!(
            "increment {}: residuals {}",
            report.increment,
            printed.join(" ")
        );
        // Once the increment's start is behind (the first two bring the sample from just
        // touching to 1 bar), the order of convergence log r_{k+1} / log r_k over the
        // iterations in the asymptotic range: from 1e-1 down to the round-off floor.
        if report.increment > 2 {
            for w in h.windows(2) {
                if w[0] < 1e-1 && w[1] > 1e-11 {
                    rates.push(w[1].ln() / w[0].ln());
                }
            }
        }
    }
    eprintln!("orders of convergence: {rates:.2?}");
    assert!(!rates.is_empty());
    let worst = rates.iter().cloned().fold(f64::INFINITY, f64::min);
    assert!(
        worst > 1.8,
        "order of convergence {worst:.2} (quadratic is 2)"
    );

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
    for config in [
        SolverConfig::default(),
        tight(LinearKind::Lu, SlipTangent::Consistent),
    ] {
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
