//! The sparse direct solver: faer's supernodal Cholesky for symmetric tangents, sparse LU for
//! the unsymmetric consistent tangent. The symbolic factorisation is made once per pattern and
//! reused across Newton iterations, topology passes and increments; the numeric storage and
//! the scratch memory are kept too (stack-notes.md: a fresh allocation per factorisation costs
//! 1.15-1.5x).
//!
//! Contract: [`LinearSolver::analyse`] is called whenever the pattern changes (friends lists
//! rebuilt); [`LinearSolver::factorize`] whenever values change; [`LinearSolver::solve_in_place`]
//! uses the last successful factorisation.

use super::config::LinearKind;
use super::stats::{secs, SolverStats};
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, LltRef, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::linalg::lu::{factorize_symbolic_lu, LuRef, NumericLu, SymbolicLu};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{Conj, MatMut, Par, Side};
use std::time::Instant;

/// The factorisation could not be made (a non-positive pivot, or a singular matrix).
#[derive(Debug, Clone, PartialEq)]
pub struct NotFactorizable(pub String);

enum Symbolic {
    None,
    Cholesky(SymbolicCholesky<usize>, Vec<f64>),
    Lu(SymbolicLu<usize>, Box<NumericLu<usize, f64>>),
}

/// A sparse direct solver with its symbolic factorisation and buffers kept.
pub struct LinearSolver {
    kind: LinearKind,
    par: Par,
    symbolic: Symbolic,
    scratch: MemBuffer,
    factorized: bool,
}

impl LinearSolver {
    /// A solver of the given kind, running single-threaded (faster on this 2-core machine;
    /// stack-notes.md).
    pub fn new(kind: LinearKind) -> Self {
        LinearSolver {
            kind,
            par: Par::Seq,
            symbolic: Symbolic::None,
            scratch: MemBuffer::new(StackReq::EMPTY),
            factorized: false,
        }
    }

    /// Which factorisation this is.
    pub fn kind(&self) -> LinearKind {
        self.kind
    }

    /// Symbolic factorisation of a new pattern (fill-reducing ordering, elimination tree,
    /// supernodes), with numeric storage and scratch sized for it.
    pub fn analyse(
        &mut self,
        pattern: &SymbolicSparseColMat<usize>,
        stats: &mut SolverStats,
    ) -> Result<(), NotFactorizable> {
        let start = Instant::now();
        let fail = |e: faer::sparse::FaerError| NotFactorizable(format!("{e:?}"));
        self.symbolic = match self.kind {
            LinearKind::Cholesky => {
                let s = factorize_symbolic_cholesky(
                    pattern.as_ref(),
                    Side::Lower,
                    SymmetricOrdering::Amd,
                    Default::default(),
                )
                .map_err(fail)?;
                self.scratch = MemBuffer::new(StackReq::any_of(&[
                    s.factorize_numeric_llt_scratch::<f64>(self.par, Default::default()),
                    s.solve_in_place_scratch::<f64>(1, self.par),
                ]));
                let values = vec![0.0; s.len_val()];
                Symbolic::Cholesky(s, values)
            }
            LinearKind::Lu => {
                let s =
                    factorize_symbolic_lu(pattern.as_ref(), Default::default()).map_err(fail)?;
                self.scratch = MemBuffer::new(StackReq::any_of(&[
                    s.factorize_numeric_lu_scratch::<f64>(self.par, Default::default()),
                    s.solve_in_place_scratch::<f64>(1, self.par),
                ]));
                Symbolic::Lu(s, Box::new(NumericLu::new()))
            }
        };
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
        let stack = MemStack::new(&mut self.scratch);
        let result = match &mut self.symbolic {
            Symbolic::None => return Err(NotFactorizable("no symbolic factorisation".into())),
            Symbolic::Cholesky(s, values) => s
                .factorize_numeric_llt(
                    values,
                    matrix,
                    Side::Lower,
                    LltRegularization::default(),
                    self.par,
                    stack,
                    Default::default(),
                )
                .map(|_| ())
                .map_err(|e| NotFactorizable(format!("{e:?}"))),
            Symbolic::Lu(s, numeric) => s
                .factorize_numeric_lu(numeric, matrix, self.par, stack, Default::default())
                .map(|_| ())
                .map_err(|e| NotFactorizable(format!("{e:?}"))),
        };
        stats.counters.numeric_factorisations += 1;
        stats.timers.factorisation += secs(start);
        self.factorized = result.is_ok();
        result
    }

    /// Forget the numeric factorisation (the symbolic one stays).
    pub fn invalidate(&mut self) {
        self.factorized = false;
    }

    /// Whether a factorisation is ready for solves.
    pub fn is_factorized(&self) -> bool {
        self.factorized
    }

    /// Solve `A x = b` in place (`rhs` holds `b` on entry and `x` on return).
    pub fn solve_in_place(&mut self, rhs: &mut [f64], stats: &mut SolverStats) {
        let start = Instant::now();
        let n = rhs.len();
        let x = MatMut::from_column_major_slice_mut(rhs, n, 1);
        let stack = MemStack::new(&mut self.scratch);
        match &self.symbolic {
            Symbolic::Cholesky(s, values) => {
                LltRef::new(s, values).solve_in_place_with_conj(Conj::No, x, self.par, stack)
            }
            Symbolic::Lu(s, numeric) => LuRef::new_unchecked(s, numeric).solve_in_place_with_conj(
                Conj::No,
                x,
                self.par,
                stack,
            ),
            Symbolic::None => {}
        }
        stats.counters.solves += 1;
        stats.timers.solve += secs(start);
    }
}
