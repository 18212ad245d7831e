//! The x,y chromaticity diagram of an observer, with its spectral locus.

use super::*;

/// The spectral locus of `observer` (x,y of each tabulated wavelength).
pub(super) fn spectral_locus(observer: Observer) -> Vec<(f64, (f64, f64))> {
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
            // Every line clipped to the plot area: the zoomed panel cuts
            // through the locus and the gamuts (see `clipped_paths`).
            let mut closed: Vec<(f64, f64)> = locus.iter().map(|l| l.1).collect();
            closed.push(locus[0].1);
            draw_clipped_line(&chart, &closed, BLACK.stroke_width(1), None)?;
            if k == 0 {
                draw_locus_labels(&chart, &locus)?;
            }
            for (space, _, dashed) in gamuts {
                let tri = vec![
                    (space.red.x, space.red.y),
                    (space.green.x, space.green.y),
                    (space.blue.x, space.blue.y),
                    (space.red.x, space.red.y),
                ];
                if dashed {
                    draw_clipped_line(&chart, &tri, grey.stroke_width(2), Some((6, 5)))?;
                } else {
                    draw_clipped_line(&chart, &tri, grey.stroke_width(1), None)?;
                }
            }
            if k == 0 && has_data {
                // Where the right panel looks.
                let corners = [(zx.0, zy.0), (zx.1, zy.0), (zx.1, zy.1), (zx.0, zy.1), (zx.0, zy.0)];
                draw_clipped_line(&chart, &corners, RGBColor(200, 0, 0).stroke_width(1), None)?;
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
    finished(svg)
}

/// The spectral locus' wavelength labels (460–620 nm every 20 nm), each a
/// dot on its locus point and the number beside it, outward from the
/// equal-energy white; where that would leave the plot area (500 nm sits
/// a few px from the y axis), on the inner side. Never on the axis gutter
/// among the tick labels (issue 46).
fn draw_locus_labels<DB: DrawingBackend, X: Ranged<ValueType = f64>, Y: Ranged<ValueType = f64>>(
    chart: &ChartContext<'_, DB, Cartesian2d<X, Y>>,
    locus: &[(f64, (f64, f64))],
) -> Result<(), String> {
    let (xr, yr) = chart.plotting_area().get_pixel_range();
    let (w_area, h_area) = ((xr.end - xr.start) as f64, (yr.end - yr.start) as f64);
    let local = |p: (f64, f64)| {
        let (x, y) = chart.as_coord_spec().translate(&p);
        ((x - xr.start) as f64, (y - yr.start) as f64)
    };
    let area = chart.plotting_area().strip_coord_spec();
    let white = local((1.0 / 3.0, 1.0 / 3.0));
    const GAP: f64 = 5.0;
    for &(nm, p) in locus
        .iter()
        .filter(|(nm, _)| [460.0, 480.0, 500.0, 520.0, 540.0, 560.0, 580.0, 600.0, 620.0].contains(nm))
    {
        let c = local(p);
        let text = format!("{nm:.0}");
        let (w, h) = super::scatter::label_extent(&text);
        let (w, h) = (w as f64, h as f64);
        let (dx, dy) = (c.0 - white.0, c.1 - white.1);
        let len = dx.hypot(dy).max(1e-9);
        let (ux, uy) = (dx / len, dy / len);
        // From the point to the box's centre: the gap plus the box's reach
        // along the direction.
        let reach = GAP + 0.5 * (w * ux.abs() + h * uy.abs());
        let fits = |x0: f64, y0: f64| x0 >= 2.0 && y0 >= 2.0 && x0 + w <= w_area - 2.0 && y0 + h <= h_area - 2.0;
        let corner = |sign: f64| (c.0 + sign * reach * ux - 0.5 * w, c.1 + sign * reach * uy - 0.5 * h);
        let (x0, y0) = [corner(1.0), corner(-1.0)]
            .into_iter()
            .find(|&(x0, y0)| fits(x0, y0))
            .unwrap_or_else(|| {
                let (x0, y0) = corner(1.0);
                (x0.clamp(2.0, w_area - 2.0 - w), y0.clamp(2.0, h_area - 2.0 - h))
            });
        let at = |v: (f64, f64)| (v.0.round() as i32, v.1.round() as i32);
        area.draw(&Circle::new(at(c), 2, BLACK.filled())).map_err(err)?;
        area.draw(&Text::new(
            text,
            at((x0, y0)),
            ("sans-serif", super::scatter::LABEL_PX).into_font(),
        ))
        .map_err(err)?;
    }
    Ok(())
}
