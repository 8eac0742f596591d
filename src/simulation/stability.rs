//! The stability indicator: the negative pivots of an `L D L^T` of the symmetric tangent at a
//! converged state, with every displacement-controlled wall freed.

use super::equations::IncrementEquations;
use super::{LoadStep, Simulation};
use crate::assembly::{contact_block, BlockTangent, DofMap, LocalBlock};
use faer::sparse::SparseColMatRef;
use std::sync::Arc;

impl Simulation {
    /// The stability indicator at the converged `u` of `step`: the negative pivots of an
    /// `L D L^T` of the symmetric (elasto-plastic) tangent, unregularised, with every
    /// displacement-controlled wall freed and held by its reaction as a dead load. Freed,
    /// a wall adds the sample's stiffness against it (the slope of its load-displacement
    /// curve) to the count: a softening sample shows a negative pivot even where its walls
    /// are moved, as at the peak of a biaxial test.
    ///
    /// The freed walls' unknowns come last, after the minimisation's own: the pivots are
    /// then those of the tangent `K` in the minimisation's unknowns, factorised in its
    /// pattern and analysis, and those of the Schur complement `S = K_ff - K_fg K^-1 K_gf`
    /// of the freed walls `f` (a few), found with solves of that factor (Haynsworth's
    /// inertia additivity). No second pattern or analysis is made.
    ///
    /// The tangent is scaled to pivots of order one first (each row and column by
    /// `1 / sqrt(k u_i)`, `k` the mean diagonal stiffness, `u_i` the unit of the row: a
    /// congruence, so the count is the same), and pivots above `-PIVOT_THRESHOLD` count as
    /// zero: rattlers and free rotations leave the tangent singular, and round-off must not
    /// make them negative. `None` when turned off, or when the factorisation fails.
    ///
    /// Where every pivot of `K` is above the threshold (positive definite: no rattler, free
    /// rotation or softening), its factor is kept for the next minimisation's first step
    /// ([`crate::solver::LinearSolver::hold_as_tangent`]).
    pub(super) fn negative_pivots(&mut self, step: &LoadStep, u: &[f64]) -> Option<usize> {
        if !self.config.stability_indicator {
            return None;
        }
        // The unknowns with the freed walls' after the minimisation's own, glued grains
        // following their walls in this step.
        let mut freed = self.dofs.clone();
        for wall in &mut freed.wall {
            if wall.is_none() {
                *wall = Some(freed.len);
                freed.len += 1;
            }
        }
        freed.follow(&self.state.grains, &self.state.walls, &step.turn);
        // The Hessian's storage, free once the minimisation is done, holds the tangent.
        let pattern = Arc::clone(&self.pattern);
        let mut values = std::mem::take(&mut self.values);
        values.clear();
        values.resize(pattern.nnz(), 0.0);
        let mut residual = vec![0.0; self.dofs.len];
        let mut eq = self.equations(step);
        (eq.symmetric, eq.projected) = (true, false);
        let evaluated = eq.evaluate_at(u, &mut residual, Some(&mut values));
        let (columns, corner) = freed_wall_columns(&eq, &freed);
        let unit: Vec<f64> = (0..eq.dofs.len).map(|dof| eq.unit_stiffness(dof)).collect();
        let timers = eq.timers;
        self.add_timers(timers);
        drop(freed);
        let count = evaluated.ok().and_then(|_| {
            // The scale of the rows: the minimisation's unknowns, then the freed walls (unit 1).
            let diagonal = pattern
                .diagonal
                .iter()
                .zip(&unit)
                .map(|(&s, &u)| (values[s], u));
            let k = mean_stiffness(
                diagonal.chain(corner.iter().enumerate().map(|(f, row)| (row[f], 1.0))),
            );
            let scale: Vec<f64> = unit.iter().map(|u| 1.0 / (k * u).sqrt()).collect();
            let wall_scale = 1.0 / k.sqrt();
            scale_tangent(&pattern, &mut values, &scale);
            let matrix = SparseColMatRef::new(pattern.symbolic.as_ref(), &values);
            let in_grains = self
                .linear
                .negative_pivots(matrix, PIVOT_THRESHOLD, &mut self.stats)
                .ok()?;
            // S, scaled: `K_ff - K_fg X`, `X` from the solves of `K X = K_gf`, all at once.
            let (n, f) = (scale.len(), columns.len());
            let mut x = vec![0.0; n * f];
            for (x, column) in x.chunks_exact_mut(n).zip(&columns) {
                for &(row, value) in column {
                    x[row] += scale[row] * value * wall_scale;
                }
            }
            if f > 0 {
                self.linear
                    .solve_ldlt_in_place(&mut x, f, &mut self.stats)
                    .ok()?;
            }
            let schur: Vec<Vec<f64>> = (0..f)
                .map(|v| {
                    (0..f)
                        .map(|w| {
                            let x = &x[w * n..(w + 1) * n];
                            let product: f64 = columns[v]
                                .iter()
                                .map(|&(row, value)| scale[row] * value * wall_scale * x[row])
                                .sum();
                            corner[v][w] * wall_scale * wall_scale - product
                        })
                        .collect()
                })
                .collect();
            // Positive definite on the minimisation's unknowns, the factor is the next
            // minimisation's first Newton matrix.
            self.linear.hold_as_tangent(scale);
            Some(in_grains + dense_negative_pivots(schur, PIVOT_THRESHOLD))
        });
        self.values = values;
        count
    }
}

/// A freed wall's column of the tangent on the minimisation's rows: (row, value).
type WallColumn = Vec<(usize, f64)>;

/// The symmetric tangent's entries in the columns of the walls that `freed` makes unknowns
/// beyond `eq.dofs` (numbered from `eq.dofs.len` on), at the configuration of `eq`'s last
/// evaluation: for each such wall, its entries on the rows of `eq.dofs` (row, value; a row
/// may come more than once, to be summed), and the block among the freed walls. They come
/// from the contacts whose unknowns in `freed` reach a freed wall (the wall's own contacts
/// and those of grains glued to it); the walls' loads add nothing, a freed wall being held by
/// a dead load.
fn freed_wall_columns(
    eq: &IncrementEquations<'_>,
    freed: &DofMap,
) -> (Vec<WallColumn>, Vec<Vec<f64>>) {
    let n = eq.dofs.len;
    let f = freed.len - n;
    let (mut columns, mut corner) = (vec![Vec::new(); f], vec![vec![0.0; f]; f]);
    let exact = eq.lagged && !eq.consistent;
    let mut block = LocalBlock::default();
    for (i, c) in eq.contacts.iter().enumerate() {
        if c.response.is_zero() || freed.glues(c.pair) {
            continue;
        }
        let map = freed.pair_map(c.pair, eq.push_direction(c.pair, i));
        let dofs = &map.dofs[..map.len];
        if dofs.iter().all(|&d| d < n) {
            continue;
        }
        contact_block(
            &eq.kin[i],
            &c.response,
            &map,
            Some(BlockTangent::Symmetric),
            exact,
            &mut block,
        );
        for (b, &col) in dofs.iter().enumerate().filter(|(_, &col)| col >= n) {
            for (a, &row) in dofs.iter().enumerate() {
                let value = block.stiffness[a][b];
                if row < n {
                    columns[col - n].push((row, value));
                } else {
                    corner[row - n][col - n] += value;
                }
            }
        }
    }
    (columns, corner)
}

/// Pivots of the scaled tangent (of order one) above `-PIVOT_THRESHOLD` count as zero in the
/// stability indicator.
const PIVOT_THRESHOLD: f64 = 1e-8;

/// The mean of `K_ii / unit_i` over the rows that have stiffness, from each row's
/// `(K_ii, unit_i)`; 1 where none has.
fn mean_stiffness(diagonal: impl Iterator<Item = (f64, f64)>) -> f64 {
    let (mut sum, mut count) = (0.0, 0usize);
    for (k, unit) in diagonal.filter(|&(k, _)| k > 0.0) {
        sum += k / unit;
        count += 1;
    }
    if count > 0 {
        sum / count as f64
    } else {
        1.0
    }
}

/// Scale the tangent `values` in place to `S K S`, `S = diag(scale)`.
fn scale_tangent(pattern: &crate::assembly::Pattern, values: &mut [f64], scale: &[f64]) {
    let symbolic = pattern.symbolic.as_ref();
    for (col, &s_col) in scale.iter().enumerate() {
        let range = symbolic.col_ptr()[col] as usize..symbolic.col_ptr()[col + 1] as usize;
        for (v, &row) in values[range]
            .iter_mut()
            .zip(symbolic.row_idx_of_col_raw(col))
        {
            *v *= scale[row as usize] * s_col;
        }
    }
}

/// The pivots below `-threshold` of an `L D L^T` of the small dense symmetric `matrix`, in
/// its own order, a pivot within `threshold` of zero set to `+-threshold` as faer's sparse
/// `L D L^T` sets it.
fn dense_negative_pivots(mut matrix: Vec<Vec<f64>>, threshold: f64) -> usize {
    let n = matrix.len();
    let mut count = 0;
    for j in 0..n {
        let mut pivot = matrix[j][j];
        if pivot.abs() <= threshold {
            pivot = if pivot < 0.0 { -threshold } else { threshold };
        }
        count += usize::from(pivot < -threshold);
        // What is left below and right of the pivot: its Schur complement.
        let (upper, lower) = matrix.split_at_mut(j + 1);
        let pivot_row = &upper[j][j + 1..];
        for row in lower {
            let l = row[j] / pivot;
            for (v, p) in row[j + 1..].iter_mut().zip(pivot_row) {
                *v -= l * p;
            }
        }
    }
    count
}

#[cfg(test)]
mod tests {
    use super::dense_negative_pivots;

    #[test]
    fn dense_pivots_count_the_negative_eigenvalues() {
        // Eigenvalues 3, -1 (the matrix [[1, 2], [2, 1]]), then with a third row: 3, -1, -2.
        assert_eq!(
            dense_negative_pivots(vec![vec![1.0, 2.0], vec![2.0, 1.0]], 1e-8),
            1
        );
        let m = vec![
            vec![1.0, 2.0, 0.0],
            vec![2.0, 1.0, 0.0],
            vec![0.0, 0.0, -2.0],
        ];
        assert_eq!(dense_negative_pivots(m, 1e-8), 2);
        // Singular: eigenvalues 2 and 0, the zero not counted.
        assert_eq!(
            dense_negative_pivots(vec![vec![1.0, 1.0], vec![1.0, 1.0]], 1e-8),
            0
        );
        assert_eq!(dense_negative_pivots(Vec::new(), 1e-8), 0);
        // A zero first pivot (eigenvalues 1 and -1) is taken as small and positive.
        assert_eq!(
            dense_negative_pivots(vec![vec![0.0, 1.0], vec![1.0, 0.0]], 1e-8),
            1
        );
    }
}
