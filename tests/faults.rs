//! Faults: a run killed (SIGKILL) at random moments leaves a result file that opens, with
//! every written increment whole, and `--resume` takes it to the state of the uninterrupted
//! run, bit for bit. Determinism: the same scene gives the same results, bit for bit, on 1
//! and 2 threads, for a run and for `grainstat generate`.

mod common;

use common::{grainstat, stderr};
use grainstat::output::{read_history, read_increments, read_state};
use grainstat::sample::read_sample;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// A 310-grain crystal loaded in 60 increments, each written: about half a second of
/// increments and writes, so a kill lands in the middle of either.
fn scene(dir: &Path) -> PathBuf {
    let mut scene = grainstat::samples::crystal_biaxial(20, 16, 1e6, 3e6);
    scene.stages[0].increments = 15;
    scene.stages[1].increments = 45;
    scene.output.every = 1;
    let path = dir.join("crystal.toml");
    std::fs::write(&path, toml::to_string(&scene).unwrap()).unwrap();
    path
}

fn run(scene: &Path, out: &Path, resume: bool, solver: &[&str]) -> Command {
    let mut cmd = common::grainstat_command();
    cmd.arg("run").arg(scene);
    cmd.arg(if resume { "--resume" } else { "-o" }).arg(out);
    cmd.args(["--quiet", "--no-plot"]);
    cmd.args(solver);
    cmd.stdout(Stdio::null()).stderr(Stdio::null());
    cmd
}

/// Every complete increment of the file reads back whole, and `/history` has a row for each.
fn assert_whole(path: &Path) -> Vec<usize> {
    let increments = read_increments(path).unwrap_or_else(|e| panic!("{e}"));
    assert!(!increments.is_empty(), "the file has increment 0");
    for &k in &increments {
        let (_, state) = read_state(path, k).unwrap_or_else(|e| panic!("increment {k}: {e}"));
        assert_eq!(state.increment, k);
    }
    let history = read_history(path).unwrap_or_else(|e| panic!("{e}"));
    let rows: Vec<usize> = history
        .int("increment")
        .iter()
        .map(|&k| k as usize)
        .collect();
    assert_eq!(rows, increments, "one history row per complete increment");
    // The stability indicator, counted for every increment solved (-1 for the start).
    let pivots = history.int("negative_pivots");
    assert_eq!(pivots.len(), rows.len());
    for (&k, &n) in rows.iter().zip(pivots) {
        assert!(if k == 0 { n == -1 } else { n >= 0 }, "increment {k}: {n}");
    }
    increments
}

/// With the minimisation, whose increment starts from the last one's displacements (kept in
/// the state for that).
#[test]
fn a_run_killed_at_random_moments_resumes_to_the_uninterrupted_state() {
    killed_and_resumed(&[]);
}

/// The same with the relaxation, whose increments are taken as they stand after their sweeps.
#[test]
fn a_relaxed_run_killed_at_random_moments_resumes_to_the_uninterrupted_state() {
    killed_and_resumed(&["--solver", "solvers/relaxation.toml"]);
}

/// Kill the run with settings `solver` a few times, resume it after each kill, and compare
/// every increment with the uninterrupted run's.
fn killed_and_resumed(solver: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene(dir.path());
    let whole = dir.path().join("whole.h5");
    let start = Instant::now();
    let status = run(&scene, &whole, false, solver).status().unwrap();
    assert!(status.success());
    let duration = start.elapsed();
    let all = assert_whole(&whole);
    assert_eq!(all.len(), 61);

    // Kill the run a few times at seeded-random moments after its file appeared, resuming
    // after each kill; then let it finish.
    let killed = dir.path().join("killed.h5");
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    let mut landed = 0;
    for attempt in 0..4 {
        let mut child = run(&scene, &killed, attempt > 0, solver).spawn().unwrap();
        // Until increment 0 is on file there is nothing to resume from (a file killed before
        // has only the header, and resuming from it is bad input).
        while !read_increments(&killed).is_ok_and(|k| !k.is_empty()) {
            assert!(child.try_wait().unwrap().is_none(), "the run ended at once");
            std::thread::sleep(Duration::from_millis(1));
        }
        std::thread::sleep(duration.mul_f64(rng.random_range(0.05..0.6)));
        child.kill().unwrap();
        let status = child.wait().unwrap();
        // A run that finished before the kill has status 0 and nothing left to resume.
        if status.success() {
            break;
        }
        landed += 1;
        let written = assert_whole(&killed);
        assert!(written.iter().all(|k| all.contains(k)));
    }
    assert!(landed > 0, "no kill landed while the run was going");
    let mut args = vec![
        "run",
        scene.to_str().unwrap(),
        "--resume",
        killed.to_str().unwrap(),
        "--quiet",
        "--no-plot",
    ];
    args.extend(solver);
    let out = grainstat(&args);
    assert!(out.status.success(), "{}", stderr(&out));

    assert_eq!(assert_whole(&killed), all);
    for &k in &all {
        let (_, a) = read_state(&whole, k).unwrap();
        let (_, b) = read_state(&killed, k).unwrap();
        assert!(a == b, "increment {k} differs after the kills and resumes");
    }
    assert!(read_history(&whole).unwrap() == read_history(&killed).unwrap());
}

/// A 2,052-grain crystal in its 6 increments, each written: enough grains and contacts that
/// the friends lists, the return map and the assembly are shared over the threads.
fn parallel_scene(dir: &Path) -> PathBuf {
    let mut scene = grainstat::samples::crystal_biaxial(57, 36, 1e6, 3e6);
    scene.output.every = 1;
    let path = dir.join("crystal-parallel.toml");
    std::fs::write(&path, toml::to_string(&scene).unwrap()).unwrap();
    path
}

#[test]
fn a_run_is_the_same_on_1_and_2_threads() {
    let dir = tempfile::tempdir().unwrap();
    let scene = parallel_scene(dir.path());
    let on = |threads: &str| {
        let out_path = dir.path().join(format!("threads-{threads}.h5"));
        let out = grainstat(&[
            "run",
            scene.to_str().unwrap(),
            "-o",
            out_path.to_str().unwrap(),
            "--threads",
            threads,
            "--quiet",
            "--no-plot",
        ]);
        assert!(out.status.success(), "{}", stderr(&out));
        out_path
    };
    let (one, two) = (on("1"), on("2"));
    let increments = read_increments(&one).unwrap();
    assert_eq!(increments, read_increments(&two).unwrap());
    let (_, first) = read_state(&one, increments[0]).unwrap();
    assert!(first.grains.len() >= grainstat::parallel::MIN_ITEMS);
    assert!(first.contacts.contacts.len() >= grainstat::parallel::MIN_ITEMS);
    for k in increments {
        let (_, a) = read_state(&one, k).unwrap();
        let (_, b) = read_state(&two, k).unwrap();
        assert!(a == b, "increment {k} differs between 1 and 2 threads");
    }
    assert!(read_history(&one).unwrap() == read_history(&two).unwrap());
}

#[test]
fn a_generated_sample_is_the_same_on_1_and_2_threads() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/sample-sand.toml"),
    )
    .unwrap()
    .replace("grains = 1000", "grains = 1100");
    let scene = dir.path().join("sample.toml");
    std::fs::write(&scene, text).unwrap();
    let on = |threads: &str| {
        let out_path = dir.path().join(format!("sample-{threads}.h5"));
        let out = grainstat(&[
            "generate",
            scene.to_str().unwrap(),
            "-o",
            out_path.to_str().unwrap(),
            "--threads",
            threads,
            "--quiet",
        ]);
        assert!(out.status.success(), "{}", stderr(&out));
        read_sample(&out_path).unwrap()
    };
    let (one, two) = (on("1"), on("2"));
    // Enough grains that the friends lists are searched on both threads.
    assert!(one.grains.len() >= grainstat::parallel::MIN_ITEMS);
    assert!(one == two, "the same sample, bit for bit");
}
