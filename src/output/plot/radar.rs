//! Radar (polar) plots of the contact fabric: the number of contacts per direction (thesis
//! fig. 14) and the mean normal and shear force per direction (figs. 37 and 38). Grain-grain
//! contacts only: wall contacts all have the wall's normal and would swamp a few bins. A
//! contact's normal and its opposite are one direction, so angles are folded over 180
//! degrees and drawn twice, point-symmetric.

use std::f64::consts::PI;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::style::{legend, titled, Drawn, Picture, FONT, LABEL_SIZE, TITLE_HEIGHT};
use crate::geometry::Side;
use crate::state::State;

/// Bins over 180 degrees (10 degrees each, bin `k` centred on `10 k` degrees).
pub(super) const BINS: usize = 18;

/// Grain-grain contacts binned by the angle of their normal (anticlockwise from x).
pub(super) struct Fabric {
    /// Contacts per bin.
    pub(super) count: [f64; BINS],
    /// Mean normal force per bin (N), compression positive; 0 in an empty bin.
    pub(super) normal: [f64; BINS],
    /// Mean shear force per bin (N); 0 in an empty bin.
    pub(super) shear: [f64; BINS],
}

impl Fabric {
    pub(super) fn of(state: &State) -> Fabric {
        let p = &state.grains.position;
        let mut f = Fabric {
            count: [0.0; BINS],
            normal: [0.0; BINS],
            shear: [0.0; BINS],
        };
        for c in &state.contacts.contacts {
            let Side::Grain(a) = c.pair.a else { continue };
            let b = c.pair.b;
            let angle = (p[b][1] - p[a][1]).atan2(p[b][0] - p[a][0]).rem_euclid(PI);
            // Bins centred on 0, 10, 20 ... degrees: a lattice's directions fall mid-bin.
            let k = (angle / PI * BINS as f64 + 0.5) as usize % BINS;
            f.count[k] += 1.0;
            f.normal[k] += c.response.normal_force;
            f.shear[k] += c.response.shear_force;
        }
        for k in 0..BINS {
            if f.count[k] > 0.0 {
                f.normal[k] /= f.count[k];
                f.shear[k] /= f.count[k];
            }
        }
        f
    }
}

/// One closed curve: a value per bin, drawn across the bin and across its opposite.
pub(super) struct RadarSeries {
    pub(super) label: String,
    pub(super) values: [f64; BINS],
    pub(super) colour: RGBColor,
    pub(super) dashed: bool,
}

/// A radar plot of non-negative values per direction.
pub(super) struct Radar {
    pub(super) title: String,
    pub(super) series: Vec<RadarSeries>,
}

const LEGEND: u32 = 50;
const SIDE: u32 = 1000;

impl Picture for Radar {
    fn size(&self) -> (u32, u32) {
        (SIDE, TITLE_HEIGHT + SIDE + LEGEND)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Drawn
    where
        DB::ErrorType: 'static,
    {
        let area = titled(root, &self.title)?;
        let (main, strip) = area.split_vertically(SIDE);
        let largest = self
            .series
            .iter()
            .flat_map(|s| s.values.iter())
            .fold(0.0, |m: f64, v| m.max(*v));
        let step = nice_step(if largest > 0.0 { largest / 4.0 } else { 0.25 });
        let rings = ((largest / step).ceil() as usize).max(1);
        let outer = rings as f64 * step;
        let reach = 1.18 * outer;
        let mut chart = ChartBuilder::on(&main)
            .margin(30)
            .build_cartesian_2d(-reach..reach, -reach..reach)?;
        let grid = RGBColor(200, 200, 200);
        let polar = |r: f64, a: f64| (r * a.cos(), r * a.sin());
        let ring_label = TextStyle::from((FONT, LABEL_SIZE).into_font())
            .color(&RGBColor(90, 90, 90))
            .pos(Pos::new(HPos::Left, VPos::Bottom));
        for k in 1..=rings {
            let r = k as f64 * step;
            let circle: Vec<_> = (0..=180).map(|j| polar(r, j as f64 * PI / 90.0)).collect();
            chart.draw_series([PathElement::new(circle, grid.stroke_width(1))])?;
            chart.draw_series([Text::new(
                format_value(r, step),
                polar(r, 0.4 * PI),
                ring_label.clone(),
            )])?;
        }
        let angle_label = TextStyle::from((FONT, LABEL_SIZE).into_font())
            .pos(Pos::new(HPos::Center, VPos::Center));
        for k in 0..12 {
            let a = k as f64 * PI / 6.0;
            chart.draw_series([PathElement::new(
                vec![(0.0, 0.0), polar(outer, a)],
                grid.stroke_width(1),
            )])?;
            chart.draw_series([Text::new(
                format!("{}°", k * 30),
                polar(1.09 * outer, a),
                angle_label.clone(),
            )])?;
        }
        for s in &self.series {
            // A rose: an arc at each bin's value across the bin, radial steps between bins.
            let mut points: Vec<(f64, f64)> = (0..2 * BINS)
                .flat_map(|k| {
                    (0..=4).map(move |j| (k, (k as f64 - 0.5 + j as f64 / 4.0) * PI / BINS as f64))
                })
                .map(|(k, a)| polar(s.values[k % BINS], a))
                .collect();
            points.push(points[0]);
            let style = s.colour.stroke_width(3);
            if s.dashed {
                chart.draw_series(DashedLineSeries::new(points, 12, 8, style))?;
            } else {
                chart.draw_series(LineSeries::new(points, style))?;
            }
        }
        let entries: Vec<_> = self
            .series
            .iter()
            .map(|s| (s.label.clone(), s.colour, 3))
            .collect();
        legend(&strip, &entries)?;
        Ok(())
    }
}

/// A step of 1, 2 or 5 times a power of ten, at least `rough`.
fn nice_step(rough: f64) -> f64 {
    let power = 10f64.powi(rough.log10().floor() as i32);
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * power)
        .find(|s| *s >= rough)
        .unwrap_or(10.0 * power)
}

/// A ring value with as many decimals as its step needs.
fn format_value(v: f64, step: f64) -> String {
    let digits = (-step.log10().floor()).max(0.0) as usize;
    format!("{v:.digits$}")
}
