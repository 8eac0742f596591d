//! The force and tangent of one contact on its 6 local entries `[xa, ya, phia, xb, yb, phib]`
//! (`a` a wall: its displacement vector instead of `xa, ya`, no `phia`).
//!
//! With `B_n = d(overlap)/dq = [n, 0, -n, 0]` and `B_t = [-t, -l_a, t, -l_b]` (`l` the arms
//! from the centres to the middle of the overlap), the contact pushes its sides with
//! `f = -(F_n B_n + F_s B_t)`, and the tangent `K = -df/dq` is
//!
//! `K = F_n' B_n^T B_n + dF_s/dn B_t^T B_n + dF_s/ds B_t^T S + F_n G + F_s H`
//!
//! where `S = ds/dq` (the tangent turns and the arms grow as the centres move) and `G`, `H`
//! are the geometric terms of the rotating normal (`t t^T / d` and `-n t^T / d` on the
//! centres). The arms' own terms in `H` (the shear force on a centre as a grain turns) are
//! left out: against `dF_s/ds B_t^T S` they are of the order of the shear displacement over
//! the radius. Only `G` and the elastic blocks are symmetric; for a symmetric solver `S` is
//! taken as `B_t` and `H` by its symmetric part.

use super::PairMap;
use crate::contact::{Kinematics, Response};

/// Which tangent a contact's block gives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BlockTangent {
    /// `-df/dq` in full: unsymmetric.
    Consistent,
    /// Its symmetric part (`S` taken as `B_t`, `H` by its symmetric part).
    Symmetric,
    /// The symmetric part projected to positive semi-definite: the geometric terms left out
    /// where they soften (`F_n G` under compression, `F_s H` always), so every block is a sum
    /// of `k b b^T` with `k >= 0`. The minimisation's Hessian.
    Projected,
}

/// A contact's force on, and stiffness of, the unknowns it touches.
#[derive(Debug, Clone, Copy, Default)]
pub struct LocalBlock {
    /// Force on each reduced unknown.
    pub force: [f64; 6],
    /// Tangent `-df/dq`, row-major over the reduced unknowns.
    pub stiffness: [[f64; 6]; 6],
    /// A second force on each reduced unknown, where one is asked for: what the shear force's
    /// true push has beyond the potential's gradient ([`frame_turn_force`]).
    pub second_force: [f64; 6],
}

/// The force and, when `tangent` says which, the tangent of one contact, reduced to the
/// unknowns of `map`, into `out` (its stiffness left as it was without a tangent).
pub fn contact_block(
    k: &Kinematics,
    r: &Response,
    map: &PairMap,
    tangent: Option<BlockTangent>,
    exact_gradient: bool,
    out: &mut LocalBlock,
) {
    let n = k.normal;
    let bn = [n[0], n[1], 0.0, -n[0], -n[1], 0.0];
    // The shear force pushes the centres along `B_t`, or, as the exact gradient of the
    // contact's potential, along `S`: its tangent turns as the centres move.
    let push = if exact_gradient {
        turning_push(k)
    } else {
        shear_push(k)
    };
    let f: [f64; 6] = std::array::from_fn(|a| -(r.normal_force * bn[a] + r.shear_force * push[a]));
    match tangent {
        None => reduce(&f, None, map, out),
        Some(tangent) if map.is_direct() => {
            out.force = f;
            local_tangent(k, r, tangent, &mut out.stiffness);
        }
        Some(tangent) => {
            let mut kl = [[0.0; 6]; 6];
            local_tangent(k, r, tangent, &mut kl);
            reduce(&f, Some(&kl), map, out);
        }
    }
}

/// The tangent of one contact on its 6 local entries into `kl`.
fn local_tangent(k: &Kinematics, r: &Response, tangent: BlockTangent, kl: &mut [[f64; 6]; 6]) {
    let symmetric = tangent != BlockTangent::Consistent;
    let projected = tangent == BlockTangent::Projected;
    let (n, t) = (k.normal, k.tangent);
    let bn = [n[0], n[1], 0.0, -n[0], -n[1], 0.0];
    let bt = shear_push(k);
    let s = if symmetric { bt } else { turning_push(k) };
    for a in 0..6 {
        for b in 0..6 {
            kl[a][b] =
                r.dfn_dn * bn[a] * bn[b] + r.dfs_dn * bt[a] * bn[b] + r.dfs_ds * bt[a] * s[b];
        }
    }
    // `-F_n / d` is the sign of G's block on the centres: it stiffens in tension, or
    // against a concave ring (negative distance).
    let softens = projected && r.normal_force / k.distance > 0.0;
    if !k.flat && !softens {
        // Geometric terms on the centre entries: blocks [[-X, X], [X, -X]] for G and
        // [[X, -X], [-X, X]] for H, with X the 2x2 term.
        let d = k.distance;
        for p in 0..2 {
            for q in 0..2 {
                let gpq = r.normal_force * t[p] * t[q] / d;
                let hpq = if projected {
                    0.0
                } else if symmetric {
                    -0.5 * r.shear_force * (n[p] * t[q] + t[p] * n[q]) / d
                } else {
                    -r.shear_force * n[p] * t[q] / d
                };
                kl[p][q] += -gpq + hpq;
                kl[p][3 + q] += gpq - hpq;
                kl[3 + p][q] += gpq - hpq;
                kl[3 + p][3 + q] += -gpq + hpq;
            }
        }
    }
}

/// What the true push of a contact's shear force on its sides (along `B_t`) has beyond its
/// push as the exact gradient of the contact's potential (along `S`), reduced to the unknowns
/// of `map`, into `out`'s second force: the part of the force the turning tangent leaves out
/// of the potential.
pub fn frame_turn_force(k: &Kinematics, r: &Response, map: &PairMap, out: &mut LocalBlock) {
    let (bt, scaled) = (shear_push(k), turning_push(k));
    let f: [f64; 6] = std::array::from_fn(|a| -r.shear_force * (bt[a] - scaled[a]));
    out.second_force = reduce_force(&f, map);
}

/// `B_t = d(shear)/dq` with the tangent held.
fn shear_push(k: &Kinematics) -> [f64; 6] {
    let t = k.tangent;
    [-t[0], -t[1], -k.lever_a, t[0], t[1], -k.lever_b]
}

/// `S = ds/dq`: `B_t` with the centre entries scaled by `1 - (dd . n)/d`, as the tangent
/// turns, and moved along `n` as the arms grow with the centre distance.
fn turning_push(k: &Kinematics) -> [f64; 6] {
    let (n, t, g, h) = (k.normal, k.tangent, k.shear_scale, k.lever_shear);
    let centre = [g * t[0] + h * n[0], g * t[1] + h * n[1]];
    [
        -centre[0], -centre[1], -k.lever_a, centre[0], centre[1], -k.lever_b,
    ]
}

/// The local force (and tangent) reduced to the unknowns of `map`, into `out` (its stiffness
/// left as it was without a tangent).
fn reduce(f: &[f64; 6], kl: Option<&[[f64; 6]; 6]>, map: &PairMap, out: &mut LocalBlock) {
    out.force = reduce_force(f, map);
    let Some(kl) = kl else { return };
    let Some(feeds) = &map.feeds else {
        out.stiffness = *kl;
        return;
    };
    out.stiffness = [[0.0; 6]; 6];
    for (a, feeds_a) in feeds.iter().enumerate() {
        for &(ra, wa) in feeds_a.iter().flatten() {
            for (b, feeds_b) in feeds.iter().enumerate() {
                for &(rb, wb) in feeds_b.iter().flatten() {
                    out.stiffness[ra][rb] += wa * wb * kl[a][b];
                }
            }
        }
    }
}

/// A local force reduced to the unknowns of `map`.
fn reduce_force(f: &[f64; 6], map: &PairMap) -> [f64; 6] {
    let Some(feeds) = &map.feeds else {
        return *f;
    };
    let mut out = [0.0; 6];
    for (a, feeds_a) in feeds.iter().enumerate() {
        for &(ra, wa) in feeds_a.iter().flatten() {
            out[ra] += wa * f[a];
        }
    }
    out
}
