//! `grainstat spread`: a test run again with its last stage's loads changed by round-off,
//! and with the last stage's increments doubled, each run's failure load read as the plain
//! run's is.

mod common;

use common::{assert_input_error, crystal_to_failure, grainstat, stderr};
use grainstat::spread::{figure_of, Figure};

/// The 164-grain cemented crystal pushed down until it fails, in 20 steps: two runs a step
/// and both steps. Run k = 0 is the scene as written, so its peak is the plain run's to the
/// last bit; runs one round-off apart agree to well within 1%, and so does halving the step
/// (the crystal's peak does not depend on it, `tests/increment_size.rs`).
#[test]
fn a_spread_reads_each_run_as_the_plain_run_and_gives_the_change_on_halving() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("crystal.toml");
    std::fs::write(
        &scene,
        toml::to_string(&crystal_to_failure(20, true)).unwrap(),
    )
    .unwrap();
    let scene = scene.to_str().unwrap();
    let spread = dir.path().join("spread");
    let out = grainstat(&[
        "spread",
        scene,
        "--runs",
        "2",
        "--halved",
        "--jobs",
        "2",
        "--quiet",
        "-o",
        spread.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let plain = dir.path().join("plain.h5");
    let out = grainstat(&[
        "run",
        scene,
        "--no-plot",
        "--quiet",
        "-o",
        plain.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let peak = |file: &std::path::Path| {
        figure_of(file, Some(&Figure::Deviator))
            .unwrap()
            .expect("a peak")
    };
    let at = |name: &str| peak(&spread.join(name));
    assert_eq!(at("run-0.h5"), peak(&plain));
    for other in ["run-1.h5", "run-0-halved.h5", "run-1-halved.h5"] {
        assert!(
            (at(other) / at("run-0.h5") - 1.0).abs() < 0.01,
            "{other}: {:e} against {:e}",
            at(other),
            at("run-0.h5")
        );
    }
    // The top wall's peak stress is the peak's axial stress, and a wall the run does not
    // have is bad input.
    let top = figure_of(&plain, Some(&Figure::Wall("top".into())))
        .unwrap()
        .expect("a stress on the top wall");
    let lateral = 1e6;
    assert!(
        (top - lateral) >= peak(&plain) * 0.99 && top < 1.5 * (peak(&plain) + lateral),
        "top {top:e}, deviator {:e}",
        peak(&plain)
    );
    assert!(figure_of(&plain, Some(&Figure::Wall("nowhere".into()))).is_err());
    let table = std::fs::read_to_string(spread.join("spread.md")).unwrap();
    assert!(
        table.contains("| 20 | 2 | 0 |") && table.contains("| 40 | 2 | 0 |"),
        "{table}"
    );
    assert!(
        table.contains("Halving the increment changes the mean peak deviator"),
        "{table}"
    );
    let csv = std::fs::read_to_string(spread.join("spread.csv")).unwrap();
    assert_eq!(csv.lines().count(), 5, "{csv}");
}

/// A failure figure the run cannot give, a wall the scene does not have, or a scene
/// without stages, is bad input, found before any run.
#[test]
fn a_spread_of_what_cannot_be_read_is_exit_status_2() {
    let dir = tempfile::tempdir().unwrap();
    let out = grainstat(&["spread", "x.toml", "--figure", "peak"]);
    assert_input_error(&out, &["--figure", "peak"]);
    let scene = dir.path().join("none.toml");
    std::fs::write(&scene, "name = \"none\"\n").unwrap();
    let out = grainstat(&["spread", scene.to_str().unwrap(), "--quiet"]);
    assert_input_error(&out, &["none.toml", "stages"]);
    // A wall the scene does not have, before any run.
    let crystal = dir.path().join("crystal.toml");
    std::fs::write(
        &crystal,
        toml::to_string(&crystal_to_failure(20, true)).unwrap(),
    )
    .unwrap();
    let runs = dir.path().join("runs");
    let out = grainstat(&[
        "spread",
        crystal.to_str().unwrap(),
        "--figure",
        "wall:plug",
        "-o",
        runs.to_str().unwrap(),
    ]);
    assert_input_error(&out, &["crystal.toml", "--figure", "plug"]);
    assert!(!runs.exists());
}
