//! Line plots for every experiment: PNG and SVG from the same description.
//!
//! A [`Plot`] is a title, axis labels, optional logarithmic axes, named
//! [`Series`] of points with colours, and text [`Annotation`]s (fitted
//! slopes, parameters). It is drawn with plotters; text uses DejaVu Sans
//! embedded in the binary (`assets/DejaVuSans.ttf`, registered with the
//! `ab_glyph` backend), so no system font library is needed. Both files are
//! written atomically through [`smokelab::io::write_atomic`].
//!
//! ```no_run
//! use smokelab_app::figures::plot::{Annotation, Plot, Series};
//! let xs: Vec<f64> = (1..=5).map(|i| 2f64.powi(i)).collect();
//! Plot::new("error vs resolution", "N", "L2 error")
//!     .log_x()
//!     .log_y()
//!     .series(Series::line("SL advection", xs.iter().map(|&n| (n, 1.0 / n)).collect()))
//!     .annotate(Annotation::at_fraction(0.05, 0.1, "slope −1.00"))
//!     .write(std::path::Path::new("results/demo/error"))
//!     .unwrap();
//! ```

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::Once;

use anyhow::{anyhow, bail, Result};
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::coord::Shift;
use plotters::element::{DashedPathElement, Drawable, PointCollection};
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};
use plotters_backend::{BackendCoord, DrawingErrorKind};

use smokelab::io::write_atomic;

/// The embedded plot font.
static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
/// Family name the font is registered under.
pub(crate) const FAMILY: &str = "sans-serif";

/// Register the embedded font with plotters (once per process).
pub(crate) fn ensure_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        if register_font(FAMILY, FontStyle::Normal, FONT).is_err() {
            panic!("the embedded DejaVuSans.ttf is not a valid font");
        }
    });
}

/// Ten distinguishable colours (the "tab10" palette), used in series order
/// when a series has no colour of its own.
pub const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Style {
    /// A solid line.
    Line,
    /// A dashed line (reference slopes, fits).
    Dashed,
    /// Markers only (measurements).
    Markers,
    /// A line with markers.
    LineMarkers,
}

/// A named set of points.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend entry (empty: not in the legend).
    pub name: String,
    /// `(x, y)` points, drawn in order.
    pub points: Vec<(f64, f64)>,
    /// Colour (`None`: the next [`PALETTE`] colour).
    pub color: Option<RGBColor>,
    /// Line or markers.
    pub style: Style,
}

impl Series {
    /// A solid line.
    pub fn line(name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            name: name.into(),
            points,
            color: None,
            style: Style::Line,
        }
    }

    /// The same series in another style.
    pub fn styled(mut self, style: Style) -> Self {
        self.style = style;
        self
    }

    /// The same series in a fixed colour.
    pub fn colored(mut self, color: RGBColor) -> Self {
        self.color = Some(color);
        self
    }
}

/// Where an annotation's text starts (its upper-left corner).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Anchor {
    /// A point in data coordinates.
    Data(f64, f64),
    /// Fractions of the plotting area from its upper-left corner.
    Fraction(f64, f64),
}

/// A line of text on the plot.
#[derive(Clone, Debug, PartialEq)]
pub struct Annotation {
    /// The text.
    pub text: String,
    /// Where it goes.
    pub anchor: Anchor,
}

impl Annotation {
    /// Text at data point `(x, y)`.
    pub fn at_data(x: f64, y: f64, text: impl Into<String>) -> Self {
        Self {
            text: text.into(),
            anchor: Anchor::Data(x, y),
        }
    }

    /// Text at fractions `(fx, fy)` of the plotting area from its upper-left corner.
    pub fn at_fraction(fx: f64, fy: f64, text: impl Into<String>) -> Self {
        Self {
            text: text.into(),
            anchor: Anchor::Fraction(fx, fy),
        }
    }
}

/// Corner of the plotting area that holds the legend.
pub use plotters::chart::SeriesLabelPosition as LegendPosition;

/// A line plot.
#[derive(Clone, Debug)]
pub struct Plot {
    /// Title above the plot.
    pub title: String,
    /// Label of the x axis.
    pub x_label: String,
    /// Label of the y axis.
    pub y_label: String,
    /// Logarithmic x axis (points with x ≤ 0 are dropped).
    pub log_x: bool,
    /// Logarithmic y axis (points with y ≤ 0 are dropped).
    pub log_y: bool,
    /// x range (`None`: from the data).
    pub x_range: Option<(f64, f64)>,
    /// y range (`None`: from the data).
    pub y_range: Option<(f64, f64)>,
    /// The series, drawn in order.
    pub series: Vec<Series>,
    /// Text drawn on top.
    pub annotations: Vec<Annotation>,
    /// Legend corner.
    pub legend: LegendPosition,
    /// Image size in pixels (PNG) or user units (SVG).
    pub size: (u32, u32),
}

impl Plot {
    /// An empty plot with linear axes, 800×560.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Self {
        Self {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            log_x: false,
            log_y: false,
            x_range: None,
            y_range: None,
            series: vec![],
            annotations: vec![],
            legend: LegendPosition::UpperRight,
            size: (800, 560),
        }
    }

    /// Logarithmic x axis.
    pub fn log_x(mut self) -> Self {
        self.log_x = true;
        self
    }

    /// Logarithmic y axis.
    pub fn log_y(mut self) -> Self {
        self.log_y = true;
        self
    }

    /// Fix the x range.
    pub fn x_range(mut self, lo: f64, hi: f64) -> Self {
        self.x_range = Some((lo, hi));
        self
    }

    /// Fix the y range.
    pub fn y_range(mut self, lo: f64, hi: f64) -> Self {
        self.y_range = Some((lo, hi));
        self
    }

    /// Add a series.
    pub fn series(mut self, s: Series) -> Self {
        self.series.push(s);
        self
    }

    /// Add an annotation.
    pub fn annotate(mut self, a: Annotation) -> Self {
        self.annotations.push(a);
        self
    }

    /// Put the legend in another corner.
    pub fn legend(mut self, at: LegendPosition) -> Self {
        self.legend = at;
        self
    }

    /// Write `<base>.png` and `<base>.svg`; returns both paths.
    pub fn write(&self, base: &Path) -> Result<[PathBuf; 2]> {
        let png = base.with_extension("png");
        let svg = base.with_extension("svg");
        self.write_png(&png)?;
        self.write_svg(&svg)?;
        Ok([png, svg])
    }

    /// Write a PNG.
    pub fn write_png(&self, path: &Path) -> Result<()> {
        let (w, h) = self.size;
        let mut buf = vec![0u8; 3 * w as usize * h as usize];
        {
            let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
            self.draw(&root)?;
            root.present()
                .map_err(|e| anyhow!("cannot draw {}: {e}", path.display()))?;
        }
        let img = image::RgbImage::from_raw(w, h, buf).expect("buffer has the image's size");
        smokelab::io::write_png(path, &img)
    }

    /// Write an SVG.
    pub fn write_svg(&self, path: &Path) -> Result<()> {
        let mut text = String::new();
        {
            let root = SVGBackend::with_string(&mut text, self.size).into_drawing_area();
            self.draw(&root)?;
            root.present()
                .map_err(|e| anyhow!("cannot draw {}: {e}", path.display()))?;
        }
        write_atomic(path, |w| Ok(std::io::Write::write_all(w, text.as_bytes())?))
    }

    /// The points that can be drawn on the chosen axes.
    fn drawable(&self, s: &Series) -> Vec<(f64, f64)> {
        s.points
            .iter()
            .copied()
            .filter(|&(x, y)| {
                x.is_finite()
                    && y.is_finite()
                    && (!self.log_x || x > 0.0)
                    && (!self.log_y || y > 0.0)
            })
            .collect()
    }

    /// Axis ranges: the fixed ones, or the data's extent with a margin (5 %
    /// of the span on linear axes, 10 % of a decade-fraction on log axes).
    fn ranges(&self) -> Result<(Range<f64>, Range<f64>)> {
        let pts: Vec<(f64, f64)> = self.series.iter().flat_map(|s| self.drawable(s)).collect();
        let extent = |get: fn(&(f64, f64)) -> f64, log: bool, fixed: Option<(f64, f64)>| {
            if let Some((lo, hi)) = fixed {
                let ordered = lo.is_finite() && hi.is_finite() && lo < hi;
                if !ordered || (log && lo <= 0.0) {
                    bail!("plot range [{lo}, {hi}] is empty or not positive on a log axis");
                }
                return Ok(lo..hi);
            }
            let lo = pts.iter().map(get).fold(f64::INFINITY, f64::min);
            let hi = pts.iter().map(get).fold(f64::NEG_INFINITY, f64::max);
            if !lo.is_finite() {
                return Ok(if log { 0.1..10.0 } else { 0.0..1.0 });
            }
            Ok(if log {
                let (l, h) = (lo.log10(), hi.log10());
                let m = 0.05 * (h - l).max(0.2);
                10f64.powf(l - m)..10f64.powf(h + m)
            } else {
                let m = 0.05 * (hi - lo).max(1e-12 * hi.abs().max(1.0));
                (lo - m)..(hi + m)
            })
        };
        Ok((
            extent(|p| p.0, self.log_x, self.x_range)?,
            extent(|p| p.1, self.log_y, self.y_range)?,
        ))
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()>
    where
        DB::ErrorType: 'static,
    {
        ensure_font();
        root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
        let (xr, yr) = self.ranges()?;
        let log = |r: Range<f64>| {
            let ticks = log_ticks(&r);
            r.log_scale().with_key_points(ticks)
        };
        match (self.log_x, self.log_y) {
            (false, false) => self.draw_axes(root, xr, yr),
            (true, false) => self.draw_axes(root, log(xr), yr),
            (false, true) => self.draw_axes(root, xr, log(yr)),
            (true, true) => self.draw_axes(root, log(xr), log(yr)),
        }
    }

    fn draw_axes<DB, X, Y>(&self, root: &DrawingArea<DB, Shift>, x: X, y: Y) -> Result<()>
    where
        DB: DrawingBackend,
        DB::ErrorType: 'static,
        X: AsRangedCoord<Value = f64>,
        Y: AsRangedCoord<Value = f64>,
        X::CoordDescType: ValueFormatter<f64>,
        Y::CoordDescType: ValueFormatter<f64>,
    {
        let err = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow!("plot '{}': {e}", self.title);
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, (FAMILY, 24))
            .margin(16)
            .x_label_area_size(48)
            .y_label_area_size(72)
            .build_cartesian_2d(x, y)
            .map_err(err)?;
        let mut mesh = chart.configure_mesh();
        mesh.x_desc(&self.x_label)
            .y_desc(&self.y_label)
            .axis_desc_style((FAMILY, 18))
            .label_style((FAMILY, 14))
            .x_label_formatter(&|v| tick_label(*v))
            .y_label_formatter(&|v| tick_label(*v))
            .bold_line_style(RGBColor(210, 210, 210));
        if self.log_x || self.log_y {
            // plotters' minor grid on log axes is uneven; keep the major one.
            mesh.light_line_style(TRANSPARENT);
        } else {
            mesh.light_line_style(RGBColor(238, 238, 238));
        }
        mesh.draw().map_err(err)?;
        let mut legend = false;
        for (i, s) in self.series.iter().enumerate() {
            let color = s.color.unwrap_or(PALETTE[i % PALETTE.len()]);
            let line = color.stroke_width(LINE_WIDTH);
            let pts = self.drawable(s);
            let marker = |p| Circle::new(p, MARKER_RADIUS, color.filled());
            let anno = match s.style {
                Style::Line => chart.draw_series(LineSeries::new(pts, line)),
                Style::Dashed => chart.draw_series(DashedLineSeries::new(pts, DASH, GAP, line)),
                Style::Markers => chart.draw_series(pts.into_iter().map(marker)),
                Style::LineMarkers => {
                    chart
                        .draw_series(LineSeries::new(pts.clone(), line))
                        .map_err(err)?;
                    chart.draw_series(pts.into_iter().map(marker))
                }
            }
            .map_err(err)?;
            if !s.name.is_empty() {
                legend = true;
                let style = s.style;
                anno.label(s.name.as_str())
                    .legend(move |at| LegendGlyph { style, color, at });
            }
        }
        if legend {
            chart
                .configure_series_labels()
                .position(self.legend.clone())
                .label_font((FAMILY, 15))
                .background_style(WHITE.mix(0.85))
                .border_style(RGBColor(160, 160, 160))
                .draw()
                .map_err(err)?;
        }
        let style = TextStyle::from((FAMILY, 16)).color(&BLACK);
        for a in &self.annotations {
            match a.anchor {
                Anchor::Data(x, y) => chart
                    .draw_series(std::iter::once(Text::new(
                        a.text.clone(),
                        (x, y),
                        style.clone(),
                    )))
                    .map(|_| ()),
                Anchor::Fraction(fx, fy) => {
                    let area = chart.plotting_area().strip_coord_spec();
                    let (w, h) = area.dim_in_pixel();
                    let at = ((fx * w as f64) as i32, (fy * h as f64) as i32);
                    area.draw(&Text::new(a.text.clone(), at, style.clone()))
                }
            }
            .map_err(err)?;
        }
        Ok(())
    }
}

/// Width in pixels of the series' lines.
const LINE_WIDTH: u32 = 2;
/// Radius in pixels of the series' point markers.
const MARKER_RADIUS: i32 = 4;
/// Length in pixels of a dash of a [`Style::Dashed`] line.
const DASH: i32 = 8;
/// Gap in pixels between two dashes of a [`Style::Dashed`] line.
const GAP: i32 = 5;
/// Width in pixels of a legend entry's sample of its series (plotters
/// leaves 30 px for it, the text starting 6 px after the sample).
const GLYPH: i32 = 24;

/// The legend entry of a series drawn in `style` and `color`: a [`GLYPH`]-wide
/// sample starting at `at` (its left end, on the label's middle line), drawn
/// as the series is drawn — a solid line, a dashed line with the series'
/// dash pattern (two dashes and a gap), a marker, or a line through a marker.
///
/// An element of its own rather than a sum of plotters' elements: a legend
/// entry must be an element that outlives the backend, which a sum (generic
/// over the backend) is not.
struct LegendGlyph {
    style: Style,
    color: RGBColor,
    at: BackendCoord,
}

impl<'a> PointCollection<'a, BackendCoord> for &'a LegendGlyph {
    type Point = &'a BackendCoord;
    type IntoIter = std::iter::Once<&'a BackendCoord>;
    fn point_iter(self) -> Self::IntoIter {
        std::iter::once(&self.at)
    }
}

impl<DB: DrawingBackend> Drawable<DB> for LegendGlyph {
    fn draw<I: Iterator<Item = BackendCoord>>(
        &self,
        mut at: I,
        backend: &mut DB,
        dim: (u32, u32),
    ) -> Result<(), DrawingErrorKind<DB::ErrorType>> {
        let Some((x, y)) = at.next() else {
            return Ok(());
        };
        let line = self.color.stroke_width(LINE_WIDTH);
        let span = [(x, y), (x + GLYPH, y)];
        let centre = (x + GLYPH / 2, y);
        let marker = Circle::new(centre, MARKER_RADIUS, self.color.filled());
        match self.style {
            Style::Line => PathElement::new(span, line).draw(span.into_iter(), backend, dim),
            Style::Dashed => {
                let dashes = DashedPathElement::new(span, DASH, GAP, line);
                dashes.draw(span.into_iter(), backend, dim)
            }
            Style::Markers => marker.draw(std::iter::once(centre), backend, dim),
            Style::LineMarkers => {
                PathElement::new(span, line).draw(span.into_iter(), backend, dim)?;
                marker.draw(std::iter::once(centre), backend, dim)
            }
        }
    }
}

/// The ticks of a log axis over `r` (`0 < r.start < r.end`): the powers of
/// ten in it; with their 2× and 5× when it spans under three decades, with
/// every multiple 1–9× under half a decade, and only every k-th power over
/// ten decades (k the span ÷ 10, rounded up). The powers are counted from
/// the one at or below `r.start`, so the part of a decade below the first
/// power in range is labelled too (plotters' own log ticks start at that
/// power and leave it bare). A range with fewer than two such ticks gets
/// evenly spaced ticks of a 1-2-5 step instead.
fn log_ticks(r: &Range<f64>) -> Vec<f64> {
    let (lo, hi) = (r.start, r.end);
    let span = (hi / lo).log10();
    let (multiples, every): (&[f64], i32) = if span < 0.5 {
        (&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0], 1)
    } else if span < 3.0 {
        (&[1.0, 2.0, 5.0], 1)
    } else {
        (&[1.0], (span / 10.0).ceil().max(1.0) as i32)
    };
    let first = lo.log10().floor() as i32;
    let ticks: Vec<f64> = (first..=hi.log10().ceil() as i32)
        .filter(|e| (e - first) % every == 0)
        // m·10^e correctly rounded: powers of ten to 10²² are exact.
        .flat_map(|e| {
            let scale = 10f64.powi(e.abs());
            multiples
                .iter()
                .map(move |m| if e < 0 { m / scale } else { m * scale })
        })
        .filter(|v| r.contains(v))
        .collect();
    if ticks.len() >= 2 {
        return ticks;
    }
    let magnitude = 10f64.powf(((hi - lo) / 5.0).log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * magnitude)
        .find(|s| (hi - lo) / s <= 6.0)
        .expect("ten times the magnitude is at most 6 steps");
    let start = (lo / step).ceil() as i64;
    (start..)
        .map(|i| i as f64 * step)
        .take_while(|v| *v <= hi)
        .collect()
}

/// A tick label with at most four significant digits and no trailing
/// zeros; scientific notation outside `[10⁻³, 10⁵)`.
pub fn tick_label(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let a = v.abs();
    if !(1e-3..1e5).contains(&a) {
        let s = format!("{v:.3e}");
        let (mant, exp) = s
            .split_once('e')
            .expect("scientific format has an exponent");
        let mant = mant.trim_end_matches('0').trim_end_matches('.');
        return format!("{mant}e{exp}");
    }
    let decimals = (3 - a.log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(tick_label(1000.0), "1000");
        assert_eq!(tick_label(0.25), "0.25");
        assert_eq!(tick_label(10.000001), "10");
        assert_eq!(tick_label(1e-5), "1e-5");
        assert_eq!(tick_label(2.5e6), "2.5e6");
        assert_eq!(tick_label(-0.5), "-0.5");
        assert_eq!(tick_label(0.0), "0");
    }

    fn demo(log: bool) -> Plot {
        let pts: Vec<(f64, f64)> = (1..=20).map(|i| (i as f64, (i * i) as f64)).collect();
        let mut p = Plot::new("demo", "x", "y")
            .series(Series::line("x²", pts.clone()))
            .series(
                Series::line("", pts.iter().map(|&(x, y)| (x, 2.0 * y)).collect())
                    .styled(Style::Dashed),
            )
            .series(
                Series::line("pts", pts)
                    .styled(Style::Markers)
                    .colored(PALETTE[3]),
            )
            .annotate(Annotation::at_fraction(0.05, 0.05, "slope 2.00"))
            .annotate(Annotation::at_data(5.0, 100.0, "here"));
        if log {
            p = p.log_x().log_y();
        }
        p
    }

    #[test]
    fn writes_png_and_svg_with_text_on_linear_and_log_axes() {
        let dir = tempfile::tempdir().unwrap();
        for log in [false, true] {
            let [png, svg] = demo(log)
                .write(&dir.path().join(format!("p{log}")))
                .unwrap();
            if std::env::var_os("SMOKELAB_KEEP_PLOTS").is_some() {
                std::fs::copy(&png, format!("scratch/plot_demo_{log}.png")).unwrap();
            }
            let img = image::open(&png).unwrap().to_rgb8();
            assert_eq!(img.dimensions(), (800, 560));
            // Something other than the white background was drawn, including
            // dark text pixels (the title and labels need the embedded font).
            let dark = img.pixels().filter(|p| p.0.iter().all(|&c| c < 80)).count();
            assert!(dark > 500, "only {dark} dark pixels");
            let text = std::fs::read_to_string(&svg).unwrap();
            assert!(text.contains("slope 2.00") && text.contains("<svg"));
        }
    }

    /// Each legend entry is drawn in its series' style: the dashed series'
    /// sample has a gap between two dashes on its middle row, the marked
    /// series' sample has ink above and below its line (the marker). Drawn
    /// as plain solid lines, as before, both entries fail.
    #[test]
    fn legend_entries_show_dashes_and_markers() {
        const DASHED: RGBColor = RGBColor(255, 0, 0);
        const MARKED: RGBColor = RGBColor(0, 0, 255);
        // The data stay in the lower left, the legend in the upper right.
        let low: Vec<(f64, f64)> = (0..=4).map(|i| (f64::from(i), 1.0)).collect();
        let plot = Plot {
            size: (400, 300),
            ..Plot::new("legend", "x", "y")
        }
        .x_range(0.0, 10.0)
        .y_range(0.0, 10.0)
        .series(
            Series::line("dashed", low.clone())
                .styled(Style::Dashed)
                .colored(DASHED),
        )
        .series(
            Series::line("marked", low)
                .styled(Style::LineMarkers)
                .colored(MARKED),
        );
        let dir = tempfile::tempdir().unwrap();
        let png = dir.path().join("legend.png");
        plot.write_png(&png).unwrap();
        let img = image::open(&png).unwrap().to_rgb8();
        let (w, h) = img.dimensions();
        // The rows of the upper-right quarter with pixels in `c`, and their columns.
        let ink = |c: RGBColor| -> Vec<(u32, Vec<u32>)> {
            (0..h / 2)
                .map(|y| {
                    let xs = (w / 2..w)
                        .filter(|&x| img.get_pixel(x, y).0 == [c.0, c.1, c.2])
                        .collect::<Vec<_>>();
                    (y, xs)
                })
                .filter(|(_, xs)| !xs.is_empty())
                .collect()
        };
        // The glyph's row: the one with the most ink.
        let glyph_row = |rows: &[(u32, Vec<u32>)]| -> (u32, Vec<u32>) {
            let row = rows.iter().max_by_key(|(_, xs)| xs.len());
            row.expect("no legend entry in the upper right").clone()
        };
        let (y, xs) = glyph_row(&ink(DASHED));
        let gap = xs.windows(2).find(|p| p[1] > p[0] + 1);
        let Some(&[left, right]) = gap else {
            panic!("dashed legend entry solid on row {y}: {xs:?}");
        };
        let between = img.get_pixel((left + right) / 2, y).0;
        assert!(
            right - left > GAP as u32 / 2 && between.iter().all(|&c| c > 200),
            "dashed legend entry, row {y}: {left}–{right} holds {between:?}"
        );
        let rows = ink(MARKED);
        let (y, _) = glyph_row(&rows);
        let reach = MARKER_RADIUS as u32 - 1;
        let above = rows.iter().any(|(r, _)| r + reach <= y);
        let below = rows.iter().any(|(r, _)| *r >= y + reach);
        assert!(
            above && below,
            "marked legend entry has no marker around row {y}: rows {:?}",
            rows.iter().map(|(r, _)| r).collect::<Vec<_>>()
        );
    }

    /// The decade below the first power of ten is labelled (06-5's wall
    /// times, 0.0025–0.13 s, had no label under 0.01); fifteen decades get
    /// at most ten labels; a range inside one decade's steps still two.
    #[test]
    fn log_ticks_cover_the_range() {
        let t = log_ticks(&(0.0025..0.13));
        assert_eq!(t.first().copied(), Some(0.005));
        assert!(
            t.contains(&0.01) && t.contains(&0.1) && t.iter().all(|v| (0.0025..0.13).contains(v))
        );
        let t = log_ticks(&(1e-15..2.0));
        assert!(t.len() <= 10 && t.len() >= 7, "{t:?}");
        assert!(t
            .iter()
            .all(|v| (v.log10().round() - v.log10()).abs() < 1e-9));
        let t = log_ticks(&(0.12..0.15));
        assert!(
            t.len() >= 2 && t.iter().all(|v| (0.12..=0.15).contains(v)),
            "{t:?}"
        );
        let t = log_ticks(&(3.0..700.0));
        assert_eq!(t, [5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 500.0]);
        assert_eq!(log_ticks(&(4096.0..32768.0)), [5000.0, 10000.0, 20000.0]);
    }

    #[test]
    fn log_axes_drop_non_positive_points_and_ranges_pad() {
        let p = Plot::new("t", "x", "y").log_y().series(Series::line(
            "s",
            vec![(0.0, -1.0), (1.0, 1.0), (2.0, 100.0)],
        ));
        let (x, y) = p.ranges().unwrap();
        // (0, −1) is dropped, so x spans [1, 2] plus 5 % margins.
        assert!((x.start - 0.95).abs() < 1e-12 && (x.end - 2.05).abs() < 1e-12);
        assert!(y.start < 1.0 && y.start > 0.5 && y.end > 100.0 && y.end < 200.0);
        assert!(Plot::new("t", "x", "y")
            .log_x()
            .x_range(0.0, 1.0)
            .ranges()
            .is_err());
    }
}
