//! Pictures of the sample at one increment, drawn to scale: the grains with the force
//! chains and broken bonds (thesis figs. 39 and 44), the displacement field (fig. 26), the
//! rotation field (fig. 42), and each cluster of grains that broke out of it. Grains taken
//! out of the sample are drawn faded where they were taken out.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::style::{
    colour_bar, diverging, legend, max_abs, si_unit, significant, titled, viridis, Drawn, Entry,
    Failure, Picture, Unit, COMPRESSION, DESC_SIZE, FONT, GRAIN, LABEL_SIZE, TENSION, TITLE_HEIGHT,
    WALL,
};
use crate::contact::BreakMode;
use crate::geometry::{Side, Wall};
use crate::state::State;

/// What a sample picture shows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Field {
    /// Grain outlines, contact forces as lines between centres, broken bonds, walls.
    Forces,
    /// Displacement since the start as arrows coloured by their length.
    Displacement,
    /// Grains coloured by their rotation since the start, with a radial line each.
    Rotation,
    /// The grains of one breakout (its index in the state's) filled, against the sample.
    Breakout(usize),
}

const MARGIN: u32 = 20;
const X_LABELS: u32 = 60;
const Y_LABELS: u32 = 90;
/// Width of the colour bar strip of a field.
const BAR: u32 = 200;
/// Height of the legend strip under the force picture.
const LEGEND: u32 = 50;
const MIN_WIDTH: u32 = 1000;

/// Broken bonds by mode.
const BROKEN_TENSION: RGBColor = RGBColor(0, 114, 178);
const BROKEN_SHEAR: RGBColor = RGBColor(0, 158, 115);

/// Grains taken out of the sample: filled in a pale grey, where the sample's are outlines.
const TAKEN_OUT: RGBColor = RGBColor(218, 218, 218);
/// The cluster of a breakout picture.
const CLUSTER: RGBColor = RGBColor(213, 94, 0);

/// A grain as drawn: its centre in display units and its radius in pixels.
type Disc = ((f64, f64), u32);

/// A picture of the sample at one increment.
pub(super) struct SamplePicture<'a> {
    field: Field,
    title: String,
    state: &'a State,
    /// The box drawn (m): the grains and the walls around them.
    lo: [f64; 2],
    hi: [f64; 2],
    /// Axis unit (m with a prefix).
    length: Unit,
    /// Size of the plotting area (pixels).
    plot: (u32, u32),
    /// Walls as polylines (m).
    walls: Vec<Vec<[f64; 2]>>,
}

impl<'a> SamplePicture<'a> {
    pub(super) fn new(field: Field, title: String, state: &'a State) -> Self {
        let g = &state.grains;
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for (p, r) in g.position.iter().zip(&g.radius) {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k] - r);
                hi[k] = hi[k].max(p[k] + r);
            }
        }
        if lo[0] > hi[0] {
            (lo, hi) = ([0.0; 2], [1e-3; 2]);
        }
        let walls: Vec<Vec<[f64; 2]>> = state
            .walls
            .walls
            .iter()
            .map(|w| wall_line(w, lo, hi))
            .collect();
        for p in walls.iter().flatten() {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let r_mean = g.mean_radius();
        for k in 0..2 {
            lo[k] -= r_mean;
            hi[k] += r_mean;
        }
        let longest = (hi[0] - lo[0]).max(hi[1] - lo[1]);
        // At least 8 pixels per radius, the longest side 1200 to 4000 pixels.
        let px_per_m = (1200.0 / longest).max(8.0 / r_mean).min(4000.0 / longest);
        let plot = (
            ((hi[0] - lo[0]) * px_per_m).round() as u32,
            ((hi[1] - lo[1]) * px_per_m).round() as u32,
        );
        SamplePicture {
            field,
            title,
            state,
            lo,
            hi,
            length: si_unit(longest, "m"),
            plot,
            walls,
        }
    }

    fn bar(&self) -> u32 {
        match self.field {
            Field::Forces | Field::Breakout(_) => 0,
            Field::Displacement | Field::Rotation => BAR,
        }
    }

    fn legend(&self) -> u32 {
        match self.field {
            Field::Forces | Field::Breakout(_) => LEGEND,
            Field::Displacement | Field::Rotation => 0,
        }
    }

    /// The grains, split into those in the sample and those taken out of it, `px` turning
    /// metres into pixels.
    fn circles(&self, px: impl Fn(f64) -> f64) -> [Vec<Disc>; 2] {
        let g = &self.state.grains;
        let mut split = [Vec::new(), Vec::new()];
        for i in 0..g.len() {
            let radius = px(g.radius[i]).round().max(1.0) as u32;
            split[usize::from(g.taken_out[i])].push((self.at(g.position[i]), radius));
        }
        split
    }

    /// Display coordinates of a point.
    fn at(&self, p: [f64; 2]) -> (f64, f64) {
        (p[0] * self.length.factor, p[1] * self.length.factor)
    }

    /// The largest displacement of a grain in the sample (m).
    fn longest_displacement(&self) -> f64 {
        let g = &self.state.grains;
        let u = |i: usize| g.displacement[i][0].hypot(g.displacement[i][1]);
        g.in_sample().map(u).fold(0.0, f64::max)
    }

    /// Arrow magnification of the displacement field: the longest arrow about three mean
    /// radii, rounded to two significant digits.
    fn magnification(&self) -> f64 {
        let longest = self.longest_displacement();
        if longest > 0.0 {
            let k = 3.0 * self.state.grains.mean_radius() / longest;
            let step = 10f64.powi(k.log10().floor() as i32 - 1);
            (k / step).round() * step
        } else {
            1.0
        }
    }
}

impl Picture for SamplePicture<'_> {
    fn size(&self) -> (u32, u32) {
        let width = self.plot.0 + 2 * MARGIN + Y_LABELS + self.bar();
        let height = TITLE_HEIGHT + self.plot.1 + 2 * MARGIN + X_LABELS + self.legend();
        (width.max(MIN_WIDTH), height)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Drawn
    where
        DB::ErrorType: 'static,
    {
        let title = match self.field {
            Field::Displacement => format!(
                "{}; arrows ×{}",
                self.title,
                significant(self.magnification(), 2)
            ),
            _ => self.title.clone(),
        };
        let area = titled(root, &title)?;
        let (w, h) = area.dim_in_pixel();
        let (area, strip) = area.split_vertically(h - self.legend());
        let (main, bar) = area.split_horizontally(w - self.bar());
        // Whatever the minimum width adds goes to both sides, keeping the scale equal.
        let extra = self.size().0 - (self.plot.0 + 2 * MARGIN + Y_LABELS + self.bar());
        let (x0, y0) = self.at(self.lo);
        let (x1, y1) = self.at(self.hi);
        let mut chart = ChartBuilder::on(&main)
            .margin(MARGIN)
            .margin_left(MARGIN + extra / 2)
            .margin_right(MARGIN + extra - extra / 2)
            .x_label_area_size(X_LABELS)
            .y_label_area_size(Y_LABELS)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(format!("x [{}]", self.length.unit))
            .y_desc(format!("y [{}]", self.length.unit))
            .label_style((FONT, LABEL_SIZE))
            .axis_desc_style((FONT, DESC_SIZE))
            .draw()?;
        // Pixels per display unit.
        let scale = chart.plotting_area().dim_in_pixel().0 as f64 / (x1 - x0);
        let px = |r: f64| r * self.length.factor * scale;
        let g = &self.state.grains;
        let wall_width = (px(g.mean_radius()) * 0.3).clamp(2.0, 8.0) as u32;
        chart.draw_series(self.walls.iter().map(|line| {
            let points: Vec<_> = line.iter().map(|p| self.at(*p)).collect();
            PathElement::new(points, WALL.stroke_width(wall_width))
        }))?;
        let [in_sample, taken_out] = self.circles(px);
        chart.draw_series(
            (taken_out.iter()).map(|&(at, radius)| Circle::new(at, radius, TAKEN_OUT.filled())),
        )?;
        let taken_out_entry = (!taken_out.is_empty())
            .then(|| (format!("taken out ({})", taken_out.len()), TAKEN_OUT, 8));
        match self.field {
            Field::Forces => {
                chart.draw_series(
                    (in_sample.iter()).map(|&(at, radius)| Circle::new(at, radius, GRAIN)),
                )?;
                let mut entries = self.draw_forces(&mut chart, px(g.mean_radius()))?;
                entries.extend(taken_out_entry);
                legend(&strip, &entries)?;
            }
            Field::Breakout(k) => {
                chart.draw_series(
                    (in_sample.iter()).map(|&(at, radius)| Circle::new(at, radius, GRAIN)),
                )?;
                let cluster = &self.state.breakouts[k].grains;
                chart.draw_series(cluster.iter().map(|&i| {
                    let radius = (px(g.radius[i]) - 1.0).round().max(1.0) as u32;
                    Circle::new(self.at(g.position[i]), radius, CLUSTER.filled())
                }))?;
                let mut entries = vec![
                    ("in the sample".into(), GRAIN, 4),
                    (
                        format!(
                            "broken out in increment {}",
                            self.state.breakouts[k].increment
                        ),
                        CLUSTER,
                        8,
                    ),
                ];
                if taken_out.len() > cluster.len() {
                    let others = taken_out.len() - cluster.len();
                    entries.push((format!("other breakouts ({others} grains)"), TAKEN_OUT, 8));
                }
                legend(&strip, &entries)?;
            }
            Field::Displacement => {
                chart.draw_series(
                    in_sample
                        .iter()
                        .map(|&(at, radius)| Circle::new(at, radius, GRAIN.mix(0.6))),
                )?;
                let longest = self.longest_displacement();
                let unit = si_unit(longest, "m");
                let k = self.magnification();
                let head = 0.6 * g.mean_radius();
                let width = (px(g.mean_radius()) * 0.15).clamp(1.0, 4.0) as u32;
                for i in g.in_sample() {
                    let (p, u) = (&g.position[i], &g.displacement[i]);
                    let length = u[0].hypot(u[1]);
                    if length == 0.0 {
                        continue;
                    }
                    let style = viridis(length / longest).stroke_width(width);
                    let tip = [p[0] + k * u[0], p[1] + k * u[1]];
                    let d = [u[0] / length, u[1] / length];
                    let h = head.min(0.4 * k * length);
                    let barb = |s: f64| {
                        let (c, sn) = (0.906_f64, 0.423 * s); // cos and sin of 25 degrees
                        [
                            tip[0] - h * (c * d[0] - sn * d[1]),
                            tip[1] - h * (sn * d[0] + c * d[1]),
                        ]
                    };
                    chart.draw_series([
                        PathElement::new(vec![self.at(*p), self.at(tip)], style),
                        PathElement::new(
                            vec![self.at(barb(1.0)), self.at(tip), self.at(barb(-1.0))],
                            style,
                        ),
                    ])?;
                }
                colour_bar(
                    &bar,
                    (0.0, longest.max(f64::MIN_POSITIVE) * unit.factor),
                    viridis,
                    &format!("displacement [{}]", unit.unit),
                    (MARGIN, MARGIN + X_LABELS),
                )?;
            }
            Field::Rotation => {
                let rotation = |i: usize| g.rotation[i];
                let largest = max_abs(g.in_sample().map(|i| &g.rotation[i]));
                let span = if largest > 0.0 { largest } else { 1.0 };
                chart.draw_series(g.in_sample().map(|i| {
                    // One pixel less than the radius leaves a gap between touching grains.
                    let radius = (px(g.radius[i]) - 1.0).round().max(1.0) as u32;
                    let colour = diverging(0.5 + 0.5 * rotation(i) / span);
                    Circle::new(self.at(g.position[i]), radius, colour.filled())
                }))?;
                // A radial line per grain that pointed up at the start (fig. 42).
                chart.draw_series(g.in_sample().map(|i| {
                    let (p, r, theta) = (g.position[i], g.radius[i], rotation(i));
                    let rim = [p[0] - r * theta.sin(), p[1] + r * theta.cos()];
                    PathElement::new(vec![self.at(p), self.at(rim)], BLACK.stroke_width(1))
                }))?;
                let unit = si_unit(span, "rad");
                colour_bar(
                    &bar,
                    (-span * unit.factor, span * unit.factor),
                    diverging,
                    &format!("rotation [{}], anticlockwise positive", unit.unit),
                    (MARGIN, MARGIN + X_LABELS),
                )?;
            }
        }
        Ok(())
    }
}

type Chart<'b, DB> = ChartContext<
    'b,
    DB,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

impl SamplePicture<'_> {
    /// Contact forces as lines from centre to centre (or to the wall), width proportional
    /// to `|F_n|`, and broken bonds as thick bars across the contact. Returns the legend.
    fn draw_forces<DB: DrawingBackend>(
        &self,
        chart: &mut Chart<'_, DB>,
        radius_px: f64,
    ) -> Result<Vec<Entry>, Failure>
    where
        DB::ErrorType: 'static,
    {
        let s = self.state;
        let g = &s.grains;
        let largest = max_abs(s.contacts.contacts.iter().map(|c| &c.response.normal_force));
        let widest = (0.5 * radius_px).clamp(2.0, 20.0);
        let lines = s.contacts.contacts.iter().filter_map(|c| {
            let f = c.response.normal_force;
            if f == 0.0 || !f.is_finite() {
                return None;
            }
            let b = g.position[c.pair.b];
            let a = match c.pair.a {
                Side::Grain(a) => g.position[a],
                Side::Wall(w) => touch_point(&s.walls.walls[w], b),
            };
            let width = (widest * f.abs() / largest).round().max(1.0) as u32;
            let colour = if f > 0.0 { COMPRESSION } else { TENSION };
            Some(PathElement::new(
                vec![self.at(a), self.at(b)],
                colour.stroke_width(width),
            ))
        });
        chart.draw_series(lines)?;

        let bar_width = (0.3 * radius_px).round().max(3.0) as u32;
        let mut count = [0usize; 2];
        let bars: Vec<_> = s
            .contacts
            .broken_bonds
            .iter()
            .filter_map(|bond| {
                let Side::Grain(a) = bond.pair.a else {
                    return None;
                };
                let b = bond.pair.b;
                let (pa, pb) = (g.position[a], g.position[b]);
                let (ra, rb) = (g.radius[a], g.radius[b]);
                let d = (pb[0] - pa[0]).hypot(pb[1] - pa[1]);
                let n = [(pb[0] - pa[0]) / d, (pb[1] - pa[1]) / d];
                // The middle of the gap (or overlap) between the two surfaces.
                let along = ra + 0.5 * (d - ra - rb);
                let c = [pa[0] + along * n[0], pa[1] + along * n[1]];
                let half = 0.6 * ra.min(rb);
                let ends = [
                    [c[0] + half * n[1], c[1] - half * n[0]],
                    [c[0] - half * n[1], c[1] + half * n[0]],
                ];
                let (mode, colour) = match bond.mode {
                    BreakMode::Tension => (0, BROKEN_TENSION),
                    BreakMode::Shear => (1, BROKEN_SHEAR),
                };
                count[mode] += 1;
                Some(PathElement::new(
                    vec![self.at(ends[0]), self.at(ends[1])],
                    colour.stroke_width(bar_width),
                ))
            })
            .collect();
        chart.draw_series(bars)?;

        let force = si_unit(largest, "N");
        let scale = if largest > 0.0 {
            format!(
                ", largest {} {}",
                significant(largest * force.factor, 3),
                force.unit
            )
        } else {
            String::new()
        };
        let mut entries = vec![
            (
                format!("compression (width ∝ |F_n|{scale})"),
                COMPRESSION,
                4,
            ),
            ("tension".into(), TENSION, 4),
        ];
        if count[0] > 0 {
            entries.push((
                format!("bond broken in tension ({})", count[0]),
                BROKEN_TENSION,
                6,
            ));
        }
        if count[1] > 0 {
            entries.push((
                format!("bond broken in shear ({})", count[1]),
                BROKEN_SHEAR,
                6,
            ));
        }
        Ok(entries)
    }
}

/// Where a grain centred at `p` touches a wall: its centre moved onto the wall's surface.
fn touch_point(wall: &Wall, p: [f64; 2]) -> [f64; 2] {
    match &wall.circle {
        Some(c) => {
            let (radius, center) = (wall.surface(wall.position), c.center_at(wall.position));
            let d = (p[0] - center[0]).hypot(p[1] - center[1]);
            [
                center[0] + radius * (p[0] - center[0]) / d,
                center[1] + radius * (p[1] - center[1]) / d,
            ]
        }
        None => {
            let (d, n) = (wall.distance(p), wall.current_normal());
            [p[0] - d * n[0], p[1] - d * n[1]]
        }
    }
}

/// A wall as a polyline: a straight wall across the box `lo`-`hi` of the grains, a
/// circular one all round.
fn wall_line(wall: &Wall, lo: [f64; 2], hi: [f64; 2]) -> Vec<[f64; 2]> {
    let surface = wall.surface(wall.position);
    match &wall.circle {
        Some(c) => {
            let center = c.center_at(wall.position);
            (0..=180)
                .map(|k| {
                    let a = k as f64 * std::f64::consts::PI / 90.0;
                    [center[0] + surface * a.cos(), center[1] + surface * a.sin()]
                })
                .collect()
        }
        None => {
            let (n, surface) = (wall.current_normal(), wall.line_constant());
            if n[1].abs() > n[0].abs() {
                [lo[0], hi[0]]
                    .iter()
                    .map(|&x| [x, (surface - n[0] * x) / n[1]])
                    .collect()
            } else {
                [lo[1], hi[1]]
                    .iter()
                    .map(|&y| [(surface - n[1] * y) / n[0], y])
                    .collect()
            }
        }
    }
}
