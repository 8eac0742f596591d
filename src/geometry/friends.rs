//! The 'friends' lists of appendix 3: every pair of grains (and grain and wall) closer than a
//! skin distance, found once with a cell grid and kept until some grain has moved half the
//! skin from where it was when the list was made. Contacts are made and lost only within
//! this list, and it also fixes the sparsity pattern of the global stiffness matrix.

use super::{CellGrid, GrainSet, WallSet};
use crate::parallel;

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
    /// Wall turns when the list was made (rad).
    pub wall_turn: Vec<f64>,
    /// Size of the grains' bounding box (its diagonal) when the list was made (m): the
    /// farthest a wall's grains can be from its pivot, the lever of its turn.
    pub span: f64,
    /// Gap below which two surfaces are friends (m).
    pub skin: f64,
    /// The pairs farther apart than the skin that the lists hold because they were contacts
    /// when the lists were made, sorted.
    pub held: Vec<Pair>,
}

impl FriendSet {
    /// Build the lists around the current positions: a cell grid with cells as wide as the
    /// largest possible friend distance, so only the 3x3 cells around a grain are searched.
    /// Each grain's search is its own, shared over the threads; the lists come back in
    /// grain order. Grains taken out of the sample have no friends.
    pub fn build(grains: &GrainSet, walls: &WallSet, skin: f64) -> FriendSet {
        let n = grains.len();
        let out = &grains.taken_out;
        let mut pairs = Vec::new();
        if n > 0 {
            let r_max = grains.radius.iter().cloned().fold(0.0, f64::max);
            let grid = CellGrid::new(&grains.position, 2.0 * r_max + skin);
            pairs = parallel::flat_map(n, |i| {
                let mut near: Vec<usize> = grid
                    .near(grains.position[i])
                    .filter(|&j| j > i && !out[i] && !out[j] && gap(grains, i, j) < skin)
                    .collect();
                near.sort_unstable();
                near.into_iter().map(move |j| Pair {
                    a: Side::Grain(i),
                    b: j,
                })
            });
        }
        for (w, wall) in walls.walls.iter().enumerate() {
            pairs.extend(parallel::flat_map(n, |i| {
                (!out[i] && wall.distance(grains.position[i]) - grains.radius[i] < skin).then_some(
                    Pair {
                        a: Side::Wall(w),
                        b: i,
                    },
                )
            }));
        }
        FriendSet {
            pairs,
            reference: grains.position.clone(),
            wall_reference: walls.walls.iter().map(|w| [w.position, w.slide]).collect(),
            wall_turn: walls.walls.iter().map(|w| w.turn).collect(),
            span: {
                let b = grains.bounding_box();
                if n > 0 {
                    (b[2] - b[0]).hypot(b[3] - b[1])
                } else {
                    0.0
                }
            },
            skin,
            held: Vec::new(),
        }
    }

    /// Whether a grain or wall has moved half the skin since the lists were made, so that a
    /// pair outside the lists could now touch (`position`: grain centres, `wall_position`:
    /// each wall's move into the sample, `wall_turn`: each wall's turn).
    pub fn is_stale(
        &self,
        position: &[[f64; 2]],
        wall_position: &[f64],
        wall_turn: &[f64],
    ) -> bool {
        self.drift(position, wall_position, wall_turn) > 0.5 * self.skin
    }

    /// The furthest any grain or wall has moved since the lists were made (m); a wall that
    /// turned moves its line by up to the turn times the span of the grains.
    pub fn drift(&self, position: &[[f64; 2]], wall_position: &[f64], wall_turn: &[f64]) -> f64 {
        let grains = position
            .iter()
            .zip(&self.reference)
            .map(|(p, q)| (p[0] - q[0]).hypot(p[1] - q[1]));
        let walls = wall_position
            .iter()
            .zip(&self.wall_reference)
            .zip(wall_turn.iter().zip(&self.wall_turn))
            .map(|((w, q), (turn, was))| (w - q[0]).abs() + (turn - was).abs() * self.span);
        grains.chain(walls).fold(0.0, f64::max)
    }
}

/// Surface-to-surface gap between two grains (negative when they overlap).
pub fn gap(grains: &GrainSet, i: usize, j: usize) -> f64 {
    let (p, q) = (grains.position[i], grains.position[j]);
    (q[0] - p[0]).hypot(q[1] - p[1]) - grains.radius[i] - grains.radius[j]
}
