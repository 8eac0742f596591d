//! What holds a sample beyond its walls: the grains a membrane's chain may run over, and the
//! anchors that hold the rigid-body motions no wall holds.

use crate::contact::Contact;
use crate::geometry::{GrainSet, Side, WallSet};

/// A spring on one grain along `direction`, holding a rigid-body motion of the sample that no
/// wall holds: its rotation inside frictionless rings and plugs, and also its translations
/// when membranes alone bound it. The loads on such a sample balance in those motions, so in
/// equilibrium the anchors, three at most and statically determinate, carry only what the
/// residual tolerance leaves: they make the system regular without changing the answer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Anchor {
    /// The grain held.
    pub grain: usize,
    /// Unit direction it is held in.
    pub direction: [f64; 2],
}

/// How many contacts hold each of `n` grains (bonded, or pressed: walls included), and the
/// grains each is held by.
fn holding(n: usize, contacts: &[Contact]) -> (Vec<usize>, Vec<Vec<usize>>) {
    let mut neighbours = vec![Vec::new(); n];
    let mut held = vec![0usize; n];
    for c in contacts.iter().filter(|c| c.bonded || c.overlap > 0.0) {
        held[c.pair.b] += 1;
        if let Side::Grain(a) = c.pair.a {
            held[a] += 1;
            neighbours[a].push(c.pair.b);
            neighbours[c.pair.b].push(a);
        }
    }
    (held, neighbours)
}

/// The grains a membrane may lie on: those bonded to at least two others, or pressed by at
/// least three contacts, which push back on a pressure from any side. A grain held by less
/// (a rattler left against a ring that was taken away, a grain hanging on one bond, a grain
/// perched on two neighbours, whose friction it slides on) is pushed around its supports or
/// into the sample, with no equilibrium until it meets another; the membrane passes over it.
/// All grains when none is held so (a packing before its first contacts). Fixed from the
/// committed state at the start of each increment, so the chain does not gain or lose grains
/// as they touch within it. Grains taken out of the sample never carry.
pub fn membrane_carriers(grains: &GrainSet, contacts: &[Contact]) -> Vec<bool> {
    let n = grains.len();
    let (held, _) = holding(n, contacts);
    let mut bonds = vec![0usize; n];
    for c in contacts.iter().filter(|c| c.bonded) {
        bonds[c.pair.b] += 1;
        if let Side::Grain(a) = c.pair.a {
            bonds[a] += 1;
        }
    }
    let carrying: Vec<bool> = (0..n).map(|g| bonds[g] >= 2 || held[g] >= 3).collect();
    if carrying.iter().any(|&c| c) {
        carrying
    } else {
        grains.taken_out.iter().map(|&out| !out).collect()
    }
}

/// Contacts below which a grain counts as loose when anchors are chosen: a grain held by
/// fewer can roll or swing about its supports (a rattler, a grain on the borehole's surface
/// that leaned on the plug, a grain standing out of the membrane's chain).
const ANCHOR_CONTACTS: usize = 4;

/// The anchors a sample needs: none while a straight wall or friction holds it; its rotation
/// inside frictionless circles alone; its translations too with no walls at all. An anchor
/// holds the whole sample only through its grain's contacts, so it goes on the grains deepest
/// in the network of contacts that hold (bonded or pressed): counted in contacts from the
/// nearest grain with fewer than four of them (`ANCHOR_CONTACTS`). The deepest grain,
/// nearest the centroid among equals, takes the translations; of the grains at least two
/// contacts deep, the one farthest from the centroid takes the rotation, so its lever is
/// long. Chosen anew from the committed state at the start of every increment (a spring acts
/// on the move within the increment only), so a resumed run chooses the same. Grains taken
/// out of the sample are not in it: they count in neither the centroid nor the choice.
pub fn anchors(grains: &GrainSet, walls: &WallSet, contacts: &[Contact]) -> Vec<Anchor> {
    let straight = walls.walls.iter().any(|w| w.circle.is_none());
    let friction = walls.walls.iter().any(|w| w.friction != 0.0);
    let n = grains.len();
    let in_sample: Vec<usize> = grains.in_sample().collect();
    if in_sample.len() < 2 || straight || friction {
        return Vec::new();
    }
    // The network of contacts that hold, and each grain's depth in it.
    let (held, neighbours) = holding(n, contacts);
    let mut depth = vec![usize::MAX; n];
    let mut queue = std::collections::VecDeque::new();
    for g in (0..n).filter(|&g| held[g] < ANCHOR_CONTACTS) {
        depth[g] = 0;
        queue.push_back(g);
    }
    while let Some(g) = queue.pop_front() {
        for &h in &neighbours[g] {
            if depth[h] == usize::MAX {
                depth[h] = depth[g] + 1;
                queue.push_back(h);
            }
        }
    }
    // Grains no loose grain reaches (none is loose): as deep as can be.
    let depth = |g: usize| depth[g].min(n);
    let count = in_sample.len() as f64;
    let centroid = in_sample.iter().fold([0.0; 2], |c, &g| {
        let p = grains.position[g];
        [c[0] + p[0] / count, c[1] + p[1] / count]
    });
    let offset = |g: usize| {
        let p = grains.position[g];
        [p[0] - centroid[0], p[1] - centroid[1]]
    };
    let distance = |g: usize| offset(g)[0].hypot(offset(g)[1]);
    let mut out = Vec::new();
    if walls.is_empty() {
        let deepest = (in_sample.iter().copied())
            .min_by(|&a, &b| {
                depth(b)
                    .cmp(&depth(a))
                    .then(distance(a).total_cmp(&distance(b)))
                    .then(a.cmp(&b))
            })
            .expect("grains");
        for direction in [[1.0, 0.0], [0.0, 1.0]] {
            out.push(Anchor {
                grain: deepest,
                direction,
            });
        }
    }
    let deep = in_sample
        .iter()
        .map(|&g| depth(g))
        .max()
        .unwrap_or(0)
        .min(2);
    let far = (in_sample.iter().copied())
        .filter(|&g| depth(g) >= deep)
        .max_by(|&a, &b| distance(a).total_cmp(&distance(b)).then(b.cmp(&a)))
        .expect("grains");
    let (r, size) = (offset(far), distance(far));
    if size > 0.0 {
        out.push(Anchor {
            grain: far,
            direction: [-r[1] / size, r[0] / size],
        });
    }
    out
}
