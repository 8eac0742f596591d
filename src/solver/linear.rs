//! The sparse direct solver: faer's supernodal Cholesky of the symmetric Hessian. The symbolic
//! factorisation is made once per pattern and reused across iterations, passes and
//! increments; the numeric storage and the scratch memory are kept too (stack-notes.md: a
//! fresh allocation per factorisation costs 1.15-1.5x).
//!
//! Contract: [`LinearSolver::analyse`] is called whenever the pattern changes (friends lists
//! rebuilt); [`LinearSolver::factorize`] whenever values change; [`LinearSolver::solve_in_place`]
//! uses the last successful factorisation.
//!
//! [`LinearSolver::negative_pivots`] counts the negative pivots of an `L D L^T` of a symmetric
//! matrix in the Cholesky pattern, into storage of its own, so the `L L^T` it solves with
//! stays valid: by Sylvester's law of inertia, the number of negative eigenvalues.

use super::stats::{secs, SolverStats};
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::ldlt::factor::LdltRegularization;
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, simplicial::SimplicialLdltRef, supernodal::SupernodalLdltRef,
    LltRef, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{Conj, MatMut, Par, Side};
use std::time::Instant;

/// The factorisation could not be made (a non-positive pivot, or a singular matrix).
#[derive(Debug, Clone, PartialEq)]
pub struct NotFactorizable(pub String);

/// Unknowns from which faer's Cholesky runs on the pool's threads. On two free cores,
/// 300,000 unknowns factorise 1.25 times as fast on two threads, 30,000 no faster
/// (docs/performance.md, Threads). Its factors are the same bit for bit on any number of
/// threads.
pub const PARALLEL_UNKNOWNS: usize = 100_000;

/// The symbolic factorisation, the values of `L L^T`, and those of the `L D L^T` of the
/// stability indicator (allocated when first needed).
struct Analysed {
    symbolic: SymbolicCholesky<usize>,
    llt: Vec<f64>,
    ldlt: Vec<f64>,
}

/// A sparse Cholesky solver with its symbolic factorisation and buffers kept.
pub struct LinearSolver {
    par: Par,
    analysed: Option<Analysed>,
    scratch: MemBuffer,
    factorized: bool,
}

impl Default for LinearSolver {
    fn default() -> Self {
        Self::new()
    }
}

impl LinearSolver {
    /// A solver with nothing analysed yet; [`LinearSolver::analyse`] chooses its threads.
    pub fn new() -> Self {
        LinearSolver {
            par: Par::Seq,
            analysed: None,
            scratch: MemBuffer::new(StackReq::EMPTY),
            factorized: false,
        }
    }

    /// Symbolic factorisation of a new pattern (fill-reducing ordering, elimination tree,
    /// supernodes), with numeric storage and scratch sized for it, on the pool's threads from
    /// [`PARALLEL_UNKNOWNS`] unknowns on.
    pub fn analyse(
        &mut self,
        pattern: &SymbolicSparseColMat<usize>,
        stats: &mut SolverStats,
    ) -> Result<(), NotFactorizable> {
        let start = Instant::now();
        let threads = rayon::current_num_threads();
        self.par = if threads > 1 && pattern.nrows() >= PARALLEL_UNKNOWNS {
            Par::rayon(threads)
        } else {
            Par::Seq
        };
        let symbolic = factorize_symbolic_cholesky(
            pattern.as_ref(),
            Side::Lower,
            SymmetricOrdering::Amd,
            Default::default(),
        )
        .map_err(|e| NotFactorizable(format!("{e:?}")))?;
        self.scratch = MemBuffer::new(StackReq::any_of(&[
            symbolic.factorize_numeric_llt_scratch::<f64>(self.par, Default::default()),
            symbolic.factorize_numeric_ldlt_scratch::<f64>(self.par, Default::default()),
            symbolic.solve_in_place_scratch::<f64>(1, self.par),
        ]));
        self.analysed = Some(Analysed {
            llt: vec![0.0; symbolic.len_val()],
            ldlt: Vec::new(),
            symbolic,
        });
        self.factorized = false;
        stats.counters.symbolic_factorisations += 1;
        stats.timers.symbolic += secs(start);
        Ok(())
    }

    /// Numeric factorisation of `matrix` (which has the analysed pattern).
    pub fn factorize(
        &mut self,
        matrix: SparseColMatRef<'_, usize, f64>,
        stats: &mut SolverStats,
    ) -> Result<(), NotFactorizable> {
        let start = Instant::now();
        self.factorized = false;
        let Some(a) = &mut self.analysed else {
            return Err(NotFactorizable("no symbolic factorisation".into()));
        };
        let result = a
            .symbolic
            .factorize_numeric_llt(
                &mut a.llt,
                matrix,
                Side::Lower,
                LltRegularization::default(),
                self.par,
                MemStack::new(&mut self.scratch),
                Default::default(),
            )
            .map(|_| ())
            .map_err(|e| NotFactorizable(format!("{e:?}")));
        stats.counters.numeric_factorisations += 1;
        stats.timers.factorisation += secs(start);
        self.factorized = result.is_ok();
        result
    }

    /// Forget the numeric factorisation (the symbolic one stays).
    pub fn invalidate(&mut self) {
        self.factorized = false;
    }

    /// Solve `A x = b` in place (`rhs` holds `b` on entry and `x` on return).
    pub fn solve_in_place(&mut self, rhs: &mut [f64], stats: &mut SolverStats) {
        let start = Instant::now();
        let n = rhs.len();
        let x = MatMut::from_column_major_slice_mut(rhs, n, 1);
        if let Some(a) = &self.analysed {
            LltRef::new(&a.symbolic, &a.llt).solve_in_place_with_conj(
                Conj::No,
                x,
                self.par,
                MemStack::new(&mut self.scratch),
            );
        }
        stats.counters.solves += 1;
        stats.timers.solve += secs(start);
    }

    /// Pivots of an `L D L^T` of `matrix` (symmetric, in the analysed pattern, scaled so that
    /// its pivots are of order one) below `-threshold`. Pivots within `threshold` of zero
    /// (rattlers, free rotations: a singular direction) are taken as zero and not counted.
    /// The `L L^T` kept for solves is left as it was.
    pub fn negative_pivots(
        &mut self,
        matrix: SparseColMatRef<'_, usize, f64>,
        threshold: f64,
        stats: &mut SolverStats,
    ) -> Result<usize, NotFactorizable> {
        let start = Instant::now();
        let Some(Analysed {
            symbolic: s,
            ldlt: values,
            ..
        }) = &mut self.analysed
        else {
            return Err(NotFactorizable("no symbolic factorisation".into()));
        };
        values.resize(s.len_val(), 0.0);
        // Pivots within the threshold are set to +-threshold, so that none is zero.
        let regularization = LdltRegularization {
            dynamic_regularization_signs: None,
            dynamic_regularization_delta: threshold,
            dynamic_regularization_epsilon: threshold,
        };
        let result = s.factorize_numeric_ldlt(
            values,
            matrix,
            Side::Lower,
            regularization,
            self.par,
            MemStack::new(&mut self.scratch),
            Default::default(),
        );
        stats.counters.numeric_factorisations += 1;
        stats.timers.factorisation += secs(start);
        result.map_err(|e| NotFactorizable(format!("{e:?}")))?;
        let negative = |d: &f64| *d < -threshold;
        Ok(match s.raw() {
            // Each column of a simplicial factor starts with its pivot.
            SymbolicCholeskyRaw::Simplicial(sym) => {
                let factor = SimplicialLdltRef::new(sym, values);
                let col_ptr = sym.col_ptr();
                (0..sym.nrows())
                    .filter(|&j| negative(&factor.values()[col_ptr[j]]))
                    .count()
            }
            // A supernode's diagonal block holds its pivots on its diagonal.
            SymbolicCholeskyRaw::Supernodal(sym) => {
                let factor = SupernodalLdltRef::new(sym, values);
                (0..sym.n_supernodes())
                    .map(|k| {
                        let block = factor.supernode(k).val();
                        (0..block.ncols())
                            .filter(|&j| negative(&block[(j, j)]))
                            .count()
                    })
                    .sum()
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::sparse::{SparseColMat, Triplet};

    /// The Dirichlet Laplacian of an `n` x `n` grid shifted by `-shift` (full storage), and
    /// how many of its eigenvalues, `4 - 2 cos(i pi / (n + 1)) - 2 cos(j pi / (n + 1))`, are
    /// below the shift.
    fn shifted_laplacian(n: usize, shift: f64) -> (SparseColMat<usize, f64>, usize) {
        let index = |i: usize, j: usize| i * n + j;
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
        // Small grids factor simplicially, the large one in supernodes.
        let mut supernodal = false;
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
            if let Some(a) = &solver.analysed {
                supernodal |= matches!(a.symbolic.raw(), SymbolicCholeskyRaw::Supernodal(_));
            }
        }
        assert!(supernodal, "the supernodal path was taken");
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
}
