//! Macro measurements of a converged state: wall forces and stresses, the macro stress
//! from the contact forces (eq. A.41) over the sample and in regions (eq. A.40), contact
//! counts and the mean grain rotation.

mod region;

pub use region::{Region, RegionShape};

use crate::assembly::DofMap;
use crate::contact::{kinematics, Configuration, ContactSet};
use crate::geometry::{polygon_area, Chain, GrainSet, Membrane, MembraneShape, Side, WallSet};

/// Measurements of one state.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Measurements {
    /// Normal force of the grains on each wall (N); on a moving plug, along its direction.
    pub wall_normal_force: Vec<f64>,
    /// Shear force of the grains on each wall, along its tangent (N) (the direction turned a
    /// quarter anticlockwise, for a moving plug).
    pub wall_shear_force: Vec<f64>,
    /// Normal stress on each wall: force / (loaded length * depth) (Pa); between membranes the
    /// loaded length is the grains' extent along the wall.
    pub wall_stress: Vec<f64>,
    /// Shear stress on each wall: its shear force / (loaded length * depth) (Pa).
    pub wall_shear_stress: Vec<f64>,
    /// Macro stress `sigma_ij = (1/V) sum_c d_i F_j` (eq. A.41), compression positive (Pa),
    /// over every contact, wall contacts included (their branch runs to the wall line), and
    /// over the membranes' loads on their grains (the branch from the grain's surface).
    pub macro_stress: [[f64; 2]; 2],
    /// Volume `V` enclosed by the walls and membranes times the depth (m^3); NaN when they do
    /// not close.
    pub volume: f64,
    /// Grain-grain contacts.
    pub grain_contacts: usize,
    /// Grain-wall contacts.
    pub wall_contacts: usize,
    /// Grain-grain contacts per grain (`2 n_c / n_g`, `n_g` the grains in the sample).
    pub contacts_per_grain: f64,
    /// Bonds intact.
    pub bonds: usize,
    /// Bonds broken so far.
    pub broken_bonds: usize,
    /// Mean rotation of the grains in the sample since their origin (rad, anticlockwise);
    /// rattlers, which the solver leaves where they are, count with the rotation they have.
    pub mean_rotation: f64,
    /// Mean of the grains' absolute rotations (rad): rolling both ways, which cancels in
    /// [`Measurements::mean_rotation`].
    pub mean_absolute_rotation: f64,
    /// Stress in each region (eq. A.40 over the grains whose centres lie in it, divided by
    /// its area times the depth), compression positive (Pa), indexed as `macro_stress`.
    pub region_stress: Vec<[[f64; 2]; 2]>,
    /// Mean rotation of the grains whose centres lie in each region (rad, anticlockwise):
    /// the thesis's `gamma_mu` of the interior (eq. 30).
    pub region_rotation: Vec<f64>,
}

/// Add `u_i f_j` to `sum`.
fn add_dyad(sum: &mut [[f64; 2]; 2], u: [f64; 2], f: [f64; 2]) {
    for (i, row) in sum.iter_mut().enumerate() {
        for (j, s) in row.iter_mut().enumerate() {
            *s += u[i] * f[j];
        }
    }
}

/// The membranes of a state, each with its chain of grains.
#[derive(Debug, Clone, Copy, Default)]
pub struct MembraneBoundary<'a> {
    /// The membranes, with their pressures.
    pub membranes: &'a [Membrane],
    /// Their chains, one per membrane.
    pub chains: &'a [Chain],
}

/// Measure a converged state, with the stress in each of `regions`. Grains taken out of the
/// sample have no contacts and lie in no region; they count in no mean.
///
/// A grain glued to a wall is a part of it: its contacts with that wall and with grains
/// glued to the same wall are the glue, which carries nothing measured, and the forces of
/// the other grains on it load the walls it follows ([`crate::assembly::Glue`]): a wall's
/// normal force is then the force its normal move works against (for a stress-controlled
/// wall, in equilibrium, its applied load), and its shear force the force along it on the
/// grains glued to it.
///
/// Eq. A.41 sums `d_i F_j` over the contacts, `d` the branch from one side to the other;
/// eq. A.40 sums over each grain `u_i F_j` of its contacts, `u` from its centre to the
/// contact point (here, with compression positive, `-u` and the force on the grain). Split at
/// the middle of the overlap, a contact's two grains share its `d F` as `(r - n/2) n F`
/// each, so a region's sum counts the part of every contact of its grains that lies on
/// their side; over all grains it is eq. A.41's sum.
pub fn measure(
    grains: &GrainSet,
    walls: &WallSet,
    contacts: &ContactSet,
    boundary: MembraneBoundary,
    depth: f64,
    regions: &[Region],
) -> Measurements {
    let q = Configuration::at_rest(grains, walls);
    let mut m = Measurements {
        wall_normal_force: vec![0.0; walls.len()],
        wall_shear_force: vec![0.0; walls.len()],
        ..Default::default()
    };
    let members: Vec<Vec<bool>> = regions
        .iter()
        .map(|r| {
            (grains.position.iter().zip(&grains.taken_out))
                .map(|(&p, &out)| !out && r.contains(p))
                .collect()
        })
        .collect();
    let mut region_sums = vec![[[0.0; 2]; 2]; regions.len()];
    // Add `u F` of grain `g` to the sums of the regions it lies in.
    let mut to_regions = |g: usize, u: [f64; 2], f: [f64; 2]| {
        for (sum, inside) in region_sums.iter_mut().zip(&members) {
            if inside[g] {
                add_dyad(sum, u, f);
            }
        }
    };
    let glued = contacts.glued(grains.len());
    let mut glue = DofMap::new(grains.len(), false, walls, &glued, &grains.taken_out);
    glue.follow(grains, walls, &vec![0.0; walls.len()]);
    let mut sum = [[0.0; 2]; 2];
    for c in &contacts.contacts {
        match c.pair.a {
            Side::Wall(_) => m.wall_contacts += 1,
            Side::Grain(_) => {
                m.grain_contacts += 1;
                m.bonds += c.bonded as usize;
            }
        }
        let wall_of_a = match c.pair.a {
            Side::Wall(w) => Some(w),
            Side::Grain(a) => glued[a],
        };
        if wall_of_a.is_some() && wall_of_a == glued[c.pair.b] {
            continue;
        }
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
            Side::Wall(_) => k.lever_b - k.overlap,
        };
        let along = |length: f64| [length * k.normal[0], length * k.normal[1]];
        add_dyad(&mut sum, along(arm), force);
        let b_arm = match c.pair.a {
            Side::Grain(a) => {
                to_regions(a, along(k.lever_a), force);
                k.lever_b
            }
            Side::Wall(_) => arm,
        };
        to_regions(c.pair.b, along(b_arm), force);
        // A glued grain: the force on it (on side a, `-force`) loads the walls it follows.
        let mut on_glued = |g: usize, f: [f64; 2]| {
            let Some(glue) = glue.glue[g] else { return };
            for &(w, v) in glue.follows.iter().flatten() {
                m.wall_normal_force[w] -= f[0] * v[0] + f[1] * v[1];
            }
            let t = walls.walls[glue.wall].current_tangent();
            m.wall_shear_force[glue.wall] += f[0] * t[0] + f[1] * t[1];
        };
        on_glued(c.pair.b, force);
        match c.pair.a {
            Side::Grain(a) => on_glued(a, [-force[0], -force[1]]),
            Side::Wall(w) => {
                match walls.walls[w].circle.and_then(|c| c.moves) {
                    // A moving plug: the force along its direction and across it.
                    Some(d) => {
                        m.wall_normal_force[w] += force[0] * d[0] + force[1] * d[1];
                        m.wall_shear_force[w] += force[1] * d[0] - force[0] * d[1];
                    }
                    None => {
                        m.wall_normal_force[w] += fn_;
                        m.wall_shear_force[w] += fs;
                    }
                }
            }
        }
    }
    // A membrane acts on its grains' surfaces: branch r f / |f| from there to the centre.
    for (membrane, chain) in boundary.membranes.iter().zip(boundary.chains) {
        for (g, f) in chain.loads(membrane.shape, &grains.position, membrane.pressure * depth) {
            let size = f[0].hypot(f[1]);
            if size == 0.0 {
                continue;
            }
            let branch = f.map(|v| grains.radius[g] * v / size);
            add_dyad(&mut sum, branch, f);
            to_regions(g, branch, f);
        }
    }
    m.region_stress = regions
        .iter()
        .zip(&region_sums)
        .map(|(r, s)| s.map(|row| row.map(|v| v / (r.area() * depth))))
        .collect();
    m.region_rotation = members
        .iter()
        .map(|inside| {
            let (sum, count) = grains
                .rotation
                .iter()
                .zip(inside)
                .filter(|(_, &i)| i)
                .fold((0.0, 0usize), |(s, n), (r, _)| (s + r, n + 1));
            sum / count.max(1) as f64
        })
        .collect();
    let n = grains.in_sample().count().max(1) as f64;
    let rotations = || grains.in_sample().map(|g| grains.rotation[g]);
    m.mean_rotation = rotations().sum::<f64>() / n;
    m.mean_absolute_rotation = rotations().map(f64::abs).sum::<f64>() / n;
    m.broken_bonds = contacts.broken_bonds.len();
    m.volume = enclosed_area(grains, walls, boundary).map_or(f64::NAN, |a| a * depth);
    m.macro_stress = sum.map(|row| row.map(|s| s / m.volume));
    let length: Vec<f64> = (0..walls.len())
        .map(|w| walls.loaded_length(w, grains) * depth)
        .collect();
    m.wall_stress = (0..walls.len())
        .map(|w| m.wall_normal_force[w] / length[w])
        .collect();
    m.wall_shear_stress = (0..walls.len())
        .map(|w| m.wall_shear_force[w] / length[w])
        .collect();
    m.contacts_per_grain = 2.0 * m.grain_contacts as f64 / n;
    m
}

/// Area the walls and membranes enclose. A membrane's edge runs over its grains' outer
/// surfaces (each centre moved out by its radius, square to the chain); a side membrane
/// reaches the sample's ends, and consecutive straight walls meet at their corner. The
/// pieces are taken in the order of their outward directions, as around a convex sample.
/// A free borehole counts in the area; plugs do not.
fn enclosed_area(grains: &GrainSet, walls: &WallSet, boundary: MembraneBoundary) -> Option<f64> {
    if boundary.membranes.is_empty() {
        return walls.enclosed_area();
    }
    let plugs: f64 = walls
        .walls
        .iter()
        .filter_map(|w| w.circle.filter(|c| !c.grains_inside).map(|_| w))
        .map(|w| std::f64::consts::PI * w.surface(w.position).powi(2))
        .sum();
    // Outer edge points of a chain, in its order.
    let edge = |chain: &Chain| -> Vec<[f64; 2]> {
        let g = &chain.grains;
        let p = |k: usize| grains.position[g[k]];
        (0..g.len())
            .map(|k| {
                // Outward: the chain's direction at the grain turned a quarter turn clockwise.
                let (before, after) = match (k, chain.closed) {
                    (0, true) => (p(g.len() - 1), p((k + 1) % g.len())),
                    (0, false) => (p(0), p((1).min(g.len() - 1))),
                    (_, _) if k + 1 == g.len() && !chain.closed => (p(k - 1), p(k)),
                    _ => (p(k - 1), p((k + 1) % g.len())),
                };
                let d = [after[0] - before[0], after[1] - before[1]];
                let size = d[0].hypot(d[1]);
                let r = grains.radius[g[k]];
                let at = p(k);
                if size == 0.0 {
                    return at;
                }
                [at[0] + r * d[1] / size, at[1] - r * d[0] / size]
            })
            .collect()
    };
    let ring = boundary
        .membranes
        .iter()
        .zip(boundary.chains)
        .find(|(m, _)| matches!(m.shape, MembraneShape::Ring { .. }));
    if let Some((_, chain)) = ring {
        return Some(polygon_area(&edge(chain)).abs() - plugs);
    }
    // Sides and straight walls, by the angle of their outward direction.
    enum Piece<'a> {
        Wall(&'a crate::geometry::Wall),
        Side([f64; 2], &'a Chain),
    }
    let mut pieces: Vec<(f64, Piece)> = walls
        .walls
        .iter()
        .filter(|w| w.circle.is_none())
        .map(|w| {
            let n = w.current_normal();
            ((-n[1]).atan2(-n[0]), Piece::Wall(w))
        })
        .collect();
    for (m, chain) in boundary.membranes.iter().zip(boundary.chains) {
        if let MembraneShape::Side { outward } = m.shape {
            pieces.push((outward[1].atan2(outward[0]), Piece::Side(outward, chain)));
        }
    }
    pieces.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut corners = Vec::new();
    for k in 0..pieces.len() {
        match (&pieces[k].1, &pieces[(k + 1) % pieces.len()].1) {
            (Piece::Wall(a), Piece::Wall(b)) => corners.push(a.corner(b)?),
            (Piece::Side(outward, chain), _) => {
                let points = edge(chain);
                let (first, last) = (points.first()?, points.last()?);
                let out = |p: &[f64; 2]| p[0] * outward[0] + p[1] * outward[1];
                let at = |along: f64, p: &[f64; 2]| {
                    let o = out(p);
                    [
                        along * chain.along[0] + o * outward[0],
                        along * chain.along[1] + o * outward[1],
                    ]
                };
                corners.push(at(chain.extent[0], first));
                corners.extend_from_slice(&points);
                corners.push(at(chain.extent[1], last));
            }
            (Piece::Wall(_), Piece::Side(..)) => {}
        }
    }
    let area = polygon_area(&corners);
    (corners.len() >= 3 && area > 0.0).then_some(area - plugs)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_rotation_and_mean_absolute_rotation() {
        let grains = GrainSet::from_parts(
            vec![[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]],
            vec![[0.0, 0.0]; 4],
            vec![0.1, -0.3, 0.2, 0.4],
            vec![0.5; 4],
        );
        let m = measure(
            &grains,
            &WallSet::default(),
            &ContactSet::default(),
            MembraneBoundary::default(),
            1.0,
            &[],
        );
        assert!((m.mean_rotation - 0.1).abs() < 1e-15);
        assert!((m.mean_absolute_rotation - 0.25).abs() < 1e-15);
        assert!(m.region_stress.is_empty());
    }
}
