//! The stability indicator: the negative pivots of the tangent at each converged increment
//! (displacement-controlled walls freed under their reactions) are zero while a biaxial test
//! hardens and turn positive where it passes its peak and softens.

use grainstat::geometry::WallControl;
use grainstat::samples;
use grainstat::scene::{build_grains, Scene};
use grainstat::simulation::Simulation;
use grainstat::solver::SolverConfig;
use std::path::Path;

/// A Hertz patch (12 x 10, 3% vacancies, grain friction 0.2) at 1 bar all round, then its top
/// pushed down 2% of its height in 40 steps with the sides held at 1 bar.
fn biaxial_patch() -> Scene {
    let mut scene = samples::hertz_patch(12, 10, 1, 0.2, 0.03, 0);
    let height = 2e-4 + 3f64.sqrt() * 1e-4 * 11.0;
    let biaxial = &mut scene.stages[1];
    biaxial.stress.clear();
    biaxial
        .control
        .insert("top".into(), WallControl::Displacement);
    biaxial.displacement.insert("top".into(), 0.02 * height);
    biaxial.increments = 40;
    scene
}

#[test]
fn negative_pivots_flag_the_peak_of_a_biaxial_test() {
    let scene = biaxial_patch();
    let grains = build_grains(&scene.grains, Path::new("."), "t").unwrap();
    let mut sim = Simulation::new(&scene, grains, SolverConfig::default(), "t").unwrap();
    let top = sim.state.walls.walls.iter().position(|w| w.name == "top");
    let top = top.unwrap();
    let (mut stress, mut pivots) = (Vec::new(), Vec::new());
    while !sim.is_finished() {
        let r = sim.run_increment().unwrap();
        eprintln!(
            "increment {}: top {:.4e} Pa, {:?} negative pivots",
            r.increment, r.measurements.wall_stress[top], r.negative_pivots
        );
        stress.push(r.measurements.wall_stress[top]);
        pivots.push(r.negative_pivots.expect("counted by default"));
    }
    let peak = (0..stress.len())
        .max_by(|&a, &b| stress[a].total_cmp(&stress[b]))
        .unwrap();
    assert!(peak + 10 < stress.len(), "the test passes its peak");
    assert!(
        stress[stress.len() - 1] < 0.95 * stress[peak],
        "and softens"
    );
    // Zero up to the peak, positive within two increments after it.
    assert!(pivots[..=peak].iter().all(|&n| n == 0), "{pivots:?}");
    let first = pivots
        .iter()
        .position(|&n| n > 0)
        .expect("a negative pivot");
    assert!(first <= peak + 2, "first at {first}, peak at {peak}");
    // Where the sample softens, mostly positive.
    let softening = &pivots[peak + 1..];
    let flagged = softening.iter().filter(|&&n| n > 0).count();
    assert!(
        4 * flagged >= 3 * softening.len(),
        "{flagged} of {} softening increments flagged",
        softening.len()
    );
}

/// The crystal of chapter 5 (21 rows of 15): isotropic 10 bar in 3 increments, then the
/// vertical stress to 40 bar in 6.
fn crystal() -> Scene {
    let mut scene = samples::crystal_biaxial(21, 15, 1e6, 4e6);
    scene.stages[0].increments = 3;
    scene.stages[1].increments = 6;
    scene
}

#[test]
fn a_positive_definite_tangent_factorised_for_the_indicator_makes_the_next_first_step() {
    // The crystal's tangent is positive definite (no rattler, no free rotation): the
    // indicator's factor of it is the next increment's first Newton matrix, so a smooth
    // increment converges in one iteration on one factorisation, the indicator's. The
    // answer is the one the minimisation finds on its own factors, to the tolerance.
    let run = |stability_indicator: bool| {
        let scene = crystal();
        let grains = build_grains(&scene.grains, Path::new("."), "t").unwrap();
        let config = SolverConfig {
            stability_indicator,
            ..SolverConfig::default()
        };
        let mut sim = Simulation::new(&scene, grains, config, "t").unwrap();
        let mut increments = Vec::new();
        while !sim.is_finished() {
            let before = sim.stats.counters.numeric_factorisations;
            let r = sim.run_increment().unwrap();
            let factorisations = sim.stats.counters.numeric_factorisations - before;
            increments.push((r, factorisations));
        }
        increments
    };
    let (held, own) = (run(true), run(false));
    for (k, ((r, factorisations), (mine, _))) in held.iter().zip(&own).enumerate() {
        eprintln!(
            "increment {}: {} iterations, {factorisations} factorisations (indicator off: {} \
             iterations)",
            r.increment, r.newton_iterations, mine.newton_iterations
        );
        assert_eq!(r.negative_pivots, Some(0));
        if k > 0 {
            // Every increment after the first starts on the held factor: its first step
            // factorises nothing, its indicator once, one iteration where the stage goes on
            // and two where a stage starts (no predictor).
            assert!(r.newton_iterations <= 2, "increment {}", r.increment);
            assert_eq!(
                *factorisations, r.newton_iterations,
                "increment {}",
                r.increment
            );
        }
        let (s, t) = (r.measurements.macro_stress, mine.measurements.macro_stress);
        for (a, b) in s.iter().flatten().zip(t.iter().flatten()) {
            assert!((a - b).abs() <= 1e-7 * s[1][1].abs(), "{s:?} against {t:?}");
        }
    }
    let iterations = |runs: &[(grainstat::state::IncrementReport, usize)]| -> usize {
        runs.iter().map(|(r, _)| r.newton_iterations).sum()
    };
    assert!(iterations(&held) < iterations(&own));
}
