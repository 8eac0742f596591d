//! Curves over the written increments: stress-strain, volumetric strain, contacts per grain,
//! bonds broken.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::style::{range, titled, Drawn, Picture, DESC_SIZE, FONT, LABEL_SIZE};

/// One curve of a chart, in display units.
pub(super) struct Series {
    pub(super) label: String,
    pub(super) points: Vec<(f64, f64)>,
    pub(super) colour: RGBColor,
    /// Dashed: measured from the contacts rather than on the walls.
    pub(super) dashed: bool,
}

/// A line chart with a legend (when it has more than one curve).
pub(super) struct LineChart {
    pub(super) title: String,
    pub(super) x_label: String,
    pub(super) y_label: String,
    /// Whether the y axis starts at zero (stresses, counts).
    pub(super) y_from_zero: bool,
    pub(super) series: Vec<Series>,
}

impl Picture for LineChart {
    fn size(&self) -> (u32, u32) {
        (1200, 820)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Drawn
    where
        DB::ErrorType: 'static,
    {
        let area = titled(root, &self.title)?;
        let points = || self.series.iter().flat_map(|s| s.points.iter());
        let xs: Vec<f64> = points().map(|p| p.0).collect();
        let ys: Vec<f64> = points().map(|p| p.1).collect();
        let (x0, x1) = range(&xs, false);
        let (y0, y1) = range(&ys, self.y_from_zero);
        let mut chart = ChartBuilder::on(&area)
            .margin(25)
            .x_label_area_size(70)
            .y_label_area_size(110)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        chart
            .configure_mesh()
            .x_desc(self.x_label.as_str())
            .y_desc(self.y_label.as_str())
            .label_style((FONT, LABEL_SIZE))
            .axis_desc_style((FONT, DESC_SIZE))
            .bold_line_style(RGBColor(220, 220, 220))
            .light_line_style(RGBColor(245, 245, 245))
            .draw()?;
        for s in &self.series {
            let points = s
                .points
                .iter()
                .copied()
                .filter(|p| p.0.is_finite() && p.1.is_finite());
            let style = s.colour.stroke_width(3);
            let drawn = if s.dashed {
                chart.draw_series(DashedLineSeries::new(points, 12, 8, style))?
            } else {
                chart.draw_series(LineSeries::new(points, style))?
            };
            if self.series.len() > 1 {
                let dashed = s.dashed;
                drawn.label(s.label.as_str()).legend(move |(x, y)| {
                    let (end, start) = if dashed { (12, 20) } else { (16, 16) };
                    EmptyElement::at((x, y))
                        + PathElement::new(vec![(0, 0), (end, 0)], style)
                        + PathElement::new(vec![(start, 0), (32, 0)], style)
                });
            }
        }
        if self.series.len() > 1 {
            chart
                .configure_series_labels()
                .position(emptiest_corner(&xs, &ys, (x0, x1), (y0, y1)))
                .margin(15)
                .legend_area_size(40)
                .label_font((FONT, LABEL_SIZE))
                .background_style(WHITE.mix(0.85))
                .border_style(RGBColor(180, 180, 180))
                .draw()?;
        }
        Ok(())
    }
}

/// The corner of the chart with the fewest points near it, for the legend.
fn emptiest_corner(
    xs: &[f64],
    ys: &[f64],
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
) -> SeriesLabelPosition {
    let count = |left: bool, top: bool| {
        xs.iter()
            .zip(ys)
            .filter(|(x, y)| {
                let fx = (*x - x0) / (x1 - x0);
                let fy = (*y - y0) / (y1 - y0);
                (if left { fx < 0.5 } else { fx > 0.5 }) && (if top { fy > 0.5 } else { fy < 0.5 })
            })
            .count()
    };
    [
        (SeriesLabelPosition::UpperLeft, count(true, true)),
        (SeriesLabelPosition::LowerRight, count(false, false)),
        (SeriesLabelPosition::UpperRight, count(false, true)),
        (SeriesLabelPosition::LowerLeft, count(true, false)),
    ]
    .into_iter()
    .min_by_key(|(_, n)| *n)
    .map_or(SeriesLabelPosition::UpperLeft, |(p, _)| p)
}
