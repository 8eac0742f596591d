//! Contact kinematics in the current configuration: normal, overlap, and the shear
//! displacement made in this increment (the contact point of `b` relative to that of `a`,
//! along the tangent).

use crate::geometry::{rotate, GrainSet, Pair, Side, WallSet};

/// Where everything is now, and how far it moved in this increment.
#[derive(Debug, Clone, Default)]
pub struct Configuration {
    /// Current grain centres.
    pub position: Vec<[f64; 2]>,
    /// Centre displacement since the start of the increment.
    pub displacement: Vec<[f64; 2]>,
    /// Rotation since the start of the increment.
    pub rotation: Vec<f64>,
    /// Current wall surface constants: `offset + position` of a line, the radius of a circle.
    pub wall_line: Vec<f64>,
    /// Wall displacement vector since the start of the increment (a line's, a moving
    /// plug's centre's; zero for a circle that only grows).
    pub wall_displacement: Vec<[f64; 2]>,
    /// Each wall's move into the sample since the start (m): its `position` now.
    pub wall_position: Vec<f64>,
    /// Angle each straight wall turned about its pivot in this increment (rad,
    /// anticlockwise).
    pub wall_turn: Vec<f64>,
}

impl Configuration {
    /// The configuration at the start of an increment: nothing has moved yet.
    pub fn at_rest(grains: &GrainSet, walls: &WallSet) -> Self {
        Configuration {
            position: grains.position.clone(),
            displacement: vec![[0.0; 2]; grains.len()],
            rotation: vec![0.0; grains.len()],
            wall_line: walls.walls.iter().map(|w| w.surface(w.position)).collect(),
            wall_displacement: vec![[0.0; 2]; walls.len()],
            wall_position: walls.walls.iter().map(|w| w.position).collect(),
            wall_turn: vec![0.0; walls.len()],
        }
    }
}

/// The geometry of one contact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Kinematics {
    /// Unit normal from `a` to `b`.
    pub normal: [f64; 2],
    /// Unit tangent: the normal turned 90 degrees anticlockwise.
    pub tangent: [f64; 2],
    /// Centre distance (grain-grain), centre-to-wall distance (line), or the distance from a
    /// circle's centre, negative for a ring (concave), where it sets the geometric terms (m).
    pub distance: f64,
    /// Overlap `n = r_a + r_b - d` (m).
    pub overlap: f64,
    /// Shear displacement of this increment (m).
    pub shear_increment: f64,
    /// `1 - (dd . n) / d`: how the rotating tangent scales the shear of a centre displacement.
    pub shear_scale: f64,
    /// The arm of the shear force about `a`'s centre: to the middle of the overlap (zero for
    /// a wall).
    pub lever_a: f64,
    /// The arm about `b`'s centre (its radius against a wall). With a grain on side `a` the
    /// two arms sum to the centre distance, so a pair turned as one body makes no shear
    /// displacement.
    pub lever_b: f64,
    /// `-(phi_a + phi_b) / 2`: the shear a unit of centre distance makes, as both arms grow
    /// with it by half a unit (zero against a wall).
    pub lever_shear: f64,
    /// Whether the contact normal is fixed (a straight wall): no geometric terms.
    pub flat: bool,
}

/// Kinematics of `pair` in configuration `q`, whose increments are taken from the committed
/// positions of `grains` and `walls`.
#[inline]
pub fn kinematics(pair: Pair, grains: &GrainSet, walls: &WallSet, q: &Configuration) -> Kinematics {
    // Branches are formed as (committed branch) + (increment difference): the rounding
    // error then scales with the grain size, not with the distance from the origin.
    let b = pair.b;
    let (ub, rb) = (q.displacement[b], grains.radius[b]);
    match pair.a {
        Side::Grain(a) => {
            let (ua, ra) = (q.displacement[a], grains.radius[a]);
            let d0 = grains.branch(a, b);
            let d = [d0[0] + (ub[0] - ua[0]), d0[1] + (ub[1] - ua[1])];
            let len = (d[0] * d[0] + d[1] * d[1]).sqrt();
            let n = [d[0] / len, d[1] / len];
            let t = [-n[1], n[0]];
            let dd = [ub[0] - ua[0], ub[1] - ua[1]];
            let (la, lb) = (0.5 * (len + ra - rb), 0.5 * (len + rb - ra));
            Kinematics {
                normal: n,
                tangent: t,
                distance: len,
                overlap: ra + rb - len,
                shear_increment: dd[0] * t[0] + dd[1] * t[1]
                    - la * q.rotation[a]
                    - lb * q.rotation[b],
                shear_scale: 1.0 - (dd[0] * n[0] + dd[1] * n[1]) / len,
                lever_a: la,
                lever_b: lb,
                lever_shear: -0.5 * (q.rotation[a] + q.rotation[b]),
                flat: false,
            }
        }
        Side::Wall(w) => wall_kinematics(w, b, grains, walls, q),
    }
}

/// Kinematics of wall `w` and grain `b` (see [`kinematics`]).
fn wall_kinematics(
    w: usize,
    b: usize,
    grains: &GrainSet,
    walls: &WallSet,
    q: &Configuration,
) -> Kinematics {
    let (ub, rb) = (q.displacement[b], grains.radius[b]);
    let wall = &walls.walls[w];
    let (ob, db) = (grains.origin[b], grains.displacement[b]);
    if let Some(circle) = &wall.circle {
        // Like a contact with a disc whose radius is the wall's: the normal turns as the
        // grain (or a moving plug) moves, the other way round inside a ring.
        let c = circle.center_at(wall.position);
        let uw = q.wall_displacement[w];
        let du = [ub[0] - uw[0], ub[1] - uw[1]];
        let d = [
            (ob[0] - c[0]) + (db[0] + du[0]),
            (ob[1] - c[1]) + (db[1] + du[1]),
        ];
        let len = (d[0] * d[0] + d[1] * d[1]).sqrt();
        let e = [d[0] / len, d[1] / len];
        let radius = q.wall_line[w];
        let (n, distance, overlap) = if circle.grains_inside {
            ([-e[0], -e[1]], -len, rb + len - radius)
        } else {
            (e, len, radius + rb - len)
        };
        let t = [-n[1], n[0]];
        return Kinematics {
            normal: n,
            tangent: t,
            distance,
            overlap,
            shear_increment: du[0] * t[0] + du[1] * t[1] - rb * q.rotation[b],
            shear_scale: 1.0 - (du[0] * n[0] + du[1] * n[1]) / distance,
            lever_a: 0.0,
            lever_b: rb,
            lever_shear: 0.0,
            flat: false,
        };
    }
    // A line: in this increment it moves by `uw` and then turns by `turn` about its
    // pivot (moved by `uw`). The grain's centre is taken in the wall's frame, along its
    // committed normal `nc` and tangent `tc` from the pivot; the turned frame gives
    // the distance, and the shear is the move along the wall in the wall's frame,
    // less the grain's rotation relative to the wall's.
    let (nc, tc) = (wall.current_normal(), wall.current_tangent());
    let turn = q.wall_turn[w];
    let (n, t) = (rotate(nc, turn), rotate(tc, turn));
    let pivot = wall.pivot_at(wall.position);
    let (start, moved) = wall.line_parts();
    let along0 = (nc[0] * ob[0] + nc[1] * ob[1] - start) + (nc[0] * db[0] + nc[1] * db[1] - moved);
    let across0 = tc[0] * (ob[0] - pivot[0] + db[0]) + tc[1] * (ob[1] - pivot[1] + db[1]);
    let (sin, cos) = turn.sin_cos();
    let uw = q.wall_displacement[w];
    let dd = [ub[0] - uw[0], ub[1] - uw[1]];
    let dist = (cos * along0 + sin * across0) + (n[0] * dd[0] + n[1] * dd[1]);
    Kinematics {
        normal: n,
        tangent: t,
        distance: dist,
        overlap: rb - dist,
        shear_increment: dd[0] * t[0] + dd[1] * t[1] + ((cos - 1.0) * across0 - sin * along0)
            - rb * (q.rotation[b] - turn),
        shear_scale: 1.0,
        lever_a: 0.0,
        lever_b: rb,
        lever_shear: 0.0,
        flat: true,
    }
}
