//! A sweep: one test scene run at several values of some of its keys (the lateral pressure of
//! a biaxial test, a sample's seed), the macro parameters of each run collected in one table,
//! and `c'`, `phi'` fitted to their peaks (eq. A.94).
//!
//! The sweep file names the scene, the keys and the values:
//!
//! ```toml
//! scene = "biaxial-sand.toml"
//! solver = "../solvers/reference.toml"
//! label = "sigma_3"
//! unit = "Pa"
//! keys = ["stages.0.stress.left", "stages.0.stress.right", "stages.0.stress.top"]
//! values = [1e5, 2e5, 3e5, 4e5]
//! ```
//!
//! Each run sets every key to the run's value (a key is a dotted path into the scene; a
//! number picks an element of an array of tables) and goes to `DIR/run-K.h5`, with its
//! pictures beside it. A run that stops early keeps what it computed, and its parameters are
//! estimated from that.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::estimate::{estimate, mohr_coulomb, significant, Parameters, Peak};
use crate::output::curves::Curves;
use crate::output::plot::plot;
use crate::output::{read_history, read_increments, read_state, ResultFile};
use crate::run::{header, initial_report, run_to_end, start, RunEnd};
use crate::scene::parse_scene;
use crate::solver::SolverConfig;
use crate::{Error, InputError};

/// A sweep file.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SweepSpec {
    /// The test scene (relative to the sweep file).
    pub scene: String,
    /// What the values are, for the table's first column.
    #[serde(default = "default_label")]
    pub label: String,
    /// Their unit.
    #[serde(default)]
    pub unit: String,
    /// Solver settings of every run (relative to the sweep file); `--solver` overrides it.
    #[serde(default)]
    pub solver: Option<String>,
    /// Dotted paths of the scene keys each run sets.
    pub keys: Vec<String>,
    /// One run per value.
    pub values: Vec<toml::Value>,
}

fn default_label() -> String {
    "value".into()
}

/// One run of a sweep.
#[derive(Debug, Clone)]
pub struct SweepRun {
    /// The value the keys were set to.
    pub value: toml::Value,
    /// Its result file.
    pub result: PathBuf,
    /// Why it stopped before the end of its load program, if it did.
    pub stopped: Option<String>,
    /// Its macro parameters, or why there are none.
    pub parameters: Result<Parameters, String>,
}

/// Read a sweep file.
pub fn load_sweep(path: &Path) -> Result<SweepSpec, Error> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(&file, e))?;
    let spec: SweepSpec = toml::from_str(&text).map_err(|e| {
        let mut err = InputError::new(&file, e.message().to_string());
        if let Some(span) = e.span() {
            err = err.at_line(text[..span.start].lines().count().max(1));
        }
        err
    })?;
    if spec.keys.is_empty() || spec.values.is_empty() {
        return Err(
            InputError::new(&file, "a sweep needs at least one key and one value")
                .at_key(if spec.keys.is_empty() {
                    "keys"
                } else {
                    "values"
                })
                .into(),
        );
    }
    Ok(spec)
}

/// The scene text with every key set to `value`.
pub fn set_keys(
    scene_text: &str,
    keys: &[String],
    value: &toml::Value,
    file: &str,
) -> Result<String, Error> {
    let table: toml::Table = scene_text
        .parse()
        .map_err(|e: toml::de::Error| InputError::new(file, e.message().to_string()))?;
    let mut root = toml::Value::Table(table);
    for key in keys {
        let missing = || InputError::new(file, format!("the scene has no key `{key}` to set"));
        let parts: Vec<&str> = key.split('.').collect();
        let (last, path) = parts.split_last().ok_or_else(missing)?;
        let mut at = &mut root;
        for part in path {
            at = match at {
                toml::Value::Table(t) => t.get_mut(*part),
                toml::Value::Array(items) => {
                    part.parse::<usize>().ok().and_then(|i| items.get_mut(i))
                }
                _ => None,
            }
            .ok_or_else(missing)?;
        }
        match at {
            toml::Value::Table(t) => {
                t.insert((*last).to_string(), value.clone());
            }
            _ => return Err(missing().into()),
        }
    }
    Ok(toml::to_string(&root).expect("a TOML table serialises"))
}

/// Run every value of a sweep with `config` into `dir`; `progress` hears each run's start.
pub fn run_sweep(
    spec: &SweepSpec,
    sweep_path: &Path,
    config: &SolverConfig,
    solver_text: &str,
    dir: &Path,
    mut progress: impl FnMut(usize, &toml::Value),
) -> Result<Vec<SweepRun>, Error> {
    let base = sweep_path.parent().unwrap_or(Path::new("."));
    let scene_path = base.join(&spec.scene);
    let scene_file = scene_path.display().to_string();
    let text = std::fs::read_to_string(&scene_path).map_err(|e| Error::io(&scene_file, e))?;
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir.display(), e))?;
    let mut runs = Vec::new();
    for (k, value) in spec.values.iter().enumerate() {
        progress(k, value);
        let scene_text = set_keys(&text, &spec.keys, value, &scene_file)?;
        let scene = parse_scene(&scene_text, &scene_file)?;
        let mut sim = start(&scene, &scene_path, config.clone())?;
        let result = dir.join(format!("run-{k}.h5"));
        let mut file = ResultFile::create(&result, &header(&sim, &scene_text, solver_text))?;
        file.write_increment(&sim.state, &initial_report(&sim), &sim.stats)?;
        // A run that stops keeps what it computed; the sweep goes on.
        let stopped = match run_to_end(&mut sim, Some(&mut file), scene.output.every, |_, _| {}) {
            Ok(RunEnd::Finished) => None,
            Ok(RunEnd::Failed(failure)) => Some(failure.to_string()),
            Err(Error::Numeric(e)) => Some(e.to_string()),
            Err(e) => return Err(e),
        };
        plot(&result, None, None)?;
        runs.push(SweepRun {
            value: value.clone(),
            parameters: parameters_of(&result),
            result,
            stopped,
        });
    }
    Ok(runs)
}

/// The macro parameters of a result file.
pub fn parameters_of(result: &Path) -> Result<Parameters, String> {
    let history = read_history(result).map_err(|e| e.to_string())?;
    let last = *read_increments(result)
        .map_err(|e| e.to_string())?
        .last()
        .ok_or("no increment written")?;
    let (header, _) = read_state(result, last).map_err(|e| e.to_string())?;
    let curves = Curves::new(&header, &history);
    estimate(&header, &history, &curves).map_err(|e| e.0)
}

/// The sweep's table as markdown: one row per run, then the Mohr-Coulomb fit of the peaks.
pub fn markdown(spec: &SweepSpec, runs: &[SweepRun]) -> String {
    let unit = if spec.unit.is_empty() {
        String::new()
    } else {
        format!(" [{}]", spec.unit)
    };
    let mut text = format!(
        "| {}{unit} | E [Pa] | E predicted [Pa] | nu begin | nu end | peak sigma_1 [Pa] | sigma_3 at peak [Pa] | phi' [deg] | psi [deg] | n_c/v | run |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n",
        spec.label
    );
    for run in runs {
        let value = value_text(&run.value);
        let state = match &run.stopped {
            None => "to the end".to_string(),
            Some(why) => format!("stopped: {why}"),
        };
        match &run.parameters {
            Ok(p) => {
                let f = |v: f64| significant(v);
                let peak = p.peak.as_ref();
                let bound = |text: String| match peak {
                    Some(pk) if !failed(run, pk) => format!("≥ {text}"),
                    _ => text,
                };
                let _ = writeln!(
                    text,
                    "| {value} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {state} |",
                    f(p.young),
                    p.prediction.map_or("-".into(), |q| f(q.young)),
                    f(p.poisson_begin),
                    f(p.poisson_end),
                    peak.map_or("-".into(), |pk| bound(f(pk.axial_stress))),
                    peak.map_or("-".into(), |pk| f(pk.lateral_stress)),
                    peak.map_or("-".into(), |pk| bound(f(pk.friction_angle))),
                    f(p.dilatancy_angle),
                    f(p.contact_density),
                );
            }
            Err(why) => {
                let _ = writeln!(
                    text,
                    "| {value} | no estimate: {why} | | | | | | | | | {state} |"
                );
            }
        }
    }
    let peaks: Vec<(f64, f64)> = runs
        .iter()
        .filter_map(|r| Some((r, r.parameters.as_ref().ok()?.peak?)))
        .filter(|(r, p)| failed(r, p))
        .map(|(_, p)| (p.lateral_stress, p.axial_stress))
        .collect();
    match mohr_coulomb(&peaks) {
        Some((c, phi)) => {
            let _ = writeln!(
                text,
                "\nMohr-Coulomb fit (eq. A.94) over the {} peaks: c' = {} Pa, phi' = {} deg",
                peaks.len(),
                significant(c),
                significant(phi)
            );
        }
        None => {
            let _ = writeln!(
                text,
                "\nMohr-Coulomb fit: needs peaks at two lateral stresses or more ({} reached)",
                peaks.len()
            );
        }
    }
    text
}

/// The sweep's table as CSV, one row per run.
pub fn csv(spec: &SweepSpec, runs: &[SweepRun]) -> String {
    let mut text = format!(
        "{},young,young_predicted,poisson_begin,poisson_end,peak_axial_stress,peak_lateral_stress,failed,friction_angle,dilatancy_angle,contact_density,stopped\n",
        spec.label.replace(',', ";")
    );
    for run in runs {
        let stopped = run
            .stopped
            .as_deref()
            .unwrap_or("")
            .replace(['"', ','], ";");
        let row = match &run.parameters {
            Ok(p) => {
                let peak = p.peak;
                let v = |x: Option<f64>| x.map_or(String::new(), |x| format!("{x:e}"));
                [
                    v(Some(p.young)),
                    v(p.prediction.map(|q| q.young)),
                    v(Some(p.poisson_begin)),
                    v(Some(p.poisson_end)),
                    v(peak.map(|k| k.axial_stress)),
                    v(peak.map(|k| k.lateral_stress)),
                    peak.map_or(String::new(), |k| failed(run, &k).to_string()),
                    v(peak.map(|k| k.friction_angle)),
                    v(Some(p.dilatancy_angle)),
                    v(Some(p.contact_density)),
                ]
                .join(",")
            }
            Err(_) => ",,,,,,,,,".into(),
        };
        let _ = writeln!(text, "{},{row},\"{stopped}\"", value_text(&run.value));
    }
    text
}

/// Whether a run's peak is its failure: the deviator fell after it, or the run stopped
/// there because the sample found no equilibrium beyond it.
fn failed(run: &SweepRun, peak: &Peak) -> bool {
    peak.reached || run.stopped.is_some()
}

fn value_text(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}
