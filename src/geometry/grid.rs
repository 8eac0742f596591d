//! A cell grid over grain centres: cells at least as wide as the largest distance asked
//! about, so the grains near a point are those in the 3x3 cells around it.

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
        let cell = cell.max(((hi[0] - lo[0]) * (hi[1] - lo[1]) / most).sqrt());
        let count = |k: usize| (((hi[k] - lo[k]) / cell).floor() as usize + 1).min(1 << 16);
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
        let rows = r.saturating_sub(1)..=(r + 1).min(self.rows - 1);
        rows.flat_map(move |rr| {
            let k = rr * self.cols;
            let (c0, c1) = (c.saturating_sub(1), (c + 1).min(self.cols - 1));
            self.members[self.start[k + c0]..self.start[k + c1 + 1]]
                .iter()
                .copied()
        })
    }
}
