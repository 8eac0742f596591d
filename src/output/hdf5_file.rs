//! The HDF5 result file: written after each increment, read back to resume a run, to plot
//! and to inspect (`grainstat info`).
//!
//! A run killed at any moment must leave a file that opens and can be resumed. HDF5 updates
//! its metadata in place and reuses space it freed, so a process killed in the middle of a
//! write, even one followed by a flush, can leave a file that no longer opens or whose
//! compressed chunks no longer inflate. So the file is never written where it lies: every
//! change (the header, each increment, the summary, the tidying on resume) is made to a copy
//! beside it (`NAME.h5.writing`), flushed and closed there, and the copy is then renamed over
//! the file. The rename is atomic, so at every moment `NAME.h5` is the file as it was after one
//! whole change. Each increment is still written into its own group with its `complete`
//! attribute set last, and on resume every group without it is deleted (files written before
//! this scheme). Every value a [`State`] holds is stored
//! exactly (f64 as f64, indices as i64), so a resumed run repeats the uninterrupted one bit
//! for bit. The layout is documented for Python users in `docs/hdf5-layout.md`; keep the two
//! in step (and raise [`FORMAT_VERSION`] when a change breaks old readers).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use hdf5::types::VarLenUnicode;
use hdf5::{Extent, File, Group, H5Type};
use ndarray::{s, Array1, ArrayView1, ArrayView2};

use super::h5::{
    dataset, get_attr, get_count, get_str_attr, input_error, put, put_strings, put_text,
    read_error, read_in_child, read_rows, read_vec, require_format, set_attr, set_str_attr,
    write_error, Fail, R,
};
use crate::contact::{BreakMode, BrokenBond, Contact, ContactParams, ContactSet, Response};
use crate::error::Error;
use crate::geometry::{
    Circle, GrainSet, Membrane, MembraneShape, Pair, Side, Wall, WallControl, WallSet,
};
use crate::measure::Region;
use crate::solver::stats::{Counters, SolverStats, StageTimers};
use crate::state::{IncrementReport, State};

/// Value of the root attribute `format`: tells our files from other HDF5 files.
pub const FORMAT: &str = "grainstat-result";

/// Version of the layout, root attribute `format_version`.
pub const FORMAT_VERSION: i64 = 1;

/// Rows per chunk of the growable `/history` datasets.
const HISTORY_CHUNK: usize = 256;

/// Digits of an increment group's name: fixed width, so lexical order is numeric order.
const GROUP_DIGITS: usize = 8;

/// The static description of a run, written once when the file is created.
#[derive(Debug, Clone, PartialEq)]
pub struct RunHeader {
    /// Scene name.
    pub scene_name: String,
    /// The scene file as read (TOML), so the file alone says what was run.
    pub scene_text: String,
    /// The solver file as read (TOML).
    pub solver_text: String,
    /// grainstat version that wrote the file (`env!("CARGO_PKG_VERSION")`).
    pub version: String,
    /// Depth `D` (m) that turns 2D forces into stresses.
    pub depth: f64,
    /// Grain radii (m); they never change, so they are not repeated per increment.
    pub radius: Vec<f64>,
    /// The static part of each wall, in scene order.
    pub walls: Vec<WallHeader>,
    /// Whether grain rotations are held fixed.
    pub fixed_rotations: bool,
    /// Contact law: `"linear"` or `"hertz"`.
    pub law: String,
    /// Membranes: names and shapes (their pressures come from each increment).
    pub membranes: Vec<Membrane>,
    /// Regions whose stress `/history` keeps.
    pub regions: Vec<Region>,
}

/// The part of a [`Wall`] that never changes; position, slide and applied stress come from
/// each increment.
#[derive(Debug, Clone, PartialEq)]
pub struct WallHeader {
    /// Name from the scene.
    pub name: String,
    /// Unit normal into the sample.
    pub normal: [f64; 2],
    /// `normal . point` of the wall at the start (m).
    pub offset: f64,
    /// The point of the starting line the wall turns about (m).
    pub pivot: [f64; 2],
    /// Displacement- or stress-controlled.
    pub control: WallControl,
    /// Grain-wall friction (`INFINITY` when glued).
    pub friction: f64,
    /// Fixed loaded length (m), `None` for the distance between the perpendicular walls.
    pub length: Option<f64>,
    /// The circle of a circular wall.
    pub circle: Option<Circle>,
}

impl WallHeader {
    /// The static part of a wall.
    pub fn of(wall: &Wall) -> Self {
        WallHeader {
            name: wall.name.clone(),
            normal: wall.normal,
            offset: wall.offset,
            pivot: wall.pivot,
            control: wall.control,
            friction: wall.friction,
            length: wall.length,
            circle: wall.circle,
        }
    }

    /// The wall again, at a position, slide, turn and applied stress.
    pub fn wall(&self, [position, slide, turn]: [f64; 3], stress: f64) -> Wall {
        Wall {
            name: self.name.clone(),
            normal: self.normal,
            offset: self.offset,
            pivot: self.pivot,
            turn,
            position,
            slide,
            control: self.control,
            stress,
            length: self.length,
            friction: self.friction,
            circle: self.circle,
        }
    }
}

impl RunHeader {
    /// The static parts of a set of walls, for [`RunHeader::walls`].
    pub fn walls_of(walls: &WallSet) -> Vec<WallHeader> {
        walls.walls.iter().map(WallHeader::of).collect()
    }
}

/// A result file being written. No HDF5 handle stays open between changes: each one is made
/// to a copy and renamed over the file (see the module's notes).
#[derive(Debug)]
pub struct ResultFile {
    path: PathBuf,
    grains: usize,
    walls: usize,
    membranes: usize,
    regions: usize,
    history_rows: usize,
}

impl ResultFile {
    /// Create (or overwrite) a result file and write the run's static data.
    pub fn create(path: impl AsRef<Path>, header: &RunHeader) -> Result<ResultFile, Error> {
        let path = path.as_ref();
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| Error::io(dir.display(), e))?;
        }
        let side = side_path(path);
        let file = File::create(&side).map_err(|e| Error::io(side.display(), e))?;
        let make = || -> R<()> {
            write_header(&file, header)?;
            file.create_group("increments")?;
            create_history(
                &file.create_group("history")?,
                header.walls.len(),
                header.membranes.len(),
                header.regions.len(),
            )?;
            Ok(())
        };
        make().map_err(write_error(path))?;
        close_and_rename(file, &side, path)?;
        Ok(ResultFile {
            path: path.to_path_buf(),
            grains: header.radius.len(),
            walls: header.walls.len(),
            membranes: header.membranes.len(),
            regions: header.regions.len(),
            history_rows: 0,
        })
    }

    /// Open a file to continue its run: the last complete increment is the state to resume
    /// from; incomplete groups (a run killed while writing) and their history rows are
    /// deleted.
    pub fn open_for_resume(
        path: impl AsRef<Path>,
    ) -> Result<(ResultFile, RunHeader, State), Error> {
        let path = path.as_ref();
        // All of it in a child process first, with a trial write of the state resumed from
        // to a copy that is then dropped: libhdf5 can crash or hang on a corrupt file, and
        // may meet the corruption only when it writes (see `read_in_child`).
        read_in_child(path, || {
            let probe = ResultFile::tidied(path, &side_path(path)).and_then(|(out, _, state)| {
                out.edit_copy(&out.path, read_error(path), |file| {
                    let report = IncrementReport::default();
                    let rows = out.history_rows;
                    out.try_write_increment(file, rows, &state, &report, &SolverStats::default())
                        .map(drop)
                })
            });
            let _ = std::fs::remove_file(side_path(&side_path(path)));
            let _ = std::fs::remove_file(side_path(path));
            probe.is_ok()
        })?;
        ResultFile::tidied(path, path)
    }

    /// The file at `path` for resuming, written to `to`: incomplete groups and their history
    /// rows deleted.
    fn tidied(path: &Path, to: &Path) -> Result<(ResultFile, RunHeader, State), Error> {
        // Read-only first: a file that is not a whole result file is bad input, and is left
        // as it is.
        let (header, state, incomplete, keep) = read_for_resume(path)?;
        let widths = Widths::of(&header);
        let out = ResultFile {
            path: to.to_path_buf(),
            grains: header.radius.len(),
            walls: widths.walls,
            membranes: widths.membranes,
            regions: widths.regions,
            history_rows: keep,
        };
        // The file read whole, but deleting in it may still find it corrupt: bad input too.
        out.edit_copy(path, read_error(path), |file| {
            let inc = file.group("increments")?;
            for name in &incomplete {
                inc.unlink(name)?;
            }
            truncate_history(&file.group("history")?, keep, widths)
        })?;
        Ok((out, header, state))
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    fn widths(&self) -> Widths {
        Widths {
            walls: self.walls,
            membranes: self.membranes,
            regions: self.regions,
        }
    }

    /// Write a converged (committed) state with its report as group
    /// `/increments/<increment>`, append a `/history` row, update `/summary`, then mark the
    /// group complete; all in one change (see the module's notes). Writing an increment that
    /// is already in the file replaces it (and drops its history rows and any after them).
    pub fn write_increment(
        &mut self,
        state: &State,
        report: &IncrementReport,
        stats: &SolverStats,
    ) -> Result<(), Error> {
        let mut rows = self.history_rows;
        self.change(|file| {
            rows = self.try_write_increment(file, rows, state, report, stats)?;
            Ok(())
        })?;
        self.history_rows = rows;
        Ok(())
    }

    /// Write the solver's timers and counters as attributes of `/summary`, replacing the
    /// last ones.
    pub fn write_summary(&mut self, stats: &SolverStats) -> Result<(), Error> {
        self.change(|file| write_summary_group(file, stats))
    }

    /// Make one change to the file: to a copy beside it, flushed, closed and renamed over
    /// it. Killed at any moment, the file is as it was before the change or after it.
    fn change(&self, write: impl FnOnce(&File) -> R<()>) -> Result<(), Error> {
        self.edit_copy(&self.path, write_error(&self.path), write)
    }

    /// Make one change to the file at `from` and put the result at this file's path: the
    /// change is made to a copy beside that (`side_path`), flushed, closed and renamed over
    /// it. HDF5's failures become errors by `blame`.
    fn edit_copy(
        &self,
        from: &Path,
        blame: impl FnOnce(Fail) -> Error,
        write: impl FnOnce(&File) -> R<()>,
    ) -> Result<(), Error> {
        let side = side_path(&self.path);
        std::fs::copy(from, &side).map_err(|e| Error::io(side.display(), e))?;
        let file = File::open_rw(&side).map_err(|e| Error::io(side.display(), e))?;
        if let Err(fail) = write(&file) {
            drop(file);
            // The file itself is untouched; the half-changed copy is of no use.
            let _ = std::fs::remove_file(&side);
            return Err(blame(fail));
        }
        close_and_rename(file, &side, &self.path)
    }

    /// Write one increment into `file` whose `/history` has `rows` rows; the rows after.
    fn try_write_increment(
        &self,
        file: &File,
        mut rows: usize,
        state: &State,
        report: &IncrementReport,
        stats: &SolverStats,
    ) -> R<usize> {
        if state.grains.len() != self.grains || state.walls.len() != self.walls {
            return Err(Fail(format!(
                "the state has {} grains and {} walls, the file was created for {} and {}",
                state.grains.len(),
                state.walls.len(),
                self.grains,
                self.walls
            )));
        }
        let g = &state.grains;
        let n = self.grains;
        if g.position.len() != n
            || g.origin.len() != n
            || g.displacement.len() != n
            || g.rotation.len() != n
        {
            return Err(Fail(format!(
                "the grains' arrays have lengths {}, {}, {} and {} (position, origin, \
                 displacement, rotation); there are {n} grains",
                g.position.len(),
                g.origin.len(),
                g.displacement.len(),
                g.rotation.len()
            )));
        }
        let k = state.increment;
        let name = group_name(k);
        let inc = file.group("increments")?;
        let history = file.group("history")?;
        if inc.link_exists(&name) {
            inc.unlink(&name)?;
            rows = leading_rows(&history, |j| j < k as i64)?;
            truncate_history(&history, rows, self.widths())?;
        }
        let g = inc.create_group(&name)?;
        write_group_state(&g, state, report)?;
        append_history(&history, rows, self.widths(), state, report)?;
        let pivots = report.negative_pivots.map_or(-1, |n| n as i64);
        append_scalar(&history, NEGATIVE_PIVOTS, rows, pivots)?;
        write_summary_group(file, stats)?;
        // Last: only now is the increment whole.
        set_attr(&g, "complete", &1u8)?;
        Ok(rows + 1)
    }
}

/// What resuming from `path` needs: the header, the state of the last complete increment,
/// the incomplete groups to delete and the `/history` rows to keep.
fn read_for_resume(path: &Path) -> Result<(RunHeader, State, Vec<String>, usize), Error> {
    let file = open_existing(path)?;
    let header = read_header(&file).map_err(read_error(path))?;
    let inc = file.group("increments").map_err(|e| {
        input_error(
            path,
            format!("not a complete result file (no /increments: {e})"),
        )
    })?;
    let groups = increment_groups(&inc).map_err(read_error(path))?;
    let (last, name) = groups
        .iter()
        .rev()
        .find(|(_, _, complete)| *complete)
        .map(|(k, name, _)| (*k, name.clone()))
        .ok_or_else(|| input_error(path, "has no complete increment to resume from"))?;
    let state = inc
        .group(&name)
        .map_err(Fail::from)
        .and_then(|g| read_group_state(&g, &header))
        .map_err(read_error(path))?;
    let incomplete = groups
        .into_iter()
        .filter(|(_, _, complete)| !complete)
        .map(|(_, name, _)| name)
        .collect();
    let keep = file
        .group("history")
        .map_err(Fail::from)
        .and_then(|h| leading_rows(&h, |k| k <= last as i64))
        .map_err(read_error(path))?;
    Ok((header, state, incomplete, keep))
}

/// Where changes to the result file `path` are made before they replace it: `NAME.h5.writing`
/// beside `NAME.h5`. A run killed while changing the file leaves it there; the next change
/// writes over it.
pub fn side_path(path: &Path) -> PathBuf {
    let mut name = path.as_os_str().to_owned();
    name.push(".writing");
    PathBuf::from(name)
}

/// Flush and close the changed copy `side`, then rename it over `path`.
fn close_and_rename(file: File, side: &Path, path: &Path) -> Result<(), Error> {
    file.flush()
        .and_then(|()| file.close())
        .map_err(|e| Error::io(side.display(), e))?;
    std::fs::rename(side, path).map_err(|e| Error::io(path.display(), e))
}

/// The increments written completely to a result file, in order.
pub fn read_increments(path: impl AsRef<Path>) -> Result<Vec<usize>, Error> {
    let path = path.as_ref();
    let file = open_existing(path)?;
    let read = || -> R<Vec<usize>> {
        let inc = file.group("increments")?;
        Ok(increment_groups(&inc)?
            .into_iter()
            .filter(|(_, _, complete)| *complete)
            .map(|(k, _, _)| k)
            .collect())
    };
    read().map_err(read_error(path))
}

/// The run's header and the state after one complete increment.
pub fn read_state(path: impl AsRef<Path>, increment: usize) -> Result<(RunHeader, State), Error> {
    let path = path.as_ref();
    let file = open_existing(path)?;
    let read = || -> R<(RunHeader, State)> {
        let header = read_header(&file)?;
        let inc = file.group("increments")?;
        let name = group_name(increment);
        if !inc.link_exists(&name) {
            return Err(Fail(format!("has no increment {increment}")));
        }
        let g = inc.group(&name)?;
        if !is_complete(&g) {
            return Err(Fail(format!(
                "increment {increment} is incomplete (the run stopped while writing it)"
            )));
        }
        let state = read_group_state(&g, &header)?;
        Ok((header, state))
    };
    read().map_err(read_error(path))
}

/// The timers and counters last written to `/summary`, `None` when there are none yet (so
/// a resumed run can go on counting).
pub fn read_summary(path: impl AsRef<Path>) -> Result<Option<SolverStats>, Error> {
    let path = path.as_ref();
    let file = open_existing(path)?;
    read_summary_group(&file).map_err(read_error(path))
}

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
}

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
                Ok((name, keep.iter().map(|&r| v[r]).collect()))
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
        for name in WALL_SHEAR {
            wall_columns.push(table(name, walls)?);
        }
        let region_count = read_regions(&file)?.len();
        let mut regions = REGION_STRESS
            .iter()
            .map(|&name| Ok((name, read_table(&h, name, rows, &keep)?)))
            .collect::<R<Vec<_>>>()?;
        regions.push(table(REGION_ROTATION, region_count)?);
        Ok(History {
            ints,
            floats,
            walls: wall_columns,
            membrane_pressure: read_table(&h, MEMBRANE_PRESSURE, rows, &keep)?,
            regions,
        })
    };
    read().map_err(read_error(path))
}

/// A human summary of a result file, for `grainstat info`.
pub fn info(path: impl AsRef<Path>) -> Result<String, Error> {
    let path = path.as_ref();
    read_in_child(path, || summarise(path).is_ok())?;
    summarise(path)
}

fn summarise(path: &Path) -> Result<String, Error> {
    let file = open_existing(path)?;
    let text = || -> R<String> {
        let header = read_header(&file)?;
        let inc = file.group("increments")?;
        let groups = increment_groups(&inc)?;
        let complete: Vec<usize> = groups.iter().filter(|g| g.2).map(|g| g.0).collect();
        let mut out = String::new();
        let w = &mut out;
        let _ = writeln!(w, "file        {}", path.display());
        let _ = writeln!(
            w,
            "scene       {} (grainstat {}, {} law{})",
            header.scene_name,
            header.version,
            header.law,
            if header.fixed_rotations {
                ", rotations fixed"
            } else {
                ""
            }
        );
        let _ = writeln!(
            w,
            "grains      {} (radius {:.4e} .. {:.4e} m), depth {:.4e} m",
            header.radius.len(),
            header.radius.iter().cloned().fold(f64::INFINITY, f64::min),
            header
                .radius
                .iter()
                .cloned()
                .fold(f64::NEG_INFINITY, f64::max),
            header.depth
        );
        let walls: Vec<String> = header
            .walls
            .iter()
            .map(|h| format!("{} ({})", h.name, control_name(h.control)))
            .collect();
        let _ = writeln!(w, "walls       {}: {}", walls.len(), walls.join(", "));
        match (complete.first(), complete.last()) {
            (Some(first), Some(last)) => {
                let _ = writeln!(
                    w,
                    "increments  {} written, {} .. {}",
                    complete.len(),
                    first,
                    last
                );
            }
            _ => {
                let _ = writeln!(w, "increments  none complete");
            }
        }
        let incomplete = groups.len() - complete.len();
        if incomplete > 0 {
            let _ = writeln!(w, "            {incomplete} incomplete (removed on resume)");
        }
        if let Some(&last) = complete.last() {
            let g = inc.group(&group_name(last))?;
            let _ = writeln!(
                w,
                "\nincrement {} (stage {}, increment {} of the stage)",
                last,
                get_attr::<i64>(&g, "stage")?,
                get_attr::<i64>(&g, "stage_increment")?
            );
            let position = read_vec::<f64>(&g, "walls/position", Some(header.walls.len()))?;
            let applied = read_vec::<f64>(&g, "walls/stress", Some(header.walls.len()))?;
            let measured = read_vec::<f64>(&g, "walls/measured_stress", Some(header.walls.len()))?;
            let _ = writeln!(
                w,
                "  {:<12} {:>14} {:>16} {:>16}",
                "wall", "position [m]", "applied [Pa]", "measured [Pa]"
            );
            for (k, h) in header.walls.iter().enumerate() {
                let _ = writeln!(
                    w,
                    "  {:<12} {:>14.6e} {:>16.6e} {:>16.6e}",
                    h.name, position[k], applied[k], measured[k]
                );
            }
            let sigma = read_rows::<f64, 2>(&g, "macro_stress", Some(2))?;
            let _ = writeln!(
                w,
                "  macro stress [Pa]  xx {:.6e}  yy {:.6e}  xy {:.6e}  yx {:.6e}",
                sigma[0][0], sigma[1][1], sigma[0][1], sigma[1][0]
            );
            let _ = writeln!(
                w,
                "  volume [m^3]       {:.6e}",
                get_attr::<f64>(&g, "volume")?
            );
            let _ = writeln!(
                w,
                "  contacts           {} grain-grain, {} grain-wall, {:.4} per grain",
                get_attr::<i64>(&g, "grain_contacts")?,
                get_attr::<i64>(&g, "wall_contacts")?,
                get_attr::<f64>(&g, "contacts_per_grain")?
            );
            let _ = writeln!(
                w,
                "  bonds              {} intact, {} broken",
                get_attr::<i64>(&g, "bonds")?,
                dataset(&g, "broken_bonds")?
                    .shape()
                    .first()
                    .copied()
                    .unwrap_or(0)
            );
            let _ = writeln!(
                w,
                "  solver             residual {:.3e}, {} Newton iterations, {} topology passes, {} cuts",
                get_attr::<f64>(&g, "residual")?,
                get_attr::<i64>(&g, "newton_iterations")?,
                get_attr::<i64>(&g, "topology_passes")?,
                get_attr::<i64>(&g, "cuts")?
            );
        }
        if let Some(mut stats) = read_summary_group(&file)? {
            let timers = timers_mut(&mut stats.timers);
            let total: f64 = timers.iter().map(|(_, v)| **v).sum();
            let _ = writeln!(w, "\ntime [s]    {total:.3} in all");
            for (name, v) in timers {
                let _ = writeln!(w, "  {name:<24} {:>10.3}", *v);
            }
            let _ = writeln!(w, "counters");
            for (name, v) in counters_mut(&mut stats.counters) {
                let _ = writeln!(w, "  {name:<24} {:>10}", *v);
            }
        }
        Ok(out)
    };
    text().map_err(read_error(path))
}

// ---------------------------------------------------------------------------------------
// Opening.

/// Open a file the user named: a missing file, a directory, or one HDF5 cannot read is an
/// input error, and so is an HDF5 file that is not ours.
pub(crate) fn open_existing(path: &Path) -> Result<File, Error> {
    if !path.exists() {
        return Err(input_error(path, "no such file"));
    }
    if path.is_dir() {
        return Err(input_error(path, "is a directory, not a result file"));
    }
    let file = File::open(path).map_err(|e| {
        let e = e.to_string();
        let hint = if e.contains("unable to lock") {
            " (is a run still writing it? HDF5_USE_FILE_LOCKING=FALSE reads it anyway)"
        } else {
            ""
        };
        input_error(path, format!("cannot be opened as an HDF5 file: {e}{hint}"))
    })?;
    require_format(file, path, FORMAT, "result")
}

pub(crate) fn group_name(increment: usize) -> String {
    format!("{increment:0width$}", width = GROUP_DIGITS)
}

fn is_complete(g: &Group) -> bool {
    g.attr("complete")
        .and_then(|a| a.read_scalar::<u8>())
        .is_ok_and(|v| v == 1)
}

/// The increment groups by number: (increment, name, complete). Other names are ignored.
pub(crate) fn increment_groups(inc: &Group) -> R<Vec<(usize, String, bool)>> {
    let mut groups = Vec::new();
    for name in inc.member_names()? {
        if name.is_empty() || !name.bytes().all(|b| b.is_ascii_digit()) {
            continue;
        }
        let Ok(k) = name.parse::<usize>() else {
            continue;
        };
        let complete = inc.group(&name).map(|g| is_complete(&g)).unwrap_or(false);
        groups.push((k, name, complete));
    }
    groups.sort();
    Ok(groups)
}

// ---------------------------------------------------------------------------------------
// Small helpers.

pub(crate) fn control_name(c: WallControl) -> &'static str {
    match c {
        WallControl::Displacement => "displacement",
        WallControl::Stress => "stress",
    }
}

/// Pair side `a` as stored: a grain index, or `-(w + 1)` for wall `w`.
pub(crate) fn side_code(a: Side) -> i64 {
    match a {
        Side::Grain(i) => i as i64,
        Side::Wall(w) => -(w as i64) - 1,
    }
}

pub(crate) fn decode_pair(a: i64, b: i64, grains: usize, walls: usize) -> R<Pair> {
    let bad = || Fail(format!("pair ({a}, {b}) names no grain or wall"));
    let b = usize::try_from(b)
        .ok()
        .filter(|&b| b < grains)
        .ok_or_else(bad)?;
    let a = if a >= 0 {
        Side::Grain(
            usize::try_from(a)
                .ok()
                .filter(|&a| a < grains)
                .ok_or_else(bad)?,
        )
    } else {
        Side::Wall(
            usize::try_from(-(a + 1))
                .ok()
                .filter(|&w| w < walls)
                .ok_or_else(bad)?,
        )
    };
    Ok(Pair { a, b })
}

fn timers_mut(t: &mut StageTimers) -> [(&'static str, &mut f64); 9] {
    [
        ("detection", &mut t.detection),
        ("return_map", &mut t.return_map),
        ("assembly", &mut t.assembly),
        ("symbolic", &mut t.symbolic),
        ("factorisation", &mut t.factorisation),
        ("solve", &mut t.solve),
        ("topology", &mut t.topology),
        ("output", &mut t.output),
        ("settling", &mut t.settling),
    ]
}

fn counters_mut(c: &mut Counters) -> [(&'static str, &mut usize); 13] {
    [
        ("increments", &mut c.increments),
        ("newton_iterations", &mut c.newton_iterations),
        ("symbolic_factorisations", &mut c.symbolic_factorisations),
        ("numeric_factorisations", &mut c.numeric_factorisations),
        ("factorisations_reused", &mut c.factorisations_reused),
        ("solves", &mut c.solves),
        ("topology_passes", &mut c.topology_passes),
        ("friends_rebuilds", &mut c.friends_rebuilds),
        ("contacts_made", &mut c.contacts_made),
        ("contacts_lost", &mut c.contacts_lost),
        ("bonds_broken", &mut c.bonds_broken),
        ("cuts", &mut c.cuts),
        ("settling_steps", &mut c.settling_steps),
    ]
}

// ---------------------------------------------------------------------------------------
// Header.

fn write_header(file: &File, h: &RunHeader) -> R<()> {
    set_str_attr(file, "format", FORMAT)?;
    set_attr(file, "format_version", &FORMAT_VERSION)?;
    set_str_attr(file, "grainstat_version", &h.version)?;
    set_str_attr(file, "scene_name", &h.scene_name)?;
    set_str_attr(file, "law", &h.law)?;
    set_attr(file, "depth", &h.depth)?;
    set_attr(file, "fixed_rotations", &u8::from(h.fixed_rotations))?;
    set_attr(file, "grains", &(h.radius.len() as i64))?;
    set_attr(file, "walls", &(h.walls.len() as i64))?;

    let run = file.create_group("run")?;
    put_text(&run, "scene", &h.scene_text)?;
    put_text(&run, "solver", &h.solver_text)?;

    let grains = file.create_group("grains")?;
    put(&grains, "radius", ArrayView1::from(&h.radius[..]))?;
    // Point numbers for XDMF, whose point cells need a connectivity array.
    let index: Array1<i64> = (0..h.radius.len() as i64).collect();
    put(&grains, "index", index.view())?;

    write_walls(&file.create_group("walls")?, &h.walls)?;
    write_membranes(file, &h.membranes)?;
    write_regions(file, &h.regions)
}

/// The static part of walls, one row per wall, into `group` (`/walls` of a result file).
pub(crate) fn write_walls(group: &Group, walls: &[WallHeader]) -> R<()> {
    let names: Vec<String> = walls.iter().map(|w| w.name.clone()).collect();
    put_strings(group, "name", &names)?;
    let normal: Vec<[f64; 2]> = walls.iter().map(|w| w.normal).collect();
    put(group, "normal", ArrayView2::from(&normal[..]))?;
    let offset: Vec<f64> = walls.iter().map(|w| w.offset).collect();
    put(group, "offset", ArrayView1::from(&offset[..]))?;
    let pivot: Vec<[f64; 2]> = walls.iter().map(|w| w.pivot).collect();
    put(group, "pivot", ArrayView2::from(&pivot[..]))?;
    let control: Vec<String> = walls
        .iter()
        .map(|w| control_name(w.control).to_owned())
        .collect();
    put_strings(group, "control", &control)?;
    let friction: Vec<f64> = walls.iter().map(|w| w.friction).collect();
    put(group, "friction", ArrayView1::from(&friction[..]))?;
    let length: Vec<f64> = walls.iter().map(|w| w.length.unwrap_or(f64::NAN)).collect();
    put(group, "length", ArrayView1::from(&length[..]))?;
    // Circles as centre x, centre y, radius, grains inside (1) or outside (0); NaN for lines.
    let circle: Vec<[f64; 4]> = walls
        .iter()
        .map(|w| match w.circle {
            Some(c) => [
                c.center[0],
                c.center[1],
                c.radius,
                c.grains_inside as u8 as f64,
            ],
            None => [f64::NAN; 4],
        })
        .collect();
    put(group, "circle", ArrayView2::from(&circle[..]))?;
    // The direction a moving plug's centre goes; NaN for lines and circles that grow.
    let moves: Vec<[f64; 2]> = walls
        .iter()
        .map(|w| w.circle.and_then(|c| c.moves).unwrap_or([f64::NAN; 2]))
        .collect();
    put(group, "circle_moves", ArrayView2::from(&moves[..]))?;
    Ok(())
}

/// The static part of `w` walls from `group`, as [`write_walls`] wrote them.
pub(crate) fn read_walls(group: &Group, w: usize) -> R<Vec<WallHeader>> {
    let names = read_vec::<VarLenUnicode>(group, "name", Some(w))?;
    let normal = read_rows::<f64, 2>(group, "normal", Some(w))?;
    let offset = read_vec::<f64>(group, "offset", Some(w))?;
    // Files written before walls turned: each wall's foot from the origin, on its line.
    let pivot = match group.link_exists("pivot") {
        true => read_rows::<f64, 2>(group, "pivot", Some(w))?,
        false => (0..w).map(|k| normal[k].map(|v| v * offset[k])).collect(),
    };
    let control = read_vec::<VarLenUnicode>(group, "control", Some(w))?;
    let friction = read_vec::<f64>(group, "friction", Some(w))?;
    let length = read_vec::<f64>(group, "length", Some(w))?;
    let circle = read_rows::<f64, 4>(group, "circle", Some(w))?;
    let moves = match group.link_exists("circle_moves") {
        true => read_rows::<f64, 2>(group, "circle_moves", Some(w))?,
        false => vec![[f64::NAN; 2]; w],
    };
    (0..w)
        .map(|k| {
            let control = match control[k].as_str() {
                "displacement" => WallControl::Displacement,
                "stress" => WallControl::Stress,
                other => return Err(Fail(format!("wall {k} has control `{other}`"))),
            };
            Ok(WallHeader {
                name: names[k].as_str().to_owned(),
                normal: normal[k],
                offset: offset[k],
                pivot: pivot[k],
                control,
                friction: friction[k],
                length: (!length[k].is_nan()).then_some(length[k]),
                circle: (!circle[k][2].is_nan()).then_some(Circle {
                    center: [circle[k][0], circle[k][1]],
                    radius: circle[k][2],
                    grains_inside: circle[k][3] != 0.0,
                    moves: (!moves[k][0].is_nan()).then_some(moves[k]),
                }),
            })
        })
        .collect()
}

fn read_header(file: &File) -> R<RunHeader> {
    let version = get_attr::<i64>(file, "format_version")?;
    if version != FORMAT_VERSION {
        return Err(Fail(format!(
            "layout version {version}; this grainstat reads version {FORMAT_VERSION}"
        )));
    }
    let text = |name: &str| -> R<String> {
        let run = file.group("run")?;
        let v = dataset(&run, name)?
            .read_scalar::<VarLenUnicode>()
            .map_err(|e| Fail(format!("dataset `/run/{name}`: {e}")))?;
        Ok(v.as_str().to_owned())
    };
    let grains = file.group("grains")?;
    let n = get_count(file, "grains")?;
    let radius = read_vec::<f64>(&grains, "radius", Some(n))?;

    let walls = read_walls(&file.group("walls")?, get_count(file, "walls")?)?;

    Ok(RunHeader {
        scene_name: get_str_attr(file, "scene_name")?,
        scene_text: text("scene")?,
        solver_text: text("solver")?,
        version: get_str_attr(file, "grainstat_version")?,
        depth: get_attr::<f64>(file, "depth")?,
        radius,
        walls,
        fixed_rotations: get_attr::<u8>(file, "fixed_rotations")? != 0,
        law: get_str_attr(file, "law")?,
        membranes: read_membranes(file)?,
        regions: read_regions(file)?,
    })
}

/// Regions as their names and shapes (see [`Region::to_row`]).
fn write_regions(file: &File, regions: &[Region]) -> R<()> {
    let group = file.create_group("regions")?;
    let names: Vec<String> = regions.iter().map(|r| r.name.clone()).collect();
    put_strings(&group, "name", &names)?;
    let shape: Vec<[f64; 5]> = regions.iter().map(Region::to_row).collect();
    put(&group, "shape", ArrayView2::from(&shape[..]))?;
    Ok(())
}

/// The regions of a file; none in a file written before regions were measured.
fn read_regions(file: &File) -> R<Vec<Region>> {
    if !file.link_exists("regions") {
        return Ok(Vec::new());
    }
    let group = file.group("regions")?;
    let names = read_vec::<VarLenUnicode>(&group, "name", None)?;
    let shape = read_rows::<f64, 5>(&group, "shape", Some(names.len()))?;
    names
        .iter()
        .zip(shape)
        .map(|(name, row)| {
            Region::from_row(name.as_str().to_owned(), row)
                .ok_or_else(|| Fail(format!("region `{name}` has an unknown shape {}", row[0])))
        })
        .collect()
}

/// Membranes as kind (0 a side, 1 a ring) and the side's outward direction or the ring's
/// centre.
fn write_membranes(file: &File, membranes: &[Membrane]) -> R<()> {
    let group = file.create_group("membranes")?;
    let names: Vec<String> = membranes.iter().map(|m| m.name.clone()).collect();
    put_strings(&group, "name", &names)?;
    let shape: Vec<[f64; 3]> = membranes
        .iter()
        .map(|m| match m.shape {
            MembraneShape::Side { outward } => [0.0, outward[0], outward[1]],
            MembraneShape::Ring { center } => [1.0, center[0], center[1]],
        })
        .collect();
    put(&group, "shape", ArrayView2::from(&shape[..]))?;
    Ok(())
}

fn read_membranes(file: &File) -> R<Vec<Membrane>> {
    let group = file.group("membranes")?;
    let names = read_vec::<VarLenUnicode>(&group, "name", None)?;
    let shape = read_rows::<f64, 3>(&group, "shape", Some(names.len()))?;
    Ok(names
        .iter()
        .zip(&shape)
        .map(|(name, s)| Membrane {
            name: name.as_str().to_owned(),
            shape: if s[0] == 0.0 {
                MembraneShape::Side {
                    outward: [s[1], s[2]],
                }
            } else {
                MembraneShape::Ring {
                    center: [s[1], s[2]],
                }
            },
            pressure: 0.0,
        })
        .collect())
}

// ---------------------------------------------------------------------------------------
// One increment.

/// `measured[w]` when the report has one value per wall, NaN otherwise (a report without
/// measurements must not stop the run from being written).
fn per_wall(values: &[f64], walls: usize) -> Vec<f64> {
    if values.len() == walls {
        values.to_vec()
    } else {
        vec![f64::NAN; walls]
    }
}

fn write_group_state(g: &Group, state: &State, report: &IncrementReport) -> R<()> {
    let grains = g.create_group("grains")?;
    put(
        &grains,
        "position",
        ArrayView2::from(&state.grains.position[..]),
    )?;
    // Origin and displacement too: the solver forms contact geometry from them, and
    // `position = origin + displacement` cannot be split again exactly.
    put(
        &grains,
        "origin",
        ArrayView2::from(&state.grains.origin[..]),
    )?;
    put(
        &grains,
        "displacement",
        ArrayView2::from(&state.grains.displacement[..]),
    )?;
    put(
        &grains,
        "rotation",
        ArrayView1::from(&state.grains.rotation[..]),
    )?;

    let cs = &state.contacts.contacts;
    let contacts = g.create_group("contacts")?;
    let pair: Vec<[i64; 2]> = cs
        .iter()
        .map(|c| [side_code(c.pair.a), c.pair.b as i64])
        .collect();
    put(&contacts, "pair", ArrayView2::from(&pair[..]))?;
    // The contact as a line between grain centres for XDMF; a wall contact's wall end is
    // its grain (a line of zero length).
    let nodes: Vec<[i64; 2]> = pair
        .iter()
        .map(|&[a, b]| [if a < 0 { b } else { a }, b])
        .collect();
    put(&contacts, "nodes", ArrayView2::from(&nodes[..]))?;
    let column = |f: fn(&Contact) -> f64| -> Array1<f64> { cs.iter().map(f).collect() };
    put(
        &contacts,
        "normal_force",
        column(|c| c.response.normal_force).view(),
    )?;
    put(
        &contacts,
        "shear_force",
        column(|c| c.response.shear_force).view(),
    )?;
    put(
        &contacts,
        "shear_displacement",
        column(|c| c.shear_displacement0).view(),
    )?;
    put(&contacts, "overlap", column(|c| c.overlap).view())?;
    let state_code: Array1<u8> = cs.iter().map(|c| c.state() as u8).collect();
    put(&contacts, "state", state_code.view())?;
    let sliding: Array1<u8> = cs.iter().map(|c| u8::from(c.response.sliding)).collect();
    put(&contacts, "sliding", sliding.view())?;
    let params: Vec<[f64; 4]> = cs
        .iter()
        .map(|c| {
            let p = &c.params;
            [p.stiffness, p.kappa, p.friction, p.strength]
        })
        .collect();
    put(&contacts, "params", ArrayView2::from(&params[..]))?;
    let tangent: Vec<[f64; 3]> = cs
        .iter()
        .map(|c| {
            let r = &c.response;
            [r.dfn_dn, r.dfs_dn, r.dfs_ds]
        })
        .collect();
    put(&contacts, "tangent", ArrayView2::from(&tangent[..]))?;

    let nw = state.walls.len();
    let m = &report.measurements;
    let walls = g.create_group("walls")?;
    let wall_column =
        |f: fn(&Wall) -> f64| -> Array1<f64> { state.walls.walls.iter().map(f).collect() };
    put(&walls, "position", wall_column(|w| w.position).view())?;
    put(&walls, "slide", wall_column(|w| w.slide).view())?;
    put(&walls, "turn", wall_column(|w| w.turn).view())?;
    put(&walls, "stress", wall_column(|w| w.stress).view())?;
    let normal_force = per_wall(&m.wall_normal_force, nw);
    put(&walls, "normal_force", ArrayView1::from(&normal_force[..]))?;
    let shear_force = per_wall(&m.wall_shear_force, nw);
    put(&walls, "shear_force", ArrayView1::from(&shear_force[..]))?;
    let measured = per_wall(&m.wall_stress, nw);
    put(&walls, "measured_stress", ArrayView1::from(&measured[..]))?;
    let membranes = g.create_group("membranes")?;
    let pressure: Vec<f64> = state.membranes.iter().map(|m| m.pressure).collect();
    put(&membranes, "pressure", ArrayView1::from(&pressure[..]))?;

    put(g, "macro_stress", ArrayView2::from(&m.macro_stress[..]))?;

    let broken: Vec<[i64; 4]> = state
        .contacts
        .broken_bonds
        .iter()
        .map(|b| {
            [
                side_code(b.pair.a),
                b.pair.b as i64,
                b.increment as i64,
                b.mode as u8 as i64,
            ]
        })
        .collect();
    put(g, "broken_bonds", ArrayView2::from(&broken[..]))?;

    let friends = g.create_group("friends")?;
    put(
        &friends,
        "reference",
        ArrayView2::from(&state.friends_reference[..]),
    )?;
    put(
        &friends,
        "wall_reference",
        ArrayView2::from(&state.friends_wall_reference[..]),
    )?;
    put(g, "last_step", ArrayView1::from(&state.last_step[..]))?;

    let count = |v: usize| v as i64;
    set_attr(g, "increment", &count(state.increment))?;
    set_attr(g, "stage", &count(state.stage))?;
    set_attr(g, "stage_increment", &count(state.stage_increment))?;
    set_attr(g, "residual", &report.residual)?;
    set_attr(g, "newton_iterations", &count(report.newton_iterations))?;
    set_attr(g, "topology_passes", &count(report.topology_passes))?;
    set_attr(g, "cuts", &i64::from(report.cuts))?;
    set_attr(g, "contacts_made", &count(report.contacts_made))?;
    set_attr(g, "contacts_lost", &count(report.contacts_lost))?;
    set_attr(g, "bonds_broken", &count(report.bonds_broken))?;
    set_attr(g, "contacts_per_grain", &m.contacts_per_grain)?;
    set_attr(g, "grain_contacts", &count(m.grain_contacts))?;
    set_attr(g, "wall_contacts", &count(m.wall_contacts))?;
    set_attr(g, "bonds", &count(m.bonds))?;
    set_attr(g, "volume", &m.volume)?;
    Ok(())
}

fn read_group_state(g: &Group, h: &RunHeader) -> R<State> {
    let n = h.radius.len();
    let nw = h.walls.len();
    let grains = g.group("grains")?;
    let grains = GrainSet {
        position: read_rows::<f64, 2>(&grains, "position", Some(n))?,
        origin: read_rows::<f64, 2>(&grains, "origin", Some(n))?,
        displacement: read_rows::<f64, 2>(&grains, "displacement", Some(n))?,
        rotation: read_vec::<f64>(&grains, "rotation", Some(n))?,
        radius: h.radius.clone(),
    };

    let walls = g.group("walls")?;
    let wall_position = read_vec::<f64>(&walls, "position", Some(nw))?;
    let slide = read_vec::<f64>(&walls, "slide", Some(nw))?;
    // No turns in a file written before walls turned.
    let turn = match walls.link_exists("turn") {
        true => read_vec::<f64>(&walls, "turn", Some(nw))?,
        false => vec![0.0; nw],
    };
    let stress = read_vec::<f64>(&walls, "stress", Some(nw))?;
    let walls = h
        .walls
        .iter()
        .enumerate()
        .map(|(k, w)| w.wall([wall_position[k], slide[k], turn[k]], stress[k]))
        .collect();

    let c = g.group("contacts")?;
    let pair = read_rows::<i64, 2>(&c, "pair", None)?;
    let m = Some(pair.len());
    let normal_force = read_vec::<f64>(&c, "normal_force", m)?;
    let shear_force = read_vec::<f64>(&c, "shear_force", m)?;
    let shear_displacement = read_vec::<f64>(&c, "shear_displacement", m)?;
    let overlap = read_vec::<f64>(&c, "overlap", m)?;
    let state_code = read_vec::<u8>(&c, "state", m)?;
    let sliding = read_vec::<u8>(&c, "sliding", m)?;
    let params = read_rows::<f64, 4>(&c, "params", m)?;
    let tangent = read_rows::<f64, 3>(&c, "tangent", m)?;
    let mut contacts = Vec::with_capacity(pair.len());
    for k in 0..pair.len() {
        let (bonded, broken) = match state_code[k] {
            0 | 1 => (false, false),
            2 => (true, false),
            3 => (false, true),
            s => return Err(Fail(format!("contact {k} has state {s}"))),
        };
        contacts.push(Contact {
            pair: decode_pair(pair[k][0], pair[k][1], n, nw)?,
            params: ContactParams {
                stiffness: params[k][0],
                kappa: params[k][1],
                friction: params[k][2],
                strength: params[k][3],
            },
            bonded,
            broken,
            shear_force0: shear_force[k],
            shear_displacement0: shear_displacement[k],
            shear_offset: 0.0,
            response: Response {
                normal_force: normal_force[k],
                shear_force: shear_force[k],
                sliding: sliding[k] != 0,
                dfn_dn: tangent[k][0],
                dfs_dn: tangent[k][1],
                dfs_ds: tangent[k][2],
            },
            overlap: overlap[k],
            shear_increment: 0.0,
            start_overlap: overlap[k],
            lag: Default::default(),
            energy: 0.0,
        });
    }

    let broken_bonds = read_rows::<i64, 4>(g, "broken_bonds", None)?
        .into_iter()
        .map(|[a, b, increment, mode]| {
            Ok(BrokenBond {
                pair: decode_pair(a, b, n, nw)?,
                increment: usize::try_from(increment)
                    .map_err(|_| Fail(format!("broken bond at increment {increment}")))?,
                mode: match mode {
                    0 => BreakMode::Tension,
                    1 => BreakMode::Shear,
                    _ => return Err(Fail(format!("broken bond mode {mode}"))),
                },
            })
        })
        .collect::<R<Vec<_>>>()?;

    let pressure = read_vec::<f64>(&g.group("membranes")?, "pressure", Some(h.membranes.len()))?;
    let membranes = h
        .membranes
        .iter()
        .zip(&pressure)
        .map(|(m, p)| Membrane {
            pressure: *p,
            ..m.clone()
        })
        .collect();
    let friends = g.group("friends")?;
    Ok(State {
        increment: get_count(g, "increment")?,
        stage: get_count(g, "stage")?,
        stage_increment: get_count(g, "stage_increment")?,
        grains,
        walls: WallSet { walls },
        contacts: ContactSet {
            contacts,
            broken_bonds,
        },
        friends_reference: read_rows::<f64, 2>(&friends, "reference", None)?,
        friends_wall_reference: read_rows::<f64, 2>(&friends, "wall_reference", None)?,
        last_step: if g.link_exists("last_step") {
            read_vec::<f64>(g, "last_step", None)?
        } else {
            Vec::new()
        },
        membranes,
    })
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

const HISTORY_FLOAT: [&str; 14] = [
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
const NEGATIVE_PIVOTS: &str = "negative_pivots";

/// Each wall's turn (rad) and shear stress (Pa), a row of `W` values per increment, kept
/// apart from the walls' first columns so files written before them read.
const WALL_SHEAR: [&str; 2] = ["wall_turn", "wall_shear_stress"];

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
struct Widths {
    walls: usize,
    membranes: usize,
    regions: usize,
}

impl Widths {
    fn of(header: &RunHeader) -> Widths {
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
    }
}

fn filtered(b: hdf5::DatasetBuilder) -> hdf5::DatasetBuilder {
    let b = b.shuffle();
    if hdf5::filters::deflate_available() {
        b.deflate(4)
    } else {
        b
    }
}

fn create_history(h: &Group, walls: usize, membranes: usize, regions: usize) -> R<()> {
    for name in HISTORY_INT {
        filtered(h.new_dataset_builder())
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
    filtered(h.new_dataset_builder())
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
    filtered(h.new_dataset_builder())
        .empty::<f64>()
        .shape(vec![Extent::resizable(0), second])
        .chunk((HISTORY_CHUNK, width.max(1)))
        .create(name)?;
    Ok(())
}

fn append_table_row(h: &Group, name: &str, row: usize, values: &[f64]) -> R<()> {
    let ds = dataset(h, name)?;
    ds.resize([row + 1, values.len()])?;
    if !values.is_empty() {
        let view = ArrayView2::from_shape((1, values.len()), values)?;
        ds.write_slice(view, s![row..row + 1, ..])?;
    }
    Ok(())
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

fn append_history(
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
    let floats: [f64; 14] = [
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
    for (name, value) in HISTORY_FLOAT.iter().zip(floats) {
        append_scalar(h, name, row, value)?;
    }
    for (name, value) in HISTORY_INT.iter().zip(ints) {
        append_scalar(h, name, row, value)?;
    }
    Ok(())
}

fn append_scalar<T: H5Type>(h: &Group, name: &str, row: usize, value: T) -> R<()> {
    let ds = dataset(h, name)?;
    ds.resize([row + 1])?;
    ds.write_slice(
        ArrayView1::from(std::slice::from_ref(&value)),
        s![row..row + 1],
    )?;
    Ok(())
}

/// Number of leading history rows whose increment passes `keep`, and that every history
/// dataset holds (those added since the file was written are made by `truncate_history`).
fn leading_rows(h: &Group, keep: impl Fn(i64) -> bool) -> R<usize> {
    let increments = read_vec::<i64>(h, "increment", None)?;
    let mut rows = increments.iter().take_while(|&&k| keep(k)).count();
    for name in HISTORY_INT
        .iter()
        .chain(&HISTORY_FLOAT)
        .chain(&HISTORY_WALL)
        .chain(&REGION_STRESS)
        .chain(&WALL_SHEAR)
        .chain(&[REGION_ROTATION])
    {
        if h.link_exists(name) {
            rows = rows.min(dataset(h, name)?.shape().first().copied().unwrap_or(0));
        }
    }
    Ok(rows)
}

fn truncate_history(h: &Group, rows: usize, widths: Widths) -> R<()> {
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

// ---------------------------------------------------------------------------------------
// Summary.

fn write_summary_group(file: &File, stats: &SolverStats) -> R<()> {
    let g = if file.link_exists("summary") {
        file.group("summary")?
    } else {
        file.create_group("summary")?
    };
    let mut stats = *stats;
    for (name, v) in timers_mut(&mut stats.timers) {
        set_attr(&g, &format!("time_{name}"), &*v)?;
    }
    for (name, v) in counters_mut(&mut stats.counters) {
        set_attr(&g, name, &(*v as i64))?;
    }
    Ok(())
}

fn read_summary_group(file: &File) -> R<Option<SolverStats>> {
    if !file.link_exists("summary") {
        return Ok(None);
    }
    let g = file.group("summary")?;
    let mut stats = SolverStats::default();
    for (name, v) in timers_mut(&mut stats.timers) {
        *v = get_attr::<f64>(&g, &format!("time_{name}"))?;
    }
    for (name, v) in counters_mut(&mut stats.counters) {
        *v = get_count(&g, name)?;
    }
    Ok(Some(stats))
}
