//! One load increment as the minimisation of its incremental potential (method note, "One
//! load increment"): projected Newton with an Armijo line search on the potential.
//!
//! Each iteration evaluates every friends-list pair, so contacts are made and lost wherever
//! the iterate puts them, any number per iteration; factorises the projected (positive
//! semi-definite) Hessian once with the sparse Cholesky (the first step solves instead with
//! the positive definite tangent the last stability indicator factorised, where it is held);
//! and backtracks along the step until the potential falls. The friction of each contact is
//! a convex potential with its normal force and shear stiffness lagged: refrozen after every
//! step far from the answer, and near it once the lagged problem is solved to a share of the
//! true residual (an inexact inner solve; refreezing after every step there can cycle).
//! Convergence is tested on the residual of a refrozen evaluation, which is the true,
//! unlagged one. Near the answer the grain the step leaves worst is balanced exactly on its
//! own ([`Potential::balance_grain`]), and where the lag stalls, semi-smooth Newton steps
//! on the consistent tangent take over, regularised as the Hessian is (Levenberg-Marquardt).
//!
//! The minimiser knows neither the physics (the [`Potential`]) nor the linear solver beyond
//! the [`LinearSolver`] contract.

use super::krylov;
use super::linear::{LinearSolver, NotFactorizable};
use super::stats::SolverStats;
use crate::memory::HeapBytes;
use crate::NumericError;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};

/// The matrix the minimisation factorises: a fixed pattern, its values, and its diagonal
/// slots.
pub struct SystemMatrix<'a> {
    /// Pattern (full storage).
    pub symbolic: &'a SymbolicSparseColMat<u32>,
    /// Values of the Hessian, filled by [`Potential::evaluate`].
    pub values: &'a mut Vec<f64>,
    /// Value index of each diagonal entry.
    pub diagonal: &'a [usize],
}

/// The minimisation's work vectors, kept from one minimisation to the next so that, once
/// grown to the system's size, none is allocated again: from some 25,000 grains a vector of
/// the pattern's size (32 MB and more) is a fresh mapping of memory each time it is
/// allocated, every page of it zeroed by the system as it is first written.
#[derive(Debug, Default)]
pub struct MinimiseWork {
    residual: Vec<f64>,
    trial_residual: Vec<f64>,
    du: Vec<f64>,
    trial_u: Vec<f64>,
    loads: Vec<f64>,
    /// The regularisation added to the diagonal of the Hessian factorised, and of the
    /// consistent tangent in a semi-smooth step.
    shift: Vec<f64>,
    /// Each row's next place by rows, while the consistent tangent is put in that order.
    row_cursors: Vec<u32>,
    gmres: krylov::Gmres,
}

impl MinimiseWork {
    /// Bytes its vectors hold.
    pub fn heap_bytes(&self) -> usize {
        let vectors = [
            &self.residual,
            &self.trial_residual,
            &self.du,
            &self.trial_u,
            &self.loads,
            &self.shift,
        ];
        vectors.iter().map(|v| v.heap_bytes()).sum::<usize>()
            + self.row_cursors.heap_bytes()
            + self.gmres.heap_bytes()
    }
}

/// An incremental potential `Pi(u)` with its gradient and projected Hessian in a fixed
/// pattern.
pub trait Potential {
    /// Evaluate at `u` the residual `R = -dPi/du` into `residual` and, when given, the
    /// projected Hessian into `tangent` (the values of the fixed pattern). With `refreeze`
    /// the lagged quantities are first taken from `u`. Returns the stored energy of the
    /// contacts, the part of `Pi` that is not the work of the loads (see
    /// [`Potential::loads`]).
    fn evaluate(
        &mut self,
        u: &[f64],
        residual: &mut [f64],
        tangent: Option<&mut [f64]>,
        refreeze: bool,
    ) -> Result<f64, NumericError>;

    /// The loads of the last evaluation (walls, membranes, springs on free motions): affine in
    /// `u`, so their work along a straight step is exact by the trapezoid rule.
    fn loads(&self) -> &[f64];

    /// Convergence measure of a residual: `(|R|_inf / F_ref, worst grain, |R|_2 / F_ref)`.
    fn residual_norm(&self, residual: &[f64]) -> (f64, usize, f64);

    /// How the stiffness of each unknown scales: 1 for a translation, `r^2` for a rotation.
    fn unit_stiffness(&self, dof: usize) -> f64;

    /// The translation unknowns of the grain whose rotation `dof` is, if it is one.
    fn rotation_of(&self, dof: usize) -> Option<[usize; 2]>;

    /// A stiffness to regularise with when the Hessian has none at all.
    fn stiffness_hint(&self) -> f64;

    /// The largest share of the step `du` from `u` (at most 1) that keeps every grain and
    /// wall within the reach of the friends lists.
    fn reach(&mut self, u: &[f64], du: &[f64]) -> f64;

    /// Evaluate at `u`, refreezing, the true residual into `residual` and its consistent
    /// (unsymmetric) tangent into `tangent`: the semi-smooth Newton of the friction law,
    /// where a sliding contact's limit follows its normal force.
    fn consistent_tangent(
        &mut self,
        u: &[f64],
        residual: &mut [f64],
        tangent: &mut [f64],
    ) -> Result<(), NumericError>;

    /// Turn each grain, one after the other, to where its moments balance with everything
    /// else held and the lag as it is: the exact minimum of the potential along its rotation,
    /// a convex, piecewise quadratic function (stick windows `2 f N / k_s` wide between
    /// stretches where the contact slides). Newton's step cannot find such a window where
    /// a grain's contacts all slide (its rotation then has no curvature); this lowers the
    /// potential further after every accepted step.
    fn balance_rotations(&mut self, u: &mut [f64]);

    /// Move grain `grain`, everything else held, to its exact equilibrium under the true
    /// contact law (the friction limit following its own normal forces, not lagged), the
    /// residual at `u` being `residual`: its contacts' states (apart, sticking, sliding
    /// either way) are tried from `hint`, then as the law gives them where the grain is, then
    /// every assignment one or two changes away, the nearest consistent equilibrium first;
    /// `hint` is left with the states found. Returns whether it moved.
    fn balance_grain(
        &mut self,
        u: &mut [f64],
        residual: &[f64],
        grain: usize,
        hint: &mut Vec<u8>,
    ) -> bool;

    /// The share of the step `du` from `u` after which the first pair apart now has closed to
    /// a small overlap (1 when none closes within the step).
    fn closing(&mut self, u: &[f64], du: &[f64]) -> f64;

    /// Whether the pattern no longer holds what the last refreeze found (a membrane's chain
    /// on grains it does not couple): it must be made anew before the minimisation goes on.
    fn needs_new_pattern(&self) -> bool;

    /// The grains that moved more than their diameter in this increment.
    fn runaway(&self, u: &[f64]) -> Vec<usize>;

    /// Move each loose grain left out of the minimisation that the step put into another
    /// the least way out of it; returns whether one could not be moved so and was taken in
    /// among the others, which changes the potential.
    fn place_loose(&mut self, u: &mut [f64]) -> bool;

    /// The loosely held grains that touch `grain`, as of the last evaluation: those pressed
    /// on it by an unbonded contact that touch or are bonded to at most three bodies in all
    /// (a rattler it touches, a grain wedged against it).
    fn loose_neighbours(&self, grain: usize) -> Vec<usize>;
}

/// Settings of one minimisation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MinimiseSettings {
    /// Converged when `|R|_inf <= tolerance * F_ref` on a refrozen evaluation.
    pub tolerance: f64,
    /// Smallest Levenberg-Marquardt factor: it keeps the rigid motions no wall holds regular.
    pub lambda_min: f64,
    /// Iterations allowed.
    pub max_iterations: usize,
    /// Levenberg-Marquardt factor to start from: [`start_factor`] of the sample, or where this
    /// minimisation goes on from one that stopped at the edge of the friends lists, the
    /// factor that one ended with (the potential is the same, and so is how far its Newton
    /// model holds).
    pub lambda_start: f64,
}

/// How a minimisation ended.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MinimiseOutcome {
    /// Whether the tolerance was met.
    pub converged: bool,
    /// Iterations made (steps, each with at most one factorisation of the Hessian).
    pub iterations: usize,
    /// Final relative residual.
    pub residual: f64,
    /// Grain with the largest residual.
    pub worst_grain: usize,
    /// Relative residual before the first iteration and after each.
    pub history: Vec<f64>,
    /// Stopped where a step reached the edge of the friends lists, or where the pattern no
    /// longer holds the membranes' chains: they are made anew before it goes on.
    pub at_reach: bool,
    /// Grains that moved more than their diameter while the potential kept falling: no
    /// equilibrium near (method note, step 4).
    pub runaway: Vec<usize>,
    /// Stopped where a loose grain was taken in among the others ([`Potential::place_loose`]):
    /// the potential changed, and the minimisation starts again from here.
    pub changed: bool,
    /// Levenberg-Marquardt factor the minimisation ended with.
    pub lambda: f64,
}

/// Armijo's constant: a step is taken when the potential falls by this share of what the
/// slope at its start promises.
const ARMIJO: f64 = 1e-4;

/// Smallest step share the line search tries before it gives up on a direction.
const MIN_STEP: f64 = 1e-10;

/// Stiffness, as a share of the mean diagonal stiffness, below which a row counts as having
/// none (a rattler, a just-touching Hertz contact): it gets that much, so the Hessian
/// factorises and the row's step stays bounded. Rows with stiffness are left exact.
const WEAK_ROW: f64 = 1e-3;

/// Share of its grain's translational stiffness (times `r^2`) below which a rotation counts
/// as floppy: its contacts slide, or stick only just touching, so its curvature holds over a
/// tiny turn (a stick window of `2 f N / k_s`). It gets that much: the step then turns the
/// grain a bounded way towards the window instead of beyond any contact's reach, and inside
/// the window, where the curvature is a loaded contact's, the row is exact again.
const FLOPPY_ROTATION: f64 = 1e-2;

/// Levenberg-Marquardt factor a minimisation starts with: soft modes (a grain perched on
/// contacts that slide, a pair of grains hanging together) then move a bounded way until
/// full steps have brought it down. Capped by [`start_factor`] in large samples.
const LAMBDA_START: f64 = 1e-4;

/// The Levenberg-Marquardt factor a minimisation of a sample of `grains` grains starts with:
/// 1e-4 (`LAMBDA_START`), but no more than `1 / grains`. The factor shifts every row by its
/// share of the mean stiffness, which damps the sample's own softest modes as much as the
/// loose grains it is meant for: the longest wave across `n` grains has some `(pi / n)^2` of
/// a grain's stiffness, about `10 / grains`. Kept a tenth below that, the start leaves the
/// load's response to the first step: every sample up to 10,000 grains starts at 1e-4, a
/// million-grain one at 1e-6 (docs/minimise.md, "The Levenberg-Marquardt start below the
/// sample's longest wave, kept").
pub fn start_factor(grains: usize) -> f64 {
    LAMBDA_START.min(1.0 / grains.max(1) as f64)
}

/// Relative residual below which a lag that stops converging hands over to semi-smooth
/// Newton steps, and below which the worst grain is balanced on its own: after a bond breaks
/// the lag, refrozen at every step, can wander well above [`SEMISMOOTH_NEAR`] where the
/// consistent tangent's steps converge.
const SEMISMOOTH_BELOW: f64 = 1e-1;

/// Relative residual below which every step is a semi-smooth one: near the answer the
/// contacts' states have settled, and Newton on the true residual converges in a step or two
/// where the fixed point on the lag converges linearly.
const SEMISMOOTH_NEAR: f64 = 1e-3;

/// Share of the residual at which a semi-smooth step failed below which it is tried again:
/// where the consistent tangent is no better a model than the Hessian (an unstable packing's
/// softening, not the lag), its steps fail again and again, and the lagged descent alone
/// converges.
const RETRY_SHARE: f64 = 0.1;

/// A refreeze that multiplies the residual the lagged problem reached by more than this shows
/// the lag stalling (a wedged grain's normal force chasing its friction), and semi-smooth steps
/// may be tried again at once.
const LAG_JUMP: f64 = 2.0;

/// The lag is refrozen once a step has brought the residual of the lagged problem below this
/// share of the last true residual: the refrozen lag is a fixed-point iteration, and
/// refreezing after every step, whatever the lagged problem's own progress, can cycle.
const INNER: f64 = 0.1;

/// Relative residual below which the lag is held between refreezes ([`INNER`]). Above it the
/// lag is refrozen after every accepted step: there the normal forces change more over a step
/// than the lagged problem's own residual falls (a rearrangement, contacts made and lost, a
/// bond broken), and a lag held from an earlier iterate only drags the steps back towards it.
const HOLD_BELOW: f64 = 1e-3;

/// Iterations that may pass since the residual was last lowered to [`CYCLE_FALL`] of the
/// lowest it reached since it last jumped ([`FRESH_START`]) before a semi-smooth step hands
/// over to the lagged descent, until that has taken the residual a tenth below the lowest:
/// near a cluster of grains whose contacts slide (a packing close to a mechanism) the
/// consistent tangent's steps and the grains' own balances can cycle, each undoing the last,
/// where the lagged descent moves the cluster on to where it holds. Meanwhile a refreeze that
/// jumps does not call the semi-smooth steps back ([`LAG_JUMP`]), unless the residual has gone
/// [`FRESH_START`] times above that lowest: the descent then went elsewhere.
const CYCLE_STEPS: usize = 6;

/// Lagged steps after the semi-smooth steps were held off (a step of theirs failed, or they
/// cycled) without the residual lowered ([`CYCLE_FALL`]), after which they may be tried
/// again at once: where the lagged descent crawls too (a cluster whose contacts switch
/// between sticking and sliding from step to step, the lag held), waiting for it to go a
/// tenth below where they stopped can take hundreds of steps.
const LAG_PATIENCE: usize = 40;

/// Share of the lowest residual a step must reach for the residual to count as lowered
/// ([`CYCLE_STEPS`]): semi-smooth steps near their answer converge superlinearly, so steps
/// that creep (a rattler just closed on, its contacts at the edge of sliding, each step cut
/// to a hundredth and the residual falling a thousandth) cycle as much as steps that undo
/// each other.
const CYCLE_FALL: f64 = 0.5;

/// A residual this many times the lowest one counts as a new start (a contact made, a bond
/// broken, a refreeze that moved the limits), from which the lowest is counted again.
const FRESH_START: f64 = 10.0;

/// Steps the lag is held for at most: a lagged problem whose limits let a cluster slide (the
/// normal forces held where the true law would raise them, or a mechanism forming) has no
/// minimum near, and its descent would crawl on without the true residual ever being looked
/// at again.
const HOLD_STEPS: usize = 20;

/// Refreezes in a row that did not halve the true residual before semi-smooth Newton takes
/// over: the refrozen lag is a fixed-point iteration, and where a sliding contact's friction
/// drives it into itself (a grain wedged on a barely touching contact) it diverges.
const LAG_STALLS: usize = 2;

/// GMRES on the consistent tangent, preconditioned by the Cholesky of the Hessian: its
/// relative tolerance and its iterations at most.
const KRYLOV_TOLERANCE: f64 = 1e-3;
const KRYLOV_ITERATIONS: usize = 40;

/// Relative change of the potential below which round-off hides it: a step there is taken
/// when it lowers the residual instead.
const ROUNDOFF: f64 = 1e-12;

/// Relative residual below which a step is also taken where it lowers the residual by
/// Armijo's share: the residual is the potential's gradient only to within the turn of the
/// shear frame over the step, and near the answer the two tests can disagree (a Hertz patch
/// then cut every step of a grain whose contacts all stick).
const NEAR: f64 = 1e-4;

/// A semi-smooth step cut where a pair apart closes is taken while it at most multiplies the
/// residual by this: the closed pair's stiffness is in the next step's tangent (an active
/// set), so the residual may rise once on the way. Once: another such rise is taken only
/// after the residual has fallen below where the last one started, or a pair that closes
/// and opens again step after step cycles with the residual creeping up.
const CLOSING_RISE: f64 = 2.0;

/// Minimise from `u`; `u` holds the last iterate on return. `work` holds the vectors it
/// works in, of any size and contents: they are made the system's.
pub fn minimise(
    eq: &mut dyn Potential,
    matrix: SystemMatrix<'_>,
    linear: &mut LinearSolver,
    u: &mut [f64],
    settings: &MinimiseSettings,
    work: &mut MinimiseWork,
    stats: &mut SolverStats,
) -> Result<MinimiseOutcome, NumericError> {
    let n = u.len();
    let SystemMatrix {
        symbolic,
        values,
        diagonal,
    } = matrix;
    let MinimiseWork {
        residual,
        trial_residual,
        du,
        trial_u,
        loads,
        shift,
        row_cursors,
        gmres,
    } = work;
    for v in [
        &mut *residual,
        &mut *trial_residual,
        &mut *du,
        &mut *trial_u,
        &mut *loads,
        &mut *shift,
    ] {
        v.clear();
        v.resize(n, 0.0);
    }

    let mut energy = eq.evaluate(u, residual, Some(values), true)?;
    let (mut rel, mut worst, mut merit) = eq.residual_norm(residual);
    let mut true_merit = merit;
    let mut out = MinimiseOutcome {
        history: vec![rel],
        ..Default::default()
    };
    if eq.needs_new_pattern() {
        out.at_reach = true;
    }
    // Levenberg-Marquardt factor, raised after steps the line search had to cut hard and
    // lowered after full ones: it costs no factorisation of its own.
    let mut lambda = settings.lambda_start;
    let mut frozen = true;
    // Accepted steps since the lag was last refrozen.
    let mut held = 0usize;
    // Semi-smooth Newton: on once the lag stalls, off again where its step fails, and tried
    // again only once the lagged descent has taken the residual a tenth further down.
    let (mut semismooth, mut stalls) = (false, 0usize);
    let mut semismooth_below = f64::INFINITY;
    // The iteration at which the semi-smooth steps were last held off below a residual.
    let mut held_off_at = 0usize;
    // Where the last semi-smooth step that raised the residual at a closing pair started.
    let mut rise_from = f64::INFINITY;
    // The lowest residual since the last new start and the iteration that reached it; whether
    // the semi-smooth steps cycled and wait for the lagged descent to go a tenth below it.
    let mut lowest = (rel, 0usize);
    let mut cycled = false;
    // The grain last moved to its own equilibrium, with the states of its contacts there.
    let mut balanced: (usize, Vec<u8>) = (usize::MAX, Vec::new());
    // The grain the lagged descent last balanced, and the residual's 2-norm it left.
    let mut last_balance = (usize::MAX, f64::INFINITY);
    // Whether the linear solver holds a factor of a Hessian of this minimisation.
    let mut factored = false;
    // Whether the residual is the law's own: the lag refrozen twice at this iterate.
    let mut confirmed = false;
    while !out.at_reach && !out.changed {
        if rel <= settings.tolerance {
            if confirmed {
                out.converged = true;
                break;
            }
            // Met with the lag held, or on a refreeze that relaxed a limit towards `f N`
            // (`Lag::refrozen_limit`): refreeze here, and once more if it was refrozen here
            // already, where the lag then takes `f N` and `k_s` as they are, relaxing nothing,
            // and test that, the true residual.
            // The second refreeze makes the Hessian anew: where it does not confirm, the next
            // step is taken on the lag it took.
            confirmed = frozen;
            (energy, (rel, worst, merit)) = refrozen(eq, u, residual, values)?;
            true_merit = merit;
            frozen = true;
            match out.history.last_mut() {
                // The same iterate's residual, as the law gives it.
                Some(last) if confirmed => *last = rel,
                _ => out.history.push(rel),
            }
            if eq.needs_new_pattern() {
                out.at_reach = true;
                break;
            }
            continue;
        }
        confirmed = false;
        if out.iterations >= settings.max_iterations {
            break;
        }
        out.iterations += 1;
        stats.counters.newton_iterations += 1;

        // Direction: the projected Hessian, regularised only where a row has no stiffness.
        // A semi-smooth step needs its factor only as GMRES's preconditioner, and the factor
        // of an earlier iterate of this minimisation serves there: near the answer the
        // Hessian changes little from step to step.
        let stale = semismooth && factored;
        // The first step solves with the tangent at the last equilibrium where the stability
        // indicator left its factor, positive definite: a Newton step made without a
        // factorisation of its own, and without the Levenberg-Marquardt shift, there being no
        // soft mode to hold back. Any later step factorises its own Hessian.
        let on_tangent = out.iterations == 1 && linear.holds_tangent();
        let lm = lambda.max(settings.lambda_min);
        if !stale && !on_tangent {
            let a = SparseColMatRef::new(symbolic.as_ref(), values);
            let made = factorize_hessian(eq, a, diagonal, lm, shift, linear, stats);
            factored = made.is_ok();
            if let Err(e) = made {
                if lambda >= 1e6 {
                    return Err(NumericError::Singular { detail: e.0 });
                }
                lambda = (10.0 * lambda).max(1e-6);
                continue;
            }
        }
        if semismooth {
            // The consistent tangent's Newton step by GMRES, preconditioned by the last
            // Cholesky of the Hessian, and a line search on the true residual.
            // The consistent tangent is regularised as the Hessian is (`regularise` with the
            // present Levenberg-Marquardt factor: its share on every row, and the floor of rows
            // with no stiffness). A grain whose contacts all slide has no stiffness along its
            // turn in either, its contacts' forces not depending on it: unregularised, the step
            // turns it without bound and no share of the step lowers the residual
            // (docs/minimise.md, "The semi-smooth step regularised as the Hessian is, kept").
            // The share falls tenfold after each step taken; the floor stays.
            regularise(eq, values, diagonal, lm, shift);
            // The consistent tangent takes the Hessian's storage (503 MB at a million grains).
            // With an earlier iterate's factor, this iterate's Hessian, regularised the same
            // way, is first taken into the factor's order: a fresh factor of it where the
            // earlier one fails GMRES.
            if stale {
                linear
                    .stage(values, shift)
                    .map_err(|e| NumericError::Singular { detail: e.0 })?;
            }
            eq.consistent_tangent(u, residual, values)?;
            (rel, worst, merit) = eq.residual_norm(residual);
            true_merit = merit;
            frozen = true;
            if rel <= settings.tolerance {
                continue;
            }
            krylov::to_rows_in_place(symbolic, values, row_cursors);
            let mut solve = |linear: &mut LinearSolver, du: &mut [f64], stats: &mut SolverStats| {
                du.fill(0.0);
                gmres.solve(
                    &mut |v, out| {
                        krylov::multiply_by_rows(symbolic, values, v, out);
                        for ((o, r), x) in out.iter_mut().zip(shift.iter()).zip(v) {
                            *o += r * x;
                        }
                    },
                    &mut |v| linear.solve_in_place(v, stats),
                    residual,
                    du,
                    KRYLOV_TOLERANCE,
                    KRYLOV_ITERATIONS,
                )
            };
            let mut solved = solve(linear, du, stats);
            if solved.is_none() && stale {
                // The earlier factor no longer serves: this iterate's Hessian may.
                factored = linear.factorize_staged(stats).is_ok();
                if factored {
                    solved = solve(linear, du, stats);
                }
            }
            if solved.is_none() {
                // The Hessian is no preconditioner of the consistent tangent here: back to
                // the lagged minimisation.
                (semismooth, stalls) = (false, 0);
                semismooth_below = RETRY_SHARE * rel;
                held_off_at = out.iterations;
                (energy, (rel, worst, merit)) = refrozen(eq, u, residual, values)?;
                true_merit = merit;
                continue;
            }
            // A contact closing within the step has none of its stiffness in the tangent:
            // the step stops where it closes, and the next one has it (an active set).
            let reach = eq.reach(u, du);
            let closing = eq.closing(u, du);
            let mut alpha = reach.min(closing);
            let first = alpha;
            let accepted = loop {
                for k in 0..n {
                    trial_u[k] = u[k] + alpha * du[k];
                }
                eq.evaluate(trial_u, trial_residual, None, true)?;
                let (_, _, t_merit) = eq.residual_norm(trial_residual);
                if t_merit <= (1.0 - ARMIJO * alpha) * merit {
                    break true;
                }
                let closes = alpha == first && closing < reach;
                if closes && t_merit < CLOSING_RISE * merit && merit < rise_from {
                    rise_from = merit;
                    break true;
                }
                if alpha < 1.0 / 64.0 {
                    break false;
                }
                alpha *= 0.5;
            };
            if accepted {
                u.copy_from_slice(trial_u);
                out.changed |= eq.place_loose(u);
                lambda *= 0.1;
            } else {
                // Back to the lagged minimisation, regularised harder.
                semismooth = false;
                semismooth_below = RETRY_SHARE * rel;
                held_off_at = out.iterations;
                lambda = (100.0 * lambda).max(1e-4);
            }
            (energy, (rel, worst, merit)) = refrozen(eq, u, residual, values)?;
            true_merit = merit;
            if balance_worst(eq, u, residual, rel, worst, settings, &mut balanced) {
                (energy, (rel, worst, merit)) = refrozen(eq, u, residual, values)?;
                true_merit = merit;
            }
            out.history.push(rel);
            lowest = lowest_since_start(lowest, rel, out.iterations);
            if out.iterations - lowest.1 >= CYCLE_STEPS {
                (semismooth, cycled) = (false, true);
                semismooth_below = RETRY_SHARE * lowest.0;
                held_off_at = out.iterations;
            }
            if eq.needs_new_pattern() || (accepted && alpha == reach && reach < 1.0) {
                out.at_reach = true;
            }
            continue;
        }
        du.copy_from_slice(residual);
        linear.solve_in_place(du, stats);
        if du.iter().any(|v| !v.is_finite()) {
            return Err(NumericError::NotFinite {
                what: "Newton step",
                place: format!("iteration {}", out.iterations),
            });
        }

        // Armijo backtracking on the potential, from no further than the lists reach.
        let slope = -dot(residual, du);
        if slope >= 0.0 {
            // Round-off left a (nearly) singular step that does not descend: regularise.
            lambda = (100.0 * lambda).max(1e-4);
            continue;
        }
        let reach = eq.reach(u, du);
        let mut alpha = reach;
        loads.copy_from_slice(eq.loads());
        let scale = energy.abs() + dot(loads, u).abs();
        // Whether the step taken changed the potential by no more than round-off.
        let mut flat = false;
        let accepted = loop {
            for k in 0..n {
                trial_u[k] = u[k] + alpha * du[k];
            }
            let trial_energy = eq.evaluate(trial_u, trial_residual, None, false)?;
            let work: f64 = 0.5
                * alpha
                * eq.loads()
                    .iter()
                    .zip(loads.iter())
                    .zip(du.iter())
                    .map(|((a, b), d)| (a + b) * d)
                    .sum::<f64>();
            let fall = trial_energy - energy - work;
            let (t_rel, _, t_merit) = eq.residual_norm(trial_residual);
            let armijo = fall <= ARMIJO * alpha * slope;
            let hidden = fall.abs() <= ROUNDOFF * scale && t_merit < merit;
            let near = rel < NEAR && t_merit <= (1.0 - ARMIJO * alpha) * merit;
            if fall.is_finite() && (armijo || hidden || near || t_rel <= settings.tolerance) {
                flat = fall.abs() <= ROUNDOFF * scale;
                break Some(t_merit);
            }
            if alpha < MIN_STEP {
                break None;
            }
            // The minimum of the quadratic through the slope and the fall, within [0.1, 0.5].
            let quadratic = -slope * alpha * alpha / (2.0 * (fall - slope * alpha));
            alpha = quadratic.clamp(0.1 * alpha, 0.5 * alpha);
        };
        let Some(trial_merit) = accepted else {
            if !frozen {
                // The lagged potential is as low as round-off lets it go: refreeze.
                (energy, (rel, worst, merit)) = refrozen(eq, u, residual, values)?;
                stalls = lag_stalls(stalls, merit, true_merit);
                true_merit = merit;
                frozen = true;
                out.history.push(rel);
                continue;
            }
            // No descent along a Newton direction: near round-off, or a Hessian far from the
            // potential's curvature. Regularise harder and try again from here.
            if lambda >= 1e6 {
                break;
            }
            lambda = (100.0 * lambda).max(1e-4);
            continue;
        };
        lambda = if alpha >= 0.5 * reach {
            0.1 * lambda
        } else {
            (10.0 * lambda).max(1e-6)
        };
        u.copy_from_slice(trial_u);
        if eq.place_loose(u) {
            out.changed = true;
            break;
        }
        eq.balance_rotations(u);
        // Far from the answer, refreeze after every step. Near it, refreeze once the lagged
        // problem is solved well enough (an inexact inner solve of the fixed point on the
        // lag), or as far as round-off lets its potential fall (at a kink of a friction
        // potential the gradient need not vanish); hold the lag until then.
        held = if frozen { 1 } else { held + 1 };
        frozen =
            trial_merit <= INNER * true_merit || flat || rel > HOLD_BELOW || held >= HOLD_STEPS;
        energy = eq.evaluate(u, residual, Some(values), frozen)?;
        (rel, worst, merit) = eq.residual_norm(residual);
        if frozen {
            let stalls_before = stalls;
            stalls = lag_stalls(stalls, merit, true_merit);
            true_merit = merit;
            if merit > LAG_JUMP * trial_merit && !cycled {
                // The lag, not the model, is what stalls: semi-smooth steps are for that.
                semismooth_below = f64::INFINITY;
            }
            let grain = worst;
            if balance_worst(eq, u, residual, rel, worst, settings, &mut balanced) {
                (energy, (rel, worst, merit)) = refrozen(eq, u, residual, values)?;
                true_merit = merit;
                // The same grain balanced again, the residual left above where its last
                // balance left it: the step and the balance undo each other, and the lag
                // stalls however much each step lowers the residual the balance raised.
                if last_balance.0 == grain && merit > last_balance.1 {
                    stalls = stalls_before + 1;
                }
                last_balance = (grain, merit);
            }
        }
        semismooth = (rel < SEMISMOOTH_NEAR || (stalls >= LAG_STALLS && rel < SEMISMOOTH_BELOW))
            && rel < semismooth_below;
        cycled &= !semismooth;
        if cycled && rel > FRESH_START * lowest.0 {
            // The lagged descent took the residual far from the cycle's: the cycle is behind
            // it, and the semi-smooth steps may come back as before.
            cycled = false;
            semismooth_below = f64::INFINITY;
        }
        lowest = lowest_since_start(lowest, rel, out.iterations);
        if semismooth_below.is_finite()
            && out.iterations - held_off_at.max(lowest.1) >= LAG_PATIENCE
        {
            // The lagged descent has not done what the semi-smooth steps wait for.
            cycled = false;
            semismooth_below = f64::INFINITY;
        }
        out.history.push(rel);
        if eq.needs_new_pattern() || (alpha == reach && reach < 1.0) {
            out.at_reach = true;
        }
        if rel > settings.tolerance {
            out.runaway = eq.runaway(u);
            if !out.runaway.is_empty() {
                break;
            }
        }
    }
    out.residual = rel;
    out.worst_grain = worst;
    out.lambda = lambda;
    Ok(out)
}

/// Nonlinear elimination of the grain the global step leaves worst (method note, "One load
/// increment"): while the residual is below [`SEMISMOOTH_BELOW`], after every refreeze that
/// grain is moved to its exact equilibrium with the rest held ([`Potential::balance_grain`]),
/// from the states its contacts had when it was last balanced. The global step cannot resolve
/// a grain whose contacts sit on the edge of sticking, sliding or touching; the next global
/// step starts from where the grain is balanced. The loosely held grains that touch it are
/// balanced first ([`Potential::loose_neighbours`]): the worst grain's residual is often
/// theirs, the force of a rattler it touches whose sliding contact's limit the lag moves at
/// every refreeze, and balancing the worst grain alone moves the wrong one. Returns whether
/// any moved.
fn balance_worst(
    eq: &mut dyn Potential,
    u: &mut [f64],
    residual: &[f64],
    rel: f64,
    worst: usize,
    settings: &MinimiseSettings,
    balanced: &mut (usize, Vec<u8>),
) -> bool {
    if rel >= SEMISMOOTH_BELOW || rel <= settings.tolerance {
        return false;
    }
    if balanced.0 != worst {
        *balanced = (worst, Vec::new());
    }
    let mut moved = false;
    for grain in eq.loose_neighbours(worst) {
        moved |= eq.balance_grain(u, residual, grain, &mut Vec::new());
    }
    eq.balance_grain(u, residual, worst, &mut balanced.1) || moved
}

/// Factorise the Hessian `a`, regularised (see [`regularise`]) with the Levenberg-Marquardt
/// factor `lambda`; `shift` takes the regularisation.
fn factorize_hessian(
    eq: &dyn Potential,
    a: SparseColMatRef<'_, u32, f64>,
    diagonal: &[usize],
    lambda: f64,
    shift: &mut [f64],
    linear: &mut LinearSolver,
    stats: &mut SolverStats,
) -> Result<(), NotFactorizable> {
    regularise(eq, a.val(), diagonal, lambda, shift);
    linear.factorize_shifted(a, shift, stats)
}

/// Evaluate at `u` on a lag refrozen there: the stored energy and the residual's norms.
fn refrozen(
    eq: &mut dyn Potential,
    u: &[f64],
    residual: &mut [f64],
    values: &mut [f64],
) -> Result<(f64, (f64, usize, f64)), NumericError> {
    let energy = eq.evaluate(u, residual, Some(values), true)?;
    Ok((energy, eq.residual_norm(residual)))
}

/// The lowest residual since the last new start ([`FRESH_START`]) and the iteration that
/// reached it, after iteration `iteration` left the residual at `rel`; a residual counts as
/// lower only [`CYCLE_FALL`] below it.
fn lowest_since_start(lowest: (f64, usize), rel: f64, iteration: usize) -> (f64, usize) {
    if rel < CYCLE_FALL * lowest.0 || rel > FRESH_START * lowest.0 {
        (rel, iteration)
    } else {
        lowest
    }
}

/// Refreezes in a row that did not halve the true residual (from `before` to `merit`): the
/// lag stalls.
fn lag_stalls(stalls: usize, merit: f64, before: f64) -> usize {
    if merit > 0.5 * before {
        stalls + 1
    } else {
        0
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// What `K + lambda k U` adds to each diagonal entry of `K` into `shift`, `k` the mean
/// diagonal stiffness of the rows that have one and `U` the units of the rows; a row with
/// less than `WEAK_ROW k u_i` gets that much more, and a floppy rotation its floor
/// (`FLOPPY_ROTATION`). The linear solver adds it as it takes `K` in.
pub fn regularise(
    eq: &dyn Potential,
    values: &[f64],
    diagonal: &[usize],
    lambda: f64,
    shift: &mut [f64],
) {
    let (mut sum, mut count) = (0.0, 0usize);
    for (dof, &s) in diagonal.iter().enumerate() {
        if values[s] > 0.0 {
            sum += values[s] / eq.unit_stiffness(dof);
            count += 1;
        }
    }
    let k = if count > 0 {
        sum / count as f64
    } else {
        eq.stiffness_hint()
    };
    for (dof, &s) in diagonal.iter().enumerate() {
        let unit = k * eq.unit_stiffness(dof);
        let floor = match eq.rotation_of(dof) {
            Some([x, y]) => {
                let translation = 0.5 * (values[diagonal[x]] + values[diagonal[y]]);
                (FLOPPY_ROTATION * translation * eq.unit_stiffness(dof)).max(WEAK_ROW * unit)
            }
            None => WEAK_ROW * unit,
        };
        shift[dof] = lambda * unit + (floor - values[s]).max(0.0);
    }
}
