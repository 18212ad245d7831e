//! Scatter charts: points per series, labelled or with their spread.

use super::*;

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

pub(super) fn scatter_legend(series: &[ScatterSeries]) -> Vec<LegendEntry> {
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
pub(super) fn draw_scatter<'a, DB: DrawingBackend + 'a, X: Ranged<ValueType = f64>, Y: Ranged<ValueType = f64>>(
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
