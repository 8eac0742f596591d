//! The thesis's grain-by-grain method (van Baars 1996, 2.3 and 2.4, the program 'Grain'):
//! each block of unknowns (a grain's `x, y, phi`, or a stress-controlled wall's position) is
//! moved to its own equilibrium with everything else held where it is, by one Gauss
//! elimination of its 3x3 system (eq. 19), block after block in a fixed order (Gauss-Seidel),
//! and the whole sample is swept again until the residual is small enough or the sweeps
//! allowed (`n_i`) are spent.
//!
//! It knows nothing of the physics: the [`BlockEquations`] give each block's residual and
//! stiffness. The elasto-plastic shear stiffness of the thesis (2.4) is
//! the equations' slip tangent; 'truncate' is here: no block moves more than a set length in
//! one visit.

use super::stats::SolverStats;
use crate::NumericError;

/// A sliding contact of a block: the elasto-plastic stiffness leaves out its shear stiffness,
/// which comes back when the step would take the shear force off the limit (thesis 2.4).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Slip {
    /// How the contact's shear displacement changes with the block's unknowns.
    pub shear: [f64; 3],
    /// Its elastic shear stiffness `k_s`.
    pub stiffness: f64,
    /// Sign of its shear force: a step with `shear . du` of the other sign unloads it.
    pub sense: f64,
}

/// The residual of one block's unknowns and their stiffness, everything else held fixed.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BlockSystem {
    /// The block's unknowns (global indices).
    pub dofs: [usize; 3],
    /// How many of `dofs` are used (1 to 3).
    pub len: usize,
    /// Out-of-balance force (and moment) on the block.
    pub residual: [f64; 3],
    /// Its stiffness `-dR/du` for the block's own unknowns.
    pub stiffness: [[f64; 3]; 3],
    /// Its sliding contacts.
    pub slips: Vec<Slip>,
}

impl BlockSystem {
    /// Empty, for a block with `len` unknowns from `first` on (capacity kept).
    pub fn reset(&mut self, first: usize, len: usize) {
        self.len = len;
        for k in 0..3 {
            self.dofs[k] = first + k.min(len - 1);
        }
        self.residual = [0.0; 3];
        self.stiffness = [[0.0; 3]; 3];
        self.slips.clear();
    }
}

/// Equations solved one block at a time.
pub trait BlockEquations {
    /// Evaluate the residual `R(u)` of every unknown into `residual`.
    fn evaluate(&mut self, u: &[f64], residual: &mut [f64]) -> Result<(), NumericError>;

    /// Convergence measure of a residual: `(|R|_inf / F_ref, worst grain, |R|_2 / F_ref)`.
    fn residual_norm(&self, residual: &[f64]) -> (f64, usize, f64);

    /// How the stiffness of each unknown scales: 1 for a translation, `r^2` for a rotation.
    fn unit_stiffness(&self, dof: usize) -> f64;

    /// Whether the iterate is still far from the answer: the equations may then offer a
    /// stiffer tangent where theirs vanishes (only the path changes, not the answer).
    fn set_far(&mut self, far: bool);

    /// Number of blocks, visited in index order.
    fn blocks(&self) -> usize;

    /// Get ready for a sweep from the iterate `u`.
    fn begin_sweep(&mut self, u: &[f64]) -> Result<(), NumericError>;

    /// The system of block `block` at the current iterate, into `system`.
    fn block_system(&mut self, block: usize, system: &mut BlockSystem) -> Result<(), NumericError>;

    /// The block's unknowns in `u` have changed: move it there. Returns whether the move needs
    /// the contact topology updated before going on (a gap closed, or the block left the reach
    /// of its friends lists).
    fn move_block(&mut self, block: usize, u: &[f64]) -> bool;

    /// Length of a block's step `du` in mean radii (a rotation times the mean radius).
    fn step_length(&self, system: &BlockSystem, du: &[f64; 3]) -> f64;

    /// The longest move block `block` may still make, in mean radii, before its friends
    /// lists go stale.
    fn reach_left(&self, block: usize) -> f64;
}

/// Settings of one relaxation pass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RelaxationSettings {
    /// Stop once `|R|_inf <= tolerance * F_ref`.
    pub tolerance: f64,
    /// Sweeps allowed in this pass.
    pub sweeps: usize,
    /// Longest move of one block in one visit, in mean radii ('truncate').
    pub truncate: f64,
}

/// How a relaxation pass ended.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RelaxationOutcome {
    /// Sweeps made.
    pub iterations: usize,
    /// Final relative residual.
    pub residual: f64,
    /// Relative residual before the first sweep and after each.
    pub history: Vec<f64>,
    /// Stopped where a gap closed or a block neared the edge of its friends lists: the
    /// topology is updated before the sweeps go on.
    pub at_reach: bool,
}

/// Run sweeps from `u` until the tolerance is met, the sweeps are spent, or the topology must
/// be updated.
pub fn relax(
    eq: &mut dyn BlockEquations,
    u: &mut [f64],
    settings: &RelaxationSettings,
    stats: &mut SolverStats,
) -> Result<RelaxationOutcome, NumericError> {
    let mut residual = vec![0.0; u.len()];
    eq.set_far(true);
    eq.evaluate(u, &mut residual)?;
    let mut rel = eq.residual_norm(&residual).0;
    let mut out = RelaxationOutcome {
        history: vec![rel],
        ..Default::default()
    };
    let mut system = BlockSystem::default();
    while rel > settings.tolerance && out.iterations < settings.sweeps {
        out.iterations += 1;
        stats.counters.newton_iterations += 1;
        eq.set_far(rel > FAR);
        eq.begin_sweep(u)?;
        for block in 0..eq.blocks() {
            eq.block_system(block, &mut system)?;
            let mut du = solve_block(eq, &system);
            // 'Truncate': a long step is cut short, the rest comes in later sweeps; and no
            // block leaves the reach of its friends lists.
            let length = eq.step_length(&system, &du);
            let limit = settings.truncate.min(eq.reach_left(block).max(0.0));
            if length > limit {
                du.iter_mut().for_each(|d| *d *= limit / length);
            }
            for k in 0..system.len {
                u[system.dofs[k]] += du[k];
            }
            if eq.move_block(block, u) {
                out.at_reach = true;
            }
        }
        eq.evaluate(u, &mut residual)?;
        let worst;
        (rel, worst, _) = eq.residual_norm(&residual);
        out.history.push(rel);
        if !rel.is_finite() {
            return Err(NumericError::NotFinite {
                what: "relaxation residual",
                place: format!("grain {worst}"),
            });
        }
        if out.at_reach {
            break;
        }
    }
    out.residual = rel;
    Ok(out)
}

/// Relative residual above which the iterate counts as far from the answer.
const FAR: f64 = 1e-2;

/// The block's step `K du = R` by Gauss elimination with partial pivoting, with the
/// elasto-plastic stiffness; a sliding contact the step would unload gets its shear stiffness
/// back and the step is solved again (thesis 2.4: without that, a grain on sliding contacts
/// swings from one side of its slip to the other). A block without stiffness in some
/// direction (a rattler, a rotation with only frictionless contacts) gets a small share of its
/// largest stiffness there; a step that would not lower the residual (a geometric softening
/// larger than the elastic stiffness) gives way to a step along the residual scaled by that
/// largest stiffness.
fn solve_block(eq: &dyn BlockEquations, s: &BlockSystem) -> [f64; 3] {
    let n = s.len;
    let unit = |k: usize| eq.unit_stiffness(s.dofs[k]);
    let largest = (0..n)
        .map(|k| s.stiffness[k][k] / unit(k))
        .fold(0.0f64, f64::max);
    let mut stiffness = s.stiffness;
    let mut restored = vec![false; s.slips.len()];
    let mut du = [0.0; 3];
    for _round in 0..=s.slips.len() {
        let largest = (0..n)
            .map(|k| stiffness[k][k] / unit(k))
            .fold(largest, f64::max);
        if largest <= 0.0 {
            return [0.0; 3];
        }
        let mut a = stiffness;
        let mut b = s.residual;
        for (k, row) in a.iter_mut().enumerate().take(n) {
            row[k] += 1e-6 * largest * unit(k);
        }
        let solved = gauss(&mut a, &mut b, n, &mut du);
        let descent: f64 = (0..n).map(|k| du[k] * s.residual[k]).sum();
        if !(solved && descent > 0.0 && du.iter().all(|d| d.is_finite())) {
            for (k, d) in du.iter_mut().enumerate().take(n) {
                *d = s.residual[k] / (largest * unit(k));
            }
        }
        let mut again = false;
        for (slip, back) in s.slips.iter().zip(restored.iter_mut()) {
            let ds: f64 = (0..n).map(|k| slip.shear[k] * du[k]).sum();
            if !*back && slip.sense * ds < 0.0 {
                *back = true;
                again = true;
                for (row, si) in stiffness.iter_mut().zip(slip.shear).take(n) {
                    for (k, sj) in row.iter_mut().zip(slip.shear).take(n) {
                        *k += slip.stiffness * si * sj;
                    }
                }
            }
        }
        if !again {
            break;
        }
    }
    du
}

/// Gauss elimination with partial pivoting of the leading `n x n` system; false when singular.
fn gauss(a: &mut [[f64; 3]; 3], b: &mut [f64; 3], n: usize, x: &mut [f64; 3]) -> bool {
    for col in 0..n {
        let pivot = (col..n)
            .max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))
            .expect("rows");
        if a[pivot][col] == 0.0 {
            return false;
        }
        a.swap(col, pivot);
        b.swap(col, pivot);
        for row in col + 1..n {
            let f = a[row][col] / a[col][col];
            let pivot_row = a[col];
            for (k, p) in a[row].iter_mut().zip(pivot_row).take(n).skip(col) {
                *k -= f * p;
            }
            b[row] -= f * b[col];
        }
    }
    for row in (0..n).rev() {
        let mut v = b[row];
        for k in row + 1..n {
            v -= a[row][k] * x[k];
        }
        x[row] = v / a[row][row];
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_elimination_solves_a_pivoting_system() {
        let mut a = [[0.0, 2.0, 1.0], [1.0, 1.0, 0.0], [2.0, 0.0, 3.0]];
        let x_true = [1.0, -2.0, 0.5];
        let mut b = [0.0; 3];
        for i in 0..3 {
            b[i] = (0..3).map(|j| a[i][j] * x_true[j]).sum();
        }
        let mut x = [0.0; 3];
        assert!(gauss(&mut a, &mut b, 3, &mut x));
        for i in 0..3 {
            assert!((x[i] - x_true[i]).abs() < 1e-14, "{x:?}");
        }
    }
}
