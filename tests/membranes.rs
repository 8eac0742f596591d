//! Membranes (thesis 2.5, 4.1.2, 4.4): a prepared sample handed from its walls to membranes
//! reaches equilibrium, and a cemented annulus under outer pressure with a free borehole has
//! the elastic stresses of Lame's thick-walled cylinder (eq. A.113).

mod common;

use common::{free_under_membrane, prepared, sandstone};
use grainstat::geometry::{Membrane, MembraneShape};
use grainstat::measure::ring_stresses;
use grainstat::sample::prepare::RegionShape;
use grainstat::simulation::{Simulation, StageProgram};
use grainstat::solver::SolverConfig;

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
        shear_strain: vec![0.0; walls],
        glue: vec![false; walls],
        pressure,
        control: Vec::new(),
        until_failure: false,
        failure_drop: None,
        breakouts: false,
        until_breakout: false,
    }
}

#[test]
fn a_rectangle_handed_to_side_membranes_carries_the_biaxial_load() {
    let p0 = 1e6;
    let prepared = prepared(RegionShape::Rectangle, 2.0, 400, 3, p0);
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

/// How an annulus is loaded for the Lame check.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Outer {
    /// In the frictionless ring and around the plug it was prepared with: the ring's stress
    /// is raised while the plug's is held, and the change of stress is compared with Lame's
    /// for the change of outer pressure (elastic, so the changes superpose).
    Ring,
    /// Borehole freed of its plug, a membrane all around.
    Membrane,
}

#[test]
fn a_cemented_annulus_in_a_ring_under_pressure_follows_lame() {
    annulus_follows_lame(Outer::Ring);
}

#[test]
fn a_cemented_annulus_under_a_membrane_follows_lame() {
    annulus_follows_lame(Outer::Membrane);
}

fn annulus_follows_lame(outer_boundary: Outer) {
    let p0 = 1e6;
    let prepared = prepared(RegionShape::Annulus, 3.0, 2000, 3, p0);
    let mut state = prepared.state;
    let radius = |name: &str| {
        let w = state.walls.walls.iter().find(|w| w.name == name).unwrap();
        w.surface(w.position)
    };
    let (inner, outer) = (radius("inner"), radius("outer"));
    let p1 = 3.0 * p0;
    let (stages, pressure_change) = match outer_boundary {
        // Walls: the ring ("outer") and the plug ("inner"), both stress-controlled.
        Outer::Ring => (vec![stage(4, 2, vec![Some(p1), Some(p0)], vec![])], p1 - p0),
        Outer::Membrane => {
            free_under_membrane(&mut state, p0);
            (vec![stage(4, 0, vec![], vec![Some(p1)])], p1)
        }
    };
    let d = 2.0 * state.grains.mean_radius();
    let edges: Vec<f64> = (0..)
        .map(|k| inner + 2.0 * d + 3.0 * d * k as f64)
        .take_while(|&r| r <= outer - 2.0 * d)
        .collect();
    let depth = prepared.depth;
    let rings_of = |sim: &Simulation| {
        ring_stresses(
            &sim.state.grains,
            &sim.state.contacts,
            [0.0; 2],
            &edges,
            depth,
        )
    };
    let mut sim = Simulation::from_state(
        "lame".into(),
        SolverConfig::default(),
        sandstone(),
        depth,
        stages,
        state,
    )
    .unwrap();
    // The stresses before: the prepared isotropic state (the plug then counts as freed).
    let before = match outer_boundary {
        Outer::Ring => rings_of(&sim),
        Outer::Membrane => edges
            .windows(2)
            .map(|w| (0.5 * (w[0] + w[1]), 0.0, 0.0))
            .collect(),
    };
    while !sim.is_finished() {
        sim.run_increment()
            .unwrap_or_else(|e| panic!("increment {}: {e}", sim.state.increment + 1));
    }
    // The spring that holds the free rotation carries the net moment of the contact forces:
    // with the thesis's moment r F_s on each grain (eq. 19) rather than the distance to the
    // contact point, a contact of overlap d and shear force F_s leaves d F_s unbalanced. Here
    // that is some 1e-4 of the mean contact force at the anchored grain.
    let (error, grain) = sim.equilibrium_error();
    assert!(error < 1e-3, "imbalance {error:e} at grain {grain}");
    assert_eq!(sim.state.contacts.broken_bonds.len(), 0, "elastic");

    // Eq. A.113 with no change of pressure in the borehole: sigma_rr = A (1 - a^2/r^2),
    // sigma_tt = A (1 + a^2/r^2), A = p b^2 / (b^2 - a^2), for the change p of the outer one.
    let a_coef = pressure_change * outer * outer / (outer * outer - inner * inner);
    let after = rings_of(&sim);
    assert!(after.len() >= 3, "{} rings", after.len());
    eprintln!("r / r_inner, change of sigma_rr / p, Lame, of sigma_tt / p, Lame:");
    for ((r, rr1, tt1), (_, rr0, tt0)) in after.into_iter().zip(before) {
        let (srr, stt) = (rr1 - rr0, tt1 - tt0);
        let q = inner * inner / (r * r);
        let (lame_rr, lame_tt) = (a_coef * (1.0 - q), a_coef * (1.0 + q));
        let p = pressure_change;
        eprintln!(
            "  {:.2}  {:.3} {:.3}  {:.3} {:.3}",
            r / inner,
            srr / p,
            lame_rr / p,
            stt / p,
            lame_tt / p
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

/// The start of the cylinder test (thesis 4.4): a 1,000-grain cemented annulus freed of its
/// ring and plug, a ring membrane raised from the prepared 10 bar with the borehole free.
/// Its first increment used to fail: the sample's translation was held on a rattler at the
/// borehole, and grains left loose against the ring were in the membrane's chain.
#[test]
fn a_freed_annulus_takes_its_first_increments_under_a_ring_membrane() {
    let p0 = 1e6;
    // Seed 1, the sample of examples/cylinder-sample.toml (with seed 3 the preparation's
    // exact solve does not converge).
    let prepared = prepared(RegionShape::Annulus, 3.0, 1000, 1, p0);
    let mut state = prepared.state;
    free_under_membrane(&mut state, p0);
    let mut sim = Simulation::from_state(
        "cylinder".into(),
        SolverConfig::default(),
        sandstone(),
        prepared.depth,
        vec![stage(3, 0, vec![], vec![Some(4.0 * p0)])],
        state,
    )
    .unwrap();
    while !sim.is_finished() {
        let report = sim
            .run_increment()
            .unwrap_or_else(|e| panic!("increment {}: {e}", sim.state.increment + 1));
        eprintln!(
            "increment {}: {} cuts, {} Newton iterations, residual {:.1e}",
            report.increment, report.cuts, report.newton_iterations, report.residual
        );
    }
    let (error, grain) = sim.equilibrium_error();
    assert!(error < 1e-3, "imbalance {error:e} at grain {grain}");
    assert_eq!(sim.state.membranes[0].pressure, 4.0 * p0);
}
