//! What several test files share: running the `grainstat` binary, reading its errors, the
//! sand of table 1 and the sandstone of table 8, and samples of it prepared in walls or freed under a membrane,
//! and the small cemented annulus and crystal loaded until they fail.

#![allow(dead_code)] // each test file uses its own part

use grainstat::geometry::WallControl;
use grainstat::geometry::{Membrane, MembraneShape};
use grainstat::sample::prepare::{prepare, PrepareSpec, Prepared, RegionShape};
use grainstat::sample::{SizeDistribution, SizeKind};
use grainstat::samples::{cemented_annulus, crystal_biaxial};
use grainstat::scene::{build_grains, CohesionRadius, LawKind, Scene};
use grainstat::simulation::{MaterialModel, Simulation};
use grainstat::solver::SolverConfig;
use grainstat::state::State;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Run the `grainstat` binary with `args`.
pub fn grainstat(args: &[&str]) -> Output {
    grainstat_command()
        .args(args)
        .output()
        .expect("grainstat runs")
}

/// The `grainstat` binary, started without the test process's open files. libhdf5 opens
/// files without close-on-exec: a child started while another test of the binary has an
/// HDF5 file open would hold that file's lock until it exits, and a test that opens the file
/// meanwhile would find it locked.
pub fn grainstat_command() -> Command {
    use std::os::unix::process::CommandExt;
    let mut command = Command::new(env!("CARGO_BIN_EXE_grainstat"));
    // SAFETY: between fork and exec, only closes this child's descriptors from 3 up (its
    // standard streams are already in place); nothing it runs needs the others.
    unsafe {
        command.pre_exec(|| {
            libc::syscall(libc::SYS_close_range, 3u32, u32::MAX, 0u32);
            Ok(())
        });
    }
    command
}

/// One test at a time, for the tests of a file that open HDF5 files in the test process while
/// others start child processes. A child holds the descriptors it inherits, and with them
/// HDF5's file locks, from its fork until it closes them: at once for [`grainstat_command`],
/// but a loaded machine can pause it before that, and a test that opens such a file
/// meanwhile finds it locked.
pub fn serial() -> std::sync::MutexGuard<'static, ()> {
    static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());
    SERIAL.lock().unwrap_or_else(|e| e.into_inner())
}

/// What a run printed on standard error.
pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// A run that failed on bad input: exit status 2, no panic, and every expected phrase.
pub fn assert_input_error(out: &Output, expected: &[&str]) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(2), "exit status of: {err}");
    assert!(!err.contains("panicked"), "no panic: {err}");
    for e in expected {
        assert!(err.contains(e), "`{e}` in: {err}");
    }
}

/// A small crystal scene (`samples::crystal_biaxial`) written to `dir`, written every
/// `every` increments, with a region about its centre.
pub fn crystal_scene(dir: &Path, every: usize) -> PathBuf {
    let mut scene = grainstat::samples::crystal_biaxial(9, 8, 1e6, 3e6);
    scene.output.every = every;
    scene.regions = vec![grainstat::scene::RegionSpec {
        name: "core".into(),
        min: None,
        max: None,
        center: Some([8e-4, 7.9e-4]),
        radius: Some(4e-4),
        inner_radius: None,
    }];
    let path = dir.join("crystal.toml");
    std::fs::write(&path, toml::to_string(&scene).unwrap()).unwrap();
    path
}

/// Sand, table 1: Hertz-Mindlin contacts, `G_mu` = 1 GPa, `nu_mu` = 0.16, `f_gg''` = 0.6.
pub fn sand() -> MaterialModel {
    MaterialModel {
        law: LawKind::Hertz,
        normal_stiffness: 0.0,
        shear_modulus: 1e9,
        poisson: 0.16,
        friction: 0.6,
        cohesion: 0.0,
        cohesion_radius: CohesionRadius::Mean,
        cohesion_horizontal: 1.0,
        bonded: false,
        fixed_rotations: false,
    }
}

/// Sandstone, table 8: linear contacts, `k_n` = 1 MN/m, cemented.
pub fn sandstone() -> MaterialModel {
    MaterialModel {
        law: LawKind::Linear,
        normal_stiffness: 1e6,
        shear_modulus: 0.0,
        poisson: 0.16,
        friction: 0.6,
        cohesion: 1e8,
        cohesion_radius: CohesionRadius::Mean,
        cohesion_horizontal: 1.0,
        bonded: true,
        fixed_rotations: false,
    }
}

/// The sandstone prepared in `shape` (type A grains, `f_gg' = 0`) to the isotropic `stress`.
pub fn prepared(
    shape: RegionShape,
    aspect: f64,
    grains: usize,
    seed: u64,
    stress: f64,
) -> Prepared {
    let spec = PrepareSpec {
        shape,
        aspect,
        grains,
        distribution: SizeDistribution::new(SizeKind::A, 1e-4, 4.0).unwrap(),
        seed,
        friction: 0.0,
        stress,
        start_fraction: 0.5,
        solid_fraction: 0.75,
        depth: None,
    };
    prepare(
        &spec,
        &sandstone(),
        &SolverConfig::default(),
        "test",
        |_, _| {},
    )
    .unwrap()
}

/// A prepared annulus freed of its ring and plug: a ring membrane at `pressure` all around,
/// the borehole free (the start of the cylinder test, thesis 4.4).
pub fn free_under_membrane(state: &mut State, pressure: f64) {
    state.keep_walls(&[]);
    state.membranes = vec![Membrane {
        name: "outer".into(),
        shape: MembraneShape::Ring { center: [0.0; 2] },
        pressure,
    }];
}

/// A small valid scene (for bad-input tests to spoil): box walls around a crystal, one stage.
pub const BASE: &str = r#"name = "t"
[material]
law = "linear"
normal_stiffness = 1e8
poisson = 0.16
friction = 0.5
[grains.crystal]
rows = 5
columns = 6
radius = 1e-4
[box]
stress_controlled = ["top", "right"]
stress = 1e5
[[stages]]
increments = 2
stress = { top = 2e5, right = 1e5 }
"#;

/// A disc under a stress-controlled wall with nothing beneath: the wall's load does work
/// without end, and no equilibrium is near.
pub const FALLING_DISC: &str = r#"
name = "falling-disc"
[material]
law = "linear"
normal_stiffness = 1e6
poisson = 0.16
friction = 0.5
[grains]
x = [1e-4]
y = [1e-4]
r = [1e-4]
[[walls]]
name = "top"
point = [0.0, 2e-4]
normal = [0.0, -1.0]
control = "stress"
length = 2e-4
[[stages]]
increments = 1
stress = { top = 1e5 }
"#;

/// The small cemented annulus (three to eight grain diameters from the borehole's centre,
/// 200 grains) under a ring membrane raised from 10 bar to 401 MPa in `steps` equal steps,
/// loaded until it fails, clusters breaking out taken out.
pub fn annulus_to_failure_scene(steps: usize) -> Scene {
    let mut scene = cemented_annulus(3.0, 8.0, steps);
    let stage = &mut scene.stages[0];
    stage.stress.insert("outer".into(), 4.01e8);
    stage.until_failure = true;
    stage.breakouts = true;
    scene
}

/// The simulation of [`annulus_to_failure_scene`].
pub fn annulus_to_failure(steps: usize) -> Simulation {
    let scene = annulus_to_failure_scene(steps);
    let grains = build_grains(&scene.grains, Path::new("."), "annulus").unwrap();
    Simulation::new(&scene, grains, SolverConfig::default(), "annulus").unwrap()
}

/// The cemented crystal of 21 rows of 8 (`samples::crystal_biaxial`), isotropic at 10 bar in
/// five increments, then pushed down by 8% of its height under displacement control in
/// `steps` equal steps until it fails. With `short_first` its bottom and top rows are the
/// short ones (164 grains, the bottom and top walls 7 diameters long), else the long ones
/// (168 grains).
pub fn crystal_to_failure(steps: usize, short_first: bool) -> Scene {
    let mut scene = crystal_biaxial(21, 8, 1e6, 1e6);
    scene.name = "crystal-failure".into();
    if short_first {
        let crystal = scene.grains.crystal.as_mut().expect("a crystal");
        crystal.short_first = true;
        let short_row = 2.0 * crystal.radius * (crystal.columns - 1) as f64;
        for wall in scene.walls.iter_mut() {
            if wall.name == "bottom" || wall.name == "top" {
                wall.length = Some(short_row);
            }
        }
    }
    scene.stages[0].increments = 5;
    let stage = &mut scene.stages[1];
    stage.increments = steps;
    stage.stress.clear();
    stage
        .control
        .insert("top".into(), WallControl::Displacement);
    stage
        .displacement
        .insert("top".into(), 2.931281292110204e-4);
    stage.until_failure = true;
    scene
}
