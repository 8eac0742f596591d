//! Load programs: a stage that turns a wall from stress to displacement control (the
//! biaxial test after its isotropic stage) starts in equilibrium where the stage before ended,
//! a resumed run goes on with the controls of its stage, and a stage cannot load a wall in a
//! way its control at that stage does not allow.

mod common;

use common::{assert_input_error, grainstat, stderr};
use grainstat::output::{read_increments, read_state};
use grainstat::run::start;
use grainstat::scene::{Scene, WallControl};
use grainstat::solver::SolverConfig;
use std::path::Path;

/// The small crystal: isotropic 1 MPa, then the top wall turned to displacement control and
/// pushed in by `push` over `increments`.
fn switching_scene(push: f64, increments: usize) -> Scene {
    let mut scene = grainstat::samples::crystal_biaxial(9, 8, 1e6, 3e6);
    let biaxial = &mut scene.stages[1];
    biaxial.stress.clear();
    biaxial
        .control
        .insert("top".into(), WallControl::Displacement);
    biaxial.displacement.insert("top".into(), push);
    biaxial.increments = increments;
    scene
}

#[test]
fn a_wall_turned_to_displacement_control_holds_the_equilibrium_it_took_over() {
    let scene = switching_scene(0.0, 2);
    assert_eq!(scene.stages[1].control.len(), 1);
    let mut sim = start(&scene, Path::new("switching.toml"), SolverConfig::default()).unwrap();
    let top = sim
        .state
        .walls
        .walls
        .iter()
        .position(|w| w.name == "top")
        .unwrap();
    for _ in 0..2 {
        sim.run_increment().unwrap();
    }
    let before = sim.state.walls.walls[top].clone();
    let stress = sim.measure().wall_stress[top];
    assert!((stress - 1e6).abs() < 1e-6 * 1e6, "top at {stress}");
    // Held in place with nothing moved, the stage changes nothing: the grains stay put.
    let positions = sim.state.grains.position.clone();
    for _ in 0..2 {
        let report = sim.run_increment().unwrap();
        assert_eq!(report.cuts, 0);
    }
    let after = &sim.state.walls.walls[top];
    assert_eq!(after.control, WallControl::Displacement);
    assert_eq!(after.position, before.position);
    let moved = positions
        .iter()
        .zip(&sim.state.grains.position)
        .map(|(a, b)| (a[0] - b[0]).hypot(a[1] - b[1]))
        .fold(0.0, f64::max);
    assert!(moved < 1e-12 * 1e-4, "grains moved {moved}");
    let stress_after = sim.measure().wall_stress[top];
    assert!((stress_after - stress).abs() < 1e-8 * stress);
}

#[test]
fn a_run_resumed_within_the_switched_stage_ends_where_the_whole_run_does() {
    let dir = tempfile::tempdir().unwrap();
    let mut scene = switching_scene(2e-7, 4);
    scene.output.every = 1;
    let scene_path = dir.path().join("switching.toml");
    std::fs::write(&scene_path, toml::to_string(&scene).unwrap()).unwrap();
    let whole = dir.path().join("whole.h5");
    let args = |out: &Path, flag: &str| {
        grainstat(&[
            "run",
            scene_path.to_str().unwrap(),
            flag,
            out.to_str().unwrap(),
            "--quiet",
            "--no-plot",
        ])
    };
    let out = args(&whole, "-o");
    assert!(out.status.success(), "{}", stderr(&out));
    let last = *read_increments(&whole).unwrap().last().unwrap();
    assert_eq!(last, 6);

    // Increment 4 is within the biaxial stage: stop the copy there and go on.
    let resumed = dir.path().join("resumed.h5");
    std::fs::copy(&whole, &resumed).unwrap();
    {
        let file = hdf5::File::open_rw(&resumed).unwrap();
        let increments = file.group("increments").unwrap();
        for name in increments.member_names().unwrap() {
            if name.parse::<usize>().unwrap() > 4 {
                let g = increments.group(&name).unwrap();
                g.delete_attr("complete").unwrap();
            }
        }
    }
    let out = args(&resumed, "--resume");
    assert!(out.status.success(), "{}", stderr(&out));
    let (_, a) = read_state(&whole, last).unwrap();
    let (_, b) = read_state(&resumed, last).unwrap();
    assert!(a == b, "the resumed run ends elsewhere");
    // The top wall was pushed in by the stage's displacement.
    let top = a.walls.walls.iter().find(|w| w.name == "top").unwrap();
    let (_, start) = read_state(&whole, 2).unwrap();
    let top0 = start.walls.walls.iter().find(|w| w.name == "top").unwrap();
    assert!((top.position - top0.position - 2e-7).abs() < 1e-18);
}

#[test]
fn a_stage_loads_each_wall_as_its_control_at_that_stage_allows() {
    let dir = tempfile::tempdir().unwrap();
    // After the switch the top wall is displacement-controlled: no stress for it.
    let mut stressed = switching_scene(1e-7, 2);
    stressed.stages[1].displacement.clear();
    stressed.stages[1].stress.insert("top".into(), 3e6);
    // Only walls have a control.
    let mut roof = switching_scene(1e-7, 2);
    roof.stages[1]
        .control
        .insert("roof".into(), WallControl::Stress);
    let cases = [
        (
            toml::to_string(&stressed).unwrap(),
            vec!["stages[1].stress.top", "displacement-controlled"],
        ),
        (
            toml::to_string(&roof).unwrap(),
            vec!["stages[1].control.roof", "no wall named `roof`"],
        ),
    ];
    for (k, (text, expected)) in cases.iter().enumerate() {
        let path = dir.path().join(format!("bad-{k}.toml"));
        std::fs::write(&path, text).unwrap();
        let out = grainstat(&["run", path.to_str().unwrap(), "--quiet", "--no-plot"]);
        let expected: Vec<&str> = expected.iter().map(|s| &**s).collect();
        assert_input_error(&out, &expected);
    }
}
