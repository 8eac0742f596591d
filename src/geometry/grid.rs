//! A cell grid over grain centres: with cells at least as wide as the largest distance asked
//! about, the grains near a point are those in the 3x3 cells around it ([`CellGrid::near`]);
//! with narrower cells, those in the cells a square around it covers ([`CellGrid::within`]).

/// Grain indices sorted into square cells (a counting sort: `start[k]..start[k + 1]` indexes
/// `members` for cell `k`).
#[derive(Debug, Clone)]
pub struct CellGrid {
    origin: [f64; 2],
    cell: f64,
    cols: usize,
    rows: usize,
    start: Vec<usize>,
    members: Vec<usize>,
}

/// Cells along a side at most, less one: 2^16 in all.
const MAX_CELLS_ALONG: f64 = 65_535.0;

impl CellGrid {
    /// A grid of cells at least `cell` wide over the given centres; wider where the centres
    /// are spread so far (grains flung apart by a run gone wrong) that the cells would not fit
    /// in memory.
    pub fn new(position: &[[f64; 2]], cell: f64) -> CellGrid {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in position {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        if position.is_empty() {
            (lo, hi) = ([0.0; 2], [0.0; 2]);
        }
        // At most 16 cells per grain beyond 2^24 (128 MB of cell starts).
        let most = 16.0 * position.len() as f64 + (1u64 << 24) as f64;
        // And at most 2^16 cells along each side, however thin the box.
        let cell = cell
            .max(((hi[0] - lo[0]) * (hi[1] - lo[1]) / most).sqrt())
            .max((hi[0] - lo[0]) / MAX_CELLS_ALONG)
            .max((hi[1] - lo[1]) / MAX_CELLS_ALONG);
        let count = |k: usize| ((hi[k] - lo[k]) / cell).floor() as usize + 1;
        let mut grid = CellGrid {
            origin: lo,
            cell,
            cols: count(0),
            rows: count(1),
            start: Vec::new(),
            members: vec![0; position.len()],
        };
        let mut start = vec![0usize; grid.cols * grid.rows + 1];
        for p in position {
            start[grid.index(*p) + 1] += 1;
        }
        for k in 0..grid.cols * grid.rows {
            start[k + 1] += start[k];
        }
        let mut fill = start.clone();
        for (i, p) in position.iter().enumerate() {
            let k = grid.index(*p);
            grid.members[fill[k]] = i;
            fill[k] += 1;
        }
        grid.start = start;
        grid
    }

    /// Column and row of the cell holding `p`, clamped to the grid.
    fn cell_of(&self, p: [f64; 2]) -> (usize, usize) {
        let at = |k: usize, n: usize| {
            (((p[k] - self.origin[k]) / self.cell).floor().max(0.0) as usize).min(n - 1)
        };
        (at(0, self.cols), at(1, self.rows))
    }

    fn index(&self, p: [f64; 2]) -> usize {
        let (c, r) = self.cell_of(p);
        r * self.cols + c
    }

    /// The grains in the 3x3 cells around `p`: every grain within one cell width of it, and
    /// some further ones.
    pub fn near(&self, p: [f64; 2]) -> impl Iterator<Item = usize> + '_ {
        let (c, r) = self.cell_of(p);
        self.block(
            c.saturating_sub(1),
            (c + 1).min(self.cols - 1),
            r.saturating_sub(1)..=(r + 1).min(self.rows - 1),
        )
    }

    /// The grains in the cells that the square of half-width `distance` about `p` covers:
    /// every grain whose centre is within `distance` of `p` along both axes, and some more.
    pub fn within(&self, p: [f64; 2], distance: f64) -> impl Iterator<Item = usize> + '_ {
        let (c0, r0) = self.cell_of([p[0] - distance, p[1] - distance]);
        let (c1, r1) = self.cell_of([p[0] + distance, p[1] + distance]);
        self.block(c0, c1, r0..=r1)
    }

    /// The grains in the cells of columns `c0..=c1` in `rows`, row by row: one slice of
    /// `members` a row.
    fn block(
        &self,
        c0: usize,
        c1: usize,
        rows: std::ops::RangeInclusive<usize>,
    ) -> impl Iterator<Item = usize> + '_ {
        rows.flat_map(move |r| {
            let k = r * self.cols;
            self.members[self.start[k + c0]..self.start[k + c1 + 1]]
                .iter()
                .copied()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every grain on one line, one far out along it: the box has no area, so only the
    /// bound along each side keeps the cells few; the near grains are still found.
    #[test]
    fn a_grain_far_along_a_line_only_widens_the_cells() {
        let position = [[0.0, 0.0], [2e-4, 0.0], [1e300, 0.0]];
        let grid = CellGrid::new(&position, 3e-4);
        assert!(grid.cols * grid.rows <= 1 << 16);
        let near: Vec<usize> = grid.near([0.0, 0.0]).collect();
        assert!(near.contains(&0) && near.contains(&1), "{near:?}");
    }
}
