//! The solve with a supernodal `L L^T` factor, a loop of our own over its supernodes.

use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;
use faer::Index;

/// Solve `L L^T x = b` in place on the supernodal factor `l`, supernode by supernode: a
/// dense triangular solve of its diagonal block and a matrix-vector product with the rows
/// below it, scattered to (forward) or gathered from (backward) the rows of its pattern.
/// With one right-hand side this is bound by reading `L` once each way; faer's own solve
/// calls its dense kernels once per supernode, which costs more than the arithmetic where
/// supernodes are small (0.11 against 0.16 ms a solve on the 1,000-grain sand biaxial,
/// docs/minimise.md, "Per-iteration cost"). Sequential at every size. Backward, the
/// columns' products with the rows below are summed four columns at a time, each sum in the
/// order one column alone makes it (the same values to the last bit), so that the four sums
/// overlap instead of waiting on each other's additions.
pub(super) fn solve_llt<I: Index>(
    symbolic: &SymbolicSupernodalCholesky<I>,
    l: &[f64],
    x: &mut [f64],
    (below, dots): (&mut Vec<f64>, &mut Vec<f64>),
) {
    let (begin, end) = (symbolic.supernode_begin(), symbolic.supernode_end());
    let (row_ptr, val_ptr, rows) = (
        symbolic.col_ptr_for_row_idx(),
        symbolic.col_ptr_for_val(),
        symbolic.row_idx(),
    );
    // Supernode `s`: its columns `start..start + size`, its column-major block of `height`
    // rows (the diagonal block, then the rows of `pattern`).
    let block = |s: usize| {
        let (start, size) = (begin[s].zx(), end[s].zx() - begin[s].zx());
        let values = &l[val_ptr[s].zx()..val_ptr[s + 1].zx()];
        let height = values.len() / size;
        let pattern = &rows[row_ptr[s].zx()..row_ptr[s].zx() + height - size];
        (start, size, height, values, pattern)
    };
    for s in 0..symbolic.n_supernodes() {
        let (start, size, height, values, pattern) = block(s);
        below.clear();
        below.resize(pattern.len(), 0.0);
        for j in 0..size {
            let column = &values[j * height..(j + 1) * height];
            let xj = x[start + j] / column[j];
            x[start + j] = xj;
            for (xi, lij) in x[start + j + 1..start + size]
                .iter_mut()
                .zip(&column[j + 1..size])
            {
                *xi -= lij * xj;
            }
            for (b, lij) in below.iter_mut().zip(&column[size..]) {
                *b += lij * xj;
            }
        }
        for (&i, b) in pattern.iter().zip(below.iter()) {
            x[i.zx()] -= b;
        }
    }
    for s in (0..symbolic.n_supernodes()).rev() {
        let (start, size, height, values, pattern) = block(s);
        below.clear();
        below.extend(pattern.iter().map(|&i| x[i.zx()]));
        dots.clear();
        let below_of = |j: usize| &values[j * height + size..(j + 1) * height];
        let mut j = 0;
        while j + 4 <= size {
            // Started from -0.0, as `Iterator::sum` starts.
            let mut sums = [-0.0f64; 4];
            let columns = (
                below_of(j),
                below_of(j + 1),
                below_of(j + 2),
                below_of(j + 3),
            );
            let rows = columns
                .0
                .iter()
                .zip(columns.1)
                .zip(columns.2)
                .zip(columns.3);
            for ((((l0, l1), l2), l3), b) in rows.zip(below.iter()) {
                sums[0] += l0 * b;
                sums[1] += l1 * b;
                sums[2] += l2 * b;
                sums[3] += l3 * b;
            }
            dots.extend(sums);
            j += 4;
        }
        while j + 2 <= size {
            let mut sums = [-0.0f64; 2];
            for ((l0, l1), b) in below_of(j).iter().zip(below_of(j + 1)).zip(below.iter()) {
                sums[0] += l0 * b;
                sums[1] += l1 * b;
            }
            dots.extend(sums);
            j += 2;
        }
        if j < size {
            dots.push(
                below_of(j)
                    .iter()
                    .zip(below.iter())
                    .map(|(l, b)| l * b)
                    .sum(),
            );
        }
        for j in (0..size).rev() {
            let column = &values[j * height..(j + 1) * height];
            let mut sum = x[start + j];
            sum -= dots[j];
            sum -= column[j + 1..size]
                .iter()
                .zip(&x[start + j + 1..start + size])
                .map(|(lij, xi)| lij * xi)
                .sum::<f64>();
            x[start + j] = sum / column[j];
        }
    }
}
