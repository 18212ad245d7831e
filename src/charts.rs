//! The study's charts as SVG, drawn with `plotters` on the server.
//!
//! Why server-side SVG: the same chart serves the dashboard, downloads for
//! papers and the `study --report` HTML, with no JavaScript build step and no
//! charting code in the browser. Text is left to the viewer's fonts (SVG
//! `<text>`), so no font files are needed here.
//!
//! Every function is pure: data in, SVG text out.

use plotters::prelude::*;

use crate::colorimetry::rgb::RgbSpace;
use crate::colorimetry::{Cmf, Observer, Xyz};
use crate::spectrum::Grid;

/// Chart size in px; the dashboard scales the SVG to its box.
const W: u32 = 720;
const H: u32 = 440;

/// Colours per series, chosen to stay distinguishable for common colour-vision deficiencies (Okabe–Ito).
pub const PALETTE: [RGBColor; 8] = [
    RGBColor(0, 114, 178),
    RGBColor(230, 159, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(86, 180, 233),
    RGBColor(213, 94, 0),
    RGBColor(240, 228, 66),
    RGBColor(0, 0, 0),
];

type ChartResult = Result<String, String>;

fn err<E: std::fmt::Debug>(e: E) -> String {
    format!("chart drawing failed: {e:?}")
}

/// The series legend every chart draws, in one style.
fn draw_legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
) -> Result<(), String> {
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .draw()
        .map_err(err)
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
        return (lo - 0.5 * lo.abs().max(1e-9), hi + 0.5 * hi.abs().max(1e-9));
    }
    let pad = 0.05 * (hi - lo);
    (lo - pad, hi + pad)
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
        root.fill(&WHITE).map_err(err)?;
        let all = samples.iter().flatten().chain(mean.into_iter().flatten()).copied();
        let (_, hi) = bounds(all.chain(std::iter::once(0.0)));
        let (x0, x1) = (
            wavelength_nm.first().copied().unwrap_or(380.0),
            wavelength_nm.last().copied().unwrap_or(780.0),
        );
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(x0..x1, 0.0..hi.max(1e-12))
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("wavelength (nm)")
            .y_desc("radiance W/(sr·m²·nm)")
            .y_label_formatter(&|v| format!("{v:.2e}"))
            .draw()
            .map_err(err)?;
        for (i, s) in samples.iter().enumerate() {
            chart
                .draw_series(LineSeries::new(
                    wavelength_nm.iter().copied().zip(s.iter().copied()),
                    PALETTE[4].mix(0.6).stroke_width(1),
                ))
                .map_err(err)?
                .label(if i == 0 { "raw samples" } else { "" })
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], PALETTE[4]));
        }
        if let (Some(m), Some(sd)) = (mean, sd) {
            let upper: Vec<(f64, f64)> = wavelength_nm
                .iter()
                .zip(m.iter().zip(sd))
                .map(|(w, (m, s))| (*w, m + s))
                .collect();
            let lower: Vec<(f64, f64)> = wavelength_nm
                .iter()
                .zip(m.iter().zip(sd))
                .map(|(w, (m, s))| (*w, m - s))
                .rev()
                .collect();
            let band: Vec<(f64, f64)> = upper.into_iter().chain(lower).collect();
            chart
                .draw_series(std::iter::once(Polygon::new(band, PALETTE[1].mix(0.35).filled())))
                .map_err(err)?
                .label("±1 SD")
                .legend(|(x, y)| Rectangle::new([(x, y - 4), (x + 16, y + 4)], PALETTE[1].mix(0.35).filled()));
        }
        if let Some(m) = mean {
            chart
                .draw_series(LineSeries::new(
                    wavelength_nm.iter().copied().zip(m.iter().copied()),
                    PALETTE[0].stroke_width(2),
                ))
                .map_err(err)?
                .label("mean")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], PALETTE[0].stroke_width(2)));
        }
        draw_legend(&mut chart)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// The CIE 1931 x,y diagram with the spectral locus and the two display
/// gamuts, and each series. The view is zoomed to the data when `zoom`.
/// Series are [`ScatterSeries`]: a coding's results, or the measurement;
/// `connect` joins a profile's points (the cylinder's heights).
pub fn chromaticity_chart(title: &str, series: &[ScatterSeries], zoom: bool) -> ChartResult {
    let cmf = Cmf::of(Observer::Cie1931);
    let locus: Vec<(f64, f64)> = Grid::uniform(380.0, 5.0, 65)
        .wavelengths()
        .iter()
        .map(|&nm| {
            let b = cmf.at(nm);
            let xy = Xyz::from_array(b).chromaticity();
            (xy.x, xy.y)
        })
        .collect();
    let ((x0, x1), (y0, y1)) = if zoom && series.iter().any(|s| !s.points.is_empty()) {
        let xs = bounds(series.iter().flat_map(|s| s.points.iter().map(|p| p.0)));
        let ys = bounds(series.iter().flat_map(|s| s.points.iter().map(|p| p.1)));
        let half = ((xs.1 - xs.0).max(ys.1 - ys.0) / 2.0).max(0.01);
        let (cx, cy) = ((xs.0 + xs.1) / 2.0, (ys.0 + ys.1) / 2.0);
        ((cx - half, cx + half), (cy - half, cy + half))
    } else {
        ((0.0, 0.8), (0.0, 0.9))
    };
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (H + 120, H)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(50)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(err)?;
        chart.configure_mesh().x_desc("x").y_desc("y").draw().map_err(err)?;
        let mut closed = locus.clone();
        closed.push(locus[0]);
        chart
            .draw_series(LineSeries::new(closed, BLACK.stroke_width(1)))
            .map_err(err)?
            .label("spectral locus")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], BLACK));
        for (space, color) in [
            (RgbSpace::SRGB, RGBColor(120, 120, 120)),
            (RgbSpace::RADIANCE, RGBColor(170, 170, 170)),
        ] {
            let tri = vec![
                (space.red.x, space.red.y),
                (space.green.x, space.green.y),
                (space.blue.x, space.blue.y),
                (space.red.x, space.red.y),
            ];
            chart
                .draw_series(LineSeries::new(tri, color.stroke_width(1)))
                .map_err(err)?
                .label(format!("{} gamut", space.name))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color));
        }
        draw_scatter(&mut chart, series)?;
        draw_legend(&mut chart)?;
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

/// Luminance profiles (cd/m² against height), Pareto charts and the like.
pub fn line_chart(title: &str, x_desc: &str, y_desc: &str, series: &[LineSeriesData], log_x: bool) -> ChartResult {
    let xs = bounds(series.iter().flat_map(|s| s.points.iter().map(|p| p.0)));
    let ys = bounds(series.iter().flat_map(|s| {
        s.points.iter().enumerate().flat_map(move |(i, p)| {
            let e = s.errors.as_ref().map(|e| e[i]).unwrap_or(0.0);
            [p.1 - e, p.1 + e]
        })
    }));
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let mut builder = ChartBuilder::on(&root);
        builder
            .caption(title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70);
        if log_x {
            let lo = xs.0.max(1e-9);
            let mut chart = builder
                .build_cartesian_2d((lo..xs.1.max(lo * 10.0)).log_scale(), ys.0..ys.1)
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_desc(x_desc)
                .y_desc(y_desc)
                .draw()
                .map_err(err)?;
            draw_lines(&mut chart, series)?;
            draw_legend(&mut chart)?;
        } else {
            let mut chart = builder.build_cartesian_2d(xs.0..xs.1, ys.0..ys.1).map_err(err)?;
            chart
                .configure_mesh()
                .x_desc(x_desc)
                .y_desc(y_desc)
                .draw()
                .map_err(err)?;
            draw_lines(&mut chart, series)?;
            draw_legend(&mut chart)?;
        }
        root.present().map_err(err)?;
    }
    Ok(svg)
}

fn draw_lines<DB: DrawingBackend, X: Ranged<ValueType = f64>>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<X, plotters::coord::types::RangedCoordf64>>,
    series: &[LineSeriesData],
) -> Result<(), String> {
    for (i, s) in series.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        chart
            .draw_series(LineSeries::new(s.points.clone(), color.stroke_width(2)))
            .map_err(err)?
            .label(s.name.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(2)));
        chart
            .draw_series(s.points.iter().map(|p| Circle::new(*p, 3, color.filled())))
            .map_err(err)?;
        if let Some(errors) = &s.errors {
            chart
                .draw_series(
                    s.points
                        .iter()
                        .zip(errors)
                        .map(|(p, e)| ErrorBar::new_vertical(p.0, p.1 - e, p.1, p.1 + e, color, 6)),
                )
                .map_err(err)?;
        }
    }
    Ok(())
}

/// One bar of a bar chart with its ±1 SD.
pub struct Bar {
    pub label: String,
    pub value: f64,
    pub sd: Option<f64>,
}

/// Bars with ±1 SD error bars (rms_rel and mean ΔE per coding).
pub fn bar_chart(title: &str, y_desc: &str, bars: &[Bar]) -> ChartResult {
    let hi = bars
        .iter()
        .map(|b| b.value + b.sd.unwrap_or(0.0))
        .fold(0.0, f64::max)
        .max(1e-9)
        * 1.1;
    let n = bars.len().max(1);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let labels: Vec<String> = bars.iter().map(|b| b.label.clone()).collect();
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d((0..n).into_segmented(), 0.0..hi)
            .map_err(err)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(n)
            .x_label_formatter(&|v| match v {
                SegmentValue::CenterOf(i) | SegmentValue::Exact(i) => labels.get(*i).cloned().unwrap_or_default(),
                SegmentValue::Last => String::new(),
            })
            .y_desc(y_desc)
            .draw()
            .map_err(err)?;
        for (i, b) in bars.iter().enumerate() {
            let color = PALETTE[i % PALETTE.len()];
            let mut bar = Rectangle::new(
                [(SegmentValue::Exact(i), 0.0), (SegmentValue::Exact(i + 1), b.value)],
                color.mix(0.8).filled(),
            );
            bar.set_margin(0, 0, 12, 12);
            chart.draw_series(std::iter::once(bar)).map_err(err)?;
            if let Some(sd) = b.sd {
                chart
                    .draw_series(std::iter::once(ErrorBar::new_vertical(
                        SegmentValue::CenterOf(i),
                        b.value - sd,
                        b.value,
                        b.value + sd,
                        BLACK,
                        10,
                    )))
                    .map_err(err)?;
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
    let (cell_w, cell_h) = (30i32, 20i32);
    let label_w = 8 * row_labels.iter().map(|l| l.chars().count()).max().unwrap_or(0) as i32 + 12;
    let head_h = 8 * col_labels.iter().map(|l| l.chars().count()).max().unwrap_or(0) as i32 + 50;
    let (x0, y0) = (label_w, head_h);
    let width = (x0 + cell_w * col_labels.len() as i32 + 20).max(480) as u32;
    let height = (y0 + cell_h * row_labels.len() as i32 + 50) as u32;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        root.draw(&Text::new(title.to_string(), (10, 8), ("sans-serif", 16).into_font()))
            .map_err(err)?;
        let col_style = ("sans-serif", 11).into_font().transform(FontTransform::Rotate270);
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
                    ("sans-serif", 9).into_font().color(&colour),
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
    let xs = bounds(series.iter().flat_map(|s| s.points.iter().map(|p| p.0)));
    let ys = bounds(series.iter().flat_map(|s| s.points.iter().map(|p| p.1)));
    // A log axis from the positive values, one decade at least.
    let positive = |r: (f64, f64), pick: fn(&(f64, f64)) -> f64| {
        let vals = series
            .iter()
            .flat_map(|s| s.points.iter().map(pick))
            .filter(|v| *v > 0.0);
        let (lo, hi) = vals.fold((f64::INFINITY, 0.0f64), |(l, h), v| (l.min(v), h.max(v)));
        if lo.is_finite() {
            (lo / 1.2, (hi * 1.2).max(lo * 10.0))
        } else {
            (r.0.max(1e-9), r.1.max(1e-8))
        }
    };
    let (lx, ly) = (positive(xs, |p| p.0), positive(ys, |p| p.1));
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let mut builder = ChartBuilder::on(&root);
        builder
            .caption(title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70);
        macro_rules! draw {
            ($x:expr, $y:expr) => {{
                let mut chart = builder.build_cartesian_2d($x, $y).map_err(err)?;
                chart
                    .configure_mesh()
                    .x_desc(x_desc)
                    .y_desc(y_desc)
                    .draw()
                    .map_err(err)?;
                draw_scatter(&mut chart, series)?;
                draw_legend(&mut chart)?;
            }};
        }
        match log {
            (true, true) => draw!((lx.0..lx.1).log_scale(), (ly.0..ly.1).log_scale()),
            (true, false) => draw!((lx.0..lx.1).log_scale(), ys.0..ys.1),
            (false, true) => draw!(xs.0..xs.1, (ly.0..ly.1).log_scale()),
            (false, false) => draw!(xs.0..xs.1, ys.0..ys.1),
        }
        root.present().map_err(err)?;
    }
    Ok(svg)
}

fn draw_scatter<DB: DrawingBackend, X: Ranged<ValueType = f64>, Y: Ranged<ValueType = f64>>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<X, Y>>,
    series: &[ScatterSeries],
) -> Result<(), String> {
    for (i, s) in series.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        if s.connect {
            chart
                .draw_series(LineSeries::new(s.points.clone(), color.stroke_width(2)))
                .map_err(err)?;
        }
        chart
            .draw_series(s.points.iter().map(|p| Circle::new(*p, 4, color.filled())))
            .map_err(err)?
            .label(s.name.clone())
            .legend(move |(x, y)| Circle::new((x + 8, y), 4, color.filled()));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn charts_are_svg_with_their_labels() {
        let wl: Vec<f64> = Grid::pr650().wavelengths().to_vec();
        let mean: Vec<f64> = wl.iter().map(|w| 1e-3 * (w / 780.0)).collect();
        let sd = vec![1e-5; wl.len()];
        let svg = spectrum_chart("patch", &wl, Some(&mean), Some(&sd), std::slice::from_ref(&mean)).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("wavelength (nm)") && svg.contains("mean"));
        let xy = chromaticity_chart(
            "chromaticity",
            &[ScatterSeries {
                name: "measured".into(),
                points: vec![(0.31, 0.33)],
                connect: false,
            }],
            false,
        )
        .unwrap();
        assert!(xy.contains("spectral locus") && xy.contains("srgb gamut"));
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
        let lines = line_chart(
            "speed",
            "s",
            "dE",
            &[LineSeriesData {
                name: "pareto".into(),
                points: vec![(0.1, 3.0), (1.0, 1.0)],
                errors: Some(vec![0.1, 0.1]),
            }],
            true,
        )
        .unwrap();
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
            ScatterSeries {
                name: "candidates".into(),
                points: vec![(0.1, 2.0), (1.0, 0.5)],
                connect: false,
            },
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
}
