//! The 'friends' lists of appendix 3: every pair of grains (and grain and wall) closer than a
//! skin distance, found once with a cell grid and kept until some grain has moved half the
//! skin from where it was when the list was made. Contacts are made and lost only within
//! this list, and it also fixes the sparsity pattern of the global stiffness matrix.

use super::{GrainSet, WallSet};

/// One side of a pair: a grain or a wall.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Side {
    /// A grain, by index.
    Grain(usize),
    /// A wall, by index.
    Wall(usize),
}

/// Two things that may touch: side `a` (grain with the lower index, or a wall) and grain `b`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Pair {
    /// The lower grain or the wall.
    pub a: Side,
    /// The higher grain.
    pub b: usize,
}

/// The friends lists: all pairs within the skin, and where everything was when they were made.
#[derive(Debug, Clone, PartialEq)]
pub struct FriendSet {
    /// Sorted pairs: grain-grain pairs first (by `a`, then `b`), then grain-wall pairs.
    pub pairs: Vec<Pair>,
    /// Grain centres when the list was made.
    pub reference: Vec<[f64; 2]>,
    /// Wall positions (normal, along) when the list was made.
    pub wall_reference: Vec<[f64; 2]>,
    /// Gap below which two surfaces are friends (m).
    pub skin: f64,
}

impl FriendSet {
    /// Build the lists around the current positions: a cell grid with cells as wide as the
    /// largest possible friend distance, so only the 3x3 cells around a grain are searched.
    pub fn build(grains: &GrainSet, walls: &WallSet, skin: f64) -> FriendSet {
        let n = grains.len();
        let mut pairs = Vec::new();
        if n > 0 {
            let r_max = grains.radius.iter().cloned().fold(0.0, f64::max);
            let cell = 2.0 * r_max + skin;
            let b = grains.bounding_box();
            let cols = (((b[2] - b[0]) / cell).floor() as usize + 1).min(1 << 16);
            let rows = (((b[3] - b[1]) / cell).floor() as usize + 1).min(1 << 16);
            let cell_of = |p: [f64; 2]| {
                let c = (((p[0] - b[0]) / cell).floor().max(0.0) as usize).min(cols - 1);
                let r = (((p[1] - b[1]) / cell).floor().max(0.0) as usize).min(rows - 1);
                (c, r)
            };
            // Counting sort of grains into cells: `start[k]..start[k+1]` indexes `members`.
            let mut start = vec![0usize; cols * rows + 1];
            for p in &grains.position {
                let (c, r) = cell_of(*p);
                start[r * cols + c + 1] += 1;
            }
            for k in 0..cols * rows {
                start[k + 1] += start[k];
            }
            let mut fill = start.clone();
            let mut members = vec![0usize; n];
            for (i, p) in grains.position.iter().enumerate() {
                let (c, r) = cell_of(*p);
                members[fill[r * cols + c]] = i;
                fill[r * cols + c] += 1;
            }
            for i in 0..n {
                let (c, r) = cell_of(grains.position[i]);
                let mut near = Vec::new();
                for rr in r.saturating_sub(1)..=(r + 1).min(rows - 1) {
                    for cc in c.saturating_sub(1)..=(c + 1).min(cols - 1) {
                        let k = rr * cols + cc;
                        for &j in &members[start[k]..start[k + 1]] {
                            if j > i && gap(grains, i, j) < skin {
                                near.push(j);
                            }
                        }
                    }
                }
                near.sort_unstable();
                pairs.extend(near.into_iter().map(|j| Pair {
                    a: Side::Grain(i),
                    b: j,
                }));
            }
        }
        for (w, wall) in walls.walls.iter().enumerate() {
            for i in 0..n {
                if wall.distance(grains.position[i]) - grains.radius[i] < skin {
                    pairs.push(Pair {
                        a: Side::Wall(w),
                        b: i,
                    });
                }
            }
        }
        FriendSet {
            pairs,
            reference: grains.position.clone(),
            wall_reference: walls.walls.iter().map(|w| [w.position, w.slide]).collect(),
            skin,
        }
    }

    /// Whether a grain or wall has moved half the skin since the lists were made, so that a
    /// pair outside the lists could now touch (`position`: grain centres, `wall_position`:
    /// each wall's move into the sample).
    pub fn is_stale(&self, position: &[[f64; 2]], wall_position: &[f64]) -> bool {
        let half = 0.5 * self.skin;
        position
            .iter()
            .zip(&self.reference)
            .any(|(p, q)| (p[0] - q[0]).hypot(p[1] - q[1]) > half)
            || wall_position
                .iter()
                .zip(&self.wall_reference)
                .any(|(w, q)| (w - q[0]).abs() > half)
    }
}

/// Surface-to-surface gap between two grains (negative when they overlap).
pub fn gap(grains: &GrainSet, i: usize, j: usize) -> f64 {
    let (p, q) = (grains.position[i], grains.position[j]);
    (q[0] - p[0]).hypot(q[1] - p[1]) - grains.radius[i] - grains.radius[j]
}
