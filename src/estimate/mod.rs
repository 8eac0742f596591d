//! Macro parameters from the curves of a test (thesis 3.2, appendices 5 and 7): Young's
//! modulus and Poisson's ratio, the friction and dilatancy angles at failure, and `c'`,
//! `phi'` from the peaks of tests at several lateral pressures (eq. A.94). Beside them stand
//! the predictions of appendix 7 from the sample's contact density `n_c/v = d^3 n_c / V`.
//!
//! The estimate is made over one stage, the last of the run: a test starts from its sample's
//! equilibrium, brought to the test's stresses by the stages before. Stresses are the walls'
//! (compression positive), strains those of the walls' gaps since the stage began.

mod cylinder;

pub use cylinder::{
    cylinder_failure, predict_cylinder, CylinderBreakout, CylinderFailure, CylinderPrediction,
    CylinderRow,
};

use std::fmt::Write as _;

use crate::output::curves::{Curves, LoadAxis};
use crate::output::{History, RunHeader};
use crate::scene::{parse_scene, LawKind, Scene};

/// What the walls did during the stage.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TestKind {
    /// One-dimensional compression: the lateral walls held in place.
    Compression,
    /// Biaxial: the lateral stress held while the sample is pushed axially.
    Biaxial,
}

/// The peak of a biaxial test: where the deviator stress was largest.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Peak {
    /// Axial stress `sigma_1` there (Pa).
    pub axial_stress: f64,
    /// Lateral stress `sigma_3` there (Pa).
    pub lateral_stress: f64,
    /// Axial strain since the stage began.
    pub strain: f64,
    /// Whether the deviator fell after it; if not, the test ended before failure and the peak
    /// is a lower bound.
    pub reached: bool,
    /// Mobilised friction angle `phi'` (degrees): `sin phi' = (s1 - s3) / (s1 + s3)` (eq. 20),
    /// the friction angle of a material without cohesion; with cohesion, `c'` and `phi'`
    /// come from several tests ([`mohr_coulomb`]).
    pub friction_angle: f64,
}

/// What appendix 7 predicts for this sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prediction {
    /// Young's modulus (Pa): for sand eq. A.89 (`E50` at `sigma_0 = 1.5 sigma_3`) in a
    /// biaxial test, eq. 24 (at the stage's mean vertical stress) in compression; eq. A.83
    /// for cemented grains.
    pub young: f64,
    /// The equation `young` comes from.
    pub equation: &'static str,
    /// Poisson's ratio of grains that do not rotate, eq. A.83 (cemented grains):
    /// `nu = -(kappa - 1) / (kappa + 1)`.
    pub poisson: Option<f64>,
    /// `E / (1 - nu)` from isotropic compression (Pa), eq. A.85 (cemented grains): with the
    /// measured `nu` it predicts `E` where the grains rotate.
    pub young_isotropic: Option<f64>,
    /// Cohesion `c'` (Pa), eq. A.95 (bonded grains).
    pub cohesion: Option<f64>,
    /// Friction angle `phi'` (degrees), eq. A.95 (bonded grains): `sin phi' = 1/3`.
    pub friction_angle: Option<f64>,
}

/// The macro parameters of one test.
#[derive(Debug, Clone, PartialEq)]
pub struct Parameters {
    /// What the walls did.
    pub kind: TestKind,
    /// The stage estimated (0-based).
    pub stage: usize,
    /// Lateral stress at the stage's start (Pa).
    pub lateral_stress: f64,
    /// Axial stress at the stage's start (Pa).
    pub axial_stress: f64,
    /// Contact density `n_c/v = d^3 n_c / V` at the stage's start (eq. A.83).
    pub contact_density: f64,
    /// Young's modulus (Pa): the secant `E50` to half the peak deviator (biaxial), or from
    /// eq. A.9 with no lateral strain, `E = (1 - nu^2) ds_a / de_a` (compression).
    pub young: f64,
    /// Poisson's ratio at the start: `-de_l / de_a` up to half the peak (biaxial), or from
    /// eq. A.9 with no lateral strain, `nu = ds_l / ds_a` (compression).
    pub poisson_begin: f64,
    /// `-de_l / de_a` over the last tenth of the axial strain (biaxial; NaN otherwise).
    pub poisson_end: f64,
    /// The peak (biaxial).
    pub peak: Option<Peak>,
    /// Dilatancy angle `psi` (degrees) after the peak (or over the last tenth of the axial
    /// strain when there is none): `sin psi = -de_v / (de_a - de_l)`, `e_v = e_a + e_l`.
    pub dilatancy_angle: f64,
    /// What appendix 7 predicts.
    pub prediction: Option<Prediction>,
}

impl Parameters {
    /// The parameters as (name, value, unit) rows, predictions marked by their equation.
    pub fn rows(&self) -> Vec<(String, f64, &'static str)> {
        let mut rows: Vec<(String, f64, &'static str)> = vec![
            (
                "lateral stress sigma_3 at the start".into(),
                self.lateral_stress,
                "Pa",
            ),
            ("axial stress at the start".into(), self.axial_stress, "Pa"),
            ("contact density n_c/v".into(), self.contact_density, "-"),
        ];
        let (young, nu) = match self.kind {
            TestKind::Biaxial => ("E50", "Poisson's ratio, begin"),
            TestKind::Compression => ("E (eq. A.9)", "Poisson's ratio (eq. A.9)"),
        };
        rows.push((young.into(), self.young, "Pa"));
        rows.push((nu.into(), self.poisson_begin, "-"));
        if self.kind == TestKind::Biaxial {
            rows.push(("Poisson's ratio, end".into(), self.poisson_end, "-"));
        }
        if let Some(peak) = &self.peak {
            let bound = if peak.reached {
                ""
            } else {
                " (not reached: lower bound)"
            };
            rows.push((format!("peak sigma_1{bound}"), peak.axial_stress, "Pa"));
            rows.push(("sigma_3 at the peak".into(), peak.lateral_stress, "Pa"));
            rows.push(("axial strain at the peak".into(), peak.strain, "-"));
            rows.push((
                format!("phi' mobilised, c' = 0{bound}"),
                peak.friction_angle,
                "deg",
            ));
            rows.push(("dilatancy psi".into(), self.dilatancy_angle, "deg"));
        }
        if let Some(p) = &self.prediction {
            rows.push((format!("E predicted (eq. {})", p.equation), p.young, "Pa"));
            if let Some(nu) = p.poisson {
                rows.push(("Poisson's ratio predicted (eq. A.83)".into(), nu, "-"));
            }
            if let Some(e) = p.young_isotropic {
                rows.push(("E / (1 - nu) predicted (eq. A.85)".into(), e, "Pa"));
                rows.push((
                    "E predicted with the measured nu (eq. A.85)".into(),
                    e * (1.0 - self.poisson_begin),
                    "Pa",
                ));
            }
            if let Some(c) = p.cohesion {
                rows.push(("c' predicted (eq. A.95)".into(), c, "Pa"));
            }
            if let Some(phi) = p.friction_angle {
                rows.push(("phi' predicted (eq. A.95)".into(), phi, "deg"));
            }
        }
        rows
    }

    /// The rows as a CSV table (`name,value,unit`).
    pub fn csv(&self) -> String {
        let mut text = String::from("name,value,unit\n");
        for (name, value, unit) in self.rows() {
            let _ = writeln!(text, "\"{name}\",{value:e},{unit}");
        }
        text
    }

    /// The rows as a markdown table.
    pub fn markdown(&self) -> String {
        let mut text = String::from("| parameter | value | unit |\n|---|---|---|\n");
        for (name, value, unit) in self.rows() {
            let _ = writeln!(text, "| {name} | {} | {unit} |", significant(value));
        }
        text
    }
}

/// A value to four significant digits.
pub fn significant(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        format!("{v}")
    } else if (1e-3..1e5).contains(&v.abs()) {
        let digits = (3 - v.abs().log10().floor() as i32).max(0) as usize;
        format!("{v:.digits$}")
    } else {
        format!("{v:.3e}")
    }
}

/// `c'` (Pa) and `phi'` (degrees) of the Mohr-Coulomb line (eq. A.94) through the peaks
/// `(sigma_3, sigma_1)` of several tests, fitted by least squares as
/// `sigma_1 = a sigma_3 + b`: `sin phi' = (a - 1) / (a + 1)`, `c' = b (1 - sin phi') / (2 cos phi')`.
/// `None` with fewer than two distinct lateral stresses.
pub fn mohr_coulomb(peaks: &[(f64, f64)]) -> Option<(f64, f64)> {
    let n = peaks.len() as f64;
    let mean = |f: fn(&(f64, f64)) -> f64| peaks.iter().map(f).sum::<f64>() / n;
    let (m3, m1) = (mean(|p| p.0), mean(|p| p.1));
    let sxx: f64 = peaks.iter().map(|p| (p.0 - m3).powi(2)).sum();
    if peaks.len() < 2 || sxx <= 1e-12 * m3 * m3 {
        return None;
    }
    let a = peaks.iter().map(|p| (p.0 - m3) * (p.1 - m1)).sum::<f64>() / sxx;
    let b = m1 - a * m3;
    let sin = (a - 1.0) / (a + 1.0);
    let phi = sin.asin();
    Some((b * (1.0 - sin) / (2.0 * phi.cos()), phi.to_degrees()))
}

/// Why no parameters could be estimated.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NotEstimated(pub String);

/// Share of the axial stress change within which the lateral stress counts as held.
const HELD: f64 = 0.02;

/// The macro parameters of the last stage of a run.
pub fn estimate(
    header: &RunHeader,
    history: &History,
    curves: &Curves,
) -> Result<Parameters, NotEstimated> {
    let last = *stage_rows(&curves.stage)
        .last()
        .ok_or_else(|| NotEstimated("no increment of a stage was written".into()))?;
    estimate_stage(header, history, curves, last)
}

/// The macro parameters of every stage they can be read from (a cyclic compression test:
/// the first loading and each reloading and unloading).
pub fn estimate_stages(header: &RunHeader, history: &History, curves: &Curves) -> Vec<Parameters> {
    stage_rows(&curves.stage)
        .into_iter()
        .filter_map(|rows| estimate_stage(header, history, curves, rows).ok())
        .collect()
}

/// The macro parameters of one stage, given as (first row, last row, stage).
fn estimate_stage(
    header: &RunHeader,
    history: &History,
    curves: &Curves,
    (start, end, stage): (usize, usize, usize),
) -> Result<Parameters, NotEstimated> {
    let (LoadAxis::Strain { .. }, Some(lateral_strain)) = (&curves.axis, &curves.lateral_strain)
    else {
        return Err(NotEstimated(
            "the walls are not two pairs of opposite walls".into(),
        ));
    };
    let stress = |key: &str| {
        curves
            .stresses
            .iter()
            .find(|c| c.key == key)
            .map(|c| c.values.as_slice())
    };
    let (Some(sa), Some(sl)) = (stress("axial_stress_walls"), stress("lateral_stress_walls"))
    else {
        return Err(NotEstimated("no wall stresses".into()));
    };
    let (ea, el) = (&curves.load.values, &lateral_strain.values);
    if end <= start {
        return Err(NotEstimated(
            "the stage has fewer than two written states".into(),
        ));
    }
    let d = |v: &[f64], r: usize| v[r] - v[start];
    let rows = start..=end;
    let dsa_max = rows.clone().map(|r| d(sa, r).abs()).fold(0.0, f64::max);
    let dsl_max = rows.clone().map(|r| d(sl, r).abs()).fold(0.0, f64::max);
    let del_max = rows.clone().map(|r| d(el, r).abs()).fold(0.0, f64::max);
    // Within the equilibrium tolerance of the stage's start, nothing was loaded.
    if dsa_max <= 1e-6 * sa[start].abs() {
        return Err(NotEstimated(
            "the stage does not change the axial stress".into(),
        ));
    }
    let kind = if del_max <= 1e-12 {
        TestKind::Compression
    } else if dsl_max <= HELD * dsa_max {
        TestKind::Biaxial
    } else {
        return Err(NotEstimated(
            "in the last stage neither the lateral walls nor the lateral stress are held".into(),
        ));
    };
    let scene = parse_scene(&header.scene_text, "the result's scene").ok();
    let density = contact_density(header, history, start);
    let mut p = Parameters {
        kind,
        stage,
        lateral_stress: sl[start],
        axial_stress: sa[start],
        contact_density: density,
        young: f64::NAN,
        poisson_begin: f64::NAN,
        poisson_end: f64::NAN,
        peak: None,
        dilatancy_angle: f64::NAN,
        // The appendix takes the depth to be the mean diameter.
        prediction: scene
            .filter(|_| (header.depth / mean_diameter(header) - 1.0).abs() < 1e-9)
            .and_then(|s| {
                let vertical = 0.5 * (sa[start] + sa[end]);
                predict(
                    &s,
                    kind,
                    density,
                    sl[start],
                    vertical,
                    mean_diameter(header),
                )
            }),
    };
    match kind {
        TestKind::Compression => {
            let nu = d(sl, end) / d(sa, end);
            p.poisson_begin = nu;
            p.young = (1.0 - nu * nu) * d(sa, end) / d(ea, end);
        }
        TestKind::Biaxial => {
            let q = |r: usize| (sa[r] - sl[r]) - (sa[start] - sl[start]);
            // The peak from the rows at each increment's peak, and after the last, where the
            // run ended on no equilibrium near, at the failing increment's: a bond broken
            // within an increment leaves its end past the peak.
            let at_peaks = Curves::new(header, &history.at_peaks());
            let peaks = |key: &str| {
                let c = at_peaks.stresses.iter().find(|c| c.key == key)?;
                (c.values.len() >= sa.len()).then_some(c.values.as_slice())
            };
            let (pa, pl, pe) = match (peaks("axial_stress_walls"), peaks("lateral_stress_walls")) {
                (Some(pa), Some(pl)) => (pa, pl, at_peaks.load.values.as_slice()),
                _ => (sa, sl, ea.as_slice()),
            };
            let last = if end + 1 == sa.len() && pa.len() > sa.len() {
                end + 1
            } else {
                end
            };
            let q_peak = |r: usize| (pa[r] - pl[r]) - (sa[start] - sl[start]);
            let top = (start..=last)
                .max_by(|&a, &b| q_peak(a).total_cmp(&q_peak(b)))
                .expect("rows");
            if top == start || q_peak(top) <= 0.0 {
                return Err(NotEstimated(
                    "the deviator does not rise in the stage".into(),
                ));
            }
            // Half the peak deviator, between two written rows.
            let half = 0.5 * q_peak(top);
            let top_row = top.min(end);
            let k = (start + 1..=top_row)
                .find(|&r| q(r) >= half)
                .unwrap_or(top_row);
            let w = if q(k) > q(k - 1) {
                (half - q(k - 1)) / (q(k) - q(k - 1))
            } else {
                1.0
            };
            let at = |v: &[f64]| d(v, k - 1) + w * (v[k] - v[k - 1]);
            p.young = half / at(ea);
            p.poisson_begin = -at(el) / at(ea);
            let last_tenth = ea[end] - 0.1 * (ea[end] - ea[start]);
            let tail = (start..end).find(|&r| ea[r] >= last_tenth).unwrap_or(start);
            p.poisson_end = -(el[end] - el[tail]) / (ea[end] - ea[tail]);
            let (s1, s3) = (pa[top], pl[top]);
            p.peak = Some(Peak {
                axial_stress: s1,
                lateral_stress: s3,
                strain: pe[top] - ea[start],
                reached: top < end || q_peak(top) > q(end),
                friction_angle: ((s1 - s3) / (s1 + s3)).asin().to_degrees(),
            });
            let from = if top < end { top } else { tail };
            let (dea, del) = (ea[end] - ea[from], el[end] - el[from]);
            p.dilatancy_angle = (-(dea + del) / (dea - del)).asin().to_degrees();
        }
    }
    Ok(p)
}

/// The rows of every stage that has a written increment: the row it starts from (the last
/// one written before it, which ended the stage before), its last row, and the stage.
fn stage_rows(stage: &[(i64, i64)]) -> Vec<(usize, usize, usize)> {
    // A row (s, 0) ends stage s - 1; (s, k > 0) is within stage s.
    let of = |(s, k): (i64, i64)| if k == 0 { s - 1 } else { s };
    let mut out: Vec<(usize, usize, usize)> = Vec::new();
    for (r, &row) in stage.iter().enumerate() {
        let s = of(row);
        if s < 0 {
            continue;
        }
        match out.last_mut() {
            Some(last) if last.2 == s as usize => last.1 = r,
            _ => out.push((r.saturating_sub(1), r, s as usize)),
        }
    }
    out
}

/// `n_c/v = d^3 n_c / V` at a row: grain-grain contacts per cube of the mean diameter, with
/// the sample's volume taken at the depth `D = d` the thesis uses (eq. A.83).
fn contact_density(header: &RunHeader, history: &History, row: usize) -> f64 {
    let d = mean_diameter(header);
    let contacts = history.int("grain_contacts")[row] as f64;
    let area = history.float("volume")[row] / header.depth;
    d * d * contacts / area
}

/// The mean grain diameter (m).
fn mean_diameter(header: &RunHeader) -> f64 {
    2.0 * header.radius.iter().sum::<f64>() / header.radius.len() as f64
}

/// The predictions of appendix 7 for the scene's material, at the contact density and
/// lateral stress the stage starts from (and the mean vertical stress of a compression
/// stage), for grains of mean diameter `d`.
fn predict(
    scene: &Scene,
    kind: TestKind,
    density: f64,
    lateral_stress: f64,
    vertical_stress: f64,
    d: f64,
) -> Option<Prediction> {
    let m = &scene.material;
    let nu = m.poisson;
    let kappa = 3.0 * (1.0 - nu) / (2.0 - nu);
    match m.law {
        LawKind::Hertz => {
            // Eqs. A.88-A.89 with sigma_ref = 1 bar and sigma_0 = 1.5 sigma_3 (table 4).
            let reference: f64 = 1e5;
            let g = m.shear_modulus?;
            let e_ref =
                (reference.sqrt() * g / (3.0 * (1.0 - nu)) * density).powf(2.0 / 3.0) * 2.0 * kappa
                    / (kappa + 1.0);
            let (young, equation) = match kind {
                TestKind::Biaxial => (e_ref * (1.5 * lateral_stress / reference).cbrt(), "A.89"),
                TestKind::Compression => (
                    0.75f64.cbrt() * e_ref * (vertical_stress / reference).cbrt(),
                    "24",
                ),
            };
            Some(Prediction {
                young,
                equation,
                poisson: None,
                young_isotropic: None,
                cohesion: None,
                friction_angle: None,
            })
        }
        LawKind::Linear => {
            let k_n = m.normal_stiffness?;
            Some(Prediction {
                young: density * k_n / d * kappa / (kappa + 1.0),
                equation: "A.83",
                poisson: Some(-(kappa - 1.0) / (kappa + 1.0)),
                young_isotropic: Some(density * k_n / (2.0 * d)),
                cohesion: m
                    .bonded
                    .then(|| m.cohesion * density / (16.0 * 2f64.sqrt())),
                friction_angle: m.bonded.then(|| (1.0f64 / 3.0).asin().to_degrees()),
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mohr_coulomb_recovers_the_line_it_was_drawn_from() {
        // c' = 2e5 Pa, phi' = 30 deg: sigma_1 = 3 sigma_3 + 2 c' cos / (1 - sin).
        let (c, phi) = (2e5, 30f64.to_radians());
        let a = (1.0 + phi.sin()) / (1.0 - phi.sin());
        let b = 2.0 * c * phi.cos() / (1.0 - phi.sin());
        let peaks: Vec<(f64, f64)> = [1e5, 2e5, 4e5].iter().map(|&s3| (s3, a * s3 + b)).collect();
        let (c_fit, phi_fit) = mohr_coulomb(&peaks).unwrap();
        assert!((c_fit - c).abs() < 1e-6 * c);
        assert!((phi_fit - 30.0).abs() < 1e-9);
        assert!(mohr_coulomb(&peaks[..1]).is_none());
        assert!(mohr_coulomb(&[(1e5, 3e5), (1e5, 3.1e5)]).is_none());
    }

    #[test]
    fn each_stage_starts_at_the_row_that_ended_the_one_before() {
        // Rows: start (0, 0); stage 0 at 2; its end (1, 0); stage 1 at 3, 6; its end (2, 0).
        let rows = [(0, 0), (0, 2), (1, 0), (1, 3), (1, 6), (2, 0)];
        assert_eq!(stage_rows(&rows), vec![(0, 2, 0), (2, 5, 1)]);
        // A run stopped within stage 1.
        assert_eq!(stage_rows(&rows[..5]), vec![(0, 2, 0), (2, 4, 1)]);
        assert!(stage_rows(&rows[..1]).is_empty());
    }

    #[test]
    fn a_linear_elastic_biaxial_curve_gives_back_e_and_nu() {
        // sigma_3 held at 1e5; E = 5e7, nu = 0.25 up to the peak at row 6, then softening
        // with dilatancy: e_v falls as e_a grows.
        let (e, nu) = (5e7, 0.25);
        let mut ea = Vec::new();
        let mut el = Vec::new();
        let mut sa = Vec::new();
        for k in 0..=10 {
            let strain = 1e-3 * k as f64;
            let (axial, lateral) = if k <= 6 {
                (1e5 + e * strain, -nu * strain)
            } else {
                let after = strain - 6e-3;
                (1e5 + e * 6e-3 - 1e7 * after, -nu * 6e-3 - 1.5 * after)
            };
            ea.push(strain);
            el.push(lateral);
            sa.push(axial);
        }
        let curve = |key: &str, values: Vec<f64>| crate::output::curves::Curve {
            key: key.into(),
            label: key.into(),
            from_contacts: false,
            values,
        };
        let rows = ea.len();
        let curves = Curves {
            increment: (0..rows as i64).collect(),
            axis: LoadAxis::Strain {
                axial: [0, 2],
                lateral: Some([1, 3]),
            },
            load: curve("axial_strain", ea),
            stresses: vec![
                curve("axial_stress_walls", sa),
                curve("lateral_stress_walls", vec![1e5; rows]),
            ],
            lateral_strain: Some(curve("lateral_strain", el)),
            volumetric_strain: None,
            stage: (0..rows as i64).map(|k| (0, k)).collect(),
            contacts_per_grain: vec![4.0; rows],
            broken_bonds: vec![0.0; rows],
            shear: Vec::new(),
        };
        let header = RunHeader {
            scene_name: "synthetic".into(),
            scene_text: String::new(),
            solver_text: String::new(),
            version: String::new(),
            depth: 2e-4,
            radius: vec![1e-4],
            walls: Vec::new(),
            fixed_rotations: false,
            law: "hertz".into(),
            membranes: Vec::new(),
            regions: Vec::new(),
        };
        let history = History {
            ints: vec![("grain_contacts", vec![2; rows])],
            floats: vec![("volume", vec![1e-6 * 2e-4; rows])],
            walls: Vec::new(),
            membrane_pressure: Vec::new(),
            regions: Vec::new(),
            failure_peak: None,
        };
        let p = estimate(&header, &history, &curves).unwrap();
        assert_eq!(p.kind, TestKind::Biaxial);
        assert!((p.young - e).abs() < 1e-6 * e, "E50 {}", p.young);
        assert!((p.poisson_begin - nu).abs() < 1e-9);
        // The last tenth: de_l / de_a = -1.5.
        assert!((p.poisson_end - 1.5).abs() < 1e-9);
        let peak = p.peak.unwrap();
        assert!(peak.reached);
        assert!((peak.axial_stress - 4e5).abs() < 1e-6);
        let phi = (3e5f64 / 5e5).asin().to_degrees();
        assert!((peak.friction_angle - phi).abs() < 1e-9);
        // After the peak: de_v = de_a + de_l = -0.5 de_a, d gamma = 2.5 de_a.
        assert!((p.dilatancy_angle - 0.2f64.asin().to_degrees()).abs() < 1e-9);
        // n_c/v = d^2 n_c / A with d = 2e-4, two contacts, A = 1e-6.
        assert!((p.contact_density - 0.08).abs() < 1e-12);
    }
}
