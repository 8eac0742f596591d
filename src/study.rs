//! Speed against error: one scene run by the global solver (the minimisation) over a range of
//! tolerances and by the grain-by-grain relaxation over a range of sweeps per increment
//! (`n_i`) and of tolerances, each run compared increment by increment with a reference (the
//! global solver near machine precision): the wall stresses and the macro stress (eq. A.41) relative to
//! the reference's, the grain positions in mean radii (of the grains the reference holds,
//! up to the motions no force fixes: a rattler in its cage, a free sample's rigid motion, a
//! box's sideways shift), and the run's own relative residual, against the CPU time the run
//! took.

use crate::contact::Contact;
use crate::geometry::{Side, Wall};
use crate::measure::Measurements;
use crate::scene::WallControl;
use crate::simulation::Simulation;
use crate::solver::{SolverConfig, Strategy};
use crate::{Error, NumericError};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The runs of a study: the reference, and the efforts each strategy is tried at.
#[derive(Debug, Clone, PartialEq)]
pub struct StudyPlan {
    /// Settings of the reference run.
    pub reference: SolverConfig,
    /// The global solver's settings, its tolerance set per run.
    pub global: SolverConfig,
    /// Tolerances of the global solver's runs.
    pub tolerances: Vec<f64>,
    /// The relaxation's settings, its sweeps and tolerance set per run.
    pub relaxation: SolverConfig,
    /// Sweeps per increment of the relaxation runs that do just that many (the thesis's way).
    pub sweeps: Vec<usize>,
    /// Tolerances of the relaxation runs that sweep until the residual meets them.
    pub relaxation_tolerances: Vec<f64>,
    /// Sweeps per increment allowed to those.
    pub max_sweeps: usize,
}

/// One run of a study.
#[derive(Debug, Clone, PartialEq)]
pub struct Trial {
    /// `minimise` or `relaxation`.
    pub solver: String,
    /// What was varied, as shown in the table (`tolerance 1e-6`, `n_i = 20`).
    pub setting: String,
    /// Its settings.
    pub config: SolverConfig,
}

/// Tolerance of the relaxation runs with a fixed number of sweeps: never met first.
const NO_TOLERANCE: f64 = 1e-300;

impl StudyPlan {
    /// The runs to make, the global solver's first, each family from least to most effort.
    pub fn trials(&self) -> Vec<Trial> {
        let trial = |solver: &str, setting: String, config: SolverConfig| Trial {
            solver: solver.into(),
            setting,
            config,
        };
        let global = self.tolerances.iter().map(|&t| {
            let config = SolverConfig {
                strategy: Strategy::Minimise,
                tolerance: t,
                ..self.global.clone()
            };
            trial("minimise", format!("tolerance {t:.0e}"), config)
        });
        let relaxation = |sweeps: usize, tolerance: f64| SolverConfig {
            strategy: Strategy::Relaxation,
            sweeps,
            tolerance,
            ..self.relaxation.clone()
        };
        let fixed_sweeps = self.sweeps.iter().map(|&n| {
            trial(
                "relaxation",
                format!("n_i = {n}"),
                relaxation(n, NO_TOLERANCE),
            )
        });
        let to_tolerance = self.relaxation_tolerances.iter().map(|&t| {
            let config = relaxation(self.max_sweeps, t);
            trial("relaxation", format!("tolerance {t:.0e}"), config)
        });
        global.chain(fixed_sweeps).chain(to_tolerance).collect()
    }
}

/// What one run left after each increment, and what it cost.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Track {
    /// Macro stress (eq. A.41) after each increment (Pa).
    pub macro_stress: Vec<[[f64; 2]; 2]>,
    /// Wall stresses after each increment (Pa).
    pub wall_stress: Vec<Vec<f64>>,
    /// Grain centres after each increment (m).
    pub position: Vec<Vec<[f64; 2]>>,
    /// Whether a contact presses on each grain after each increment ([`held_grains`]).
    pub held: Vec<Vec<bool>>,
    /// Relative residual of the committed state after each increment, measured alike for
    /// every strategy (largest imbalance over the mean contact force).
    pub residual: Vec<f64>,
    /// CPU seconds of the process spent in the increments (measuring excluded).
    pub cpu: f64,
    /// Wall-clock seconds of the same.
    pub wall: f64,
    /// Newton iterations or sweeps, over all increments.
    pub iterations: usize,
    /// Numeric factorisations.
    pub factorisations: usize,
    /// Increments halved.
    pub cuts: usize,
    /// Mean grain radius (m).
    pub r_mean: f64,
    /// The motion of the whole sample that no force fixes ([`free_motion`]).
    pub free_motion: FreeMotion,
    /// Why the run stopped early, if it did.
    pub failure: Option<NumericError>,
}

/// CPU seconds used by this process so far (user and system, all threads).
pub fn cpu_seconds() -> f64 {
    // SAFETY: getrusage only writes the struct it is given.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut usage) } != 0 {
        return f64::NAN;
    }
    let t = |v: libc::timeval| v.tv_sec as f64 + 1e-6 * v.tv_usec as f64;
    t(usage.ru_utime) + t(usage.ru_stime)
}

/// Run a simulation to the end of its load program, timing only the increments and
/// recording after each one what the study compares. A failing increment ends the track.
pub fn track(sim: &mut Simulation, mut on_increment: impl FnMut(usize)) -> Track {
    let mut out = Track {
        r_mean: sim.mean_radius(),
        free_motion: free_motion(&sim.state.walls.walls),
        ..Default::default()
    };
    while !sim.is_finished() {
        let (cpu, wall) = (cpu_seconds(), Instant::now());
        let result = sim.run_increment();
        out.cpu += cpu_seconds() - cpu;
        out.wall += wall.elapsed().as_secs_f64();
        let report = match result {
            Ok(report) => report,
            Err(err) => {
                out.failure = Some(err);
                break;
            }
        };
        out.iterations += report.newton_iterations;
        out.cuts += report.cuts as usize;
        let Measurements {
            macro_stress,
            wall_stress,
            ..
        } = report.measurements;
        out.macro_stress.push(macro_stress);
        out.wall_stress.push(wall_stress);
        out.position.push(sim.state.grains.position.clone());
        out.held.push(held_grains(
            &sim.state.contacts.contacts,
            sim.state.grains.position.len(),
        ));
        out.residual.push(sim.equilibrium_error().0);
        on_increment(report.increment);
    }
    out.factorisations = sim.stats.counters.numeric_factorisations;
    out
}

/// The motion of the whole sample that no force fixes: the solvers' paths put the sample
/// where they put it, and the study fits that motion away before it compares grain places.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum FreeMotion {
    /// The walls hold the sample in place.
    #[default]
    None,
    /// A rigid motion: no walls, the place fixed only by the global solver's anchors, which
    /// the relaxation does not have.
    Rigid,
    /// Translations along these unit directions, the stress-controlled walls following.
    Along(Vec<[f64; 2]>),
}

/// The sample's [`FreeMotion`] between `walls`. A translation changes no force where every
/// wall is smooth (`f_gw = 0`), flat and unturned, and those held in place all lie across
/// it: a biaxial box with its sides under stress is free sideways.
pub fn free_motion(walls: &[Wall]) -> FreeMotion {
    if walls.is_empty() {
        return FreeMotion::Rigid;
    }
    if walls
        .iter()
        .any(|w| w.friction != 0.0 || w.circle.is_some() || w.turn != 0.0)
    {
        return FreeMotion::None;
    }
    let held: Vec<[f64; 2]> = (walls.iter())
        .filter(|w| w.control == WallControl::Displacement)
        .map(|w| w.normal)
        .collect();
    match held.first() {
        None => FreeMotion::Along(vec![[1.0, 0.0], [0.0, 1.0]]),
        Some(n)
            if held
                .iter()
                .all(|m| (n[0] * m[1] - n[1] * m[0]).abs() < 1e-12) =>
        {
            FreeMotion::Along(vec![[-n[1], n[0]]])
        }
        Some(_) => FreeMotion::None,
    }
}

/// Share of the mean contact force a contact must press with to hold a grain: far below any
/// tolerance the study runs at, far above the forces of pairs that touch to round-off.
const HOLDING: f64 = 1e-8;

/// Whether a contact presses on each of `grains` grains with more than `HOLDING` (1e-8) of the
/// mean contact force, or bonds it. A grain held by none (a rattler in its cage) is in
/// equilibrium anywhere in the cage: no force fixes its place, and the solvers leave it where
/// their paths put it.
pub fn held_grains(contacts: &[Contact], grains: usize) -> Vec<bool> {
    let forces: Vec<f64> = contacts
        .iter()
        .map(|c| c.response.normal_force.abs())
        .collect();
    let mean = forces.iter().sum::<f64>() / forces.len().max(1) as f64;
    let mut held = vec![false; grains];
    for (c, force) in contacts.iter().zip(&forces) {
        if c.bonded || *force > HOLDING * mean {
            held[c.pair.b] = true;
            if let Side::Grain(a) = c.pair.a {
                held[a] = true;
            }
        }
    }
    held
}

/// A run's errors against the reference in one increment.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct IncrementError {
    /// Largest difference of a macro stress component over the reference's largest.
    pub macro_stress: f64,
    /// Largest difference of a wall stress over the reference's largest wall stress (NaN
    /// without walls).
    pub wall_stress: f64,
    /// Largest distance of a grain centre from the reference's, in mean radii, over the
    /// grains the reference holds ([`held_grains`]).
    pub displacement: f64,
    /// Root mean square of those distances, in mean radii: the largest is often a grain on
    /// a mechanism (sliding on all its contacts), whose place the forces barely fix.
    pub displacement_rms: f64,
    /// The run's own relative residual.
    pub residual: f64,
}

impl IncrementError {
    /// The larger of each error.
    fn max(self, o: IncrementError) -> IncrementError {
        IncrementError {
            macro_stress: self.macro_stress.max(o.macro_stress),
            wall_stress: self.wall_stress.max(o.wall_stress),
            displacement: self.displacement.max(o.displacement),
            displacement_rms: self.displacement_rms.max(o.displacement_rms),
            residual: self.residual.max(o.residual),
        }
    }
}

/// The run's errors in each increment both reached.
pub fn compare(run: &Track, reference: &Track) -> Vec<IncrementError> {
    let largest = |v: &mut dyn Iterator<Item = f64>| v.fold(0.0f64, |m, x| m.max(x.abs()));
    (0..run.macro_stress.len().min(reference.macro_stress.len()))
        .map(|k| {
            let (a, b) = (run.macro_stress[k], reference.macro_stress[k]);
            let scale = largest(&mut b.iter().flatten().copied());
            let diff = largest(&mut (0..4).map(|i| a[i / 2][i % 2] - b[i / 2][i % 2]));
            let (wa, wb) = (&run.wall_stress[k], &reference.wall_stress[k]);
            let wall_scale = largest(&mut wb.iter().copied());
            let wall_diff = largest(&mut wa.iter().zip(wb).map(|(x, y)| x - y));
            // Rattlers are left out of the rigid fit too: their places would pull it.
            let held = |v: &[[f64; 2]]| -> Vec<[f64; 2]> {
                (v.iter().zip(&reference.held[k]))
                    .filter(|(_, &held)| held)
                    .map(|(p, _)| *p)
                    .collect()
            };
            let (run_held, reference_held) = (held(&run.position[k]), held(&reference.position[k]));
            let positions = match &reference.free_motion {
                FreeMotion::None => run_held,
                FreeMotion::Rigid => rigidly_fitted(&run_held, &reference_held),
                FreeMotion::Along(directions) => {
                    translated_along(&run_held, &reference_held, directions)
                }
            };
            let moved: Vec<f64> = positions
                .iter()
                .zip(&reference_held)
                .map(|(p, q)| (p[0] - q[0]).hypot(p[1] - q[1]))
                .collect();
            let rms = (moved.iter().map(|d| d * d).sum::<f64>() / moved.len().max(1) as f64).sqrt();
            IncrementError {
                macro_stress: diff / scale,
                wall_stress: wall_diff / wall_scale,
                displacement: moved.iter().fold(0.0f64, |m, d| m.max(*d)) / reference.r_mean,
                displacement_rms: rms / reference.r_mean,
                residual: run.residual[k],
            }
        })
        .collect()
}

/// `points` moved along each of the unit `directions` (orthogonal) by the mean distance
/// that separates them from `target` along it.
fn translated_along(
    points: &[[f64; 2]],
    target: &[[f64; 2]],
    directions: &[[f64; 2]],
) -> Vec<[f64; 2]> {
    let n = points.len().max(1) as f64;
    let mut out = points.to_vec();
    for d in directions {
        let mean = (points.iter().zip(target))
            .map(|(p, q)| (q[0] - p[0]) * d[0] + (q[1] - p[1]) * d[1])
            .sum::<f64>()
            / n;
        for p in &mut out {
            p[0] += mean * d[0];
            p[1] += mean * d[1];
        }
    }
    out
}

/// `points` moved by the rigid motion (rotation about their centroid, then translation)
/// that best fits them onto `target` in the least-squares sense.
fn rigidly_fitted(points: &[[f64; 2]], target: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let n = points.len().max(1) as f64;
    let centroid = |v: &[[f64; 2]]| {
        v.iter()
            .fold([0.0; 2], |c, p| [c[0] + p[0] / n, c[1] + p[1] / n])
    };
    let (cp, ct) = (centroid(points), centroid(target));
    let (mut dot, mut cross) = (0.0, 0.0);
    for (p, t) in points.iter().zip(target) {
        let (a, b) = ([p[0] - cp[0], p[1] - cp[1]], [t[0] - ct[0], t[1] - ct[1]]);
        dot += a[0] * b[0] + a[1] * b[1];
        cross += a[0] * b[1] - a[1] * b[0];
    }
    let (sin, cos) = cross.atan2(dot).sin_cos();
    points
        .iter()
        .map(|p| {
            let a = [p[0] - cp[0], p[1] - cp[1]];
            [
                ct[0] + cos * a[0] - sin * a[1],
                ct[1] + sin * a[0] + cos * a[1],
            ]
        })
        .collect()
}

/// One run's result in the study.
#[derive(Debug, Clone, PartialEq)]
pub struct StudyRow {
    /// The run.
    pub trial: Trial,
    /// What it left.
    pub track: Track,
    /// Its errors per increment.
    pub errors: Vec<IncrementError>,
}

impl StudyRow {
    /// The largest error of each kind over the increments, or `None` when the run did not
    /// reach the end of the load program.
    pub fn worst(&self) -> Option<IncrementError> {
        if self.track.failure.is_some() {
            return None;
        }
        // A scene without walls keeps its wall stress error NaN.
        Some(
            self.errors
                .iter()
                .copied()
                .reduce(IncrementError::max)
                .unwrap_or_default(),
        )
    }
}

/// Macro stress errors the study reports the time to reach.
pub const TARGETS: [f64; 3] = [1e-3, 1e-6, 1e-9];

/// The fastest finished run of `solver` whose macro stress error stays within `target` in
/// every increment.
pub fn fastest<'a>(rows: &'a [StudyRow], solver: &str, target: f64) -> Option<&'a StudyRow> {
    rows.iter()
        .filter(|r| r.trial.solver == solver)
        .filter(|r| r.worst().is_some_and(|w| w.macro_stress <= target))
        .min_by(|a, b| a.track.cpu.total_cmp(&b.track.cpu))
}

/// Write `study.csv` (one row per run), `study-increments.csv` (one row per run and
/// increment) and `study.md` (the tables) into `dir`; returns their paths.
pub fn write_tables(
    dir: &Path,
    scene: &str,
    reference: &Track,
    rows: &[StudyRow],
) -> Result<Vec<PathBuf>, Error> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir.display().to_string(), e))?;
    let mut runs = String::from(
        "solver,setting,cpu_s,wall_s,iterations,factorisations,cuts,macro_stress_error,\
         wall_stress_error,displacement_error,displacement_rms,residual,status\n",
    );
    let mut increments =
        String::from("solver,setting,increment,macro_stress_error,wall_stress_error,displacement_error,displacement_rms,residual\n");
    for row in rows {
        let w = row.worst().unwrap_or_default();
        let status = match &row.track.failure {
            Some(f) => format!("failed: {}", f.to_string().replace(',', ";")),
            None => "ok".into(),
        };
        let t = &row.track;
        writeln!(
            runs,
            "{},{},{:.4},{:.4},{},{},{},{:.3e},{:.3e},{:.3e},{:.3e},{:.3e},{}",
            row.trial.solver,
            row.trial.setting,
            t.cpu,
            t.wall,
            t.iterations,
            t.factorisations,
            t.cuts,
            w.macro_stress,
            w.wall_stress,
            w.displacement,
            w.displacement_rms,
            w.residual,
            status
        )
        .expect("string");
        for (k, e) in row.errors.iter().enumerate() {
            writeln!(
                increments,
                "{},{},{},{:.3e},{:.3e},{:.3e},{:.3e},{:.3e}",
                row.trial.solver,
                row.trial.setting,
                k + 1,
                e.macro_stress,
                e.wall_stress,
                e.displacement,
                e.displacement_rms,
                e.residual
            )
            .expect("string");
        }
    }
    let paths = [
        (dir.join("study.csv"), runs),
        (dir.join("study-increments.csv"), increments),
        (dir.join("study.md"), markdown(scene, reference, rows)),
    ];
    for (path, text) in &paths {
        std::fs::write(path, text).map_err(|e| Error::io(path.display().to_string(), e))?;
    }
    Ok(paths.into_iter().map(|(p, _)| p).collect())
}

/// The study as markdown: every run, the time each strategy needs to reach each target, and
/// the thesis's setting (`n_i = 20`) increment by increment.
pub fn markdown(scene: &str, reference: &Track, rows: &[StudyRow]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "## Speed against error: {scene}\n\nReference: the global solver near machine \
         precision, {:.2} s CPU, {} Newton iterations, {} cuts; largest residual {:.1e}. \
         Errors are the largest over the increments: macro stress (eq. A.41) and wall \
         stresses relative to the reference's largest component, grain positions in mean \
         radii over the grains a contact holds in the reference (up to {} rattlers, held by \
         none, left out), after fitting away the motion no force fixes (a sample without \
         walls: a rigid motion; a box with smooth walls and its sides under stress: a \
         shift sideways); the residual is the run's own.\n",
        reference.cpu,
        reference.iterations,
        reference.cuts,
        reference.residual.iter().fold(0.0f64, |m, r| m.max(*r)),
        (reference.held.iter())
            .map(|h| h.iter().filter(|&&held| !held).count())
            .max()
            .unwrap_or(0)
    );
    s.push_str(
        "| solver | setting | CPU [s] | iterations / sweeps | macro stress error | \
         in increment 1 | wall stress error | displacement error, largest / rms [r_mean] | \
         residual |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    for row in rows {
        let t = &row.track;
        match row.worst() {
            Some(w) => {
                let _ = writeln!(
                    s,
                    "| {} | {} | {:.2} | {} | {:.1e} | {:.1e} | {} | {:.1e} / {:.1e} | {:.1e} |",
                    row.trial.solver,
                    row.trial.setting,
                    t.cpu,
                    t.iterations,
                    w.macro_stress,
                    row.errors.first().map_or(f64::NAN, |e| e.macro_stress),
                    wall_cell(w.wall_stress),
                    w.displacement,
                    w.displacement_rms,
                    w.residual
                );
            }
            None => {
                let _ = writeln!(
                    s,
                    "| {} | {} | {:.2} | {} | failed after {} increments: {} | | | | |",
                    row.trial.solver,
                    row.trial.setting,
                    t.cpu,
                    t.iterations,
                    row.errors.len(),
                    t.failure
                        .as_ref()
                        .map(|f| f.to_string())
                        .unwrap_or_default()
                );
            }
        }
    }
    s.push_str(
        "\nCPU time of the whole run to a macro stress error of (largest over the \
         increments):\n\n| solver |",
    );
    for t in TARGETS {
        let _ = write!(s, " {t:.0e} |");
    }
    s.push_str("\n|---|---|---|---|\n");
    for solver in ["minimise", "relaxation"] {
        let _ = write!(s, "| {solver} |");
        for target in TARGETS {
            match fastest(rows, solver, target) {
                Some(r) => {
                    let _ = write!(s, " {:.2} s ({}) |", r.track.cpu, r.trial.setting);
                }
                None => s.push_str(" not reached |"),
            }
        }
        s.push('\n');
    }
    s.push_str("\nSmallest n_i run that reaches it:");
    for target in TARGETS {
        let smallest = rows
            .iter()
            .filter(|r| r.trial.setting.starts_with("n_i"))
            .filter(|r| r.worst().is_some_and(|w| w.macro_stress <= target))
            .min_by_key(|r| r.trial.config.sweeps);
        let _ = write!(
            s,
            " {target:.0e}: {};",
            smallest.map_or("none".into(), |r| r.trial.setting.clone())
        );
    }
    s.push('\n');
    if let Some(row) = rows
        .iter()
        .find(|r| r.trial.solver == "relaxation" && r.trial.setting == "n_i = 20")
    {
        s.push_str(
            "\nThe thesis's setting, relaxation with n_i = 20, increment by increment:\n\n\
             | increment | macro stress error | wall stress error | displacement error, \
             largest / rms [r_mean] | residual |\n|---|---|---|---|---|\n",
        );
        for (k, e) in row.errors.iter().enumerate() {
            let _ = writeln!(
                s,
                "| {} | {:.1e} | {} | {:.1e} / {:.1e} | {:.1e} |",
                k + 1,
                e.macro_stress,
                wall_cell(e.wall_stress),
                e.displacement,
                e.displacement_rms,
                e.residual
            );
        }
    }
    s
}

/// A wall stress error for the tables: none where the scene has no walls.
fn wall_cell(error: f64) -> String {
    if error.is_nan() {
        "no walls".into()
    } else {
        format!("{error:.1e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A track of one increment with the grains at `position`, `held` as given.
    fn one_increment(position: Vec<[f64; 2]>, held: Vec<bool>, free_motion: FreeMotion) -> Track {
        Track {
            macro_stress: vec![[[1.0, 0.0], [0.0, 1.0]]],
            wall_stress: vec![Vec::new()],
            position: vec![position],
            held: vec![held],
            residual: vec![0.0],
            r_mean: 1.0,
            free_motion,
            ..Default::default()
        }
    }

    #[test]
    fn a_grain_is_held_by_a_pressing_or_bonded_contact_only() {
        use crate::contact::{Contact, ContactParams};
        use crate::geometry::Pair;
        let params = ContactParams {
            stiffness: 1.0,
            kappa: 1.0,
            friction: 0.5,
            strength: 0.0,
        };
        let contact = |a: Side, b: usize, force: f64, bonded: bool| {
            let mut c = Contact::new(Pair { a, b }, params, bonded);
            c.response.normal_force = force;
            c
        };
        // Grain 0 pressed on a wall, 1 and 2 pressed together, 3 touching 2 to round-off,
        // 4 bonded to 5 without force, 6 touching nothing.
        let contacts = [
            contact(Side::Wall(0), 0, 2.0, false),
            contact(Side::Grain(1), 2, 1.0, false),
            contact(Side::Grain(2), 3, 1e-13, false),
            contact(Side::Grain(4), 5, 0.0, true),
        ];
        let held = held_grains(&contacts, 7);
        assert_eq!(held, [true, true, true, false, true, true, false]);
    }

    #[test]
    fn a_rattler_is_left_out_of_the_displacement_error() {
        let grains = vec![[0.0, 0.0], [2.0, 0.0], [0.0, 2.0], [1.0, 1.0]];
        let held = vec![true, true, true, false];
        for free_motion in [FreeMotion::None, FreeMotion::Rigid] {
            let reference = one_increment(grains.clone(), held.clone(), free_motion);
            let mut moved = grains.clone();
            // The rattler moves across its cage, a held grain by a little.
            moved[3] = [1.4, 0.7];
            moved[1][0] += 1e-3;
            let run = one_increment(moved, vec![true; 4], FreeMotion::None);
            let e = compare(&run, &reference)[0];
            assert!(
                e.displacement > 1e-4 && e.displacement <= 1e-3 + 1e-15,
                "{e:?}"
            );
        }
    }

    /// A flat smooth wall with inward normal `normal` under `control`.
    fn wall(normal: [f64; 2], control: WallControl) -> Wall {
        Wall {
            name: String::new(),
            normal,
            offset: 0.0,
            pivot: [0.0; 2],
            turn: 0.0,
            position: 0.0,
            slide: 0.0,
            control,
            stress: 0.0,
            length: None,
            friction: 0.0,
            circle: None,
        }
    }

    #[test]
    fn a_box_with_its_sides_under_stress_is_free_sideways_only_when_smooth() {
        use WallControl::{Displacement, Stress};
        let mut walls = vec![
            wall([0.0, 1.0], Displacement),
            wall([-1.0, 0.0], Stress),
            wall([0.0, -1.0], Displacement),
            wall([1.0, 0.0], Stress),
        ];
        let FreeMotion::Along(free) = free_motion(&walls) else {
            panic!("not free: {:?}", free_motion(&walls));
        };
        assert_eq!(free.len(), 1);
        assert!(
            (free[0][0].abs() - 1.0).abs() < 1e-15 && free[0][1] == 0.0,
            "{free:?}"
        );
        walls[1].control = Displacement;
        assert_eq!(free_motion(&walls), FreeMotion::None);
        walls[1].control = Stress;
        walls[0].friction = 0.6;
        assert_eq!(free_motion(&walls), FreeMotion::None);
        assert_eq!(free_motion(&[]), FreeMotion::Rigid);
    }

    #[test]
    fn a_free_sideways_shift_is_fitted_away_and_a_held_one_is_not() {
        let grains = vec![[0.0, 0.0], [2.0, 0.0], [0.0, 2.0], [2.0, 2.0]];
        let mut moved: Vec<[f64; 2]> = grains.iter().map(|p| [p[0] + 0.3, p[1] + 0.2]).collect();
        moved[1][0] += 4e-3;
        let mut reference = one_increment(grains, vec![true; 4], FreeMotion::None);
        let run = one_increment(moved, vec![true; 4], FreeMotion::None);
        let held = compare(&run, &reference)[0].displacement;
        assert!((held - (0.3f64 + 4e-3).hypot(0.2)).abs() < 1e-12, "{held}");
        reference.free_motion = FreeMotion::Along(vec![[1.0, 0.0]]);
        let free = compare(&run, &reference)[0].displacement;
        // Sideways, the mean shift (0.301) is fitted away, leaving 3e-3 and 1e-3; upwards not.
        assert!((free - 3e-3f64.hypot(0.2)).abs() < 1e-12, "{free}");
    }

    #[test]
    fn a_rigid_motion_is_fitted_away() {
        let target = [[0.0, 0.0], [1.0, 0.2], [0.3, 1.5], [-0.7, 0.4]];
        let (sin, cos) = 0.3f64.sin_cos();
        let moved: Vec<[f64; 2]> = target
            .iter()
            .map(|p| [cos * p[0] - sin * p[1] + 2.0, sin * p[0] + cos * p[1] - 1.0])
            .collect();
        for (p, t) in rigidly_fitted(&moved, &target).iter().zip(&target) {
            assert!(
                (p[0] - t[0]).abs() < 1e-14 && (p[1] - t[1]).abs() < 1e-14,
                "{p:?} {t:?}"
            );
        }
    }
}
