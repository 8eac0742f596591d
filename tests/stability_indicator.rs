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
