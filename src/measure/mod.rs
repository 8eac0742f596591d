//! Macro measurements of a converged state: wall forces and stresses, and the macro stress
//! from the contact forces (eq. A.41).

use crate::contact::{kinematics, Configuration, ContactSet};
use crate::geometry::{GrainSet, Side, WallSet};

/// Measurements of one state.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Measurements {
    /// Normal force of the grains on each wall (N).
    pub wall_normal_force: Vec<f64>,
    /// Shear force of the grains on each wall, along its tangent (N).
    pub wall_shear_force: Vec<f64>,
    /// Normal stress on each wall: force / (length * depth) (Pa); NaN when it has no length.
    pub wall_stress: Vec<f64>,
    /// Macro stress `sigma_ij = (1/V) sum_c d_i F_j` (eq. A.41), compression positive (Pa),
    /// over every contact, wall contacts included (their branch runs to the wall line).
    pub macro_stress: [[f64; 2]; 2],
    /// Volume `V` enclosed by the walls times the depth (m^3); NaN when the walls do not close.
    pub volume: f64,
    /// Grain-grain contacts.
    pub grain_contacts: usize,
    /// Grain-wall contacts.
    pub wall_contacts: usize,
    /// Grain-grain contacts per grain (`2 n_c / n_g`).
    pub contacts_per_grain: f64,
    /// Bonds intact.
    pub bonds: usize,
    /// Bonds broken so far.
    pub broken_bonds: usize,
}

/// Measure a converged state.
pub fn measure(
    grains: &GrainSet,
    walls: &WallSet,
    contacts: &ContactSet,
    depth: f64,
) -> Measurements {
    let q = Configuration::at_rest(grains, walls);
    let mut m = Measurements {
        wall_normal_force: vec![0.0; walls.len()],
        wall_shear_force: vec![0.0; walls.len()],
        ..Default::default()
    };
    let mut sum = [[0.0; 2]; 2];
    for c in &contacts.contacts {
        let k = kinematics(c.pair, grains, walls, &q);
        let (fn_, fs) = (c.response.normal_force, c.response.shear_force);
        // Force on side b: F_n n - F_s t; branch from a's centre, or from the contact point on
        // a wall's surface, to b's centre.
        let force = [
            fn_ * k.normal[0] - fs * k.tangent[0],
            fn_ * k.normal[1] - fs * k.tangent[1],
        ];
        let arm = match c.pair.a {
            Side::Grain(_) => k.distance,
            Side::Wall(_) => k.radius_b - k.overlap,
        };
        let branch = [arm * k.normal[0], arm * k.normal[1]];
        for (i, row) in sum.iter_mut().enumerate() {
            for (j, s) in row.iter_mut().enumerate() {
                *s += branch[i] * force[j];
            }
        }
        match c.pair.a {
            Side::Wall(w) => {
                m.wall_contacts += 1;
                m.wall_normal_force[w] += fn_;
                m.wall_shear_force[w] += fs;
            }
            Side::Grain(_) => m.grain_contacts += 1,
        }
        m.bonds += c.bonded as usize;
    }
    m.broken_bonds = contacts.broken_bonds.len();
    m.volume = walls.enclosed_area().map_or(f64::NAN, |a| a * depth);
    m.macro_stress = sum.map(|row| row.map(|s| s / m.volume));
    m.wall_stress = (0..walls.len())
        .map(|w| {
            walls
                .length(w)
                .map_or(f64::NAN, |l| m.wall_normal_force[w] / (l * depth))
        })
        .collect();
    m.contacts_per_grain = 2.0 * m.grain_contacts as f64 / grains.len().max(1) as f64;
    m
}

/// Radial and tangential stress (eq. A.41) in rings about `center`: for each ring between
/// consecutive `edges` (m), `(mid radius, sigma_rr, sigma_tt)` from the grain-grain contacts
/// whose midpoints lie in it, each contact's `d F` projected on the radial and tangential
/// directions at its midpoint, over the ring's area times the depth. Compression positive.
pub fn ring_stresses(
    grains: &GrainSet,
    contacts: &ContactSet,
    center: [f64; 2],
    edges: &[f64],
    depth: f64,
) -> Vec<(f64, f64, f64)> {
    let rings = edges.len().saturating_sub(1);
    let mut sums = vec![[0.0f64; 2]; rings];
    for c in &contacts.contacts {
        let Side::Grain(a) = c.pair.a else {
            continue;
        };
        let b = c.pair.b;
        let d = grains.branch(a, b);
        let (pa, len) = (grains.position[a], d[0].hypot(d[1]));
        let mid = [
            pa[0] + 0.5 * d[0] - center[0],
            pa[1] + 0.5 * d[1] - center[1],
        ];
        let r = mid[0].hypot(mid[1]);
        let Some(k) = edges.windows(2).position(|w| w[0] <= r && r < w[1]) else {
            continue;
        };
        let (n, t) = ([d[0] / len, d[1] / len], [-d[1] / len, d[0] / len]);
        let (fn_, fs) = (c.response.normal_force, c.response.shear_force);
        let force = [fn_ * n[0] - fs * t[0], fn_ * n[1] - fs * t[1]];
        let (er, et) = ([mid[0] / r, mid[1] / r], [-mid[1] / r, mid[0] / r]);
        let dot = |u: [f64; 2], v: [f64; 2]| u[0] * v[0] + u[1] * v[1];
        sums[k][0] += dot(d, er) * dot(force, er);
        sums[k][1] += dot(d, et) * dot(force, et);
    }
    (0..rings)
        .map(|k| {
            let (r0, r1) = (edges[k], edges[k + 1]);
            let volume = std::f64::consts::PI * (r1 * r1 - r0 * r0) * depth;
            (0.5 * (r0 + r1), sums[k][0] / volume, sums[k][1] / volume)
        })
        .collect()
}
