//! Line charts: series against a linear or log x, and profiles along a
//! scene's targets.

use super::*;

/// A y-against-x line chart of several named series with optional error bars.
pub struct LineSeriesData {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    /// ±1 SD (or SE) per point, drawn as error bars when present (as a band
    /// for a series of more than [`BAND_ABOVE_POINTS`] points).
    pub errors: Option<Vec<f64>>,
}

pub(super) fn line_y_bounds(series: &[LineSeriesData]) -> (f64, f64) {
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
            // A point on a whole decade stays off the edge (see `LOG_MARGIN`).
            let mut chart = builder(&plot)
                .build_cartesian_2d(log_axis(lo / LOG_MARGIN, hi * LOG_MARGIN), ys.0..ys.1)
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
        draw_legend(&legend_area, &line_legend(series, y_desc))?;
        root.present().map_err(err)?;
    }
    finished(svg)
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
            let y = log_axis(lo / LOG_MARGIN, hi * LOG_MARGIN);
            let mut chart = builder(&plot).build_cartesian_2d(x, y).map_err(err)?;
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
        draw_legend(&legend_area, &line_legend(series, y_desc))?;
        root.present().map_err(err)?;
    }
    finished(svg)
}

/// Series in drawing order: others first, the measurement last.
pub(super) fn measurement_last<T>(series: &[T], name: impl Fn(&T) -> &str) -> Vec<(usize, &T)> {
    let mut order: Vec<(usize, &T)> = series.iter().enumerate().collect();
    order.sort_by_key(|(_, s)| is_measurement(name(s)));
    order
}

/// Styles for series by name, in the series' own order.
pub(super) fn styles<T>(series: &[T], name: impl Fn(&T) -> &str) -> Vec<Style> {
    let mut other = 0;
    series.iter().map(|s| series_style(name(s), &mut other)).collect()
}

/// A series with more points than this draws its ±1 SD (or SE) as a band
/// and its mean as a line without markers (a 401-wavelength spectrum's
/// error bars were a smear of 401 overlapping markers); fewer points (RGB
/// channels, a sweep) keep their markers and error bars.
pub const BAND_ABOVE_POINTS: usize = 40;

fn as_band(s: &LineSeriesData) -> bool {
    s.errors.is_some() && s.points.len() > BAND_ABOVE_POINTS
}

/// How opaque a band is over white.
const BAND_OPACITY: f64 = 0.25;

/// A band's colour as it looks on white (the legend's opaque swatch).
fn band_on_white(RGBColor(r, g, b): RGBColor) -> RGBColor {
    let mix = |c: u8| (BAND_OPACITY * c as f64 + (1.0 - BAND_OPACITY) * 255.0).round() as u8;
    RGBColor(mix(r), mix(g), mix(b))
}

/// The legend of `series`; a band is named after what the y axis says the
/// errors are (`y_desc` mentioning SE or SD).
pub(super) fn line_legend(series: &[LineSeriesData], y_desc: &str) -> Vec<LegendEntry> {
    let spread = if y_desc.contains("SE") {
        "±1 SE"
    } else if y_desc.contains("SD") {
        "±1 SD"
    } else {
        "± its error"
    };
    let st = styles(series, |s| s.name.as_str());
    let mut entries = Vec::new();
    for (s, style) in series.iter().zip(st) {
        if as_band(s) {
            entries.push(LegendEntry {
                name: s.name.clone(),
                glyph: Glyph::Line(style.colour, 2),
            });
            entries.push(LegendEntry {
                name: format!("{} {spread}", s.name),
                glyph: Glyph::Band(band_on_white(style.colour)),
            });
        } else {
            entries.push(LegendEntry {
                name: s.name.clone(),
                glyph: Glyph::LineMarker(style),
            });
        }
    }
    entries
}

pub(super) fn draw_lines<'a, DB: DrawingBackend + 'a, X: Ranged<ValueType = f64>, Y: Ranged<ValueType = f64>>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    series: &[LineSeriesData],
) -> Result<(), String> {
    let st = styles(series, |s| s.name.as_str());
    for (i, s) in measurement_last(series, |s| s.name.as_str()) {
        let style = st[i];
        let width = if is_measurement(&s.name) { 3 } else { 2 };
        if let (true, Some(errors)) = (as_band(s), &s.errors) {
            // Upper edge left to right, lower edge back: one polygon.
            let edge: Vec<(f64, f64, f64)> = s
                .points
                .iter()
                .zip(errors)
                .filter(|(p, e)| p.0.is_finite() && p.1.is_finite() && e.is_finite())
                .map(|(p, e)| (p.0, p.1 - e, p.1 + e))
                .collect();
            let outline: Vec<(f64, f64)> = edge
                .iter()
                .map(|&(x, _, hi)| (x, hi))
                .chain(edge.iter().rev().map(|&(x, lo, _)| (x, lo)))
                .collect();
            chart
                .draw_series(std::iter::once(Polygon::new(
                    outline,
                    style.colour.mix(BAND_OPACITY).filled(),
                )))
                .map_err(err)?;
            chart
                .draw_series(LineSeries::new(s.points.clone(), style.colour.stroke_width(width)))
                .map_err(err)?;
            continue;
        }
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
