//! Assembly: the map from grains and walls to unknowns (only those the scene needs), the
//! sparsity pattern built once from the friends lists (symbolic), and the residual and
//! tangent scattered into that fixed pattern every iteration (numeric).
//!
//! Contract: the [`Pattern`] depends only on the friends lists and the [`DofMap`]; contacts
//! may open and close freely inside it. A new pattern (and so a new symbolic factorisation)
//! is needed only when the friends lists are rebuilt.

mod local;

pub use local::{contact_block, frame_turn_force, BlockTangent, LocalBlock};

use crate::geometry::{Chain, FriendSet, Pair, Side, WallSet};
use crate::memory::HeapBytes;
use crate::parallel;
use faer::sparse::SymbolicSparseColMat;
use rayon::prelude::*;
use std::ops::Range;

/// How a grain glued to a wall moves in a step: as a part of its wall, which stretches with
/// the walls across it (its span walls), so that the box's edge deforms as the box does.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Glue {
    /// The wall the grain is glued to.
    pub wall: usize,
    /// The walls whose normal moves carry the grain's centre, each with the centre's move per
    /// unit of the wall's move: its own wall (along that wall's starting normal), then its
    /// span walls (along its own wall). The weights of a step are set by [`DofMap::follow`].
    pub follows: [Option<(usize, [f64; 2])>; 3],
}

/// Which unknowns exist: `x, y` (and `phi` unless rotations are fixed) per grain, then one
/// normal position per stress-controlled wall. A grain glued to a wall moves with it as a
/// part of it ([`Glue`]): its contacts feed the unknowns of the walls it follows instead of
/// its own, and its own unknowns stay in place, held at zero by springs, so every grain
/// keeps the same layout of unknowns. A grain taken out of the sample has its unknowns held
/// so too: it has no contacts, and stays where it was taken out.
#[derive(Debug, Clone, PartialEq)]
pub struct DofMap {
    /// Unknowns per grain: 2 or 3.
    pub per_grain: usize,
    /// Number of grains.
    pub grains: usize,
    /// The unknown of each wall, `None` for prescribed walls.
    pub wall: Vec<Option<usize>>,
    /// For each grain, how it follows the wall it is glued to.
    pub glue: Vec<Option<Glue>>,
    /// For each grain, whether it has been taken out of the sample.
    pub taken_out: Vec<bool>,
    /// Total number of unknowns.
    pub len: usize,
}

impl DofMap {
    /// Unknowns for `grains` grains and the stress-controlled walls of `walls`; `glued` gives
    /// the wall each grain is glued to, if any, and `taken_out` whether it has been taken out
    /// of the sample (either empty: none is).
    pub fn new(
        grains: usize,
        fixed_rotations: bool,
        walls: &WallSet,
        glued: &[Option<usize>],
        taken_out: &[bool],
    ) -> Self {
        let per_grain = if fixed_rotations { 2 } else { 3 };
        let mut next = grains * per_grain;
        let wall = walls
            .walls
            .iter()
            .map(|w| {
                (w.control == crate::geometry::WallControl::Stress).then(|| {
                    next += 1;
                    next - 1
                })
            })
            .collect();
        let glue = (0..grains)
            .map(|g| {
                let w = glued.get(g).copied().flatten()?;
                let span = walls.span_walls(w);
                Some(Glue {
                    wall: w,
                    follows: [
                        Some((w, walls.walls[w].normal)),
                        span.map(|(a, _)| (a, [0.0; 2])),
                        span.map(|(_, b)| (b, [0.0; 2])),
                    ],
                })
            })
            .collect();
        DofMap {
            per_grain,
            grains,
            wall,
            glue,
            taken_out: (0..grains)
                .map(|g| taken_out.get(g) == Some(&true))
                .collect(),
            len: next,
        }
    }

    /// First unknown of grain `i`.
    pub fn grain(&self, i: usize) -> usize {
        i * self.per_grain
    }

    /// Whether grains have a rotation unknown.
    pub fn rotations(&self) -> bool {
        self.per_grain == 3
    }

    /// The grain an unknown belongs to (`None` for wall unknowns).
    pub fn owner(&self, dof: usize) -> Option<usize> {
        (dof < self.grains * self.per_grain).then(|| dof / self.per_grain)
    }

    /// The weights with which glued grains follow their span walls in a step that turns the
    /// walls by `turn`, from the committed `grains` and `walls`. A grain at the fraction `f`
    /// of the way from span wall `a` to span wall `b` moves along its wall by `1 - f` of
    /// the move of the corner where `a` meets it, and by `f` of the corner at `b`: the wall
    /// stretches as the box grows, and a shear box whose top is stress-controlled can
    /// dilate (rigid sides with their grains glued would hold it down). The stretch is taken
    /// along the committed wall and then turned with it, so glued grains stay on their walls.
    pub fn follow(&mut self, grains: &crate::geometry::GrainSet, walls: &WallSet, turn: &[f64]) {
        let dot = |u: [f64; 2], v: [f64; 2]| u[0] * v[0] + u[1] * v[1];
        for (g, glue) in self.glue.iter_mut().enumerate() {
            let Some(glue) = glue else { continue };
            let [Some(_), Some((a, _)), Some((b, _))] = glue.follows else {
                continue;
            };
            let wall = &walls.walls[glue.wall];
            let t = wall.current_tangent();
            let x = grains.position[g];
            let (wa, wb) = (&walls.walls[a], &walls.walls[b]);
            let (da, db) = (wa.distance(x), wb.distance(x));
            let f = da / (da + db);
            // How far along `t` the corner with a span wall moves per unit of its move.
            let corner = |s: &crate::geometry::Wall| {
                let n = s.current_normal();
                dot(s.normal, n) / dot(t, n)
            };
            let along = |share: f64| crate::geometry::rotate(t.map(|v| share * v), turn[glue.wall]);
            glue.follows[1] = Some((a, along((1.0 - f) * corner(wa))));
            glue.follows[2] = Some((b, along(f * corner(wb))));
        }
    }

    /// Whether `pair` is part of a wall's glue: a glued grain's contact with its wall or with
    /// another grain glued to the same wall.
    pub fn glues(&self, pair: Pair) -> bool {
        let wall_of = |g: usize| self.glue[g].map(|glue| glue.wall);
        let a = match pair.a {
            Side::Wall(w) => Some(w),
            Side::Grain(a) => wall_of(a),
        };
        a.is_some() && a == wall_of(pair.b)
    }

    /// Whether grain `g`'s own unknowns are held at zero: it is glued to a wall, or taken out
    /// of the sample.
    pub fn grain_held(&self, g: usize) -> bool {
        self.glue[g].is_some() || self.taken_out[g]
    }

    /// The reduced unknowns of a pair and, for each of the 6 local entries
    /// `[xa, ya, phia, xb, yb, phib]`, which reduced unknown it feeds and with what weight.
    /// A wall's unknown (its move into the sample) feeds `xa, ya` along `n`, the direction it
    /// moves side `a` ([`crate::geometry::Wall::push_direction`]): for a growing circle the
    /// contact normal, so moving it by `s` changes the overlap by `s`, as moving a grain `a`
    /// by `s n` would; for a line its starting normal (the contact normal until it turns);
    /// for a moving plug the direction of its centre. A glued
    /// grain's centre entries feed the unknowns of the walls it follows; its rotation, the
    /// wall's prescribed turn, feeds nothing.
    pub fn pair_map(&self, pair: Pair, n: [f64; 2]) -> PairMap {
        let mut m = PairMap::default();
        match pair.a {
            Side::Grain(a)
                if self.per_grain == 3 && self.glue[a].is_none() && self.glue[pair.b].is_none() =>
            {
                return PairMap::direct(self.grain(a), self.grain(pair.b));
            }
            Side::Grain(a) => m.push_grain(self, a, 0),
            Side::Wall(w) => {
                if let Some(dof) = self.wall[w] {
                    let k = m.add(dof);
                    m.feeds_mut()[0][0] = Some((k, n[0]));
                    m.feeds_mut()[1][0] = Some((k, n[1]));
                }
            }
        }
        m.push_grain(self, pair.b, 3);
        m
    }
}

/// For each of a contact's 6 local entries: (index into its map's `dofs`, weight), up to
/// three (a glued grain's centre follows its wall and its span walls).
pub type Feeds = [[Option<(usize, f64)>; 3]; 6];

/// The unknowns one contact touches (at most 6) and how its 6 local entries feed them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairMap {
    /// Global unknowns, in local order.
    pub dofs: [usize; 6],
    /// How many of `dofs` are used.
    pub len: usize,
    /// How the local entries feed `dofs`; `None` where each feeds the unknown of its own index
    /// with weight 1 (two free grains with rotations, most contacts): the block needs no
    /// reduction, and the map, made at every evaluation, is six numbers.
    pub feeds: Option<Feeds>,
}

impl Default for PairMap {
    /// A map that touches no unknown.
    fn default() -> PairMap {
        PairMap {
            dofs: [0; 6],
            len: 0,
            feeds: None,
        }
    }
}

impl PairMap {
    /// The map of two free grains with rotations whose first unknowns are `a` and `b`.
    fn direct(a: usize, b: usize) -> PairMap {
        PairMap {
            dofs: [a, a + 1, a + 2, b, b + 1, b + 2],
            len: 6,
            feeds: None,
        }
    }

    /// Whether each local entry is the unknown of the same index with weight 1.
    pub fn is_direct(&self) -> bool {
        self.feeds.is_none()
    }

    /// What local entry `entry` feeds: (index into `dofs`, weight).
    pub fn feeds_of(&self, entry: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let reduced = self
            .feeds
            .as_ref()
            .map(|f| f[entry].iter().flatten().copied());
        let direct = self.feeds.is_none().then_some((entry, 1.0));
        reduced.into_iter().flatten().chain(direct)
    }

    /// The feeds of a map that reduces its block, to be written.
    fn feeds_mut(&mut self) -> &mut Feeds {
        self.feeds.get_or_insert([[None; 3]; 6])
    }

    /// The index of `dof` in `dofs`, added if it is not there yet (both sides of a contact
    /// may feed one wall's unknown).
    fn add(&mut self, dof: usize) -> usize {
        if let Some(k) = self.dofs[..self.len].iter().position(|&d| d == dof) {
            return k;
        }
        self.dofs[self.len] = dof;
        self.len += 1;
        self.len - 1
    }

    fn push_grain(&mut self, map: &DofMap, i: usize, at: usize) {
        match map.glue[i] {
            Some(glue) => {
                for (j, &(w, v)) in glue.follows.iter().flatten().enumerate() {
                    if let Some(dof) = map.wall[w] {
                        let k = self.add(dof);
                        self.feeds_mut()[at][j] = Some((k, v[0]));
                        self.feeds_mut()[at + 1][j] = Some((k, v[1]));
                    }
                }
            }
            None => {
                let base = map.grain(i);
                for k in 0..map.per_grain {
                    let slot = self.add(base + k);
                    self.feeds_mut()[at + k][0] = Some((slot, 1.0));
                }
            }
        }
    }
}

/// One thread's share of a scatter: its range of unknowns and its parts of the residual, the
/// second force and the tangent's values.
type ScatterPart<'a> = (
    Range<usize>,
    &'a mut [f64],
    Option<&'a mut [f64]>,
    Option<&'a mut [f64]>,
);

/// The fixed sparsity pattern (full storage, both triangles) and where each pair's block lands
/// in the value array.
#[derive(Debug, Clone)]
pub struct Pattern {
    /// Column structure, in 32 bits as the slots (see [`value_index`]).
    pub symbolic: SymbolicSparseColMat<u32>,
    /// For pair `p`, `slots[start[p]..start[p+1]]` holds, column by column of its reduced
    /// block as the values lie, the value index of the first row of each run of consecutive
    /// unknowns in its map (see [`runs`]): the run's other rows follow it. In 32 bits:
    /// they are most of the pattern's memory.
    slots: Vec<u32>,
    start: Vec<usize>,
    /// Value index of each diagonal entry.
    pub diagonal: Vec<usize>,
    /// Value index of the (wall, span wall) entries of follower loads: `(row, col, slot)`.
    pub couplings: Vec<(usize, usize, usize)>,
    /// The grain links outside the friends lists it was built with (membrane chains).
    pub chain_links: Vec<(usize, usize)>,
}

/// A value index in 32 bits: a pattern holds about 60 entries a grain, so 32 bits hold the
/// patterns of some 70 million grains, far beyond what the factor leaves room for.
pub fn value_index(index: usize) -> u32 {
    u32::try_from(index).expect("a pattern of fewer than 2^32 entries")
}

/// The runs of consecutive unknowns among a pair's `dofs` (at most 6), each as the range of
/// its places in `dofs`, and how many there are. A column's rows are sorted and distinct,
/// so the rows of a run lie next to each other in every column that holds them: only the
/// first one's value index need be kept (a grain's two or three unknowns are one run).
fn runs(dofs: &[usize]) -> ([(usize, usize); 6], usize) {
    let mut runs = [(0, 0); 6];
    let mut count = 0;
    for a in 0..dofs.len() {
        if a > 0 && dofs[a] == dofs[a - 1] + 1 {
            runs[count - 1].1 = a + 1;
        } else {
            runs[count] = (a, a + 1);
            count += 1;
        }
    }
    (runs, count)
}

/// The unknowns pair `p` touches. Made again where needed rather than kept: its whole map
/// (weights included, which do not matter to the pattern) is some 500 bytes.
fn pair_dofs(dofs: &DofMap, p: &Pair) -> ([usize; 6], usize) {
    let m = dofs.pair_map(*p, [0.0; 2]);
    (m.dofs, m.len)
}

/// Every entry of the pattern as (column, row), repeats included: the diagonal, the centre
/// blocks of grain links outside the friends lists (membrane chains), each friend pair's
/// block, and each wall coupling both ways.
fn each_entry(
    dofs: &DofMap,
    links: &[(usize, usize)],
    pairs: &[Pair],
    couplings: &[(usize, usize)],
    mut visit: impl FnMut(usize, usize),
) {
    for j in 0..dofs.len {
        visit(j, j);
    }
    for &(a, b) in links {
        let (ga, gb) = (dofs.grain(a), dofs.grain(b));
        let d = [ga, ga + 1, gb, gb + 1];
        for c in d {
            d.iter().for_each(|&r| visit(c, r));
        }
    }
    for p in pairs {
        let (d, len) = pair_dofs(dofs, p);
        for &c in &d[..len] {
            d[..len].iter().for_each(|&r| visit(c, r));
        }
    }
    for &(row, col) in couplings {
        visit(col, row);
        visit(row, col);
    }
}

/// Sort `rows` and move its distinct values to its front, in order: how many there are.
fn sort_distinct(rows: &mut [u32]) -> usize {
    rows.sort_unstable();
    let mut k = 0;
    for i in 0..rows.len() {
        if k == 0 || rows[i] != rows[k - 1] {
            rows[k] = rows[i];
            k += 1;
        }
    }
    k
}

impl Pattern {
    /// The pattern of every friend pair's block, every diagonal entry, and the coupling of a
    /// stress-controlled wall to the walls that set its loaded length.
    pub fn build(
        friends: &FriendSet,
        dofs: &DofMap,
        walls: &WallSet,
        links: &[(usize, usize)],
    ) -> Pattern {
        let n = dofs.len;
        let mut wanted_couplings = Vec::new();
        for (w, wall) in walls.walls.iter().enumerate() {
            let (Some(row), None) = (dofs.wall[w], wall.length) else {
                continue;
            };
            if let Some((a, b)) = walls.span_walls(w) {
                for col in [dofs.wall[a], dofs.wall[b]].into_iter().flatten() {
                    wanted_couplings.push((row, col));
                }
            }
        }
        // Each column's rows, repeats included, in one vector of 32-bit indices: counted
        // first, then placed. (A vector for each column held twice the bytes or more, and
        // with the pairs' maps was most of a million-grain run's peak, where it made its
        // lists anew: docs/performance.md, "Memory by part, from 10^3 to 10^6 grains".)
        let pairs = &friends.pairs;
        let mut count = vec![0usize; n];
        each_entry(dofs, links, pairs, &wanted_couplings, |col, _| {
            count[col] += 1
        });
        // Placed from each column's end back: `next[c]` ends at the column's start.
        let mut next: Vec<usize> = count
            .iter()
            .scan(0, |end, c| {
                *end += c;
                Some(*end)
            })
            .collect();
        let mut rows = vec![0u32; next.last().copied().unwrap_or(0)];
        each_entry(dofs, links, pairs, &wanted_couplings, |col, row| {
            next[col] -= 1;
            rows[next[col]] = value_index(row);
        });
        let mut columns = Vec::with_capacity(n);
        let mut rest = rows.as_mut_slice();
        for &c in &count {
            let (column, after) = std::mem::take(&mut rest).split_at_mut(c);
            columns.push(column);
            rest = after;
        }
        let mut distinct = Vec::with_capacity(n);
        parallel::map_mut_into(&mut columns, &mut distinct, |column| sort_distinct(column));
        drop(columns);
        // Each column's distinct rows moved down to where the last one's end, in the same
        // vector: a copy would hold the pattern's rows twice at once.
        let mut col_ptr = Vec::with_capacity(n + 1);
        col_ptr.push(0);
        let (mut from, mut to) = (0, 0);
        for (&c, &k) in count.iter().zip(&distinct) {
            rows.copy_within(from..from + k, to);
            (from, to) = (from + c, to + k);
            col_ptr.push(value_index(to));
        }
        rows.truncate(to);
        rows.shrink_to_fit();
        let row_idx = rows;
        let slot = |row: usize, col: usize| {
            let range = col_ptr[col] as usize..col_ptr[col + 1] as usize;
            range.start
                + row_idx[range]
                    .binary_search(&value_index(row))
                    .expect("entry in pattern")
        };
        let mut start = Vec::with_capacity(pairs.len() + 1);
        start.push(0);
        for p in pairs {
            let (d, len) = pair_dofs(dofs, p);
            start.push(start[start.len() - 1] + len * runs(&d[..len]).1);
        }
        let mut slots = parallel::flat_map(pairs.len(), |p| {
            let (d, len) = pair_dofs(dofs, &pairs[p]);
            let (runs, count) = runs(&d[..len]);
            (0..len)
                .flat_map(move |c| (0..count).map(move |k| (d[runs[k].0], d[c])))
                .map(|(r, c)| value_index(slot(r, c)))
        });
        slots.shrink_to_fit();
        let diagonal = (0..n).map(|j| slot(j, j)).collect();
        let couplings = wanted_couplings
            .into_iter()
            .map(|(r, c)| (r, c, slot(r, c)))
            .collect();
        let symbolic = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
        Pattern {
            symbolic,
            slots,
            start,
            diagonal,
            couplings,
            chain_links: links.to_vec(),
        }
    }

    /// Value index of entry (`row`, `col`), if the pattern has it.
    pub fn slot(&self, row: usize, col: usize) -> Option<usize> {
        let start = self.symbolic.col_ptr()[col] as usize;
        let rows = self.symbolic.row_idx_of_col_raw(col);
        rows.binary_search(&value_index(row))
            .ok()
            .map(|k| start + k)
    }

    /// Whether the pattern has the centre blocks of grains `a` and `b` together.
    pub fn links(&self, dofs: &DofMap, a: usize, b: usize) -> bool {
        self.slot(dofs.grain(a), dofs.grain(b)).is_some()
    }

    /// Whether the pattern couples every pair of neighbours along `chains`.
    pub fn couples(&self, dofs: &DofMap, chains: &[Chain]) -> bool {
        chains
            .iter()
            .flat_map(Chain::links)
            .all(|(a, b)| self.links(dofs, a, b))
    }

    /// Bytes it holds: its structure (column pointers, rows, diagonal, couplings, chain
    /// links), and the value slots of each pair's block.
    pub fn heap_bytes(&self) -> (usize, usize) {
        let word = std::mem::size_of::<u32>();
        let structure = word * (self.symbolic.col_ptr().len() + self.symbolic.row_idx().len())
            + self.diagonal.heap_bytes()
            + self.couplings.heap_bytes()
            + self.chain_links.heap_bytes();
        (structure, self.slots.heap_bytes() + self.start.heap_bytes())
    }

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.symbolic.row_idx().len()
    }

    /// Value indices of the first row of each run of pair `p`'s reduced block, column by
    /// column.
    pub fn pair_slots(&self, p: usize) -> &[u32] {
        &self.slots[self.start[p]..self.start[p + 1]]
    }

    /// Add each contact's force to `residual` and its stiffness to `tangent` (this pattern's
    /// values), for contacts `0..pair_index.len()`: contact `i` is friend pair
    /// `pair_index[i]`, touches the unknowns `map(i)` and has the block `block(i, &map(i), _)`
    /// makes (its stiffness is read only when `tangent` is given, its second force only when
    /// `second` is, which it is added to as the force is to `residual`).
    /// The unknowns are split into one range per thread, rows of the residual and columns of
    /// the tangent, and each thread goes through all contacts in their order, adding the
    /// blocks of those that touch its range where they fall in it: no two threads write one
    /// entry, and every entry is summed in the contacts' order whatever the number of
    /// threads. A contact whose unknowns lie in two ranges has its block made in both.
    pub fn scatter(
        &self,
        pair_index: &[usize],
        map: impl Fn(usize) -> PairMap + Sync,
        block: impl Fn(usize, &PairMap, &mut LocalBlock) + Sync,
        residual: &mut [f64],
        second: Option<&mut [f64]>,
        tangent: Option<&mut [f64]>,
    ) {
        let col_ptr = |b: usize| self.symbolic.col_ptr()[b] as usize;
        let bounds = if parallel::worth_it(pair_index.len()) {
            // Shared by the entries of the tangent in each range, or by unknowns alone.
            match tangent {
                Some(_) => parallel::split(residual.len(), col_ptr),
                None => parallel::split(residual.len(), |b| b),
            }
        } else {
            vec![0, residual.len()]
        };
        let mut parts = Vec::with_capacity(bounds.len() - 1);
        let (mut rest, mut rest_second, mut rest_values) = (residual, second, tangent);
        for range in bounds.windows(2) {
            let (part, after) = std::mem::take(&mut rest).split_at_mut(range[1] - range[0]);
            rest = after;
            let second = rest_second.take().map(|v| {
                let (part, after) = v.split_at_mut(range[1] - range[0]);
                rest_second = Some(after);
                part
            });
            let values = rest_values.take().map(|v| {
                let (part, after) = v.split_at_mut(col_ptr(range[1]) - col_ptr(range[0]));
                rest_values = Some(after);
                part
            });
            parts.push((range[0]..range[1], part, second, values));
        }
        let add = |(range, residual, mut second, mut values): ScatterPart<'_>| {
            let offset = col_ptr(range.start);
            let mut local = LocalBlock::default();
            for (i, &p) in pair_index.iter().enumerate() {
                let map = map(i);
                let dofs = &map.dofs[..map.len];
                if !dofs.iter().any(|d| range.contains(d)) {
                    continue;
                }
                block(i, &map, &mut local);
                let slots = self.pair_slots(p);
                for (a, &row) in dofs.iter().enumerate() {
                    if range.contains(&row) {
                        residual[row - range.start] += local.force[a];
                        if let Some(second) = second.as_deref_mut() {
                            second[row - range.start] += local.second_force[a];
                        }
                    }
                }
                let Some(values) = values.as_deref_mut() else {
                    continue;
                };
                let (runs, count) = runs(dofs);
                for (b, firsts) in slots.chunks_exact(count).enumerate() {
                    if range.contains(&dofs[b]) {
                        for (&(first, end), &slot) in runs[..count].iter().zip(firsts) {
                            let slot = slot as usize - offset;
                            for (a, value) in (first..end).zip(&mut values[slot..]) {
                                *value += local.stiffness[a][b];
                            }
                        }
                    }
                }
            }
        };
        if parts.len() > 1 {
            parts.into_par_iter().for_each(add);
        } else {
            parts.into_iter().for_each(add);
        }
    }
}
