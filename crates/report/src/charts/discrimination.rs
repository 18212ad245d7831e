//! The study's Fig. 5 (right): d′ of each approximation against the
//! original, bars grouped by scene, with percent correct on a second axis
//! and chance marked.

use super::*;

/// The top of the percent-correct axis: above 100 %, so that a diamond at
/// 100 % (7 px) lies wholly inside the plot and the groups' names above it
/// (the axis is labelled 0–100 only).
const PERCENT_TOP: f64 = 114.0;

/// One bar: an approximation of one scene.
pub struct DiscriminationBar {
    /// The group (a scene) the bar belongs to.
    pub group: String,
    /// The approximation's coding: its colour.
    pub coding: String,
    pub d_prime: f64,
    /// The interval of d′ (through the same model).
    pub interval: (f64, f64),
    /// False when the interval's top is only the reporting limit.
    pub upper_bounded: bool,
    /// Percent correct, 0–100.
    pub percent_correct: f64,
}

/// d′ bars (coloured by coding, with their intervals) per group, percent
/// correct as black diamonds on the right axis, chance (33.3 %) dashed. An
/// interval with no upper bound is drawn to the top of the plot without a
/// cap. `model` names the d′ model on the axis.
pub fn discrimination_chart(title: &str, model: &str, bars: &[DiscriminationBar]) -> ChartResult {
    let mut groups: Vec<&str> = Vec::new();
    for b in bars {
        if !groups.contains(&b.group.as_str()) {
            groups.push(&b.group);
        }
    }
    // Slot of each bar: its group's bars side by side, one empty slot between groups.
    let mut x = Vec::with_capacity(bars.len());
    let mut next = 0.0;
    for (gi, g) in groups.iter().enumerate() {
        if gi > 0 {
            next += 1.0;
        }
        for (i, b) in bars.iter().enumerate() {
            if b.group == *g {
                x.push((i, next));
                next += 1.0;
            }
        }
    }
    x.sort_by_key(|(i, _)| *i);
    let x: Vec<f64> = x.into_iter().map(|(_, v)| v).collect();
    let slots = next.max(1.0);
    let top = bars
        .iter()
        .map(|b| if b.upper_bounded { b.interval.1 } else { b.d_prime })
        .fold(1.0, f64::max)
        .min(lightbooth_science::psychophysics::oddity::MAX_D_PRIME)
        * 1.15;
    let st = styles(bars, |b| b.coding.as_str());
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let body = root.titled(title, ("sans-serif", CAPTION_PX)).map_err(err)?;
        let mut chart = builder(&body)
            .right_y_label_area_size(70)
            .build_cartesian_2d(Slots::new(-0.5..slots - 0.5, x.clone()), 0.0..top)
            .map_err(err)?
            .set_secondary_coord(
                Slots::new(-0.5..slots - 0.5, x.clone()),
                Slots::new(0.0..PERCENT_TOP, vec![0.0, 20.0, 40.0, 60.0, 80.0, 100.0]),
            );
        let labels: Vec<(f64, String)> = x.iter().zip(bars).map(|(&v, b)| (v, b.coding.clone())).collect();
        mesh!(
            chart,
            "approximation (against the original)",
            format!("d′, {model} model")
        )
        .disable_x_mesh()
        .x_label_formatter(&|v| {
            labels
                .iter()
                .find(|(s, _)| (s - v).abs() < 1e-6)
                .map(|(_, l)| l.clone())
                .unwrap_or_default()
        })
        .y_label_formatter(&|v| tick_label(*v, top))
        .draw()
        .map_err(err)?;
        chart
            .configure_secondary_axes()
            .y_desc("percent correct (◆)")
            .label_style(("sans-serif", TICK_PX))
            .axis_desc_style(("sans-serif", DESC_PX))
            .y_label_formatter(&|v| format!("{v:.0}"))
            .draw()
            .map_err(err)?;
        for (i, b) in bars.iter().enumerate() {
            let v = x[i];
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(v - 0.38, 0.0), (v + 0.38, b.d_prime.min(top))],
                    st[i].colour.filled(),
                )))
                .map_err(err)?;
            if b.upper_bounded {
                draw_error_bars(&mut chart, &[(v, b.interval.0, b.interval.1.min(top))], BLACK, 6)?;
            } else {
                let line = BLACK.stroke_width(2);
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        vec![(v, b.interval.0), (v, top)],
                        line,
                    )))
                    .map_err(err)?;
                chart
                    .draw_series(std::iter::once(
                        EmptyElement::at((v, b.interval.0)) + PathElement::new(vec![(-6, 0), (6, 0)], line),
                    ))
                    .map_err(err)?;
            }
        }
        // Chance: a third correct.
        chart
            .draw_secondary_series(DashedLineSeries::new(
                vec![(-0.5, 100.0 / 3.0), (slots - 0.5, 100.0 / 3.0)],
                6,
                4,
                RGBColor(90, 90, 90).stroke_width(2),
            ))
            .map_err(err)?;
        chart
            .draw_secondary_series(std::iter::once(Text::new(
                "chance 33 %",
                (slots - 0.5, 100.0 / 3.0),
                ("sans-serif", LEGEND_PX).into_font().color(&RGBColor(90, 90, 90)).pos(
                    plotters::style::text_anchor::Pos::new(
                        plotters::style::text_anchor::HPos::Right,
                        plotters::style::text_anchor::VPos::Bottom,
                    ),
                ),
            )))
            .map_err(err)?;
        chart
            .draw_secondary_series(x.iter().zip(bars).map(|(&v, b)| {
                EmptyElement::at((v, b.percent_correct))
                    + Polygon::new(vec![(0, -7), (7, 0), (0, 7), (-7, 0)], BLACK.filled())
            }))
            .map_err(err)?;
        // Each group's name above its bars.
        for g in &groups {
            let xs: Vec<f64> = x
                .iter()
                .zip(bars)
                .filter(|(_, b)| b.group == *g)
                .map(|(v, _)| *v)
                .collect();
            let mid = xs.iter().sum::<f64>() / xs.len().max(1) as f64;
            chart
                .draw_secondary_series(std::iter::once(Text::new(
                    g.to_string(),
                    (mid, PERCENT_TOP - 1.0),
                    ("sans-serif", DESC_PX)
                        .into_font()
                        .color(&BLACK)
                        .pos(plotters::style::text_anchor::Pos::new(
                            plotters::style::text_anchor::HPos::Center,
                            plotters::style::text_anchor::VPos::Top,
                        )),
                )))
                .map_err(err)?;
        }
        root.present().map_err(err)?;
    }
    finished(svg)
}
