//! Sprinkling: random, non-overlapping places for grains at a fraction of their size.
//!
//! The thesis fills its sample by 'sprinkling' the grains at 1% of their final size and
//! blowing them up afterwards: at that size random places almost never clash, and the
//! blowing up (by the solver) makes the contacts. Each grain gets uniform random positions
//! until its scaled disc lies inside the region and clear of the scaled discs placed
//! before it; a cell grid keeps that check to the few grains nearby.

use rand::{Rng, SeedableRng};

use super::SampleError;
use crate::geometry::GrainSet;

/// Positions tried for one grain before [`sprinkle`] gives up on it.
pub const MAX_TRIES: usize = 100_000;

/// The space the grains are sprinkled into.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Region {
    /// The rectangle from (0, 0) to (`width`, `height`) (m): biaxial and simple shear tests.
    Rectangle {
        /// Extent in x (m).
        width: f64,
        /// Extent in y (m).
        height: f64,
    },
    /// The ring between two circles centred at (0, 0) (m): the thick-walled cylinder test.
    Annulus {
        /// Radius of the hole (m); 0 for a full disc.
        inner_radius: f64,
        /// Outer radius (m).
        outer_radius: f64,
    },
    /// The rectangle from (0, 0) to (`length`, `height`) (m), long in x: the three-point
    /// bend test, which puts supports under it. Kept apart from `Rectangle` for that.
    Beam {
        /// Extent in x (m).
        length: f64,
        /// Extent in y (m).
        height: f64,
    },
}

impl Region {
    /// `"rectangle"`, `"annulus"` or `"beam"`, as in sample files.
    pub fn shape(&self) -> &'static str {
        match self {
            Region::Rectangle { .. } => "rectangle",
            Region::Annulus { .. } => "annulus",
            Region::Beam { .. } => "beam",
        }
    }

    /// Whether the dimensions are usable: finite, lengths > 0, `0 <= inner < outer`.
    pub fn check(&self) -> Result<(), SampleError> {
        let bad = |what: &str, v: f64, need: &str| {
            Err(SampleError::Region(format!(
                "the {} {what} must be {need}, not {v}",
                self.shape()
            )))
        };
        match *self {
            Region::Rectangle {
                width: a,
                height: b,
            }
            | Region::Beam {
                length: a,
                height: b,
            } => {
                let first = if matches!(self, Region::Beam { .. }) {
                    "length"
                } else {
                    "width"
                };
                if !(a.is_finite() && a > 0.0) {
                    return bad(first, a, "a finite number > 0");
                }
                if !(b.is_finite() && b > 0.0) {
                    return bad("height", b, "a finite number > 0");
                }
            }
            Region::Annulus {
                inner_radius,
                outer_radius,
            } => {
                if !(outer_radius.is_finite() && outer_radius > 0.0) {
                    return bad("outer radius", outer_radius, "a finite number > 0");
                }
                if !(inner_radius.is_finite() && (0.0..outer_radius).contains(&inner_radius)) {
                    return bad(
                        "inner radius",
                        inner_radius,
                        "a finite number >= 0 and below the outer radius",
                    );
                }
            }
        }
        Ok(())
    }

    /// Area (m^2).
    pub fn area(&self) -> f64 {
        match *self {
            Region::Rectangle {
                width: a,
                height: b,
            }
            | Region::Beam {
                length: a,
                height: b,
            } => a * b,
            Region::Annulus {
                inner_radius: ri,
                outer_radius: ro,
            } => std::f64::consts::PI * (ro * ro - ri * ri),
        }
    }

    /// Whether a disc of radius `margin` (m) centred at `point` lies inside the region
    /// (touching its boundary counts as inside).
    pub fn contains(&self, point: [f64; 2], margin: f64) -> bool {
        let [x, y] = point;
        match *self {
            Region::Rectangle {
                width: a,
                height: b,
            }
            | Region::Beam {
                length: a,
                height: b,
            } => x - margin >= 0.0 && x + margin <= a && y - margin >= 0.0 && y + margin <= b,
            Region::Annulus {
                inner_radius: ri,
                outer_radius: ro,
            } => {
                let d2 = x * x + y * y;
                let (lo, hi) = (ri + margin, ro - margin);
                hi >= 0.0 && d2 <= hi * hi && (lo <= 0.0 || d2 >= lo * lo)
            }
        }
    }

    /// Smallest axis-aligned box around the region: `[xmin, ymin, xmax, ymax]` (m).
    pub fn bounding_box(&self) -> [f64; 4] {
        match *self {
            Region::Rectangle {
                width: a,
                height: b,
            }
            | Region::Beam {
                length: a,
                height: b,
            } => [0.0, 0.0, a, b],
            Region::Annulus {
                outer_radius: ro, ..
            } => [-ro, -ro, ro, ro],
        }
    }

    /// The same shape scaled to `area` (m^2): sizes a region for the grains it is to hold,
    /// e.g. `area = pi sum(r^2) / solid_fraction`.
    pub fn with_area(&self, area: f64) -> Region {
        let k = (area / self.area()).sqrt();
        match *self {
            Region::Rectangle { width, height } => Region::Rectangle {
                width: k * width,
                height: k * height,
            },
            Region::Annulus {
                inner_radius,
                outer_radius,
            } => Region::Annulus {
                inner_radius: k * inner_radius,
                outer_radius: k * outer_radius,
            },
            Region::Beam { length, height } => Region::Beam {
                length: k * length,
                height: k * height,
            },
        }
    }

    /// Whether a disc of radius `s` fits in at all.
    fn fits(&self, s: f64) -> bool {
        match *self {
            Region::Rectangle {
                width: a,
                height: b,
            }
            | Region::Beam {
                length: a,
                height: b,
            } => 2.0 * s <= a && 2.0 * s <= b,
            Region::Annulus {
                inner_radius: ri,
                outer_radius: ro,
            } => ri + 2.0 * s <= ro,
        }
    }

    /// A uniform random point at which a disc of radius `s` may lie: the box shrunk by
    /// `s` (only the annulus then needs the [`Region::contains`] check, which the caller
    /// makes). Two numbers from `rng`, basic arithmetic only.
    fn candidate<R: Rng + ?Sized>(&self, s: f64, rng: &mut R) -> [f64; 2] {
        let [x0, y0, x1, y1] = self.bounding_box();
        let (u, v) = (rng.random::<f64>(), rng.random::<f64>());
        [
            (x0 + s) + u * ((x1 - x0) - 2.0 * s),
            (y0 + s) + v * ((y1 - y0) - 2.0 * s),
        ]
    }
}

/// Places each grain at a random position in `region`, its radius scaled by `fraction`,
/// such that no scaled disc overlaps another or sticks out of the region. Grains are placed
/// in order from one `ChaCha8Rng` stream of `seed`, so the result depends on the seed only.
///
/// The returned grains have the final radii (`radii`, not scaled); only the scaled discs
/// are guaranteed clear of each other. A grain that finds no place in [`MAX_TRIES`] tries
/// (the fraction is too large for the region) is an error, not a longer wait.
pub fn sprinkle(
    region: &Region,
    radii: &[f64],
    fraction: f64,
    seed: u64,
) -> Result<GrainSet, SampleError> {
    region.check()?;
    if !(fraction.is_finite() && fraction > 0.0 && fraction <= 1.0) {
        return Err(SampleError::Fraction(fraction));
    }
    let mut s_max = 0.0f64;
    for (index, &r) in radii.iter().enumerate() {
        if !(r.is_finite() && r > 0.0) {
            return Err(SampleError::Radius { index, value: r });
        }
        let s = fraction * r;
        if !region.fits(s) {
            return Err(SampleError::TooLarge { index, radius: s });
        }
        s_max = s_max.max(s);
    }

    let mut grid = Grid::new(region.bounding_box(), 2.0 * s_max, radii.len());
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut position: Vec<[f64; 2]> = Vec::with_capacity(radii.len());
    let mut scaled: Vec<f64> = Vec::with_capacity(radii.len());
    for (index, &r) in radii.iter().enumerate() {
        let s = fraction * r;
        let mut placed = false;
        for _ in 0..MAX_TRIES {
            let p = region.candidate(s, &mut rng);
            if region.contains(p, s) && grid.is_clear(p, s, &position, &scaled) {
                grid.insert(p, index);
                position.push(p);
                scaled.push(s);
                placed = true;
                break;
            }
        }
        if !placed {
            return Err(SampleError::NoRoom {
                index,
                total: radii.len(),
                tries: MAX_TRIES,
            });
        }
    }
    Ok(GrainSet::new(position, radii.to_vec()))
}

/// Square cells at least as wide as the largest scaled diameter, so that a disc can only
/// overlap discs whose centres are in its own cell or the eight around it. Each cell holds
/// a linked list of grain indices (`head` per cell, `next` per grain).
struct Grid {
    origin: [f64; 2],
    cell: f64,
    nx: usize,
    ny: usize,
    head: Vec<usize>,
    next: Vec<usize>,
}

const EMPTY: usize = usize::MAX;

impl Grid {
    fn new(bbox: [f64; 4], min_cell: f64, n: usize) -> Grid {
        let (w, h) = (bbox[2] - bbox[0], bbox[3] - bbox[1]);
        // About one grain per cell, never narrower than the largest scaled diameter (with a
        // little to spare, so rounding in `cell_of` cannot hide a neighbour two cells away).
        let mut cell = (min_cell * (1.0 + 1e-9)).max((w * h / n.max(1) as f64).sqrt());
        let count = |c: f64| ((w / c).ceil().max(1.0), (h / c).ceil().max(1.0));
        // A very long, thin region can still ask for too many cells: widen them.
        let limit = (4 * n + 1024) as f64;
        let (cx, cy) = loop {
            let (cx, cy) = count(cell);
            if cx * cy <= limit {
                break (cx, cy);
            }
            cell *= 2.0;
        };
        let (nx, ny) = (cx as usize, cy as usize);
        Grid {
            origin: [bbox[0], bbox[1]],
            cell,
            nx,
            ny,
            head: vec![EMPTY; nx * ny],
            next: Vec::with_capacity(n),
        }
    }

    /// The cell column and row of a point, clamped to the grid.
    fn cell_of(&self, p: [f64; 2]) -> (usize, usize) {
        let at = |v: f64, o: f64, n: usize| (((v - o) / self.cell).max(0.0) as usize).min(n - 1);
        (
            at(p[0], self.origin[0], self.nx),
            at(p[1], self.origin[1], self.ny),
        )
    }

    /// Grain `index` (the next one, in order) at `p`.
    fn insert(&mut self, p: [f64; 2], index: usize) {
        let (i, j) = self.cell_of(p);
        let c = j * self.nx + i;
        debug_assert_eq!(index, self.next.len());
        self.next.push(self.head[c]);
        self.head[c] = index;
    }

    /// Whether a disc of radius `s` at `p` overlaps none of the discs placed so far.
    fn is_clear(&self, p: [f64; 2], s: f64, position: &[[f64; 2]], scaled: &[f64]) -> bool {
        let (i, j) = self.cell_of(p);
        for cj in j.saturating_sub(1)..(j + 2).min(self.ny) {
            for ci in i.saturating_sub(1)..(i + 2).min(self.nx) {
                let mut k = self.head[cj * self.nx + ci];
                while k != EMPTY {
                    let q = position[k];
                    let (dx, dy) = (q[0] - p[0], q[1] - p[1]);
                    let reach = s + scaled[k];
                    if dx * dx + dy * dy < reach * reach {
                        return false;
                    }
                    k = self.next[k];
                }
            }
        }
        true
    }
}
