//! The study's charts as SVG, drawn with `plotters` on the server.
//!
//! Why server-side SVG: the same chart serves the dashboard, downloads for
//! papers and the `study --report` HTML, with no JavaScript build step and no
//! charting code in the browser. Text is left to the viewer's fonts (SVG
//! `<text>`), so no font files are needed here.
//!
//! One visual language for every chart, page and report:
//! - each coding has one colour and one marker ([`CODING_STYLES`], Okabe–Ito
//!   colours, safe for the common colour-vision deficiencies; the dashboard
//!   and the report read the same table through [`coding_css`]);
//! - the measurement (or the study's truth) is black, an open circle larger
//!   than any coding's marker, drawn last so nothing hides it;
//! - legends sit in their own column right of the plot, never over data;
//! - tick labels are formatted from the axis span (no float noise), every
//!   axis names its unit, fonts are sized for a chart scaled to ~600 px.
//!
//! Every function is pure: data in, SVG text out.

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::colorimetry::rgb::RgbSpace;
use crate::colorimetry::{Cmf, Observer, Xyz};

/// Chart size in px; the dashboard scales the SVG to its box.
const W: u32 = 780;
const H: u32 = 460;
/// The legend column right of the plot.
const LEGEND_W: u32 = 190;
const CAPTION_PX: u32 = 20;
const DESC_PX: u32 = 16;
const TICK_PX: u32 = 14;
const LEGEND_PX: u32 = 14;
/// A coding's marker radius; the measurement's is larger.
const MARKER_PX: i32 = 5;
const MEASUREMENT_PX: i32 = 8;

/// The shape drawn at a data point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Marker {
    Circle,
    OpenCircle,
    Square,
    Diamond,
    TriangleUp,
    TriangleDown,
    Cross,
    Plus,
}

/// How one series is drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Style {
    pub colour: RGBColor,
    pub marker: Marker,
    /// Marker radius in px.
    pub size: i32,
}

/// One colour and marker per coding, the same in every chart, page and
/// report (Okabe & Ito 2008 colours; black is kept for the measurement).
pub const CODING_STYLES: [(&str, RGBColor, Marker); 7] = [
    ("rgb", RGBColor(213, 94, 0), Marker::Square),
    ("srgb", RGBColor(230, 159, 0), Marker::Diamond),
    ("nstep3", RGBColor(204, 121, 167), Marker::TriangleUp),
    ("nstep9", RGBColor(86, 180, 233), Marker::TriangleDown),
    ("nstep27", RGBColor(0, 114, 178), Marker::Circle),
    ("nstep81", RGBColor(0, 158, 115), Marker::Cross),
    ("spectral", RGBColor(90, 90, 90), Marker::Plus),
];

/// The measurement (or the study's truth): black, open, larger, drawn last.
pub const MEASUREMENT: Style = Style {
    colour: RGBColor(0, 0, 0),
    marker: Marker::OpenCircle,
    size: MEASUREMENT_PX,
};

/// Series that are neither a coding nor the measurement (a Pareto front,
/// a sweep, a threshold): greys and the one Okabe–Ito colour no coding uses.
const OTHER_COLOURS: [RGBColor; 3] = [RGBColor(110, 110, 110), RGBColor(240, 200, 40), RGBColor(170, 170, 170)];

/// A coding's style, if `name` is a coding (`nstepN` for an N not in the
/// table gets the nearest tabulated N's colour and marker).
pub fn coding_style(name: &str) -> Option<Style> {
    let name = name.trim().to_ascii_lowercase();
    let style = |(_, colour, marker): (&str, RGBColor, Marker)| Style {
        colour,
        marker,
        size: MARKER_PX,
    };
    if let Some(row) = CODING_STYLES.iter().find(|(c, _, _)| *c == name) {
        return Some(style(*row));
    }
    let n: f64 = name.strip_prefix("nstep")?.parse().ok()?;
    CODING_STYLES
        .iter()
        .filter_map(|row| Some((row.0.strip_prefix("nstep")?.parse::<f64>().ok()?, *row)))
        .min_by(|a, b| (a.0.ln() - n.ln()).abs().total_cmp(&(b.0.ln() - n.ln()).abs()))
        .map(|(_, row)| style(row))
}

/// Whether a series is the measurement (or the study's truth).
fn is_measurement(name: &str) -> bool {
    let n = name.to_ascii_lowercase();
    n.starts_with("measured") || n.starts_with("measurement") || n.starts_with("truth")
}

/// The style of a named series: its coding's, the measurement's, or the
/// `other`-th of the neutral styles.
fn series_style(name: &str, other: &mut usize) -> Style {
    if is_measurement(name) {
        return MEASUREMENT;
    }
    if let Some(style) = display_channel_style(name) {
        return style;
    }
    coding_style(name).unwrap_or_else(|| {
        let colour = OTHER_COLOURS[*other % OTHER_COLOURS.len()];
        let marker = [Marker::Square, Marker::Diamond, Marker::Circle][*other % 3];
        *other += 1;
        Style {
            colour,
            marker,
            size: MARKER_PX,
        }
    })
}

/// A display channel's series (`red`, `green measured`, `blue fit v^2.2`,
/// `black`, `white, measured`, `black + R + G + B`) in its own colour, so a
/// display profile's charts read at a glance: measured points as squares,
/// spectra and fitted curves as plain lines, the additivity sum in orange.
fn display_channel_style(name: &str) -> Option<Style> {
    let first = name.split([' ', ',']).next()?;
    let colour = if name.contains(" + ") {
        RGBColor(230, 159, 0)
    } else {
        match first {
            "red" => RGBColor(213, 40, 30),
            "green" => RGBColor(0, 150, 60),
            "blue" => RGBColor(30, 80, 210),
            "black" => RGBColor(90, 90, 90),
            "white" => RGBColor(0, 0, 0),
            _ => return None,
        }
    };
    let points = name.contains("measured") && !name.contains(" + ");
    Some(Style {
        colour,
        marker: Marker::Square,
        size: if points { MARKER_PX } else { 0 },
    })
}

/// The coding table as CSS custom properties and classes, for the dashboard
/// and the report (`--coding-nstep3: #cc79a7` …, `.coding-nstep3 { color }`).
pub fn coding_css() -> String {
    let mut css = String::from(":root{");
    for (c, RGBColor(r, g, b), _) in CODING_STYLES {
        css.push_str(&format!("--coding-{c}:#{r:02x}{g:02x}{b:02x};"));
    }
    css.push_str("--coding-measured:#000000}");
    for (c, _, _) in CODING_STYLES {
        css.push_str(&format!(".coding-{c}{{color:var(--coding-{c});font-weight:600}}"));
    }
    css
}

/// The observer's name as charts print it.
pub fn observer_name(observer: Observer) -> &'static str {
    match observer {
        Observer::JuddVos => "Judd–Vos 1978 2°",
        Observer::Cie1931 => "CIE 1931 2°",
    }
}

type ChartResult = Result<String, String>;
type Area<DB> = DrawingArea<DB, Shift>;

fn err<E: std::fmt::Debug>(e: E) -> String {
    format!("chart drawing failed: {e:?}")
}

/// Runs `$body` with `$mk` bound to a closure that builds the marker of
/// `$style` at a point (data or pixel coordinates). A macro because each
/// marker shape is its own element type (and plotters' boxed `DynElement`
/// needs a `'static` backend).
macro_rules! with_marker {
    ($style:expr, |$mk:ident| $body:expr) => {{
        let st: Style = $style;
        let (s, c) = (st.size, st.colour);
        let tri = (s as f64 * 0.9) as i32;
        match st.marker {
            Marker::Circle => {
                let $mk = |at| EmptyElement::at(at) + Circle::new((0, 0), s, c.filled());
                $body
            }
            Marker::OpenCircle => {
                let $mk = |at| EmptyElement::at(at) + Circle::new((0, 0), s, c.stroke_width(2));
                $body
            }
            Marker::Square => {
                let $mk = |at| EmptyElement::at(at) + Rectangle::new([(1 - s, 1 - s), (s - 1, s - 1)], c.filled());
                $body
            }
            Marker::Diamond => {
                let $mk = |at| {
                    EmptyElement::at(at)
                        + Polygon::new(vec![(0, -s - 1), (s + 1, 0), (0, s + 1), (-s - 1, 0)], c.filled())
                };
                $body
            }
            Marker::TriangleUp => {
                let $mk = |at| {
                    EmptyElement::at(at) + Polygon::new(vec![(0, -s - 1), (s + 1, tri), (-s - 1, tri)], c.filled())
                };
                $body
            }
            Marker::TriangleDown => {
                let $mk = |at| {
                    EmptyElement::at(at) + Polygon::new(vec![(0, s + 1), (s + 1, -tri), (-s - 1, -tri)], c.filled())
                };
                $body
            }
            Marker::Cross => {
                let $mk = |at| {
                    EmptyElement::at(at)
                        + PathElement::new(vec![(-s, -s), (s, s)], c.stroke_width(3))
                        + PathElement::new(vec![(-s, s), (s, -s)], c.stroke_width(3))
                };
                $body
            }
            Marker::Plus => {
                let $mk = |at| {
                    EmptyElement::at(at)
                        + PathElement::new(vec![(-s - 1, 0), (s + 1, 0)], c.stroke_width(3))
                        + PathElement::new(vec![(0, -s - 1), (0, s + 1)], c.stroke_width(3))
                };
                $body
            }
        }
    }};
}

/// Draws `points` as markers of `style` into a chart.
fn draw_markers<'a, DB: DrawingBackend + 'a, X: Ranged<ValueType = f64>, Y: Ranged<ValueType = f64>>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    points: &[(f64, f64)],
    style: Style,
) -> Result<(), String> {
    with_marker!(style, |mk| chart
        .draw_series(points.iter().map(|p| mk(*p)))
        .map(|_| ())
        .map_err(err))
}

/// Vertical error bars (x, low, high) with caps `cap` px wide each side;
/// unlike plotters' `ErrorBar`, no circle at the centre (which would hide
/// or fake a marker).
fn draw_error_bars<'a, DB: DrawingBackend + 'a, X: Ranged<ValueType = f64>, Y: Ranged<ValueType = f64>>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    bars: &[(f64, f64, f64)],
    colour: RGBColor,
    cap: i32,
) -> Result<(), String> {
    let style = colour.stroke_width(2);
    chart
        .draw_series(
            bars.iter()
                .map(|&(x, lo, hi)| PathElement::new(vec![(x, lo), (x, hi)], style)),
        )
        .map_err(err)?;
    chart
        .draw_series(
            bars.iter()
                .flat_map(|&(x, lo, hi)| [(x, lo), (x, hi)])
                .map(|p| EmptyElement::at(p) + PathElement::new(vec![(-cap, 0), (cap, 0)], style)),
        )
        .map_err(err)?;
    Ok(())
}

/// What a legend entry shows beside its name.
#[derive(Clone, Copy)]
enum Glyph {
    Line(RGBColor, u32),
    Dashed(RGBColor),
    Marker(Style),
    LineMarker(Style),
    Band(RGBColor),
}

struct LegendEntry {
    name: String,
    glyph: Glyph,
}

/// Splits `name` into lines of at most `width` characters at spaces.
fn wrap(name: &str, width: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    for word in name.split_whitespace() {
        match lines.last_mut() {
            Some(l) if l.chars().count() + 1 + word.chars().count() <= width => {
                l.push(' ');
                l.push_str(word);
            }
            _ => lines.push(word.to_string()),
        }
    }
    lines
}

/// The legend in its own column (`area`, beside the plot): entries with an
/// empty name are skipped, so no legend shows a nameless swatch.
fn draw_legend<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, entries: &[LegendEntry]) -> Result<(), String> {
    let font = ("sans-serif", LEGEND_PX).into_font();
    let mut y = 40;
    for e in entries.iter().filter(|e| !e.name.trim().is_empty()) {
        let (x0, x1, ym) = (8, 34, y + LEGEND_PX as i32 / 2);
        match e.glyph {
            Glyph::Line(c, w) => area.draw(&PathElement::new(vec![(x0, ym), (x1, ym)], c.stroke_width(w))),
            Glyph::Dashed(c) => {
                for k in 0..3 {
                    area.draw(&PathElement::new(
                        vec![(x0 + 10 * k, ym), (x0 + 10 * k + 6, ym)],
                        c.stroke_width(2),
                    ))
                    .map_err(err)?;
                }
                Ok(())
            }
            Glyph::Marker(s) => with_marker!(s, |mk| area.draw(&mk(((x0 + x1) / 2, ym)))),
            Glyph::LineMarker(s) => {
                area.draw(&PathElement::new(vec![(x0, ym), (x1, ym)], s.colour.stroke_width(2)))
                    .map_err(err)?;
                with_marker!(s, |mk| area.draw(&mk(((x0 + x1) / 2, ym))))
            }
            Glyph::Band(c) => area.draw(&Rectangle::new([(x0, ym - 6), (x1, ym + 6)], c.filled())),
        }
        .map_err(err)?;
        for line in wrap(&e.name, 18) {
            area.draw(&Text::new(line, (x1 + 8, y), font.clone())).map_err(err)?;
            y += LEGEND_PX as i32 + 3;
        }
        y += 6;
    }
    Ok(())
}

/// A tick label for `v` on a linear axis spanning `span`: as many decimals
/// as the tick spacing needs, no more (never 0.30000000000000004), and
/// scientific notation for very small or large values.
pub fn tick_label(v: f64, span: f64) -> String {
    let span = span.abs();
    let mag = v.abs().max(span);
    if mag != 0.0 && !(1e-3..1e5).contains(&mag) {
        // Mantissa decimals down to the tick spacing's decade (~10 ticks).
        let step = (span / 10.0).max(mag * 1e-6);
        let digits = if v == 0.0 {
            0
        } else {
            ((v.abs().log10().floor() - step.log10().floor()).max(0.0) as usize).min(4)
        };
        return format!("{v:.digits$e}");
    }
    // Plotters puts ~10 ticks on an axis; one more decimal than the spacing.
    let step = (span / 10.0).max(1e-12);
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    let s = format!("{v:.decimals$}");
    // No "-0.00".
    if s.trim_start_matches('-').chars().all(|c| c == '0' || c == '.') {
        s.trim_start_matches('-').to_string()
    } else {
        s
    }
}

/// A tick label on a logarithmic axis: three significant digits at most.
pub fn log_tick_label(v: f64) -> String {
    if v <= 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    if !(1e-3..1e5).contains(&v) {
        return format!("{v:.0e}");
    }
    let decimals = (2 - v.log10().floor() as i32).clamp(0, 6) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// A logarithmic axis covering `lo..hi` (both > 0), widened to whole
/// decades so that at least two decades carry a labelled tick (plotters' own
/// log axis labelled a single tick on a narrow range). Labelled ticks at
/// every decade, and at 2× and 5× when the axis spans at most two decades;
/// light grid lines at the other integers × decade.
pub fn log_axis(lo: f64, hi: f64) -> plotters::coord::combinators::WithKeyPoints<LogCoord<f64>> {
    let (lo, hi) = if lo > 0.0 && hi.is_finite() && hi > lo {
        (lo, hi)
    } else if lo > 0.0 && lo.is_finite() {
        (lo, lo * 10.0)
    } else {
        (1e-3, 1.0)
    };
    let a = lo.log10().floor() as i32;
    let b = (hi.log10().ceil() as i32).max(a + 1);
    // Exact decimal values (10f64.powi(-3) is 0.0010000000000000002).
    let at = |m: u32, e: i32| -> f64 { format!("{m}e{e}").parse().expect("a number") };
    let dense = b - a <= 2;
    let mut bold = Vec::new();
    let mut light = Vec::new();
    for e in a..=b {
        bold.push(at(1, e));
        if e < b {
            for m in 2..=9 {
                if dense && (m == 2 || m == 5) {
                    bold.push(at(m, e));
                } else {
                    light.push(at(m, e));
                }
            }
        }
    }
    (at(1, a)..at(1, b))
        .log_scale()
        .with_key_points(bold)
        .with_light_points(light)
}

fn bounds(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    if hi - lo < 1e-12 {
        let half = (0.1 * lo.abs()).max(1e-3);
        return (lo - half, hi + half);
    }
    let pad = 0.05 * (hi - lo);
    (lo - pad, hi + pad)
}

/// The white page with the caption; returns (plot area, legend column).
fn page<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, title: &str) -> Result<(Area<DB>, Area<DB>), String> {
    root.fill(&WHITE).map_err(err)?;
    let body = root.titled(title, ("sans-serif", CAPTION_PX)).map_err(err)?;
    let width = body.dim_in_pixel().0;
    Ok(body.split_horizontally(width.saturating_sub(LEGEND_W)))
}

/// The chart's axes: descriptions and tick fonts in one style.
fn builder<'a, 'b, DB: DrawingBackend>(area: &'a DrawingArea<DB, Shift>) -> ChartBuilder<'a, 'b, DB> {
    let mut b = ChartBuilder::on(area);
    b.margin(12).x_label_area_size(50).y_label_area_size(80);
    b
}

macro_rules! mesh {
    ($chart:expr, $x_desc:expr, $y_desc:expr) => {
        $chart
            .configure_mesh()
            .x_desc($x_desc)
            .y_desc($y_desc)
            .label_style(("sans-serif", TICK_PX))
            .axis_desc_style(("sans-serif", DESC_PX))
            .light_line_style(RGBColor(244, 244, 244))
            .bold_line_style(RGBColor(215, 215, 215))
    };
}

/// An axis of numbered slots (targets, bars): linear over `range` with
/// ticks exactly at `keys`, whatever the axis length (plotters' own f64 axis
/// picks "nice" ticks, which for 1 slot are fractions and for 21 skip some).
struct Slots {
    inner: plotters::coord::types::RangedCoordf64,
    keys: Vec<f64>,
}

impl Slots {
    fn new(range: std::ops::Range<f64>, keys: Vec<f64>) -> Slots {
        Slots {
            inner: range.into(),
            keys,
        }
    }
}

impl Ranged for Slots {
    type FormatOption = plotters::coord::ranged1d::NoDefaultFormatting;
    type ValueType = f64;
    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.inner.map(value, limit)
    }
    fn key_points<Hint: plotters::coord::ranged1d::KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            Vec::new()
        } else {
            self.keys.clone()
        }
    }
    fn range(&self) -> std::ops::Range<f64> {
        self.inner.range()
    }
}

impl plotters::coord::ranged1d::ValueFormatter<f64> for Slots {
    fn format(value: &f64) -> String {
        format!("{value}")
    }
}

/// A measured spectrum: the mean with a ±1 SD band and each raw sample.
pub fn spectrum_chart(
    title: &str,
    wavelength_nm: &[f64],
    mean: Option<&[f64]>,
    sd: Option<&[f64]>,
    samples: &[Vec<f64>],
) -> ChartResult {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (W, H)).into_drawing_area();
        let (plot, legend_area) = page(&root, title)?;
        let all = samples.iter().flatten().chain(mean.into_iter().flatten()).copied();
        let (_, hi) = bounds(all.chain(std::iter::once(0.0)));
        let hi = hi.max(1e-12);
        let (x0, x1) = (
            wavelength_nm.first().copied().unwrap_or(380.0),
            wavelength_nm.last().copied().unwrap_or(780.0),
        );
        let mut chart = builder(&plot).build_cartesian_2d(x0..x1, 0.0..hi).map_err(err)?;
        mesh!(chart, "wavelength (nm)", "spectral radiance (W·sr⁻¹·m⁻²·nm⁻¹)")
            .x_label_formatter(&|v| tick_label(*v, x1 - x0))
            .y_label_formatter(&|v| tick_label(*v, hi))
            .draw()
            .map_err(err)?;
        let mut legend = Vec::new();
        let raw = RGBColor(86, 180, 233);
        for s in samples {
            chart
                .draw_series(LineSeries::new(
                    wavelength_nm.iter().copied().zip(s.iter().copied()),
                    raw.mix(0.7).stroke_width(1),
                ))
                .map_err(err)?;
        }
        if !samples.is_empty() {
            legend.push(LegendEntry {
                name: format!("raw samples ({})", samples.len()),
                glyph: Glyph::Line(raw, 1),
            });
        }
        if let (Some(m), Some(sd)) = (mean, sd) {
            let upper = wavelength_nm
                .iter()
                .zip(m.iter().zip(sd))
                .map(|(w, (m, s))| (*w, m + s));
            let lower = wavelength_nm
                .iter()
                .zip(m.iter().zip(sd))
                .map(|(w, (m, s))| (*w, m - s))
                .rev();
            let band: Vec<(f64, f64)> = upper.chain(lower).collect();
            let band_colour = RGBColor(205, 205, 205);
            chart
                .draw_series(std::iter::once(Polygon::new(band, band_colour.filled())))
                .map_err(err)?;
            legend.push(LegendEntry {
                name: "±1 SD".into(),
                glyph: Glyph::Band(band_colour),
            });
        }
        if let Some(m) = mean {
            chart
                .draw_series(LineSeries::new(
                    wavelength_nm.iter().copied().zip(m.iter().copied()),
                    BLACK.stroke_width(2),
                ))
                .map_err(err)?;
            legend.push(LegendEntry {
                name: "mean".into(),
                glyph: Glyph::Line(BLACK, 2),
            });
        }
        draw_legend(&legend_area, &legend)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// A measured reflectance: ρ(λ) with its ±1 and ±2 standard-uncertainty
/// bands, the line ρ = 1, and the wavelengths flagged above 1 (or below 0)
/// marked in red.
pub fn reflectance_chart(title: &str, wavelength_nm: &[f64], rho: &[f64], u: &[f64]) -> ChartResult {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (W, H)).into_drawing_area();
        let (plot, legend_area) = page(&root, title)?;
        let upper = rho.iter().zip(u).map(|(r, u)| r + 2.0 * u);
        let lower = rho.iter().zip(u).map(|(r, u)| r - 2.0 * u);
        let (lo, hi) = bounds(upper.chain(lower).chain([0.0, 1.05]));
        let (x0, x1) = (
            wavelength_nm.first().copied().unwrap_or(380.0),
            wavelength_nm.last().copied().unwrap_or(780.0),
        );
        let mut chart = builder(&plot).build_cartesian_2d(x0..x1, lo..hi).map_err(err)?;
        mesh!(chart, "wavelength (nm)", "reflectance factor ρ")
            .x_label_formatter(&|v| tick_label(*v, x1 - x0))
            .y_label_formatter(&|v| tick_label(*v, hi - lo))
            .draw()
            .map_err(err)?;
        let mut legend = Vec::new();
        for (k, colour) in [(2.0, RGBColor(225, 225, 225)), (1.0, RGBColor(180, 180, 180))] {
            let up = wavelength_nm
                .iter()
                .zip(rho.iter().zip(u))
                .map(|(w, (r, u))| (*w, r + k * u));
            let down = wavelength_nm
                .iter()
                .zip(rho.iter().zip(u))
                .map(|(w, (r, u))| (*w, r - k * u))
                .rev();
            let band: Vec<(f64, f64)> = up.chain(down).collect();
            chart
                .draw_series(std::iter::once(Polygon::new(band, colour.filled())))
                .map_err(err)?;
            legend.push(LegendEntry {
                name: format!("±{k} u (k = 1 standard uncertainty)"),
                glyph: Glyph::Band(colour),
            });
        }
        chart
            .draw_series(LineSeries::new(
                [(x0, 1.0), (x1, 1.0)],
                RGBColor(120, 120, 120).stroke_width(1),
            ))
            .map_err(err)?;
        chart
            .draw_series(LineSeries::new(
                wavelength_nm.iter().copied().zip(rho.iter().copied()),
                BLACK.stroke_width(2),
            ))
            .map_err(err)?;
        legend.push(LegendEntry {
            name: "ρ(λ) measured".into(),
            glyph: Glyph::Line(BLACK, 2),
        });
        let red = RGBColor(213, 94, 0);
        let flagged: Vec<(f64, f64)> = wavelength_nm
            .iter()
            .zip(rho)
            .filter(|(_, r)| !(0.0..=1.0).contains(*r))
            .map(|(w, r)| (*w, *r))
            .collect();
        if !flagged.is_empty() {
            chart
                .draw_series(flagged.iter().map(|p| Circle::new(*p, 4, red.filled())))
                .map_err(err)?;
            legend.push(LegendEntry {
                name: format!("outside [0, 1] ({}), flagged, not clipped", flagged.len()),
                glyph: Glyph::Line(red, 3),
            });
        }
        draw_legend(&legend_area, &legend)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// The spectral locus of `observer` (x,y of each tabulated wavelength).
fn spectral_locus(observer: Observer) -> Vec<(f64, (f64, f64))> {
    let cmf = Cmf::of(observer);
    cmf.grid()
        .wavelengths()
        .iter()
        .filter(|&&nm| (380.0..=700.0).contains(&nm))
        .filter_map(|&nm| {
            let b = cmf.at(nm);
            (b.iter().sum::<f64>() > 1e-9).then(|| {
                let xy = Xyz::from_array(b).chromaticity();
                (nm, (xy.x, xy.y))
            })
        })
        .collect()
}

/// The x,y chromaticity diagram for `observer`: on the left the whole
/// spectral locus (380–700 nm, closed by the purple line) with the sRGB and
/// RADIANCE RGB gamuts and the data, on the right the same zoomed on the
/// data; the legend beside both. Series are [`ScatterSeries`]: a coding's
/// results, or the measurement (drawn last); `connect` joins a profile's
/// points (the cylinder's heights).
///
/// Approximation: the gamuts' primaries are their published CIE 1931 x,y;
/// on a Judd–Vos diagram they are drawn at the same x,y (the primaries'
/// spectra, which a Judd–Vos x,y would need, are not defined by the standards).
pub fn chromaticity_chart(title: &str, observer: Observer, series: &[ScatterSeries]) -> ChartResult {
    let locus = spectral_locus(observer);
    let has_data = series.iter().any(|s| !s.points.is_empty());
    let (zx, zy) = {
        let xs = bounds(series.iter().flat_map(|s| s.points.iter().map(|p| p.0)));
        let ys = bounds(series.iter().flat_map(|s| s.points.iter().map(|p| p.1)));
        let half = ((xs.1 - xs.0).max(ys.1 - ys.0) / 2.0).max(0.005);
        let (cx, cy) = ((xs.0 + xs.1) / 2.0, (ys.0 + ys.1) / 2.0);
        ((cx - half, cx + half), (cy - half, cy + half))
    };
    let gamuts = [
        (RgbSpace::SRGB, "sRGB gamut", false),
        (RgbSpace::RADIANCE, "RADIANCE RGB gamut", true),
    ];
    let grey = RGBColor(100, 100, 100);
    let (panel, legend_w) = (440u32, LEGEND_W);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (2 * panel + legend_w, panel + 40)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let body = root
            .titled(
                &format!("{title} — {} observer", observer_name(observer)),
                ("sans-serif", CAPTION_PX),
            )
            .map_err(err)?;
        let (panels, legend_area) = body.split_horizontally(2 * panel);
        let (left, right) = panels.split_horizontally(panel);
        let views = [
            (&left, (0.0, 0.8), (0.0, 0.9), "whole diagram"),
            (&right, zx, zy, "zoomed on the data"),
        ];
        for (k, (area, (x0, x1), (y0, y1), caption)) in views.into_iter().enumerate() {
            if k == 1 && !has_data {
                continue;
            }
            let mut chart = ChartBuilder::on(area)
                .caption(caption, ("sans-serif", DESC_PX))
                .margin(10)
                .x_label_area_size(45)
                .y_label_area_size(60)
                .build_cartesian_2d(x0..x1, y0..y1)
                .map_err(err)?;
            mesh!(chart, "x (chromaticity, unitless)", "y (chromaticity, unitless)")
                .x_labels(6)
                .y_labels(6)
                .x_label_formatter(&|v| tick_label(*v, x1 - x0))
                .y_label_formatter(&|v| tick_label(*v, y1 - y0))
                .draw()
                .map_err(err)?;
            let mut closed: Vec<(f64, f64)> = locus.iter().map(|l| l.1).collect();
            closed.push(locus[0].1);
            chart
                .draw_series(LineSeries::new(closed, BLACK.stroke_width(1)))
                .map_err(err)?;
            if k == 0 {
                for &(nm, p) in locus
                    .iter()
                    .filter(|(nm, _)| [460.0, 480.0, 500.0, 520.0, 540.0, 560.0, 580.0, 600.0, 620.0].contains(nm))
                {
                    let dx = if nm < 510.0 { -34 } else { 6 };
                    chart
                        .draw_series(std::iter::once(
                            EmptyElement::at(p)
                                + Circle::new((0, 0), 2, BLACK.filled())
                                + Text::new(format!("{nm:.0}"), (dx, -6), ("sans-serif", 12).into_font()),
                        ))
                        .map_err(err)?;
                }
            }
            for (space, _, dashed) in gamuts {
                let tri = vec![
                    (space.red.x, space.red.y),
                    (space.green.x, space.green.y),
                    (space.blue.x, space.blue.y),
                    (space.red.x, space.red.y),
                ];
                if dashed {
                    chart
                        .draw_series(DashedLineSeries::new(tri, 6, 5, grey.stroke_width(2)))
                        .map_err(err)?;
                } else {
                    chart
                        .draw_series(LineSeries::new(tri, grey.stroke_width(1)))
                        .map_err(err)?;
                }
            }
            if k == 0 && has_data {
                // Where the right panel looks.
                chart
                    .draw_series(std::iter::once(Rectangle::new(
                        [(zx.0, zy.0), (zx.1, zy.1)],
                        RGBColor(200, 0, 0).stroke_width(1),
                    )))
                    .map_err(err)?;
            }
            draw_scatter(&mut chart, series, None, k == 1)?;
        }
        let mut legend = vec![LegendEntry {
            name: format!("spectral locus ({})", observer_name(observer)),
            glyph: Glyph::Line(BLACK, 1),
        }];
        for (_, name, dashed) in gamuts {
            legend.push(LegendEntry {
                name: name.into(),
                glyph: if dashed {
                    Glyph::Dashed(grey)
                } else {
                    Glyph::Line(grey, 1)
                },
            });
        }
        if has_data {
            legend.push(LegendEntry {
                name: "zoomed region".into(),
                glyph: Glyph::Line(RGBColor(200, 0, 0), 1),
            });
        }
        legend.extend(scatter_legend(series));
        draw_legend(&legend_area, &legend)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// A y-against-x line chart of several named series with optional error bars.
pub struct LineSeriesData {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    /// ±1 SD (or SE) per point, drawn as error bars when present.
    pub errors: Option<Vec<f64>>,
}

fn line_y_bounds(series: &[LineSeriesData]) -> (f64, f64) {
    bounds(series.iter().flat_map(|s| {
        s.points.iter().enumerate().flat_map(move |(i, p)| {
            let e = s.errors.as_ref().and_then(|e| e.get(i).copied()).unwrap_or(0.0);
            [p.1 - e, p.1 + e]
        })
    }))
}

/// Pareto charts, interreflection curves and the like: y against x, x linear
/// or logarithmic.
pub fn line_chart(title: &str, x_desc: &str, y_desc: &str, series: &[LineSeriesData], log_x: bool) -> ChartResult {
    let xs = bounds(series.iter().flat_map(|s| s.points.iter().map(|p| p.0)));
    let ys = line_y_bounds(series);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (W, H)).into_drawing_area();
        let (plot, legend_area) = page(&root, title)?;
        if log_x {
            let lo = series
                .iter()
                .flat_map(|s| s.points.iter().map(|p| p.0))
                .filter(|v| *v > 0.0)
                .fold(f64::INFINITY, f64::min);
            let lo = if lo.is_finite() { lo } else { 1e-3 };
            let hi = xs.1.max(lo);
            let mut chart = builder(&plot)
                .build_cartesian_2d(log_axis(lo, hi), ys.0..ys.1)
                .map_err(err)?;
            mesh!(chart, x_desc, y_desc)
                .x_label_formatter(&|v| log_tick_label(*v))
                .y_label_formatter(&|v| tick_label(*v, ys.1 - ys.0))
                .draw()
                .map_err(err)?;
            draw_lines(&mut chart, series)?;
        } else {
            let mut chart = builder(&plot).build_cartesian_2d(xs.0..xs.1, ys.0..ys.1).map_err(err)?;
            mesh!(chart, x_desc, y_desc)
                .x_label_formatter(&|v| tick_label(*v, xs.1 - xs.0))
                .y_label_formatter(&|v| tick_label(*v, ys.1 - ys.0))
                .draw()
                .map_err(err)?;
            draw_lines(&mut chart, series)?;
        }
        draw_legend(&legend_area, &line_legend(series))?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// A profile along a scene's targets: series' x are target numbers
/// 1…n (the scene's order), labelled with the targets' ids on the x axis
/// (every k-th when there are many). When the positive values span more
/// than two decades (the Cornell box's light beside its walls) the y axis
/// is logarithmic, and the axis description says so.
pub fn profile_chart(
    title: &str,
    targets: &[String],
    x_desc: &str,
    y_desc: &str,
    series: &[LineSeriesData],
) -> ChartResult {
    let n = targets.len().max(1);
    let every = n.div_ceil(11);
    let keys: Vec<f64> = (1..=n).step_by(every).map(|i| i as f64).collect();
    let ys = line_y_bounds(series);
    let x_label = |v: &f64| {
        let i = v.round() as usize;
        if (v - v.round()).abs() < 1e-6 && (1..=targets.len()).contains(&i) {
            targets[i - 1].clone()
        } else {
            String::new()
        }
    };
    let positive = series.iter().flat_map(|s| s.points.iter().map(|p| p.1));
    let (lo, hi) = positive.fold((f64::INFINITY, 0.0f64), |(lo, hi), y| {
        if y > 0.0 {
            (lo.min(y), hi.max(y))
        } else {
            (lo, hi)
        }
    });
    let all_positive = series.iter().all(|s| s.points.iter().all(|p| p.1 > 0.0));
    let log_y = all_positive && lo.is_finite() && hi / lo > 100.0;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (W, H)).into_drawing_area();
        let (plot, legend_area) = page(&root, title)?;
        let x = Slots::new(0.5..n as f64 + 0.5, keys);
        if log_y {
            let y_desc = format!("{y_desc} (log scale)");
            let mut chart = builder(&plot).build_cartesian_2d(x, log_axis(lo, hi)).map_err(err)?;
            mesh!(chart, x_desc, y_desc.as_str())
                .x_label_formatter(&x_label)
                .y_label_formatter(&|v| log_tick_label(*v))
                .draw()
                .map_err(err)?;
            draw_lines(&mut chart, series)?;
        } else {
            let mut chart = builder(&plot).build_cartesian_2d(x, ys.0..ys.1).map_err(err)?;
            mesh!(chart, x_desc, y_desc)
                .x_label_formatter(&x_label)
                .y_label_formatter(&|v| tick_label(*v, ys.1 - ys.0))
                .draw()
                .map_err(err)?;
            draw_lines(&mut chart, series)?;
        }
        draw_legend(&legend_area, &line_legend(series))?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// Series in drawing order: others first, the measurement last.
fn measurement_last<T>(series: &[T], name: impl Fn(&T) -> &str) -> Vec<(usize, &T)> {
    let mut order: Vec<(usize, &T)> = series.iter().enumerate().collect();
    order.sort_by_key(|(_, s)| is_measurement(name(s)));
    order
}

/// Styles for series by name, in the series' own order.
fn styles<T>(series: &[T], name: impl Fn(&T) -> &str) -> Vec<Style> {
    let mut other = 0;
    series.iter().map(|s| series_style(name(s), &mut other)).collect()
}

fn line_legend(series: &[LineSeriesData]) -> Vec<LegendEntry> {
    let st = styles(series, |s| s.name.as_str());
    series
        .iter()
        .zip(st)
        .map(|(s, style)| LegendEntry {
            name: s.name.clone(),
            glyph: Glyph::LineMarker(style),
        })
        .collect()
}

fn draw_lines<'a, DB: DrawingBackend + 'a, X: Ranged<ValueType = f64>, Y: Ranged<ValueType = f64>>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    series: &[LineSeriesData],
) -> Result<(), String> {
    let st = styles(series, |s| s.name.as_str());
    for (i, s) in measurement_last(series, |s| s.name.as_str()) {
        let style = st[i];
        let width = if is_measurement(&s.name) { 3 } else { 2 };
        chart
            .draw_series(LineSeries::new(s.points.clone(), style.colour.stroke_width(width)))
            .map_err(err)?;
        if let Some(errors) = &s.errors {
            let bars: Vec<(f64, f64, f64)> = s
                .points
                .iter()
                .zip(errors)
                .map(|(p, e)| (p.0, p.1 - e, p.1 + e))
                .collect();
            draw_error_bars(chart, &bars, style.colour, 4)?;
        }
        draw_markers(chart, &s.points, style)?;
    }
    Ok(())
}

/// One bar of a bar chart with its ±1 SD.
pub struct Bar {
    pub label: String,
    pub value: f64,
    pub sd: Option<f64>,
}

/// Bars with ±1 SD error bars (rms_rel and mean ΔE per coding), one slot
/// per bar and none after the last; a coding's bar has its coding's colour.
pub fn bar_chart(title: &str, y_desc: &str, bars: &[Bar]) -> ChartResult {
    let hi = bars
        .iter()
        .map(|b| b.value + b.sd.unwrap_or(0.0))
        .fold(0.0, f64::max)
        .max(1e-9)
        * 1.1;
    let n = bars.len().max(1);
    let keys: Vec<f64> = (0..n).map(|i| i as f64).collect();
    let st = styles(bars, |b| b.label.as_str());
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let body = root.titled(title, ("sans-serif", CAPTION_PX)).map_err(err)?;
        let mut chart = builder(&body)
            .build_cartesian_2d(Slots::new(-0.5..n as f64 - 0.5, keys), 0.0..hi)
            .map_err(err)?;
        mesh!(chart, "coding", y_desc)
            .disable_x_mesh()
            .x_label_formatter(&|v| {
                let i = v.round();
                if (v - i).abs() < 1e-6 && i >= 0.0 {
                    bars.get(i as usize).map(|b| b.label.clone()).unwrap_or_default()
                } else {
                    String::new()
                }
            })
            .y_label_formatter(&|v| tick_label(*v, hi))
            .draw()
            .map_err(err)?;
        for (i, b) in bars.iter().enumerate() {
            let x = i as f64;
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(x - 0.35, 0.0), (x + 0.35, b.value)],
                    st[i].colour.filled(),
                )))
                .map_err(err)?;
            if let Some(sd) = b.sd {
                draw_error_bars(&mut chart, &[(x, b.value - sd, b.value + sd)], BLACK, 8)?;
            }
        }
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// The colour of a grid cell: green → yellow up to `threshold`, orange →
/// dark red above it (saturating at 10 × threshold).
fn grid_colour(value: f64, threshold: f64) -> RGBColor {
    let lerp = |a: RGBColor, b: RGBColor, t: f64| {
        let t = t.clamp(0.0, 1.0);
        let m = |x: u8, y: u8| (x as f64 + (y as f64 - x as f64) * t).round() as u8;
        RGBColor(m(a.0, b.0), m(a.1, b.1), m(a.2, b.2))
    };
    if !value.is_finite() {
        return RGBColor(200, 200, 200);
    }
    if value <= threshold {
        lerp(RGBColor(26, 152, 80), RGBColor(254, 224, 139), value / threshold)
    } else {
        lerp(
            RGBColor(244, 109, 67),
            RGBColor(120, 0, 20),
            (value / threshold).log10(),
        )
    }
}

/// A heat map: `values[row][col]` as coloured cells with their value printed,
/// cells above `threshold` outlined in black (failure maps: ΔE per patch and
/// coding). Columns are labelled vertically above the grid.
pub fn grid_chart(
    title: &str,
    row_labels: &[String],
    col_labels: &[String],
    values: &[Vec<f64>],
    threshold: f64,
) -> ChartResult {
    if values.len() != row_labels.len() || values.iter().any(|r| r.len() != col_labels.len()) {
        return Err(format!(
            "grid chart: {} row labels and {} column labels for a {}-row grid of unequal or mismatched rows",
            row_labels.len(),
            col_labels.len(),
            values.len()
        ));
    }
    let (cell_w, cell_h) = (36i32, 22i32);
    let label_w = 8 * row_labels.iter().map(|l| l.chars().count()).max().unwrap_or(0) as i32 + 12;
    let head_h = 8 * col_labels.iter().map(|l| l.chars().count()).max().unwrap_or(0) as i32 + 50;
    let (x0, y0) = (label_w, head_h);
    let width = (x0 + cell_w * col_labels.len() as i32 + 20).max(480) as u32;
    let height = (y0 + cell_h * row_labels.len() as i32 + 50) as u32;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        root.draw(&Text::new(title.to_string(), (10, 8), ("sans-serif", 18).into_font()))
            .map_err(err)?;
        let col_style = ("sans-serif", 12).into_font().transform(FontTransform::Rotate270);
        for (c, label) in col_labels.iter().enumerate() {
            let x = x0 + cell_w * c as i32 + cell_w / 2 - 6;
            root.draw(&Text::new(label.clone(), (x, y0 - 6), col_style.clone()))
                .map_err(err)?;
        }
        for (r, label) in row_labels.iter().enumerate() {
            let y = y0 + cell_h * r as i32;
            root.draw(&Text::new(label.clone(), (6, y + 5), ("sans-serif", 11).into_font()))
                .map_err(err)?;
            for (c, &v) in values[r].iter().enumerate() {
                let x = x0 + cell_w * c as i32;
                let corners = [(x, y), (x + cell_w, y + cell_h)];
                root.draw(&Rectangle::new(corners, grid_colour(v, threshold).filled()))
                    .map_err(err)?;
                if v > threshold {
                    let inner = [(x + 1, y + 1), (x + cell_w - 1, y + cell_h - 1)];
                    root.draw(&Rectangle::new(inner, BLACK.stroke_width(2))).map_err(err)?;
                }
                let text = if v < 10.0 { format!("{v:.1}") } else { format!("{v:.0}") };
                let colour = if v > 2.0 * threshold { WHITE } else { BLACK };
                root.draw(&Text::new(
                    text,
                    (x + 4, y + 5),
                    ("sans-serif", 11).into_font().color(&colour),
                ))
                .map_err(err)?;
            }
        }
        let ly = y0 + cell_h * row_labels.len() as i32 + 15;
        let legend = [
            (0.0, "0".to_string()),
            (0.5 * threshold, format!("{}", 0.5 * threshold)),
            (threshold, format!("{threshold} (threshold)")),
            (3.0 * threshold, format!("{} (fails, outlined)", 3.0 * threshold)),
            (10.0 * threshold, format!("≥ {}", 10.0 * threshold)),
        ];
        let mut x = x0;
        for (v, label) in legend {
            root.draw(&Rectangle::new(
                [(x, ly), (x + 16, ly + 14)],
                grid_colour(v, threshold).filled(),
            ))
            .map_err(err)?;
            root.draw(&Text::new(
                label.clone(),
                (x + 20, ly + 2),
                ("sans-serif", 11).into_font(),
            ))
            .map_err(err)?;
            x += 28 + 7 * label.chars().count() as i32;
        }
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// A named set of points for [`scatter_chart`], joined by a line or not.
pub struct ScatterSeries {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    /// Join the points in order (a front, a threshold) instead of markers only.
    pub connect: bool,
}

/// Points against x (seconds, cost …), each axis linear or logarithmic
/// (`log: (x, y)`; a log axis needs positive values): speed/accuracy charts
/// with their Pareto front. Markers are drawn for every series.
pub fn scatter_chart(
    title: &str,
    x_desc: &str,
    y_desc: &str,
    series: &[ScatterSeries],
    log: (bool, bool),
) -> ChartResult {
    scatter_chart_labelled(title, x_desc, y_desc, series, &[], log)
}

/// [`scatter_chart`] with a text label beside points: `labels[i][j]` for
/// point j of series i (missing or empty: no label).
pub fn scatter_chart_labelled(
    title: &str,
    x_desc: &str,
    y_desc: &str,
    series: &[ScatterSeries],
    labels: &[Vec<String>],
    log: (bool, bool),
) -> ChartResult {
    scatter_chart_with_spread(title, x_desc, y_desc, series, labels, &[], log)
}

/// [`scatter_chart_labelled`] with a horizontal whisker through points:
/// `x_spread[i][j] = (low, high)` of point j of series i (a timing's fastest
/// and slowest repeat; missing: none).
pub fn scatter_chart_with_spread(
    title: &str,
    x_desc: &str,
    y_desc: &str,
    series: &[ScatterSeries],
    labels: &[Vec<String>],
    x_spread: &[Vec<(f64, f64)>],
    log: (bool, bool),
) -> ChartResult {
    let spread_x = x_spread.iter().flatten().flat_map(|&(a, b)| [a, b]);
    let all_x = || series.iter().flat_map(|s| s.points.iter().map(|p| p.0));
    let xs = bounds(all_x().chain(spread_x.clone()));
    let ys = bounds(series.iter().flat_map(|s| s.points.iter().map(|p| p.1)));
    // A log axis from the positive values (whole decades, see `log_axis`).
    let positive = |vals: &mut dyn Iterator<Item = f64>| {
        let (lo, hi) = vals
            .filter(|v| *v > 0.0 && v.is_finite())
            .fold((f64::INFINITY, 0.0f64), |(l, h), v| (l.min(v), h.max(v)));
        (lo, hi)
    };
    let lx = positive(&mut all_x().chain(spread_x));
    let ly = positive(&mut series.iter().flat_map(|s| s.points.iter().map(|p| p.1)));
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (W, H)).into_drawing_area();
        let (plot, legend_area) = page(&root, title)?;
        macro_rules! draw {
            ($x:expr, $y:expr, $xf:expr, $yf:expr) => {{
                let mut chart = builder(&plot).build_cartesian_2d($x, $y).map_err(err)?;
                mesh!(chart, x_desc, y_desc)
                    .x_labels(6)
                    .y_labels(6)
                    .x_label_formatter(&$xf)
                    .y_label_formatter(&$yf)
                    .draw()
                    .map_err(err)?;
                let st = styles(series, |s| s.name.as_str());
                for (i, s) in series.iter().enumerate() {
                    let Some(spread) = x_spread.get(i) else { continue };
                    chart
                        .draw_series(s.points.iter().zip(spread).map(|(p, &(a, b))| {
                            PathElement::new(vec![(a, p.1), (b, p.1)], st[i].colour.stroke_width(2))
                        }))
                        .map_err(err)?;
                }
                draw_scatter(&mut chart, series, Some(labels), true)?;
            }};
        }
        let lin_x = |v: &f64| tick_label(*v, xs.1 - xs.0);
        let lin_y = |v: &f64| tick_label(*v, ys.1 - ys.0);
        let log_l = |v: &f64| log_tick_label(*v);
        match log {
            (true, true) => draw!(log_axis(lx.0, lx.1), log_axis(ly.0, ly.1), log_l, log_l),
            (true, false) => draw!(log_axis(lx.0, lx.1), ys.0..ys.1, log_l, lin_y),
            (false, true) => draw!(xs.0..xs.1, log_axis(ly.0, ly.1), lin_x, log_l),
            (false, false) => draw!(xs.0..xs.1, ys.0..ys.1, lin_x, lin_y),
        }
        draw_legend(&legend_area, &scatter_legend(series))?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

fn scatter_legend(series: &[ScatterSeries]) -> Vec<LegendEntry> {
    let st = styles(series, |s| s.name.as_str());
    series
        .iter()
        .zip(st)
        .map(|(s, style)| LegendEntry {
            name: s.name.clone(),
            glyph: if s.connect {
                Glyph::LineMarker(style)
            } else {
                Glyph::Marker(style)
            },
        })
        .collect()
}

/// Every series' markers (and lines when `connect`), the measurement last;
/// `labels` beside points; `full_size: false` draws smaller markers (an
/// overview panel where the data are a cluster).
fn draw_scatter<'a, DB: DrawingBackend + 'a, X: Ranged<ValueType = f64>, Y: Ranged<ValueType = f64>>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    series: &[ScatterSeries],
    labels: Option<&[Vec<String>]>,
    full_size: bool,
) -> Result<(), String> {
    let st = styles(series, |s| s.name.as_str());
    for (i, s) in measurement_last(series, |s| s.name.as_str()) {
        let mut style = st[i];
        if !full_size {
            style.size = (style.size / 2).max(2);
        }
        if s.connect {
            let width = if is_measurement(&s.name) { 2 } else { 1 };
            chart
                .draw_series(LineSeries::new(s.points.clone(), style.colour.stroke_width(width)))
                .map_err(err)?;
        }
        draw_markers(chart, &s.points, style)?;
        if let Some(names) = labels.and_then(|l| l.get(i)) {
            let font = ("sans-serif", 13).into_font().color(&RGBColor(40, 40, 40));
            chart
                .draw_series(s.points.iter().zip(names).filter(|(_, n)| !n.is_empty()).map(|(p, n)| {
                    EmptyElement::at(*p) + Text::new(n.clone(), (style.size + 4, -style.size - 12), font.clone())
                }))
                .map_err(err)?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::Grid;

    /// Every `<tag …>content</tag>` (or self-closed) of an SVG: (attributes, trimmed content).
    fn elements(svg: &str, tag: &str) -> Vec<(String, String)> {
        let open = format!("<{tag} ");
        let mut out = Vec::new();
        let mut rest = svg;
        while let Some(i) = rest.find(&open) {
            rest = &rest[i + open.len()..];
            let end = rest.find('>').unwrap();
            let attrs = rest[..end].to_string();
            let content = if attrs.ends_with('/') {
                String::new()
            } else {
                let close = format!("</{tag}>");
                let c = rest.find(&close).unwrap();
                rest[end + 1..c].trim().to_string()
            };
            out.push((attrs, content));
        }
        out
    }

    fn attr(attrs: &str, name: &str) -> Option<String> {
        let key = format!(" {name}=\"");
        let i = format!(" {attrs}").find(&key)? + key.len() - 1;
        let v = &attrs[i..];
        Some(v[..v.find('"')?].to_string())
    }

    fn num(attrs: &str, name: &str) -> f64 {
        attr(attrs, name).and_then(|v| v.parse().ok()).unwrap_or(f64::NAN)
    }

    fn texts(svg: &str) -> Vec<(f64, f64, String)> {
        elements(svg, "text")
            .into_iter()
            .map(|(a, c)| (num(&a, "x"), num(&a, "y"), c))
            .collect()
    }

    fn series(name: &str, points: &[(f64, f64)]) -> LineSeriesData {
        LineSeriesData {
            name: name.into(),
            points: points.to_vec(),
            errors: None,
        }
    }

    fn scatter(name: &str, points: &[(f64, f64)]) -> ScatterSeries {
        ScatterSeries {
            name: name.into(),
            points: points.to_vec(),
            connect: false,
        }
    }

    #[test]
    fn charts_are_svg_with_their_labels() {
        let wl: Vec<f64> = Grid::pr650().wavelengths().to_vec();
        let mean: Vec<f64> = wl.iter().map(|w| 1e-3 * (w / 780.0)).collect();
        let sd = vec![1e-5; wl.len()];
        let svg = spectrum_chart("patch", &wl, Some(&mean), Some(&sd), std::slice::from_ref(&mean)).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("wavelength (nm)") && svg.contains("mean"));
        let xy = chromaticity_chart(
            "chromaticity",
            Observer::JuddVos,
            &[scatter("measured", &[(0.31, 0.33)])],
        )
        .unwrap();
        assert!(xy.contains("spectral locus") && xy.contains("sRGB gamut") && xy.contains("RADIANCE RGB gamut"));
        let bars = bar_chart(
            "rms",
            "rms_rel",
            &[Bar {
                label: "rgb".into(),
                value: 0.1,
                sd: Some(0.02),
            }],
        )
        .unwrap();
        assert!(bars.contains("rgb"));
        let mut pareto = series("pareto", &[(0.1, 3.0), (1.0, 1.0)]);
        pareto.errors = Some(vec![0.1, 0.1]);
        let lines = line_chart("speed", "s", "dE", &[pareto], true).unwrap();
        assert!(lines.contains("pareto"));
        let grid = grid_chart(
            "map",
            &["red".into(), "grey".into()],
            &["A rgb".into()],
            &[vec![5.0], vec![0.5]],
            2.0,
        )
        .unwrap();
        assert!(grid.starts_with("<svg") && grid.contains("A rgb") && grid.contains("5.0"));
        assert!(grid_chart("bad", &["r".into()], &[], &[vec![1.0]], 2.0).is_err());
    }

    #[test]
    fn scatter_chart_draws_every_series_name() {
        let series = [
            scatter("candidates", &[(0.1, 2.0), (1.0, 0.5)]),
            ScatterSeries {
                name: "front".into(),
                points: vec![(0.1, 2.0), (1.0, 0.5)],
                connect: true,
            },
        ];
        for log in [(true, true), (true, false), (false, true), (false, false)] {
            let svg = scatter_chart("t", "s", "e", &series, log).unwrap();
            assert!(svg.starts_with("<svg") && svg.contains("candidates") && svg.contains("front"));
        }
    }

    /// The CYLINDER profile plotted target k at x = k − 1 under an axis that
    /// said 1–21: the first point must sit on the first target's tick.
    #[test]
    fn profile_ticks_are_not_shifted_by_one() {
        let targets: Vec<String> = ["h01", "h02", "h03"].map(String::from).to_vec();
        let svg = profile_chart(
            "profile",
            &targets,
            "target",
            "Y (cd/m²)",
            &[series("measured", &[(1.0, 1.0), (2.0, 4.0), (3.0, 9.0)])],
        )
        .unwrap();
        let t = texts(&svg);
        let tick = |id: &str| {
            t.iter()
                .find(|(_, _, c)| c == id)
                .unwrap_or_else(|| panic!("no tick {id}"))
                .0
        };
        // The measurement's markers: black open circles, in x order.
        let marks: Vec<f64> = elements(&svg, "circle")
            .iter()
            .filter(|(a, _)| attr(a, "stroke").as_deref() == Some("#000000") && num(a, "r") == MEASUREMENT_PX as f64)
            .map(|(a, _)| num(a, "cx"))
            .filter(|x| *x < (W - LEGEND_W) as f64)
            .collect();
        assert_eq!(marks.len(), 3, "{svg}");
        for (id, x) in ["h01", "h02", "h03"].iter().zip(&marks) {
            assert!(
                (tick(id) - x).abs() <= 1.0,
                "{id} tick at {} but its point at {x}",
                tick(id)
            );
        }
    }

    /// One target (WHITE's patch) made a zero-width x range whose ticks all read "0.0".
    #[test]
    fn single_target_scene_ticks_are_not_all_zero() {
        let targets = vec!["patch".to_string()];
        let svg = profile_chart(
            "white",
            &targets,
            "target",
            "Y (cd/m²)",
            &[series("measured", &[(1.0, 34.48)]), series("rgb", &[(1.0, 34.55)])],
        )
        .unwrap();
        let t = texts(&svg);
        assert!(
            t.iter().any(|(_, _, c)| c == "patch"),
            "the target is named on its tick"
        );
        let numbers: Vec<&String> = t
            .iter()
            .map(|(_, _, c)| c)
            .filter(|c| c.parse::<f64>().is_ok())
            .collect();
        let distinct: std::collections::BTreeSet<&String> = numbers.iter().copied().collect();
        assert!(distinct.len() >= 3, "y ticks {numbers:?}");
        assert!(!numbers.iter().any(|c| c.as_str() == "0.0"), "{numbers:?}");
        // A line chart of one point: distinct ticks on both axes too.
        let one = line_chart("one", "x (s)", "y (cd/m²)", &[series("rgb", &[(0.0, 0.0)])], false).unwrap();
        let numbers: std::collections::BTreeSet<String> = texts(&one)
            .into_iter()
            .map(|t| t.2)
            .filter(|c| c.parse::<f64>().is_ok())
            .collect();
        assert!(numbers.len() >= 3, "{numbers:?}");
    }

    /// The image viewer's pixel-probe chart (radiances of a few 1e-4
    /// W/(sr·m²·nm)) labelled its ticks 3e-4, 3e-4, 2e-4, 2e-4, …: one
    /// mantissa digit for ticks 5e-5 apart.
    #[test]
    fn small_radiance_tick_labels_repeated() {
        let span = 5.5e-4;
        let labels: Vec<String> = (0..=11).map(|i| tick_label(i as f64 * 5e-5, span)).collect();
        let mut unique = labels.clone();
        unique.dedup();
        assert_eq!(unique, labels, "{labels:?}");
        assert_eq!(tick_label(3.5e-4, span), "3.5e-4");
        assert_eq!(tick_label(2e5, 1e6), "2e5");
    }

    /// A tick read 0.30000000000000004 (plotters' default f64 formatting).
    #[test]
    fn tick_labels_have_no_float_noise() {
        assert_eq!(tick_label(0.30000000000000004, 0.5), "0.30");
        assert_eq!(tick_label(0.1 + 0.2, 0.05), "0.300");
        assert_eq!(tick_label(-1e-17, 0.5), "0.00");
        assert_eq!(log_tick_label(0.30000000000000004), "0.3");
        assert_eq!(log_tick_label(20.000000000000004), "20");
        let data = [
            scatter("measured", &[(0.3, 0.3), (0.33, 0.36)]),
            scatter("rgb", &[(0.31, 0.34)]),
        ];
        let charts = [
            chromaticity_chart("xy", Observer::JuddVos, &data).unwrap(),
            scatter_chart("s", "t (s)", "ΔE", &data, (false, false)).unwrap(),
            scatter_chart("s", "t (s)", "ΔE", &data, (true, true)).unwrap(),
            line_chart(
                "l",
                "x",
                "y",
                &[series("rgb", &[(0.1, 0.3), (0.2, 0.30000000000000004)])],
                false,
            )
            .unwrap(),
        ];
        for svg in &charts {
            for (_, _, c) in texts(svg) {
                if let Some((_, decimals)) = c.split_once('.') {
                    if c.parse::<f64>().is_ok() {
                        assert!(decimals.len() <= 4, "tick `{c}`");
                    }
                }
            }
        }
    }

    fn colour_hex(c: RGBColor) -> String {
        format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2)
    }

    /// The Cornell box's light (9e5 cd/m²) flattened its walls (2e3–2e4)
    /// to a line at zero on a linear axis: beyond two decades the profile's
    /// y axis is logarithmic, and says so.
    #[test]
    fn cornell_light_beside_its_walls_gets_a_log_axis() {
        let targets: Vec<String> = ["wall", "ceiling", "light"].map(String::from).to_vec();
        let wide = profile_chart(
            "p",
            &targets,
            "target",
            "Y (cd/m²)",
            &[series("spectral", &[(1.0, 3.0e3), (2.0, 5.0e2), (3.0, 9.0e5)])],
        )
        .unwrap();
        assert!(wide.contains("Y (cd/m²) (log scale)"), "{wide}");
        let narrow = profile_chart(
            "p",
            &targets,
            "target",
            "Y (cd/m²)",
            &[series("spectral", &[(1.0, 3.0e3), (2.0, 5.0e2), (3.0, 9.0e3)])],
        )
        .unwrap();
        assert!(!narrow.contains("log scale"));
    }

    /// nstep3 was pink in one chart and green in the next: colours went by
    /// series position.
    #[test]
    fn nstep3_has_the_same_colour_in_every_chart() {
        let pink = colour_hex(coding_style("nstep3").unwrap().colour);
        let rgb = colour_hex(coding_style("rgb").unwrap().colour);
        let alone = [scatter("measured", &[(0.31, 0.33)]), scatter("nstep3", &[(0.32, 0.34)])];
        let behind = [
            scatter("measured", &[(0.31, 0.33)]),
            scatter("srgb", &[(0.30, 0.33)]),
            scatter("nstep9", &[(0.31, 0.32)]),
            scatter("nstep3", &[(0.32, 0.34)]),
        ];
        let bars = |names: &[&str]| -> Vec<Bar> {
            names
                .iter()
                .map(|n| Bar {
                    label: n.to_string(),
                    value: 1.0,
                    sd: None,
                })
                .collect()
        };
        let charts = [
            chromaticity_chart("a", Observer::JuddVos, &alone).unwrap(),
            chromaticity_chart("b", Observer::Cie1931, &behind).unwrap(),
            scatter_chart("c", "t (s)", "ΔE", &alone, (true, true)).unwrap(),
            scatter_chart("d", "t (s)", "ΔE", &behind, (false, false)).unwrap(),
            bar_chart("e", "ΔE", &bars(&["nstep3"])).unwrap(),
            bar_chart("f", "ΔE", &bars(&["srgb", "nstep81", "nstep3"])).unwrap(),
            profile_chart("g", &["patch".into()], "t", "Y", &[series("nstep3", &[(1.0, 1.0)])]).unwrap(),
            line_chart(
                "h",
                "s",
                "y",
                &[series("spectral", &[(0.0, 1.0)]), series("nstep3", &[(1.0, 2.0)])],
                false,
            )
            .unwrap(),
        ];
        for (i, svg) in charts.iter().enumerate() {
            assert!(svg.contains(&pink), "chart {i} draws nstep3 without {pink}");
            // No chart here has rgb: its colour must not be handed to another series.
            assert!(!svg.contains(&rgb), "chart {i} uses rgb's {rgb} for another series");
        }
        // The dashboard's and the report's CSS read the same table.
        assert!(coding_css().contains(&format!("--coding-nstep3:{}", pink.to_ascii_lowercase())));
        // An N not in the table takes the nearest tabulated N's style.
        assert_eq!(coding_style("nstep4"), coding_style("nstep3"));
        assert_eq!(coding_style("cie"), None);
    }

    /// The measurement is drawn after every coding, larger and in black.
    #[test]
    fn measurement_is_drawn_last_and_largest() {
        let data = [
            scatter("measured", &[(0.31, 0.33)]),
            scatter("nstep27", &[(0.311, 0.331)]),
            scatter("spectral", &[(0.312, 0.332)]),
        ];
        let svg = scatter_chart("s", "t (s)", "ΔE", &data, (false, false)).unwrap();
        let plot_right = (W - LEGEND_W) as f64;
        let circles: Vec<(String, String)> = elements(&svg, "circle")
            .into_iter()
            .filter(|(a, _)| num(a, "cx") < plot_right)
            .collect();
        let last = circles.last().expect("markers");
        assert_eq!(attr(&last.0, "stroke").as_deref(), Some("#000000"));
        assert!(circles.iter().all(|(a, _)| num(a, "r") <= num(&last.0, "r")));
        assert!(num(&last.0, "r") > MARKER_PX as f64);
    }

    /// Legends were drawn inside the plot, over the data.
    #[test]
    fn legend_is_outside_the_plot_area() {
        let data = [
            scatter("measured", &[(0.31, 0.33), (0.40, 0.45)]),
            scatter("nstep3", &[(0.32, 0.34), (0.41, 0.44)]),
        ];
        for svg in [
            scatter_chart("s", "t (s)", "ΔE", &data, (false, false)).unwrap(),
            line_chart("l", "x", "y", &[series("nstep3", &[(0.0, 1.0), (1.0, 2.0)])], false).unwrap(),
        ] {
            let plot_right = (W - LEGEND_W) as f64;
            let legend = texts(&svg).into_iter().find(|t| t.2 == "nstep3").expect("legend entry");
            assert!(legend.0 > plot_right, "legend text at x = {}", legend.0);
            // Every grid line (the plot area) ends left of the legend column.
            for (a, _) in elements(&svg, "line") {
                assert!(
                    num(&a, "x2").max(num(&a, "x1")) <= plot_right,
                    "grid line into the legend: {a}"
                );
            }
        }
        let xy = chromaticity_chart("xy", Observer::JuddVos, &data).unwrap();
        let width = num(&elements(&xy, "svg")[0].0, "width");
        let legend = texts(&xy).into_iter().find(|t| t.2 == "nstep3").unwrap();
        assert!(legend.0 > width - LEGEND_W as f64);
    }

    /// The spectrum chart added one legend entry per raw sample, all but the
    /// first with an empty name.
    #[test]
    fn no_empty_legend_entries() {
        let wl: Vec<f64> = Grid::pr650().wavelengths().to_vec();
        let mean: Vec<f64> = wl.iter().map(|w| 1e-3 * (w / 780.0)).collect();
        let sd = vec![1e-5; wl.len()];
        let samples = vec![mean.clone(), mean.clone(), mean.clone()];
        let svg = spectrum_chart("patch", &wl, Some(&mean), Some(&sd), &samples).unwrap();
        let t = texts(&svg);
        assert!(t.iter().all(|(_, _, c)| !c.is_empty()), "an empty text element");
        assert_eq!(t.iter().filter(|(_, _, c)| c.starts_with("raw samples")).count(), 1);
        // The legend column holds exactly the three entries' swatches.
        let swatches = elements(&svg, "polyline")
            .iter()
            .chain(elements(&svg, "rect").iter())
            .filter(|(a, _)| {
                num(a, "x") > (W - LEGEND_W) as f64
                    || attr(a, "points").is_some_and(|p| {
                        p.split(',')
                            .next()
                            .and_then(|x| x.parse::<f64>().ok())
                            .is_some_and(|x| x > (W - LEGEND_W) as f64)
                    })
            })
            .count();
        assert_eq!(swatches, 3, "{svg}");
    }

    /// Bar charts had an empty slot after the last bar.
    #[test]
    fn bar_chart_has_no_trailing_empty_slot() {
        let bars: Vec<Bar> = ["rgb", "srgb", "nstep3"]
            .iter()
            .map(|n| Bar {
                label: n.to_string(),
                value: 1.0,
                sd: Some(0.1),
            })
            .collect();
        let svg = bar_chart("b", "ΔE*ab (CIELAB units)", &bars).unwrap();
        let rects: Vec<(f64, f64)> = elements(&svg, "rect")
            .iter()
            .filter(|(a, _)| attr(a, "fill").as_deref() != Some("#FFFFFF"))
            .map(|(a, _)| (num(a, "x"), num(a, "x") + num(a, "width")))
            .collect();
        assert_eq!(rects.len(), 3);
        let lines = elements(&svg, "line");
        let left = lines.iter().map(|(a, _)| num(a, "x1")).fold(f64::INFINITY, f64::min);
        let right = lines.iter().map(|(a, _)| num(a, "x2")).fold(0.0, f64::max);
        let (gap_left, gap_right) = (rects[0].0 - left, right - rects[2].1);
        assert!(
            (gap_left - gap_right).abs() <= 3.0,
            "margins {gap_left} and {gap_right} px"
        );
    }

    /// The x,y diagram drew Judd–Vos points on the CIE 1931 locus under a
    /// "CIE 1931" title: the locus and the title follow the observer.
    #[test]
    fn chromaticity_locus_and_title_follow_the_observer() {
        let data = [scatter("measured", &[(0.33, 0.48)])];
        let jv = chromaticity_chart("xy", Observer::JuddVos, &data).unwrap();
        let c31 = chromaticity_chart("xy", Observer::Cie1931, &data).unwrap();
        assert!(jv.contains("Judd–Vos 1978 2°") && !jv.contains("CIE 1931 2°"));
        assert!(c31.contains("CIE 1931 2°") && !c31.contains("Judd–Vos"));
        let locus_jv = spectral_locus(Observer::JuddVos);
        let locus_31 = spectral_locus(Observer::Cie1931);
        // The whole locus, 380 (or the table's first row) to 700 nm.
        for l in [&locus_jv, &locus_31] {
            assert!(l.first().unwrap().0 <= 385.0 && l.last().unwrap().0 >= 695.0);
        }
        // The observers differ most in the blue (Judd's correction below 460 nm).
        let at = |l: &[(f64, (f64, f64))], nm: f64| l.iter().find(|p| p.0 == nm).unwrap().1;
        let (a, b) = (at(&locus_jv, 420.0), at(&locus_31, 420.0));
        assert!((a.0 - b.0).abs() + (a.1 - b.1).abs() > 1e-3, "{a:?} vs {b:?}");
        // Both gamuts are drawn and named, distinctly (one dashed).
        assert!(jv.contains("sRGB gamut") && jv.contains("RADIANCE RGB gamut"));
    }
}
