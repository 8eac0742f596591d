//! The stability indicator: the negative pivots of an `L D L^T` of the symmetric tangent at a
//! converged state, with every displacement-controlled wall freed.

use super::{LoadStep, Simulation};
use crate::assembly::{DofMap, Pattern};
use crate::geometry::{Chain, WallControl};
use crate::solver::LinearSolver;
use faer::sparse::SparseColMatRef;
use std::sync::Arc;

/// The unknowns, pattern and Cholesky analysis of the tangent with every displacement-
/// controlled wall freed (see [`Simulation::negative_pivots`]), made from `source`.
pub(super) struct FreedSystem {
    source: Arc<Pattern>,
    source_dofs: DofMap,
    dofs: DofMap,
    pattern: Arc<Pattern>,
    linear: LinearSolver,
}

impl Simulation {
    /// The stability indicator at the converged `u` of `step`: the negative pivots of an
    /// `L D L^T` of the symmetric (elasto-plastic) tangent, unregularised, with every
    /// displacement-controlled wall freed and held by its reaction as a dead load. Freed,
    /// a wall adds the sample's stiffness against it (the slope of its load-displacement
    /// curve, a Schur complement) to the count: a softening sample shows a negative pivot
    /// even where its walls are moved, as at the peak of a biaxial test.
    ///
    /// The tangent is scaled to pivots of order one first (each row and column by
    /// `1 / sqrt(k u_i)`, `k` the mean diagonal stiffness, `u_i` the unit of the row: a
    /// congruence, so the count is the same), and pivots above `-PIVOT_THRESHOLD` count as
    /// zero: rattlers and free rotations leave the tangent singular, and round-off must not
    /// make them negative. `None` when turned off, or when the factorisation fails.
    pub(super) fn negative_pivots(&mut self, step: &LoadStep, u: &[f64]) -> Option<usize> {
        if !self.config.stability_indicator {
            return None;
        }
        if self
            .state
            .walls
            .walls
            .iter()
            .all(|w| w.control == WallControl::Stress)
        {
            let pattern = Arc::clone(&self.pattern);
            let dofs = self.dofs.clone();
            let mut linear = std::mem::take(&mut self.linear);
            let count = self.count_negative_pivots(step, u, &dofs, &pattern, &mut linear);
            self.linear = linear;
            return count;
        }
        let current = self.freed.as_ref().is_some_and(|f| {
            Arc::ptr_eq(&f.source, &self.pattern)
                && f.source_dofs == self.dofs
                && f.pattern.couples(&f.dofs, &self.chains)
        });
        if !current {
            // The freed system is made anew where the pattern was: the vectors of the
            // pattern's size go first, so that the two systems' are not held at once.
            self.freed = None;
            self.minimise_work.release_pattern_sized();
            let mut walls = self.state.walls.clone();
            for wall in &mut walls.walls {
                wall.control = WallControl::Stress;
            }
            let dofs = DofMap::new(
                self.state.grains.len(),
                self.material.fixed_rotations,
                &walls,
                &self.state.contacts.glued(self.state.grains.len()),
                &self.state.grains.taken_out,
            );
            let links: Vec<(usize, usize)> = self.chains.iter().flat_map(Chain::links).collect();
            let pattern = Arc::new(Pattern::build(&self.friends, &dofs, &walls, &links));
            let mut linear = LinearSolver::in_order(self.config.ordering);
            linear.analyse(&pattern.symbolic, &mut self.stats).ok()?;
            self.freed = Some(FreedSystem {
                source: Arc::clone(&self.pattern),
                source_dofs: self.dofs.clone(),
                dofs,
                pattern,
                linear,
            });
        }
        let mut freed = self.freed.take()?;
        freed
            .dofs
            .follow(&self.state.grains, &self.state.walls, &step.turn);
        // The walls' unknowns at where the step took them.
        let mut u_freed = vec![0.0; freed.dofs.len];
        let grain_unknowns = freed.dofs.grains * freed.dofs.per_grain;
        u_freed[..grain_unknowns].copy_from_slice(&u[..grain_unknowns]);
        for (w, dof) in freed.dofs.wall.iter().enumerate() {
            u_freed[dof.expect("every wall freed")] = match self.dofs.wall[w] {
                Some(k) => u[k],
                None => step.normal_move[w],
            };
        }
        // The freed system's L D L^T goes into the storage of the minimisation's L L^T, which
        // the next minimisation factorises anew: one factor held, not two.
        freed.linear.give_factor(self.linear.take_factor());
        let count = self.count_negative_pivots(
            step,
            &u_freed,
            &freed.dofs,
            &freed.pattern,
            &mut freed.linear,
        );
        self.linear.give_factor(freed.linear.take_factor());
        self.freed = Some(freed);
        count
    }

    /// Negative pivots of the scaled symmetric tangent at `u` in the unknowns `dofs` and
    /// their `pattern`, analysed in `linear`.
    fn count_negative_pivots(
        &mut self,
        step: &LoadStep,
        u: &[f64],
        dofs: &DofMap,
        pattern: &Pattern,
        linear: &mut LinearSolver,
    ) -> Option<usize> {
        // The consistent tangent's storage, free between minimisations, holds the tangent.
        let mut values = std::mem::take(&mut self.minimise_work.consistent);
        values.clear();
        values.resize(pattern.nnz(), 0.0);
        let mut residual = vec![0.0; dofs.len];
        let mut eq = self.equations(step);
        eq.dofs = dofs;
        eq.pattern = pattern;
        eq.symmetric = true;
        eq.projected = false;
        let evaluated = eq.evaluate_at(u, &mut residual, Some(&mut values));
        let unit: Vec<f64> = (0..dofs.len).map(|dof| eq.unit_stiffness(dof)).collect();
        let timers = eq.timers;
        self.add_timers(timers);
        let count = evaluated.ok().and_then(|_| {
            scale_tangent(pattern, &mut values, &unit);
            let matrix = SparseColMatRef::new(pattern.symbolic.as_ref(), &values);
            linear
                .negative_pivots(matrix, PIVOT_THRESHOLD, &mut self.stats)
                .ok()
        });
        self.minimise_work.consistent = values;
        count
    }
}

/// Pivots of the scaled tangent (of order one) above `-PIVOT_THRESHOLD` count as zero in the
/// stability indicator.
const PIVOT_THRESHOLD: f64 = 1e-8;

/// Scale the tangent `values` in place to `S K S`, `S_ii = 1 / sqrt(k unit_i)`, `k` the mean
/// of `K_ii / unit_i` over the rows that have stiffness: every diagonal then of order one.
fn scale_tangent(pattern: &Pattern, values: &mut [f64], unit: &[f64]) {
    let (mut sum, mut count) = (0.0, 0usize);
    for (dof, &slot) in pattern.diagonal.iter().enumerate() {
        if values[slot] > 0.0 {
            sum += values[slot] / unit[dof];
            count += 1;
        }
    }
    let k = if count > 0 { sum / count as f64 } else { 1.0 };
    let scale: Vec<f64> = unit.iter().map(|u| 1.0 / (k * u).sqrt()).collect();
    let symbolic = pattern.symbolic.as_ref();
    for (col, &s_col) in scale.iter().enumerate() {
        let range = symbolic.col_ptr()[col]..symbolic.col_ptr()[col + 1];
        for (v, &row) in values[range]
            .iter_mut()
            .zip(symbolic.row_idx_of_col_raw(col))
        {
            *v *= scale[row] * s_col;
        }
    }
}
