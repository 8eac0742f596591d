//! The curves of a run, from `/history`: stresses, volumetric strain, contacts per grain and
//! bonds broken against a load axis chosen from the walls, and their CSV table.
//!
//! The axis is what a laboratory would plot against: the strain of the gap between two
//! opposite straight walls (the pair that deformed most, "axial"), else the applied stress
//! of a stress-controlled wall that changes (a cylinder test's pressure), else the increment.
//! Compression is positive throughout, as in the result file.

use std::fmt::Write as _;
use std::path::Path;

use super::hdf5_file::{History, RunHeader};
use crate::geometry::{MembraneShape, Wall};
use crate::Error;

/// What the curves are plotted against.
#[derive(Debug, Clone, PartialEq)]
pub enum LoadAxis {
    /// Strain of the gap between the `axial` pair of opposite walls; `lateral` is the pair
    /// perpendicular to it, when there is one.
    Strain {
        /// The pair of opposite walls whose gap deformed most.
        axial: [usize; 2],
        /// The pair perpendicular to it.
        lateral: Option<[usize; 2]>,
    },
    /// The applied stress of a stress-controlled wall (a pressure).
    Pressure {
        /// The wall.
        wall: usize,
    },
    /// The increment number.
    Increment,
}

/// One curve: values per written increment.
#[derive(Debug, Clone, PartialEq)]
pub struct Curve {
    /// Column name in the CSV (no spaces).
    pub key: String,
    /// Label in a legend.
    pub label: String,
    /// Measured from the contact forces (eq. A.41) rather than on the walls: drawn dashed.
    pub from_contacts: bool,
    /// One value per row (may be NaN where undefined).
    pub values: Vec<f64>,
}

/// The curves of a run, one value per complete written increment.
#[derive(Debug, Clone, PartialEq)]
pub struct Curves {
    /// The increments.
    pub increment: Vec<i64>,
    /// What `load` is.
    pub axis: LoadAxis,
    /// The load axis: strain (-), stress (Pa) or increment.
    pub load: Curve,
    /// Stresses (Pa): on the walls and from the contact forces.
    pub stresses: Vec<Curve>,
    /// Strain of the lateral pair of walls (-, compression positive), when there is one.
    pub lateral_strain: Option<Curve>,
    /// Volumetric strain (-, compaction positive), when the sample's area is known.
    pub volumetric_strain: Option<Curve>,
    /// Stage of each row and increments done in it; a row ending a stage is the next
    /// stage's increment 0.
    pub stage: Vec<(i64, i64)>,
    /// Grain-grain contacts per grain.
    pub contacts_per_grain: Vec<f64>,
    /// Bonds broken so far.
    pub broken_bonds: Vec<f64>,
    /// The simple shear curves, when walls turned (see [`shear_curves`]): the shear strain
    /// first, then the wall shear stresses and each region's stresses, principal direction,
    /// mobilised friction angle and grain rotation.
    pub shear: Vec<Curve>,
}

impl Curves {
    /// The curves of a history, with the walls of its header.
    pub fn new(header: &RunHeader, history: &History) -> Curves {
        let rows = history.len();
        let position = history.wall("wall_position");
        let applied = history.wall("wall_applied_stress");
        let measured = history.wall("wall_stress");
        let walls: Vec<Wall> = header.walls.iter().map(|h| h.wall([0.0; 3], 0.0)).collect();
        // Gap between a pair of opposite walls at a row, and its strain since the first row
        // (a test that starts from a prepared sample starts where the preparation ended).
        let gap = |[i, j]: [usize; 2], r: usize| {
            -(walls[i].surface(position[r][i]) + walls[j].surface(position[r][j]))
        };
        let strain = |pair: [usize; 2]| -> Vec<f64> {
            (0..rows)
                .map(|r| 1.0 - gap(pair, r) / gap(pair, 0))
                .collect()
        };
        let mut pairs = Vec::new();
        for i in 0..walls.len() {
            for j in i + 1..walls.len() {
                if walls[i].faces(&walls[j]) {
                    pairs.push([i, j]);
                }
            }
        }
        let on_walls = |pair: [usize; 2]| -> Vec<f64> {
            (0..rows)
                .map(|r| {
                    let v: Vec<f64> = pair
                        .iter()
                        .map(|&w| measured[r][w])
                        .filter(|s| s.is_finite())
                        .collect();
                    v.iter().sum::<f64>() / v.len() as f64
                })
                .collect()
        };
        // The loaded pair: the one whose stress changed most (a dilating sample can widen more
        // than it is shortened), else the one that deformed most, else the vertical one.
        let axial = pairs.iter().copied().max_by(|&a, &b| {
            let key = |p: [usize; 2]| {
                let stress = on_walls(p);
                let range = stress.iter().fold(f64::NEG_INFINITY, |m, &v| m.max(v))
                    - stress.iter().fold(f64::INFINITY, |m, &v| m.min(v));
                let last = strain(p).last().copied().unwrap_or(0.0).abs();
                (
                    if range.is_finite() { range } else { 0.0 },
                    last,
                    walls[p[0]].normal[1].abs(),
                )
            };
            key(a)
                .partial_cmp(&key(b))
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        let macro_along = |n: [f64; 2]| -> Vec<f64> {
            let (xx, yy) = (
                history.float("macro_stress_xx"),
                history.float("macro_stress_yy"),
            );
            let (xy, yx) = (
                history.float("macro_stress_xy"),
                history.float("macro_stress_yx"),
            );
            (0..rows)
                .map(|r| n[0] * n[0] * xx[r] + n[0] * n[1] * (xy[r] + yx[r]) + n[1] * n[1] * yy[r])
                .collect()
        };
        let curve = |key: &str, label: String, from_contacts: bool, values: Vec<f64>| Curve {
            key: key.to_owned(),
            label,
            from_contacts,
            values,
        };
        let names = |[i, j]: [usize; 2]| format!("{}-{}", walls[i].name, walls[j].name);

        let (axis, load, stresses, lateral_strain, volumetric) = if let Some(axial) = axial {
            let lateral = pairs
                .iter()
                .copied()
                .find(|p| walls[p[0]].perpendicular_to(&walls[axial[0]]));
            let load = curve(
                "axial_strain",
                format!("axial strain ε_a ({})", names(axial)),
                false,
                strain(axial),
            );
            let mut stresses = vec![
                curve(
                    "axial_stress_walls",
                    format!("σ_a on the walls ({})", names(axial)),
                    false,
                    on_walls(axial),
                ),
                curve(
                    "axial_stress_contacts",
                    "σ_a from the contacts".into(),
                    true,
                    macro_along(walls[axial[0]].normal),
                ),
            ];
            // The lateral side: a pair of walls, or side membranes (the unconfined test), whose
            // strain is the mean width's: the area they and the axial walls enclose over the
            // axial gap.
            let membranes: Vec<usize> = (0..header.membranes.len())
                .filter(|&m| match header.membranes[m].shape {
                    MembraneShape::Side { outward } => {
                        let n = walls[axial[0]].normal;
                        (outward[0] * n[0] + outward[1] * n[1]).abs() < 1e-9
                    }
                    MembraneShape::Ring { .. } => false,
                })
                .collect();
            let volume = history.float("volume");
            let side = match lateral {
                Some(lateral) => Some((
                    format!("walls {}", names(lateral)),
                    on_walls(lateral),
                    strain(lateral),
                    walls[lateral[0]].normal,
                    (0..rows)
                        .map(|r| {
                            1.0 - gap(axial, r) * gap(lateral, r)
                                / (gap(axial, 0) * gap(lateral, 0))
                        })
                        .collect::<Vec<f64>>(),
                )),
                None if !membranes.is_empty()
                    && rows > 0
                    && history.membrane_pressure.len() == rows
                    && volume.iter().all(|v| v.is_finite()) =>
                {
                    let width = |r: usize| volume[r] / gap(axial, r);
                    let MembraneShape::Side { outward } = header.membranes[membranes[0]].shape
                    else {
                        unreachable!("only side membranes are kept")
                    };
                    let names: Vec<&str> = membranes
                        .iter()
                        .map(|&m| header.membranes[m].name.as_str())
                        .collect();
                    Some((
                        format!("membranes {}", names.join("-")),
                        (0..rows)
                            .map(|r| {
                                membranes
                                    .iter()
                                    .map(|&m| history.membrane_pressure[r][m])
                                    .sum::<f64>()
                                    / membranes.len() as f64
                            })
                            .collect(),
                        (0..rows).map(|r| 1.0 - width(r) / width(0)).collect(),
                        outward,
                        volume.iter().map(|v| 1.0 - v / volume[0]).collect(),
                    ))
                }
                None => None,
            };
            let mut volumetric = None;
            let mut lateral_strain = None;
            if let Some((side_names, sl, el, lateral_normal, ev)) = side {
                lateral_strain = Some(curve(
                    "lateral_strain",
                    format!("lateral strain ε_l ({side_names})"),
                    false,
                    el,
                ));
                let sa = on_walls(axial);
                let (ma, ml) = (
                    macro_along(walls[axial[0]].normal),
                    macro_along(lateral_normal),
                );
                stresses.extend([
                    curve(
                        "lateral_stress_walls",
                        format!("σ_l on the {side_names}"),
                        false,
                        sl.clone(),
                    ),
                    curve(
                        "lateral_stress_contacts",
                        "σ_l from the contacts".into(),
                        true,
                        ml.clone(),
                    ),
                    curve(
                        "deviator_stress_walls",
                        "σ_a - σ_l on the walls".into(),
                        false,
                        sa.iter().zip(&sl).map(|(a, l)| a - l).collect(),
                    ),
                    curve(
                        "deviator_stress_contacts",
                        "σ_a - σ_l from the contacts".into(),
                        true,
                        ma.iter().zip(&ml).map(|(a, l)| a - l).collect(),
                    ),
                ]);
                volumetric = Some(curve(
                    "volumetric_strain",
                    "volumetric strain ε_v".into(),
                    false,
                    ev,
                ));
            }
            let axis = LoadAxis::Strain { axial, lateral };
            (axis, load, stresses, lateral_strain, volumetric)
        } else {
            let pressure = (0..walls.len()).find(|&w| {
                let v: Vec<f64> = (0..rows).map(|r| applied[r][w]).collect();
                header.walls[w].control == crate::geometry::WallControl::Stress
                    && v.iter().any(|s| *s != v[0])
            });
            let (axis, load) = match pressure {
                Some(w) => (
                    LoadAxis::Pressure { wall: w },
                    curve(
                        "applied_stress",
                        format!("applied stress on {}", walls[w].name),
                        false,
                        (0..rows).map(|r| applied[r][w]).collect(),
                    ),
                ),
                None => (
                    LoadAxis::Increment,
                    curve(
                        "load_step",
                        "load step (increment)".into(),
                        false,
                        history.int("increment").iter().map(|&k| k as f64).collect(),
                    ),
                ),
            };
            let mut stresses: Vec<Curve> = (0..walls.len())
                .map(|w| {
                    curve(
                        &format!("wall_stress:{}", csv_name(&walls[w].name)),
                        format!("σ on {}", walls[w].name),
                        false,
                        (0..rows).map(|r| measured[r][w]).collect(),
                    )
                })
                .collect();
            stresses.extend([
                curve(
                    "macro_stress_xx",
                    "σ_xx from the contacts".into(),
                    true,
                    history.float("macro_stress_xx").to_vec(),
                ),
                curve(
                    "macro_stress_yy",
                    "σ_yy from the contacts".into(),
                    true,
                    history.float("macro_stress_yy").to_vec(),
                ),
            ]);
            let volume = history.float("volume");
            let volumetric = (volume.iter().all(|v| v.is_finite()) && rows > 0).then(|| {
                curve(
                    "volumetric_strain",
                    "volumetric strain ε_v".into(),
                    false,
                    volume.iter().map(|v| 1.0 - v / volume[0]).collect(),
                )
            });
            (axis, load, stresses, None, volumetric)
        };
        Curves {
            increment: history.int("increment").to_vec(),
            axis,
            load,
            stresses,
            lateral_strain,
            volumetric_strain: volumetric,
            stage: history
                .int("stage")
                .iter()
                .zip(history.int("stage_increment"))
                .map(|(&s, &k)| (s, k))
                .collect(),
            contacts_per_grain: history.float("contacts_per_grain").to_vec(),
            broken_bonds: history
                .int("broken_bonds")
                .iter()
                .map(|&k| k as f64)
                .collect(),
            shear: shear_curves(header, history),
        }
    }
}

/// The curves of a simple shear test, when a wall turned: the shear strain `gamma`, the
/// turn of the first wall that turned (clockwise positive, as a box whose top moves along
/// +x shears), the shear stress `sigma_xy` on each straight wall that carries one (tension
/// positive: the shear force on the wall along its tangent over its area, divided by
/// `n_x^2 - n_y^2` of its normal, -1 for a top or bottom, +1 for a side), and for each region
/// (the thesis measures the interior, 3.3.4): `sigma_xx`, `sigma_yy`, `sigma_xy` (eq. A.40,
/// compression positive, so `-sigma_xy` is the shear stress the top's push along +x makes),
/// the direction of the major principal stress `beta` (degrees from +x, anticlockwise, in
/// [0, 180): 135 under a pure shear stress of this sense, the thesis's 45 mirrored), the
/// mobilised friction angle of eq. A.25 and the ratio of the region's mean grain rotation to
/// the wall's (eq. 30: about 0.5 during failure by the thesis). Empty when no wall turned.
pub fn shear_curves(header: &RunHeader, history: &History) -> Vec<Curve> {
    let rows = history.len();
    let turn = history.wall("wall_turn");
    let Some(w) = (0..header.walls.len()).find(|&w| turn.iter().any(|r| r[w] != 0.0)) else {
        return Vec::new();
    };
    let wall_turn: Vec<f64> = turn.iter().map(|r| r[w]).collect();
    let curve = |key: String, label: String, from_contacts: bool, values: Vec<f64>| Curve {
        key,
        label,
        from_contacts,
        values,
    };
    let mut curves = vec![curve(
        "shear_strain".into(),
        format!("shear strain γ (turn of {})", header.walls[w].name),
        false,
        wall_turn.iter().map(|t| -t).collect(),
    )];
    let shear_stress = history.wall("wall_shear_stress");
    for (k, wall) in header.walls.iter().enumerate() {
        let n = wall.normal;
        let sense = n[0] * n[0] - n[1] * n[1];
        let values: Vec<f64> = shear_stress.iter().map(|r| r[k] / sense).collect();
        if wall.circle.is_none()
            && sense.abs() > 0.5
            && values.iter().any(|v| *v != 0.0 && v.is_finite())
        {
            curves.push(curve(
                format!("tau_walls:{}", csv_name(&wall.name)),
                format!("τ on {}", wall.name),
                false,
                values,
            ));
        }
    }
    let (xx, yy, xy, yx) = (
        history.region("region_stress_xx"),
        history.region("region_stress_yy"),
        history.region("region_stress_xy"),
        history.region("region_stress_yx"),
    );
    let rotation = history.region("region_rotation");
    for (k, region) in header.regions.iter().enumerate() {
        let name = csv_name(&region.name);
        let at = |table: &[Vec<f64>], r: usize| table.get(r).and_then(|v| v.get(k)).copied();
        let stress = |r: usize| -> [f64; 3] {
            let get = |t: &[Vec<f64>]| at(t, r).unwrap_or(f64::NAN);
            [get(xx), get(yy), 0.5 * (get(xy) + get(yx))]
        };
        let column = |f: &dyn Fn(usize) -> f64| (0..rows).map(f).collect::<Vec<f64>>();
        curves.extend([
            curve(
                format!("sigma_xx:{name}"),
                format!("σ_xx in {}", region.name),
                true,
                column(&|r| stress(r)[0]),
            ),
            curve(
                format!("sigma_yy:{name}"),
                format!("σ_yy in {}", region.name),
                true,
                column(&|r| stress(r)[1]),
            ),
            curve(
                format!("tau:{name}"),
                format!("τ = -σ_xy in {}", region.name),
                true,
                column(&|r| -stress(r)[2]),
            ),
            curve(
                format!("beta:{name}"),
                format!("β, major principal direction in {}", region.name),
                true,
                column(&|r| principal_direction(stress(r))),
            ),
            curve(
                format!("phi:{name}"),
                format!("φ' of eq. A.25 in {}", region.name),
                true,
                column(&|r| friction_angle(stress(r))),
            ),
            curve(
                format!("rotation_ratio:{name}"),
                format!("γ_μ / γ in {}", region.name),
                true,
                column(&|r| match at(rotation, r) {
                    Some(g) if wall_turn[r] != 0.0 => g / wall_turn[r],
                    _ => f64::NAN,
                }),
            ),
        ]);
    }
    curves
}

/// The direction of the major (most compressive) principal stress of `[sigma_xx, sigma_yy,
/// sigma_xy]` (compression positive), in degrees from +x, anticlockwise, in [0, 180).
pub fn principal_direction([xx, yy, xy]: [f64; 3]) -> f64 {
    (0.5 * (2.0 * xy).atan2(xx - yy))
        .to_degrees()
        .rem_euclid(180.0)
}

/// The friction angle mobilised by `[sigma_xx, sigma_yy, sigma_xy]` (eq. A.25, degrees):
/// `sin phi' = sqrt((s_yy - s_xx)^2 + 4 s_xy^2) / (s_yy + s_xx)`.
pub fn friction_angle([xx, yy, xy]: [f64; 3]) -> f64 {
    let sin = ((yy - xx).powi(2) + 4.0 * xy * xy).sqrt() / (yy + xx);
    sin.asin().to_degrees()
}

/// Units of a `/history` dataset, for the CSV header.
fn history_unit(name: &str) -> &'static str {
    match name {
        "volume" => "m^3",
        "wall_position" | "wall_slide" | "wall_position_peak" => "m",
        "wall_normal_force" | "wall_shear_force" => "N",
        "mean_rotation" | "mean_absolute_rotation" | "wall_turn" | "region_rotation" => "rad",
        n if n.starts_with("macro_stress") || n.starts_with("region_stress") => "Pa",
        n if n.ends_with("stress") || n.ends_with("stress_peak") => "Pa",
        _ => "-",
    }
}

/// Units of a shear curve, for the CSV header.
fn shear_unit(key: &str) -> &'static str {
    match key.split(':').next().unwrap_or_default() {
        "tau_walls" | "sigma_xx" | "sigma_yy" | "tau" => "Pa",
        "beta" | "phi" => "deg",
        _ => "-",
    }
}

/// A wall name as part of a CSV column name: no commas, quotes or spaces.
fn csv_name(name: &str) -> String {
    name.chars()
        .map(|c| if matches!(c, ',' | '"' | ' ') { '_' } else { c })
        .collect()
}

/// Write the curves as CSV: one row per complete written increment, a header naming each
/// column with its unit (`name [unit]`). The columns are every `/history` dataset as
/// stored (per-wall ones as `name:wall`, per-region ones as `name:region`), then the strains and stresses derived from them:
/// axial strain and the stresses along the wall pairs (when the axis is a strain) and the
/// volumetric strain.
pub fn write_csv(
    path: &Path,
    header: &RunHeader,
    history: &History,
    curves: &Curves,
) -> Result<(), Error> {
    let mut head: Vec<String> = vec!["increment [-]".into()];
    let mut columns: Vec<Vec<String>> = vec![history
        .int("increment")
        .iter()
        .map(|k| k.to_string())
        .collect()];
    for (name, values) in history.ints.iter().filter(|(n, _)| *n != "increment") {
        head.push(format!("{name} [-]"));
        columns.push(values.iter().map(|v| v.to_string()).collect());
    }
    let float = |v: &f64| format!("{v:e}");
    for (name, values) in &history.floats {
        head.push(format!("{name} [{}]", history_unit(name)));
        columns.push(values.iter().map(float).collect());
    }
    for (name, rows) in &history.walls {
        for (w, wall) in header.walls.iter().enumerate() {
            head.push(format!(
                "{name}:{} [{}]",
                csv_name(&wall.name),
                history_unit(name)
            ));
            columns.push(rows.iter().map(|r| float(&r[w])).collect());
        }
    }
    for (name, rows) in &history.regions {
        for (k, region) in header.regions.iter().enumerate() {
            head.push(format!(
                "{name}:{} [{}]",
                csv_name(&region.name),
                history_unit(name)
            ));
            let cell = |r: &Vec<f64>| r.get(k).map_or("nan".into(), float);
            columns.push(rows.iter().map(cell).collect());
        }
    }
    // Derived columns; the others' curves are copies of `/history` columns.
    let mut derived: Vec<(&Curve, &str)> = Vec::new();
    if let LoadAxis::Strain { .. } = curves.axis {
        derived.push((&curves.load, "-"));
        derived.extend(curves.lateral_strain.iter().map(|c| (c, "-")));
        derived.extend(curves.stresses.iter().map(|c| (c, "Pa")));
    }
    derived.extend(curves.volumetric_strain.iter().map(|c| (c, "-")));
    derived.extend(curves.shear.iter().map(|c| (c, shear_unit(&c.key))));
    for (curve, unit) in derived {
        head.push(format!("{} [{unit}]", curve.key));
        columns.push(curve.values.iter().map(float).collect());
    }

    let mut text = head.join(",");
    text.push('\n');
    for row in 0..history.len() {
        let cells: Vec<&str> = columns.iter().map(|c| c[row].as_str()).collect();
        let _ = writeln!(text, "{}", cells.join(","));
    }
    std::fs::write(path, text).map_err(|e| Error::io(path.display(), e))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Circle, Membrane, WallControl};
    use crate::output::WallHeader;

    fn header(walls: Vec<WallHeader>) -> RunHeader {
        RunHeader {
            scene_name: "test".into(),
            scene_text: String::new(),
            solver_text: String::new(),
            version: String::new(),
            depth: 1.0,
            radius: vec![1.0],
            walls,
            fixed_rotations: false,
            law: "linear".into(),
            membranes: Vec::new(),
            regions: Vec::new(),
        }
    }

    fn line(name: &str, normal: [f64; 2], offset: f64, control: WallControl) -> WallHeader {
        WallHeader {
            name: name.into(),
            normal,
            offset,
            pivot: normal.map(|v| v * offset),
            control,
            friction: 0.0,
            length: None,
            circle: None,
        }
    }

    /// A history of two rows: wall positions and applied stresses per row.
    fn history(position: [Vec<f64>; 2], applied: [Vec<f64>; 2]) -> History {
        let walls = position[0].len();
        History {
            ints: vec![
                ("increment", vec![0, 1]),
                ("broken_bonds", vec![0, 0]),
                ("stage", vec![0, 0]),
                ("stage_increment", vec![0, 1]),
            ],
            floats: [
                "macro_stress_xx",
                "macro_stress_yy",
                "macro_stress_xy",
                "macro_stress_yx",
            ]
            .into_iter()
            .map(|n| (n, vec![0.0; 2]))
            .chain([
                ("volume", vec![f64::NAN; 2]),
                ("contacts_per_grain", vec![4.0; 2]),
            ])
            .collect(),
            walls: vec![
                ("wall_position", position.to_vec()),
                ("wall_applied_stress", applied.to_vec()),
                ("wall_stress", vec![vec![1.0; walls]; 2]),
            ],
            membrane_pressure: vec![Vec::new(); 2],
            regions: Vec::new(),
            failure_peak: None,
        }
    }

    #[test]
    fn with_no_change_of_stress_the_axial_pair_is_the_one_that_deformed_most() {
        // A 2 x 4 box: x from 0 to 2, y from 0 to 4.
        let d = WallControl::Displacement;
        let h = header(vec![
            line("bottom", [0.0, 1.0], 0.0, d),
            line("right", [-1.0, 0.0], -2.0, d),
            line("top", [0.0, -1.0], -4.0, d),
            line("left", [1.0, 0.0], 0.0, d),
        ]);
        // The right wall moves in by 0.1 (5%), the top by 0.1 (2.5%).
        let curves = Curves::new(
            &h,
            &history(
                [vec![0.0; 4], vec![0.0, 0.1, 0.1, 0.0]],
                [vec![0.0; 4], vec![0.0; 4]],
            ),
        );
        assert_eq!(
            curves.axis,
            LoadAxis::Strain {
                axial: [1, 3],
                lateral: Some([0, 2])
            }
        );
        assert!((curves.load.values[1] - 0.05).abs() < 1e-12);
        let volumetric = curves.volumetric_strain.unwrap().values;
        assert!((volumetric[1] - (1.0 - 1.9 * 3.9 / 8.0)).abs() < 1e-12);
    }

    #[test]
    fn circular_walls_are_plotted_against_a_changing_pressure_else_the_increment() {
        let circle = |name: &str, radius: f64, inside: bool| WallHeader {
            circle: Some(Circle {
                center: [0.0, 0.0],
                radius,
                grains_inside: inside,
                moves: None,
            }),
            ..line(name, [0.0, 0.0], 0.0, WallControl::Stress)
        };
        let h = header(vec![circle("outer", 3.0, true), circle("hole", 1.0, false)]);
        let position = [vec![0.0; 2], vec![0.0; 2]];
        let curves = Curves::new(
            &h,
            &history(position.clone(), [vec![1.0, 1.0], vec![1.0, 3.0]]),
        );
        assert_eq!(curves.axis, LoadAxis::Pressure { wall: 1 });
        assert_eq!(curves.load.values, vec![1.0, 3.0]);
        let curves = Curves::new(&h, &history(position, [vec![1.0; 2], vec![1.0; 2]]));
        assert_eq!(curves.axis, LoadAxis::Increment);
        assert_eq!(curves.load.values, vec![0.0, 1.0]);
        assert!(curves.volumetric_strain.is_none());
    }

    #[test]
    fn side_membranes_give_the_lateral_stress_and_the_mean_width() {
        // A 2 x 4 sample between a bottom and a top wall, membranes on its left and right.
        let d = WallControl::Displacement;
        let mut h = header(vec![
            line("bottom", [0.0, 1.0], 0.0, d),
            line("top", [0.0, -1.0], -4.0, d),
        ]);
        let side = |name: &str, outward: [f64; 2]| Membrane {
            name: name.into(),
            shape: MembraneShape::Side { outward },
            pressure: 0.0,
        };
        h.membranes = vec![side("left", [-1.0, 0.0]), side("right", [1.0, 0.0])];
        // The top moves in by 0.1 (2.5%); the area grows from 8 to 8.2 (the sample bulges).
        let mut history = history([vec![0.0; 2], vec![0.0, 0.1]], [vec![0.0; 2], vec![0.0; 2]]);
        history.floats.retain(|(n, _)| *n != "volume");
        history.floats.push(("volume", vec![8.0, 8.2]));
        history.membrane_pressure = vec![vec![2.0, 2.0], vec![2.0, 2.0]];
        let curves = Curves::new(&h, &history);
        assert_eq!(
            curves.axis,
            LoadAxis::Strain {
                axial: [0, 1],
                lateral: None
            }
        );
        assert!((curves.load.values[1] - 0.025).abs() < 1e-12);
        let width = 8.2 / 3.9 / 2.0;
        let lateral = curves.lateral_strain.unwrap().values;
        assert!((lateral[1] - (1.0 - width)).abs() < 1e-12);
        let volumetric = curves.volumetric_strain.unwrap().values;
        assert!((volumetric[1] + 0.025).abs() < 1e-12);
        let sl = curves
            .stresses
            .iter()
            .find(|c| c.key == "lateral_stress_walls")
            .unwrap();
        assert_eq!(sl.values, vec![2.0, 2.0]);
    }
}
