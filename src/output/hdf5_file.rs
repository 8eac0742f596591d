//! The HDF5 result file: written after each increment, read back to resume a run, to plot
//! and to inspect (`grainstat info`).
//!
//! A run killed at any moment must leave a file that opens and can be resumed. HDF5 updates
//! its metadata in place and reuses space it freed, so a process killed in the middle of a
//! write, even one followed by a flush, can leave a file that no longer opens or whose
//! compressed chunks no longer inflate. So the file is never written where it lies. Beside it
//! lies its twin (`NAME.h5.writing`), a second copy of the same file: every change (each
//! increment, the summary, the tidying on resume) is made to the twin, which is flushed,
//! closed and swapped with the file in one atomic rename (`renameat2`'s `RENAME_EXCHANGE`).
//! A new file is written whole beside it and renamed over it. The old file, now the twin, is then given the same change on another
//! thread while the run goes on, so the two are equal again by the next change, and kept
//! open for it. At every
//! moment `NAME.h5` is the file as it was after one whole change, and no change copies the
//! file (copying the whole file at every increment made writing one cost as much as all
//! before it): the file is copied only to make a twin not known to be equal, at a run's
//! first change, after a failed change, or when a reader still holds the twin open (HDF5's
//! file lock tells). Where the file system cannot exchange two files, the twin is renamed over
//! the file and made again at the next change. The twin is deleted when the [`ResultFile`]
//! is dropped. Each increment is still written into its own group with its `complete`
//! attribute set last, and on resume every group without it is deleted (files written before
//! this scheme). Every value a [`State`] holds is stored
//! exactly (f64 as f64, indices as i64), so a resumed run repeats the uninterrupted one bit
//! for bit. The layout is documented for Python users in `docs/hdf5-layout.md`; keep the two
//! in step (and raise [`FORMAT_VERSION`] when a change breaks old readers).

mod group;
mod header;
mod history;
mod info;
mod summary;

use group::{per_wall, read_breakouts, read_group_state, write_breakouts, write_group_state};
use header::{read_header, read_regions, write_header};
pub(crate) use header::{read_walls, write_walls};
use history::{
    append_history, append_scalar, create_history, leading_rows, truncate_history, Widths,
    NEGATIVE_PIVOTS,
};
pub use history::{read_history, History};
pub use info::info;
pub use summary::Mechanism;
use summary::{
    counters_mut, read_mechanism_group, read_summary_group, timers_mut, write_mechanism_group,
    write_summary_group,
};

use std::ffi::CString;
use std::fmt::Write as _;
use std::os::unix::ffi::OsStrExt;
use std::path::{Path, PathBuf};
use std::thread::JoinHandle;

use hdf5::types::VarLenUnicode;
use hdf5::{Extent, File, Group, H5Type};
use ndarray::{s, Array1, Array2, ArrayView1, ArrayView2};

use super::h5::{
    dataset, get_attr, get_count, get_str_attr, input_error, put, put_plain, put_row, put_strings,
    put_text, read_error, read_in_child, read_rows, read_vec, require_format, set_attr,
    set_str_attr, write_error, Fail, R,
};
use crate::contact::{
    BreakMode, BrokenBond, CommittedContact, Contact, ContactParams, ContactSet, Response,
};
use crate::error::Error;
use crate::geometry::{
    Circle, GrainSet, Membrane, MembraneShape, Pair, Side, Wall, WallControl, WallSet,
};
use crate::measure::Region;
use crate::solver::stats::{Counters, SolverStats, StageTimers};
use crate::state::{Breakout, IncrementReport, PeakState, State};

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

/// A result file being written. No HDF5 handle to it stays open between changes: each one is
/// made to the twin, which is then swapped in (see the module's notes).
#[derive(Debug)]
pub struct ResultFile {
    path: PathBuf,
    sizes: Sizes,
    history_rows: usize,
    twin: Twin,
}

/// What a result file was made for, which every increment written to it must fit.
#[derive(Debug, Clone, Copy)]
struct Sizes {
    grains: usize,
    widths: Widths,
}

/// Where the twin stands between changes.
#[derive(Debug)]
enum Twin {
    /// Not known to hold the file as it is: the next change copies the file first.
    Stale,
    /// Being given the file's last change on another thread, which hands it on open, in step
    /// with the file, for the next change to be made to (none where it could not be).
    CatchingUp(JoinHandle<Option<File>>),
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
        close(file, &side)?;
        std::fs::rename(&side, path).map_err(|e| Error::io(path.display(), e))?;
        Ok(ResultFile {
            path: path.to_path_buf(),
            sizes: Sizes::of(header),
            history_rows: 0,
            twin: Twin::Stale,
        })
    }

    /// Open a file to continue its run: the last complete increment is the state to resume
    /// from; incomplete groups (a run killed while writing) and their history rows are
    /// deleted.
    pub fn open_for_resume(
        path: impl AsRef<Path>,
    ) -> Result<(ResultFile, RunHeader, State), Error> {
        let path = path.as_ref();
        // All of it in a child process first, on a copy that is then dropped, with a trial
        // write of the state resumed from: libhdf5 can crash or hang on a corrupt file, and
        // may meet the corruption only when it writes (see `read_in_child`).
        read_in_child(path, || {
            let probe = side_path(path);
            let written = fresh_copy(path, &probe).is_ok() && probe_resume(&probe).is_ok();
            let _ = std::fs::remove_file(&probe);
            written
        })?;
        // Read-only first: a file that is not a whole result file is bad input, and is left
        // as it is.
        let (header, state, incomplete, keep) = read_for_resume(path)?;
        let mut out = ResultFile {
            path: path.to_path_buf(),
            sizes: Sizes::of(&header),
            history_rows: keep,
            twin: Twin::Stale,
        };
        let widths = out.sizes.widths;
        // The file read whole, but deleting in it may still find it corrupt: bad input too.
        out.change(read_error(path), move |file| {
            tidy(file, &incomplete, keep, widths)
        })?;
        Ok((out, header, state))
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
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
        let (sizes, rows, path) = (self.sizes, self.history_rows, self.path.clone());
        // Owned: the twin is given the same change on another thread.
        let (state, report, stats) = (state.clone(), report.clone(), *stats);
        self.history_rows = self.change(write_error(&path), move |file| {
            sizes.write_increment(file, rows, &state, &report, &stats)
        })?;
        Ok(())
    }

    /// Write the solver's timers and counters as attributes of `/summary`, replacing the
    /// last ones.
    pub fn write_summary(&mut self, stats: &SolverStats) -> Result<(), Error> {
        let (path, stats) = (self.path.clone(), *stats);
        self.change(write_error(&path), move |file| {
            write_summary_group(file, &stats)
        })
    }

    /// Write the mechanism of the failure that ends the run as `/failure`, in place of one
    /// written before.
    pub fn write_mechanism(&mut self, mechanism: &Mechanism) -> Result<(), Error> {
        let (path, mechanism) = (self.path.clone(), mechanism.clone());
        self.change(write_error(&path), move |file| {
            write_mechanism_group(file, &mechanism)
        })
    }

    /// Make one change to the file, `write`, and return what it returns: made to the twin,
    /// which is swapped with the file and then given the same change on another thread, to
    /// be done by the next change (see the module's notes). Killed at any moment, the file is
    /// as it was before the change or after it. HDF5's failures become errors by `blame`.
    fn change<T>(
        &mut self,
        blame: impl FnOnce(Fail) -> Error,
        write: impl Fn(&File) -> R<T> + Send + 'static,
    ) -> Result<T, Error> {
        let twin = side_path(&self.path);
        let in_step = match std::mem::replace(&mut self.twin, Twin::Stale) {
            Twin::Stale => None,
            Twin::CatchingUp(done) => done.join().ok().flatten(),
        };
        let file = match in_step {
            Some(file) => file,
            None => {
                fresh_copy(&self.path, &twin)?;
                File::open_rw(&twin).map_err(|e| Error::io(twin.display(), e))?
            }
        };
        // On failure the file itself is untouched; the half-changed twin is made again.
        let value = write(&file).map_err(blame)?;
        close(file, &twin)?;
        if swap(&twin, &self.path)? {
            // Kept open for the next change, which then neither opens it nor reads its
            // metadata anew. A twin that a reader still holds open does not open for writing.
            let catch_up = std::thread::Builder::new().spawn(move || {
                let file = File::open_rw(&twin).ok()?;
                write(&file).is_ok().then_some(file)
            });
            // No thread to be had: the next change starts from a copy.
            if let Ok(done) = catch_up {
                self.twin = Twin::CatchingUp(done);
            }
        }
        Ok(value)
    }
}

impl Drop for ResultFile {
    /// The twin is of no use once the file is no longer written.
    fn drop(&mut self) {
        if let Twin::CatchingUp(done) = std::mem::replace(&mut self.twin, Twin::Stale) {
            let _ = done.join();
        }
        let _ = std::fs::remove_file(side_path(&self.path));
    }
}

impl Sizes {
    fn of(header: &RunHeader) -> Sizes {
        Sizes {
            grains: header.radius.len(),
            widths: Widths::of(header),
        }
    }

    /// Write one increment into `file` whose `/history` has `rows` rows; the rows after.
    fn write_increment(
        self,
        file: &File,
        mut rows: usize,
        state: &State,
        report: &IncrementReport,
        stats: &SolverStats,
    ) -> R<usize> {
        let (n, walls) = (self.grains, self.widths.walls);
        if state.grains.len() != n || state.walls.len() != walls {
            return Err(Fail(format!(
                "the state has {} grains and {} walls, the file was created for {n} and {walls}",
                state.grains.len(),
                state.walls.len(),
            )));
        }
        let g = &state.grains;
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
            truncate_history(&history, rows, self.widths)?;
        }
        let g = inc.create_group(&name)?;
        write_group_state(&g, state, report)?;
        append_history(&history, rows, self.widths, state, report)?;
        let pivots = report.negative_pivots.map_or(-1, |n| n as i64);
        append_scalar(&history, NEGATIVE_PIVOTS, rows, pivots)?;
        write_summary_group(file, stats)?;
        // Last: only now is the increment whole.
        set_attr(&g, "complete", &1u8)?;
        Ok(rows + 1)
    }
}

/// Delete the `incomplete` groups and the history rows after the first `keep`.
fn tidy(file: &File, incomplete: &[String], keep: usize, widths: Widths) -> R<()> {
    let inc = file.group("increments")?;
    for name in incomplete {
        inc.unlink(name)?;
    }
    // The run resumed goes on from the state the failure started from.
    if file.link_exists("failure") {
        file.unlink("failure")?;
    }
    truncate_history(&file.group("history")?, keep, widths)
}

/// What resuming makes of the file at `path`, done to it in place: tidied, and the state
/// resumed from written again.
fn probe_resume(path: &Path) -> Result<(), Error> {
    let (header, state, incomplete, keep) = read_for_resume(path)?;
    let sizes = Sizes::of(&header);
    let file = File::open_rw(path).map_err(|e| Error::io(path.display(), e))?;
    tidy(&file, &incomplete, keep, sizes.widths)
        .and_then(|()| {
            let report = IncrementReport::default();
            sizes.write_increment(&file, keep, &state, &report, &SolverStats::default())
        })
        .map_err(read_error(path))?;
    close(file, path)
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

/// The twin of the result file `path`, to which its changes are made before it replaces it:
/// `NAME.h5.writing` beside `NAME.h5`. A run killed while changing the file leaves it there;
/// the next run writes over it.
pub fn side_path(path: &Path) -> PathBuf {
    let mut name = path.as_os_str().to_owned();
    name.push(".writing");
    PathBuf::from(name)
}

/// Copy `from` to `to` as a new file: the file `to` names may be held open by a reader, who
/// must not see it written over.
fn fresh_copy(from: &Path, to: &Path) -> Result<(), Error> {
    match std::fs::remove_file(to) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            return Err(Error::io(to.display(), e));
        }
        _ => {}
    }
    std::fs::copy(from, to).map_err(|e| Error::io(to.display(), e))?;
    Ok(())
}

/// Flush and close a changed file.
fn close(file: File, path: &Path) -> Result<(), Error> {
    file.flush()
        .and_then(|()| file.close())
        .map_err(|e| Error::io(path.display(), e))
}

/// Put `twin` at `path` in one atomic step: exchanged with the file there, which becomes the
/// twin (true), or, where they cannot be exchanged (a file system without it, no file at
/// `path`), renamed over it (false).
fn swap(twin: &Path, path: &Path) -> Result<bool, Error> {
    let c_path = |p: &Path| CString::new(p.as_os_str().as_bytes());
    let exchanged = match (c_path(twin), c_path(path)) {
        // SAFETY: two NUL-terminated paths, only read.
        (Ok(a), Ok(b)) => unsafe {
            libc::renameat2(
                libc::AT_FDCWD,
                a.as_ptr(),
                libc::AT_FDCWD,
                b.as_ptr(),
                libc::RENAME_EXCHANGE,
            ) == 0
        },
        _ => false,
    };
    if !exchanged {
        std::fs::rename(twin, path).map_err(|e| Error::io(path.display(), e))?;
    }
    Ok(exchanged)
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

/// The mechanism written to `/failure` by the run that ended on no equilibrium near, if one
/// did.
pub fn read_mechanism(path: impl AsRef<Path>) -> Result<Option<Mechanism>, Error> {
    let path = path.as_ref();
    let file = open_existing(path)?;
    read_mechanism_group(&file).map_err(read_error(path))
}

/// The timers and counters last written to `/summary`, `None` when there are none yet (so
/// a resumed run can go on counting).
pub fn read_summary(path: impl AsRef<Path>) -> Result<Option<SolverStats>, Error> {
    let path = path.as_ref();
    let file = open_existing(path)?;
    read_summary_group(&file).map_err(read_error(path))
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
            " (was a run swapping in its next version? try again)"
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

/// A wall's control as stored: `"displacement"` or `"stress"`.
pub fn control_name(c: WallControl) -> &'static str {
    match c {
        WallControl::Displacement => "displacement",
        WallControl::Stress => "stress",
    }
}

/// Pair side `a` as stored: a grain index, or `-(w + 1)` for wall `w`.
pub fn side_code(a: Side) -> i64 {
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
