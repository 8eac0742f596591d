//! The increment as one minimisation (the global solver): it finds the equilibrium the
//! grain-by-grain relaxation finds when that is run to a tight tolerance, on the crystal and
//! on a prepared Hertz sample, in a handful of iterations with one factorisation each.

mod common;

use common::{grainstat, stderr};
use grainstat::output::read_history;
use grainstat::scene::build_grains;
use grainstat::simulation::Simulation;
use grainstat::solver::{SolverConfig, Strategy};
use std::path::Path;

/// Each increment's iterations (or sweeps), and the final grain positions and wall stresses.
fn run_crystal(config: SolverConfig) -> (Vec<usize>, Vec<[f64; 2]>, Vec<f64>) {
    let scene = grainstat::samples::crystal_biaxial(9, 8, 1e6, 3e6);
    let grains = build_grains(&scene.grains, Path::new("."), "crystal").unwrap();
    let mut sim = Simulation::new(&scene, grains, config, "crystal").unwrap();
    let mut iterations = Vec::new();
    while !sim.is_finished() {
        iterations.push(sim.run_increment().unwrap().newton_iterations);
    }
    let stress = sim.measure().wall_stress;
    (iterations, sim.state.grains.position.clone(), stress)
}

/// The relaxation swept until its residual is at `tolerance`: an answer found without the
/// minimisation.
fn relaxed(tolerance: f64) -> SolverConfig {
    SolverConfig {
        strategy: Strategy::Relaxation,
        sweeps: 1_000_000,
        tolerance,
        ..SolverConfig::default()
    }
}

/// The cemented crystal is linear while no bond breaks: its potential is quadratic but for
/// the walls' follower loads (a side wall's load follows the length the top and bottom give
/// it), and the minimisation takes a step or two per increment, with the answer of the
/// relaxation run to 1e-10 (2 s; to 1e-12, near its round-off floor, it takes minutes).
#[test]
fn the_crystal_takes_a_step_or_two_per_increment_with_the_relaxations_answer() {
    let (relaxed_sweeps, relaxed_at, relaxed_stress) = run_crystal(relaxed(1e-10));
    let (its, at, stress) = run_crystal(SolverConfig::default());
    assert_eq!(its.len(), relaxed_sweeps.len());
    let mut sorted = its.clone();
    sorted.sort_unstable();
    assert!(
        sorted[sorted.len() / 2] <= 2,
        "iterations per increment {its:?}"
    );
    let r = 1e-4;
    let moved = at
        .iter()
        .zip(&relaxed_at)
        .map(|(a, b)| (a[0] - b[0]).hypot(a[1] - b[1]) / r)
        .fold(0.0, f64::max);
    assert!(moved < 1e-8, "grains apart by {moved:e} radii");
    for (a, b) in stress.iter().zip(&relaxed_stress) {
        assert!(
            (a - b).abs() <= 1e-7 * b.abs(),
            "wall stress {a:e} against {b:e}"
        );
    }
}

/// A dense Hertz sample (sand, table 1) prepared to 1 bar and pushed down in the thesis's
/// load steps of 4e-5 strain, the sides at 1 bar: the minimisation converges in every
/// increment in a handful of iterations (a median of 8 measured), and agrees with the
/// relaxation run to 1e-10 on the stresses to within what the tolerance and the shear made
/// before a contact touched (counted by the relaxation from where a sweep finds it touching,
/// estimated on the straight way by the minimisation) allow. The relaxation's steps are
/// truncated at 1e-3 radii, so it finds a contact near where its surfaces touch: at its
/// default 0.05 a contact found deep in a long step drifts its stresses 1e-4 away by the
/// 14th increment.
#[test]
fn a_hertz_biaxial_converges_in_a_handful_of_iterations_with_the_relaxations_answer() {
    let dir = tempfile::tempdir().unwrap();
    let sample = dir.path().join("sand.h5");
    let sample_scene = dir.path().join("sample.toml");
    let text = std::fs::read_to_string("examples/sample-sand.toml")
        .unwrap()
        .replace("grains = 1000", "grains = 300");
    std::fs::write(&sample_scene, text).unwrap();
    let out = grainstat(&[
        "generate",
        sample_scene.to_str().unwrap(),
        "-o",
        sample.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    // The benchmark scene on this sample, in 15 steps of 4e-5 of its height (5.8 mm).
    let scene = dir.path().join("biaxial.toml");
    let text = std::fs::read_to_string("examples/biaxial-sand-steps.toml")
        .unwrap()
        .replace("../samples/sand.h5", sample.to_str().unwrap())
        .replace("increments = 50", "increments = 15")
        .replace("top = 2.125e-5", "top = 3.5e-6");
    std::fs::write(&scene, text).unwrap();
    let relaxation = dir.path().join("relaxation.toml");
    std::fs::write(
        &relaxation,
        "strategy = \"relaxation\"\nsweeps = 1000000\ntolerance = 1e-10\ntruncate = 1e-3\n",
    )
    .unwrap();
    let run = |solver: Option<&Path>, name: &str| {
        let result = dir.path().join(name);
        let mut args = vec![
            "run",
            scene.to_str().unwrap(),
            "-o",
            result.to_str().unwrap(),
            "--quiet",
            "--no-plot",
        ];
        if let Some(s) = solver {
            args.extend(["--solver", s.to_str().unwrap()]);
        }
        let out = grainstat(&args);
        assert!(out.status.success(), "{name}: {}", stderr(&out));
        read_history(&result).unwrap()
    };
    let minimised = run(None, "minimise.h5");
    let reference = run(Some(&relaxation), "relaxation.h5");
    let iterations = minimised.int("newton_iterations")[1..].to_vec();
    assert_eq!(iterations.len(), 15);
    let mut sorted = iterations.clone();
    sorted.sort_unstable();
    assert!(
        sorted[sorted.len() / 2] <= 12,
        "iterations per increment {iterations:?}"
    );
    for name in ["macro_stress_xx", "macro_stress_yy"] {
        let (a, b) = (minimised.float(name), reference.float(name));
        for (k, (x, y)) in a.iter().zip(b).enumerate() {
            assert!(
                (x - y).abs() <= 1e-4 * y.abs(),
                "{name} at increment {k}: {x:e} against {y:e}"
            );
        }
    }
}

/// A disc under a stress-controlled wall with nothing beneath: the wall's load does work
/// without end, the potential falls as far as the disc goes, and the minimisation names it
/// as no equilibrium near, not as a solver that gave up.
#[test]
fn a_disc_with_nothing_beneath_is_no_equilibrium_near() {
    let scene = grainstat::scene::parse_scene(common::FALLING_DISC, "falling-disc").unwrap();
    let grains = build_grains(&scene.grains, Path::new("."), "falling-disc").unwrap();
    let mut sim = Simulation::new(&scene, grains, SolverConfig::default(), "falling-disc").unwrap();
    match sim.run_increment() {
        Err(grainstat::NumericError::NoEquilibrium { grains, .. }) => assert_eq!(grains, [0]),
        other => panic!("expected no equilibrium near, got {other:?}"),
    }
}

/// The run that ends on no equilibrium near writes the mechanism to the result file, as the
/// descent carried it from the last state in equilibrium, and pictures it: the disc, carried
/// down, out from under the wall, by more than its radius.
#[test]
fn a_run_that_finds_no_equilibrium_near_keeps_and_pictures_the_mechanism() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("falling-disc.toml");
    let text =
        common::FALLING_DISC.replace("increments = 1", "increments = 1\nuntil_failure = true");
    std::fs::write(&scene, text).unwrap();
    let result = dir.path().join("falling-disc.h5");
    let out = grainstat(&[
        "run",
        scene.to_str().unwrap(),
        "-o",
        result.to_str().unwrap(),
        "--quiet",
    ]);
    let said = stderr(&out);
    assert_eq!(out.status.code(), Some(0), "{said}");
    assert!(said.contains("no equilibrium near"), "{said}");
    let mechanism = grainstat::output::read_mechanism(&result).unwrap().unwrap();
    assert_eq!(mechanism.increment, 1);
    assert_eq!(mechanism.grains, [0]);
    assert!(mechanism.description.contains("no equilibrium near"));
    let [dx, dy] = mechanism.displacement[0];
    assert!(
        dy < -1e-4 && dy.abs() > 10.0 * dx.abs(),
        "carried by [{dx:e}, {dy:e}]"
    );
    let plots = grainstat::output::plot::default_dir(&result);
    assert!(plots.join("mechanism-00000000.png").is_file());
}
