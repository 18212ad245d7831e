//! Axes: tick labels from the axis span, readable log decades, value
//! bounds, the page and its caption, and axes of numbered slots.

use super::*;

/// The one tick formatter of every linear axis: a tick label for `v` on an
/// axis spanning `span`. Every tick of an axis gets the same number of
/// decimals, as many as the tick spacing needs and no more (never
/// 0.30000000000000004), in plain decimals wherever they fit (up to
/// [`PLAIN_DECIMALS`] decimals, values below 1e7: 0.00035, not 3.5e-4);
/// only finer or larger axes use the exponent form, their mantissas to the
/// tick spacing.
pub fn tick_label(v: f64, span: f64) -> String {
    let span = span.abs();
    // Plotters' float residue of zero (7e-21 on an axis of 1e-4s) is zero.
    let v = if v.abs() <= span * 1e-9 { 0.0 } else { v };
    // Plotters puts ~10 ticks on an axis; one more decimal than the spacing.
    let step = (span / 10.0).max(1e-300);
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    if decimals <= PLAIN_DECIMALS && v.abs().max(span) < 1e7 {
        let s = format!("{v:.decimals$}");
        // No "-0.00".
        return if s.trim_start_matches('-').chars().all(|c| c == '0' || c == '.') {
            s.trim_start_matches('-').to_string()
        } else {
            s
        };
    }
    if v == 0.0 {
        return "0".to_string();
    }
    // Mantissa decimals down to the tick spacing's decade.
    let digits = ((v.abs().log10().floor() - step.log10().floor()).max(0.0) as usize).min(4);
    format!("{v:.digits$e}")
}

/// The most decimals a tick label is written with before the exponent form.
pub const PLAIN_DECIMALS: usize = 6;

/// A tick label on a logarithmic axis: three significant digits at most,
/// plain decimals from 1e-6 to 1e7 (0.0001, not 1e-4), as [`tick_label`].
pub fn log_tick_label(v: f64) -> String {
    if v <= 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    if !(1e-6..1e7).contains(&v) {
        return format!("{v:.0e}");
    }
    let decimals = (2 - v.log10().floor() as i32).clamp(0, 8) as usize;
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

pub(super) fn bounds(values: impl Iterator<Item = f64>) -> (f64, f64) {
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
    // 8 % each side: on a plot of ~360 px the outermost marker (the
    // measurement's, 8 px and its stroke) stays ≥ 10 px clear of the axes.
    let pad = 0.08 * (hi - lo);
    (lo - pad, hi + pad)
}

/// The white page with the caption; returns (plot area, legend column).
pub(super) fn page<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
) -> Result<(Area<DB>, Area<DB>), String> {
    root.fill(&WHITE).map_err(err)?;
    let body = root.titled(title, ("sans-serif", CAPTION_PX)).map_err(err)?;
    let width = body.dim_in_pixel().0;
    Ok(body.split_horizontally(width.saturating_sub(LEGEND_W)))
}

/// The chart's axes: descriptions and tick fonts in one style.
pub(super) fn builder<'a, 'b, DB: DrawingBackend>(area: &'a DrawingArea<DB, Shift>) -> ChartBuilder<'a, 'b, DB> {
    let mut b = ChartBuilder::on(area);
    b.margin(12).x_label_area_size(50).y_label_area_size(80);
    b
}

/// An axis of numbered slots (targets, bars): linear over `range` with
/// ticks exactly at `keys`, whatever the axis length (plotters' own f64 axis
/// picks "nice" ticks, which for 1 slot are fractions and for 21 skip some).
pub(super) struct Slots {
    pub(super) inner: plotters::coord::types::RangedCoordf64,
    pub(super) keys: Vec<f64>,
}

impl Slots {
    pub(super) fn new(range: std::ops::Range<f64>, keys: Vec<f64>) -> Slots {
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
