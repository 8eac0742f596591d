//! The round-off spread of a test: the scene run again and again with its last stage's loads
//! multiplied by `1 + k eps` (k = 0, 1, 2, ...; k = 0 is the scene as written), runs that
//! differ by round-off alone. A failure load is a result only where it does not depend on
//! such a difference, nor on the increment size: a bond cascade or a breakout can take
//! another path at a difference of 1e-13, so one run's failure load, iterations and time are
//! one draw from a spread, and each is reported here as its median and range. With
//! `halved`, every run is made once more with the last stage in twice its increments, and
//! the failure figure's change on halving is given with a 95% bootstrap interval.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use rand::{Rng, SeedableRng};

use crate::estimate::{cylinder_failure, estimate};
use crate::output::curves::Curves;
use crate::output::{read_history, read_increments, read_state, ResultFile};
use crate::run::{header, initial_report, run_to_end, start, RunEnd};
use crate::scene::parse_scene;
use crate::solver::SolverConfig;
use crate::{Error, InputError};

/// The load tables of a stage that [`perturbed`] multiplies.
const LOAD_TABLES: [&str; 4] = ["stress", "displacement", "shear", "shear_strain"];

/// Resamples of the bootstrap interval of the change on halving.
const RESAMPLES: usize = 20_000;

/// What is read from each run as its failure load.
#[derive(Debug, Clone, PartialEq)]
pub enum Figure {
    /// The cylinder test's first breakout: the membrane pressure at which the first cluster
    /// broke out of the borehole (thesis 4.4.2, the functional failure).
    Breakout,
    /// The peak deviator `sigma_1 - sigma_3` of the walls' stresses, as `grainstat plot`
    /// estimates it (increments' peaks included); none where the deviator did not fall
    /// after it (the run ended before the peak: a lower bound, not a failure load).
    Deviator,
    /// The largest normal stress on the named wall or circle (a bend test's loading plug),
    /// at the increments' ends and peaks and at the failing increment's peak.
    Wall(String),
}

impl Figure {
    /// From the command line: `breakout`, `deviator` or `wall:NAME`.
    pub fn parse(text: &str) -> Result<Figure, InputError> {
        match text.split_once(':') {
            None if text == "breakout" => Ok(Figure::Breakout),
            None if text == "deviator" => Ok(Figure::Deviator),
            Some(("wall", name)) if !name.is_empty() => Ok(Figure::Wall(name.to_string())),
            _ => Err(InputError::new(
                "--figure",
                format!("`{text}` is none of breakout, deviator, wall:NAME"),
            )),
        }
    }

    /// What it is, for the table.
    pub fn label(&self) -> String {
        match self {
            Figure::Breakout => "first breakout [Pa]".into(),
            Figure::Deviator => "peak deviator [Pa]".into(),
            Figure::Wall(name) => format!("peak stress on `{name}` [Pa]"),
        }
    }
}

/// What a spread runs.
#[derive(Debug, Clone)]
pub struct SpreadPlan {
    /// Runs per increment size.
    pub runs: usize,
    /// The relative change of the last stage's loads from one run to the next.
    pub eps: f64,
    /// Also every run with the last stage in twice its increments.
    pub halved: bool,
    /// Runs at a time, each on one thread.
    pub jobs: usize,
    /// The failure figure; `None`: the first breakout for a cylinder test, else the deviator.
    pub figure: Option<Figure>,
}

/// One run of a spread.
#[derive(Debug, Clone)]
pub struct SpreadRun {
    /// Its `k`: the last stage's loads times `1 + k eps`.
    pub k: usize,
    /// The last stage's increments in it.
    pub increments: usize,
    /// Its result file.
    pub result: PathBuf,
    /// How it ended: "finished", the failure found, or the solver's error.
    pub end: String,
    /// Whether the solver gave up (no failure found).
    pub stalled: bool,
    /// Newton iterations over the run.
    pub iterations: usize,
    /// CPU time of the run (s), on its own thread, result file included.
    pub cpu: f64,
    /// The failure figure, where the run reached it.
    pub figure: Option<f64>,
}

/// The scene text with the last stage's load tables multiplied by `factor`, and, with
/// `halved`, its increments doubled.
pub fn perturbed(text: &str, file: &str, factor: f64, halved: bool) -> Result<String, Error> {
    let mut root: toml::Table = text
        .parse()
        .map_err(|e: toml::de::Error| InputError::new(file, e.message().to_string()))?;
    let no_stage = || InputError::new(file, "the scene has no stage to perturb").at_key("stages");
    let stage = match root.get_mut("stages") {
        Some(toml::Value::Array(stages)) => stages.last_mut().and_then(|s| s.as_table_mut()),
        _ => None,
    }
    .ok_or_else(no_stage)?;
    for name in LOAD_TABLES.iter().filter(|_| factor != 1.0) {
        if let Some(toml::Value::Table(loads)) = stage.get_mut(*name) {
            for (_, value) in loads.iter_mut() {
                *value = match *value {
                    toml::Value::Float(v) => toml::Value::Float(v * factor),
                    toml::Value::Integer(v) => toml::Value::Float(v as f64 * factor),
                    ref other => other.clone(),
                };
            }
        }
    }
    if halved {
        let doubled = match stage.get("increments") {
            Some(toml::Value::Integer(n)) if *n > 0 => 2 * n,
            _ => {
                return Err(
                    InputError::new(file, "the last stage has no increments to double")
                        .at_key("stages.increments")
                        .into(),
                )
            }
        };
        stage.insert("increments".into(), toml::Value::Integer(doubled));
    }
    Ok(toml::to_string(&root).expect("a TOML table serialises"))
}

/// Run the spread of the scene at `scene_path` with `config` into `dir`; `progress` hears
/// each run as it ends.
pub fn run_spread(
    plan: &SpreadPlan,
    scene_path: &Path,
    config: &SolverConfig,
    solver_text: &str,
    dir: &Path,
    progress: impl Fn(&SpreadRun) + Sync,
) -> Result<Vec<SpreadRun>, Error> {
    let scene_file = scene_path.display().to_string();
    let text = std::fs::read_to_string(scene_path).map_err(|e| Error::io(&scene_file, e))?;
    let sizes: &[bool] = if plan.halved {
        &[false, true]
    } else {
        &[false]
    };
    let jobs: Vec<(usize, bool)> = (0..plan.runs)
        .flat_map(|k| sizes.iter().map(move |&h| (k, h)))
        .collect();
    // Every scene is checked before any run starts: bad input stops the spread at once.
    let mut scenes = Vec::with_capacity(jobs.len());
    for &(k, halved) in &jobs {
        let scene_text = perturbed(&text, &scene_file, 1.0 + k as f64 * plan.eps, halved)?;
        let scene = parse_scene(&scene_text, &scene_file)?;
        scenes.push((scene_text, scene));
    }
    if let (Some(Figure::Wall(name)), Some((_, scene))) = (&plan.figure, scenes.first()) {
        let walls = scene.walls.iter().map(|w| &w.name);
        if !walls
            .chain(scene.circles.iter().map(|c| &c.name))
            .any(|n| n == name)
        {
            let message = format!("the scene has no wall or circle `{name}`");
            return Err(InputError::new(&scene_file, message)
                .at_key("--figure")
                .into());
        }
    }
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir.display(), e))?;
    let next = AtomicUsize::new(0);
    let done: Mutex<Vec<Option<Result<SpreadRun, Error>>>> =
        Mutex::new((0..jobs.len()).map(|_| None).collect());
    std::thread::scope(|scope| {
        for _ in 0..plan.jobs.clamp(1, jobs.len().max(1)) {
            scope.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(&(k, halved)) = jobs.get(i) else {
                    break;
                };
                let (scene_text, scene) = &scenes[i];
                let name = format!("run-{k}{}.h5", if halved { "-halved" } else { "" });
                let result = dir.join(name);
                let run = one_thread(|| {
                    let cpu = thread_cpu();
                    let mut sim = start(scene, scene_path, config.clone())?;
                    let increments = scene.stages.last().map_or(0, |s| s.increments);
                    let mut file =
                        ResultFile::create(&result, &header(&sim, scene_text, solver_text))?;
                    file.write_increment(&sim.state, &initial_report(&sim), &sim.stats)?;
                    let ended =
                        run_to_end(&mut sim, Some(&mut file), scene.output.every, |_, _| {});
                    drop(file);
                    let (end, stalled) = match ended {
                        Ok(RunEnd::Finished) => ("finished".to_string(), false),
                        Ok(RunEnd::Failed(failure)) => (failure.to_string(), false),
                        Err(Error::Numeric(e)) => (e.to_string(), true),
                        Err(e) => return Err(e),
                    };
                    Ok(SpreadRun {
                        k,
                        increments,
                        end,
                        stalled,
                        iterations: sim.stats.counters.newton_iterations,
                        cpu: thread_cpu() - cpu,
                        figure: None,
                        result: result.clone(),
                    })
                })
                .and_then(|mut run| {
                    run.figure = figure_of(&run.result, plan.figure.as_ref())?;
                    Ok(run)
                });
                if let Ok(run) = &run {
                    progress(run);
                }
                done.lock().expect("no run panics")[i] = Some(run);
            });
        }
    });
    let done = done.into_inner().expect("no run panics");
    done.into_iter()
        .map(|r| r.expect("every run ran"))
        .collect()
}

/// `work` on a pool of its own of one thread, as `grainstat run --threads 1` runs.
fn one_thread<T: Send>(work: impl FnOnce() -> Result<T, Error> + Send) -> Result<T, Error> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .map_err(|e| Error::io("thread pool", e))?
        .install(work)
}

/// CPU time of the calling thread (s).
fn thread_cpu() -> f64 {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `t` is a valid timespec for the call to fill.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut t) };
    t.tv_sec as f64 + 1e-9 * t.tv_nsec as f64
}

/// The failure figure of the run in `result` (see [`Figure`]; `None`: the first breakout of
/// a cylinder test, else the deviator); `None` where the run did not reach it (no breakout).
pub fn figure_of(result: &Path, figure: Option<&Figure>) -> Result<Option<f64>, Error> {
    let cylinder = match figure {
        None | Some(Figure::Breakout) => cylinder_failure(result)?,
        _ => None,
    };
    let figure = match (figure, &cylinder) {
        (Some(f), _) => f.clone(),
        (None, Some(_)) => Figure::Breakout,
        (None, None) => Figure::Deviator,
    };
    let history = read_history(result)?;
    let largest = |values: &mut dyn Iterator<Item = f64>| {
        values
            .filter(|v| v.is_finite())
            .map(f64::abs)
            .fold(None, |m: Option<f64>, v| Some(m.map_or(v, |m| m.max(v))))
    };
    Ok(match figure {
        Figure::Breakout => {
            let Some(c) = cylinder else {
                return Err(InputError::new(
                    result.display().to_string(),
                    "the run is no cylinder test: it has no breakout to read",
                )
                .into());
            };
            c.first_breakout()
        }
        Figure::Deviator => {
            // As `grainstat plot` estimates the peak: from the walls' stresses, at the
            // increments' peaks and at the failing increment's.
            let last = *read_increments(result)?.last().unwrap_or(&0);
            let (header, _) = read_state(result, last)?;
            let curves = Curves::new(&header, &history);
            (estimate(&header, &history, &curves).ok())
                .and_then(|p| p.peak)
                .filter(|p| p.reached)
                .map(|p| p.axial_stress - p.lateral_stress)
        }
        Figure::Wall(name) => {
            let last = *read_increments(result)?.last().unwrap_or(&0);
            let (header, _) = read_state(result, last)?;
            let Some(w) = header.walls.iter().position(|w| w.name == name) else {
                return Err(InputError::new(
                    result.display().to_string(),
                    format!("the run has no wall or circle `{name}`"),
                )
                .at_key("--figure")
                .into());
            };
            // At the increments' ends and their peaks, the failing increment's included.
            let peaks = history.at_peaks();
            let rows = history
                .wall("wall_stress")
                .iter()
                .chain(peaks.wall("wall_stress"));
            largest(&mut rows.filter_map(|row| row.get(w).copied()))
        }
    })
}

/// Median of `values` (NaN when there are none).
fn median(values: &[f64]) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len() as f64
}

/// The change of the mean from `coarse` to `fine` as a share of the coarse mean, with a 95%
/// bootstrap interval of it (each sample resampled on its own, seeded: the same runs give
/// the same interval).
pub fn change_on_halving(coarse: &[f64], fine: &[f64]) -> Option<(f64, f64, f64)> {
    if coarse.is_empty() || fine.is_empty() {
        return None;
    }
    let change = |c: f64, f: f64| f / c - 1.0;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let mut resample = |values: &[f64]| {
        (0..values.len())
            .map(|_| values[rng.random_range(0..values.len())])
            .sum::<f64>()
            / values.len() as f64
    };
    let mut changes: Vec<f64> = (0..RESAMPLES)
        .map(|_| {
            let c = resample(coarse);
            change(c, resample(fine))
        })
        .collect();
    changes.sort_by(f64::total_cmp);
    let at = |q: f64| changes[((q * RESAMPLES as f64) as usize).min(RESAMPLES - 1)];
    Some((change(mean(coarse), mean(fine)), at(0.025), at(0.975)))
}

/// The spread's table as markdown: one row per increment size (runs, stalls, iterations,
/// CPU, the figure's median, range and spread), the change on halving, then every run.
pub fn markdown(plan: &SpreadPlan, scene: &Path, runs: &[SpreadRun]) -> String {
    let mut out = String::new();
    let label = runs
        .first()
        .and_then(|r| figure_label(plan, &r.result))
        .unwrap_or_else(|| "failure figure".into());
    let _ = writeln!(
        out,
        "Round-off spread of `{}`: {} runs a step, the last stage's loads times `1 + k {:e}`.\n",
        scene.display(),
        plan.runs,
        plan.eps
    );
    let _ = writeln!(
        out,
        "| last stage's increments | runs | stalled | iterations: median (range) | CPU [s]: median (range) | {label}: median (range) | mean, sd |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|");
    let mut sizes: Vec<usize> = runs.iter().map(|r| r.increments).collect();
    sizes.sort_unstable();
    sizes.dedup();
    let figures_at = |n: usize| -> Vec<f64> {
        (runs.iter())
            .filter(|r| r.increments == n)
            .filter_map(|r| r.figure)
            .collect()
    };
    let range = |v: &[f64]| {
        let lo = v.iter().cloned().fold(f64::INFINITY, f64::min);
        let hi = v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        (lo, hi)
    };
    for &n in &sizes {
        let at: Vec<&SpreadRun> = runs.iter().filter(|r| r.increments == n).collect();
        let iterations: Vec<f64> = at.iter().map(|r| r.iterations as f64).collect();
        let cpu: Vec<f64> = at.iter().map(|r| r.cpu).collect();
        let figures = figures_at(n);
        let (ilo, ihi) = range(&iterations);
        let (clo, chi) = range(&cpu);
        let figure = if figures.is_empty() {
            "none reached".to_string()
        } else {
            let (flo, fhi) = range(&figures);
            let m = mean(&figures);
            let sd = (figures.iter().map(|f| (f - m).powi(2)).sum::<f64>()
                / (figures.len().max(2) - 1) as f64)
                .sqrt();
            format!(
                "{:.5e} ({:.5e} to {:.5e}) | {:.5e}, {:.2}%",
                median(&figures),
                flo,
                fhi,
                m,
                100.0 * sd / m.abs()
            )
        };
        let _ = writeln!(
            out,
            "| {n} | {} | {} | {:.0} ({:.0} to {:.0}) | {:.2} ({:.2} to {:.2}) | {figure} |",
            at.len(),
            at.iter().filter(|r| r.stalled).count(),
            median(&iterations),
            ilo,
            ihi,
            median(&cpu),
            clo,
            chi,
        );
    }
    if let [coarse, fine] = sizes[..] {
        let _ = writeln!(out);
        match change_on_halving(&figures_at(coarse), &figures_at(fine)) {
            Some((change, lo, hi)) => {
                let _ = writeln!(
                    out,
                    "Halving the increment changes the mean {label} by {:+.2}% (95%: {:+.2} to {:+.2}%).",
                    100.0 * change,
                    100.0 * lo,
                    100.0 * hi
                );
            }
            None => {
                let _ = writeln!(out, "The change on halving needs a figure at both steps.");
            }
        }
    }
    let _ = writeln!(
        out,
        "\n| k | increments | iterations | CPU [s] | {label} | end |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|");
    for r in runs {
        let figure = r.figure.map_or("-".to_string(), |f| format!("{f:.6e}"));
        let _ = writeln!(
            out,
            "| {} | {} | {} | {:.2} | {figure} | {} |",
            r.k,
            r.increments,
            r.iterations,
            r.cpu,
            r.end.split(':').next().unwrap_or_default()
        );
    }
    out
}

/// The figure's label as [`figure_of`] reads it from the run in `result`.
fn figure_label(plan: &SpreadPlan, result: &Path) -> Option<String> {
    Some(match &plan.figure {
        Some(f) => f.label(),
        None => match cylinder_failure(result).ok()? {
            Some(_) => Figure::Breakout.label(),
            None => Figure::Deviator.label(),
        },
    })
}

/// The spread's runs as CSV.
pub fn csv(runs: &[SpreadRun]) -> String {
    let mut out = String::from("k,increments,stalled,iterations,cpu_s,figure,end\n");
    for r in runs {
        let figure = r.figure.map_or(String::new(), |f| format!("{f:e}"));
        let _ = writeln!(
            out,
            "{},{},{},{},{:.4},{figure},\"{}\"",
            r.k,
            r.increments,
            r.stalled,
            r.iterations,
            r.cpu,
            r.end.replace('"', "'")
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const SCENE: &str = r#"
name = "t"
[[stages]]
increments = 5
stress = { top = 1e6 }
[[stages]]
increments = 10
stress = { outer = 1e8, top = 2 }
displacement = { top = 1e-4 }
"#;

    #[test]
    fn only_the_last_stage_is_perturbed_and_halved() {
        let text = perturbed(SCENE, "t.toml", 1.5, true).unwrap();
        let root: toml::Table = text.parse().unwrap();
        let stages = root["stages"].as_array().unwrap();
        assert_eq!(stages[0]["stress"]["top"].as_float(), Some(1e6));
        assert_eq!(stages[0]["increments"].as_integer(), Some(5));
        let last = &stages[1];
        assert_eq!(last["stress"]["outer"].as_float(), Some(1e8 * 1.5));
        assert_eq!(last["stress"]["top"].as_float(), Some(3.0));
        assert_eq!(last["displacement"]["top"].as_float(), Some(1e-4 * 1.5));
        assert_eq!(last["increments"].as_integer(), Some(20));
        // k = 0 is the scene as written.
        let same: toml::Table = perturbed(SCENE, "t.toml", 1.0, false)
            .unwrap()
            .parse()
            .unwrap();
        assert_eq!(same, SCENE.parse::<toml::Table>().unwrap());
    }

    #[test]
    fn a_scene_without_stages_is_bad_input() {
        let err = perturbed("name = \"t\"\n", "t.toml", 1.0, false).unwrap_err();
        assert!(matches!(err, Error::Input(_)), "{err}");
    }

    #[test]
    fn the_change_on_halving_brackets_its_mean() {
        let coarse = [100.0, 101.0, 99.0, 100.5, 99.5];
        let fine = [101.0, 102.0, 100.0, 101.5, 100.5];
        let (change, lo, hi) = change_on_halving(&coarse, &fine).unwrap();
        assert!((change - 0.01).abs() < 1e-12);
        assert!(
            lo < change && change < hi && lo > 0.0 && hi < 0.02,
            "{lo} {hi}"
        );
        assert!(change_on_halving(&[], &fine).is_none());
        assert!(Figure::parse("wall:load") == Ok(Figure::Wall("load".into())));
        assert!(Figure::parse("peak").is_err());
    }
}
