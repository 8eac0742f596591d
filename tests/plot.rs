//! `grainstat plot` and the pictures at the end of `grainstat run`: every picture is written
//! as well-formed SVG (one circle per grain where grains are drawn) and PNG, the CSV has one
//! row per complete increment with the `/history` values, the XDMF has one time step per
//! complete increment and points only at datasets that exist with the shapes it states, and
//! bad input is exit status 2 naming the file.

mod common;

use common::{assert_input_error, crystal_scene, grainstat, serial, stderr};
use grainstat::output::{read_history, read_increments, read_state};
use grainstat::samples;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// A small crystal run (written every second increment) in `dir`, with its pictures.
fn crystal_run(dir: &Path) -> PathBuf {
    let path = crystal_scene(dir, 2);
    let result = dir.join("crystal.h5");
    let out = grainstat(&[
        "run",
        path.to_str().unwrap(),
        "-o",
        result.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(out.status.success(), "run: {}", stderr(&out));
    result
}

const PICTURES: [&str; 6] = [
    "stress-strain",
    "volumetric-strain",
    "contacts-per-grain",
    "broken-bonds",
    "mean-rotation",
    "region-stresses",
];

const SAMPLE_PICTURES: [&str; 5] = [
    "forces",
    "displacement",
    "rotation",
    "orientation",
    "contact-forces",
];

/// Width and height from a PNG's signature and IHDR chunk.
fn png_size(path: &Path) -> (u32, u32) {
    let bytes = std::fs::read(path).unwrap();
    assert!(bytes.len() > 33, "{} is too short", path.display());
    assert_eq!(
        &bytes[..8],
        b"\x89PNG\r\n\x1a\n",
        "{} signature",
        path.display()
    );
    assert_eq!(&bytes[12..16], b"IHDR", "{} header chunk", path.display());
    let word = |k: usize| u32::from_be_bytes(bytes[k..k + 4].try_into().unwrap());
    (word(16), word(20))
}

/// The SVG's circle elements, after checking it parses as XML with an `svg` root.
fn svg_circles(path: &Path) -> usize {
    let text = std::fs::read_to_string(path).unwrap();
    let doc = roxmltree::Document::parse(&text)
        .unwrap_or_else(|e| panic!("{} is not XML: {e}", path.display()));
    assert_eq!(doc.root_element().tag_name().name(), "svg");
    doc.descendants()
        .filter(|n| n.tag_name().name() == "circle")
        .count()
}

/// Every picture of `names` is in `dir` as SVG and PNG; the sample pictures at `increment`.
fn check_pictures(dir: &Path, increment: usize, grains: usize) {
    for name in PICTURES {
        svg_circles(&dir.join(format!("{name}.svg")));
        let (w, h) = png_size(&dir.join(format!("{name}.png")));
        assert!(w > 0 && h > 0, "{name}.png is {w} x {h}");
    }
    for name in SAMPLE_PICTURES {
        let stem = format!("{name}-{increment:08}");
        let circles = svg_circles(&dir.join(format!("{stem}.svg")));
        if matches!(name, "forces" | "displacement" | "rotation") {
            assert_eq!(circles, grains, "circles in {stem}.svg");
        }
        let (w, h) = png_size(&dir.join(format!("{stem}.png")));
        assert!(w > 0 && h > 0, "{stem}.png is {w} x {h}");
    }
}

/// The CSV as a header and rows of cells.
fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let head: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_owned)
        .collect();
    let rows: Vec<Vec<String>> = lines
        .map(|l| l.split(',').map(str::to_owned).collect())
        .collect();
    for r in &rows {
        assert_eq!(r.len(), head.len(), "cells in row {r:?}");
    }
    (head, rows)
}

/// The CSV has one row per complete increment, and each `/history` column (per-wall ones
/// per wall) with the stored values.
fn check_csv(csv: &Path, result: &Path) {
    let history = read_history(result).unwrap();
    let increments = read_increments(result).unwrap();
    let (head, rows) = read_csv(csv);
    assert_eq!(
        rows.len(),
        increments.len(),
        "one row per complete increment"
    );
    assert_eq!(history.len(), increments.len());
    let column = |name: &str| -> Vec<f64> {
        let k = head
            .iter()
            .position(|h| h.split(" [").next() == Some(name))
            .unwrap_or_else(|| panic!("column {name} in {head:?}"));
        rows.iter().map(|r| r[k].parse::<f64>().unwrap()).collect()
    };
    let same = |a: f64, b: f64| a == b || (a.is_nan() && b.is_nan());
    let stored: Vec<f64> = increments.iter().map(|&k| k as f64).collect();
    assert_eq!(column("increment"), stored);
    for (name, values) in &history.ints {
        let expected: Vec<f64> = values.iter().map(|&v| v as f64).collect();
        assert_eq!(column(name), expected, "column {name}");
    }
    for (name, values) in &history.floats {
        let got = column(name);
        assert!(
            got.iter().zip(values).all(|(a, b)| same(*a, *b)),
            "column {name}: {got:?} against {values:?}"
        );
    }
    let (header, _) = read_state(result, increments[0]).unwrap();
    for (name, rows) in &history.walls {
        for (w, wall) in header.walls.iter().enumerate() {
            let got = column(&format!("{name}:{}", wall.name));
            assert!(
                got.iter().zip(rows).all(|(a, r)| same(*a, r[w])),
                "column {name}:{}",
                wall.name
            );
        }
    }
    assert!(!header.regions.is_empty(), "the scene has a region");
    for (name, rows) in &history.regions {
        for (k, region) in header.regions.iter().enumerate() {
            let got = column(&format!("{name}:{}", region.name));
            assert!(got.iter().zip(rows).all(|(a, r)| same(*a, r[k])));
        }
    }
    assert!(head.contains(&"region_stress_yy:core [Pa]".to_string()));
    assert!(head.contains(&"mean_absolute_rotation [rad]".to_string()));
    // The crystal is squeezed between its top and bottom walls: compression is positive.
    let strain = column("axial_strain");
    assert_eq!(strain[0], 0.0);
    assert!(*strain.last().unwrap() > 0.0, "axial strain {strain:?}");
    assert!(head.iter().any(|h| h.starts_with("volumetric_strain [")));
}

/// The XDMF's time steps are the complete increments, and every dataset it names exists in
/// the result file with the dimensions it gives.
fn check_xdmf(xmf: &Path, result: &Path) {
    let increments = read_increments(result).unwrap();
    let text = std::fs::read_to_string(xmf).unwrap();
    let doc = roxmltree::Document::parse(&text).unwrap();
    let root = doc.root_element();
    assert_eq!(root.tag_name().name(), "Xdmf");
    assert_eq!(root.attribute("Version"), Some("3.0"));
    let collections: Vec<_> = doc
        .descendants()
        .filter(|n| n.attribute("CollectionType") == Some("Temporal"))
        .collect();
    assert_eq!(collections.len(), 2, "grains and contacts");
    for c in &collections {
        let times: Vec<usize> = c
            .children()
            .filter(|n| n.tag_name().name() == "Grid")
            .map(|g| {
                let time = g
                    .children()
                    .find(|n| n.tag_name().name() == "Time")
                    .expect("a Time per step");
                time.attribute("Value").unwrap().parse().unwrap()
            })
            .collect();
        assert_eq!(times, increments, "time steps of {:?}", c.attribute("Name"));
    }
    let file = hdf5::File::open(result).unwrap();
    let name = result.file_name().unwrap().to_str().unwrap();
    let mut checked = HashMap::new();
    for item in doc
        .descendants()
        .filter(|n| n.attribute("Format") == Some("HDF"))
    {
        let reference = item.text().unwrap().trim();
        let (h5, path) = reference.split_once(':').unwrap();
        assert_eq!(h5, name, "the result file beside the XDMF");
        let ds = file
            .dataset(path)
            .unwrap_or_else(|e| panic!("{path} in the result file: {e}"));
        let dims: Vec<usize> = item
            .attribute("Dimensions")
            .unwrap()
            .split(' ')
            .map(|d| d.parse().unwrap())
            .collect();
        assert_eq!(ds.shape(), dims, "dimensions of {path}");
        *checked.entry(path.rsplit('/').next().unwrap()).or_insert(0) += 1;
    }
    for dataset in [
        "position",
        "index",
        "radius",
        "nodes",
        "normal_force",
        "state",
    ] {
        assert!(checked.contains_key(dataset), "{dataset} referenced");
    }
}

/// The pictures of `increment` and the CSV in `pictures`, the XDMF beside `result`.
fn check_outputs(pictures: &Path, increment: usize, result: &Path) {
    let grains = read_state(result, increment).unwrap().0.radius.len();
    check_pictures(pictures, increment, grains);
    check_csv(&pictures.join("curves.csv"), result);
    check_xdmf(&result.with_extension("xmf"), result);
}

#[test]
fn a_run_draws_its_pictures_and_writes_csv_and_xdmf() {
    let _serial = serial();
    let dir = tempfile::tempdir().unwrap();
    let result = crystal_run(dir.path());
    let last = *read_increments(&result).unwrap().last().unwrap();
    check_outputs(&dir.path().join("crystal-plots"), last, &result);
}

#[test]
fn plot_draws_an_increment_into_a_directory() {
    let _serial = serial();
    let dir = tempfile::tempdir().unwrap();
    let result = crystal_run(dir.path());
    let increments = read_increments(&result).unwrap();
    let first = increments[1];
    let out_dir = dir.path().join("figures");
    let out = grainstat(&[
        "plot",
        result.to_str().unwrap(),
        "-o",
        out_dir.to_str().unwrap(),
        "--increment",
        &first.to_string(),
    ]);
    assert!(out.status.success(), "plot: {}", stderr(&out));
    let grains = read_state(&result, first).unwrap().0.radius.len();
    check_pictures(&out_dir, first, grains);
    // It lists what it wrote.
    let listed = String::from_utf8_lossy(&out.stdout);
    assert!(
        listed.contains(&format!("forces-{first:08}.png")),
        "{listed}"
    );
    assert!(listed.contains("crystal.xmf"), "{listed}");
}

#[test]
fn a_partly_written_file_is_plotted_up_to_its_last_complete_increment() {
    let _serial = serial();
    let dir = tempfile::tempdir().unwrap();
    let result = crystal_run(dir.path());
    let increments = read_increments(&result).unwrap();
    let cut = increments[increments.len() - 2];
    {
        // As a run killed while writing its last increment leaves the file.
        let file = hdf5::File::open_rw(&result).unwrap();
        let last = format!("increments/{:08}", increments.last().unwrap());
        file.group(&last).unwrap().delete_attr("complete").unwrap();
    }
    let out_dir = dir.path().join("cut");
    let out = grainstat(&[
        "plot",
        result.to_str().unwrap(),
        "-o",
        out_dir.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "plot: {}", stderr(&out));
    check_outputs(&out_dir, cut, &result);
}

#[test]
fn no_plot_draws_nothing() {
    let _serial = serial();
    let dir = tempfile::tempdir().unwrap();
    let scene = samples::crystal_biaxial(5, 4, 1e6, 2e6);
    let path = dir.path().join("small.toml");
    std::fs::write(&path, toml::to_string(&scene).unwrap()).unwrap();
    let result = dir.path().join("small.h5");
    let out = grainstat(&[
        "run",
        path.to_str().unwrap(),
        "-o",
        result.to_str().unwrap(),
        "--quiet",
        "--no-plot",
    ]);
    assert!(out.status.success(), "run: {}", stderr(&out));
    assert!(result.exists());
    assert!(!dir.path().join("small-plots").exists());
    assert!(!dir.path().join("small.xmf").exists());
}

#[test]
fn bad_input_to_plot_is_exit_status_2_naming_the_file() {
    let _serial = serial();
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.h5");
    let out = grainstat(&["plot", missing.to_str().unwrap()]);
    assert_input_error(&out, &["missing.h5", "no such file"]);

    let text = dir.path().join("notes.h5");
    std::fs::write(&text, "not HDF5").unwrap();
    let out = grainstat(&["plot", text.to_str().unwrap()]);
    assert_input_error(&out, &["notes.h5"]);

    let other = dir.path().join("other.h5");
    hdf5::File::create(&other).unwrap();
    let out = grainstat(&["plot", other.to_str().unwrap()]);
    assert_input_error(&out, &["other.h5", "not a grainstat result file"]);

    let result = crystal_run(dir.path());
    let out = grainstat(&["plot", result.to_str().unwrap(), "--increment", "3"]);
    assert_input_error(&out, &["crystal.h5", "no complete increment 3"]);
}
