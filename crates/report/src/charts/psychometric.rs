//! The psychometric figure of an oddity experiment: percent correct
//! against ΔE00 per observer with its exact 95 % interval, the fitted
//! d′ = ΔE00/σ curve as a plain line (no markers: it is a function, not
//! data), chance as a dashed line, and the fit's predictions for the
//! approximations that could not be shown as hollow markers.

use super::*;

/// One observer's (or the pool's) points: (ΔE00, percent correct, its
/// interval's low and high ends in percent).
pub struct PsychometricPoints {
    pub name: String,
    pub points: Vec<(f64, f64, f64, f64)>,
}

/// What [`psychometric_chart`] draws.
pub struct Psychometric {
    pub title: String,
    pub observed: Vec<PsychometricPoints>,
    /// The fitted curve (ΔE00, percent) and its legend name.
    pub curve: Option<(String, Vec<(f64, f64)>)>,
    /// Predictions (ΔE00, percent, label), drawn hollow.
    pub predicted: Vec<(f64, f64, String)>,
    /// Chance in percent (33.3 for the oddity task).
    pub chance_percent: f64,
}

/// The figure (see the module doc); the y axis is 0–100 %.
pub fn psychometric_chart(f: &Psychometric) -> ChartResult {
    let xs = f
        .observed
        .iter()
        .flat_map(|o| o.points.iter().map(|p| p.0))
        .chain(f.curve.iter().flat_map(|(_, c)| c.iter().map(|p| p.0)))
        .chain(f.predicted.iter().map(|p| p.0))
        .fold(0.0f64, f64::max)
        .max(0.5);
    let x_range = -0.02 * xs..1.05 * xs;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (W, H)).into_drawing_area();
        let (plot, legend_area) = page(&root, &f.title)?;
        let mut chart = builder(&plot)
            .build_cartesian_2d(x_range.clone(), -2.0..102.0)
            .map_err(err)?;
        mesh!(chart, "ΔE00 (display white)", "percent correct")
            .x_label_formatter(&|v| tick_label(*v, x_range.end - x_range.start))
            .y_label_formatter(&|v| format!("{v:.0}"))
            .draw()
            .map_err(err)?;
        let names: Vec<&str> = f.observed.iter().map(|o| o.name.as_str()).collect();
        let st = styles(&names, |n| n);
        let mut legend = Vec::new();
        draw_clipped_line(
            &chart,
            &[(x_range.start, f.chance_percent), (x_range.end, f.chance_percent)],
            BLACK.mix(0.6).stroke_width(1),
            Some((6, 4)),
        )?;
        legend.push(LegendEntry {
            name: format!("chance ({:.0} %)", f.chance_percent),
            glyph: Glyph::Dashed(RGBColor(100, 100, 100)),
        });
        if let Some((name, curve)) = &f.curve {
            draw_clipped_line(&chart, curve, BLACK.stroke_width(2), None)?;
            legend.push(LegendEntry {
                name: name.clone(),
                glyph: Glyph::Line(BLACK, 2),
            });
        }
        for (o, style) in f.observed.iter().zip(&st) {
            let bars: Vec<(f64, f64, f64)> = o.points.iter().map(|p| (p.0, p.2, p.3)).collect();
            draw_error_bars(&mut chart, &bars, style.colour, 3)?;
            let at: Vec<(f64, f64)> = o.points.iter().map(|p| (p.0, p.1)).collect();
            draw_markers(&mut chart, &at, *style)?;
            legend.push(LegendEntry {
                name: o.name.clone(),
                glyph: Glyph::Marker(*style),
            });
        }
        if !f.predicted.is_empty() {
            let style = Style {
                colour: BLACK,
                marker: Marker::Diamond,
                size: 5,
            };
            let outline = marker_outline(style);
            chart
                .draw_series(
                    f.predicted
                        .iter()
                        .flat_map(|p| outline.iter().map(move |path| ((p.0, p.1), path)))
                        .map(|(p, path)| EmptyElement::at(p) + PathElement::new(path.clone(), BLACK.stroke_width(2))),
                )
                .map_err(err)?;
            legend.push(LegendEntry {
                name: format!(
                    "predicted, not shown apart at 8 bits: {}",
                    f.predicted.iter().map(|p| p.2.as_str()).collect::<Vec<_>>().join(", ")
                ),
                glyph: Glyph::HollowMarker(style),
            });
        }
        draw_legend(&legend_area, &legend)?;
        root.present().map_err(err)?;
    }
    finished(svg)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The figure draws what its legend says: the predictions hollow in the
    /// plot *and* in the legend (the first version's legend showed a filled
    /// diamond beside hollow points), the fitted curve as one line, chance
    /// dashed.
    #[test]
    fn a_hollow_prediction_has_a_hollow_legend_entry() {
        let f = Psychometric {
            title: "t".into(),
            observed: vec![PsychometricPoints {
                name: "sim1: observed".into(),
                points: vec![(0.5, 40.0, 30.0, 50.0), (2.0, 90.0, 80.0, 97.0)],
            }],
            curve: Some((
                "fit".into(),
                (0..=20)
                    .map(|i| (0.1 * f64::from(i), 33.3 + 3.0 * f64::from(i)))
                    .collect(),
            )),
            predicted: vec![(0.05, 34.0, "nstep81".into())],
            chance_percent: 100.0 / 3.0,
        };
        let svg = psychometric_chart(&f).unwrap();
        // A filled black polygon would be a filled diamond (plot or legend).
        assert!(
            !svg.contains(r##"<polygon opacity="1" fill="#000000""##),
            "a filled black diamond: {svg}"
        );
        assert!(svg.contains("chance (33 %)") && svg.contains("nstep81"), "{svg}");
    }
}
