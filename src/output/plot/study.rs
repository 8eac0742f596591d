//! The study's picture: error against CPU time, log-log, one line per strategy.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::style::{titled, Drawn, Picture, DESC_SIZE, FONT, LABEL_SIZE};

/// One strategy's runs: (CPU seconds, error, label) from least to most effort.
pub(super) struct ErrorSeries {
    pub(super) label: String,
    pub(super) points: Vec<(f64, f64, String)>,
    pub(super) colour: RGBColor,
}

/// Error against time on logarithmic axes, each run marked and named.
pub(super) struct ErrorChart {
    pub(super) title: String,
    pub(super) y_label: String,
    pub(super) series: Vec<ErrorSeries>,
}

/// Errors below this are drawn on it (a run that matched the reference to the last bit).
const FLOOR: f64 = 1e-16;

/// A decade-aligned range around positive values.
fn decades(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if lo > hi {
        return (1e-3, 1.0);
    }
    (
        10f64.powf(lo.log10().floor()),
        10f64.powf(hi.log10().ceil().max(lo.log10().floor() + 1.0)),
    )
}

impl Picture for ErrorChart {
    fn size(&self) -> (u32, u32) {
        (1200, 860)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Drawn
    where
        DB::ErrorType: 'static,
    {
        let area = titled(root, &self.title)?;
        let points = || self.series.iter().flat_map(|s| s.points.iter());
        let (x0, x1) = decades(points().map(|p| p.0));
        let (y0, y1) = decades(points().map(|p| p.1.max(FLOOR)));
        let mut chart = ChartBuilder::on(&area)
            .margin(25)
            .x_label_area_size(70)
            .y_label_area_size(120)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())?;
        chart
            .configure_mesh()
            .x_desc("CPU time of the run [s]")
            .y_desc(self.y_label.as_str())
            .x_label_formatter(&|v| format!("{v:.0e}"))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .label_style((FONT, LABEL_SIZE))
            .axis_desc_style((FONT, DESC_SIZE))
            .bold_line_style(RGBColor(220, 220, 220))
            .light_line_style(RGBColor(245, 245, 245))
            .draw()?;
        for s in &self.series {
            let line: Vec<(f64, f64)> = s.points.iter().map(|p| (p.0, p.1.max(FLOOR))).collect();
            let style = s.colour.stroke_width(3);
            chart
                .draw_series(LineSeries::new(line.iter().copied(), style))?
                .label(s.label.as_str())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 32, y)], style));
            chart.draw_series(line.iter().map(|&p| Circle::new(p, 6, s.colour.filled())))?;
            chart.draw_series(s.points.iter().zip(&line).map(|(p, &at)| {
                Text::new(
                    format!("  {}", p.2),
                    at,
                    (FONT, LABEL_SIZE - 4).into_font().color(&s.colour),
                )
            }))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .margin(15)
            .legend_area_size(40)
            .label_font((FONT, LABEL_SIZE))
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(180, 180, 180))
            .draw()?;
        Ok(())
    }
}
