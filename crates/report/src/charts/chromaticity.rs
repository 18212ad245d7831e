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
            let triangle = |space: RgbSpace| {
                vec![
                    (space.red.x, space.red.y),
                    (space.green.x, space.green.y),
                    (space.blue.x, space.blue.y),
                    (space.red.x, space.red.y),
                ]
            };
            // Where the right panel looks.
            let corners = [(zx.0, zy.0), (zx.1, zy.0), (zx.1, zy.1), (zx.0, zy.1), (zx.0, zy.0)];
            if k == 0 {
                let mut lines = vec![closed.clone()];
                lines.extend(gamuts.iter().map(|g| triangle(g.0)));
                if has_data {
                    lines.push(corners.to_vec());
                }
                draw_locus_labels(&chart, &locus, &lines)?;
            }
            for (space, _, dashed) in gamuts {
                let tri = triangle(space);
                if dashed {
                    draw_clipped_line(&chart, &tri, grey.stroke_width(2), Some((6, 5)))?;
                } else {
                    draw_clipped_line(&chart, &tri, grey.stroke_width(1), None)?;
                }
            }
            if k == 0 && has_data {
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
/// dot on its locus point and the number beside it: outward along the
/// locus' normal where that box lies inside the plot area and clear of
/// every line of `lines` (data coordinates: the locus, the gamuts, the
/// zoomed region) and of the labels before it; else the nearest direction
/// turned from the normal, either way, that is (460 nm sits a few px above
/// the x axis, where outward leaves the plot and inward lay on the gamuts'
/// blue corners; 500 nm a few px from the y axis). Never on the axis
/// gutter among the tick labels (issue 46).
fn draw_locus_labels<DB: DrawingBackend, X: Ranged<ValueType = f64>, Y: Ranged<ValueType = f64>>(
    chart: &ChartContext<'_, DB, Cartesian2d<X, Y>>,
    locus: &[(f64, (f64, f64))],
    lines: &[Vec<(f64, f64)>],
) -> Result<(), String> {
    let (xr, yr) = chart.plotting_area().get_pixel_range();
    let (w_area, h_area) = ((xr.end - xr.start) as f64, (yr.end - yr.start) as f64);
    let local = |p: (f64, f64)| {
        let (x, y) = chart.as_coord_spec().translate(&p);
        ((x - xr.start) as f64, (y - yr.start) as f64)
    };
    let segments: Vec<((f64, f64), (f64, f64))> = lines
        .iter()
        .flat_map(|l| l.windows(2).map(|w| (local(w[0]), local(w[1]))).collect::<Vec<_>>())
        .collect();
    let area = chart.plotting_area().strip_coord_spec();
    let white = local((1.0 / 3.0, 1.0 / 3.0));
    const GAP: f64 = 5.0;
    let mut placed: Vec<(f64, f64, f64, f64)> = Vec::new();
    for (i, &(nm, p)) in locus.iter().enumerate() {
        if ![460.0, 480.0, 500.0, 520.0, 540.0, 560.0, 580.0, 600.0, 620.0].contains(&nm) {
            continue;
        }
        let c = local(p);
        let text = format!("{nm:.0}");
        let (w, h) = super::scatter::label_extent(&text);
        let (w, h) = (w as f64, h as f64);
        // The normal: across the locus' direction through its neighbours,
        // on the side away from white.
        let (a, b) = (
            local(locus[i.saturating_sub(1)].1),
            local(locus[(i + 1).min(locus.len() - 1)].1),
        );
        let (tx, ty) = (b.0 - a.0, b.1 - a.1);
        let (mut nx, mut ny) = (-ty, tx);
        if nx * (c.0 - white.0) + ny * (c.1 - white.1) < 0.0 {
            (nx, ny) = (-nx, -ny);
        }
        let normal = ny.atan2(nx);
        let fits = |x0: f64, y0: f64| x0 >= 2.0 && y0 >= 2.0 && x0 + w <= w_area - 2.0 && y0 + h <= h_area - 2.0;
        // The box's top-left corner `gap` px from the point towards `angle`.
        let corner = |angle: f64, gap: f64| {
            let (ux, uy) = (angle.cos(), angle.sin());
            let reach = gap + 0.5 * (w * ux.abs() + h * uy.abs());
            (c.0 + reach * ux - 0.5 * w, c.1 + reach * uy - 0.5 * h)
        };
        let clear = |(x0, y0): (f64, f64)| {
            let b = (x0, y0, x0 + w, y0 + h);
            fits(x0, y0)
                && !segments.iter().any(|(s, e)| clip_segment(*s, *e, b).is_some())
                && !placed.iter().any(|q| b.0 < q.2 && q.0 < b.2 && b.1 < q.3 && q.1 < b.3)
        };
        let turns = (0..=12).flat_map(|k| {
            let t = k as f64 * std::f64::consts::PI / 12.0;
            [t, -t]
        });
        let (x0, y0) = [GAP, GAP + 4.0]
            .into_iter()
            .flat_map(|gap| turns.clone().map(move |t| (t, gap)))
            .map(|(t, gap)| corner(normal + t, gap))
            .find(|&b| clear(b))
            .unwrap_or_else(|| {
                let (x0, y0) = corner(normal, GAP);
                (x0.clamp(2.0, w_area - 2.0 - w), y0.clamp(2.0, h_area - 2.0 - h))
            });
        placed.push((x0, y0, x0 + w, y0 + h));
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
