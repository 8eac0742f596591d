//! The sparse direct solver: faer's supernodal Cholesky of the symmetric Hessian, solved with
//! by a loop of our own over its supernodes (`solve_llt`). The symbolic
//! factorisation is made once per pattern and reused across iterations, passes and
//! increments; the numeric storage and the scratch memory are kept too (stack-notes.md: a
//! fresh allocation per factorisation costs 1.15-1.5x).
//!
//! Contract: [`LinearSolver::analyse`] is called whenever the pattern changes (friends lists
//! rebuilt); [`LinearSolver::factorize`] whenever values change; [`LinearSolver::solve_in_place`]
//! uses the last successful factorisation.
//!
//! [`LinearSolver::negative_pivots`] counts the negative pivots of an `L D L^T` of a symmetric
//! matrix in the Cholesky pattern: by Sylvester's law of inertia, the number of negative
//! eigenvalues. It is made in the storage of the `L L^T`, which is then gone: the stability
//! indicator is taken once a minimisation has converged, and the next one factorises anew,
//! so the two factors are never needed at once and only one is ever held. The `L D L^T`
//! then solves ([`LinearSolver::solve_ldlt_in_place`]) for the indicator's walls, freed
//! (a Schur complement), so that a run holds one pattern, one analysis and one factor. Where
//! it is positive definite it is kept as a factor of the tangent at that equilibrium
//! ([`LinearSolver::hold_as_tangent`]), and the next minimisation's first step solves with it
//! instead of factorising.

mod ordering;
mod supernodal_solve;

pub use ordering::{FillOrdering, METIS_UNKNOWNS};

use ordering::nested_dissection;
use supernodal_solve::solve_llt;

use super::stats::{secs, SolverStats};
use crate::assembly::value_index;
use crate::memory::HeapBytes;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::ldlt::factor::LdltRegularization;
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::supernodal::{
    factorize_supernodal_numeric_ldlt, factorize_supernodal_numeric_ldlt_scratch,
    factorize_supernodal_numeric_llt, factorize_supernodal_numeric_llt_scratch, SupernodalLdltRef,
    SymbolicSupernodalCholesky,
};
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw,
    SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::utils::{permute_self_adjoint_scratch, permute_self_adjoint_to_unsorted};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{Index, Par, Side};
use std::time::Instant;

/// The factorisation could not be made (a non-positive pivot, or a singular matrix).
#[derive(Debug, Clone, PartialEq)]
pub struct NotFactorizable(pub String);

/// Unknowns from which faer's Cholesky runs on the pool's threads. On two free cores,
/// 300,000 unknowns factorise 1.25 times as fast on two threads, 30,000 no faster
/// (docs/performance.md, Threads). Its factors are the same bit for bit on any number of
/// threads.
pub const PARALLEL_UNKNOWNS: usize = 100_000;

/// The Cholesky of a pattern: faer's supernodal symbolic factorisation in a fill-reducing
/// order, the matrix in that order, and the factors' values, with indices of the word `I`.
///
/// The supernodal factorisation is taken at every size: on these matrices (three unknowns
/// per grain, each coupled to its neighbours') it is 1.3 to 6 times as fast as the simplicial
/// one faer's own rule takes below some 5,000 grains. faer would permute the matrix into its
/// order (and copy it) at every factorisation; here the values are gathered into that order
/// straight from the pattern's, laid out as faer lays them out itself.
struct Cholesky<I: Index> {
    /// The symbolic factorisation, with the order.
    symbolic: SymbolicCholesky<I>,
    /// `P A P^T`: its lower triangle, which the numeric factorisation reads.
    ordered: SymbolicSparseColMat<I>,
    /// The value of `A` each entry of `ordered` takes (in 32 bits, as the pattern's slots).
    source: Vec<u32>,
    /// Where each pivot's diagonal entry lies in `ordered`.
    diagonal: Vec<I>,
    /// The values of `ordered`.
    values: Vec<f64>,
    /// A right-hand side in the pivots' order.
    work: Vec<f64>,
    /// The entries of the right-hand side below a supernode, gathered, and each of its
    /// columns' products with them (`solve_llt`).
    below: Vec<f64>,
    column_dots: Vec<f64>,
}

/// A pattern's Cholesky in the word its factor needs. faer indexes the factor's values in
/// the word of the matrix's indices, below that word's signed maximum, and a factor fills in
/// to many times the pattern's entries: in 32 bits while it holds fewer than 2^31 values
/// (some 3.5 million grains of a crystal), which halves the indices of the analysis, and in
/// the machine's word past that.
enum Analysis {
    Narrow(Box<Cholesky<u32>>),
    Wide(Box<Cholesky<usize>>),
}

/// `$body` with `$c` the Cholesky of `$analysis`, in whichever word it is.
macro_rules! with_cholesky {
    ($analysis:expr, $c:ident => $body:expr) => {
        match $analysis {
            Analysis::Narrow($c) => $body,
            Analysis::Wide($c) => $body,
        }
    };
}

impl Analysis {
    /// The Cholesky of `pattern` (both triangles stored) in the fill-reducing `ordering`: in
    /// the pattern's own 32 bits, or, where the factor would hold 2^31 values or more, in a
    /// copy of it in the machine's word.
    fn of(
        pattern: &SymbolicSparseColMat<u32>,
        ordering: FillOrdering,
    ) -> Result<Self, NotFactorizable> {
        let metis = match ordering {
            FillOrdering::Auto => pattern.nrows() >= METIS_UNKNOWNS,
            FillOrdering::Amd => false,
            FillOrdering::Metis => true,
        };
        let dissected = metis.then(|| nested_dissection(pattern)).transpose()?;
        let Some(c) = Cholesky::analyse(pattern, dissected.as_ref())? else {
            let wide = Cholesky::analyse(&widened(pattern), dissected.as_ref())?;
            let c = wide.ok_or_else(|| NotFactorizable("the factor's indices overflow".into()))?;
            return Ok(Analysis::Wide(Box::new(c)));
        };
        Ok(Analysis::Narrow(Box::new(c)))
    }
}

impl<I: Index> Cholesky<I> {
    /// The Cholesky of `pattern` (both triangles stored) in METIS's order `dissected` (the
    /// unknown of each pivot, and the pivot of each unknown), or else in faer's AMD; `None`
    /// where the factor's indices overflow the word `I`.
    fn analyse(
        pattern: &SymbolicSparseColMat<I>,
        dissected: Option<&(Vec<usize>, Vec<usize>)>,
    ) -> Result<Option<Self>, NotFactorizable> {
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        };
        let word = |v: &[usize]| v.iter().map(|&k| I::truncate(k)).collect::<Vec<I>>();
        let dissected = dissected.map(|(fwd, inv)| (word(fwd), word(inv)));
        let pivot_order = match &dissected {
            Some((fwd, inv)) => {
                SymmetricOrdering::Custom(PermRef::new_checked(fwd, inv, fwd.len()))
            }
            None => SymmetricOrdering::Amd,
        };
        let symbolic =
            match factorize_symbolic_cholesky(pattern.as_ref(), Side::Lower, pivot_order, params) {
                Ok(symbolic) => symbolic,
                Err(faer::sparse::FaerError::IndexOverflow) => return Ok(None),
                Err(e) => return Err(NotFactorizable(format!("{e:?}"))),
            };
        let perm = symbolic.perm().expect("an ordering");
        let (ordered, source) = permute(pattern, perm);
        let n = pattern.nrows();
        let diagonal = (0..n)
            .map(|j| {
                let start = ordered.col_ptr()[j].zx();
                let rows = ordered.row_idx_of_col_raw(j);
                I::truncate(start + rows.iter().position(|&i| i.zx() == j).expect("a diagonal"))
            })
            .collect();
        Ok(Some(Cholesky {
            values: vec![0.0; source.len()],
            ordered,
            source,
            diagonal,
            work: vec![0.0; n],
            below: Vec::new(),
            column_dots: Vec::new(),
            symbolic,
        }))
    }

    /// `P (A + diag(shift)) P^T` into `values` (no shift when `shift` is empty).
    fn gather(&mut self, a: &[f64], shift: &[f64]) {
        for (value, &k) in self.values.iter_mut().zip(&self.source) {
            *value = a[k as usize];
        }
        if !shift.is_empty() {
            for (&slot, &dof) in self.diagonal.iter().zip(order(&self.symbolic).0) {
                self.values[slot.zx()] += shift[dof.zx()];
            }
        }
    }

    /// Numeric factorisation of the matrix gathered last into `factor`: `L L^T`.
    fn factorize_llt(
        &mut self,
        factor: &mut Vec<f64>,
        (par, scratch): (Par, &mut MemBuffer),
    ) -> Result<(), NotFactorizable> {
        factor.resize(self.symbolic.len_val(), 0.0);
        factorize_supernodal_numeric_llt(
            factor,
            SparseColMatRef::new(self.ordered.as_ref(), &self.values),
            LltRegularization::default(),
            supernodes(&self.symbolic),
            par,
            MemStack::new(scratch),
            Default::default(),
        )
        .map(|_| ())
        .map_err(|e| NotFactorizable(format!("{e:?}")))
    }

    /// Numeric factorisation of `a` into `factor`: `L D L^T`, its pivots within `threshold`
    /// of zero set to `+-threshold`; the pivots below `-threshold`, and those within
    /// `threshold` of zero, counted.
    fn factorize_ldlt(
        &mut self,
        a: &[f64],
        threshold: f64,
        factor: &mut Vec<f64>,
        (par, scratch): (Par, &mut MemBuffer),
    ) -> Result<(usize, usize), NotFactorizable> {
        self.gather(a, &[]);
        factor.resize(self.symbolic.len_val(), 0.0);
        let regularization = LdltRegularization {
            dynamic_regularization_signs: None,
            dynamic_regularization_delta: threshold,
            dynamic_regularization_epsilon: threshold,
        };
        factorize_supernodal_numeric_ldlt(
            factor,
            SparseColMatRef::new(self.ordered.as_ref(), &self.values),
            regularization,
            supernodes(&self.symbolic),
            par,
            MemStack::new(scratch),
            Default::default(),
        )
        .map_err(|e| NotFactorizable(format!("{e:?}")))?;
        // A supernode's diagonal block holds its pivots on its diagonal.
        let factor = SupernodalLdltRef::new(
            supernodes(&self.symbolic),
            &factor[..self.symbolic.len_val()],
        );
        let (mut negative, mut zero) = (0, 0);
        for k in 0..factor.symbolic().n_supernodes() {
            let block = factor.supernode(k).val();
            for j in 0..block.ncols() {
                let pivot = block[(j, j)];
                negative += usize::from(pivot < -threshold);
                zero += usize::from(pivot.abs() <= threshold);
            }
        }
        Ok((negative, zero))
    }

    /// Solve `L L^T x = b` in place with `factor`.
    fn solve(&mut self, factor: &[f64], rhs: &mut [f64]) {
        let (forward, inverse) = order(&self.symbolic);
        for (w, &dof) in self.work.iter_mut().zip(forward) {
            *w = rhs[dof.zx()];
        }
        let scratch = (&mut self.below, &mut self.column_dots);
        solve_llt(supernodes(&self.symbolic), factor, &mut self.work, scratch);
        for (r, &pivot) in rhs.iter_mut().zip(inverse) {
            *r = self.work[pivot.zx()];
        }
    }

    /// Solve `A X = B` in place with the `L D L^T` in `factor`, for the `columns`
    /// right-hand sides that `rhs` holds one after another.
    fn solve_ldlt(&self, factor: &[f64], rhs: &mut [f64], columns: usize, par: Par) {
        let n = self.work.len();
        let (forward, inverse) = order(&self.symbolic);
        let mut ordered = vec![0.0; n * columns];
        for (o, b) in ordered.chunks_exact_mut(n).zip(rhs.chunks_exact(n)) {
            for (v, &dof) in o.iter_mut().zip(forward) {
                *v = b[dof.zx()];
            }
        }
        let s = supernodes(&self.symbolic);
        let mut scratch = MemBuffer::new(s.solve_in_place_scratch::<f64>(columns, par));
        SupernodalLdltRef::new(s, &factor[..self.symbolic.len_val()]).solve_in_place_with_conj(
            faer::Conj::No,
            faer::MatMut::from_column_major_slice_mut(&mut ordered, n, columns),
            par,
            MemStack::new(&mut scratch),
        );
        for (x, o) in rhs.chunks_exact_mut(n).zip(ordered.chunks_exact(n)) {
            for (v, &pivot) in x.iter_mut().zip(inverse) {
                *v = o[pivot.zx()];
            }
        }
    }

    /// The scratch of its numeric factorisations on `par`.
    fn scratch(&self, par: Par) -> StackReq {
        let s = supernodes(&self.symbolic);
        StackReq::any_of(&[
            factorize_supernodal_numeric_llt_scratch::<I, f64>(s, par, Default::default()),
            factorize_supernodal_numeric_ldlt_scratch::<I, f64>(s, par, Default::default()),
        ])
    }

    /// Bytes the analysis holds: the matrix in its order, its map and values, the symbolic
    /// factor and its order, the work vectors.
    fn heap_bytes(&self) -> usize {
        let word = std::mem::size_of::<I>();
        let s = supernodes(&self.symbolic);
        let symbolic = s.supernode_begin().len()
            + s.supernode_end().len()
            + s.col_ptr_for_row_idx().len()
            + s.col_ptr_for_val().len()
            + s.row_idx().len()
            + 2 * self.work.len();
        let ordered = self.ordered.col_ptr().len() + self.ordered.row_idx().len();
        let vectors = [&self.values, &self.work, &self.below, &self.column_dots];
        word * (symbolic + ordered + self.diagonal.len())
            + self.source.heap_bytes()
            + vectors.iter().map(|v| v.heap_bytes()).sum::<usize>()
    }
}

/// `pattern` with its indices in the machine's word.
fn widened(pattern: &SymbolicSparseColMat<u32>) -> SymbolicSparseColMat<usize> {
    let word = |v: &[u32]| v.iter().map(|&i| i as usize).collect();
    SymbolicSparseColMat::new_checked(
        pattern.nrows(),
        pattern.ncols(),
        word(pattern.col_ptr()),
        None,
        word(pattern.row_idx()),
    )
}

/// The supernodes of a Cholesky analysed in supernodes.
fn supernodes<I: Index>(symbolic: &SymbolicCholesky<I>) -> &SymbolicSupernodalCholesky<I> {
    match symbolic.raw() {
        SymbolicCholeskyRaw::Supernodal(s) => s,
        SymbolicCholeskyRaw::Simplicial(_) => unreachable!("analysed in supernodes"),
    }
}

/// The unknown of each pivot, and the pivot of each unknown.
fn order<I: Index>(symbolic: &SymbolicCholesky<I>) -> (&[I], &[I]) {
    symbolic.perm().expect("an ordering").arrays()
}

/// The lower triangle of `P A P^T` of the pattern `A` (both triangles stored), laid out as
/// faer lays it out when it permutes a matrix itself, and the entry of `A` each of its
/// entries is.
fn permute<I: Index>(
    pattern: &SymbolicSparseColMat<I>,
    perm: PermRef<'_, I>,
) -> (SymbolicSparseColMat<I>, Vec<u32>) {
    let (n, nnz) = (pattern.nrows(), pattern.row_idx().len());
    // Each entry's index as its value (exact: far below 2^53), carried along by faer.
    let index: Vec<f64> = (0..nnz).map(|k| k as f64).collect();
    // The lower triangle's entries: as many in `P A P^T` as in `A`, the pattern being
    // symmetric. faer fills that many; buffers of the whole pattern's size would be kept
    // half empty.
    let lower = (0..n)
        .map(|j| {
            pattern
                .row_idx_of_col_raw(j)
                .iter()
                .filter(|&&i| i.zx() >= j)
                .count()
        })
        .sum();
    let zero = I::truncate(0);
    let (mut source, mut col_ptr, mut row_idx) =
        (vec![0.0; lower], vec![zero; n + 1], vec![zero; lower]);
    let mut scratch = MemBuffer::new(permute_self_adjoint_scratch::<I>(n));
    permute_self_adjoint_to_unsorted(
        &mut source,
        &mut col_ptr,
        &mut row_idx,
        SparseColMatRef::new(pattern.as_ref(), &index),
        perm,
        Side::Lower,
        Side::Lower,
        MemStack::new(&mut scratch),
    );
    debug_assert_eq!(col_ptr[n].zx(), lower);
    let source = source.iter().map(|&k| value_index(k as usize)).collect();
    let ordered = SymbolicSparseColMat::new_unsorted_checked(n, n, col_ptr, None, row_idx);
    (ordered, source)
}

/// What a solver's factor storage holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Factor {
    /// Nothing to solve with.
    Nothing,
    /// The `L L^T` of the last [`LinearSolver::factorize`].
    Llt,
    /// The `L D L^T` of the last [`LinearSolver::negative_pivots`].
    Ldlt,
    /// That `L D L^T`, positive definite, kept as a factor of the tangent it was made of
    /// ([`LinearSolver::hold_as_tangent`]).
    Tangent,
}

/// A sparse Cholesky solver with its symbolic factorisation and buffers kept.
pub struct LinearSolver {
    ordering: FillOrdering,
    par: Par,
    cholesky: Option<Analysis>,
    scratch: MemBuffer,
    /// What `factor` holds.
    holds: Factor,
    /// The factor's values: the `L L^T` solved with, or the stability indicator's `L D L^T`.
    /// Sized when first factorised into.
    factor: Vec<f64>,
    /// Whether the analysis's copy holds the matrix of the last [`LinearSolver::stage`].
    staged: bool,
    /// Whether the last `L D L^T` had all its pivots above its threshold.
    definite: bool,
    /// The scale `S` of the tangent `K` whose `S K S` the `L D L^T` held as
    /// [`Factor::Tangent`] factorises.
    tangent_scale: Vec<f64>,
}

impl Default for LinearSolver {
    fn default() -> Self {
        Self::new()
    }
}

impl LinearSolver {
    /// A solver in the default order ([`FillOrdering::Auto`]) with nothing analysed yet;
    /// [`LinearSolver::analyse`] chooses its threads.
    pub fn new() -> Self {
        Self::in_order(FillOrdering::Auto)
    }

    /// A solver in the fill-reducing `ordering`, with nothing analysed yet.
    pub fn in_order(ordering: FillOrdering) -> Self {
        LinearSolver {
            ordering,
            par: Par::Seq,
            cholesky: None,
            scratch: MemBuffer::new(StackReq::EMPTY),
            holds: Factor::Nothing,
            factor: Vec::new(),
            staged: false,
            definite: false,
            tangent_scale: Vec::new(),
        }
    }

    /// Symbolic factorisation of a new pattern (fill-reducing ordering, elimination tree,
    /// supernodes), with numeric storage and scratch sized for it, on the pool's threads from
    /// [`PARALLEL_UNKNOWNS`] unknowns on.
    pub fn analyse(
        &mut self,
        pattern: &SymbolicSparseColMat<u32>,
        stats: &mut SolverStats,
    ) -> Result<(), NotFactorizable> {
        let start = Instant::now();
        // The old analysis goes first, so that the two are not held at once.
        self.cholesky = None;
        (self.holds, self.staged) = (Factor::Nothing, false);
        let threads = rayon::current_num_threads();
        self.par = if threads > 1 && pattern.nrows() >= PARALLEL_UNKNOWNS {
            Par::rayon(threads)
        } else {
            Par::Seq
        };
        let analysis = Analysis::of(pattern, self.ordering)?;
        // The supernodal factorisations' own scratch: the matrix comes already in the order.
        self.scratch = MemBuffer::new(with_cholesky!(&analysis, c => c.scratch(self.par)));
        self.cholesky = Some(analysis);
        stats.counters.symbolic_factorisations += 1;
        stats.timers.symbolic += secs(start);
        Ok(())
    }

    /// Numeric factorisation of `matrix` (which has the analysed pattern).
    pub fn factorize(
        &mut self,
        matrix: SparseColMatRef<'_, u32, f64>,
        stats: &mut SolverStats,
    ) -> Result<(), NotFactorizable> {
        self.factorize_shifted(matrix, &[], stats)
    }

    /// Numeric factorisation of `matrix + diag(shift)` (`matrix` with the analysed pattern);
    /// an empty `shift` adds nothing.
    pub fn factorize_shifted(
        &mut self,
        matrix: SparseColMatRef<'_, u32, f64>,
        shift: &[f64],
        stats: &mut SolverStats,
    ) -> Result<(), NotFactorizable> {
        let start = Instant::now();
        self.stage(matrix.val(), shift)?;
        stats.timers.factorisation += secs(start);
        self.factorize_staged(stats)
    }

    /// Take `values + diag(shift)` (values of the analysed pattern) into the analysis's own
    /// copy in its order, for [`LinearSolver::factorize_staged`]: `values` can then be
    /// overwritten. The factor held stays until then.
    pub fn stage(&mut self, values: &[f64], shift: &[f64]) -> Result<(), NotFactorizable> {
        let Some(analysis) = &mut self.cholesky else {
            return Err(NotFactorizable("no symbolic factorisation".into()));
        };
        with_cholesky!(analysis, c => c.gather(values, shift));
        self.staged = true;
        Ok(())
    }

    /// Numeric factorisation, `L L^T`, of the matrix of the last [`LinearSolver::stage`].
    pub fn factorize_staged(&mut self, stats: &mut SolverStats) -> Result<(), NotFactorizable> {
        let start = Instant::now();
        self.holds = Factor::Nothing;
        let (Some(analysis), true) = (&mut self.cholesky, self.staged) else {
            return Err(NotFactorizable("no matrix staged".into()));
        };
        let work = (self.par, &mut self.scratch);
        let result = with_cholesky!(analysis, c => c.factorize_llt(&mut self.factor, work));
        stats.counters.numeric_factorisations += 1;
        stats.timers.factorisation += secs(start);
        if result.is_ok() {
            self.holds = Factor::Llt;
        }
        result
    }

    /// Forget the numeric factorisation (the symbolic one stays).
    pub fn invalidate(&mut self) {
        self.holds = Factor::Nothing;
    }

    /// Values the factor of the analysed pattern holds (its supernodes' dense blocks, padding
    /// included): its fill.
    pub fn factor_entries(&self) -> usize {
        (self.cholesky.as_ref()).map_or(0, |a| with_cholesky!(a, c => c.symbolic.len_val()))
    }

    /// Bytes it holds: the analysis (the matrix in its order, its map and values, the
    /// symbolic factor and its order, the work vectors), and the factor's values (with the
    /// scale of a tangent held). The
    /// factorisation's scratch is not counted: faer reserves it, and touches what the
    /// largest supernode needs.
    pub fn heap_bytes(&self) -> (usize, usize) {
        let analysis =
            (self.cholesky.as_ref()).map_or(0, |a| with_cholesky!(a, c => c.heap_bytes()));
        (
            analysis,
            self.factor.heap_bytes() + self.tangent_scale.heap_bytes(),
        )
    }

    /// Whether a pattern has been analysed.
    pub fn is_analysed(&self) -> bool {
        self.cholesky.is_some()
    }

    /// Solve `A x = b` in place (`rhs` holds `b` on entry and `x` on return), `A` the matrix
    /// of the last factorisation, or the tangent held by [`LinearSolver::hold_as_tangent`].
    pub fn solve_in_place(&mut self, rhs: &mut [f64], stats: &mut SolverStats) {
        let start = Instant::now();
        match (&mut self.cholesky, self.holds) {
            (Some(analysis), Factor::Tangent) => {
                // `K^-1 = S (S K S)^-1 S`.
                let scale = |rhs: &mut [f64]| {
                    for (r, s) in rhs.iter_mut().zip(&self.tangent_scale) {
                        *r *= s;
                    }
                };
                scale(rhs);
                with_cholesky!(analysis, c => c.solve_ldlt(&self.factor, rhs, 1, self.par));
                scale(rhs);
            }
            (Some(analysis), _) => with_cholesky!(analysis, c => c.solve(&self.factor, rhs)),
            (None, _) => {}
        }
        stats.counters.solves += 1;
        stats.timers.solve += secs(start);
    }

    /// Pivots of an `L D L^T` of `matrix` (symmetric, in the analysed pattern, scaled so that
    /// its pivots are of order one) below `-threshold`. Pivots within `threshold` of zero
    /// (rattlers, free rotations: a singular direction) are taken as zero and not counted.
    /// It takes the storage of the `L L^T`, which must be factorised anew before the next
    /// solve; until then [`LinearSolver::solve_ldlt_in_place`] solves with it.
    pub fn negative_pivots(
        &mut self,
        matrix: SparseColMatRef<'_, u32, f64>,
        threshold: f64,
        stats: &mut SolverStats,
    ) -> Result<usize, NotFactorizable> {
        let start = Instant::now();
        (self.holds, self.staged) = (Factor::Nothing, false);
        let Some(analysis) = &mut self.cholesky else {
            return Err(NotFactorizable("no symbolic factorisation".into()));
        };
        let work = (self.par, &mut self.scratch);
        let counts = with_cholesky!(analysis, c => {
            c.factorize_ldlt(matrix.val(), threshold, &mut self.factor, work)
        });
        stats.counters.numeric_factorisations += 1;
        stats.timers.factorisation += secs(start);
        let (negative, zero) = counts?;
        self.holds = Factor::Ldlt;
        self.definite = negative == 0 && zero == 0;
        Ok(negative)
    }

    /// Keep the `L D L^T` of the last [`LinearSolver::negative_pivots`], of `S K S` with
    /// `S = diag(scale)`, as a factor of the tangent `K` for [`LinearSolver::solve_in_place`],
    /// where it is positive definite (every pivot above its threshold: no rattler or free
    /// rotation, no softening). Returns whether it is kept; the next factorisation replaces it.
    pub fn hold_as_tangent(&mut self, scale: Vec<f64>) -> bool {
        if self.holds != Factor::Ldlt || !self.definite {
            return false;
        }
        self.tangent_scale = scale;
        self.holds = Factor::Tangent;
        true
    }

    /// Whether it holds a factor of the tangent at an equilibrium
    /// ([`LinearSolver::hold_as_tangent`]).
    pub fn holds_tangent(&self) -> bool {
        self.holds == Factor::Tangent
    }

    /// Solve `A X = B` in place with the `L D L^T` of the last
    /// [`LinearSolver::negative_pivots`], for the `columns` right-hand sides that `rhs` holds
    /// one after another (`B` on entry, `X` on return): all at once, reading the factor once.
    pub fn solve_ldlt_in_place(
        &mut self,
        rhs: &mut [f64],
        columns: usize,
        stats: &mut SolverStats,
    ) -> Result<(), NotFactorizable> {
        let (Some(analysis), Factor::Ldlt) = (&self.cholesky, self.holds) else {
            return Err(NotFactorizable("no L D L^T to solve with".into()));
        };
        let start = Instant::now();
        with_cholesky!(analysis, c => c.solve_ldlt(&self.factor, rhs, columns, self.par));
        stats.counters.solves += columns;
        stats.timers.solve += secs(start);
        Ok(())
    }
}

#[cfg(test)]
pub(super) mod tests;
