//! The minimisation's tangents against finite differences of its residuals.

use super::*;
use crate::contact::Contact;
use crate::samples;
use crate::scene::build_grains;
use crate::solver::krylov;
use rand::{Rng, SeedableRng};
use std::path::Path;

/// A fresh simulation of `scene` ready for the minimisation of its first increment (every
/// friends-list pair engaged), its load step, a random iterate `u` and a random direction
/// `v` (translations in mean radii, rotations in radians).
fn at_random_iterate(
    scene: &crate::scene::Scene,
    size: f64,
) -> (Simulation, LoadStep, Vec<f64>, Vec<f64>) {
    let grains = build_grains(&scene.grains, Path::new("."), "t").unwrap();
    let mut sim = Simulation::new(scene, grains, SolverConfig::default(), "t").unwrap();
    sim.apply_glue().unwrap();
    let step = sim.next_load_step();
    sim.start_step();
    sim.start_newton().unwrap();
    sim.engage_pairs();
    let n = sim.dofs.len;
    let r = sim.r_mean;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let scale = |k: usize, dofs: &DofMap| match dofs.owner(k) {
        Some(_) if dofs.per_grain == 3 && k % 3 == 2 => 1.0,
        _ => r,
    };
    let u: Vec<f64> = (0..n)
        .map(|k| size * scale(k, &sim.dofs) * (rng.random::<f64>() - 0.5))
        .collect();
    let v: Vec<f64> = (0..n)
        .map(|k| scale(k, &sim.dofs) * (rng.random::<f64>() - 0.5))
        .collect();
    (sim, step, u, v)
}

/// `|K v - fd|_inf / |fd|_inf`, `fd` the central difference `-(R(u + h v) - R(u - h v)) / 2h`
/// of the residuals `plus` and `minus` at `u +- h v`.
fn relative_error(
    pattern: &Pattern,
    values: &[f64],
    v: &[f64],
    plus: &[f64],
    minus: &[f64],
    h: f64,
) -> f64 {
    let mut kv = vec![0.0; v.len()];
    let mut by_rows = values.to_vec();
    krylov::to_rows_in_place(&pattern.symbolic, &mut by_rows, &mut Vec::new());
    krylov::multiply_by_rows(&pattern.symbolic, &by_rows, v, &mut kv);
    let (mut err, mut norm) = (0.0f64, 0.0f64);
    for k in 0..v.len() {
        let fd = -(plus[k] - minus[k]) / (2.0 * h);
        err = err.max((fd - kv[k]).abs());
        norm = norm.max(fd.abs());
    }
    err / norm
}

/// `Potential::consistent_tangent` against finite differences of the true residual, the
/// lag refrozen at every point as in the semi-smooth steps, the membranes' chains held
/// (refrozen with the lag, they are not differentiated).
fn consistent_tangent_error(scene: &crate::scene::Scene) -> f64 {
    let (mut sim, step, u, v) = at_random_iterate(scene, 2e-4);
    let pattern = Arc::clone(&sim.pattern);
    let n = u.len();
    let mut values = vec![0.0; pattern.nnz()];
    let mut residual = vec![0.0; n];
    let mut eq = sim.equations(&step);
    // Twice: a pair found touching for the first time sticks until the next refreeze.
    for _ in 0..2 {
        eq.consistent_tangent(&u, &mut residual, &mut values)
            .unwrap();
    }
    eq.chains_held = true;
    // Each point refreezes from the lag at `u`: a refreeze relaxes a limit whose change turns
    // back (`Lag::refrozen_limit`), so from the lag the other point left, the limit there
    // would not be its `f N`.
    let at_u = eq.contacts.clone();
    let h = 1e-7;
    let mut scratch = vec![0.0; pattern.nnz()];
    let mut at = |sign: f64| {
        eq.contacts.clone_from(&at_u);
        let w: Vec<f64> = u.iter().zip(&v).map(|(a, b)| a + sign * h * b).collect();
        let mut out = vec![0.0; n];
        eq.consistent_tangent(&w, &mut out, &mut scratch).unwrap();
        out
    };
    let (plus, minus) = (at(1.0), at(-1.0));
    relative_error(&pattern, &values, &v, &plus, &minus, h)
}

/// The Hessian of the lagged potential, the lag frozen at a random iterate of `size`
/// mean radii, as the minimisation assembles it before it symmetrises and projects it
/// (the walls' follower terms and the softening geometric terms kept), against finite
/// differences of the lagged residual.
fn lagged_hessian_error(scene: &crate::scene::Scene, size: f64) -> f64 {
    let (mut sim, step, u, v) = at_random_iterate(scene, size);
    let pattern = Arc::clone(&sim.pattern);
    let n = u.len();
    let mut values = vec![0.0; pattern.nnz()];
    let mut residual = vec![0.0; n];
    let mut eq = sim.equations(&step);
    for _ in 0..2 {
        Potential::evaluate(&mut eq, &u, &mut residual, None, true).unwrap();
    }
    (eq.symmetric, eq.projected) = (false, false);
    Potential::evaluate(&mut eq, &u, &mut residual, Some(&mut values), false).unwrap();
    let h = 1e-7;
    let mut at = |sign: f64| {
        let w: Vec<f64> = u.iter().zip(&v).map(|(a, b)| a + sign * h * b).collect();
        let mut out = vec![0.0; n];
        Potential::evaluate(&mut eq, &w, &mut out, None, false).unwrap();
        out
    };
    let (plus, minus) = (at(1.0), at(-1.0));
    relative_error(&pattern, &values, &v, &plus, &minus, h)
}

/// The scenes the tangents are checked on: Hertz patches with and without friction, a
/// crystal, membranes, a frictional plug moving obliquely, a simple shear box.
fn scenes() -> Vec<(&'static str, crate::scene::Scene)> {
    let mut out = Vec::new();
    for (name, friction) in [("hertz, friction 0.6", 0.6), ("hertz, friction 0", 0.0)] {
        out.push((name, samples::hertz_patch(6, 5, 1, friction, 0.1, 0)));
    }
    out.push(("crystal", samples::crystal_biaxial(5, 6, 1e6, 3e6)));
    // Membranes on a side and all around.
    let mut scene = samples::hertz_patch(6, 5, 1, 0.6, 0.1, 0);
    for (name, side, ring) in [
        ("east", Some([1.0, 0.0]), None),
        ("around", None, Some([5e-4, 5e-4])),
    ] {
        scene.membranes.push(crate::scene::MembraneSpec {
            name: name.into(),
            side,
            ring,
            pressure: 1e5,
        });
        scene.stages[0].stress.insert(name.into(), 2e5);
    }
    out.push(("membranes", scene));
    // A frictional plug whose centre moves obliquely, its move an unknown: it overlaps the
    // two top grains it sits between by a thousandth of their radius.
    let mut scene = samples::crystal_biaxial(5, 6, 1e6, 3e6);
    let r = 1e-4;
    let top = r + 4.0 * 3f64.sqrt() * r;
    let rise = ((2.999 * r).powi(2) - r * r).sqrt();
    scene.circles.push(crate::scene::CircleSpec {
        name: "punch".into(),
        center: [6.0 * r, top + rise],
        radius: 2.0 * r,
        grains: crate::scene::CircleSide::Outside,
        friction: crate::scene::Friction::Coefficient(0.5),
        control: WallControl::Stress,
        stress: 1e5,
        moves: Some([0.3, -1.0]),
        touch: false,
    });
    scene.stages[0].stress.insert("punch".into(), 2e5);
    out.push(("moving plug", scene));
    // A simple shear box: the grains on its four walls glued, its top, left and right
    // stress-controlled, the top sliding and the sides turning in the step.
    let mut scene = samples::hertz_patch(6, 5, 1, 0.6, 0.1, 0);
    let b = scene.wall_box.as_mut().expect("a box");
    b.friction = crate::scene::Friction::Coefficient(0.5);
    b.stress_controlled.push("left".into());
    let stage = &mut scene.stages[0];
    stage.stress.insert("left".into(), 1e5);
    stage.glue = ["bottom", "right", "top", "left"]
        .map(String::from)
        .to_vec();
    stage.shear_strain.insert("top".into(), 0.05);
    out.push(("shear box", scene));
    out
}

#[test]
fn the_consistent_tangent_matches_finite_differences() {
    for (name, scene) in scenes() {
        let e = consistent_tangent_error(&scene);
        assert!(e < 1e-5, "{name}: relative error {e:e}");
    }
}

/// Exact without friction. Where the shear springs act, the Hessian takes the shear's
/// gradient `S` as `B_t`: they differ by the turn of the contact frame over the iterate,
/// about its size (1.9e-5 on the crystal at 2e-4 radii), so the linear scenes with friction
/// are checked at an iterate of 2e-5 radii. Not the frictional Hertz patches (at so small
/// an iterate their barely touching contacts are too curved for the differences) nor the
/// shear box (its step turns the frames of its glued grains by far more than the iterate).
#[test]
fn the_hessian_of_the_lagged_potential_matches_finite_differences() {
    let frictionless = samples::hertz_patch(6, 5, 1, 0.0, 0.1, 0);
    let e = lagged_hessian_error(&frictionless, 2e-4);
    assert!(e < 1e-5, "hertz, friction 0: relative error {e:e}");
    let linear = scenes()
        .into_iter()
        .filter(|(name, _)| matches!(*name, "crystal" | "moving plug"));
    for (name, scene) in linear {
        let e = lagged_hessian_error(&scene, 2e-5);
        assert!(e < 1e-5, "{name}: relative error {e:e}");
    }
}

/// A cemented annulus under a ring membrane raised until it fails, and its simulation: it
/// breaks bonds, in parts of its increments, loses contacts, takes clusters out and moves
/// its chain from grain to grain.
fn failing_annulus() -> (crate::scene::Scene, Simulation) {
    let mut scene = samples::cemented_annulus(3.0, 8.0, 20);
    scene.stages[0].stress.insert("outer".into(), 4.01e8);
    scene.stages[0].breakouts = true;
    let grains = build_grains(&scene.grains, Path::new("."), "t").unwrap();
    let sim = Simulation::new(&scene, grains, SolverConfig::default(), "t").unwrap();
    (scene, sim)
}

/// After each written increment the workspace is the one a run resumed from the written
/// state starts with: the same friends pairs and the same pattern, entry for entry, so that
/// the resumed run repeats the arithmetic of the uninterrupted one. A cemented annulus under
/// a ring membrane raised until it fails breaks bonds, loses contacts and moves its chain
/// from grain to grain, which leaves the running lists and pattern holding pairs and links
/// a resumed run's do not.
#[test]
fn the_workspace_after_a_write_is_the_one_a_resumed_run_starts_with() {
    let (scene, mut sim) = failing_annulus();
    while sim.run_increment().is_ok() && !sim.is_finished() {
        sim.refresh_workspace().unwrap();
        let config = SolverConfig::default();
        let resumed = Simulation::resume(&scene, sim.state.clone(), sim.depth, config).unwrap();
        let k = sim.state.increment;
        assert!(
            sim.friends.pairs == resumed.friends.pairs,
            "friends, increment {k}"
        );
        let (a, b) = (&sim.pattern.symbolic, &resumed.pattern.symbolic);
        let same = a.col_ptr() == b.col_ptr() && a.row_idx() == b.row_idx();
        assert!(same, "pattern, increment {k}");
    }
    assert!(
        sim.state.increment >= 10,
        "failed in increment {}",
        sim.state.increment + 1
    );
}

/// An increment keeps the state it starts from as the result file keeps it
/// ([`KeptState`]), and a part of it goes back to the contacts it started from: every
/// increment starts from committed contacts, whose history is their response, so that the
/// state kept gives back the state, its contacts' lag and energy apart (the increment's own).
/// On the failing annulus, which breaks bonds in parts of its increments.
#[test]
fn an_increment_starts_from_committed_contacts_it_keeps_whole() {
    let (_, mut sim) = failing_annulus();
    let mut cuts = 0;
    loop {
        let k = sim.state.increment;
        let contacts = &sim.state.contacts;
        assert!(
            contacts.contacts.iter().all(Contact::is_committed),
            "increment {k}"
        );
        let kept = KeptState::of(&sim.state);
        let back = kept.state();
        assert!(kept.contacts().holds(&back.contacts), "increment {k}");
        let mut state = sim.state.clone();
        state.contacts = back.contacts.clone();
        assert!(state == back, "increment {k}");
        match sim.run_increment() {
            Ok(report) if !sim.is_finished() => cuts += report.cuts,
            _ => break,
        }
    }
    assert!(cuts > 0, "no increment in parts");
}

/// A simulation of the scene `text`, with the default solver.
pub(crate) fn simulation_of(text: &str) -> Simulation {
    let scene = crate::scene::parse_scene(text, "scene.toml").unwrap();
    let grains = build_grains(&scene.grains, Path::new("."), "t").unwrap();
    Simulation::new(&scene, grains, SolverConfig::default(), "t").unwrap()
}

/// Two grains closing on a small loose grain between them from sides half a degree from
/// opposite: its least way out, with the pairs linearised where it is, lies some forty of its
/// radii along the wedge. A placement that far is not made: the grain stays where it was,
/// and is taken in among the others.
#[test]
fn a_loose_grain_is_not_placed_further_than_its_radius() {
    let mut sim = simulation_of(
        r#"
name = "wedge"
[material]
law = "linear"
normal_stiffness = 1e6
bonded = false
[grains]
x = [-1.05e-4, 1.05e-4, 0.0]
y = [0.0, 0.0, 1e-6]
r = [1e-4, 1e-4, 4e-6]
[box]
[[stages]]
increments = 1
"#,
    );
    let step = sim.next_load_step();
    sim.start_step();
    sim.start_newton().unwrap();
    sim.engage_pairs();
    sim.loose = vec![false, false, true];
    let mut u = vec![0.0; sim.dofs.len];
    // The right grain moved 5 um towards the left one, into the loose grain.
    u[sim.dofs.grain(1)] = -5e-6;
    let mut eq = sim.equations(&step);
    let failed = eq.place_loose(&mut u);
    assert_eq!(failed, [2]);
    let base = sim.dofs.grain(2);
    assert_eq!([u[base], u[base + 1]], [0.0, 0.0]);
    // On the line of the two centres, pressed from exactly opposite sides, it has no way out
    // at all: it goes to where its overlaps balance, within its radius.
    let mut u = vec![0.0; sim.dofs.len];
    u[sim.dofs.grain(1)] = -5e-6;
    u[sim.dofs.grain(2) + 1] = -1e-6;
    sim.loose = vec![false, false, true];
    let failed = sim.equations(&step).place_loose(&mut u);
    assert_eq!(failed, [2]);
    let moved = u[base].hypot(u[base + 1] + 1e-6);
    assert!(moved < 4e-6, "moved {moved:e}");
}
