//! Newton's method on `R(u) = 0` for all unknowns at once, with backtracking line search on
//! `|R|` and Levenberg-Marquardt regularisation of the step (`K + lambda D`, `D` the diagonal of
//! `K` with a floor) for singular or indefinite tangents: rattlers, free rotations,
//! just-touching Hertz contacts, buckling force chains. The regularisation changes the path,
//! never the converged answer.
//!
//! Newton knows neither the physics (the [`Equations`]) nor how the linear systems are solved
//! beyond the [`LinearSolver`] contract.

use super::config::LinearKind;
use super::krylov;
use super::linear::LinearSolver;
use super::stats::SolverStats;
use crate::NumericError;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};

/// A system of equations `R(u) = 0` with its tangent `K = -dR/du` in a fixed pattern.
pub trait Equations {
    /// Evaluate `R(u)` into `residual` and, when given, the tangent into `tangent` (the values
    /// of the fixed pattern, already zeroed by the callee).
    fn evaluate(
        &mut self,
        u: &[f64],
        residual: &mut [f64],
        tangent: Option<&mut [f64]>,
    ) -> Result<(), NumericError>;

    /// Convergence measure of a residual: `(|R|_inf / F_ref, worst grain, |R|_2 / F_ref)`.
    fn residual_norm(&self, residual: &[f64]) -> (f64, usize, f64);

    /// Size of a step in mean radii (rotations times the mean radius).
    fn step_norm(&self, du: &[f64]) -> f64;

    /// How the stiffness of each unknown scales: 1 for a translation, `r^2` for a rotation,
    /// so one stiffness scale serves every row of the regularisation.
    fn unit_stiffness(&self, dof: usize) -> f64;

    /// A stiffness to regularise with when the tangent has none at all (a Hertz sample whose
    /// contacts just touch).
    fn stiffness_hint(&self) -> f64;

    /// Whether the iterate is still far from the answer: the equations may then offer a
    /// stiffer tangent where theirs vanishes (only the path changes, not the answer).
    fn set_far(&mut self, far: bool);

    /// The fraction of the step `du` from `u` after which the first pair of surfaces that is
    /// apart now has closed to a small overlap (1 when none closes that far within the step).
    fn closing_fraction(&mut self, u: &[f64], du: &[f64]) -> f64;

    /// After a step that stopped where a gap closed: make a contact of every pair that is
    /// apart in the contact set but overlaps at `u`, and let the boundaries follow. Returns how
    /// many contacts were made, or `None` when the topology must be rebuilt before Newton can
    /// go on (nothing then changed).
    fn close_gaps(&mut self, u: &[f64]) -> Option<usize>;
}

/// Settings of one Newton solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonSettings {
    /// `|R|_inf <= tolerance * F_ref`.
    pub tolerance: f64,
    /// `|du|_inf <= displacement_tolerance * r_mean`.
    pub displacement_tolerance: f64,
    /// Iterations allowed.
    pub max_iterations: usize,
    /// Backtrack when a full step increases `|R|`.
    pub line_search: bool,
    /// Smallest regularisation factor.
    pub lambda_min: f64,
    /// For linear scenes, where the tangent changes only where contacts slip, crack or
    /// open: keep a Cholesky factorisation while it contracts the residual well (chord
    /// steps), and an LU as GMRES's preconditioner while GMRES converges in a few solves.
    pub reuse_factorisation: bool,
    /// Largest step, in mean radii: the trust radius never exceeds it, so no grain jumps past
    /// contacts its friends lists cannot see.
    pub max_step: f64,
    /// Trust radius at the start, in mean radii (about the contact overlaps).
    pub initial_trust: f64,
}

/// How a Newton solve ended.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct NewtonOutcome {
    /// Whether both tolerances were met.
    pub converged: bool,
    /// Iterations made.
    pub iterations: usize,
    /// Final relative residual.
    pub residual: f64,
    /// Final step norm (mean radii).
    pub step: f64,
    /// Grain with the largest residual.
    pub worst_grain: usize,
    /// Relative residual after each iteration (the first entry: before any step).
    pub history: Vec<f64>,
    /// Converged with the residual at its round-off floor: no step reduced it, and the Newton
    /// step was already below the displacement tolerance.
    pub at_roundoff: bool,
    /// Stopped where a step would take a grain out of the friends lists' reach, or closed a
    /// gap that the topology must be rebuilt for: that is done before Newton goes on.
    pub at_reach: bool,
    /// Contacts made where steps closed gaps.
    pub contacts_made: usize,
    /// Trust radius at the end, for the next pass of the same increment to start from.
    pub trust: f64,
}

/// The matrix of the Newton systems: a fixed pattern, its values, and its diagonal slots.
pub struct SystemMatrix<'a> {
    /// Pattern (full storage).
    pub symbolic: &'a SymbolicSparseColMat<usize>,
    /// Values of the tangent, filled by [`Equations::evaluate`].
    pub values: &'a mut Vec<f64>,
    /// Value index of each diagonal entry.
    pub diagonal: &'a [usize],
}

/// Relative residual above which the iterate counts as far from the answer.
const FAR: f64 = 1e-2;

/// Regularisation while creeping. A grain on a mechanism (rolling round its one support under
/// a membrane's push, sliding freely) has no equilibrium until it meets its next neighbour,
/// and no step along that path lowers |R|: the line search stalls. Creeping takes the
/// regularised step whatever |R| does, like a pseudo-time step: the stiff part of
/// the system is solved, the free part moves a bounded way (at most the largest step), until
/// a gap closes or |R| falls.
const CREEP_LAMBDA: f64 = 1e-3;

/// Slow steps in a row after which Newton creeps.
const STALL_ITERATIONS: usize = 3;

/// Relative residual below which a residual no step lowers counts as round-off. Above it a
/// short step that lowers nothing is a kink of the equations (a contact at its slip limit
/// or tension cut-off, a membrane chain changing), not the answer: with a displacement
/// tolerance of 1e-6 radii, steps that short stopped a 10,000-grain annulus at 8e-2.
const ROUNDOFF_RESIDUAL: f64 = 1e-8;

/// Relative linear residual `|R - K du| / |R|` at which GMRES's step counts as Newton's.
const KRYLOV_TOLERANCE: f64 = 1e-6;

/// GMRES iterations, each a solve with the kept LU factorisation, before the LU is made
/// anew: on the 10,000-grain annulus an LU factorisation costs about sixteen of its solves.
/// GMRES's steps are Newton's, so the LU takes no chord steps. A Cholesky costs about three
/// of its solves: it takes chord steps and is made anew where they stop contracting.
const KRYLOV_ITERATIONS: usize = 16;

/// Solve `R(u) = 0` starting from `u`; `u` holds the last iterate on return.
pub fn solve(
    eq: &mut dyn Equations,
    matrix: SystemMatrix<'_>,
    linear: &mut LinearSolver,
    u: &mut [f64],
    settings: &NewtonSettings,
    stats: &mut SolverStats,
) -> Result<NewtonOutcome, NumericError> {
    let n = u.len();
    let SystemMatrix {
        symbolic,
        values,
        diagonal,
    } = matrix;
    let mut residual = vec![0.0; n];
    let mut trial_residual = vec![0.0; n];
    let mut trial_values = vec![0.0; values.len()];
    let mut du = vec![0.0; n];
    let mut trial_u = vec![0.0; n];
    let mut gmres = krylov::Gmres::default();

    // The start counts as far until the first residual says otherwise.
    eq.set_far(true);
    eq.evaluate(u, &mut residual, Some(values))?;
    let (mut rel, mut worst, mut merit) = eq.residual_norm(&residual);
    if rel <= FAR {
        eq.set_far(false);
        eq.evaluate(u, &mut residual, Some(values))?;
    }
    let mut out = NewtonOutcome {
        history: vec![rel],
        ..Default::default()
    };
    let mut lambda = 0.0f64;
    let mut trust = settings.initial_trust.min(settings.max_step);
    // Creeping (see `CREEP_LAMBDA`) starts after `STALL_ITERATIONS` steps in a row that each
    // took off less than a tenth of |R| though no growing trust radius held them back, and
    // ends once |R| has halved.
    let (mut creep_from, mut slow) = (None::<f64>, 0usize);
    let mut last_step = 0.0;
    // A factorisation kept from an earlier solve is trusted only as a chord.
    let mut fresh_factor = false;
    // A kept LU takes no chord steps: GMRES solves with it (see `KRYLOV_ITERATIONS`).
    let chords = settings.reuse_factorisation && linear.kind() == LinearKind::Cholesky;
    let mut chord = chords && linear.is_factorized();

    for iteration in 1..=settings.max_iterations {
        if rel <= settings.tolerance && last_step <= settings.displacement_tolerance {
            out.converged = true;
            break;
        }
        out.iterations = iteration;
        stats.counters.newton_iterations += 1;
        eq.set_far(rel > FAR);

        let mut accepted = false;
        let mut closed = false;
        let merit_before = merit;
        // Whether the accepted step was held back by a trust radius still growing: slow
        // then, but not stalled.
        let mut growing = false;
        if creep_from.is_some() {
            chord = false;
            lambda = lambda.max(CREEP_LAMBDA);
        }
        for _attempt in 0..12 {
            // Direction: K du = R, with the chord factorisation or a fresh, regularised one.
            // A kept LU solves the fresh system by GMRES when it can do so in a few solves.
            let mut solved = false;
            if chord {
                stats.counters.factorisations_reused += 1;
            } else {
                let regularised = regularise(eq, values, diagonal, lambda.max(settings.lambda_min));
                solved = settings.reuse_factorisation
                    && linear.kind() == LinearKind::Lu
                    && linear.is_factorized()
                    && gmres
                        .solve(
                            &mut |v, out| krylov::multiply(symbolic, &regularised, v, out),
                            &mut |v| linear.solve_in_place(v, stats),
                            &residual,
                            &mut du,
                            KRYLOV_TOLERANCE,
                            KRYLOV_ITERATIONS,
                        )
                        .is_some();
                if solved {
                    stats.counters.factorisations_reused += 1;
                } else {
                    let a = SparseColMatRef::new(symbolic.as_ref(), &regularised);
                    if linear.factorize(a, stats).is_err() {
                        lambda = (lambda * 100.0).max(1e-8);
                        if lambda > 1e6 {
                            return Err(NumericError::Singular {
                                detail: format!("no factorisation up to lambda = {lambda:.1e}"),
                            });
                        }
                        continue;
                    }
                    fresh_factor = true;
                }
            }
            if !solved {
                du.copy_from_slice(&residual);
                linear.solve_in_place(&mut du, stats);
            }
            if du.iter().any(|v| !v.is_finite()) {
                chord = false;
                lambda = (lambda * 100.0).max(1e-8);
                continue;
            }

            // Trust region: a step longer than the trust radius is truncated to it (thesis
            // 2.4, 'truncate'). The radius starts at the scale of contact overlaps, grows
            // while full steps succeed and shrinks to what the line search accepted.
            let length = eq.step_norm(&du);
            let limit = if creep_from.is_some() {
                settings.max_step
            } else {
                trust
            };
            let truncated = length > limit;
            if truncated {
                let shrink = limit / length;
                du.iter_mut().for_each(|d| *d *= shrink);
            }
            // A step that closes a gap stops where it closes: that much of the step is taken
            // whatever the residual does, and the contact is made before Newton goes on, so
            // grains do not pass through each other. A step that would leave the lists' reach
            // stops there too, and the pass ends for them to be made anew.
            let fraction = eq.closing_fraction(u, &du);
            if fraction < 1.0 {
                for k in 0..n {
                    u[k] += fraction * du[k];
                }
                let made = eq.close_gaps(u).unwrap_or(0);
                out.contacts_made += made;
                eq.evaluate(u, &mut residual, Some(values))?;
                (rel, worst, merit) = eq.residual_norm(&residual);
                last_step = fraction * eq.step_norm(&du);
                closed = made > 0;
                out.at_reach = !closed;
                break;
            }
            // Line search on |R|_2: halve the step while it does not decrease enough.
            let mut alpha = 1.0;
            loop {
                for k in 0..n {
                    trial_u[k] = u[k] + alpha * du[k];
                }
                eq.evaluate(&trial_u, &mut trial_residual, Some(&mut trial_values))?;
                let (t_rel, t_worst, t_merit) = eq.residual_norm(&trial_residual);
                let good = t_merit.is_finite()
                    && (t_merit <= (1.0 - 1e-4 * alpha) * merit || t_rel <= settings.tolerance);
                // A chord step must also contract well, or the tangent is refreshed.
                let contracts = !chord || t_merit <= 0.25 * merit || t_rel <= settings.tolerance;
                if (good && contracts) || (creep_from.is_some() && t_merit.is_finite()) {
                    u.copy_from_slice(&trial_u);
                    std::mem::swap(&mut residual, &mut trial_residual);
                    std::mem::swap(values, &mut trial_values);
                    (rel, worst, merit) = (t_rel, t_worst, t_merit);
                    last_step = alpha * eq.step_norm(&du);
                    accepted = true;
                    break;
                }
                if chord || !settings.line_search || alpha < 1.0 / 64.0 {
                    break;
                }
                alpha *= 0.5;
            }
            if accepted {
                growing = truncated && limit < settings.max_step;
                if alpha == 1.0 {
                    lambda *= 0.1;
                    if lambda < settings.lambda_min {
                        lambda = 0.0;
                    }
                    if truncated {
                        trust = (2.0 * trust).min(settings.max_step);
                    }
                } else if truncated {
                    // The trust region was the limit, and still too long a step.
                    trust = (alpha * trust).max(1e-12);
                }
                break;
            }
            // No acceptable step along this direction. When even the fresh, unregularised step is
            // below the displacement tolerance and the residual is small, it is at its round-off
            // floor.
            if !chord
                && lambda == 0.0
                && rel <= ROUNDOFF_RESIDUAL
                && eq.step_norm(&du) <= settings.displacement_tolerance
            {
                out.at_roundoff = true;
                break;
            }
            // Otherwise refresh the tangent, then regularise.
            if chord {
                chord = false;
            } else {
                lambda = (lambda * 10.0).max(1e-6);
            }
        }
        if out.at_roundoff {
            out.converged = true;
            break;
        }
        if out.at_reach {
            out.history.push(rel);
            break;
        }
        if closed {
            // New contacts: a new tangent, and the stall count starts again.
            out.history.push(rel);
            (chord, slow) = (false, 0);
            continue;
        }
        if !accepted {
            break;
        }
        match creep_from {
            Some(start) if merit <= 0.5 * start => {
                creep_from = None;
                lambda = 0.0;
                trust = settings.max_step;
                fresh_factor = false;
            }
            Some(_) => {}
            None => {
                slow = if merit > 0.9 * merit_before && !growing {
                    slow + 1
                } else {
                    0
                };
                if slow >= STALL_ITERATIONS {
                    creep_from = Some(merit);
                    slow = 0;
                }
            }
        }
        chord = chords && fresh_factor;
        out.history.push(rel);
    }
    if !out.converged
        && !out.at_reach
        && rel <= settings.tolerance
        && last_step <= settings.displacement_tolerance
    {
        out.converged = true;
    }
    out.residual = rel;
    out.trust = trust;
    out.step = last_step;
    out.worst_grain = worst;
    Ok(out)
}

/// `K + lambda D` with `D_ii = max(|K_ii|, k u_i)`, `k` the mean stiffness of the rows that
/// have one and `u_i` the unit of row `i`. A row without stiffness (a rattler, a rotation with
/// only frictionless contacts, a just-touching Hertz contact) also gets `1e-6 k u_i`: its
/// residual is zero or its step is truncated, so the answer does not change.
pub(crate) fn regularise(
    eq: &dyn Equations,
    values: &[f64],
    diagonal: &[usize],
    lambda: f64,
) -> Vec<f64> {
    let mut out = values.to_vec();
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
        out[s] +=
            lambda * values[s].abs().max(unit) + if values[s] <= 0.0 { 1e-6 * unit } else { 0.0 };
    }
    out
}
