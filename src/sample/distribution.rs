//! Grain size distributions of the thesis (appendix 4), each set by the average radius
//! `rbar` and the ratio `M = r_max / r_min`.
//!
//! Type A has a straight sieve curve on a logarithmic scale: the weight of the grains up to
//! `r` grows with `ln r` (eq. A.1), so with the weight `~ r^3` (A.2) the number density goes
//! as `1 / r^4` (A.3) and there are many more small grains than large ones. Type B is
//! uniform in `r` (A.7). Radii are drawn by inverting the cumulative distribution, with
//! basic arithmetic only (see [`SizeDistribution::draw`]).

use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

use super::SampleError;

/// Which of the thesis's two distributions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SizeKind {
    /// Straight sieve curve in `ln r`: density `~ 1 / r^4` (eqs. A.3-A.6).
    A,
    /// Uniform in `r` (eqs. A.7-A.8).
    B,
}

impl SizeKind {
    /// `"a"` or `"b"`, as in scene and sample files.
    pub fn name(self) -> &'static str {
        match self {
            SizeKind::A => "a",
            SizeKind::B => "b",
        }
    }
}

/// A grain size distribution: its kind, the average radius and the ratio `M`.
///
/// The fields are public so the struct can sit in a scene; [`SizeDistribution::new`] or
/// [`SizeDistribution::check`] says whether the values make sense. The other methods assume
/// they do.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SizeDistribution {
    /// Type A or B.
    pub kind: SizeKind,
    /// Average radius `rbar` (m): the mean of the distribution, not its median (eq. A.6).
    pub mean_radius: f64,
    /// `M = r_max / r_min >= 1`; 1 makes all grains equal.
    pub ratio: f64,
}

impl SizeDistribution {
    /// A checked distribution.
    pub fn new(kind: SizeKind, mean_radius: f64, ratio: f64) -> Result<Self, SampleError> {
        let d = SizeDistribution {
            kind,
            mean_radius,
            ratio,
        };
        d.check()?;
        Ok(d)
    }

    /// Whether the parameters are usable: `mean_radius` finite and > 0, `ratio` finite and
    /// >= 1.
    pub fn check(&self) -> Result<(), SampleError> {
        if !(self.mean_radius.is_finite() && self.mean_radius > 0.0) {
            return Err(SampleError::Distribution(format!(
                "the mean radius must be a finite number > 0, not {}",
                self.mean_radius
            )));
        }
        if !(self.ratio.is_finite() && self.ratio >= 1.0) {
            return Err(SampleError::Distribution(format!(
                "the ratio r_max / r_min must be a finite number >= 1, not {}",
                self.ratio
            )));
        }
        Ok(())
    }

    /// Smallest radius `r_min` (m). Type A from eq. A.5,
    /// `rbar = r_max 3 (M^2 - 1) / (2 (M^3 - 1))`, written as
    /// `r_min = rbar 2 (M^2 + M + 1) / (3 M (M + 1))` so that `M = 1` needs no limit; type B
    /// from eq. A.8, `rbar = r_min (M + 1) / 2`.
    pub fn r_min(&self) -> f64 {
        let m = self.ratio;
        match self.kind {
            SizeKind::A => self.mean_radius * (2.0 * (m * m + m + 1.0)) / (3.0 * m * (m + 1.0)),
            SizeKind::B => 2.0 * self.mean_radius / (m + 1.0),
        }
    }

    /// Largest radius `r_max = M r_min` (m).
    pub fn r_max(&self) -> f64 {
        self.ratio * self.r_min()
    }

    /// Probability density of the radius (1/m): type A eq. A.3,
    /// `f = 3 r_min^3 / (r^4 (1 - M^-3))`, type B `1 / (r_max - r_min)`, zero outside
    /// `[r_min, r_max]`. With `M = 1` all mass sits at one radius: infinite there, zero
    /// elsewhere.
    pub fn pdf(&self, r: f64) -> f64 {
        let (lo, hi) = (self.r_min(), self.r_max());
        if !(lo..=hi).contains(&r) {
            return 0.0;
        }
        if hi <= lo {
            return f64::INFINITY;
        }
        match self.kind {
            SizeKind::A => {
                let s = lo / r;
                3.0 * s * s * s / (r * self.one_minus_m3())
            }
            SizeKind::B => 1.0 / (hi - lo),
        }
    }

    /// Fraction of the grains (by number) with a radius up to `r`: type A
    /// `(1 - (r_min / r)^3) / (1 - M^-3)`, type B `(r - r_min) / (r_max - r_min)`.
    pub fn cdf(&self, r: f64) -> f64 {
        let (lo, hi) = (self.r_min(), self.r_max());
        if r < lo {
            return 0.0;
        }
        if r > hi || hi <= lo {
            return 1.0;
        }
        let f = match self.kind {
            SizeKind::A => {
                let s = lo / r;
                (1.0 - s * s * s) / self.one_minus_m3()
            }
            SizeKind::B => (r - lo) / (hi - lo),
        };
        f.clamp(0.0, 1.0)
    }

    /// The radius below which a fraction `p` (in `[0, 1]`) of the grains lies: the inverse
    /// of [`SizeDistribution::cdf`]. Type A is eq. A.4 with `r_min^-3` taken out,
    /// `r = r_min (1 - p (1 - M^-3))^(-1/3)`; type B is eq. A.7. Kept within
    /// `[r_min, r_max]` against rounding.
    pub fn quantile(&self, p: f64) -> f64 {
        let (lo, hi) = (self.r_min(), self.r_max());
        let r = match self.kind {
            SizeKind::A => lo / portable_cbrt(1.0 - p * self.one_minus_m3()),
            SizeKind::B => lo + (hi - lo) * p,
        };
        r.clamp(lo, hi)
    }

    /// The median radius `r_50` by number (m). Type A: `r_min (2 M^3 / (M^3 + 1))^(1/3)`.
    ///
    /// Eq. A.6 of the thesis, `rbar / r_50 = (M + 1) / (2 sqrt(M))`, does not follow from
    /// A.3-A.5 for any reading of `r_50` (by number it gives 1.140 for `M = 4`, by weight,
    /// `r_50 = sqrt(r_min r_max)`, 0.714; A.6 says 1.25); this is the median of A.3 itself.
    pub fn median(&self) -> f64 {
        self.quantile(0.5)
    }

    /// The mean radius from `r_min` and `r_max` (m), integrated analytically: type A
    /// `3 r_min r_max (r_min + r_max) / (2 (r_min^2 + r_min r_max + r_max^2))`, type B
    /// `(r_min + r_max) / 2`. Equal to `mean_radius` up to rounding; a check on A.5 and A.8.
    pub fn mean(&self) -> f64 {
        let (lo, hi) = (self.r_min(), self.r_max());
        match self.kind {
            SizeKind::A => 1.5 * lo * hi * (lo + hi) / (lo * lo + lo * hi + hi * hi),
            SizeKind::B => 0.5 * (lo + hi),
        }
    }

    /// One radius (m): the quantile of a uniform number in `[0, 1)` (eqs. A.4 and A.7).
    pub fn draw<R: Rng + ?Sized>(&self, rng: &mut R) -> f64 {
        self.quantile(rng.random::<f64>())
    }

    /// `n` radii (m) from the `ChaCha8Rng` stream of `seed`: the same on every machine.
    pub fn radii(&self, n: usize, seed: u64) -> Vec<f64> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..n).map(|_| self.draw(&mut rng)).collect()
    }

    /// `1 - M^-3 = (M - 1)(M^2 + M + 1) / M^3`: no cancellation beyond that of `M - 1`
    /// (exact for `M` up to 2).
    fn one_minus_m3(&self) -> f64 {
        let m = self.ratio;
        (m - 1.0) * (m * m + m + 1.0) / (m * m * m)
    }
}

/// Cube root with basic IEEE arithmetic only, so that it rounds the same on every platform
/// (`f64::cbrt` calls the system's libm, whose last bit may differ between machines). The
/// algorithm and constants are those of FreeBSD's and musl's `cbrt` (error below 0.667 ulp):
/// a bit-level first guess, a polynomial to 23 bits, then one Newton step in double.
pub(crate) fn portable_cbrt(x: f64) -> f64 {
    // (1023 - 1023/3 - 0.03306235651) * 2^20, and the same less 54/3 for subnormals.
    const B1: u32 = 715_094_163;
    const B2: u32 = 696_219_795;
    // |1/cbrt(x) - p(x)| < 2^-23.5 on the range of the first guess.
    const P0: f64 = f64::from_bits(0x3ffe_03e6_0f61_e692); // 1.87595182427177
    const P1: f64 = f64::from_bits(0xbffe_28e0_92f0_2420); // -1.8849797954337717
    const P2: f64 = f64::from_bits(0x3ff9_f160_4a49_d6c2); // 1.6214297201053545
    const P3: f64 = f64::from_bits(0xbfe8_44cb_bee7_51d9); // -0.758397934778766
    const P4: f64 = f64::from_bits(0x3fc2_b000_d4e4_edd7); // 0.14599619288661245

    let mut bits = x.to_bits();
    let mut hx = ((bits >> 32) as u32) & 0x7fff_ffff;
    if hx >= 0x7ff0_0000 {
        return x + x; // NaN and infinities
    }
    if hx < 0x0010_0000 {
        // Zero or subnormal: scale by 2^54 to get the exponent.
        bits = (x * f64::from_bits(0x4350_0000_0000_0000)).to_bits();
        hx = ((bits >> 32) as u32) & 0x7fff_ffff;
        if hx == 0 {
            return x;
        }
        hx = hx / 3 + B2;
    } else {
        hx = hx / 3 + B1;
    }
    let mut t = f64::from_bits((bits & (1u64 << 63)) | (u64::from(hx) << 32));

    // To 23 bits with a polynomial in r = t^3 / x.
    let r = (t * t) * (t / x);
    t *= (P0 + r * (P1 + r * P2)) + ((r * r) * r) * (P3 + r * P4);

    // Round t to 21 bits (away from zero) so that t*t is exact below.
    t = f64::from_bits((t.to_bits() + 0x8000_0000) & 0xffff_ffff_c000_0000);

    // One Newton step to 53 bits.
    let s = t * t;
    let r = x / s;
    let w = t + t;
    let r = (r - t) / (w + r);
    t + t * r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn portable_cbrt_matches_the_system_one() {
        for &x in &[
            1.0, 8.0, 27.0, 0.001, 1e-300, 5e-324, 1e300, 0.5, 0.015625, 2.0,
        ] {
            let (a, b) = (portable_cbrt(x), x.cbrt());
            assert!((a - b).abs() <= 2.0 * f64::EPSILON * b, "{x}: {a} {b}");
        }
        assert_eq!(portable_cbrt(8.0), 2.0);
        assert_eq!(portable_cbrt(0.0), 0.0);
        assert_eq!(portable_cbrt(-27.0), -3.0);
        assert!(portable_cbrt(f64::NAN).is_nan());
        let mut x = 1e-3;
        while x < 1e3 {
            let (a, b) = (portable_cbrt(x), x.cbrt());
            assert!((a - b).abs() <= f64::EPSILON * b, "{x}: {a} {b}");
            x *= 1.0137;
        }
    }

    #[test]
    fn equal_grains_when_the_ratio_is_one() {
        for kind in [SizeKind::A, SizeKind::B] {
            let d = SizeDistribution::new(kind, 1e-4, 1.0).unwrap();
            assert_eq!((d.r_min(), d.r_max(), d.mean()), (1e-4, 1e-4, 1e-4));
            assert!(d.radii(10, 1).iter().all(|&r| r == 1e-4));
            assert_eq!((d.cdf(0.99e-4), d.cdf(1e-4)), (0.0, 1.0));
        }
    }

    #[test]
    fn bad_parameters() {
        for (mean, ratio) in [(0.0, 2.0), (-1.0, 2.0), (f64::NAN, 2.0), (1.0, 0.5)] {
            assert!(SizeDistribution::new(SizeKind::A, mean, ratio).is_err());
        }
        assert!(SizeDistribution::new(SizeKind::B, 1.0, f64::INFINITY).is_err());
    }
}
