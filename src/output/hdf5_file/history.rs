//! `/history`: one row per written increment, for curves; columns added since a file was
//! written read as unknown.

use super::*;

/// The `/history` table as stored, one row per complete written increment.
#[derive(Debug, Clone, PartialEq)]
pub struct History {
    /// Integer columns (dataset name, values), `increment` among them.
    pub ints: Vec<(&'static str, Vec<i64>)>,
    /// Float columns (dataset name, values).
    pub floats: Vec<(&'static str, Vec<f64>)>,
    /// Per-wall columns (dataset name, one row of `W` values per increment).
    pub walls: Vec<(&'static str, Vec<Vec<f64>>)>,
    /// Each membrane's pressure (Pa), one row of `M` values per increment.
    pub membrane_pressure: Vec<Vec<f64>>,
    /// Per-region columns (dataset name, one row of `R` values per increment).
    pub regions: Vec<(&'static str, Vec<Vec<f64>>)>,
    /// Where the run ended on no equilibrium near, the part of the failing increment found
    /// in equilibrium with the highest macro deviator (`/failure`).
    pub failure_peak: Option<PeakState>,
}

impl History {
    /// Rows (complete written increments).
    pub fn len(&self) -> usize {
        self.int("increment").len()
    }

    /// Whether no increment is complete.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// An integer column by dataset name (empty when there is none).
    pub fn int(&self, name: &str) -> &[i64] {
        self.ints
            .iter()
            .find(|(n, _)| *n == name)
            .map_or(&[], |(_, v)| v)
    }

    /// A float column by dataset name (empty when there is none).
    pub fn float(&self, name: &str) -> &[f64] {
        self.floats
            .iter()
            .find(|(n, _)| *n == name)
            .map_or(&[], |(_, v)| v)
    }

    /// A per-wall column by dataset name (empty when there is none).
    pub fn wall(&self, name: &str) -> &[Vec<f64>] {
        self.walls
            .iter()
            .find(|(n, _)| *n == name)
            .map_or(&[], |(_, v)| v)
    }

    /// A per-region column by dataset name (empty when there is none).
    pub fn region(&self, name: &str) -> &[Vec<f64>] {
        self.regions
            .iter()
            .find(|(n, _)| *n == name)
            .map_or(&[], |(_, v)| v)
    }

    /// The history at each increment's peak: the macro stress and the walls' positions and
    /// stresses as they were at the part of the increment with the highest macro deviator
    /// (where the file has them), the other columns as at its end; after the last row, where
    /// the run ended on no equilibrium near, a row at the failing increment's peak. A
    /// test's peak is read from these rows, not from the increments' ends alone.
    pub fn at_peaks(&self) -> History {
        let mut h = self.clone();
        // After the last row, a copy of it, its peak columns at the failing increment's peak.
        if let (Some(peak), false) = (&self.failure_peak, self.is_empty()) {
            for (name, values) in &mut h.ints {
                let next = matches!(*name, "stage_increment" | "increment");
                values.push(values[values.len() - 1] + i64::from(next));
            }
            for (name, values) in &mut h.floats {
                let peak_of = MACRO_PEAK.iter().find(|(_, p, _)| p == name);
                let last = values[values.len() - 1];
                values.push(peak_of.map_or(last, |&(_, _, [i, j])| peak.macro_stress[i][j]));
            }
            for (name, rows) in &mut h.walls {
                let last = rows[rows.len() - 1].clone();
                rows.push(match *name {
                    "wall_position_peak" => peak.wall_position.clone(),
                    "wall_stress_peak" => peak.wall_stress.clone(),
                    _ => last,
                });
            }
            for rows in std::iter::once(&mut h.membrane_pressure)
                .chain(h.regions.iter_mut().map(|(_, rows)| rows))
            {
                if let Some(last) = rows.last().cloned() {
                    rows.push(last);
                }
            }
        }
        h.failure_peak = None;
        // The end's columns take the peak's, where the file has them.
        let peaks = h.clone();
        for (end, peak, _) in MACRO_PEAK {
            if let Some((_, values)) = h.floats.iter_mut().find(|(n, _)| *n == end) {
                for (v, &p) in values.iter_mut().zip(peaks.float(peak)) {
                    if p.is_finite() {
                        *v = p;
                    }
                }
            }
        }
        for (end, peak) in [
            ("wall_position", WALL_PEAK[0]),
            ("wall_stress", WALL_PEAK[1]),
        ] {
            if let Some((_, rows)) = h.walls.iter_mut().find(|(n, _)| *n == end) {
                for (row, p) in rows.iter_mut().zip(peaks.wall(peak)) {
                    if p.iter().all(|v| v.is_finite()) {
                        row.clone_from(p);
                    }
                }
            }
        }
        h
    }
}

/// The macro stress columns, their values at the increment's peak, and the component.
const MACRO_PEAK: [(&str, &str, [usize; 2]); 4] = [
    ("macro_stress_xx", "macro_stress_xx_peak", [0, 0]),
    ("macro_stress_yy", "macro_stress_yy_peak", [1, 1]),
    ("macro_stress_xy", "macro_stress_xy_peak", [0, 1]),
    ("macro_stress_yx", "macro_stress_yx_peak", [1, 0]),
];

/// The `/history` table, keeping only rows whose increment group is complete: a run killed
/// while writing may have left a row (or part of one) for an increment that is not whole.
pub fn read_history(path: impl AsRef<Path>) -> Result<History, Error> {
    let path = path.as_ref();
    let file = open_existing(path)?;
    let read = || -> R<History> {
        let walls = get_count(&file, "walls")?;
        let complete: Vec<i64> = increment_groups(&file.group("increments")?)?
            .into_iter()
            .filter(|g| g.2)
            .map(|g| g.0 as i64)
            .collect();
        let h = file.group("history")?;
        let rows = leading_rows(&h, |_| true)?;
        let increment = &read_vec::<i64>(&h, "increment", None)?[..rows];
        let keep: Vec<usize> = (0..rows)
            .filter(|&r| complete.binary_search(&increment[r]).is_ok())
            .collect();
        let pick = |v: Vec<f64>| keep.iter().map(|&r| v[r]).collect::<Vec<_>>();
        let mut ints = HISTORY_INT
            .iter()
            .map(|&name| {
                let v = read_vec::<i64>(&h, name, None)?;
                Ok((name, keep.iter().map(|&r| v[r]).collect::<Vec<i64>>()))
            })
            .collect::<R<Vec<_>>>()?;
        // Files written before the stability indicator have none.
        if h.link_exists(NEGATIVE_PIVOTS) {
            let v = read_vec::<i64>(&h, NEGATIVE_PIVOTS, None)?;
            if v.len() < rows {
                return Err(Fail(format!(
                    "dataset `/history/{NEGATIVE_PIVOTS}` is short"
                )));
            }
            ints.push((NEGATIVE_PIVOTS, keep.iter().map(|&r| v[r]).collect()));
        }
        // Columns added since a file was written read as unknown.
        let floats = HISTORY_FLOAT
            .iter()
            .map(|&name| match h.link_exists(name) {
                true => Ok((name, pick(read_vec::<f64>(&h, name, None)?))),
                false => Ok((name, vec![f64::NAN; keep.len()])),
            })
            .collect::<R<Vec<_>>>()?;
        let wall_columns = HISTORY_WALL
            .iter()
            .map(|&name| {
                let ds = dataset(&h, name)?;
                let raw = ds
                    .read_raw::<f64>()
                    .map_err(|e| Fail(format!("dataset `/history/{name}`: {e}")))?;
                if raw.len() < rows * walls {
                    return Err(Fail(format!("dataset `/history/{name}` is short")));
                }
                let rows = keep
                    .iter()
                    .map(|&r| raw[r * walls..(r + 1) * walls].to_vec())
                    .collect();
                Ok((name, rows))
            })
            .collect::<R<Vec<_>>>()?;
        // Tables added since a file was written read as unknown.
        let table = |name: &'static str, width: usize| -> R<(&'static str, Vec<Vec<f64>>)> {
            let rows = read_table(&h, name, rows, &keep)?;
            match rows.is_empty() && !keep.is_empty() {
                true => Ok((name, vec![vec![f64::NAN; width]; keep.len()])),
                false => Ok((name, rows)),
            }
        };
        let mut wall_columns = wall_columns;
        for name in WALL_SHEAR.iter().chain(&WALL_PEAK) {
            wall_columns.push(table(name, walls)?);
        }
        let region_count = read_regions(&file)?.len();
        let mut regions = REGION_STRESS
            .iter()
            .map(|&name| Ok((name, read_table(&h, name, rows, &keep)?)))
            .collect::<R<Vec<_>>>()?;
        regions.push(table(REGION_ROTATION, region_count)?);
        // The failure's peak, where the failing increment is the one after the last row.
        let last = ints.iter().find(|(n, _)| *n == "increment");
        let last = last.and_then(|(_, v)| v.last().copied());
        let failure_peak = read_mechanism_group(&file)?
            .filter(|m| Some(m.increment as i64) == last.map(|k| k + 1))
            .and_then(|m| m.peak);
        Ok(History {
            ints,
            floats,
            walls: wall_columns,
            membrane_pressure: read_table(&h, MEMBRANE_PRESSURE, rows, &keep)?,
            regions,
            failure_peak,
        })
    };
    read().map_err(read_error(path))
}

// ---------------------------------------------------------------------------------------
// History: one row per written increment.

const HISTORY_INT: [&str; 13] = [
    "stage",
    "stage_increment",
    "newton_iterations",
    "topology_passes",
    "cuts",
    "contacts_made",
    "contacts_lost",
    "bonds_broken",
    "grain_contacts",
    "wall_contacts",
    "bonds",
    "broken_bonds",
    // Written last: a row whose increment is present is whole.
    "increment",
];

const HISTORY_FLOAT: [&str; 19] = [
    "residual",
    "contacts_per_grain",
    "macro_stress_xx",
    "macro_stress_yy",
    "macro_stress_xy",
    "macro_stress_yx",
    "volume",
    "mean_rotation",
    "mean_absolute_rotation",
    // The energy balance (J), NaN in files from before it.
    "energy_work",
    "energy_stored",
    "energy_dissipated",
    "energy_bonds_released",
    "energy_imbalance",
    // NaN in files from before grains were taken out.
    "energy_taken_out",
    // The macro stress at the increment's peak (`IncrementReport::peak`, else its end); NaN
    // in files from before it.
    "macro_stress_xx_peak",
    "macro_stress_yy_peak",
    "macro_stress_xy_peak",
    "macro_stress_yx_peak",
];

const HISTORY_WALL: [&str; 6] = [
    "wall_position",
    "wall_slide",
    "wall_applied_stress",
    "wall_normal_force",
    "wall_shear_force",
    "wall_stress",
];

/// Each membrane's pressure: a row of `M` values per increment, like the walls' columns.
const MEMBRANE_PRESSURE: &str = "membrane_pressure";

/// The stability indicator of each increment (negative pivots of the tangent; -1: not
/// counted). Kept apart from the other integer columns, so files written before it read.
pub(super) const NEGATIVE_PIVOTS: &str = "negative_pivots";

/// Each wall's turn (rad) and shear stress (Pa), a row of `W` values per increment, kept
/// apart from the walls' first columns so files written before them read.
const WALL_SHEAR: [&str; 2] = ["wall_turn", "wall_shear_stress"];

/// Each wall's position (m) and stress (Pa, as the grains put it on the wall) at the
/// increment's peak (`IncrementReport::peak`, else its end), a row of `W` values per
/// increment.
const WALL_PEAK: [&str; 2] = ["wall_position_peak", "wall_stress_peak"];

/// Each region's mean grain rotation (rad), a row of `R` values per increment.
const REGION_ROTATION: &str = "region_rotation";

/// Each region's stress (eq. A.40), a row of `R` values per component and increment.
const REGION_STRESS: [&str; 4] = [
    "region_stress_xx",
    "region_stress_yy",
    "region_stress_xy",
    "region_stress_yx",
];

/// The widths of the per-wall, per-membrane and per-region `/history` tables.
#[derive(Debug, Clone, Copy)]
pub(super) struct Widths {
    pub(super) walls: usize,
    pub(super) membranes: usize,
    pub(super) regions: usize,
}

impl Widths {
    pub(super) fn of(header: &RunHeader) -> Widths {
        Widths {
            walls: header.walls.len(),
            membranes: header.membranes.len(),
            regions: header.regions.len(),
        }
    }

    /// The tables beside the walls', with their widths.
    fn tables(self) -> impl Iterator<Item = (&'static str, usize)> {
        std::iter::once((MEMBRANE_PRESSURE, self.membranes))
            .chain(REGION_STRESS.iter().map(move |&n| (n, self.regions)))
            .chain(WALL_SHEAR.iter().map(move |&n| (n, self.walls)))
            .chain(std::iter::once((REGION_ROTATION, self.regions)))
            .chain(WALL_PEAK.iter().map(move |&n| (n, self.walls)))
    }
}

pub(super) fn create_history(h: &Group, walls: usize, membranes: usize, regions: usize) -> R<()> {
    for name in HISTORY_INT {
        h.new_dataset_builder()
            .empty::<i64>()
            .shape(0..)
            .chunk(HISTORY_CHUNK)
            .create(name)?;
    }
    for name in HISTORY_FLOAT {
        create_float_column(h, name)?;
    }
    for name in HISTORY_WALL {
        create_table(h, name, walls)?;
    }
    let widths = Widths {
        walls,
        membranes,
        regions,
    };
    for (name, width) in widths.tables() {
        create_table(h, name, width)?;
    }
    create_negative_pivots(h)
}

fn create_negative_pivots(h: &Group) -> R<()> {
    h.new_dataset_builder()
        .empty::<i64>()
        .shape(0..)
        .chunk(HISTORY_CHUNK)
        .create(NEGATIVE_PIVOTS)?;
    Ok(())
}

fn create_float_column(h: &Group, name: &str) -> R<()> {
    h.new_dataset_builder()
        .empty::<f64>()
        .shape(0..)
        .chunk(HISTORY_CHUNK)
        .create(name)?;
    Ok(())
}

/// A growable table of `width` columns, one row per increment.
fn create_table(h: &Group, name: &str, width: usize) -> R<()> {
    // No columns: a zero-width fixed dimension cannot be chunked, so let it grow too.
    let second = if width == 0 {
        Extent::resizable(0)
    } else {
        Extent::fixed(width)
    };
    h.new_dataset_builder()
        .empty::<f64>()
        .shape(vec![Extent::resizable(0), second])
        .chunk((HISTORY_CHUNK, width.max(1)))
        .create(name)?;
    Ok(())
}

fn append_table_row(h: &Group, name: &str, row: usize, values: &[f64]) -> R<()> {
    put_row(h, name, row, values, true)
}

/// The rows `keep` of a table; none from a file written before the table was kept.
fn read_table(h: &Group, name: &str, rows: usize, keep: &[usize]) -> R<Vec<Vec<f64>>> {
    if !h.link_exists(name) {
        return Ok(Vec::new());
    }
    let ds = dataset(h, name)?;
    let width = ds.shape().get(1).copied().unwrap_or(0);
    let raw = ds
        .read_raw::<f64>()
        .map_err(|e| Fail(format!("dataset `/history/{name}`: {e}")))?;
    if raw.len() < rows * width {
        return Err(Fail(format!("dataset `/history/{name}` is short")));
    }
    Ok(keep
        .iter()
        .map(|&r| raw[r * width..(r + 1) * width].to_vec())
        .collect())
}

pub(super) fn append_history(
    h: &Group,
    row: usize,
    widths: Widths,
    state: &State,
    report: &IncrementReport,
) -> R<()> {
    let m = &report.measurements;
    let walls = widths.walls;
    let ints: [i64; 13] = [
        state.stage as i64,
        state.stage_increment as i64,
        report.newton_iterations as i64,
        report.topology_passes as i64,
        i64::from(report.cuts),
        report.contacts_made as i64,
        report.contacts_lost as i64,
        report.bonds_broken as i64,
        m.grain_contacts as i64,
        m.wall_contacts as i64,
        m.bonds as i64,
        state.contacts.broken_bonds.len() as i64,
        state.increment as i64,
    ];
    let e = &report.energy;
    let peak = report.peak_or_end(&state.walls);
    let floats: [f64; 19] = [
        report.residual,
        m.contacts_per_grain,
        m.macro_stress[0][0],
        m.macro_stress[1][1],
        m.macro_stress[0][1],
        m.macro_stress[1][0],
        m.volume,
        m.mean_rotation,
        m.mean_absolute_rotation,
        e.work,
        e.stored,
        e.dissipated,
        e.bonds_released,
        e.imbalance(),
        e.taken_out,
        peak.macro_stress[0][0],
        peak.macro_stress[1][1],
        peak.macro_stress[0][1],
        peak.macro_stress[1][0],
    ];
    let column = |f: fn(&Wall) -> f64| -> Vec<f64> { state.walls.walls.iter().map(f).collect() };
    let wall_rows: [Vec<f64>; 6] = [
        column(|w| w.position),
        column(|w| w.slide),
        column(|w| w.stress),
        per_wall(&m.wall_normal_force, walls),
        per_wall(&m.wall_shear_force, walls),
        per_wall(&m.wall_stress, walls),
    ];
    for (name, values) in HISTORY_WALL.iter().zip(&wall_rows) {
        append_table_row(h, name, row, values)?;
    }
    let pressure: Vec<f64> = state.membranes.iter().map(|m| m.pressure).collect();
    append_table_row(h, MEMBRANE_PRESSURE, row, &pressure)?;
    for (name, [i, j]) in REGION_STRESS.iter().zip([[0, 0], [1, 1], [0, 1], [1, 0]]) {
        // A report without measurements (the probe of a resume) has none: unknown.
        let stress: Vec<f64> = match m.region_stress.len() == widths.regions {
            true => m.region_stress.iter().map(|s| s[i][j]).collect(),
            false => vec![f64::NAN; widths.regions],
        };
        append_table_row(h, name, row, &stress)?;
    }
    let turn: Vec<f64> = state.walls.walls.iter().map(|w| w.turn).collect();
    append_table_row(h, WALL_SHEAR[0], row, &turn)?;
    append_table_row(
        h,
        WALL_SHEAR[1],
        row,
        &per_wall(&m.wall_shear_stress, walls),
    )?;
    let rotation = match m.region_rotation.len() == widths.regions {
        true => m.region_rotation.clone(),
        false => vec![f64::NAN; widths.regions],
    };
    append_table_row(h, REGION_ROTATION, row, &rotation)?;
    append_table_row(h, WALL_PEAK[0], row, &peak.wall_position)?;
    append_table_row(h, WALL_PEAK[1], row, &per_wall(&peak.wall_stress, walls))?;
    for (name, value) in HISTORY_FLOAT.iter().zip(floats) {
        append_scalar(h, name, row, value)?;
    }
    for (name, value) in HISTORY_INT.iter().zip(ints) {
        append_scalar(h, name, row, value)?;
    }
    Ok(())
}

pub(super) fn append_scalar<T: H5Type>(h: &Group, name: &str, row: usize, value: T) -> R<()> {
    put_row(h, name, row, &[value], false)
}

/// Number of leading history rows whose increment passes `keep`, and that every history
/// dataset holds (those added since the file was written are made by `truncate_history`).
pub(super) fn leading_rows(h: &Group, keep: impl Fn(i64) -> bool) -> R<usize> {
    let increments = read_vec::<i64>(h, "increment", None)?;
    let mut rows = increments.iter().take_while(|&&k| keep(k)).count();
    for name in HISTORY_INT
        .iter()
        .chain(&HISTORY_FLOAT)
        .chain(&HISTORY_WALL)
        .chain(&REGION_STRESS)
        .chain(&WALL_SHEAR)
        .chain(&[REGION_ROTATION])
        .chain(&WALL_PEAK)
    {
        if h.link_exists(name) {
            rows = rows.min(dataset(h, name)?.shape().first().copied().unwrap_or(0));
        }
    }
    Ok(rows)
}

pub(super) fn truncate_history(h: &Group, rows: usize, widths: Widths) -> R<()> {
    for name in HISTORY_INT {
        dataset(h, name)?.resize([rows])?;
    }
    for name in HISTORY_FLOAT {
        // A file from before this column was kept gets it, unknown so far.
        if !h.link_exists(name) {
            create_float_column(h, name)?;
            let ds = dataset(h, name)?;
            ds.resize([rows])?;
            if rows > 0 {
                let unknown = vec![f64::NAN; rows];
                ds.write_slice(ArrayView1::from(&unknown[..]), s![..])?;
            }
        }
        dataset(h, name)?.resize([rows])?;
    }
    for name in HISTORY_WALL {
        dataset(h, name)?.resize([rows, widths.walls])?;
    }
    for (name, width) in widths.tables() {
        // Likewise a table: the membranes' pressures, the regions' stresses.
        if !h.link_exists(name) {
            create_table(h, name, width)?;
            let ds = dataset(h, name)?;
            ds.resize([rows, width])?;
            if rows * width > 0 {
                let unknown = vec![f64::NAN; rows * width];
                ds.write_slice(
                    ArrayView2::from_shape((rows, width), &unknown[..])?,
                    s![.., ..],
                )?;
            }
        }
        dataset(h, name)?.resize([rows, width])?;
    }
    // A file from before the stability indicator: not counted so far.
    if !h.link_exists(NEGATIVE_PIVOTS) {
        create_negative_pivots(h)?;
        let ds = dataset(h, NEGATIVE_PIVOTS)?;
        ds.resize([rows])?;
        if rows > 0 {
            ds.write_slice(ArrayView1::from(&vec![-1i64; rows][..]), s![..])?;
        }
    }
    dataset(h, NEGATIVE_PIVOTS)?.resize([rows])?;
    Ok(())
}
