//! The simple shear test and the true simple shear test (thesis 3.3.4, appendix 5): a square
//! box whose bottom is held, whose top slides by `gamma` times its height and whose sides
//! turn by `gamma` about their bottom ends, the grains on all four walls glued to them. In
//! simple shear the top and the sides are stress-controlled; in true simple shear the sides
//! keep their distance (`eps_xx = 0`).

use grainstat::scene::{build_grains, parse_scene};
use grainstat::simulation::Simulation;
use grainstat::solver::SolverConfig;
use grainstat::state::IncrementReport;
use std::path::Path;

const R: f64 = 1e-4;

fn simulation(text: &str) -> Simulation {
    let scene = parse_scene(text, "simple-shear.toml").unwrap();
    let grains = build_grains(&scene.grains, Path::new("."), "simple-shear.toml").unwrap();
    Simulation::new(&scene, grains, SolverConfig::default(), "simple-shear.toml").unwrap()
}

fn increments(sim: &mut Simulation, n: usize) -> Vec<IncrementReport> {
    (0..n).map(|_| sim.run_increment().unwrap()).collect()
}

/// A Hertz patch (sand, table 1; a hexagonal lattice of 12 rows of 10 grains with 3% of them
/// missing, about as high as wide) in a box: isotropic 1 bar, then `gamma` in `n` steps
/// with the grains glued to the four walls; in true simple shear the sides are held.
fn sand_box(gamma: f64, n: usize, true_simple: bool) -> String {
    let patch = grainstat::samples::hertz_patch(12, 10, 1, 0.6, 0.03, 0);
    let list = |v: &[f64]| {
        let items: Vec<String> = v.iter().map(|x| format!("{x:e}")).collect();
        items.join(", ")
    };
    let g = &patch.grains;
    let sides = if true_simple {
        r#"control = { left = "displacement", right = "displacement" }"#
    } else {
        ""
    };
    format!(
        r#"
[material]
law = "hertz"
shear_modulus = 1e9
poisson = 0.16
friction = 0.6
[grains]
x = [{}]
y = [{}]
r = [{}]
[box]
stress_controlled = ["top", "right", "left"]
[[regions]]
name = "centre"
min = [0.5e-3, 0.5e-3]
max = [1.5e-3, 1.5e-3]
[[stages]]
name = "isotropic"
increments = 4
stress = {{ top = 1e5, right = 1e5, left = 1e5 }}
[[stages]]
name = "shear"
increments = {n}
glue = ["bottom", "right", "top", "left"]
shear_strain = {{ top = {gamma:e} }}
{sides}
"#,
        list(&g.x),
        list(&g.y),
        list(&g.r)
    )
}

/// A cemented hexagonal crystal (sandstone, table 8: linear contacts, `k_n = 1e6` N/m,
/// bonded) of 21 rows of 12 grains in a frictionless box, isotropic 10 bar; then either a
/// biaxial step (top to 12 bar, sides held at 10 bar) or simple shear by `gamma` with the
/// grains glued to the four walls. Its centre region holds about 60 grains.
fn crystal_box(second: &str) -> String {
    format!(
        r#"
[material]
law = "linear"
normal_stiffness = 1e6
poisson = 0.16
friction = 0.6
cohesion = 1e8
bonded = true
[grains.crystal]
rows = 21
columns = 12
radius = 1e-4
short_first = false
[box]
stress_controlled = ["top", "right", "left"]
[[regions]]
name = "centre"
min = [0.6e-3, 1.0e-3]
max = [1.8e-3, 2.6e-3]
[[stages]]
name = "isotropic"
increments = 2
stress = {{ top = 1e6, right = 1e6, left = 1e6 }}
[[stages]]
{second}
"#
    )
}

/// Distance of grain centre `x` from the line of `wall`, and how far along the way from its
/// span wall `a` to `b` it lies.
fn place(walls: &grainstat::geometry::WallSet, w: usize, x: [f64; 2]) -> (f64, f64) {
    let (a, b) = walls.span_walls(w).unwrap();
    let (da, db) = (walls.walls[a].distance(x), walls.walls[b].distance(x));
    (walls.walls[w].distance(x), da / (da + db))
}

/// Glued grains move as parts of their walls: each keeps its distance from its wall's line
/// and turns with it, to round-off (no slip, no roll), and keeps its place along the wall as
/// the wall stretches with the box. The applied stresses stay at their targets; the top's
/// measured stress stays close to its target.
#[test]
fn glued_grains_follow_their_walls() {
    let gamma = 2e-3;
    let mut sim = simulation(&crystal_box(&format!(
        r#"name = "shear"
increments = 4
glue = ["bottom", "right", "top", "left"]
shear_strain = {{ top = {gamma:e} }}"#
    )));
    increments(&mut sim, 3);
    let (grains0, walls0) = (sim.state.grains.clone(), sim.state.walls.clone());
    let reports = increments(&mut sim, 3);
    let glued = sim.state.contacts.glued(sim.state.grains.len());
    let count = |w: usize| glued.iter().filter(|g| **g == Some(w)).count();
    assert!((0..4).all(|w| count(w) >= 9), "grains glued to each wall");
    let walls = &sim.state.walls;
    let (mut off, mut roll, mut along) = (0.0f64, 0.0f64, 0.0f64);
    for (g, w) in glued.iter().enumerate() {
        let Some(w) = *w else { continue };
        let (d0, f0) = place(&walls0, w, grains0.position[g]);
        let (d, f) = place(walls, w, sim.state.grains.position[g]);
        off = off.max((d - d0).abs() / R);
        along = along.max((f - f0).abs());
        let turn = walls.walls[w].turn - walls0.walls[w].turn;
        roll = roll.max((sim.state.grains.rotation[g] - grains0.rotation[g] - turn).abs());
    }
    println!("glued grains: off their walls by {off:.1e} r, along them by {along:.1e} of the box, rolled {roll:.1e} rad relative to them");
    assert!(off < 1e-10 && roll < 1e-15 && along < 1e-3);
    // The sides turned by gamma, the top slid by its height times tan(gamma).
    let [left, top] = [3, 2].map(|w| &walls.walls[w]);
    assert!((left.turn + gamma).abs() < 1e-15);
    let slide = top.slide / (walls0.gap(2, 0) * gamma.tan());
    assert!(
        (slide - 1.0).abs() < 1e-3,
        "top slide over H tan gamma: {slide}"
    );
    for r in &reports {
        let m = &r.measurements;
        println!(
            "sigma on the walls (bottom, right, top, left) {:.4e} {:.4e} {:.4e} {:.4e}",
            m.wall_stress[0], m.wall_stress[1], m.wall_stress[2], m.wall_stress[3]
        );
        assert!(
            (m.wall_stress[2] / 1e6 - 1.0).abs() < 1e-2,
            "sigma_yy on the top"
        );
    }
    assert!([1, 2, 3].iter().all(|&w| walls.walls[w].stress == 1e6));
}

/// True simple shear of sand: the sides keep their distance (`eps_xx = 0`) while the
/// horizontal stress changes; in simple shear they move and keep theirs.
#[test]
fn true_simple_shear_holds_the_width_and_the_horizontal_stress_changes() {
    for true_simple in [false, true] {
        let mut sim = simulation(&sand_box(0.01, 5, true_simple));
        increments(&mut sim, 4);
        let width0 = sim.state.walls.gap(1, 3);
        let reports = increments(&mut sim, 5);
        let m = &reports.last().unwrap().measurements;
        let eps_xx = 1.0 - sim.state.walls.gap(1, 3) / width0;
        let sigma_xx = 0.5 * (m.wall_stress[1] + m.wall_stress[3]);
        println!(
            "true simple shear {true_simple}: eps_xx {eps_xx:.2e}, sigma_xx on the sides {sigma_xx:.4e}, applied {:.4e}, sigma_yy on the top {:.4e}",
            sim.state.walls.walls[1].stress, m.wall_stress[2]
        );
        if true_simple {
            assert_eq!(eps_xx, 0.0);
            assert!((sigma_xx / 1e5 - 1.0).abs() > 0.05, "sigma_xx changes");
        } else {
            assert!(eps_xx.abs() > 1e-4, "the sides move");
            assert_eq!(sim.state.walls.walls[1].stress, 1e5);
            assert_eq!(sim.state.walls.walls[3].stress, 1e5);
            assert!((sigma_xx / 1e5 - 1.0).abs() < 1e-2, "sigma_xx on the sides");
        }
    }
}

/// The displacement gradient `L` (`u = u0 + L x`) of the grains whose centres lie in the
/// rectangle `[min, max]`, fitted by least squares to their moves from `before` to `after`.
fn gradient(
    before: &[[f64; 2]],
    after: &[[f64; 2]],
    min: [f64; 2],
    max: [f64; 2],
) -> [[f64; 2]; 2] {
    let inside: Vec<usize> = (0..before.len())
        .filter(|&g| (0..2).all(|k| (min[k]..max[k]).contains(&before[g][k])))
        .collect();
    let n = inside.len() as f64;
    let mean = |f: &dyn Fn(usize) -> f64| inside.iter().map(|&g| f(g)).sum::<f64>() / n;
    let x0 = [mean(&|g| before[g][0]), mean(&|g| before[g][1])];
    let u0 = [0, 1].map(|k| mean(&|g| after[g][k] - before[g][k]));
    let (mut xx, mut ux) = ([[0.0; 2]; 2], [[0.0; 2]; 2]);
    for &g in &inside {
        let x = [before[g][0] - x0[0], before[g][1] - x0[1]];
        let u = [0, 1].map(|k| after[g][k] - before[g][k] - u0[k]);
        for i in 0..2 {
            for j in 0..2 {
                xx[i][j] += x[i] * x[j];
                ux[i][j] += u[i] * x[j];
            }
        }
    }
    let det = xx[0][0] * xx[1][1] - xx[0][1] * xx[1][0];
    let inv = [
        [xx[1][1] / det, -xx[0][1] / det],
        [-xx[1][0] / det, xx[0][0] / det],
    ];
    [0, 1].map(|i| [0, 1].map(|j| ux[i][0] * inv[0][j] + ux[i][1] * inv[1][j]))
}

/// The elastic stage against continuum theory (eq. A.24, `tau = G gamma`): on the cemented
/// crystal (isotropic in the plane), the shear modulus of the interior (its shear stress,
/// eq. A.40, over its shear strain, both from the grains in the centre region) matches
/// `E / (2 (1 + nu))` with E and nu of the same interior in a biaxial step on the same
/// crystal (the top from 10 to 12 bar, the sides held at 10 bar; plane isotropic
/// elasticity, A.9, solved for E and nu from both strains and both stresses).
#[test]
fn the_elastic_shear_modulus_matches_e_over_two_one_plus_nu() {
    let (min, max) = ([0.6e-3, 1.0e-3], [1.8e-3, 2.6e-3]);
    let mut biaxial = simulation(&crystal_box(
        r#"name = "biaxial"
increments = 2
stress = { top = 1.2e6 }"#,
    ));
    let stress = |r: &IncrementReport| r.measurements.region_stress[0];
    let s0 = stress(&increments(&mut biaxial, 2)[1]);
    let x0 = biaxial.state.grains.position.clone();
    let s1 = stress(&increments(&mut biaxial, 2)[1]);
    let l = gradient(&x0, &biaxial.state.grains.position, min, max);
    // Compression positive: eps = -L; E eps_yy + nu ds_xx = ds_yy, E eps_xx + nu ds_yy = ds_xx.
    let (eyy, exx) = (-l[1][1], -l[0][0]);
    let (dyy, dxx) = (s1[1][1] - s0[1][1], s1[0][0] - s0[0][0]);
    let det = eyy * dyy - dxx * exx;
    let e = (dyy * dyy - dxx * dxx) / det;
    let nu = (eyy * dxx - exx * dyy) / det;
    let g_theory = e / (2.0 * (1.0 + nu));

    let mut shear = simulation(&crystal_box(
        r#"name = "shear"
increments = 2
glue = ["bottom", "right", "top", "left"]
shear_strain = { top = 1e-4 }"#,
    ));
    let t0 = -stress(&increments(&mut shear, 3)[2])[0][1];
    let x0 = shear.state.grains.position.clone();
    let t1 = -stress(&increments(&mut shear, 1)[0])[0][1];
    let l = gradient(&x0, &shear.state.grains.position, min, max);
    let gamma = l[0][1] + l[1][0];
    let g = (t1 - t0) / gamma;
    println!(
        "interior: E {e:.4e} Pa, nu {nu:.4}, E / (2 (1 + nu)) {g_theory:.4e} Pa; G {g:.4e} Pa \
         ({:+.2}%), its shear strain {:.3} of the walls'",
        100.0 * (g / g_theory - 1.0),
        gamma / 5e-5
    );
    assert!((g / g_theory - 1.0).abs() < 0.02);
}
