//! Scene and solver input: every kind of bad input is an error that names the key and the
//! line (expected lines are computed from each test's own text).

mod common;

use common::BASE;
use grainstat::scene::{
    build_grains, load_scene, parse_scene, parse_solver, Friction, GrainSource, LawKind,
};
use grainstat::InputError;
use std::path::{Path, PathBuf};

/// 1-based line of the first line of `text` containing `needle`.
fn line_with(text: &str, needle: &str) -> usize {
    text.lines()
        .position(|l| l.contains(needle))
        .unwrap_or_else(|| panic!("`{needle}` not in the text"))
        + 1
}

/// `BASE` with one line replaced; panics if the line is not there, so tests stay honest.
fn base_with(old: &str, new: &str) -> String {
    assert!(BASE.contains(old), "`{old}` not in BASE");
    BASE.replacen(old, new, 1)
}

fn parse_err(text: &str) -> InputError {
    match parse_scene(text, "scene.toml") {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e,
    }
}

fn assert_at(e: &InputError, key: Option<&str>, line: Option<usize>) {
    assert_eq!(e.file, "scene.toml", "{e}");
    assert_eq!(e.key.as_deref(), key, "{e}");
    assert_eq!(e.line, line, "{e}");
    assert!(!e.message.is_empty());
}

fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data")
}

#[test]
fn valid_scene_parses() {
    let scene = parse_scene(BASE, "scene.toml").unwrap();
    assert_eq!(scene.name, "t");
    assert_eq!(scene.material.law, LawKind::Linear);
    assert_eq!(scene.material.friction, Friction::Coefficient(0.5));
    let crystal = scene.grains.crystal.as_ref().unwrap();
    assert_eq!((crystal.rows, crystal.columns), (5, 6));
    assert_eq!(scene.stages.len(), 1);
    assert_eq!(scene.stages[0].stress["top"], 2e5);
    assert_eq!(scene.output.every, 1);
}

#[test]
fn malformed_toml_names_the_line() {
    let text = base_with("poisson = 0.16", "poisson = = 0.16");
    let e = parse_err(&text);
    // A syntax error has a line but no key: the key around it cannot be trusted.
    assert_at(&e, None, Some(line_with(&text, "poisson")));
    assert!(e.message.starts_with("invalid TOML"), "{e}");
    let text = base_with("[box]", "[box");
    let e = parse_err(&text);
    assert_at(&e, None, Some(line_with(&text, "[box")));
}

#[test]
fn unknown_key_names_key_and_line() {
    let text = base_with("friction = 0.5", "frction = 0.5");
    let e = parse_err(&text);
    assert_at(
        &e,
        Some("material.frction"),
        Some(line_with(&text, "frction")),
    );
    assert!(e.message.contains("frction"), "{e}");
}

#[test]
fn unknown_key_in_a_stage_names_the_stage() {
    let text = format!("{BASE}[[stages]]\nincrements = 1\ndisplacment = {{ bottom = 1e-6 }}\n");
    let e = parse_err(&text);
    assert_at(
        &e,
        Some("stages[1].displacment"),
        Some(line_with(&text, "displacment")),
    );
}

#[test]
fn wrong_type_names_key_and_line() {
    let text = base_with("rows = 5", "rows = \"five\"");
    let e = parse_err(&text);
    assert_at(
        &e,
        Some("grains.crystal.rows"),
        Some(line_with(&text, "rows =")),
    );
    let text = base_with("law = \"linear\"", "law = \"lineer\"");
    let e = parse_err(&text);
    assert_at(&e, Some("material.law"), Some(line_with(&text, "lineer")));
    assert!(e.message.contains("linear"), "{e}");
}

#[test]
fn missing_key_names_its_table() {
    let text = base_with("radius = 1e-4\n", "");
    let e = parse_err(&text);
    assert_at(
        &e,
        Some("grains.crystal.radius"),
        Some(line_with(&text, "[grains.crystal]")),
    );
}

#[test]
fn negative_radius() {
    let text = base_with(
        "[grains.crystal]\nrows = 5\ncolumns = 6\nradius = 1e-4\n",
        "[grains]\nx = [0.0, 2e-4]\ny = [0.0, 0.0]\nr = [\n  1e-4,\n  -1e-4,\n]\n",
    );
    let e = parse_err(&text);
    assert_at(&e, Some("grains.r[1]"), Some(line_with(&text, "-1e-4")));
    assert!(e.message.contains("> 0"), "{e}");

    let text = base_with("radius = 1e-4", "radius = -1e-4");
    let e = parse_err(&text);
    assert_at(
        &e,
        Some("grains.crystal.radius"),
        Some(line_with(&text, "radius")),
    );
}

#[test]
fn negative_friction() {
    let text = base_with("friction = 0.5", "friction = -0.1");
    let e = parse_err(&text);
    assert_at(
        &e,
        Some("material.friction"),
        Some(line_with(&text, "friction")),
    );
    assert!(e.message.contains(">= 0"), "{e}");
}

#[test]
fn infinite_friction_is_allowed_by_name_only() {
    let text = base_with("friction = 0.5", "friction = \"infinite\"");
    let scene = parse_scene(&text, "scene.toml").unwrap();
    assert_eq!(scene.material.friction, Friction::Infinite);
    let text = base_with("friction = 0.5", "friction = inf");
    let e = parse_err(&text);
    assert_at(
        &e,
        Some("material.friction"),
        Some(line_with(&text, "friction")),
    );
}

#[test]
fn nan_is_rejected_everywhere() {
    let text = base_with("stress = 1e5", "stress = nan");
    let e = parse_err(&text);
    assert_at(&e, Some("box.stress"), Some(line_with(&text, "nan")));

    let text = base_with("top = 2e5", "top = nan");
    let e = parse_err(&text);
    assert_at(
        &e,
        Some("stages[0].stress.top"),
        Some(line_with(&text, "nan")),
    );

    let text = base_with("normal_stiffness = 1e8", "normal_stiffness = -inf");
    let e = parse_err(&text);
    assert_at(
        &e,
        Some("material.normal_stiffness"),
        Some(line_with(&text, "-inf")),
    );

    let text = format!("{BASE}[[walls]]\nname = \"w\"\npoint = [0.0, nan]\nnormal = [0.0, 1.0]\n");
    let e = parse_err(&text);
    assert_at(&e, Some("walls[0].point[1]"), Some(line_with(&text, "nan")));
}

#[test]
fn stage_naming_an_unknown_wall() {
    let text = base_with(
        "stress = { top = 2e5, right = 1e5 }",
        "stress = { top = 2e5, middle = 1e5 }",
    );
    let e = parse_err(&text);
    assert_at(
        &e,
        Some("stages[0].stress.middle"),
        Some(line_with(&text, "middle")),
    );
    assert!(e.message.contains("`top`"), "lists the walls: {e}");
}

#[test]
fn stage_loading_a_wall_the_wrong_way() {
    let text = format!("{BASE}[[stages]]\nincrements = 1\nstress = {{ bottom = 1e5 }}\n");
    let e = parse_err(&text);
    let line = text.lines().count();
    assert_at(&e, Some("stages[1].stress.bottom"), Some(line));
    assert!(e.message.contains("displacement-controlled"), "{e}");

    let text = format!("{BASE}[[stages]]\nincrements = 1\ndisplacement = {{ top = 1e-6 }}\n");
    let e = parse_err(&text);
    assert_at(&e, Some("stages[1].displacement.top"), Some(line));
}

#[test]
fn wall_names_must_be_unique() {
    let text =
        format!("{BASE}[[walls]]\nname = \"top\"\npoint = [0.0, 0.0]\nnormal = [0.0, 1.0]\n");
    let e = parse_err(&text);
    assert_at(
        &e,
        Some("walls[0].name"),
        Some(line_with(&text, "name = \"top\"")),
    );
}

#[test]
fn zero_normal_and_bad_box_side() {
    let text = format!("{BASE}[[walls]]\nname = \"w\"\npoint = [0.0, 0.0]\nnormal = [0.0, 0.0]\n");
    let e = parse_err(&text);
    assert_at(
        &e,
        Some("walls[0].normal"),
        Some(line_with(&text, "normal =")),
    );

    let text = base_with("[\"top\", \"right\"]", "[\"top\",\n  \"up\"]");
    let e = parse_err(&text);
    assert_at(
        &e,
        Some("box.stress_controlled[1]"),
        Some(line_with(&text, "\"up\"")),
    );
}

#[test]
fn missing_grain_source() {
    let text = base_with(
        "[grains.crystal]\nrows = 5\ncolumns = 6\nradius = 1e-4\n",
        "[grains]\n",
    );
    let e = parse_err(&text);
    assert_at(&e, Some("grains"), Some(line_with(&text, "[grains]")));
    assert!(e.message.contains("crystal"), "says what is allowed: {e}");

    // No `[grains]` at all: serde's missing field, at the top of the document.
    let text = base_with(
        "[grains.crystal]\nrows = 5\ncolumns = 6\nradius = 1e-4\n",
        "",
    );
    let e = parse_err(&text);
    assert_at(&e, Some("grains"), None);
}

#[test]
fn two_grain_sources() {
    let text = base_with(
        "[grains.crystal]",
        "[grains]\nfile = \"g.csv\"\n[grains.crystal]",
    );
    let e = parse_err(&text);
    assert_at(&e, Some("grains"), Some(line_with(&text, "[grains]")));
}

#[test]
fn no_stages_is_an_error() {
    let end = BASE.find("[[stages]]").unwrap();
    let e = parse_err(&BASE[..end]);
    assert_at(&e, Some("stages"), None);
    assert!(e.message.contains("nothing to do"), "{e}");
}

#[test]
fn zero_increments_and_output_every() {
    let text = format!(
        "{}\n[output]\nevery = 0\n",
        base_with("increments = 2", "increments = 0")
    );
    let e = parse_err(&text);
    assert_at(
        &e,
        Some("stages[0].increments"),
        Some(line_with(&text, "increments")),
    );
    // The second problem is listed too, with its own line.
    let every = format!(
        "scene.toml:{}: key `output.every`",
        line_with(&text, "every")
    );
    assert!(e.message.contains(&every), "{e}");
}

#[test]
fn hertz_needs_shear_modulus_and_no_cohesion() {
    let text = base_with("law = \"linear\"", "law = \"hertz\"");
    let e = parse_err(&text);
    assert_at(
        &e,
        Some("material.shear_modulus"),
        Some(line_with(&text, "[material]")),
    );
    let text = base_with(
        "law = \"linear\"\nnormal_stiffness = 1e8",
        "law = \"hertz\"\nshear_modulus = 2.9e10\ncohesion = 1e6",
    );
    let e = parse_err(&text);
    assert_at(
        &e,
        Some("material.cohesion"),
        Some(line_with(&text, "cohesion")),
    );
}

#[test]
fn poisson_range() {
    let text = base_with("poisson = 0.16", "poisson = 0.5");
    let e = parse_err(&text);
    assert_at(
        &e,
        Some("material.poisson"),
        Some(line_with(&text, "poisson")),
    );
}

#[test]
fn garbage_does_not_panic() {
    for text in [
        "",
        "[",
        "[[",
        "a = [",
        "= 1",
        "\u{feff}",
        "[material]\nlaw = 3",
        "grains = 5",
        "stages = [1, 2]",
        "[[material]]",
        "name = \"t\"\n[grains]\nx = [1e400]\n",
    ] {
        assert!(parse_scene(text, "s.toml").is_err(), "{text:?}");
    }
}

#[test]
fn csv_grains() {
    let source = GrainSource {
        file: Some("grains_ok.csv".into()),
        ..Default::default()
    };
    let grains = build_grains(&source, &data_dir(), "scene.toml").unwrap();
    assert_eq!(grains.position, vec![[0.0, 0.0], [2e-4, 0.0]]);
    assert_eq!(grains.radius, vec![1e-4, 1e-4]);
}

#[test]
fn csv_bad_line_names_the_csv_line() {
    let dir = data_dir();
    for (name, needle) in [
        ("grains_bad_line.csv", "2e-4;"),
        ("grains_negative_radius.csv", "-1e-4"),
    ] {
        let source = GrainSource {
            file: Some(name.into()),
            ..Default::default()
        };
        let e = build_grains(&source, &dir, "scene.toml").unwrap_err();
        let text = std::fs::read_to_string(dir.join(name)).unwrap();
        assert!(e.file.ends_with(name), "{e}");
        assert_eq!(e.line, Some(line_with(&text, needle)), "{e}");
    }
}

#[test]
fn csv_without_grains_or_missing() {
    let dir = data_dir();
    let source = GrainSource {
        file: Some("grains_empty.csv".into()),
        ..Default::default()
    };
    let e = build_grains(&source, &dir, "scene.toml").unwrap_err();
    assert!(e.message.contains("no grains"), "{e}");
    let source = GrainSource {
        file: Some("grains_not_there.csv".into()),
        ..Default::default()
    };
    let e = build_grains(&source, &dir, "scene.toml").unwrap_err();
    assert!(e.file.ends_with("grains_not_there.csv"), "{e}");
}

#[test]
fn inline_and_crystal_grains() {
    let scene = parse_scene(BASE, "scene.toml").unwrap();
    let grains = build_grains(&scene.grains, Path::new("."), "scene.toml").unwrap();
    // 3 short rows of 5 and 2 long rows of 6.
    assert_eq!(grains.len(), 27);

    let source = GrainSource {
        x: vec![0.0, 2e-4],
        y: vec![0.0, 0.0],
        r: vec![1e-4, 1e-4],
        ..Default::default()
    };
    let grains = build_grains(&source, Path::new("."), "scene.toml").unwrap();
    assert_eq!(grains.position[1], [2e-4, 0.0]);

    let source = GrainSource {
        x: vec![0.0, 2e-4],
        y: vec![0.0],
        r: vec![1e-4, 1e-4],
        ..Default::default()
    };
    let e = build_grains(&source, Path::new("."), "scene.toml").unwrap_err();
    assert_eq!(
        (e.file.as_str(), e.key.as_deref()),
        ("scene.toml", Some("grains.y"))
    );
}

#[test]
fn load_scene_returns_the_text_or_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, BASE).unwrap();
    let (scene, text) = load_scene(&path).unwrap();
    assert_eq!((scene.name.as_str(), text.as_str()), ("t", BASE));

    let missing = dir.path().join("nope.toml");
    let e = load_scene(&missing).unwrap_err();
    assert!(e.file.ends_with("nope.toml"), "{e}");
    assert_eq!(e.line, None);
}

#[test]
fn solver_files() {
    let cfg = parse_solver("tolerance = 1e-9\n", "solver.toml").unwrap();
    assert_eq!(cfg.tolerance, 1e-9);

    let text = "tolerance = 1e-9\nmax_iteration = 5\n";
    let e = parse_solver(text, "solver.toml").unwrap_err();
    assert_eq!(
        (e.key.as_deref(), e.line),
        (Some("max_iteration"), Some(2)),
        "{e}"
    );

    let text = "tolerance = 1e-9\n\nskin = nan\n";
    let e = parse_solver(text, "solver.toml").unwrap_err();
    assert_eq!((e.key.as_deref(), e.line), (Some("skin"), Some(3)), "{e}");

    let text = "# settings\nslip_tangent = \"consistent\"\n";
    let e = parse_solver(text, "solver.toml").unwrap_err();
    assert_eq!(
        (e.key.as_deref(), e.line),
        (Some("slip_tangent"), Some(2)),
        "{e}"
    );
}

/// The Newton solver's files: its strategy reads as the minimisation, each of its own
/// settings is refused, named with its line.
#[test]
fn solver_files_of_the_newton_solver() {
    let cfg = parse_solver("strategy = \"newton\"\n", "solver.toml").unwrap();
    assert_eq!(cfg, grainstat::solver::SolverConfig::default());
    for (key, value) in [
        ("linear", "\"lu\""),
        ("slip_tangent", "\"elasto-plastic\""),
        ("displacement_tolerance", "1e-8"),
        ("line_search", "true"),
        ("max_topology_passes", "30"),
        ("settle_after_cuts", "0"),
        ("settle_steps", "20000"),
        ("settle_tolerance", "1e-3"),
    ] {
        let text = format!("tolerance = 1e-8\n{key} = {value}\n");
        let e = parse_solver(&text, "solver.toml").unwrap_err();
        assert_eq!((e.key.as_deref(), e.line), (Some(key), Some(2)), "{e}");
        assert!(e.message.contains("Newton"), "{e}");
    }
}

/// The presets: `minimise.toml` is the defaults written out, `reference.toml` the global
/// solver to a tighter tolerance.
#[test]
fn the_solver_presets_read() {
    let read = |name: &str| {
        let path = format!("solvers/{name}");
        parse_solver(&std::fs::read_to_string(&path).unwrap(), &path).unwrap()
    };
    let defaults = grainstat::solver::SolverConfig::default();
    assert_eq!(read("minimise.toml"), defaults);
    let reference = read("reference.toml");
    assert_eq!(reference.strategy, defaults.strategy);
    assert!(reference.tolerance < defaults.tolerance);
}

#[test]
fn every_example_scene_loads() {
    let mut count = 0;
    for entry in std::fs::read_dir("examples").unwrap() {
        let path = entry.unwrap().path();
        let sweep = path
            .file_name()
            .is_some_and(|n| n.to_string_lossy().starts_with("sweep-"));
        if sweep {
            // A sweep file names a scene, which must load, and keys it has.
            let spec = grainstat::sweep::load_sweep(&path)
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            let scene = path.with_file_name(&spec.scene);
            let text = std::fs::read_to_string(&scene).unwrap();
            for value in &spec.values {
                let text = grainstat::sweep::set_keys(&text, &spec.keys, value, "sweep")
                    .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
                grainstat::scene::parse_scene(&text, &scene.display().to_string())
                    .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            }
        } else if path.extension().is_some_and(|e| e == "toml") {
            grainstat::scene::load_scene(&path)
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            count += 1;
        }
    }
    assert!(count >= 5, "{count} example scenes");
}
