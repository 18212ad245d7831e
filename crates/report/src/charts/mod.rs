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

use lightbooth_science::colorimetry::rgb::RgbSpace;
use lightbooth_science::colorimetry::{Cmf, Observer, Xyz};

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
            Marker::TriangleLeft => {
                let $mk = |at| {
                    EmptyElement::at(at) + Polygon::new(vec![(-s - 1, 0), (tri, -s - 1), (tri, s + 1)], c.filled())
                };
                $body
            }
            Marker::TriangleRight => {
                let $mk = |at| {
                    EmptyElement::at(at) + Polygon::new(vec![(s + 1, 0), (-tri, -s - 1), (-tri, s + 1)], c.filled())
                };
                $body
            }
            Marker::Star => {
                let $mk = |at| EmptyElement::at(at) + Polygon::new(star_points(s), c.filled());
                $body
            }
            Marker::Hexagon => {
                let $mk = |at| EmptyElement::at(at) + Polygon::new(hexagon_points(s), c.filled());
                $body
            }
            Marker::Asterisk => {
                let h = (s as f64 * 0.87).round() as i32;
                let half = (s + 1) / 2;
                let $mk = |at| {
                    EmptyElement::at(at)
                        + PathElement::new(vec![(0, -s - 1), (0, s + 1)], c.stroke_width(2))
                        + PathElement::new(vec![(-h, -half), (h, half)], c.stroke_width(2))
                        + PathElement::new(vec![(-h, half), (h, -half)], c.stroke_width(2))
                };
                $body
            }
        }
    }};
}

/// A filled five-pointed star of outer radius `s + 2` px around (0, 0), point up.
fn star_points(s: i32) -> Vec<(i32, i32)> {
    let (outer, inner) = ((s + 2) as f64, (s + 2) as f64 * 0.45);
    (0..10)
        .map(|k| {
            let a = -std::f64::consts::FRAC_PI_2 + k as f64 * std::f64::consts::PI / 5.0;
            let r = if k % 2 == 0 { outer } else { inner };
            ((r * a.cos()).round() as i32, (r * a.sin()).round() as i32)
        })
        .collect()
}

/// A filled hexagon of radius `s + 1` px around (0, 0), flat top and bottom.
fn hexagon_points(s: i32) -> Vec<(i32, i32)> {
    let r = (s + 1) as f64;
    (0..6)
        .map(|k| {
            let a = k as f64 * std::f64::consts::PI / 3.0;
            ((r * a.cos()).round() as i32, (r * a.sin()).round() as i32)
        })
        .collect()
}

/// The parts of the polyline `points` (data coordinates) that lie inside
/// the chart's plot area, in the plot area's own pixels (origin at its top
/// left). Each segment is clipped where it crosses the area's edge
/// (Liang–Barsky); a vertex outside is never moved onto the edge, which
/// is what plotters does with a coordinate outside its range (it clamps
/// each vertex, so a line leaving the area came back along a false edge).
fn clipped_paths<DB: DrawingBackend, X: Ranged<ValueType = f64>, Y: Ranged<ValueType = f64>>(
    chart: &ChartContext<'_, DB, Cartesian2d<X, Y>>,
    points: &[(f64, f64)],
) -> Vec<Vec<(i32, i32)>> {
    let (xr, yr) = chart.plotting_area().get_pixel_range();
    let rect = (xr.start as f64, yr.start as f64, xr.end as f64, yr.end as f64);
    let px: Vec<(f64, f64)> = points
        .iter()
        .filter(|p| p.0.is_finite() && p.1.is_finite())
        .map(|p| {
            let (x, y) = chart.as_coord_spec().translate(p);
            (x as f64, y as f64)
        })
        .collect();
    let mut paths: Vec<Vec<(i32, i32)>> = Vec::new();
    let mut open = false;
    let local = |p: (f64, f64)| ((p.0 - rect.0).round() as i32, (p.1 - rect.1).round() as i32);
    for w in px.windows(2) {
        match clip_segment(w[0], w[1], rect) {
            Some((a, b)) => {
                let (a, b) = (local(a), local(b));
                match paths.last_mut() {
                    Some(path) if open && path.last() == Some(&a) => path.push(b),
                    _ => paths.push(vec![a, b]),
                }
                // The path goes on only if the segment's end was not clipped.
                open = b == local(w[1]);
            }
            None => open = false,
        }
    }
    paths
}

/// The part of the segment `a`–`b` inside `rect` (left, top, right,
/// bottom), if any (Liang–Barsky).
pub(super) fn clip_segment(
    a: (f64, f64),
    b: (f64, f64),
    rect: (f64, f64, f64, f64),
) -> Option<((f64, f64), (f64, f64))> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-dx, a.0 - rect.0),
        (dx, rect.2 - a.0),
        (-dy, a.1 - rect.1),
        (dy, rect.3 - a.1),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    (t0 <= t1).then_some(((a.0 + t0 * dx, a.1 + t0 * dy), (a.0 + t1 * dx, a.1 + t1 * dy)))
}

/// Draws the polyline `points` (data coordinates) clipped to the plot
/// area (see [`clipped_paths`]), solid or dashed (`dash`: dash and gap, px).
fn draw_clipped_line<DB: DrawingBackend, X: Ranged<ValueType = f64>, Y: Ranged<ValueType = f64>>(
    chart: &ChartContext<'_, DB, Cartesian2d<X, Y>>,
    points: &[(f64, f64)],
    style: ShapeStyle,
    dash: Option<(i32, i32)>,
) -> Result<(), String> {
    let area = chart.plotting_area().strip_coord_spec();
    for path in clipped_paths(chart, points) {
        match dash {
            Some((size, gap)) => area.draw(&plotters::element::DashedPathElement::new(path, size, gap, style)),
            None => area.draw(&PathElement::new(path, style)),
        }
        .map_err(err)?;
    }
    Ok(())
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

/// A chart's SVG as its callers get it. A chart is no Markdown: a backtick
/// in a title, axis description, legend or label would be drawn as it is,
/// so one is a bug, refused in debug builds (every test) and dropped in
/// release builds.
fn finished(svg: String) -> ChartResult {
    if let Some(i) = svg.find('`') {
        let from = svg[..i].rfind('>').map_or(0, |j| j + 1);
        let to = svg[i..].find('<').map_or(svg.len(), |j| i + j);
        debug_assert!(false, "a Markdown backtick in a chart's text: {:?}", &svg[from..to]);
        return Ok(svg.replace('`', ""));
    }
    Ok(svg)
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

mod axes;
mod bars;
mod chromaticity;
mod discrimination;
#[cfg(test)]
mod drawn;
mod false_colour;
mod legend;
mod lines;
mod psychometric;
mod scatter;
mod spectra;
mod style;
#[cfg(test)]
mod tests;

pub use axes::*;
pub use bars::*;
pub use chromaticity::*;
pub use discrimination::*;
pub use false_colour::*;
use legend::*;
pub use lines::*;
pub use psychometric::*;
pub use scatter::*;
pub use spectra::*;
pub use style::*;
