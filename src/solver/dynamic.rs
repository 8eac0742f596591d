//! Settling an increment that has no equilibrium near the last one: explicit damped dynamics
//! on the increment's own equations, as PFC and Yade relax a sample, until the grains are
//! near rest again; Newton then finds the equilibrium exactly from there.
//!
//! A sample at a limit point has none: a force chain buckles, a grain that lost a support
//! rolls to its next, a crack runs through a bond after bond. However small the load step,
//! the next equilibrium lies a finite way off, and the path there is dynamic. The masses are
//! fictitious (Underwood's dynamic relaxation): each unknown's mass is the absolute sum of
//! its column of the tangent, which bounds the highest frequency by Gershgorin so that a time
//! step of one is stable; only the state at rest matters. FIRE (Bitzek et al. 2006) damps it:
//! the velocity is turned towards the force while the power is positive and stopped when
//! it turns negative, which finds the nearest rest far faster than viscous damping.

use super::newton::{Equations, NewtonOutcome, SystemMatrix};
use super::stats::{secs, SolverStats};
use crate::NumericError;
use std::time::Instant;

/// Settings of one settling run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SettleSettings {
    /// Stop when the relative residual is below this: near enough for Newton.
    pub tolerance: f64,
    /// Explicit steps allowed.
    pub steps: usize,
    /// Largest move of an unknown in one step, in mean radii.
    pub max_step: f64,
}

/// FIRE's mixing factor at the start and its decay per step while the power stays positive.
const ALPHA_START: f64 = 0.1;
const ALPHA_DECAY: f64 = 0.99;
/// Steps with positive power before the mixing starts to decay.
const DELAY: usize = 5;
/// Steps between refreshing the masses from the tangent (Hertz contacts stiffen as they
/// close, and contacts are made).
const MASS_REFRESH: usize = 100;

/// Run explicit damped dynamics from `u` until the residual is below the tolerance, a gap
/// closes that needs new friends lists, or the steps are spent. The outcome's `at_reach`
/// says the lists must be made anew before going on; `iterations` counts explicit steps.
pub fn settle<E: Equations>(
    eq: &mut E,
    matrix: SystemMatrix,
    u: &mut [f64],
    settings: &SettleSettings,
    stats: &mut SolverStats,
) -> Result<NewtonOutcome, NumericError> {
    let start = Instant::now();
    let n = u.len();
    let mut residual = vec![0.0; n];
    let mut mass = vec![0.0; n];
    let mut velocity = vec![0.0; n];
    let mut out = NewtonOutcome {
        converged: false,
        iterations: 0,
        residual: f64::INFINITY,
        step: 0.0,
        worst_grain: 0,
        history: Vec::new(),
        at_roundoff: false,
        at_reach: false,
        contacts_made: 0,
        trust: settings.max_step,
    };
    let mut alpha = ALPHA_START;
    let mut positive = 0;
    // The stiffness floor of contacts that carry little makes the masses safe; it changes
    // no force.
    eq.set_far(true);
    for step in 0..=settings.steps {
        let refresh = step % MASS_REFRESH == 0;
        eq.evaluate(u, &mut residual, refresh.then_some(&mut *matrix.values))?;
        if refresh {
            column_sums(eq, &matrix, &mut mass);
        }
        let (rel, worst, _) = eq.residual_norm(&residual);
        out.residual = rel;
        out.worst_grain = worst;
        if refresh {
            out.history.push(rel);
        }
        if !rel.is_finite() {
            break;
        }
        if rel <= settings.tolerance || step == settings.steps {
            out.converged = rel <= settings.tolerance;
            break;
        }
        out.iterations += 1;
        // FIRE with a time step of one: the residual is the net force on each unknown.
        let power: f64 = residual.iter().zip(&velocity).map(|(r, v)| r * v).sum();
        if power > 0.0 {
            let v_norm = weighted_norm(&velocity, &mass, 1.0);
            let f_norm = weighted_norm(&residual, &mass, -1.0);
            if f_norm > 0.0 {
                for k in 0..n {
                    velocity[k] = (1.0 - alpha) * velocity[k]
                        + alpha * v_norm * residual[k] / (f_norm * mass[k]);
                }
            }
            positive += 1;
            if positive > DELAY {
                alpha *= ALPHA_DECAY;
            }
        } else {
            velocity.iter_mut().for_each(|v| *v = 0.0);
            alpha = ALPHA_START;
            positive = 0;
        }
        // The step of a time step of one is the velocity, at most the largest step.
        for k in 0..n {
            velocity[k] += residual[k] / mass[k];
        }
        let length = eq.step_norm(&velocity);
        if length > settings.max_step {
            let shrink = settings.max_step / length;
            velocity.iter_mut().for_each(|v| *v *= shrink);
        }
        // Grains do not pass through each other: a step that closes a gap stops where it
        // closes, and the contact is made; one that would leave the lists' reach ends the run.
        let fraction = eq.closing_fraction(u, &velocity).min(1.0);
        for k in 0..n {
            u[k] += fraction * velocity[k];
        }
        out.step = fraction * eq.step_norm(&velocity);
        if fraction < 1.0 {
            match eq.close_gaps(u) {
                Some(made) if made > 0 => out.contacts_made += made,
                _ => {
                    out.at_reach = true;
                    eq.evaluate(u, &mut residual, None)?;
                    (out.residual, out.worst_grain, _) = eq.residual_norm(&residual);
                    break;
                }
            }
        }
    }
    stats.counters.settling_steps += out.iterations;
    stats.timers.settling += secs(start);
    Ok(out)
}

/// Each unknown's fictitious mass: the absolute sum of its column of the tangent, or the
/// equations' stiffness scale where the column is empty (a grain touching nothing).
fn column_sums<E: Equations>(eq: &E, matrix: &SystemMatrix, mass: &mut [f64]) {
    let col_ptr = matrix.symbolic.col_ptr();
    for (j, m) in mass.iter_mut().enumerate() {
        let sum: f64 = matrix.values[col_ptr[j]..col_ptr[j + 1]]
            .iter()
            .map(|v| v.abs())
            .sum();
        *m = if sum > 0.0 {
            sum
        } else {
            eq.stiffness_hint() * eq.unit_stiffness(j)
        };
    }
}

/// `sqrt(sum x^2 m^power)`: a velocity's norm in the mass (`power = 1`), a force's in its
/// inverse (`power = -1`).
fn weighted_norm(x: &[f64], mass: &[f64], power: f64) -> f64 {
    x.iter()
        .zip(mass)
        .map(|(x, m)| x * x * m.powf(power))
        .sum::<f64>()
        .sqrt()
}
