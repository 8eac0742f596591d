//! The sparse direct solver's unit tests, and the grids other modules' tests factorise.

use super::*;
use faer::sparse::{SparseColMat, Triplet};
use faer::{Conj, MatMut};

/// The Dirichlet Laplacian of an `n` x `n` grid shifted by `-shift` (full storage), and
/// how many of its eigenvalues, `4 - 2 cos(i pi / (n + 1)) - 2 cos(j pi / (n + 1))`, are
/// below the shift.
pub(super) fn shifted_laplacian(n: usize, shift: f64) -> (SparseColMat<u32, f64>, usize) {
    let index = |i: usize, j: usize| (i * n + j) as u32;
    let mut entries = Vec::new();
    for i in 0..n {
        for j in 0..n {
            entries.push(Triplet::new(index(i, j), index(i, j), 4.0 - shift));
            if i + 1 < n {
                entries.push(Triplet::new(index(i, j), index(i + 1, j), -1.0));
                entries.push(Triplet::new(index(i + 1, j), index(i, j), -1.0));
            }
            if j + 1 < n {
                entries.push(Triplet::new(index(i, j), index(i, j + 1), -1.0));
                entries.push(Triplet::new(index(i, j + 1), index(i, j), -1.0));
            }
        }
    }
    let matrix = SparseColMat::try_new_from_triplets(n * n, n * n, &entries).unwrap();
    let mode = |k: usize| 2.0 - 2.0 * (k as f64 * std::f64::consts::PI / (n + 1) as f64).cos();
    let below = (1..=n)
        .flat_map(|i| (1..=n).map(move |j| mode(i) + mode(j)))
        .filter(|&lambda| lambda < shift)
        .count();
    (matrix, below)
}

#[test]
fn negative_pivots_count_the_negative_eigenvalues() {
    let mut stats = SolverStats::default();
    for (n, shift) in [(6, 0.0), (6, 1.3), (6, 5.1), (250, 0.1), (250, 4.4)] {
        let (matrix, below) = shifted_laplacian(n, shift);
        let mut solver = LinearSolver::new();
        solver
            .analyse(&matrix.symbolic().to_owned().unwrap(), &mut stats)
            .unwrap();
        let counted = solver
            .negative_pivots(matrix.as_ref(), 1e-10, &mut stats)
            .unwrap();
        assert_eq!(counted, below, "grid {n} x {n} shifted by {shift}");
        assert!(below > 0 || shift == 0.0);
        // The indefinite factor solves as well as it counts.
        let b: Vec<f64> = (0..n * n).map(|i| (i % 7) as f64 - 3.0).collect();
        let mut x = b.clone();
        solver.solve_ldlt_in_place(&mut x, 1, &mut stats).unwrap();
        let mut ax = vec![0.0; n * n];
        for (j, xj) in x.iter().enumerate() {
            for (i, v) in matrix.row_idx_of_col(j).zip(matrix.val_of_col(j)) {
                ax[i] += v * xj;
            }
        }
        let misfit = ax
            .iter()
            .zip(&b)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(
            misfit < 1e-9,
            "grid {n} x {n} shifted by {shift}: {misfit:e}"
        );
        // Two right-hand sides at once, each as it is alone (to round-off).
        let mut two: Vec<f64> = b.iter().chain(b.iter().rev()).copied().collect();
        solver.solve_ldlt_in_place(&mut two, 2, &mut stats).unwrap();
        let mut reversed: Vec<f64> = b.iter().rev().copied().collect();
        solver
            .solve_ldlt_in_place(&mut reversed, 1, &mut stats)
            .unwrap();
        let alone = x.iter().chain(&reversed);
        let size = alone.clone().fold(0.0, |m: f64, v| m.max(v.abs()));
        let apart = two.iter().zip(alone).map(|(a, b)| (a - b).abs());
        let worst = apart.fold(0.0, f64::max);
        assert!(worst <= 1e-10 * size, "{n} {shift}: {worst:e} of {size:e}");
    }
    let mut solver = LinearSolver::new();
    let (matrix, _) = shifted_laplacian(6, 0.0);
    solver
        .analyse(&matrix.symbolic().to_owned().unwrap(), &mut stats)
        .unwrap();
    solver.factorize(matrix.as_ref(), &mut stats).unwrap();
    assert!(solver
        .solve_ldlt_in_place(&mut [0.0; 36], 1, &mut stats)
        .is_err());
}

#[test]
fn metis_order_solves_and_counts_as_amd_does() {
    let mut stats = SolverStats::default();
    for (n, shift) in [(30, 0.0), (30, 2.2)] {
        let (matrix, below) = shifted_laplacian(n, shift);
        let pattern = matrix.symbolic().to_owned().unwrap();
        let rhs: Vec<f64> = (0..n * n).map(|i| (i % 7) as f64 - 3.0).collect();
        let mut solutions = Vec::new();
        for ordering in [FillOrdering::Amd, FillOrdering::Metis] {
            let mut solver = LinearSolver::in_order(ordering);
            solver.analyse(&pattern, &mut stats).unwrap();
            let counted = solver
                .negative_pivots(matrix.as_ref(), 1e-10, &mut stats)
                .unwrap();
            assert_eq!(counted, below, "{ordering:?}, shifted by {shift}");
            if shift == 0.0 {
                solver.factorize(matrix.as_ref(), &mut stats).unwrap();
                let mut x = rhs.clone();
                solver.solve_in_place(&mut x, &mut stats);
                solutions.push(x);
            }
        }
        if let [amd, metis] = solutions.as_slice() {
            let scale = amd.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            for (a, m) in amd.iter().zip(metis) {
                assert!((a - m).abs() <= 1e-12 * scale, "{a} against {m}");
            }
        }
    }
}

#[test]
fn the_cholesky_and_its_solve_are_faers_own_in_supernodes() {
    let mut stats = SolverStats::default();
    for n in [6, 250] {
        let (mut matrix, _) = shifted_laplacian(n, 0.0);
        let pattern = matrix.symbolic().to_owned().unwrap();
        let diagonal: Vec<usize> = (0..n * n)
            .map(|j| {
                let start = pattern.col_ptr()[j] as usize;
                start
                    + (pattern.row_idx_of_col_raw(j))
                        .binary_search(&(j as u32))
                        .unwrap()
            })
            .collect();
        let shift: Vec<f64> = (0..n * n).map(|j| 0.1 * (j % 3) as f64).collect();
        let rhs: Vec<f64> = (0..n * n).map(|i| (i % 7) as f64 - 3.0).collect();
        let mut solver = LinearSolver::new();
        solver.analyse(&pattern, &mut stats).unwrap();
        solver
            .factorize_shifted(matrix.as_ref(), &shift, &mut stats)
            .unwrap();
        let mut ours = rhs.clone();
        solver.solve_in_place(&mut ours, &mut stats);

        for (&slot, add) in diagonal.iter().zip(&shift) {
            matrix.val_mut()[slot] += add;
        }
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        };
        let faer = factorize_symbolic_cholesky(
            pattern.as_ref(),
            Side::Lower,
            SymmetricOrdering::Amd,
            params,
        )
        .unwrap();
        let mut values = vec![0.0; faer.len_val()];
        let mut scratch = MemBuffer::new(StackReq::any_of(&[
            faer.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
            faer.solve_in_place_scratch::<f64>(1, Par::Seq),
        ]));
        let factor = faer
            .factorize_numeric_llt(
                &mut values,
                matrix.as_ref(),
                Side::Lower,
                LltRegularization::default(),
                Par::Seq,
                MemStack::new(&mut scratch),
                Default::default(),
            )
            .unwrap();
        let mut theirs = rhs.clone();
        factor.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(&mut theirs, n * n, 1),
            Par::Seq,
            MemStack::new(&mut scratch),
        );
        // The factors are faer's; the solve sums in its own order.
        let scale = theirs.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (a, b) in ours.iter().zip(&theirs) {
            assert!(
                (a - b).abs() <= 1e-13 * scale,
                "grid {n} x {n}: {a} against {b}"
            );
        }
    }
}

#[test]
fn the_analysis_in_32_bits_factorises_and_solves_as_in_the_machines_word() {
    let (matrix, _) = shifted_laplacian(40, 0.0);
    let pattern = matrix.symbolic().to_owned().unwrap();
    let shift: Vec<f64> = (0..1600).map(|j| 0.1 * (j % 3) as f64).collect();
    let rhs: Vec<f64> = (0..1600).map(|i| (i % 7) as f64 - 3.0).collect();
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let dissected = nested_dissection(&pattern).unwrap();
    for ordering in [None, Some(&dissected)] {
        let mut narrow = Cholesky::analyse(&pattern, ordering).unwrap().unwrap();
        let mut wide = Cholesky::analyse(&widened(&pattern), ordering)
            .unwrap()
            .unwrap();
        let mut scratch = MemBuffer::new(narrow.scratch(Par::Seq));
        let (mut factor, mut wide_factor) = (Vec::new(), Vec::new());
        narrow.gather(matrix.val(), &shift);
        narrow
            .factorize_llt(&mut factor, (Par::Seq, &mut scratch))
            .unwrap();
        let mut scratch = MemBuffer::new(wide.scratch(Par::Seq));
        wide.gather(matrix.val(), &shift);
        wide.factorize_llt(&mut wide_factor, (Par::Seq, &mut scratch))
            .unwrap();
        assert_eq!(
            bits(&factor),
            bits(&wide_factor),
            "METIS: {}",
            ordering.is_some()
        );
        let (mut x, mut y) = (rhs.clone(), rhs.clone());
        narrow.solve(&factor, &mut x);
        wide.solve(&wide_factor, &mut y);
        assert_eq!(bits(&x), bits(&y), "METIS: {}", ordering.is_some());
        assert!(x.iter().all(|v| v.is_finite()));
    }
}

#[test]
fn a_large_system_is_solved_bit_for_bit_on_one_and_two_threads() {
    let n = 320; // 102,400 unknowns, above PARALLEL_UNKNOWNS
    let (matrix, _) = shifted_laplacian(n, 0.0);
    let pattern = matrix.symbolic().to_owned().unwrap();
    let solve = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut stats = SolverStats::default();
            let mut solver = LinearSolver::new();
            solver.analyse(&pattern, &mut stats).unwrap();
            assert_eq!(matches!(solver.par, Par::Rayon(_)), threads > 1);
            solver.factorize(matrix.as_ref(), &mut stats).unwrap();
            let mut x: Vec<f64> = (0..n * n).map(|i| (i % 7) as f64 - 3.0).collect();
            solver.solve_in_place(&mut x, &mut stats);
            x
        })
    };
    let (one, two) = (solve(1), solve(2));
    assert!(one.iter().all(|x| x.is_finite()));
    let differ = one
        .iter()
        .zip(&two)
        .filter(|(a, b)| a.to_bits() != b.to_bits());
    assert_eq!(differ.count(), 0);
}

#[test]
fn a_positive_definite_ldlt_is_kept_as_the_tangent_it_factorises() {
    // `S K S` factorised, kept with `S`: the solve is `K^-1`. An indefinite or singular
    // `K` is not kept.
    let mut stats = SolverStats::default();
    let n = 12;
    let (k, _) = shifted_laplacian(n, 0.0);
    let scale: Vec<f64> = (0..n * n).map(|i| 0.5 + (i % 5) as f64 * 0.3).collect();
    let mut sks = k.clone();
    for j in 0..n * n {
        let rows: Vec<usize> = sks.row_idx_of_col(j).collect();
        for (v, i) in sks.val_of_col_mut(j).iter_mut().zip(rows) {
            *v *= scale[i] * scale[j];
        }
    }
    let mut solver = LinearSolver::new();
    solver
        .analyse(&k.symbolic().to_owned().unwrap(), &mut stats)
        .unwrap();
    assert_eq!(
        solver.negative_pivots(sks.as_ref(), 1e-10, &mut stats),
        Ok(0)
    );
    assert!(solver.hold_as_tangent(scale.clone()) && solver.holds_tangent());
    let b: Vec<f64> = (0..n * n).map(|i| (i % 7) as f64 - 3.0).collect();
    let mut x = b.clone();
    solver.solve_in_place(&mut x, &mut stats);
    let mut kx = vec![0.0; n * n];
    for (j, xj) in x.iter().enumerate() {
        for (i, v) in k.row_idx_of_col(j).zip(k.val_of_col(j)) {
            kx[i] += v * xj;
        }
    }
    let misfit = kx.iter().zip(&b).map(|(a, b)| (a - b).abs());
    assert!(misfit.fold(0.0, f64::max) < 1e-10);
    // A factorisation replaces it.
    solver.factorize(k.as_ref(), &mut stats).unwrap();
    assert!(!solver.holds_tangent());
    // Indefinite, and singular (the Laplacian's constant mode, its diagonal lowered to the
    // row sums'), neither is kept.
    let (indefinite, below) = shifted_laplacian(n, 1.0);
    assert!(below > 0);
    solver
        .negative_pivots(indefinite.as_ref(), 1e-10, &mut stats)
        .unwrap();
    assert!(!solver.hold_as_tangent(scale.clone()));
    let mut singular = k.clone();
    for j in 0..n * n {
        let sum: f64 = singular.val_of_col(j).iter().sum();
        let rows: Vec<usize> = singular.row_idx_of_col(j).collect();
        for (v, i) in singular.val_of_col_mut(j).iter_mut().zip(rows) {
            if i == j {
                *v -= sum;
            }
        }
    }
    assert_eq!(
        solver.negative_pivots(singular.as_ref(), 1e-10, &mut stats),
        Ok(0)
    );
    assert!(!solver.hold_as_tangent(scale));
}
