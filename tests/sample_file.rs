//! Sample files: a prepared sample reads back exactly (HDF5 and CSV), bad files are input
//! errors naming the file, and a scene can start from a sample.

use grainstat::geometry::{Circle, GrainSet, Pair, Side, Wall, WallControl, WallSet};
use grainstat::sample::{
    read_csv, read_sample, sprinkle, write_csv, write_sample, ContactHistory, Region, SampleFile,
    SizeDistribution, SizeKind,
};
use grainstat::scene::{build_grains, load_scene, parse_scene};
use grainstat::{Error, InputError};
use std::path::Path;

/// A sprinkled sample that has moved since: displacements, rotations and bonds that only
/// an exact file keeps.
fn prepared(n: usize, region: Region) -> SampleFile {
    let d = SizeDistribution::new(SizeKind::A, 1e-4, 4.0).unwrap();
    let radii = d.radii(n, 17);
    let solid: f64 = radii.iter().map(|r| std::f64::consts::PI * r * r).sum();
    let region = region.with_area(solid / 0.8);
    let mut grains = sprinkle(&region, &radii, 0.2, 17).unwrap();
    let step: Vec<[f64; 2]> = (0..n)
        .map(|i| [1e-7 / (i as f64 + 3.0), -1e-8 * (i as f64).sqrt()])
        .collect();
    grains.displace(&step);
    grains.displace(&step);
    grains.rotation = (0..n).map(|i| 1e-3 / (i as f64 + 7.0)).collect();
    SampleFile {
        grains,
        region,
        distribution: Some(d),
        seed: u64::MAX - 5,
        description: "type A, M = 4, blown up to 1 bar — ünïcode".into(),
        stress: 1e5 / 3.0,
        contacts_per_grain: 3.987_654_321,
        bonds: (1..n).step_by(3).map(|i| (i - 1, i)).collect(),
        walls: WallSet {
            walls: vec![
                Wall {
                    name: "bottom".into(),
                    normal: [0.0, 1.0],
                    offset: -1e-4,
                    pivot: [0.0, -1e-4],
                    turn: 0.0,
                    position: 3.25e-7,
                    slide: 0.0,
                    control: WallControl::Stress,
                    stress: 1e5 / 3.0,
                    length: None,
                    friction: f64::INFINITY,
                    circle: None,
                },
                Wall {
                    name: "ring".into(),
                    normal: [0.0; 2],
                    offset: 0.0,
                    pivot: [0.0; 2],
                    turn: 0.0,
                    position: -1e-9,
                    slide: 0.0,
                    control: WallControl::Displacement,
                    stress: 0.0,
                    length: Some(2e-3),
                    friction: 0.5,
                    circle: Some(Circle {
                        center: [1e-3, 2e-3],
                        radius: 5e-3,
                        grains_inside: true,
                        moves: None,
                    }),
                },
            ],
        },
        contacts: vec![
            ContactHistory {
                pair: Pair {
                    a: Side::Grain(0),
                    b: 1,
                },
                shear_force: -1.0 / 3.0,
                shear_displacement: 1e-9 / 7.0,
            },
            ContactHistory {
                pair: Pair {
                    a: Side::Wall(1),
                    b: 2,
                },
                shear_force: 2.5e-3,
                shear_displacement: 0.0,
            },
        ],
    }
}

fn input_error(e: Error) -> InputError {
    match e {
        Error::Input(e) => e,
        other => panic!("expected an input error, got {other}"),
    }
}

#[test]
fn samples_read_back_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let shapes = [
        Region::Rectangle {
            width: 1.0,
            height: 2.5,
        },
        Region::Annulus {
            inner_radius: 1.0,
            outer_radius: 3.0,
        },
        Region::Beam {
            length: 6.0,
            height: 1.0,
        },
    ];
    // 2000 grains: chunked and compressed datasets; 50: plain ones.
    for (k, (n, shape)) in [(2000, shapes[0]), (50, shapes[1]), (300, shapes[2])]
        .into_iter()
        .enumerate()
    {
        let mut sample = prepared(n, shape);
        if k == 1 {
            sample.distribution = None;
            sample.bonds.clear();
            sample.description.clear();
        }
        let path = dir.path().join(format!("nested/s{k}.h5"));
        write_sample(&path, &sample).unwrap();
        let back = read_sample(&path).unwrap();
        assert_eq!(back, sample);
        // Bit for bit, including what `==` cannot see (the sign of zero).
        let bits = |g: &GrainSet| -> Vec<u64> {
            g.displacement
                .iter()
                .flatten()
                .chain(g.origin.iter().flatten())
                .map(|v| v.to_bits())
                .collect()
        };
        assert_eq!(bits(&back.grains), bits(&sample.grains));
        // Writing again over the file works.
        write_sample(&path, &back).unwrap();
        assert_eq!(read_sample(&path).unwrap(), sample);
    }
}

#[test]
fn an_empty_sample_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let sample = SampleFile {
        grains: GrainSet::new(vec![], vec![]),
        region: Region::Rectangle {
            width: 1.0,
            height: 1.0,
        },
        distribution: None,
        seed: 0,
        description: String::new(),
        stress: 0.0,
        contacts_per_grain: 0.0,
        bonds: vec![],
        walls: WallSet::default(),
        contacts: vec![],
    };
    let path = dir.path().join("empty.h5");
    write_sample(&path, &sample).unwrap();
    assert_eq!(read_sample(&path).unwrap(), sample);
}

#[test]
fn csv_reads_back_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let mut sample = prepared(
        500,
        Region::Rectangle {
            width: 1.0,
            height: 2.5,
        },
    );
    // Awkward values: no short decimal form, tiny, huge, negative.
    sample.grains.position[0] = [0.1 + 0.2, -1e-300];
    sample.grains.position[1] = [1.0 / 3.0, 12345.678e10];
    sample.grains.radius[2] = 5e-324;
    let at_rest = GrainSet::new(sample.grains.position.clone(), sample.grains.radius.clone());
    let path = dir.path().join("csv/grains.csv");
    write_csv(&path, &sample.grains).unwrap();
    assert_eq!(read_csv(&path).unwrap(), at_rest);
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(
        text.starts_with("x,y,r\n3.0000000000000004e-1,-1e-300,"),
        "{text:.80}"
    );

    let mut bad = at_rest.clone();
    bad.radius[3] = f64::NAN;
    let e = input_error(write_csv(dir.path().join("bad.csv"), &bad).unwrap_err());
    assert!(e.message.contains("grain 3"), "{e}");
    let e = input_error(read_csv(dir.path().join("missing.csv")).unwrap_err());
    assert!(e.file.ends_with("missing.csv"), "{e}");
}

#[test]
fn bad_files_are_input_errors() {
    let dir = tempfile::tempdir().unwrap();
    let named = |path: &Path, e: &InputError| {
        assert_eq!(e.file, path.display().to_string(), "{e}");
        assert!(!e.message.is_empty());
    };

    let missing = dir.path().join("missing.h5");
    let e = input_error(read_sample(&missing).unwrap_err());
    named(&missing, &e);
    assert!(e.message.contains("no such file"), "{e}");

    let e = input_error(read_sample(dir.path()).unwrap_err());
    assert!(e.message.contains("directory"), "{e}");

    let garbage = dir.path().join("garbage.h5");
    std::fs::write(&garbage, b"this is not HDF5 at all\n").unwrap();
    let e = input_error(read_sample(&garbage).unwrap_err());
    named(&garbage, &e);
    assert!(e.message.contains("HDF5"), "{e}");

    let empty = dir.path().join("empty.h5");
    std::fs::write(&empty, b"").unwrap();
    named(&empty, &input_error(read_sample(&empty).unwrap_err()));

    // HDF5 files that are not samples: no `format`, another format, a result file.
    let foreign = dir.path().join("foreign.h5");
    hdf5::File::create(&foreign).unwrap();
    let e = input_error(read_sample(&foreign).unwrap_err());
    assert!(e.message.contains("no `format`"), "{e}");
    for (format, needle) in [
        ("something-else", "`something-else`"),
        ("grainstat-result", "result file"),
    ] {
        let f = hdf5::File::create(&foreign).unwrap();
        let v: hdf5::types::VarLenUnicode = format.parse().unwrap();
        f.new_attr::<hdf5::types::VarLenUnicode>()
            .create("format")
            .unwrap()
            .write_scalar(&v)
            .unwrap();
        drop(f);
        let e = input_error(read_sample(&foreign).unwrap_err());
        named(&foreign, &e);
        assert!(e.message.contains(needle), "{e}");
    }
}

#[test]
fn damaged_samples_are_input_errors() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.h5");
    let sample = prepared(
        40,
        Region::Rectangle {
            width: 1.0,
            height: 2.5,
        },
    );

    // Each damage, then the words the error must contain.
    type Damage = fn(&hdf5::File);
    let damages: [(Damage, &str); 6] = [
        (|f| f.unlink("grains/radius").unwrap(), "radius"),
        (
            |f| {
                f.attr("format_version")
                    .unwrap()
                    .write_scalar(&2i64)
                    .unwrap();
            },
            "version 2",
        ),
        (
            |f| {
                f.attr("grains").unwrap().write_scalar(&41i64).unwrap();
            },
            "shape",
        ),
        (
            |f| {
                f.unlink("bonds").unwrap();
                f.new_dataset_builder()
                    .with_data(&ndarray::arr2(&[[0i64, 40]]))
                    .create("bonds")
                    .unwrap();
            },
            "bond 0 joins grains 0 and 40",
        ),
        (
            |f| {
                let v: hdf5::types::VarLenUnicode = "circle".parse().unwrap();
                f.group("region")
                    .unwrap()
                    .attr("shape")
                    .unwrap()
                    .write_scalar(&v)
                    .unwrap();
            },
            "`circle`",
        ),
        (
            |f| {
                f.group("distribution")
                    .unwrap()
                    .attr("ratio")
                    .unwrap()
                    .write_scalar(&0.5f64)
                    .unwrap();
            },
            "ratio",
        ),
    ];
    for (damage, needle) in damages {
        write_sample(&path, &sample).unwrap();
        damage(&hdf5::File::open_rw(&path).unwrap());
        let e = input_error(read_sample(&path).unwrap_err());
        assert_eq!(e.file, path.display().to_string(), "{e}");
        assert!(e.message.contains(needle), "`{needle}` not in: {e}");
    }

    // Nor is a sample whose parts do not fit together written.
    let mut bad = sample.clone();
    bad.bonds.push((3, 3));
    let e = input_error(write_sample(dir.path().join("bad.h5"), &bad).unwrap_err());
    assert!(e.message.contains("bond"), "{e}");
    let mut bad = sample;
    bad.grains.rotation.pop();
    assert!(write_sample(dir.path().join("bad.h5"), &bad).is_err());
    assert!(!dir.path().join("bad.h5").exists());
}

/// A scene around a sample file, between box walls.
fn scene_text(grains: &str) -> String {
    format!(
        r#"name = "from-sample"
[material]
law = "linear"
normal_stiffness = 1e6
[grains]
{grains}
[box]
stress_controlled = ["top", "right"]
stress = 1e5
[[stages]]
increments = 1
stress = {{ top = 2e5, right = 1e5 }}
"#
    )
}

#[test]
fn a_scene_starts_from_a_sample() {
    let dir = tempfile::tempdir().unwrap();
    let sample = prepared(
        200,
        Region::Rectangle {
            width: 1.0,
            height: 2.5,
        },
    );
    write_sample(dir.path().join("x.h5"), &sample).unwrap();
    let scene_path = dir.path().join("scene.toml");
    std::fs::write(&scene_path, scene_text("sample = \"x.h5\"")).unwrap();

    let (scene, _) = load_scene(&scene_path).unwrap();
    assert_eq!(scene.grains.sample.as_deref(), Some("x.h5"));
    let grains = build_grains(&scene.grains, dir.path(), "scene.toml").unwrap();
    assert_eq!(grains, sample.grains);

    // A sample that is not there: the error names the sample file.
    let text = scene_text("sample = \"nope.h5\"");
    let scene = parse_scene(&text, "scene.toml").unwrap();
    let e = build_grains(&scene.grains, dir.path(), "scene.toml").unwrap_err();
    assert!(e.file.ends_with("nope.h5"), "{e}");

    // Exactly one source.
    let text = scene_text("sample = \"x.h5\"\ncrystal = { rows = 3, columns = 3, radius = 1e-4 }");
    let e = parse_scene(&text, "scene.toml").unwrap_err();
    assert_eq!(e.key.as_deref(), Some("grains"), "{e}");
    assert!(e.message.contains("`sample`"), "{e}");
    let text = scene_text("sample = \" \"");
    let e = parse_scene(&text, "scene.toml").unwrap_err();
    assert_eq!(e.key.as_deref(), Some("grains.sample"), "{e}");
    assert_eq!(e.line, Some(6), "{e}");
    let e = parse_scene(&scene_text(""), "scene.toml").unwrap_err();
    assert!(e.message.contains("sample = "), "{e}");
}
