//! The thick-walled cylinder test's failure (thesis 4.4.2): the radial pressure at which the
//! first bonds break, at which the cylinder fails locally (1% of the bonds in the borehole
//! region broken), at which the first cluster of grains breaks out of the borehole's
//! surface (the functional failure, at a much higher pressure), and the last at which the
//! sample was found in equilibrium; the grains broken out against the pressure; beside them
//! the Mohr-Coulomb predictions of eqs. 34-37 with `c'` and `phi'` of eq. A.95.
//!
//! The borehole region is the ring next to the borehole that holds a tenth of the cylinder's
//! area, where the thesis sees the cracks: `r^2 <= a^2 + (b^2 - a^2) / 10`, with `a` and `b`
//! the innermost and outermost grain edges at the start.

use std::fmt::Write as _;
use std::path::Path;

use super::significant;
use crate::geometry::{GrainSet, MembraneShape, Side};
use crate::measure::ring_stresses;
use crate::output::{read_increments, read_mechanism, read_state};
use crate::scene::{parse_scene, LawKind};
use crate::state::Breakout;
use crate::Error;

/// Share of the cylinder's area that is the borehole region.
const REGION_SHARE: f64 = 0.1;

/// Share of the borehole region's bonds broken at local failure.
const LOCAL_FAILURE: f64 = 0.01;

/// One written increment of a cylinder test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CylinderRow {
    /// The increment.
    pub increment: usize,
    /// Radial pressure on the outer membrane (Pa).
    pub pressure: f64,
    /// Bonds broken so far, in the whole sample.
    pub broken: usize,
    /// Bonds broken so far in the borehole region.
    pub broken_in_region: usize,
    /// Bonds broken so far whose grains lie within 45 degrees of the radial direction of
    /// each other: the bonds across cracks that run parallel to the borehole's surface.
    pub broken_across_radius: usize,
    /// Grains broken out of the sample so far.
    pub broken_out: usize,
}

/// A cluster of grains that broke out of the cylinder ([`crate::state::Breakout`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CylinderBreakout {
    /// The increment it broke out in.
    pub increment: usize,
    /// The radial pressure it broke out at: the last carried with it in place (Pa).
    pub pressure: f64,
    /// Its grains.
    pub grains: usize,
    /// Bonds between it and the sample that broke as it was taken out.
    pub bonds_broken: usize,
    /// Whether it is debris, a rattler squeezed out, not the wall breaking
    /// ([`Breakout::debris`]).
    pub debris: bool,
}

impl CylinderBreakout {
    /// `breakout`, its pressure that of membrane `ring`.
    fn of(breakout: &Breakout, ring: usize) -> Self {
        CylinderBreakout {
            increment: breakout.increment,
            pressure: breakout.pressure[ring],
            grains: breakout.grains.len(),
            bonds_broken: breakout.bonds_broken,
            debris: breakout.debris,
        }
    }
}

/// What eqs. 34-37 predict for the cylinder.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CylinderPrediction {
    /// `c'` (Pa) and `phi'` (degrees) of eq. A.95.
    pub cohesion: f64,
    /// See `cohesion`.
    pub friction_angle: f64,
    /// Radial pressure at which the borehole's surface fails, eqs. 34 and 36 (Pa).
    pub surface: f64,
    /// Radial pressure at which failure starts one mean diameter in, where the lateral
    /// contacts are, eq. 37 (Pa).
    pub one_diameter_in: f64,
}

/// The elastic stage's stresses against Lamé's (eq. A.113): in rings three mean diameters
/// wide, from two diameters off the borehole's surface to two off the outer edge, the radial
/// and tangential stress from the contact forces (eq. A.41) at the last written increment
/// with no bond broken, over the outer pressure then, beside eq. A.113 for that pressure
/// outside and none in the borehole: `sigma_rr / p = B (1 - a^2/r^2)`,
/// `sigma_tt / p = B (1 + a^2/r^2)`, `B = b^2 / (b^2 - a^2)`. The start, isotropic at the
/// prepared stress, is Lamé's for that stress on both sides; the plug taken away and the
/// load raised elastically, the sum is Lamé's with the borehole free.
#[derive(Debug, Clone, PartialEq)]
pub struct LameProfile {
    /// The increment measured.
    pub increment: usize,
    /// Outer pressure at it (Pa).
    pub pressure: f64,
    /// Per ring: mid radius (m), `sigma_rr / p` measured and by eq. A.113, `sigma_tt / p`
    /// measured and by eq. A.113.
    pub rings: Vec<[f64; 5]>,
}

impl LameProfile {
    /// Largest relative difference from eq. A.113, radial and tangential.
    pub fn largest_difference(&self) -> [f64; 2] {
        self.rings.iter().fold([0.0f64; 2], |m, r| {
            [
                m[0].max((r[1] / r[2] - 1.0).abs()),
                m[1].max((r[3] / r[4] - 1.0).abs()),
            ]
        })
    }
}

/// The failure of a cylinder test, read from its result file.
#[derive(Debug, Clone, PartialEq)]
pub struct CylinderFailure {
    /// Borehole radius `a` and outer radius `b` at the start (m).
    pub radii: [f64; 2],
    /// Outer radius of the borehole region (m).
    pub region_radius: f64,
    /// Mean grain diameter (m).
    pub mean_diameter: f64,
    /// Bonds in the borehole region at the start.
    pub bonds_in_region: usize,
    /// Every written increment.
    pub rows: Vec<CylinderRow>,
    /// Every breakout, in order, as the last written increment records them.
    pub breakouts: Vec<CylinderBreakout>,
    /// The predictions, where the scene's material has them (bonded linear contacts, depth
    /// equal to the mean diameter as appendix 7 takes it).
    pub prediction: Option<CylinderPrediction>,
    /// The elastic stage against eq. A.113, when an increment after the first is written
    /// before any bond broke.
    pub lame: Option<LameProfile>,
    /// The grains carried on and the pressure carried when the test ended on no equilibrium
    /// near after the last written increment: the cylinder failing as a whole (a mechanism
    /// too large to be taken out as a breakout), at the highest pressure found in
    /// equilibrium.
    pub mechanism: Option<(usize, f64)>,
}

impl CylinderFailure {
    /// Pressure of the first written increment at which `broken` holds.
    fn first(&self, reached: impl Fn(&CylinderRow) -> bool) -> Option<f64> {
        self.rows.iter().find(|r| reached(r)).map(|r| r.pressure)
    }

    /// Pressure at which the first bond broke (the first written increment with one).
    pub fn first_break(&self) -> Option<f64> {
        self.first(|r| r.broken > 0)
    }

    /// Pressure at local failure: 1% of the borehole region's bonds broken.
    pub fn local_failure(&self) -> Option<f64> {
        let bonds = self.bonds_in_region as f64;
        self.first(|r| r.broken_in_region as f64 >= LOCAL_FAILURE * bonds)
    }

    /// Pressure at which the first cluster of grains broke out of the borehole's surface
    /// (debris aside).
    pub fn first_breakout(&self) -> Option<f64> {
        self.breakouts
            .iter()
            .find(|b| !b.debris)
            .map(|b| b.pressure)
    }

    /// Pressure at which the borehole lost its function: the first breakout, else the
    /// failure as a whole that ended the test.
    pub fn functional_failure(&self) -> Option<f64> {
        self.first_breakout()
            .or(self.mechanism.map(|(_, pressure)| pressure))
    }

    /// The summary as (name, value, unit) rows.
    pub fn summary(&self) -> Vec<(String, f64, &'static str)> {
        let nan = f64::NAN;
        let mut rows = vec![
            ("borehole radius a".into(), self.radii[0], "m"),
            ("outer radius b".into(), self.radii[1], "m"),
            (
                "a / mean diameter".into(),
                self.radii[0] / self.mean_diameter,
                "-",
            ),
            (
                "borehole region: outer radius".into(),
                self.region_radius,
                "m",
            ),
            (
                "bonds in the borehole region".into(),
                self.bonds_in_region as f64,
                "-",
            ),
            (
                "pressure at the first broken bond".into(),
                self.first_break().unwrap_or(nan),
                "Pa",
            ),
            (
                "pressure at local failure (1% of the region's bonds)".into(),
                self.local_failure().unwrap_or(nan),
                "Pa",
            ),
            (
                "pressure at the first breakout".into(),
                self.first_breakout().unwrap_or(nan),
                "Pa",
            ),
            (
                "pressure at functional failure (the first breakout, else failure as a whole)"
                    .into(),
                self.functional_failure().unwrap_or(nan),
                "Pa",
            ),
            (
                "grains broken out".into(),
                self.breakouts.iter().map(|b| b.grains).sum::<usize>() as f64,
                "-",
            ),
            (
                "pressure at the last increment on file".into(),
                self.rows.last().map_or(nan, |r| r.pressure),
                "Pa",
            ),
            (
                "grains carried on in a failure as a whole (no equilibrium near)".into(),
                self.mechanism.map_or(0.0, |(grains, _)| grains as f64),
                "-",
            ),
        ];
        if let Some(p) = &self.prediction {
            rows.extend([
                ("c' (eq. A.95)".into(), p.cohesion, "Pa"),
                ("phi' (eq. A.95)".into(), p.friction_angle, "deg"),
                (
                    "failure at the surface predicted (eq. 36)".into(),
                    p.surface,
                    "Pa",
                ),
                (
                    "failure one diameter in predicted (eq. 37)".into(),
                    p.one_diameter_in,
                    "Pa",
                ),
            ]);
        }
        rows
    }

    /// The summary and the increments as markdown.
    pub fn markdown(&self) -> String {
        let mut text = String::from("| parameter | value | unit |\n|---|---|---|\n");
        for (name, value, unit) in self.summary() {
            let _ = writeln!(text, "| {name} | {} | {unit} |", significant(value));
        }
        if !self.breakouts.is_empty() {
            text.push_str(
                "\nClusters broken out of the borehole's surface (debris: rattlers squeezed out, no functional failure):\n\n| breakout | increment | pressure [Pa] | grains | bonds broken with it | grains broken out so far |\n|---|---|---|---|---|---|\n",
            );
            let mut so_far = 0;
            for (k, b) in self.breakouts.iter().enumerate() {
                so_far += b.grains;
                let debris = if b.debris { " (debris)" } else { "" };
                let _ = writeln!(
                    text,
                    "| {}{debris} | {} | {} | {} | {} | {so_far} |",
                    k + 1,
                    b.increment,
                    significant(b.pressure),
                    b.grains,
                    b.bonds_broken
                );
            }
        }
        text.push_str(
            "\n| increment | pressure [Pa] | bonds broken | in the borehole region | share of the region's bonds | across the radius (cracks parallel to the surface) | grains broken out |\n|---|---|---|---|---|---|---|\n",
        );
        for r in &self.rows {
            let _ = writeln!(
                text,
                "| {} | {} | {} | {} | {} | {} | {} |",
                r.increment,
                significant(r.pressure),
                r.broken,
                r.broken_in_region,
                significant(r.broken_in_region as f64 / self.bonds_in_region.max(1) as f64),
                r.broken_across_radius,
                r.broken_out
            );
        }
        if let Some(lame) = &self.lame {
            let [rr, tt] = lame.largest_difference();
            let _ = write!(
                text,
                "\nThe elastic stage at increment {} (outer pressure {} Pa, no bond broken) \
                 against eq. A.113 with the borehole free; largest differences: radial {:.1}%, \
                 tangential {:.1}%.\n\n| r / a | sigma_rr / p | eq. A.113 | sigma_tt / p | eq. A.113 |\n|---|---|---|---|---|\n",
                lame.increment,
                significant(lame.pressure),
                100.0 * rr,
                100.0 * tt
            );
            for r in &lame.rings {
                let _ = writeln!(
                    text,
                    "| {:.2} | {:.3} | {:.3} | {:.3} | {:.3} |",
                    r[0] / self.radii[0],
                    r[1],
                    r[2],
                    r[3],
                    r[4]
                );
            }
        }
        text
    }

    /// The increments as CSV.
    pub fn csv(&self) -> String {
        let mut text = String::from(
            "increment,pressure,broken,broken_in_region,share_in_region,broken_across_radius,broken_out\n",
        );
        for r in &self.rows {
            let _ = writeln!(
                text,
                "{},{:e},{},{},{:e},{},{}",
                r.increment,
                r.pressure,
                r.broken,
                r.broken_in_region,
                r.broken_in_region as f64 / self.bonds_in_region.max(1) as f64,
                r.broken_across_radius,
                r.broken_out
            );
        }
        text
    }
}

/// Eqs. 34-37 for a cylinder of radii `a`, `b` and mean diameter `d`, with `c'` and `phi'`
/// (radians): the tangential stress at the surface at failure, `2 c' cos / (1 - sin)` (eq.
/// 34, `sigma_3 = 0` there), the radial pressure that makes it (eq. 36), and that one
/// diameter in (eq. 37).
pub fn predict_cylinder(a: f64, b: f64, d: f64, cohesion: f64, phi: f64) -> CylinderPrediction {
    let (sin, cos) = phi.sin_cos();
    let tangential = 2.0 * cohesion * cos / (1.0 - sin);
    let surface = 0.5 * tangential * (1.0 - (a / b).powi(2));
    CylinderPrediction {
        cohesion,
        friction_angle: phi.to_degrees(),
        surface,
        one_diameter_in: surface * (1.0 - sin) / (1.0 - sin - 2.0 * d / a),
    }
}

/// Eq. A.113 for a cylinder of radii `a`, `b` under an outer pressure with the borehole
/// free: `[sigma_rr, sigma_tt]` at radius `r` over the pressure.
pub fn lame_free_borehole(a: f64, b: f64, r: f64) -> [f64; 2] {
    let outer = b * b / (b * b - a * a);
    let q = (a / r).powi(2);
    [outer * (1.0 - q), outer * (1.0 + q)]
}

/// The contact point between grains `i` and `j`, from `center`.
fn contact_point(grains: &GrainSet, i: usize, j: usize, center: [f64; 2]) -> [f64; 2] {
    let (p, q) = (grains.position[i], grains.position[j]);
    let t = grains.radius[i] / (grains.radius[i] + grains.radius[j]);
    [
        p[0] + t * (q[0] - p[0]) - center[0],
        p[1] + t * (q[1] - p[1]) - center[1],
    ]
}

/// Distance from `center` of the contact point between grains `i` and `j`.
fn contact_radius(grains: &GrainSet, i: usize, j: usize, center: [f64; 2]) -> f64 {
    let at = contact_point(grains, i, j, center);
    at[0].hypot(at[1])
}

/// Whether the line between grains `i` and `j` lies within 45 degrees of the radial
/// direction from `center` through their contact: a crack between them runs along the
/// circle about `center`.
fn across_radius(grains: &GrainSet, i: usize, j: usize, center: [f64; 2]) -> bool {
    let (p, q) = (grains.position[i], grains.position[j]);
    let at = contact_point(grains, i, j, center);
    let line = [q[0] - p[0], q[1] - p[1]];
    let cos = (at[0] * line[0] + at[1] * line[1]) / (at[0].hypot(at[1]) * line[0].hypot(line[1]));
    cos.abs() >= std::f64::consts::FRAC_1_SQRT_2
}

/// The failure of the cylinder test in `result`: `None` when the run is no cylinder test
/// (its sample is not loaded by a ring membrane).
pub fn cylinder_failure(result: &Path) -> Result<Option<CylinderFailure>, Error> {
    let increments = read_increments(result)?;
    let Some(&first) = increments.first() else {
        return Ok(None);
    };
    let (header, start) = read_state(result, first)?;
    let Some((ring, center)) =
        header
            .membranes
            .iter()
            .enumerate()
            .find_map(|(k, m)| match m.shape {
                MembraneShape::Ring { center } => Some((k, center)),
                MembraneShape::Side { .. } => None,
            })
    else {
        return Ok(None);
    };
    let grains = &start.grains;
    if grains.is_empty() {
        return Ok(None);
    }
    let distance =
        |g: usize| (grains.position[g][0] - center[0]).hypot(grains.position[g][1] - center[1]);
    let a = (0..grains.len())
        .map(|g| distance(g) - grains.radius[g])
        .fold(f64::INFINITY, f64::min);
    let b = (0..grains.len())
        .map(|g| distance(g) + grains.radius[g])
        .fold(0.0, f64::max);
    let region_radius = (a * a + REGION_SHARE * (b * b - a * a)).sqrt();
    let in_region = |grains: &GrainSet, i: usize, j: usize| {
        contact_radius(grains, i, j, center) <= region_radius
    };
    let bonds = start.contacts.contacts.iter().filter(|c| c.bonded);
    let bonds_in_region = bonds
        .clone()
        .filter(|c| matches!(c.pair.a, Side::Grain(i) if in_region(grains, i, c.pair.b)))
        .count();
    let d = 2.0 * grains.mean_radius();
    let edges: Vec<f64> = (0..)
        .map(|k| a + 2.0 * d + 3.0 * d * k as f64)
        .take_while(|&r| r <= b - 2.0 * d)
        .collect();
    let mut lame = None;
    let mut rows = Vec::with_capacity(increments.len());
    let mut breakouts = Vec::new();
    for &k in &increments {
        let (_, state) = read_state(result, k)?;
        let broken = &state.contacts.broken_bonds;
        breakouts = (state.breakouts.iter())
            .map(|b| CylinderBreakout::of(b, ring))
            .collect();
        rows.push(CylinderRow {
            increment: k,
            pressure: state.membranes[ring].pressure,
            broken: broken.len(),
            broken_in_region: broken
                .iter()
                .filter(
                    |c| matches!(c.pair.a, Side::Grain(i) if in_region(&state.grains, i, c.pair.b)),
                )
                .count(),
            broken_across_radius: broken
                .iter()
                .filter(|c| {
                    matches!(c.pair.a, Side::Grain(i)
                        if across_radius(&state.grains, i, c.pair.b, center))
                })
                .count(),
            broken_out: state.grains_taken_out(),
        });
        let row = rows.last().expect("pushed");
        if k != first && row.broken == 0 && edges.len() >= 2 {
            let p = row.pressure;
            let rings = ring_stresses(&state.grains, &state.contacts, center, &edges, header.depth)
                .into_iter()
                .map(|(r, rr, tt)| {
                    let [lame_rr, lame_tt] = lame_free_borehole(a, b, r);
                    [r, rr / p, lame_rr, tt / p, lame_tt]
                })
                .collect();
            lame = Some(LameProfile {
                increment: k,
                pressure: p,
                rings,
            });
        }
    }
    // Eq. A.95 at the sample's contact density, over the annulus's area at depth D = d.
    let prediction = parse_scene(&header.scene_text, "the result's scene")
        .ok()
        .filter(|s| s.material.law == LawKind::Linear && s.material.bonded)
        .filter(|_| (header.depth / d - 1.0).abs() < 1e-9)
        .map(|s| {
            let contacts = start
                .contacts
                .contacts
                .iter()
                .filter(|c| matches!(c.pair.a, Side::Grain(_)))
                .count() as f64;
            let density = d * d * contacts / (std::f64::consts::PI * (b * b - a * a));
            let cohesion = s.material.cohesion * density / (16.0 * 2f64.sqrt());
            predict_cylinder(a, b, d, cohesion, (1.0f64 / 3.0).asin())
        });
    let last = increments.last().copied();
    let failure = read_mechanism(result)?.filter(|m| Some(m.increment) == last.map(|k| k + 1));
    // Clusters that broke out in the increment that failed after the last one written.
    if let Some(m) = failure
        .as_ref()
        .filter(|m| m.breakouts.len() > breakouts.len())
    {
        breakouts = (m.breakouts.iter())
            .map(|b| CylinderBreakout::of(b, ring))
            .collect();
    }
    let mechanism = failure.and_then(|m| Some((m.grains.len(), *m.membrane_pressure.get(ring)?)));
    Ok(Some(CylinderFailure {
        radii: [a, b],
        region_radius,
        mean_diameter: d,
        bonds_in_region,
        rows,
        breakouts,
        prediction,
        lame,
        mechanism,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eqs_34_to_37_by_hand() {
        // sin phi' = 1/3: cos / (1 - sin) = sqrt(2), so sigma_tt = 2 sqrt(2) c' (eq. 34) and
        // with a/b = 1/3, P_r = sigma_tt / 2 * 8/9 (eq. 36); a = 10 d: 1 - sin - 2 d/a = 7/15,
        // so eq. 37's factor is (2/3) / (7/15) = 10/7.
        let phi = (1.0f64 / 3.0).asin();
        let p = predict_cylinder(1.0, 3.0, 0.1, 1e6, phi);
        let surface = 2f64.sqrt() * 1e6 * 8.0 / 9.0;
        assert!((p.surface / surface - 1.0).abs() < 1e-12);
        assert!((p.one_diameter_in / surface - 10.0 / 7.0).abs() < 1e-12);
    }

    #[test]
    fn lame_with_the_borehole_free_meets_both_boundaries() {
        let (a, b) = (1.0, 3.0);
        // Free surface: no radial stress, the tangential stress 2 b^2 / (b^2 - a^2) times p.
        assert_eq!(lame_free_borehole(a, b, a), [0.0, 2.25]);
        // Outside: the pressure itself radially, and sigma_rr + sigma_tt constant.
        let [rr, tt] = lame_free_borehole(a, b, b);
        assert!((rr - 1.0).abs() < 1e-15);
        let [rr2, tt2] = lame_free_borehole(a, b, 2.0);
        assert!((rr + tt - rr2 - tt2).abs() < 1e-15);
    }

    #[test]
    fn local_failure_is_the_first_increment_with_1_percent_of_the_regions_bonds() {
        let row = |increment, pressure, broken, broken_in_region| CylinderRow {
            increment,
            pressure,
            broken,
            broken_in_region,
            broken_across_radius: 0,
            broken_out: 0,
        };
        let failure = CylinderFailure {
            radii: [1.0, 3.0],
            region_radius: 1.34,
            mean_diameter: 0.1,
            bonds_in_region: 300,
            rows: vec![
                row(1, 1e6, 0, 0),
                row(2, 2e6, 2, 1),
                row(3, 3e6, 5, 2),
                row(4, 4e6, 9, 3),
            ],
            breakouts: Vec::new(),
            prediction: None,
            lame: None,
            mechanism: None,
        };
        assert_eq!(failure.first_break(), Some(2e6));
        assert_eq!(failure.local_failure(), Some(4e6));
        assert_eq!(failure.functional_failure(), None);
        // Failing as a whole past the last increment, with no breakout before, is its
        // functional failure, and no breakout.
        let failed = CylinderFailure {
            mechanism: Some((150, 4.5e6)),
            ..failure
        };
        assert_eq!(failed.functional_failure(), Some(4.5e6));
        assert_eq!(failed.first_breakout(), None);
    }

    #[test]
    fn a_bond_across_the_radius_is_one_a_crack_along_the_circle_parts() {
        use crate::geometry::GrainSet;
        // Two grains on the x axis (radial from the origin), two side by side at x = 2.
        let grains = GrainSet::new(
            vec![[2.0, 0.0], [2.2, 0.0], [2.0, 0.1], [2.0, -0.1]],
            vec![0.1; 4],
        );
        assert!(across_radius(&grains, 0, 1, [0.0, 0.0]));
        assert!(!across_radius(&grains, 2, 3, [0.0, 0.0]));
        // Seen from a centre above them, the first pair is tangential.
        assert!(!across_radius(&grains, 0, 1, [2.1, 5.0]));
    }
}
