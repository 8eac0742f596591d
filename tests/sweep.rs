//! `grainstat sweep`: one scene at several values of its keys, the macro parameters of every
//! run in one table. On the elastic crystal (linear springs, bonded) Young's modulus does not
//! depend on the lateral stress, so both runs must give the same E.

mod common;

use common::{assert_input_error, crystal_scene, grainstat, stderr};

#[test]
fn a_sweep_over_the_lateral_stress_collects_each_runs_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let scene = crystal_scene(dir.path(), 1);
    let sweep = dir.path().join("sweep.toml");
    std::fs::write(
        &sweep,
        "scene = \"crystal.toml\"\nlabel = \"sigma_3\"\nunit = \"Pa\"\n\
         keys = [\"stages.0.stress.right\", \"stages.0.stress.top\"]\n\
         values = [1e6, 2e6]\n",
    )
    .unwrap();
    assert!(scene.exists());
    let out_dir = dir.path().join("out");
    let out = grainstat(&[
        "sweep",
        sweep.to_str().unwrap(),
        "-o",
        out_dir.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let csv = std::fs::read_to_string(out_dir.join("sweep.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(rows.len(), 2, "{csv}");
    let young: Vec<f64> = rows.iter().map(|r| r[1].parse().unwrap()).collect();
    assert!(young.iter().all(|e| e.is_finite() && *e > 0.0), "{csv}");
    assert!(
        (young[0] - young[1]).abs() < 0.01 * young[0],
        "E at 1 and 2 MPa: {young:?}"
    );
    // The lateral stress of each run is the value set.
    let lateral: Vec<f64> = rows.iter().map(|r| r[6].parse().unwrap()).collect();
    assert!((lateral[0] - 1e6).abs() < 1e-3 * 1e6 && (lateral[1] - 2e6).abs() < 1e-3 * 2e6);
    let table = std::fs::read_to_string(out_dir.join("sweep.md")).unwrap();
    assert!(table.contains("Mohr-Coulomb fit: needs peaks"), "{table}");
    assert!(out_dir.join("run-1.h5").exists());
    assert!(out_dir.join("run-1-plots").join("parameters.md").exists());

    // A key the scene does not have is bad input.
    std::fs::write(
        &sweep,
        "scene = \"crystal.toml\"\nkeys = [\"stages.7.stress.top\"]\nvalues = [1e6]\n",
    )
    .unwrap();
    let out = grainstat(&[
        "sweep",
        sweep.to_str().unwrap(),
        "-o",
        out_dir.to_str().unwrap(),
    ]);
    assert_input_error(&out, &["crystal.toml", "no key `stages.7.stress.top`"]);
}
