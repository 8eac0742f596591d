//! Prepared samples on disk: made once (sprinkled, blown up, brought to a stress), then
//! loaded by every test that starts from them.
//!
//! The sample file is HDF5, with the conventions of the result file (`docs/hdf5-layout.md`:
//! SI units, f64 stored exactly, int64 indices, variable-length UTF-8 strings):
//!
//! | where | what |
//! |---|---|
//! | root attributes | `format = "grainstat-sample"`, `format_version = 1`, `grainstat_version`, `description`, `seed` (uint64), `stress` (Pa), `contacts_per_grain`, `grains` (N) |
//! | `/grains/position`, `origin`, `displacement` | (N, 2) f64 (m); `position = origin + displacement` |
//! | `/grains/rotation` | (N,) f64 (rad) |
//! | `/grains/radius` | (N,) f64 (m) |
//! | `/bonds` | (K, 2) int64: the grain pairs that are cemented |
//! | `/region` attributes | `shape` (`"rectangle"`, `"annulus"` or `"beam"`) and its dimensions (m): `width`, `height`; `inner_radius`, `outer_radius`; `length`, `height` |
//! | `/distribution` attributes (absent when unknown) | `kind` (`"a"` or `"b"`), `mean_radius` (m), `ratio` |
//! | `/walls` (absent in samples without walls) | the walls that held the sample, as in a result file's `/walls`, with `position` and `stress` (W,) f64: where each ended and the stress it carried |
//! | `/contacts` (absent likewise) | `pair` (M, 2) int64 coded as in a result file, `shear_force` (M,) f64 (N) and `shear_displacement` (M,) f64 (m): every contact with its history |
//!
//! Origin and displacement are both kept, as in the result file: the solver forms contact
//! geometry from them, and `position` cannot be split again exactly. A CSV file
//! (`x,y,r`, [`write_csv`]) keeps only positions and radii, for other programs.

use std::fmt::Write as _;
use std::path::Path;

use hdf5::File;
use ndarray::{ArrayView1, ArrayView2};

use super::{Region, SizeDistribution, SizeKind};
use crate::error::Error;
use crate::geometry::{GrainSet, Pair, Side, WallSet};
use crate::output::h5::{
    get_attr, get_str_attr, input_error, put, read_in_child, read_rows, read_vec, require_format,
    set_attr, set_str_attr, Fail, R,
};
use crate::output::hdf5_file::{
    decode_pair, read_walls, side_code, side_path, write_walls, WallHeader,
};

/// Value of the root attribute `format`: tells sample files from other HDF5 files.
pub const FORMAT: &str = "grainstat-sample";

/// Version of the layout, root attribute `format_version`.
pub const FORMAT_VERSION: i64 = 1;

/// A prepared sample: the grains as they are, how they were made, and what holds them.
#[derive(Debug, Clone, PartialEq)]
pub struct SampleFile {
    /// The grains, displacements and rotations included.
    pub grains: GrainSet,
    /// The region they were sprinkled into.
    pub region: Region,
    /// The size distribution their radii were drawn from, if they were.
    pub distribution: Option<SizeDistribution>,
    /// The seed of the radii and the sprinkling.
    pub seed: u64,
    /// Free text: how the sample was made.
    pub description: String,
    /// The isotropic stress the sample was prepared to (Pa) (0 for a loose one).
    pub stress: f64,
    /// Grain-grain contacts per grain at that stress.
    pub contacts_per_grain: f64,
    /// Cemented grain pairs `(i, j)`, `i != j` (may be empty).
    pub bonds: Vec<(usize, usize)>,
    /// The walls that held the sample, where they ended (empty when not kept).
    pub walls: WallSet,
    /// Every contact with its history, so a test starts from the prepared equilibrium (empty
    /// when not kept).
    pub contacts: Vec<ContactHistory>,
}

/// A contact of a prepared sample and what it remembers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactHistory {
    /// The pair (walls indexed as in [`SampleFile::walls`]).
    pub pair: Pair,
    /// Shear force (N).
    pub shear_force: f64,
    /// Accumulated shear displacement (m).
    pub shear_displacement: f64,
}

/// Writes a sample file (creating its folder, overwriting the file). A sample whose parts
/// do not fit together (lengths, bonds naming no grain, bad region) is refused before
/// anything is written.
pub fn write_sample(path: impl AsRef<Path>, sample: &SampleFile) -> Result<(), Error> {
    let path = path.as_ref();
    check_sample(sample).map_err(|m| input_error(path, format!("cannot be written: {m}")))?;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir.display(), e))?;
    }
    // Written beside it and renamed over it: killed at any moment, the path holds the old
    // file or the whole new one.
    let side = side_path(path);
    let file = File::create(&side).map_err(|e| Error::io(side.display(), e))?;
    let write = || -> R<()> {
        write_file(&file, sample)?;
        file.flush()?;
        Ok(())
    };
    write().map_err(|f| Error::io(path.display(), f.0))?;
    file.close().map_err(|e| Error::io(side.display(), e))?;
    std::fs::rename(&side, path).map_err(|e| Error::io(path.display(), e))
}

/// Reads a sample file. A missing file, one that is not HDF5, an HDF5 file that is not a
/// sample, or a sample whose parts do not fit together is an [`Error::Input`] naming the
/// file.
pub fn read_sample(path: impl AsRef<Path>) -> Result<SampleFile, Error> {
    let path = path.as_ref();
    read_in_child(path, || read_checked(path).is_ok())?;
    read_checked(path)
}

fn read_checked(path: &Path) -> Result<SampleFile, Error> {
    let file = open_existing(path)?;
    let sample = read_file(&file).map_err(|f| input_error(path, f.0))?;
    check_sample(&sample).map_err(|m| input_error(path, m))?;
    Ok(sample)
}

/// Writes grains as CSV, `x,y,r` with a header line, in Rust's shortest exponent form
/// (`1.5e-4`), which reads back to the same bits. Only positions and radii are kept:
/// the grains read back are at rest at those positions.
pub fn write_csv(path: impl AsRef<Path>, grains: &GrainSet) -> Result<(), Error> {
    let path = path.as_ref();
    if grains.position.len() != grains.radius.len() {
        return Err(input_error(
            path,
            format!(
                "cannot be written: {} positions but {} radii",
                grains.position.len(),
                grains.radius.len()
            ),
        ));
    }
    let mut text = String::from("x,y,r\n");
    for (i, (p, &r)) in grains.position.iter().zip(&grains.radius).enumerate() {
        if !(p[0].is_finite() && p[1].is_finite() && r.is_finite() && r > 0.0) {
            return Err(input_error(
                path,
                format!(
                    "cannot be written: grain {i} is at ({}, {}) with radius {r}",
                    p[0], p[1]
                ),
            ));
        }
        let _ = writeln!(text, "{:e},{:e},{:e}", p[0], p[1], r);
    }
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir.display(), e))?;
    }
    std::fs::write(path, text).map_err(|e| Error::io(path.display(), e))
}

/// Reads grains from CSV (`x, y, r` per line, as a scene's `[grains] file` reads them).
pub fn read_csv(path: impl AsRef<Path>) -> Result<GrainSet, Error> {
    Ok(crate::scene::read_grain_csv(path.as_ref())?)
}

// ---------------------------------------------------------------------------------------
// Consistency.

/// What is wrong with a sample, if anything.
fn check_sample(s: &SampleFile) -> Result<(), String> {
    let g = &s.grains;
    let n = g.radius.len();
    for (name, len) in [
        ("position", g.position.len()),
        ("origin", g.origin.len()),
        ("displacement", g.displacement.len()),
        ("rotation", g.rotation.len()),
    ] {
        if len != n {
            return Err(format!("{len} grain {name}s but {n} radii"));
        }
    }
    for (i, &r) in g.radius.iter().enumerate() {
        if !(r.is_finite() && r > 0.0) {
            return Err(format!("grain {i} has radius {r}"));
        }
    }
    let finite = |v: &[[f64; 2]]| {
        v.iter()
            .position(|p| !(p[0].is_finite() && p[1].is_finite()))
    };
    for (name, v) in [
        ("position", &g.position),
        ("origin", &g.origin),
        ("displacement", &g.displacement),
    ] {
        if let Some(i) = finite(v) {
            return Err(format!("grain {i} has {name} {:?}", v[i]));
        }
    }
    if let Some(i) = g.rotation.iter().position(|r| !r.is_finite()) {
        return Err(format!("grain {i} has rotation {}", g.rotation[i]));
    }
    for (k, &(a, b)) in s.bonds.iter().enumerate() {
        if a >= n || b >= n || a == b {
            return Err(format!(
                "bond {k} joins grains {a} and {b}: a bond joins two different grains of the \
                 {n}"
            ));
        }
    }
    for (k, h) in s.contacts.iter().enumerate() {
        let a_ok = match h.pair.a {
            Side::Grain(a) => a < h.pair.b,
            Side::Wall(w) => w < s.walls.len(),
        };
        if !(a_ok && h.pair.b < n && h.shear_force.is_finite() && h.shear_displacement.is_finite())
        {
            return Err(format!(
                "contact {k} ({:?}) does not fit the sample",
                h.pair
            ));
        }
    }
    s.region.check().map_err(|e| e.to_string())?;
    if let Some(d) = &s.distribution {
        d.check().map_err(|e| e.to_string())?;
    }
    for (name, v) in [
        ("stress", s.stress),
        ("contacts_per_grain", s.contacts_per_grain),
    ] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(format!("`{name}` is {v}; it must be a finite number >= 0"));
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------
// Layout.

fn write_file(file: &File, s: &SampleFile) -> R<()> {
    set_str_attr(file, "format", FORMAT)?;
    set_attr(file, "format_version", &FORMAT_VERSION)?;
    set_str_attr(file, "grainstat_version", env!("CARGO_PKG_VERSION"))?;
    set_str_attr(file, "description", &s.description)?;
    set_attr(file, "seed", &s.seed)?;
    set_attr(file, "stress", &s.stress)?;
    set_attr(file, "contacts_per_grain", &s.contacts_per_grain)?;
    set_attr(file, "grains", &(s.grains.len() as i64))?;

    let g = file.create_group("grains")?;
    put(&g, "position", ArrayView2::from(&s.grains.position[..]))?;
    put(&g, "origin", ArrayView2::from(&s.grains.origin[..]))?;
    put(
        &g,
        "displacement",
        ArrayView2::from(&s.grains.displacement[..]),
    )?;
    put(&g, "rotation", ArrayView1::from(&s.grains.rotation[..]))?;
    put(&g, "radius", ArrayView1::from(&s.grains.radius[..]))?;

    let bonds: Vec<[i64; 2]> = s.bonds.iter().map(|&(a, b)| [a as i64, b as i64]).collect();
    put(file, "bonds", ArrayView2::from(&bonds[..]))?;

    let region = file.create_group("region")?;
    set_str_attr(&region, "shape", s.region.shape())?;
    for (name, value) in region_dimensions(&s.region) {
        set_attr(&region, name, &value)?;
    }

    if let Some(d) = &s.distribution {
        let g = file.create_group("distribution")?;
        set_str_attr(&g, "kind", d.kind.name())?;
        set_attr(&g, "mean_radius", &d.mean_radius)?;
        set_attr(&g, "ratio", &d.ratio)?;
    }

    if !s.walls.is_empty() || !s.contacts.is_empty() {
        let w = file.create_group("walls")?;
        write_walls(
            &w,
            &s.walls.walls.iter().map(WallHeader::of).collect::<Vec<_>>(),
        )?;
        let position: Vec<f64> = s.walls.walls.iter().map(|w| w.position).collect();
        put(&w, "position", ArrayView1::from(&position[..]))?;
        let stress: Vec<f64> = s.walls.walls.iter().map(|w| w.stress).collect();
        put(&w, "stress", ArrayView1::from(&stress[..]))?;
        let c = file.create_group("contacts")?;
        let pair: Vec<[i64; 2]> = s
            .contacts
            .iter()
            .map(|h| [side_code(h.pair.a), h.pair.b as i64])
            .collect();
        put(&c, "pair", ArrayView2::from(&pair[..]))?;
        let shear: Vec<f64> = s.contacts.iter().map(|h| h.shear_force).collect();
        put(&c, "shear_force", ArrayView1::from(&shear[..]))?;
        let slip: Vec<f64> = s.contacts.iter().map(|h| h.shear_displacement).collect();
        put(&c, "shear_displacement", ArrayView1::from(&slip[..]))?;
    }
    Ok(())
}

fn read_file(file: &File) -> R<SampleFile> {
    let version = get_attr::<i64>(file, "format_version")?;
    if version != FORMAT_VERSION {
        return Err(Fail(format!(
            "sample layout version {version}; this grainstat reads version {FORMAT_VERSION}"
        )));
    }
    let n = get_attr::<i64>(file, "grains")?;
    let n = usize::try_from(n).map_err(|_| Fail(format!("attribute `grains` is {n}")))?;
    let g = file.group("grains")?;
    let grains = GrainSet {
        position: read_rows::<f64, 2>(&g, "position", Some(n))?,
        origin: read_rows::<f64, 2>(&g, "origin", Some(n))?,
        displacement: read_rows::<f64, 2>(&g, "displacement", Some(n))?,
        rotation: read_vec::<f64>(&g, "rotation", Some(n))?,
        radius: read_vec::<f64>(&g, "radius", Some(n))?,
        taken_out: vec![false; n],
    };

    let bonds = read_rows::<i64, 2>(file, "bonds", None)?
        .into_iter()
        .map(|[a, b]| match (usize::try_from(a), usize::try_from(b)) {
            (Ok(a), Ok(b)) => Ok((a, b)),
            _ => Err(Fail(format!("bond ({a}, {b}) names no grain"))),
        })
        .collect::<R<Vec<_>>>()?;

    let r = file.group("region")?;
    let dim = |name: &str| get_attr::<f64>(&r, name);
    let region = match get_str_attr(&r, "shape")?.as_str() {
        "rectangle" => Region::Rectangle {
            width: dim("width")?,
            height: dim("height")?,
        },
        "annulus" => Region::Annulus {
            inner_radius: dim("inner_radius")?,
            outer_radius: dim("outer_radius")?,
        },
        "beam" => Region::Beam {
            length: dim("length")?,
            height: dim("height")?,
        },
        other => {
            return Err(Fail(format!(
                "region shape `{other}`: expected `rectangle`, `annulus` or `beam`"
            )))
        }
    };

    let distribution = if file.link_exists("distribution") {
        let d = file.group("distribution")?;
        let kind = match get_str_attr(&d, "kind")?.as_str() {
            "a" => SizeKind::A,
            "b" => SizeKind::B,
            other => {
                return Err(Fail(format!(
                    "distribution kind `{other}`: expected `a` or `b`"
                )))
            }
        };
        Some(SizeDistribution {
            kind,
            mean_radius: get_attr::<f64>(&d, "mean_radius")?,
            ratio: get_attr::<f64>(&d, "ratio")?,
        })
    } else {
        None
    };

    let (mut walls, mut contacts) = (WallSet::default(), Vec::new());
    if file.link_exists("walls") {
        let w = file.group("walls")?;
        let count = read_vec::<f64>(&w, "position", None)?.len();
        let position = read_vec::<f64>(&w, "position", Some(count))?;
        let stress = read_vec::<f64>(&w, "stress", Some(count))?;
        walls.walls = read_walls(&w, count)?
            .iter()
            .zip(position.iter().zip(&stress))
            .map(|(h, (&p, &s))| h.wall([p, 0.0, 0.0], s))
            .collect();
        let c = file.group("contacts")?;
        let pair = read_rows::<i64, 2>(&c, "pair", None)?;
        let m = pair.len();
        let shear = read_vec::<f64>(&c, "shear_force", Some(m))?;
        let slip = read_vec::<f64>(&c, "shear_displacement", Some(m))?;
        for (k, [a, b]) in pair.into_iter().enumerate() {
            contacts.push(ContactHistory {
                pair: decode_pair(a, b, n, count)?,
                shear_force: shear[k],
                shear_displacement: slip[k],
            });
        }
    }

    Ok(SampleFile {
        walls,
        contacts,
        grains,
        region,
        distribution,
        seed: get_attr::<u64>(file, "seed")?,
        description: get_str_attr(file, "description")?,
        stress: get_attr::<f64>(file, "stress")?,
        contacts_per_grain: get_attr::<f64>(file, "contacts_per_grain")?,
        bonds,
    })
}

/// The region's dimensions as (attribute name, value).
fn region_dimensions(region: &Region) -> [(&'static str, f64); 2] {
    match *region {
        Region::Rectangle { width, height } => [("width", width), ("height", height)],
        Region::Annulus {
            inner_radius,
            outer_radius,
        } => [
            ("inner_radius", inner_radius),
            ("outer_radius", outer_radius),
        ],
        Region::Beam { length, height } => [("length", length), ("height", height)],
    }
}

// ---------------------------------------------------------------------------------------
// Opening and errors (as in `output::hdf5_file`).

/// Open a sample file the user named: missing, a directory, not HDF5, or an HDF5 file that
/// is not a sample are all input errors.
fn open_existing(path: &Path) -> Result<File, Error> {
    if !path.exists() {
        return Err(input_error(path, "no such file"));
    }
    if path.is_dir() {
        return Err(input_error(path, "is a directory, not a sample file"));
    }
    let file = File::open(path)
        .map_err(|e| input_error(path, format!("cannot be opened as an HDF5 file: {e}")))?;
    require_format(file, path, FORMAT, "sample")
}

// ---------------------------------------------------------------------------------------
// Small helpers.
