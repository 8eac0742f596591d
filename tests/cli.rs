//! The `grainstat` command line: bad input is exit status 2 with file, key and line; a run
//! writes a result file that `info` reads; `--resume` continues a run to the same state as
//! an uninterrupted one.

mod common;

use common::{assert_input_error, crystal_scene, grainstat, stderr};
use grainstat::output::{read_history, read_increments, read_state};
use std::path::{Path, PathBuf};

#[test]
fn bad_scene_files_are_exit_status_2_naming_key_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let good = std::fs::read_to_string(crystal_scene(dir.path(), 1)).unwrap();

    let unknown = good.replace("poisson = 0.16", "poisson = 0.16\nfrction = 0.5");
    let line = unknown
        .lines()
        .position(|l| l.starts_with("frction"))
        .unwrap()
        + 1;
    let path = dir.path().join("unknown.toml");
    std::fs::write(&path, &unknown).unwrap();
    let out = grainstat(&["run", path.to_str().unwrap()]);
    assert_input_error(&out, &[&format!("unknown.toml:{line}"), "frction"]);

    let negative = good.replace("radius = 0.0001", "radius = -0.0001");
    assert_ne!(negative, good, "the scene has the radius line");
    let path = dir.path().join("negative.toml");
    std::fs::write(&path, &negative).unwrap();
    let out = grainstat(&["run", path.to_str().unwrap()]);
    assert_input_error(&out, &["negative.toml:", "grains.crystal.radius"]);

    let path = dir.path().join("nan.toml");
    std::fs::write(&path, good.replace("poisson = 0.16", "poisson = nan")).unwrap();
    let out = grainstat(&["run", path.to_str().unwrap()]);
    assert_input_error(&out, &["nan.toml:", "material.poisson"]);

    let path = dir.path().join("broken.toml");
    std::fs::write(&path, "name = \"x\"\n[material\nlaw = 1\n").unwrap();
    let out = grainstat(&["run", path.to_str().unwrap()]);
    assert_input_error(&out, &["broken.toml:2"]);

    let out = grainstat(&["run", dir.path().join("missing.toml").to_str().unwrap()]);
    assert_input_error(&out, &["missing.toml"]);
}

#[test]
fn bad_solver_and_grain_files_are_exit_status_2() {
    let dir = tempfile::tempdir().unwrap();
    let scene = crystal_scene(dir.path(), 1);
    let solver = dir.path().join("solver.toml");
    std::fs::write(&solver, "skin = 0.5\ntolerance = -1.0\n").unwrap();
    let out = grainstat(&[
        "run",
        scene.to_str().unwrap(),
        "--solver",
        solver.to_str().unwrap(),
    ]);
    assert_input_error(&out, &["solver.toml:2", "tolerance"]);
    // A setting of the Newton solver the minimisation replaced.
    std::fs::write(&solver, "strategy = \"newton\"\nsettle_steps = 20000\n").unwrap();
    let out = grainstat(&[
        "run",
        scene.to_str().unwrap(),
        "--solver",
        solver.to_str().unwrap(),
    ]);
    assert_input_error(&out, &["solver.toml:2", "settle_steps", "Newton"]);

    let csv = dir.path().join("grains.csv");
    std::fs::write(&csv, "x,y,r\n0.0,0.0,1e-4\n1e-4,zero,1e-4\n").unwrap();
    let text = "name = \"csv\"\n[material]\nlaw = \"linear\"\nnormal_stiffness = 1e6\n\
                [grains]\nfile = \"grains.csv\"\n[box]\nstress_controlled = [\"top\"]\n\
                [[stages]]\nincrements = 1\nstress = { top = 1e5 }\n";
    let path = dir.path().join("csv.toml");
    std::fs::write(&path, text).unwrap();
    let out = grainstat(&["run", path.to_str().unwrap()]);
    assert_input_error(&out, &["grains.csv:3"]);
}

#[test]
fn a_run_writes_a_result_that_info_reads() {
    let dir = tempfile::tempdir().unwrap();
    let scene = crystal_scene(dir.path(), 2);
    let result = dir.path().join("out.h5");
    let out = grainstat(&[
        "run",
        scene.to_str().unwrap(),
        "-o",
        result.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    // Increment 0, every second one, and the last.
    assert_eq!(read_increments(&result).unwrap(), vec![0, 2, 4, 6]);
    let info = grainstat(&["info", result.to_str().unwrap()]);
    assert!(info.status.success(), "{}", stderr(&info));
    let text = String::from_utf8_lossy(&info.stdout);
    assert!(text.contains("crystal-biaxial"), "{text}");
    assert!(text.contains("symbolic_factorisations"), "{text}");

    let out = grainstat(&["info", dir.path().join("none.h5").to_str().unwrap()]);
    assert_input_error(&out, &["none.h5"]);
}

/// Drop every increment after `keep` from a result file, as a run killed after writing it
/// would leave it (the later groups lack their `complete` mark).
fn cut_after(path: &Path, keep: usize) {
    let file = hdf5::File::open_rw(path).unwrap();
    let increments = file.group("increments").unwrap();
    for name in increments.member_names().unwrap() {
        if name.parse::<usize>().unwrap() > keep {
            increments
                .group(&name)
                .unwrap()
                .delete_attr("complete")
                .unwrap();
        }
    }
}

/// Run the crystal of [`crystal_scene`] writing every `every`-th increment into `whole.h5`,
/// copy the file cut after increment `keep`, resume it, and check that every increment after
/// `keep` and `/history` (compared as printed, where NaN equals NaN and every digit counts)
/// are the uninterrupted run's. Returns the scene and the uninterrupted run's file.
fn resumed_as_uninterrupted(dir: &Path, every: usize, keep: usize) -> (PathBuf, PathBuf) {
    let scene = crystal_scene(dir, every);
    let (whole, resumed) = (dir.join("whole.h5"), dir.join("resumed.h5"));
    let run = |flag: &str, file: &Path| {
        let out = grainstat(&[
            "run",
            scene.to_str().unwrap(),
            flag,
            file.to_str().unwrap(),
            "--quiet",
        ]);
        assert!(out.status.success(), "{}", stderr(&out));
    };
    run("-o", &whole);
    std::fs::copy(&whole, &resumed).unwrap();
    cut_after(&resumed, keep);
    run("--resume", &resumed);
    let increments = read_increments(&whole).unwrap();
    assert_eq!(read_increments(&resumed).unwrap(), increments);
    for &increment in increments.iter().filter(|&&k| k > keep) {
        let (_, a) = read_state(&whole, increment).unwrap();
        let (_, b) = read_state(&resumed, increment).unwrap();
        assert!(a == b, "increment {increment} differs after resume");
    }
    let (a, b) = (
        read_history(&whole).unwrap(),
        read_history(&resumed).unwrap(),
    );
    assert_eq!(format!("{a:?}"), format!("{b:?}"));
    (scene, whole)
}

/// Between writes a crystal's increment starts on the stability indicator's factor of the
/// one before; a write drops it, so a run resumed from a written increment repeats the
/// uninterrupted one that wrote every second increment.
#[test]
fn resume_reproduces_a_run_that_writes_every_second_increment() {
    let dir = tempfile::tempdir().unwrap();
    resumed_as_uninterrupted(dir.path(), 2, 2);
}

#[test]
fn resume_reproduces_the_uninterrupted_run() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, whole) = resumed_as_uninterrupted(dir.path(), 1, 3);
    // The regions' stresses and the rotations are among the history compared.
    assert!(!read_history(&whole)
        .unwrap()
        .region("region_stress_yy")
        .is_empty());

    // Resuming with another scene, or from nothing, is bad input.
    let resumed = dir.path().join("resumed.h5");
    let other = dir.path().join("other.toml");
    let text = std::fs::read_to_string(&scene)
        .unwrap()
        .replace("poisson = 0.16", "poisson = 0.2");
    std::fs::write(&other, text).unwrap();
    let out = grainstat(&[
        "run",
        other.to_str().unwrap(),
        "--resume",
        resumed.to_str().unwrap(),
    ]);
    assert_input_error(&out, &["other.toml", "differs"]);
    let missing = dir.path().join("missing.h5");
    let out = grainstat(&[
        "run",
        scene.to_str().unwrap(),
        "--resume",
        missing.to_str().unwrap(),
    ]);
    assert_input_error(&out, &["missing.h5"]);
}

#[test]
fn a_failing_increment_names_itself_and_keeps_the_last_converged_state() {
    let dir = tempfile::tempdir().unwrap();
    let scene = crystal_scene(dir.path(), 1);
    // One Newton iteration and no halving cannot reach 1e-12 in the first biaxial increment.
    let solver = dir.path().join("starved.toml");
    std::fs::write(
        &solver,
        "tolerance = 1e-12\nmax_iterations = 1\nmax_cuts = 0\n",
    )
    .unwrap();
    let result = dir.path().join("failed.h5");
    let out = grainstat(&[
        "run",
        scene.to_str().unwrap(),
        "--solver",
        solver.to_str().unwrap(),
        "-o",
        result.to_str().unwrap(),
        "--quiet",
    ]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(3), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    for word in [
        "increment 1",
        "residual",
        "worst grain",
        "last converged state",
    ] {
        assert!(err.contains(word), "`{word}` in: {err}");
    }
    // The state before the failing increment is on file, whole.
    assert_eq!(read_increments(&result).unwrap(), vec![0]);
    assert!(read_state(&result, 0).is_ok());
}
