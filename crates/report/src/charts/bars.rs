//! Bar charts with ±1 SD, and grids of values against a threshold
//! (the failure maps).

use super::*;

/// One bar of a bar chart with its ±1 SD.
pub struct Bar {
    pub label: String,
    pub value: f64,
    pub sd: Option<f64>,
}

/// Bars with ±1 SD error bars (rms_rel and mean ΔE per coding), one slot
/// per bar and none after the last; a coding's bar has its coding's colour.
pub fn bar_chart(title: &str, y_desc: &str, bars: &[Bar]) -> ChartResult {
    labelled_bar_chart(title, "coding", y_desc, bars)
}

/// [`bar_chart`] with its own x-axis title (bars that are not codings).
pub fn labelled_bar_chart(title: &str, x_desc: &str, y_desc: &str, bars: &[Bar]) -> ChartResult {
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
        mesh!(chart, x_desc, y_desc)
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
    finished(svg)
}

/// The colour of a grid cell: green → yellow up to `threshold`, orange →
/// dark red above it (saturating at 10 × threshold).
pub(super) fn grid_colour(value: f64, threshold: f64) -> RGBColor {
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
    finished(svg)
}
