//! Tiny canonical cases shared by tests, examples, benches and docs: two discs, a
//! hexagonal crystal in a box of walls, a small Hertz packing.

use crate::geometry::GrainSet;
use crate::scene::{parse_scene, Scene};

/// Equal grains in a hexagonal arrangement: horizontal rows `sqrt(3) r` apart, each shifted by
/// `r` from the last, alternately `columns` and `columns - 1` grains long, every neighbour
/// exactly touching. The bounding box starts at the origin.
pub fn hex_crystal(rows: usize, columns: usize, radius: f64, short_first: bool) -> GrainSet {
    let mut position = Vec::new();
    let dy = 3f64.sqrt() * radius;
    for row in 0..rows {
        let short = (row % 2 == 0) == short_first;
        let (count, x0) = if short {
            (columns - 1, 2.0 * radius)
        } else {
            (columns, radius)
        };
        for c in 0..count {
            position.push([x0 + 2.0 * radius * c as f64, radius + dy * row as f64]);
        }
    }
    let n = position.len();
    GrainSet::new(position, vec![radius; n])
}

/// [`crystal_biaxial`] of about `grains` grains, at 1 and 3 MPa: rows 1.6 times the columns
/// (an odd number of them), so that the crystal is about as high as wide. The crystal whose
/// time and memory `examples/scale.rs` and `benches/minimise.rs` measure by its size.
pub fn crystal_of_about(grains: usize) -> Scene {
    let columns = ((grains as f64 / 1.6).sqrt().round() as usize).max(2);
    let rows = (grains / columns).max(3) | 1;
    crystal_biaxial(rows, columns, 1e6, 3e6)
}

/// A crystal of `rows` x `columns` grains of radius 0.1 mm (long rows at top and bottom when
/// `rows` is odd) with the sandstone defaults of table 8 (linear law, `k_n` = 1 MN/m,
/// `nu_mu = 0.16`, cemented), between four walls: bottom and left held, top and right
/// stress-controlled. The walls carry the stress of the lattice as the thesis defines it
/// (A.121, A.122): the top wall `sigma 2r D` per grain of the top row, a side wall
/// `sigma sqrt(3) r D` per row. Stage 1 compresses isotropically to `sigma3` in 2 increments,
/// stage 2 raises the top stress to `sigma1` in 4 (the biaxial test of chapter 5).
pub fn crystal_biaxial(rows: usize, columns: usize, sigma3: f64, sigma1: f64) -> Scene {
    let r = 1e-4;
    let width = 2.0 * r * columns as f64;
    let height = 2.0 * r + 3f64.sqrt() * r * (rows - 1) as f64;
    let top_row = if rows % 2 == 1 { columns } else { columns - 1 };
    let top_length = 2.0 * r * top_row as f64;
    let side_length = 3f64.sqrt() * r * rows as f64;
    let text = format!(
        r#"
name = "crystal-biaxial"
[material]
law = "linear"
normal_stiffness = 1e6
poisson = 0.16
friction = 0.6
cohesion = 1e8
bonded = true
[grains.crystal]
rows = {rows}
columns = {columns}
radius = {r:e}
short_first = false
[[walls]]
name = "bottom"
point = [0.0, 0.0]
normal = [0.0, 1.0]
length = {top_length:e}
[[walls]]
name = "right"
point = [{width:e}, 0.0]
normal = [-1.0, 0.0]
control = "stress"
length = {side_length:e}
[[walls]]
name = "top"
point = [0.0, {height:e}]
normal = [0.0, -1.0]
control = "stress"
length = {top_length:e}
[[walls]]
name = "left"
point = [0.0, 0.0]
normal = [1.0, 0.0]
length = {side_length:e}
[[stages]]
name = "isotropic"
increments = 2
stress = {{ top = {sigma3:e}, right = {sigma3:e} }}
[[stages]]
name = "biaxial"
increments = 4
stress = {{ top = {sigma1:e} }}
"#
    );
    parse_scene(&text, "samples::crystal_biaxial").expect("sample scene is valid")
}

/// Two equal discs between a fixed bottom wall and a stress-controlled top wall, stacked so
/// that one contact carries the whole load: the simplest check of a contact law.
pub fn two_discs(law: &str, stress: f64) -> Scene {
    let stiffness = match law {
        "hertz" => "shear_modulus = 1e9",
        _ => "normal_stiffness = 1e6",
    };
    let text = format!(
        r#"
name = "two-discs"
[material]
law = "{law}"
{stiffness}
poisson = 0.16
friction = 0.5
fixed_rotations = true
[grains]
x = [1e-4, 1e-4]
y = [1e-4, 3e-4]
r = [1e-4, 1e-4]
[[walls]]
name = "bottom"
point = [0.0, 0.0]
normal = [0.0, 1.0]
[[walls]]
name = "top"
point = [0.0, 4e-4]
normal = [0.0, -1.0]
control = "stress"
length = 2e-4
[[stages]]
increments = 4
stress = {{ top = {stress:e} }}
"#
    );
    parse_scene(&text, "samples::two_discs").expect("sample scene is valid")
}

/// A small sand sample (Hertz-Mindlin, table 1 defaults: `G_mu` = 1 GPa, `nu_mu` = 0.16,
/// radius 0.1 mm) of `rows` x `columns` grains on a hexagonal lattice, just touching, with a
/// seeded fraction `vacancies` of the grains taken out (so the force network is irregular),
/// and every `rattler_every`-th remaining grain (0: none) shrunk to 0.8 r, so that it touches
/// nothing. The box's top and right walls are stress-controlled: stage 1 raises both to
/// 1 bar, stage 2 the top one to 2 bar.
pub fn hertz_patch(
    rows: usize,
    columns: usize,
    seed: u64,
    friction: f64,
    vacancies: f64,
    rattler_every: usize,
) -> Scene {
    use rand::{Rng, SeedableRng};
    let r0 = 1e-4;
    let lattice = hex_crystal(rows, columns, r0, false);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut scene = parse_scene(
        &format!(
            r#"
name = "hertz-patch"
[material]
law = "hertz"
shear_modulus = 1e9
poisson = 0.16
friction = {friction:e}
[grains]
x = [0.0]
y = [0.0]
r = [1.0]
[box]
stress_controlled = ["top", "right"]
[[stages]]
name = "isotropic"
increments = 4
stress = {{ top = 1e5, right = 1e5 }}
[[stages]]
name = "biaxial"
increments = 4
stress = {{ top = 2e5 }}
"#
        ),
        "samples::hertz_patch",
    )
    .expect("sample scene is valid");
    let g = &mut scene.grains;
    (g.x, g.y, g.r) = (Vec::new(), Vec::new(), Vec::new());
    for p in &lattice.position {
        if rng.random::<f64>() < vacancies {
            continue;
        }
        let rattler = rattler_every > 0 && g.r.len() % rattler_every == rattler_every / 2;
        g.x.push(p[0]);
        g.y.push(p[1]);
        g.r.push(if rattler { 0.8 * r0 } else { r0 });
    }
    scene
}

/// A small thick-walled cylinder (thesis 4.4): the grains of [`hex_crystal`] (radius 0.1 mm)
/// whose centres lie between `inner` and `outer` grain diameters from the lattice's centre,
/// cemented with the sandstone defaults of table 8, under a ring membrane `outer` at 10 bar
/// with the borehole free. One stage raises the pressure by 10 bar per increment over
/// `increments`.
pub fn cemented_annulus(inner: f64, outer: f64, increments: usize) -> Scene {
    let r = 1e-4;
    let side = (2.0 * outer).ceil() as usize + 3;
    let lattice = hex_crystal(side, side, r, false);
    let [x0, y0, x1, y1] = lattice.bounding_box();
    let center = [0.5 * (x0 + x1), 0.5 * (y0 + y1)];
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for p in &lattice.position {
        let d = (p[0] - center[0]).hypot(p[1] - center[1]) / (2.0 * r);
        if (inner..=outer).contains(&d) {
            x.push(format!("{:e}", p[0] - center[0]));
            y.push(format!("{:e}", p[1] - center[1]));
        }
    }
    let (x, y) = (x.join(", "), y.join(", "));
    let n = x.matches(',').count() + 1;
    let radii = vec![format!("{r:e}"); n].join(", ");
    let target = 1e6 * (1 + increments) as f64;
    let text = format!(
        r#"
name = "cemented-annulus"
[material]
law = "linear"
normal_stiffness = 1e6
poisson = 0.16
friction = 0.6
cohesion = 1e8
bonded = true
[grains]
x = [{x}]
y = [{y}]
r = [{radii}]
[[membranes]]
name = "outer"
ring = [0.0, 0.0]
pressure = 1e6
[[stages]]
name = "radial pressure"
increments = {increments}
stress = {{ outer = {target:e} }}
"#
    );
    parse_scene(&text, "samples::cemented_annulus").expect("sample scene is valid")
}
