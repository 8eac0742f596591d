//! Membranes (thesis 2.5, 4.1.2, 4.4): a prepared sample handed from its walls to membranes
//! reaches equilibrium, and a cemented annulus under outer pressure with a free borehole has
//! the elastic stresses of Lame's thick-walled cylinder (eq. A.113).

use grainstat::geometry::{Membrane, MembraneShape};
use grainstat::measure::ring_stresses;
use grainstat::sample::prepare::{prepare, PrepareSpec, Prepared, RegionShape};
use grainstat::sample::{SizeDistribution, SizeKind};
use grainstat::scene::{CohesionRadius, LawKind};
use grainstat::simulation::{MaterialModel, Simulation, StageProgram};
use grainstat::solver::SolverConfig;

/// Sandstone, table 8.
fn sandstone() -> MaterialModel {
    MaterialModel {
        law: LawKind::Linear,
        normal_stiffness: 1e6,
        shear_modulus: 0.0,
        poisson: 0.16,
        friction: 0.6,
        cohesion: 1e8,
        cohesion_radius: CohesionRadius::Mean,
        bonded: true,
        fixed_rotations: false,
    }
}

fn prepared(shape: RegionShape, aspect: f64, grains: usize, stress: f64) -> Prepared {
    let spec = PrepareSpec {
        shape,
        aspect,
        grains,
        distribution: SizeDistribution::new(SizeKind::A, 1e-4, 4.0).unwrap(),
        seed: 3,
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

/// A stage that moves no wall and takes walls and membranes to the given stresses.
fn stage(
    increments: usize,
    walls: usize,
    stress: Vec<Option<f64>>,
    pressure: Vec<Option<f64>>,
) -> StageProgram {
    StageProgram {
        name: "load".into(),
        increments,
        stress,
        normal_move: vec![0.0; walls],
        slide: vec![0.0; walls],
        pressure,
    }
}

#[test]
fn a_rectangle_handed_to_side_membranes_carries_the_biaxial_load() {
    let p0 = 1e6;
    let prepared = prepared(RegionShape::Rectangle, 2.0, 400, p0);
    let mut state = prepared.state;
    state.keep_walls(&["bottom", "top"]);
    let side = |name: &str, outward: [f64; 2]| Membrane {
        name: name.into(),
        shape: MembraneShape::Side { outward },
        pressure: p0,
    };
    state.membranes = vec![side("left", [-1.0, 0.0]), side("right", [1.0, 0.0])];
    // Walls: bottom (held), top (stress).
    let stages = vec![
        stage(2, 2, vec![None, None], vec![None, None]),
        stage(10, 2, vec![None, Some(3.0 * p0)], vec![None, None]),
    ];
    let mut sim = Simulation::from_state(
        "membranes".into(),
        SolverConfig::default(),
        sandstone(),
        prepared.depth,
        stages,
        state,
    )
    .unwrap();
    while !sim.is_finished() {
        let report = sim
            .run_increment()
            .unwrap_or_else(|e| panic!("increment {}: {e}", sim.state.increment + 1));
        let (error, grain) = sim.equilibrium_error();
        assert!(error < 1e-6, "imbalance {error:e} at grain {grain}");
        let m = &report.measurements;
        let top = sim.state.walls.walls[1].stress;
        let (sxx, syy) = (m.macro_stress[0][0], m.macro_stress[1][1]);
        eprintln!(
            "increment {}: sigma_xx {sxx:.4e}, sigma_yy {syy:.4e}, top wall {top:.4e}, \
             measured {:.4e}",
            report.increment, m.wall_stress[1]
        );
        assert!((sxx - p0).abs() < 0.02 * p0, "sigma_xx {sxx} against {p0}");
        assert!(
            (syy - top).abs() < 0.02 * top,
            "sigma_yy {syy} against {top}"
        );
    }
}

#[test]
#[ignore = "does not converge yet: freed of its plug, the annulus's first increment stalls \
            (membranes alone leave its rigid motions free, and outer grains chatter open and \
            shut); run with --ignored"]
fn a_cemented_annulus_under_outer_pressure_follows_lame() {
    let p0 = 1e6;
    let prepared = prepared(RegionShape::Annulus, 3.0, 2000, p0);
    let mut state = prepared.state;
    let radius = |name: &str| {
        let w = state.walls.walls.iter().find(|w| w.name == name).unwrap();
        w.surface(w.position)
    };
    let (inner, outer) = (radius("inner"), radius("outer"));
    // The borehole is freed of its plug and the ring is handed to a membrane.
    state.keep_walls(&[]);
    state.membranes = vec![Membrane {
        name: "outer".into(),
        shape: MembraneShape::Ring { center: [0.0; 2] },
        pressure: p0,
    }];
    let p1 = 3.0 * p0;
    let stages = vec![stage(4, 0, vec![], vec![Some(p1)])];
    let mut sim = Simulation::from_state(
        "lame".into(),
        SolverConfig::default(),
        sandstone(),
        prepared.depth,
        stages,
        state,
    )
    .unwrap();
    while !sim.is_finished() {
        sim.run_increment()
            .unwrap_or_else(|e| panic!("increment {}: {e}", sim.state.increment + 1));
    }
    let (error, grain) = sim.equilibrium_error();
    assert!(error < 1e-6, "imbalance {error:e} at grain {grain}");
    assert_eq!(sim.state.contacts.broken_bonds.len(), 0, "elastic");

    // Eq. A.113 with no pressure in the borehole: sigma_rr = A (1 - a^2/r^2),
    // sigma_tt = A (1 + a^2/r^2), A = p b^2 / (b^2 - a^2).
    let d = 2.0 * sim.mean_radius();
    let a_coef = p1 * outer * outer / (outer * outer - inner * inner);
    let edges: Vec<f64> = (0..)
        .map(|k| inner + 2.0 * d + 3.0 * d * k as f64)
        .take_while(|&r| r <= outer - 2.0 * d)
        .collect();
    let rings = ring_stresses(
        &sim.state.grains,
        &sim.state.contacts,
        [0.0; 2],
        &edges,
        sim.depth,
    );
    assert!(rings.len() >= 3, "{} rings", rings.len());
    eprintln!("r / r_inner, sigma_rr / p, Lame, sigma_tt / p, Lame:");
    for (r, srr, stt) in rings {
        let q = inner * inner / (r * r);
        let (lame_rr, lame_tt) = (a_coef * (1.0 - q), a_coef * (1.0 + q));
        eprintln!(
            "  {:.2}  {:.3} {:.3}  {:.3} {:.3}",
            r / inner,
            srr / p1,
            lame_rr / p1,
            stt / p1,
            lame_tt / p1
        );
        assert!(
            (srr - lame_rr).abs() < 0.15 * lame_rr,
            "sigma_rr at r = {r}"
        );
        assert!(
            (stt - lame_tt).abs() < 0.15 * lame_tt,
            "sigma_tt at r = {r}"
        );
    }
}
