//! What every picture shares: the font, colours and colour maps, SI prefixes for axis units,
//! legends and colour bars, and writing one picture as both SVG and PNG.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{register_font, FontStyle};

use crate::Error;

/// The font family the pictures use (plotters' default family name).
pub(super) const FONT: &str = "sans-serif";

/// DejaVu Sans (Debian's `fonts-dejavu-core`): loaded at run time so that the build needs
/// no font library.
const FONT_FILE: &str = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";

/// Sizes of text in pixels.
pub(super) const TITLE_SIZE: u32 = 28;
pub(super) const DESC_SIZE: u32 = 22;
pub(super) const LABEL_SIZE: u32 = 18;

/// Height of the title strip above a picture.
pub(super) const TITLE_HEIGHT: u32 = 50;

/// Curves' colours (a colour-blind safe palette: Okabe and Ito).
pub(super) const PALETTE: [RGBColor; 7] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 0, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
];

/// Grain outlines.
pub(super) const GRAIN: RGBColor = RGBColor(140, 140, 140);
/// Compressive contact forces.
pub(super) const COMPRESSION: RGBColor = RGBColor(0, 0, 0);
/// Tensile contact forces.
pub(super) const TENSION: RGBColor = RGBColor(213, 0, 0);
/// Walls.
pub(super) const WALL: RGBColor = RGBColor(60, 60, 60);

/// A drawing's failure; plotters' errors differ per backend.
pub(super) type Failure = Box<dyn std::error::Error>;

/// A drawing's result.
pub(super) type Drawn = Result<(), Failure>;

/// A legend entry: label, colour, line width.
pub(super) type Entry = (String, RGBColor, u32);

/// A picture that can be drawn on any plotters backend.
pub(super) trait Picture {
    /// Width and height in pixels.
    fn size(&self) -> (u32, u32);
    /// Draw on the whole area (already white).
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Drawn
    where
        DB::ErrorType: 'static;
}

/// Register DejaVu Sans with plotters, once per process.
pub(super) fn load_font() -> Result<(), Error> {
    static LOADED: OnceLock<Result<(), String>> = OnceLock::new();
    LOADED
        .get_or_init(|| {
            let bytes = std::fs::read(FONT_FILE).map_err(|e| {
                format!("{e}: the pictures need DejaVu Sans (Debian: apt-get install fonts-dejavu-core)")
            })?;
            // plotters keeps fonts for the whole process.
            let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
            register_font(FONT, FontStyle::Normal, bytes)
                .map_err(|_| "not a font plotters can read".to_string())
        })
        .clone()
        .map_err(|message| Error::io(FONT_FILE, message))
}

/// Write `picture` as `dir/name.svg` and `dir/name.png`.
pub(super) fn save(picture: &impl Picture, dir: &Path, name: &str) -> Result<Vec<PathBuf>, Error> {
    let svg = dir.join(format!("{name}.svg"));
    let png = dir.join(format!("{name}.png"));
    let failed = |path: &Path| {
        let path = path.display().to_string();
        move |e: Failure| Error::io(path, format!("drawing failed: {e}"))
    };
    let size = picture.size();
    render(&SVGBackend::new(&svg, size).into_drawing_area(), picture).map_err(failed(&svg))?;
    render(&BitMapBackend::new(&png, size).into_drawing_area(), picture).map_err(failed(&png))?;
    Ok(vec![svg, png])
}

fn render<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, picture: &impl Picture) -> Drawn
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    picture.draw(root)?;
    root.present()?;
    Ok(())
}

/// Split a title strip off the top of `root` and write `title` in it.
pub(super) fn titled<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
) -> Result<DrawingArea<DB, Shift>, Failure>
where
    DB::ErrorType: 'static,
{
    let (top, rest) = root.split_vertically(TITLE_HEIGHT);
    let (w, h) = top.dim_in_pixel();
    let style = TextStyle::from((FONT, TITLE_SIZE).into_font())
        .pos(Pos::new(HPos::Center, VPos::Center))
        .color(&BLACK);
    top.draw_text(title, &style, (w as i32 / 2, h as i32 / 2))?;
    Ok(rest)
}

/// A legend in a strip: a line sample and a label per entry, left to right.
pub(super) fn legend<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, entries: &[Entry]) -> Drawn
where
    DB::ErrorType: 'static,
{
    let (_, h) = area.dim_in_pixel();
    let y = h as i32 / 2;
    let font = (FONT, LABEL_SIZE).into_font();
    let style = TextStyle::from(font.clone()).pos(Pos::new(HPos::Left, VPos::Center));
    let mut x = 20;
    for (label, colour, width) in entries {
        area.draw(&PathElement::new(
            vec![(x, y), (x + 36, y)],
            colour.stroke_width(*width),
        ))?;
        area.draw_text(label, &style, (x + 44, y))?;
        x += 44 + area.estimate_text_size(label, &style)?.0 as i32 + 30;
    }
    Ok(())
}

/// A vertical colour bar from `lo` to `hi` with `label` beside it.
pub(super) fn colour_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    (lo, hi): (f64, f64),
    map: fn(f64) -> RGBColor,
    label: &str,
    (top, bottom): (u32, u32),
) -> Drawn
where
    DB::ErrorType: 'static,
{
    let mut chart = ChartBuilder::on(area)
        .margin_top(top)
        .margin_bottom(bottom)
        .margin_left(10)
        .margin_right(10)
        .right_y_label_area_size(110)
        .build_cartesian_2d(0.0..1.0, lo..hi)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_desc(label)
        .label_style((FONT, LABEL_SIZE))
        .axis_desc_style((FONT, DESC_SIZE))
        .draw()?;
    const STEPS: usize = 128;
    chart.draw_series((0..STEPS).map(|k| {
        let (a, b) = (k as f64 / STEPS as f64, (k + 1) as f64 / STEPS as f64);
        let (ya, yb) = (lo + a * (hi - lo), lo + b * (hi - lo));
        Rectangle::new([(0.0, ya), (1.0, yb)], map((a + b) / 2.0).filled())
    }))?;
    Ok(())
}

/// Viridis (perceptually uniform, sequential), `t` in 0..1.
pub(super) fn viridis(t: f64) -> RGBColor {
    const STOPS: [(u8, u8, u8); 9] = [
        (68, 1, 84),
        (71, 45, 123),
        (59, 82, 139),
        (44, 114, 142),
        (33, 145, 140),
        (40, 174, 128),
        (94, 201, 98),
        (173, 220, 48),
        (253, 231, 37),
    ];
    interpolate(&STOPS, t)
}

/// Blue through white to red (ColorBrewer RdBu, diverging), `t` in 0..1, 0.5 white.
pub(super) fn diverging(t: f64) -> RGBColor {
    const STOPS: [(u8, u8, u8); 5] = [
        (5, 48, 97),
        (67, 147, 195),
        (247, 247, 247),
        (214, 96, 77),
        (103, 0, 31),
    ];
    interpolate(&STOPS, t)
}

fn interpolate(stops: &[(u8, u8, u8)], t: f64) -> RGBColor {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.5
    };
    let s = t * (stops.len() - 1) as f64;
    let k = (s.floor() as usize).min(stops.len() - 2);
    let f = s - k as f64;
    let mix = |a: u8, b: u8| (a as f64 + f * (b as f64 - a as f64)).round() as u8;
    let (a, b) = (stops[k], stops[k + 1]);
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// A display unit: SI values times `factor` are in `unit` (an SI prefix and the base unit).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Unit {
    pub(super) factor: f64,
    pub(super) unit: String,
}

/// The SI prefix that shows values up to `max_abs` with one to three digits before the
/// point.
pub(super) fn si_unit(max_abs: f64, base: &str) -> Unit {
    const PREFIXES: [(i32, &str); 7] = [
        (9, "G"),
        (6, "M"),
        (3, "k"),
        (0, ""),
        (-3, "m"),
        (-6, "µ"),
        (-9, "n"),
    ];
    let exponent = if max_abs.is_finite() && max_abs > 0.0 {
        max_abs.log10().floor() as i32
    } else {
        0
    };
    let (p, prefix) = PREFIXES
        .iter()
        .find(|(p, _)| *p <= exponent)
        .copied()
        .unwrap_or(PREFIXES[PREFIXES.len() - 1]);
    Unit {
        factor: 10f64.powi(-p),
        unit: format!("{prefix}{base}"),
    }
}

/// `v` with `digits` significant digits, as text.
pub(super) fn significant(v: f64, digits: i32) -> String {
    let decimals = if v > 0.0 {
        (digits - 1 - v.log10().floor() as i32).max(0) as usize
    } else {
        0
    };
    format!("{v:.decimals$}")
}

/// The largest absolute finite value (0 when there is none).
pub(super) fn max_abs<'a>(values: impl IntoIterator<Item = &'a f64>) -> f64 {
    values
        .into_iter()
        .filter(|v| v.is_finite())
        .fold(0.0, |m, v| m.max(v.abs()))
}

/// A range around finite `values` (and zero when `from_zero`) with 5% room, so that no curve
/// lies on an axis; a band around a constant.
pub(super) fn range<'a>(values: impl IntoIterator<Item = &'a f64>, from_zero: bool) -> (f64, f64) {
    let (mut lo, mut hi) = values
        .into_iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(*v), hi.max(*v))
        });
    if lo > hi {
        return (0.0, 1.0);
    }
    if from_zero {
        lo = lo.min(0.0);
        hi = hi.max(0.0);
    }
    if hi - lo <= 1e-12 * hi.abs().max(lo.abs()) {
        let band = if hi == 0.0 { 1.0 } else { 0.1 * hi.abs() };
        return (lo - band, hi + band);
    }
    let room = 0.05 * (hi - lo);
    (lo - room, hi + room)
}
