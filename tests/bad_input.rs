//! Bad input of every kind through the `grainstat` binary, one table row each: exit status 2,
//! no panic, and a message naming the file, the key and the line where they apply. What
//! `tests/cli.rs` (unknown key, negative radius, NaN, broken TOML, missing scene, bad solver
//! and CSV files, resuming with another scene or from nothing) and `tests/scene_input.rs`
//! (the parser on its own) cover is not repeated.

mod common;

use common::{assert_input_error, grainstat, stderr, BASE};
use std::path::Path;

/// Two grains side by side on a bottom wall, under a stress-controlled top wall at `top`.
fn two_grains(x: &str, top: &str) -> String {
    format!(
        r#"name = "w"
[material]
law = "linear"
normal_stiffness = 1e8
poisson = 0.16
friction = 0.5
[grains]
x = {x}
y = [1e-4, 1e-4]
r = [1e-4, 1e-4]
[[walls]]
name = "bottom"
point = [0.0, 0.0]
normal = [0.0, 1.0]
[[walls]]
name = "top"
point = [0.0, {top}]
normal = [0.0, -1.0]
control = "stress"
length = 1e-3
[[stages]]
increments = 1
stress = {{ top = 1e5 }}
"#
    )
}

/// A sample section for `grainstat generate`, with `extra` lines added to it.
fn sample_scene(extra: &str) -> String {
    format!(
        r#"name = "s"
[material]
law = "hertz"
shear_modulus = 1e9
poisson = 0.16
friction = 0.6
[sample]
region = "rectangle"
aspect = 2.5
grains = 60
distribution = {{ kind = "a", mean_radius = 1e-4, ratio = 4.0 }}
seed = 1
friction = 0.0
stress = 1e5
{extra}"#
    )
}

/// `BASE` with a plug far above the crystal, given `grains` and its motion in `extra`.
fn circle(extra: &str) -> String {
    format!("{BASE}[[circles]]\nname = \"plug\"\ncenter = [0.0, 1.0]\nradius = 1e-4\n{extra}\n")
}

/// `BASE` with `old` replaced by `new`; the replacement must happen.
fn base_with(old: &str, new: &str) -> String {
    assert!(BASE.contains(old), "`{old}` not in BASE");
    BASE.replacen(old, new, 1)
}

/// 1-based line of the first line of `text` containing `needle`.
fn line_of(text: &str, needle: &str) -> usize {
    text.lines()
        .position(|l| l.contains(needle))
        .unwrap_or_else(|| panic!("`{needle}` not in the text"))
        + 1
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

#[test]
fn bad_scenes_are_exit_status_2_naming_file_key_and_line() {
    let dir = tempfile::tempdir().unwrap();
    // (file name, text, phrases the message must hold; `{line}` is computed from the text)
    let huge_crystal = base_with("rows = 5", "rows = 100000000000");
    let huge_program = base_with("increments = 2", "increments = 18446744073709551615");
    let region = |lines: &str| format!("{BASE}[[regions]]\nname = \"a\"\n{lines}\n");
    let both = region("min = [0.0, 0.0]\nmax = [5e-4, 5e-4]\nradius = 3e-4");
    let inverted = region("min = [1e-3, 0.0]\nmax = [0.0, 1e-3]");
    let inner = region("center = [5e-4, 5e-4]\nradius = 2e-4\ninner_radius = 3e-4");
    let twice = format!(
        "{}[[regions]]\nname = \"a\"\ncenter = [0.0, 0.0]\nradius = 4e-4\n",
        region("center = [0.0, 0.0]\nradius = 3e-4")
    );
    let shapeless = region("");
    let cases: Vec<(&str, String, Vec<String>)> = vec![
        (
            "unclosed.toml",
            base_with("name = \"t\"", "name = \"t"),
            vec!["unclosed.toml:1".into()],
        ),
        (
            "string-number.toml",
            base_with("normal_stiffness = 1e8", "normal_stiffness = \"1e8\""),
            vec![
                "string-number.toml:4".into(),
                "material.normal_stiffness".into(),
            ],
        ),
        (
            "units.toml",
            base_with("stress = 1e5", "stress = \"1 bar\""),
            vec!["units.toml:13".into(), "box.stress".into()],
        ),
        (
            "float-count.toml",
            base_with("increments = 2", "increments = 2.5"),
            vec!["float-count.toml:15".into(), "stages[0].increments".into()],
        ),
        (
            "inf-radius.toml",
            base_with("radius = 1e-4", "radius = inf"),
            vec!["inf-radius.toml:10".into(), "grains.crystal.radius".into()],
        ),
        (
            "nan-stress.toml",
            base_with("top = 2e5", "top = nan"),
            vec!["nan-stress.toml:16".into(), "stages[0].stress.top".into()],
        ),
        (
            "inf-depth.toml",
            base_with("friction = 0.5", "friction = 0.5\ndepth = -inf"),
            vec!["inf-depth.toml:7".into(), "material.depth".into()],
        ),
        (
            "zero-radius.toml",
            two_grains("[0.0, 2e-4]", "2e-4").replace("r = [1e-4, 1e-4]", "r = [0.0, 1e-4]"),
            vec!["zero-radius.toml:10".into(), "grains.r[0]".into()],
        ),
        (
            "far-grain.toml",
            two_grains("[0.0, 1e300]", "3e-4"),
            vec![
                "far-grain.toml:8".into(),
                "grains.x[1]".into(),
                "cell grid cannot hold".into(),
            ],
        ),
        (
            "no-grains.toml",
            two_grains("[]", "2e-4")
                .replace("y = [1e-4, 1e-4]", "y = []")
                .replace("r = [1e-4, 1e-4]", "r = []"),
            vec!["no-grains.toml:7".into(), "no grains".into()],
        ),
        (
            "no-rows.toml",
            base_with("rows = 5", "rows = 0"),
            vec!["no-rows.toml:8".into(), "grains.crystal.rows".into()],
        ),
        (
            "huge-crystal.toml",
            huge_crystal.clone(),
            vec![
                format!(
                    "huge-crystal.toml:{}",
                    line_of(&huge_crystal, "[grains.crystal]")
                ),
                "at most 1e8".into(),
            ],
        ),
        (
            "huge-program.toml",
            huge_program.clone(),
            vec!["huge-program.toml:15".into(), "stages[0].increments".into()],
        ),
        (
            // Two parallel walls facing each other with no room between them.
            "walls-touching.toml",
            two_grains("[0.0, 2e-4]", "0.0"),
            vec![
                "walls-touching.toml".into(),
                "walls[1]".into(),
                "wall `top` cuts".into(),
            ],
        ),
        (
            // A wall through the grains' centres.
            "wall-across.toml",
            two_grains("[0.0, 2e-4]", "1e-4"),
            vec!["wall-across.toml".into(), "walls[1]".into()],
        ),
        (
            "grains-in-one-place.toml",
            two_grains("[0.0, 0.0]", "2e-4"),
            vec![
                "grains-in-one-place.toml".into(),
                "key `grains`".into(),
                "grains 0 and 1".into(),
            ],
        ),
        (
            "anisotropy.toml",
            base_with(
                "friction = 0.5",
                "friction = 0.5\ncohesion_horizontal = 1.5",
            ),
            vec![
                "anisotropy.toml:7".into(),
                "material.cohesion_horizontal".into(),
            ],
        ),
        (
            "region-both.toml",
            both.clone(),
            vec![
                format!("region-both.toml:{}", line_of(&both, "radius = 3e-4")),
                "regions[0].radius".into(),
                "not both".into(),
            ],
        ),
        (
            "region-inverted.toml",
            inverted.clone(),
            vec![
                format!("region-inverted.toml:{}", line_of(&inverted, "max = ")),
                "regions[0].max".into(),
            ],
        ),
        (
            "region-inner.toml",
            inner.clone(),
            vec![
                format!("region-inner.toml:{}", line_of(&inner, "inner_radius")),
                "regions[0].inner_radius".into(),
            ],
        ),
        (
            "region-twice.toml",
            twice.clone(),
            vec![
                "region-twice.toml".into(),
                "regions[1].name".into(),
                "two regions".into(),
            ],
        ),
        (
            "region-shapeless.toml",
            shapeless.clone(),
            vec![
                "region-shapeless.toml".into(),
                "regions[0].name".into(),
                "rectangle".into(),
            ],
        ),
        (
            "moving-ring.toml",
            circle("grains = \"inside\"\nmoves = [0.0, -1.0]"),
            vec![
                "moving-ring.toml".into(),
                "circles[0].moves".into(),
                "only a plug".into(),
            ],
        ),
        (
            "zero-move.toml",
            circle("grains = \"outside\"\nmoves = [0.0, 0.0]"),
            vec![
                "zero-move.toml".into(),
                "circles[0].moves".into(),
                "not be zero".into(),
            ],
        ),
        (
            "touch-unmoving.toml",
            circle("grains = \"outside\"\ntouch = true"),
            vec!["touch-unmoving.toml".into(), "circles[0].touch".into()],
        ),
        (
            "drop-too-big.toml",
            base_with(
                "increments = 2",
                "increments = 2\nuntil_failure = true\nfailure_drop = 1.5",
            ),
            vec!["drop-too-big.toml".into(), "stages[0].failure_drop".into()],
        ),
        (
            "drop-not-to-failure.toml",
            base_with("increments = 2", "increments = 2\nfailure_drop = 0.5"),
            vec![
                "drop-not-to-failure.toml".into(),
                "until_failure = true".into(),
            ],
        ),
        (
            "prepares-a-sample.toml",
            sample_scene(""),
            vec!["prepares-a-sample.toml".into(), "grainstat generate".into()],
        ),
    ];
    for (name, text, phrases) in &cases {
        let path = write(dir.path(), name, text);
        let out = grainstat(&["run", &path, "--quiet", "--no-plot"]);
        let phrases: Vec<&str> = phrases.iter().map(String::as_str).collect();
        assert_input_error(&out, &phrases);
    }
    // A wall that cuts a grain by a hair is allowed: packings start touching.
    let path = write(
        dir.path(),
        "touching.toml",
        &two_grains("[0.0, 2e-4]", "1.9999e-4"),
    );
    let result = dir.path().join("touching.h5");
    let out = grainstat(&[
        "run",
        &path,
        "-o",
        result.to_str().unwrap(),
        "--quiet",
        "--no-plot",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
}

#[test]
fn impossible_samples_are_exit_status_2() {
    let dir = tempfile::tempdir().unwrap();
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        (
            // Discs at full size cannot be sprinkled into a region at 0.9 solid fraction.
            "too-dense.toml",
            sample_scene("start_fraction = 1.0\nsolid_fraction = 0.9\n"),
            vec!["too-dense.toml", "sample.start_fraction", "no room"],
        ),
        (
            // A region thinner than one grain.
            "too-thin.toml",
            sample_scene("").replace("aspect = 2.5", "aspect = 1e-6"),
            vec!["too-thin.toml", "does not fit"],
        ),
        (
            "empty.toml",
            sample_scene("").replace("grains = 60", "grains = 0"),
            vec!["empty.toml:10", "sample.grains"],
        ),
        (
            "dense-limit.toml",
            sample_scene("solid_fraction = 0.95\n"),
            vec!["dense-limit.toml:15", "sample.solid_fraction"],
        ),
        (
            // Sand grains pressed several radii into one another: growth did not converge
            // (exit 3) at 1e10 Pa, and at 1e30 Pa it aborted allocating 34 GB of grid cells.
            "crushing.toml",
            sample_scene("").replace("stress = 1e5", "stress = 1e10"),
            vec!["crushing.toml:14", "sample.stress", "press the grains"],
        ),
        (
            "no-sample.toml",
            BASE.to_string(),
            vec!["no-sample.toml", "[sample]"],
        ),
    ];
    let out_path = dir.path().join("out.h5");
    for (name, text, phrases) in &cases {
        let path = write(dir.path(), name, text);
        let out = grainstat(&[
            "generate",
            &path,
            "-o",
            out_path.to_str().unwrap(),
            "--quiet",
        ]);
        assert_input_error(&out, phrases);
        assert!(!out_path.exists(), "{name}: nothing written");
    }
}

#[test]
fn missing_and_corrupt_hdf5_files_are_exit_status_2() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "scene.toml", BASE);
    let result = dir.path().join("result.h5");
    let out = grainstat(&[
        "run",
        &scene,
        "-o",
        result.to_str().unwrap(),
        "--quiet",
        "--no-plot",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let bytes = std::fs::read(&result).unwrap();

    let text = write(dir.path(), "text.h5", "not HDF5\n");
    let truncated = dir.path().join("truncated.h5");
    std::fs::write(&truncated, &bytes[..bytes.len() / 3]).unwrap();
    let truncated = truncated.to_str().unwrap().to_string();
    let folder = dir.path().to_str().unwrap().to_string();
    let missing = dir.path().join("missing.h5").to_str().unwrap().to_string();

    // Resuming from each.
    for (file, phrase) in [
        (&text, "cannot be opened as an HDF5 file"),
        (&truncated, "truncated"),
        (&folder, "is a directory"),
        (&missing, "no such file"),
    ] {
        let out = grainstat(&["run", &scene, "--resume", file, "--quiet", "--no-plot"]);
        assert_input_error(&out, &[file, phrase]);
        assert!(!stderr(&out).contains("swapping in its next version"));
    }

    // A result file damaged by one byte (found by flipping bytes at random) on which libhdf5
    // itself crashes with SIGSEGV: resuming from it, or summarising it, is bad input too.
    let crashing = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/corrupt-result.h5");
    let copy = dir.path().join("corrupt-result.h5");
    std::fs::copy(&crashing, &copy).unwrap();
    let copy = copy.to_str().unwrap();
    let out = grainstat(&["run", &scene, "--resume", copy, "--quiet", "--no-plot"]);
    assert_input_error(&out, &[copy, "is corrupt", "crashed the HDF5 library"]);
    let out = grainstat(&["info", copy]);
    assert_input_error(&out, &[copy, "crashed the HDF5 library"]);

    // Starting from each as a sample, and from a result file that is not a sample.
    let result = result.to_str().unwrap().to_string();
    for (file, phrase) in [
        (&text, "cannot be opened as an HDF5 file"),
        (&truncated, "truncated"),
        (&missing, "no such file"),
        (&result, "not a sample file"),
    ] {
        let text = BASE.replace(
            "[grains.crystal]\nrows = 5\ncolumns = 6\nradius = 1e-4\n",
            &format!("[grains]\nsample = {file:?}\n"),
        );
        let path = write(dir.path(), "from-sample.toml", &text);
        let out = grainstat(&["run", &path, "--quiet", "--no-plot"]);
        assert_input_error(&out, &[file, phrase]);
    }
}
