//! A test starting from a saved sample's prepared equilibrium: walls kept where they ended,
//! contacts with their shear forces and bonds, so nothing moves until the test loads it.

mod common;

use common::sandstone;
use grainstat::sample::prepare::{prepare, PrepareSpec, RegionShape};
use grainstat::sample::{read_sample, write_sample, SizeDistribution, SizeKind};
use grainstat::scene::parse_scene;
use grainstat::simulation::Simulation;
use grainstat::solver::SolverConfig;
use grainstat::Error;

const SCENE: &str = r#"
name = "from-sample"
[material]
law = "linear"
normal_stiffness = 1e6
poisson = 0.16
friction = 0.6
cohesion = 1e8
bonded = true

[grains]
sample = "sample.h5"
walls = { bottom = "displacement", left = "displacement", top = "stress", right = "stress" }

[[stages]]
name = "hold"
increments = 1
stress = { top = 1e6, right = 1e6 }
"#;

#[test]
fn a_test_starts_from_the_prepared_equilibrium_with_walls_and_contact_history() {
    let spec = PrepareSpec {
        shape: RegionShape::Rectangle,
        aspect: 2.0,
        grains: 300,
        distribution: SizeDistribution::new(SizeKind::A, 1e-4, 4.0).unwrap(),
        seed: 5,
        friction: 0.3,
        stress: 1e6,
        start_fraction: 0.5,
        solid_fraction: 0.75,
        depth: None,
    };
    let prepared = prepare(
        &spec,
        &sandstone(),
        &SolverConfig::default(),
        "t",
        |_, _| {},
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sample.h5");
    write_sample(&path, &prepared.sample).unwrap();
    let sample = read_sample(&path).unwrap();
    assert_eq!(
        sample, prepared.sample,
        "walls and contacts read back as written"
    );
    assert_eq!(sample.walls.len(), 4);
    assert_eq!(sample.contacts.len(), prepared.state.contacts.len());
    // With f_gg' = 0.3 the prepared contacts carry shear forces worth keeping.
    assert!(sample.contacts.iter().any(|h| h.shear_force.abs() > 1e-3));

    let scene = parse_scene(SCENE, "from-sample.toml").unwrap();
    let mut sim =
        Simulation::from_sample(&scene, sample.clone(), SolverConfig::default(), "s").unwrap();
    let (error, grain) = sim.equilibrium_error();
    eprintln!("imbalance at the start: {error:.2e} (grain {grain})");
    assert!(error < 1e-7, "the prepared equilibrium is kept: {error:e}");
    let start = sim.measure();
    for s in &start.wall_stress {
        assert!((s - 1e6).abs() < 1e-6 * 1e6, "wall stress {s}");
    }
    let before = sim.state.grains.position.clone();
    sim.run_increment().unwrap();
    let moved = before
        .iter()
        .zip(&sim.state.grains.position)
        .map(|(a, b)| (a[0] - b[0]).hypot(a[1] - b[1]))
        .fold(0.0, f64::max);
    eprintln!(
        "largest move in the held increment: {:.2e} mean radii",
        moved / 1e-4
    );
    assert!(
        moved < 1e-8 * 1e-4,
        "nothing moves while the load is held: {moved:e} m"
    );

    // The grains alone, without their shear history, are out of balance.
    let mut bare = sample;
    bare.contacts.clear();
    let mut sim = Simulation::from_sample(&scene, bare, SolverConfig::default(), "s").unwrap();
    let (error, _) = sim.equilibrium_error();
    eprintln!("imbalance without the shear history: {error:.2e}");
    assert!(error > 1e-3);
}

#[test]
fn a_wall_the_sample_lacks_is_an_input_error() {
    let sample = grainstat::sample::SampleFile {
        grains: grainstat::samples::hex_crystal(3, 3, 1e-4, true),
        region: grainstat::sample::Region::Rectangle {
            width: 1e-3,
            height: 1e-3,
        },
        distribution: None,
        seed: 0,
        description: String::new(),
        stress: 0.0,
        contacts_per_grain: 0.0,
        bonds: Vec::new(),
        walls: Default::default(),
        contacts: Vec::new(),
    };
    let scene = parse_scene(SCENE, "from-sample.toml").unwrap();
    match Simulation::from_sample(&scene, sample, SolverConfig::default(), "from-sample.toml") {
        Err(Error::Input(e)) => {
            let text = e.to_string();
            assert!(text.contains("grains.walls.bottom"), "{text}");
            assert!(text.contains("has no wall `bottom`"), "{text}");
        }
        other => panic!("expected an input error, got {:?}", other.map(|_| ())),
    }
}
