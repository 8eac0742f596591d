//! Sample preparation (thesis 3.1.2 and appendix 4): grain radii drawn from a size
//! distribution, sprinkled at a fraction of their size into a region, and the prepared
//! sample saved so that many tests can start from the same one.
//!
//! The thesis sprinkles the grains at 1% of their final size and then 'blows them up' until
//! the sample carries the wanted stress. This module does the first part and the file; the
//! blowing up is a load program of the solver:
//!
//! 1. [`SizeDistribution::radii`]: the final radii, type A (eqs. A.3-A.6) or B (A.7-A.8);
//! 2. [`sprinkle`]: a position for each grain, its scaled disc inside the [`Region`] and
//!    clear of the others;
//! 3. [`write_sample`] / [`read_sample`]: the prepared state in HDF5, loaded by a scene with
//!    `[grains] sample = "x.h5"`.
//!
//! Everything random comes from one `ChaCha8Rng` stream per call and uses only IEEE basic
//! arithmetic, so a seed gives the same sample on any machine.

mod distribution;
mod file;
pub mod grow;
pub mod prepare;
mod sprinkle;

pub use distribution::{SizeDistribution, SizeKind};
pub use file::{
    read_csv, read_sample, write_csv, write_sample, ContactHistory, SampleFile, FORMAT,
    FORMAT_VERSION,
};
pub use sprinkle::{sprinkle, Region, MAX_TRIES};

/// Why a distribution, a region or a sprinkling is not possible.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SampleError {
    /// The size distribution's parameters are out of range.
    #[error("invalid grain size distribution: {0}")]
    Distribution(String),
    /// The region's dimensions are out of range.
    #[error("invalid region: {0}")]
    Region(String),
    /// A radius is not a finite number > 0.
    #[error("radius {index} is {value}: radii must be finite numbers > 0")]
    Radius {
        /// The grain.
        index: usize,
        /// Its radius (m).
        value: f64,
    },
    /// The size fraction is not in (0, 1].
    #[error("the size fraction must be in (0, 1], not {0}")]
    Fraction(f64),
    /// A grain is too large for the region even on its own.
    #[error(
        "grain {index} (radius {radius:e} m at the size fraction) does not fit into the region \
         at all: sprinkle at a smaller fraction or into a larger region"
    )]
    TooLarge {
        /// The grain.
        index: usize,
        /// Its scaled radius (m).
        radius: f64,
    },
    /// No free place was found for a grain.
    #[error(
        "no room for grain {index} of {total} after {tries} tries: sprinkle at a smaller \
         fraction or into a larger region"
    )]
    NoRoom {
        /// The grain (the grains before it are placed).
        index: usize,
        /// Number of grains asked for.
        total: usize,
        /// Positions tried for it.
        tries: usize,
    },
}
