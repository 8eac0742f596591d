//! Regions of the plane in which the stress is measured grain by grain (eq. A.40): a
//! rectangle, a circle or a ring about a centre, fixed in space.

use crate::scene::RegionSpec;

/// The shape of a region.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RegionShape {
    /// The axis-parallel rectangle between two corners (m).
    Rectangle {
        /// Lower left corner.
        min: [f64; 2],
        /// Upper right corner.
        max: [f64; 2],
    },
    /// The ring `inner <= |x - center| < outer` (m); a circle has `inner = 0`.
    Ring {
        /// Centre.
        center: [f64; 2],
        /// Inner radius.
        inner: f64,
        /// Outer radius.
        outer: f64,
    },
}

/// A named region: the grains whose centres lie in it make its stress.
#[derive(Debug, Clone, PartialEq)]
pub struct Region {
    /// Name from the scene, used in the result file and the curves.
    pub name: String,
    /// Where it is.
    pub shape: RegionShape,
}

impl Region {
    /// The region of a validated scene entry: a rectangle with `min` and `max`, else a
    /// ring (or circle) about `center`.
    pub fn of_spec(spec: &RegionSpec) -> Region {
        let shape = match (spec.min, spec.max) {
            (Some(min), Some(max)) => RegionShape::Rectangle { min, max },
            _ => RegionShape::Ring {
                center: spec.center.unwrap_or_default(),
                inner: spec.inner_radius.unwrap_or(0.0),
                outer: spec.radius.unwrap_or(0.0),
            },
        };
        Region {
            name: spec.name.clone(),
            shape,
        }
    }

    /// Whether `point` lies in the region (lower edges in, upper edges out, so regions that
    /// tile the plane count every grain once).
    pub fn contains(&self, point: [f64; 2]) -> bool {
        match self.shape {
            RegionShape::Rectangle { min, max } => {
                (min[0]..max[0]).contains(&point[0]) && (min[1]..max[1]).contains(&point[1])
            }
            RegionShape::Ring {
                center,
                inner,
                outer,
            } => {
                let r = (point[0] - center[0]).hypot(point[1] - center[1]);
                (inner..outer).contains(&r)
            }
        }
    }

    /// Area (m^2): the `V / D` of eq. A.40.
    pub fn area(&self) -> f64 {
        match self.shape {
            RegionShape::Rectangle { min, max } => (max[0] - min[0]) * (max[1] - min[1]),
            RegionShape::Ring { inner, outer, .. } => {
                std::f64::consts::PI * (outer * outer - inner * inner)
            }
        }
    }

    /// The shape as a row of five numbers for the result file: kind (0 a rectangle, 1 a
    /// ring), then `min x, min y, max x, max y` or `centre x, centre y, inner, outer`.
    pub fn to_row(&self) -> [f64; 5] {
        match self.shape {
            RegionShape::Rectangle { min, max } => [0.0, min[0], min[1], max[0], max[1]],
            RegionShape::Ring {
                center,
                inner,
                outer,
            } => [1.0, center[0], center[1], inner, outer],
        }
    }

    /// The region of a row written by [`Region::to_row`]; `None` for an unknown kind.
    pub fn from_row(name: String, row: [f64; 5]) -> Option<Region> {
        let shape = if row[0] == 0.0 {
            RegionShape::Rectangle {
                min: [row[1], row[2]],
                max: [row[3], row[4]],
            }
        } else if row[0] == 1.0 {
            RegionShape::Ring {
                center: [row[1], row[2]],
                inner: row[3],
                outer: row[4],
            }
        } else {
            return None;
        };
        Some(Region { name, shape })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ring_contains_and_area() {
        let ring = Region {
            name: "r".into(),
            shape: RegionShape::Ring {
                center: [1.0, 0.0],
                inner: 1.0,
                outer: 2.0,
            },
        };
        assert!(ring.contains([2.5, 0.0]));
        assert!(!ring.contains([1.5, 0.0]));
        assert!(!ring.contains([3.0, 0.0]));
        assert!((ring.area() - 3.0 * std::f64::consts::PI).abs() < 1e-15);
        assert_eq!(Region::from_row("r".into(), ring.to_row()), Some(ring));
    }

    #[test]
    fn rectangles_that_tile_count_a_point_once() {
        let rect = |x0: f64, x1: f64| Region {
            name: "q".into(),
            shape: RegionShape::Rectangle {
                min: [x0, 0.0],
                max: [x1, 1.0],
            },
        };
        let (left, right) = (rect(0.0, 1.0), rect(1.0, 2.0));
        assert!(!left.contains([1.0, 0.5]) && right.contains([1.0, 0.5]));
        assert_eq!(left.area(), 1.0);
    }
}
