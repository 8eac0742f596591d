//! GMRES, right-preconditioned by a factorisation of a nearby matrix: the minimisation's
//! semi-smooth steps solve with the unsymmetric consistent tangent, preconditioned by the
//! last Cholesky of the symmetric Hessian made in the same minimisation.

use crate::memory::HeapBytes;
use faer::sparse::SymbolicSparseColMat;

/// The values of a matrix of a symmetric pattern (both triangles stored, each column's rows
/// sorted), by columns, put in the order by rows in place: the layout [`multiply_by_rows`]
/// reads. On such a pattern an entry's place by rows is its transpose's place by columns:
/// walking the columns in order, row `i`'s places by rows come in order too, so a cursor
/// per row (`next`, kept by the caller) finds each entry's transpose, and the values are
/// swapped pair by pair. Nothing of the size of the pattern is kept for it.
pub fn to_rows_in_place(
    pattern: &SymbolicSparseColMat<u32>,
    values: &mut [f64],
    next: &mut Vec<u32>,
) {
    let (col_ptr, row_idx) = (pattern.col_ptr(), pattern.row_idx());
    next.clear();
    next.extend_from_slice(&col_ptr[..pattern.ncols()]);
    for j in 0..pattern.ncols() {
        for p in col_ptr[j] as usize..col_ptr[j + 1] as usize {
            let i = row_idx[p] as usize;
            let k = next[i] as usize;
            debug_assert_eq!(row_idx[k] as usize, j, "a symmetric pattern");
            next[i] += 1;
            if p > k {
                values.swap(k, p);
            }
        }
    }
}

/// Rows [`multiply_by_rows`] sums side by side.
const ROWS_AT_ONCE: usize = 4;

/// `y = A x` for `A` of a symmetric pattern with its values `by_rows` in the order by rows
/// ([`to_rows_in_place`]). Each entry of the product is one running sum over its row, taken in
/// the order of the columns as a product by columns adds them into it (the same values to the
/// last bit), instead of every column scattered into the product. A row's sum is a chain of
/// dependent additions, so four rows (`ROWS_AT_ONCE`) are summed side by side, each in its own
/// order: their chains overlap, and every sum is the same.
pub fn multiply_by_rows(
    pattern: &SymbolicSparseColMat<u32>,
    by_rows: &[f64],
    x: &[f64],
    y: &mut [f64],
) {
    let (row_ptr, columns) = (pattern.col_ptr(), pattern.row_idx());
    let term = |k: usize| by_rows[k] * x[columns[k] as usize];
    let whole = y.len() / ROWS_AT_ONCE * ROWS_AT_ONCE;
    let (blocks, rest) = y.split_at_mut(whole);
    for (block, y) in blocks.chunks_exact_mut(ROWS_AT_ONCE).enumerate() {
        let first = block * ROWS_AT_ONCE;
        let start: [usize; ROWS_AT_ONCE] = std::array::from_fn(|r| row_ptr[first + r] as usize);
        let end: [usize; ROWS_AT_ONCE] = std::array::from_fn(|r| row_ptr[first + r + 1] as usize);
        let common = (0..ROWS_AT_ONCE)
            .map(|r| end[r] - start[r])
            .min()
            .unwrap_or(0);
        // From +0.0, as the product by columns starts: a zero product added to a sum never
        // changes it then, so the columns it skips where `x` is zero do not count.
        let mut sum = [0.0; ROWS_AT_ONCE];
        let values: [&[f64]; ROWS_AT_ONCE] =
            std::array::from_fn(|r| &by_rows[start[r]..start[r] + common]);
        let cols: [&[u32]; ROWS_AT_ONCE] =
            std::array::from_fn(|r| &columns[start[r]..start[r] + common]);
        for k in 0..common {
            for r in 0..ROWS_AT_ONCE {
                sum[r] += values[r][k] * x[cols[r][k] as usize];
            }
        }
        for r in 0..ROWS_AT_ONCE {
            y[r] = (start[r] + common..end[r]).fold(sum[r], |sum, k| sum + term(k));
        }
    }
    for (i, yi) in (whole..).zip(rest) {
        let range = row_ptr[i] as usize..row_ptr[i + 1] as usize;
        *yi = range.fold(0.0, |sum, k| sum + term(k));
    }
}

/// GMRES's buffers (the Arnoldi basis, the Hessenberg matrix by columns, its Givens
/// rotations and the work vectors), kept from solve to solve so that a solve allocates
/// nothing once they have grown to its size.
#[derive(Debug, Default)]
pub struct Gmres {
    basis: Vec<Vec<f64>>,
    hessenberg: Vec<Vec<f64>>,
    rotations: Vec<(f64, f64)>,
    g: Vec<f64>,
    y: Vec<f64>,
    z: Vec<f64>,
    w: Vec<f64>,
}

impl Gmres {
    /// Bytes its buffers hold.
    pub fn heap_bytes(&self) -> usize {
        let nested = self.basis.iter().chain(&self.hessenberg);
        let flat = [&self.g, &self.y, &self.z, &self.w];
        nested.chain(flat).map(|v| v.heap_bytes()).sum::<usize>()
            + self.basis.heap_bytes()
            + self.hessenberg.heap_bytes()
            + self.rotations.heap_bytes()
    }

    /// Solve `A x = b` by GMRES from `x = 0`, with `precondition` applying `M^-1` in place
    /// (right preconditioning, so the residual it measures is the true `|b - A x|`). Returns
    /// the iterations taken once `|b - A x| <= tolerance |b|`, or `None` after
    /// `max_iterations` without (then `x` is left as it was).
    pub fn solve(
        &mut self,
        apply: &mut dyn FnMut(&[f64], &mut [f64]),
        precondition: &mut dyn FnMut(&mut [f64]),
        b: &[f64],
        x: &mut [f64],
        tolerance: f64,
        max_iterations: usize,
    ) -> Option<usize> {
        let n = b.len();
        let norm = |v: &[f64]| v.iter().map(|a| a * a).sum::<f64>().sqrt();
        let beta = norm(b);
        if beta == 0.0 {
            x.fill(0.0);
            return Some(0);
        }
        let Gmres {
            basis,
            hessenberg,
            rotations,
            g,
            y,
            z,
            w,
        } = self;
        // The basis vectors in use: `basis[..=j]` at step `j`; those beyond are kept for later.
        let vector = |basis: &mut Vec<Vec<f64>>, j: usize, from: &[f64], scale: f64| {
            if basis.len() == j {
                basis.push(Vec::with_capacity(n));
            }
            let v = &mut basis[j];
            v.clear();
            v.extend(from.iter().map(|a| a / scale));
        };
        vector(basis, 0, b, beta);
        rotations.clear();
        g.clear();
        g.push(beta);
        z.resize(n, 0.0);
        w.resize(n, 0.0);
        for j in 0..max_iterations {
            z.copy_from_slice(&basis[j]);
            precondition(z);
            apply(z, w);
            if hessenberg.len() == j {
                hessenberg.push(Vec::new());
            }
            let h = &mut hessenberg[j];
            h.clear();
            h.resize(j + 2, 0.0);
            for (i, v) in basis[..=j].iter().enumerate() {
                h[i] = w.iter().zip(v).map(|(a, b)| a * b).sum();
                w.iter_mut().zip(v).for_each(|(a, b)| *a -= h[i] * b);
            }
            h[j + 1] = norm(w);
            for (i, &(c, s)) in rotations.iter().enumerate() {
                let (a, b) = (h[i], h[i + 1]);
                h[i] = c * a + s * b;
                h[i + 1] = -s * a + c * b;
            }
            let r = h[j].hypot(h[j + 1]);
            if !r.is_finite() || r == 0.0 {
                return None;
            }
            let (c, s) = (h[j] / r, h[j + 1] / r);
            rotations.push((c, s));
            h[j] = r;
            g.push(-s * g[j]);
            g[j] *= c;
            let next = h[j + 1];
            h.truncate(j + 1);
            if g[j + 1].abs() <= tolerance * beta {
                // y from the triangle, then x = M^-1 (V y).
                let k = j + 1;
                y.clear();
                y.resize(k, 0.0);
                for i in (0..k).rev() {
                    let sum: f64 = (i + 1..k).map(|l| hessenberg[l][i] * y[l]).sum();
                    y[i] = (g[i] - sum) / hessenberg[i][i];
                }
                x.fill(0.0);
                for (v, yi) in basis.iter().zip(y.iter()) {
                    x.iter_mut().zip(v).for_each(|(a, b)| *a += yi * b);
                }
                precondition(x);
                return x.iter().all(|v| v.is_finite()).then_some(k);
            }
            if next == 0.0 {
                return None;
            }
            vector(basis, j + 1, w, next);
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::sparse::{SparseColMat, Triplet};

    /// A tridiagonal, unsymmetric, diagonally dominant matrix of size `n`.
    fn matrix(n: usize) -> SparseColMat<u32, f64> {
        let mut entries = Vec::new();
        for i in 0..n as u32 {
            entries.push(Triplet::new(i, i, 4.0 + (i % 3) as f64));
            if i + 1 < n as u32 {
                entries.push(Triplet::new(i, i + 1, -1.0));
                entries.push(Triplet::new(i + 1, i, -1.5));
            }
        }
        SparseColMat::try_new_from_triplets(n, n, &entries).unwrap()
    }

    #[test]
    fn the_product_by_rows_is_the_product_by_columns_to_the_last_bit() {
        // A symmetric pattern of couplings between unknowns near each other, unsymmetric
        // values of mixed signs and magnitudes, and a vector with zeros and negative zeros.
        let n = 300;
        let mut entries = Vec::new();
        let value = |k: usize| ((k as f64) * 0.731).sin() * 10f64.powi((k % 7) as i32 - 3);
        for i in 0..n {
            for d in [0, 1, 3, 17] {
                if i + d < n && (d == 0 || (i * 7 + d) % 3 != 0) {
                    let (a, b) = (i as u32, (i + d) as u32);
                    entries.push(Triplet::new(a, b, value(entries.len())));
                    if d > 0 {
                        entries.push(Triplet::new(b, a, value(entries.len())));
                    }
                }
            }
        }
        let a = SparseColMat::<u32, f64>::try_new_from_triplets(n, n, &entries).unwrap();
        let pattern = a.symbolic().to_owned().unwrap();
        let x: Vec<f64> = (0..n)
            .map(|j| match j % 5 {
                0 => 0.0,
                1 => -0.0,
                _ => ((j as f64) * 1.37).cos(),
            })
            .collect();
        let mut by_columns = vec![0.0; n];
        for (j, &xj) in x.iter().enumerate() {
            if xj != 0.0 {
                for p in pattern.col_ptr()[j] as usize..pattern.col_ptr()[j + 1] as usize {
                    by_columns[pattern.row_idx()[p] as usize] += a.val()[p] * xj;
                }
            }
        }
        // The values by rows are those of the transpose by columns.
        let by_rows = a.transpose().to_col_major().unwrap().val().to_vec();
        let mut in_place = a.val().to_vec();
        to_rows_in_place(&pattern, &mut in_place, &mut Vec::new());
        assert_eq!(in_place, by_rows);
        let mut y = vec![f64::NAN; n];
        multiply_by_rows(&pattern, &by_rows, &x, &mut y);
        for (p, q) in y.iter().zip(&by_columns) {
            assert_eq!(p.to_bits(), q.to_bits(), "{p} against {q}");
        }
    }

    #[test]
    fn gmres_solves_an_unsymmetric_system_preconditioned_by_its_diagonal() {
        let n = 200;
        let a = matrix(n);
        let pattern = a.symbolic().to_owned().unwrap();
        let mut by_rows = a.val().to_vec();
        to_rows_in_place(&pattern, &mut by_rows, &mut Vec::new());
        let b: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
        let diagonal: Vec<f64> = (0..n).map(|i| 4.0 + (i % 3) as f64).collect();
        let mut x = vec![0.0; n];
        let mut gmres = Gmres::default();
        let iterations = gmres
            .solve(
                &mut |v, out| multiply_by_rows(&pattern, &by_rows, v, out),
                &mut |v| v.iter_mut().zip(&diagonal).for_each(|(a, d)| *a /= d),
                &b,
                &mut x,
                1e-10,
                100,
            )
            .expect("converges");
        assert!(iterations > 1 && iterations < 60, "{iterations} iterations");
        let mut ax = vec![0.0; n];
        multiply_by_rows(&pattern, &by_rows, &x, &mut ax);
        let error = ax
            .iter()
            .zip(&b)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0, f64::max);
        assert!(error < 1e-9, "residual {error}");
        // An exact preconditioner needs one iteration; too few iterations give None.
        let mut few = vec![0.0; n];
        let none = gmres.solve(
            &mut |v, out| multiply_by_rows(&pattern, &by_rows, v, out),
            &mut |_| {},
            &b,
            &mut few,
            1e-10,
            3,
        );
        assert!(none.is_none() && few.iter().all(|v| *v == 0.0));
    }
}
