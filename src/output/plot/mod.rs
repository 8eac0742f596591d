//! Pictures of a result file, each as SVG and PNG: the curves over the written increments,
//! the sample at one increment (forces, displacements, rotations) and radar plots of the
//! contact fabric; with them the curves as CSV, and the XDMF for ParaView beside the result
//! file. This is what `grainstat plot` writes, and `grainstat run` at the end of a run.

mod charts;
mod grains;
mod radar;
mod study;
mod style;

use std::path::{Path, PathBuf};

use plotters::style::RGBColor;

use super::curves::{write_csv, Curve, Curves, LoadAxis};
use super::h5::input_error;
use super::hdf5_file::{
    group_name, read_history, read_increments, read_mechanism, read_state, History,
};
use super::xdmf::write_xdmf;
use crate::estimate::{cylinder_failure, estimate_stages};
use crate::scene::parse_scene;
use crate::state::State;
use crate::Error;
use charts::{LineChart, Series};
use grains::{Field, SamplePicture};
use radar::{Fabric, Radar, RadarSeries, BINS};
use study::{ErrorChart, ErrorSeries};
use style::{load_font, max_abs, save, si_unit, significant, PALETTE};

/// Where the pictures of `result` go unless told: `NAME-plots/` beside `NAME.h5`.
pub fn default_dir(result: &Path) -> PathBuf {
    let stem = result
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "result".into());
    result.with_file_name(format!("{stem}-plots"))
}

/// Draw the pictures of the result file `result` into `dir` (default: [`default_dir`]) at
/// `increment` (default: the last complete one), write the curves as `curves.csv` there (and
/// the macro parameters as `parameters.csv` and `.md` when they can be estimated, and a
/// cylinder test's failure as `cylinder.md` and `.csv`) and the XDMF beside the result file. Returns the files written.
pub fn plot(
    result: &Path,
    dir: Option<&Path>,
    increment: Option<usize>,
) -> Result<Vec<PathBuf>, Error> {
    let increments = read_increments(result)?;
    let (Some(&first), Some(&last)) = (increments.first(), increments.last()) else {
        return Err(input_error(result, "has no complete increment to plot"));
    };
    let increment = increment.unwrap_or(last);
    if increments.binary_search(&increment).is_err() {
        return Err(input_error(
            result,
            format!(
                "has no complete increment {increment} (complete: {} of {first} .. {last})",
                increments.len()
            ),
        ));
    }
    load_font()?;
    let dir = dir.map_or_else(|| default_dir(result), Path::to_path_buf);
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(dir.display(), e))?;

    let history = read_history(result)?;
    let (header, state) = read_state(result, increment)?;
    let curves = Curves::new(&header, &history);
    let csv = dir.join("curves.csv");
    write_csv(&csv, &header, &history, &curves)?;
    let mut written = vec![csv];
    // The macro parameters of each stage the walls make a test they can be read from.
    let parameters = estimate_stages(&header, &history, &curves);
    if !parameters.is_empty() {
        let names: Vec<String> = parse_scene(&header.scene_text, "the result's scene")
            .map(|s| s.stages.into_iter().map(|s| s.name).collect())
            .unwrap_or_default();
        let (mut csv, mut md) = (String::new(), String::new());
        for p in &parameters {
            let name = names.get(p.stage).map_or("", String::as_str);
            md.push_str(&format!(
                "### stage {} {name}\n\n{}\n",
                p.stage,
                p.markdown()
            ));
            for line in p.csv().lines().skip(usize::from(!csv.is_empty())) {
                let head = if csv.is_empty() { "stage" } else { "" };
                let stage = if head.is_empty() {
                    p.stage.to_string()
                } else {
                    head.into()
                };
                csv.push_str(&format!("{stage},{line}\n"));
            }
        }
        for (name, text) in [("parameters.csv", csv), ("parameters.md", md)] {
            let path = dir.join(name);
            std::fs::write(&path, text).map_err(|e| Error::io(path.display(), e))?;
            written.push(path);
        }
    }

    // A cylinder test's failure pressures beside eqs. 36-37, and its bonds broken by increment.
    if let Some(failure) = cylinder_failure(result)? {
        for (name, text) in [
            ("cylinder.md", failure.markdown()),
            ("cylinder.csv", failure.csv()),
        ] {
            let path = dir.join(name);
            std::fs::write(&path, text).map_err(|e| Error::io(path.display(), e))?;
            written.push(path);
        }
    }

    let region_names: Vec<&str> = header.regions.iter().map(|r| r.name.as_str()).collect();
    for (name, chart) in curve_charts(&header.scene_name, &curves, &history, &region_names) {
        written.extend(save(&chart, &dir, name)?);
    }

    let tag = group_name(increment);
    let at = format!("increment {increment}");
    let sample = [
        (Field::Forces, "forces", "contact forces"),
        (
            Field::Displacement,
            "displacement",
            "displacements since the start",
        ),
        (Field::Rotation, "rotation", "rotations since the start"),
    ];
    for (field, name, what) in sample {
        let title = format!("{}: {what}, {at}", header.scene_name);
        let picture = SamplePicture::new(field, title, &state);
        written.extend(save(&picture, &dir, &format!("{name}-{tag}"))?);
    }
    // The failure that ended the run after the increment plotted, if it did.
    let failure = read_mechanism(result)?.filter(|m| m.increment == increment + 1);
    if let Some(mechanism) = &failure {
        if mechanism.position.len() != state.grains.len() {
            return Err(input_error(
                result,
                format!(
                    "failure/position has {} rows for {} grains",
                    mechanism.position.len(),
                    state.grains.len()
                ),
            ));
        }
    }
    // Each cluster that broke out, against the sample as it is at the increment plotted;
    // those of a failing increment after it too.
    let mut shown = std::borrow::Cow::Borrowed(&state);
    if let Some(mechanism) = failure.as_ref() {
        if mechanism.breakouts.len() > state.breakouts.len() {
            let shown = shown.to_mut();
            for &g in mechanism.breakouts.iter().flat_map(|b| &b.grains) {
                shown.grains.taken_out[g] = true;
            }
            shown.breakouts.clone_from(&mechanism.breakouts);
        }
    }
    for (k, breakout) in shown.breakouts.iter().enumerate() {
        let loads: Vec<String> = (breakout.carried(&shown.membranes, &shown.walls).iter())
            .map(|(name, v)| {
                let unit = si_unit(v.abs(), "Pa");
                format!("{name} {} {}", significant(v * unit.factor, 4), unit.unit)
            })
            .collect();
        let loads = match loads.is_empty() {
            true => String::new(),
            false => format!(" at {}", loads.join(", ")),
        };
        let title = format!(
            "{}: breakout {} of {}, {} grains{loads}; {at}",
            header.scene_name,
            k + 1,
            shown.breakouts.len(),
            breakout.grains.len()
        );
        let picture = SamplePicture::new(Field::Breakout(k), title, &shown);
        written.extend(save(&picture, &dir, &format!("breakout-{}-{tag}", k + 1))?);
    }

    // The mechanism of the failure that ended the run, after the last increment in
    // equilibrium: the grains as the descent that found no equilibrium near carried them.
    // A run that ended at its first breakout carried none on: its picture is the breakout's.
    if let Some(mechanism) = failure.filter(|m| !m.grains.is_empty()) {
        let mut carried = shown.into_owned();
        carried.grains.position = mechanism.position;
        carried.grains.displacement = mechanism.displacement;
        let title = format!(
            "{}: no equilibrium near in increment {}, {} grains carried on by the descent",
            header.scene_name,
            mechanism.increment,
            mechanism.grains.len()
        );
        let picture = SamplePicture::new(Field::Displacement, title, &carried);
        written.extend(save(&picture, &dir, &format!("mechanism-{tag}"))?);
    }

    let start = if first == increment {
        None
    } else {
        Some(read_state(result, first)?.1)
    };
    let (orientation, forces) = radar_plots(
        &header.scene_name,
        increment,
        &state,
        start.as_ref().map(|s| (first, s)),
    );
    written.extend(save(&orientation, &dir, &format!("orientation-{tag}"))?);
    written.extend(save(&forces, &dir, &format!("contact-forces-{tag}"))?);

    written.push(write_xdmf(result)?);
    Ok(written)
}

/// Stress-strain, volumetric strain, contacts per grain and bonds broken against the load;
/// the mean grain rotation and each region's stresses when the history has them.
fn curve_charts(
    scene: &str,
    curves: &Curves,
    history: &History,
    regions: &[&str],
) -> Vec<(&'static str, LineChart)> {
    let (x, x_label): (Vec<f64>, String) = match curves.axis {
        LoadAxis::Strain { .. } => (
            curves.load.values.iter().map(|v| 100.0 * v).collect(),
            format!("{} [%]", curves.load.label),
        ),
        LoadAxis::Pressure { .. } => {
            let unit = si_unit(max_abs(&curves.load.values), "Pa");
            (
                curves.load.values.iter().map(|v| v * unit.factor).collect(),
                format!("{} [{}]", curves.load.label, unit.unit),
            )
        }
        LoadAxis::Increment => (curves.load.values.clone(), curves.load.label.clone()),
    };
    let points = |y: &[f64], factor: f64| -> Vec<(f64, f64)> {
        x.iter().zip(y).map(|(x, y)| (*x, y * factor)).collect()
    };
    let single = |label: &str, y: &[f64], factor: f64| {
        vec![Series {
            label: label.into(),
            points: points(y, factor),
            colour: PALETTE[0],
            dashed: false,
        }]
    };
    let chart = |title: &str, y_label: String, y_from_zero: bool, series: Vec<Series>| LineChart {
        title: format!("{scene}: {title}"),
        x_label: x_label.clone(),
        y_label,
        y_from_zero,
        series,
    };

    let unit = si_unit(
        max_abs(curves.stresses.iter().flat_map(|c| c.values.iter())),
        "Pa",
    );
    let stress = curves
        .stresses
        .iter()
        .map(|c| Series {
            label: c.label.clone(),
            points: points(&c.values, unit.factor),
            colour: colour_of(&curves.stresses, c),
            dashed: c.from_contacts,
        })
        .collect();
    let mut charts = vec![(
        "stress-strain",
        chart(
            "stresses (solid: on the walls, dashed: from the contact forces)",
            format!("stress [{}], compression positive", unit.unit),
            true,
            stress,
        ),
    )];
    if let Some(v) = &curves.volumetric_strain {
        charts.push((
            "volumetric-strain",
            chart(
                "volumetric strain",
                "volumetric strain ε_v [%], compaction positive".into(),
                false,
                single(&v.label, &v.values, 100.0),
            ),
        ));
    }
    charts.push((
        "contacts-per-grain",
        chart(
            "grain-grain contacts per grain",
            "contacts per grain [-]".into(),
            false,
            single("contacts per grain", &curves.contacts_per_grain, 1.0),
        ),
    ));
    charts.push((
        "broken-bonds",
        chart(
            "bonds broken so far",
            "bonds broken [-]".into(),
            true,
            single("bonds broken", &curves.broken_bonds, 1.0),
        ),
    ));
    let (mean, absolute) = (
        history.float("mean_rotation"),
        history.float("mean_absolute_rotation"),
    );
    if mean.len() == x.len() && absolute.len() == x.len() {
        let series = [
            ("mean rotation", mean),
            ("mean absolute rotation", absolute),
        ]
        .into_iter()
        .enumerate()
        .map(|(k, (label, values))| Series {
            label: label.into(),
            points: points(values, 1.0),
            colour: PALETTE[k],
            dashed: false,
        })
        .collect();
        charts.push((
            "mean-rotation",
            chart(
                "grain rotation since the start",
                "rotation [rad], anticlockwise positive".into(),
                false,
                series,
            ),
        ));
    }
    // Each region in a colour of its own: sigma_xx solid, sigma_yy dashed.
    let components = [
        ("xx", history.region("region_stress_xx")),
        ("yy", history.region("region_stress_yy")),
    ];
    if !regions.is_empty() && components.iter().all(|(_, rows)| rows.len() == x.len()) {
        let unit = si_unit(
            max_abs(
                components
                    .iter()
                    .flat_map(|(_, rows)| rows.iter().flatten()),
            ),
            "Pa",
        );
        let mut series = Vec::new();
        for (k, name) in regions.iter().enumerate() {
            for (c, (component, rows)) in components.iter().enumerate() {
                let values: Vec<f64> = rows.iter().map(|row| row[k]).collect();
                series.push(Series {
                    label: format!("{name}: σ_{component}"),
                    points: points(&values, unit.factor),
                    colour: PALETTE[k % PALETTE.len()],
                    dashed: c == 1,
                });
            }
        }
        charts.push((
            "region-stresses",
            chart(
                "stresses in the regions, eq. A.40 (solid: σ_xx, dashed: σ_yy)",
                format!("stress [{}], compression positive", unit.unit),
                false,
                series,
            ),
        ));
    }
    charts.extend(shear_charts(scene, &curves.shear));
    charts
}

/// The simple shear charts against the shear strain: shear and normal stresses on the walls
/// and in the regions, the regions' principal direction and friction angle, and their grain
/// rotation over the walls'. None when no wall turned.
fn shear_charts(scene: &str, shear: &[Curve]) -> Vec<(&'static str, LineChart)> {
    let Some((gamma, rest)) = shear.split_first() else {
        return Vec::new();
    };
    let x_label = format!("{} [%]", gamma.label);
    let kind = |c: &Curve| c.key.split(':').next().unwrap_or_default().to_owned();
    let series = |kinds: &[&str], factor: f64| -> Vec<Series> {
        let picked: Vec<&Curve> = rest
            .iter()
            .filter(|c| kinds.contains(&kind(c).as_str()))
            .collect();
        picked
            .iter()
            .enumerate()
            .map(|(k, c)| Series {
                label: c.label.clone(),
                points: gamma
                    .values
                    .iter()
                    .zip(&c.values)
                    .map(|(g, v)| (100.0 * g, v * factor))
                    .collect(),
                colour: PALETTE[k % PALETTE.len()],
                dashed: c.from_contacts,
            })
            .collect()
    };
    let chart = |title: &str, y_label: String, y_from_zero: bool, series: Vec<Series>| LineChart {
        title: format!("{scene}: {title}"),
        x_label: x_label.clone(),
        y_label,
        y_from_zero,
        series,
    };
    let stresses = ["tau_walls", "sigma_xx", "sigma_yy", "tau"];
    let unit = si_unit(
        max_abs(
            rest.iter()
                .filter(|c| stresses.contains(&kind(c).as_str()))
                .flat_map(|c| c.values.iter()),
        ),
        "Pa",
    );
    vec![
        (
            "shear-stress",
            chart(
                "stresses (solid: on the walls, dashed: in the regions)",
                format!("stress [{}], compression positive", unit.unit),
                true,
                series(&stresses, unit.factor),
            ),
        ),
        (
            "principal-direction",
            chart(
                "major principal direction β and friction angle φ' (eq. A.25)",
                "angle [°]".into(),
                true,
                series(&["beta", "phi"], 1.0),
            ),
        ),
        (
            "grain-rotation",
            chart(
                "mean grain rotation over the walls' (eq. 30)",
                "γ_μ / γ [-]".into(),
                false,
                series(&["rotation_ratio"], 1.0),
            ),
        ),
    ]
}

/// A stress curve's colour: one per quantity, shared by its wall and contact versions.
fn colour_of(all: &[Curve], curve: &Curve) -> RGBColor {
    let quantity = |c: &Curve| {
        c.key
            .trim_end_matches("_walls")
            .trim_end_matches("_contacts")
            .to_owned()
    };
    let mut seen: Vec<String> = Vec::new();
    for c in all {
        let q = quantity(c);
        if !seen.contains(&q) {
            seen.push(q);
        }
    }
    let k = seen.iter().position(|q| *q == quantity(curve)).unwrap_or(0);
    PALETTE[k % PALETTE.len()]
}

/// The orientation histogram (against the first written increment) and the mean forces per
/// direction.
fn radar_plots(
    scene: &str,
    increment: usize,
    state: &State,
    start: Option<(usize, &State)>,
) -> (Radar, Radar) {
    let now = Fabric::of(state);
    let mut series = vec![RadarSeries {
        label: format!("increment {increment}"),
        values: now.count,
        colour: PALETTE[0],
        dashed: false,
    }];
    if let Some((first, s)) = start {
        series.push(RadarSeries {
            label: format!("increment {first}"),
            values: Fabric::of(s).count,
            colour: PALETTE[1],
            dashed: true,
        });
    }
    let orientation = Radar {
        title: format!(
            "{scene}: grain-grain contacts per {}° of contact angle",
            180 / BINS
        ),
        series,
    };

    let unit = si_unit(max_abs(now.normal.iter().chain(&now.shear)), "N");
    let mut series = Vec::new();
    for (name, values, colour) in [
        ("F_n", now.normal, PALETTE[0]),
        ("F_s", now.shear, PALETTE[1]),
    ] {
        let part = |sign: f64| values.map(|v| (sign * v).max(0.0) * unit.factor);
        series.push(RadarSeries {
            label: format!("mean {name} > 0"),
            values: part(1.0),
            colour,
            dashed: false,
        });
        if values.iter().any(|v| *v < 0.0) {
            series.push(RadarSeries {
                label: format!("-(mean {name}) where < 0"),
                values: part(-1.0),
                colour,
                dashed: true,
            });
        }
    }
    let forces = Radar {
        title: format!(
            "{scene}: mean contact forces [{}] by contact angle, increment {increment}",
            unit.unit
        ),
        series,
    };
    (orientation, forces)
}

/// The study's pictures in `dir`: the largest macro stress error of each run over its
/// increments (`study.svg`, `.png`), and its error in the first increment, where every run
/// starts from the same state (`study-increment-1.svg`, `.png`), against the run's CPU time;
/// one line per strategy and way of stopping.
pub fn plot_study(
    dir: &Path,
    scene: &str,
    rows: &[crate::study::StudyRow],
) -> Result<Vec<PathBuf>, Error> {
    load_font()?;
    let families = [
        ("minimise", "tolerance", "global minimisation, by tolerance"),
        ("relaxation", "n_i", "relaxation, n_i sweeps per increment"),
        ("relaxation", "tolerance", "relaxation, to a tolerance"),
    ];
    let chart = |first: bool| ErrorChart {
        title: if first {
            format!("{scene}: macro stress error in increment 1 against CPU time")
        } else {
            format!("{scene}: macro stress error against CPU time")
        },
        y_label: if first {
            "macro stress error in increment 1".into()
        } else {
            "largest macro stress error over the increments".into()
        },
        series: families
            .iter()
            .zip(PALETTE)
            .map(|(&(solver, setting, label), colour)| ErrorSeries {
                label: label.into(),
                points: rows
                    .iter()
                    .filter(|r| r.trial.solver == solver && r.trial.setting.starts_with(setting))
                    .filter_map(|r| {
                        let error = if first {
                            r.errors.first().map(|e| e.macro_stress)
                        } else {
                            r.worst().map(|w| w.macro_stress)
                        };
                        error.map(|e| (r.track.cpu, e, r.trial.setting.clone()))
                    })
                    .collect(),
                colour,
            })
            .filter(|s| !s.points.is_empty())
            .collect(),
    };
    let mut files = save(&chart(false), dir, "study")?;
    files.extend(save(&chart(true), dir, "study-increment-1")?);
    Ok(files)
}
