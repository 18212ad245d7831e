//! Spectra against wavelength: a measured or rendered spectrum, and a
//! reflectance with its uncertainty.

use super::*;
use lightbooth_science::spectrum::SPECTRAL_RADIANCE_UNIT;

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
        let (plot, legend_area) = page(&root, title)?;
        let all = samples.iter().flatten().chain(mean.into_iter().flatten()).copied();
        let (_, hi) = bounds(all.chain(std::iter::once(0.0)));
        let hi = hi.max(1e-12);
        let (x0, x1) = (
            wavelength_nm.first().copied().unwrap_or(380.0),
            wavelength_nm.last().copied().unwrap_or(780.0),
        );
        let mut chart = builder(&plot).build_cartesian_2d(x0..x1, 0.0..hi).map_err(err)?;
        mesh!(
            chart,
            "wavelength (nm)",
            format!("spectral radiance ({SPECTRAL_RADIANCE_UNIT})")
        )
        .x_label_formatter(&|v| tick_label(*v, x1 - x0))
        .y_label_formatter(&|v| tick_label(*v, hi))
        .draw()
        .map_err(err)?;
        let mut legend = Vec::new();
        let raw = RGBColor(86, 180, 233);
        for s in samples {
            chart
                .draw_series(LineSeries::new(
                    wavelength_nm.iter().copied().zip(s.iter().copied()),
                    raw.mix(0.7).stroke_width(1),
                ))
                .map_err(err)?;
        }
        if !samples.is_empty() {
            legend.push(LegendEntry {
                name: format!("raw samples ({})", samples.len()),
                glyph: Glyph::Line(raw, 1),
            });
        }
        if let (Some(m), Some(sd)) = (mean, sd) {
            let upper = wavelength_nm
                .iter()
                .zip(m.iter().zip(sd))
                .map(|(w, (m, s))| (*w, m + s));
            let lower = wavelength_nm
                .iter()
                .zip(m.iter().zip(sd))
                .map(|(w, (m, s))| (*w, m - s))
                .rev();
            let band: Vec<(f64, f64)> = upper.chain(lower).collect();
            let band_colour = RGBColor(205, 205, 205);
            chart
                .draw_series(std::iter::once(Polygon::new(band, band_colour.filled())))
                .map_err(err)?;
            legend.push(LegendEntry {
                name: "±1 SD".into(),
                glyph: Glyph::Band(band_colour),
            });
        }
        if let Some(m) = mean {
            chart
                .draw_series(LineSeries::new(
                    wavelength_nm.iter().copied().zip(m.iter().copied()),
                    BLACK.stroke_width(2),
                ))
                .map_err(err)?;
            legend.push(LegendEntry {
                name: "mean".into(),
                glyph: Glyph::Line(BLACK, 2),
            });
        }
        draw_legend(&legend_area, &legend)?;
        root.present().map_err(err)?;
    }
    finished(svg)
}

/// A measured reflectance: ρ(λ) with its ±1 and ±2 standard-uncertainty
/// bands, the line ρ = 1, and the wavelengths flagged above 1 (or below 0)
/// marked in red.
pub fn reflectance_chart(title: &str, wavelength_nm: &[f64], rho: &[f64], u: &[f64]) -> ChartResult {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (W, H)).into_drawing_area();
        let (plot, legend_area) = page(&root, title)?;
        let upper = rho.iter().zip(u).map(|(r, u)| r + 2.0 * u);
        let lower = rho.iter().zip(u).map(|(r, u)| r - 2.0 * u);
        let (lo, hi) = bounds(upper.chain(lower).chain([0.0, 1.05]));
        let (x0, x1) = (
            wavelength_nm.first().copied().unwrap_or(380.0),
            wavelength_nm.last().copied().unwrap_or(780.0),
        );
        // 2 % of the range each side: a flagged dot on the first or last
        // wavelength stays inside the plot.
        let pad = 0.02 * (x1 - x0);
        let mut chart = builder(&plot)
            .build_cartesian_2d(x0 - pad..x1 + pad, lo..hi)
            .map_err(err)?;
        mesh!(chart, "wavelength (nm)", "reflectance factor ρ")
            .x_label_formatter(&|v| tick_label(*v, x1 - x0))
            .y_label_formatter(&|v| tick_label(*v, hi - lo))
            .draw()
            .map_err(err)?;
        let mut legend = Vec::new();
        for (k, colour) in [(2.0, RGBColor(225, 225, 225)), (1.0, RGBColor(180, 180, 180))] {
            let up = wavelength_nm
                .iter()
                .zip(rho.iter().zip(u))
                .map(|(w, (r, u))| (*w, r + k * u));
            let down = wavelength_nm
                .iter()
                .zip(rho.iter().zip(u))
                .map(|(w, (r, u))| (*w, r - k * u))
                .rev();
            let band: Vec<(f64, f64)> = up.chain(down).collect();
            chart
                .draw_series(std::iter::once(Polygon::new(band, colour.filled())))
                .map_err(err)?;
            legend.push(LegendEntry {
                name: format!("±{k} u (k = 1 standard uncertainty)"),
                glyph: Glyph::Band(colour),
            });
        }
        chart
            .draw_series(LineSeries::new(
                [(x0 - pad, 1.0), (x1 + pad, 1.0)],
                RGBColor(120, 120, 120).stroke_width(1),
            ))
            .map_err(err)?;
        chart
            .draw_series(LineSeries::new(
                wavelength_nm.iter().copied().zip(rho.iter().copied()),
                BLACK.stroke_width(2),
            ))
            .map_err(err)?;
        legend.push(LegendEntry {
            name: "ρ(λ) measured".into(),
            glyph: Glyph::Line(BLACK, 2),
        });
        let red = RGBColor(213, 94, 0);
        let flagged: Vec<(f64, f64)> = wavelength_nm
            .iter()
            .zip(rho)
            .filter(|(_, r)| !(0.0..=1.0).contains(*r))
            .map(|(w, r)| (*w, *r))
            .collect();
        if !flagged.is_empty() {
            chart
                .draw_series(flagged.iter().map(|p| Circle::new(*p, 4, red.filled())))
                .map_err(err)?;
            legend.push(LegendEntry {
                name: format!("outside [0, 1] ({}), flagged, not clipped", flagged.len()),
                glyph: Glyph::Line(red, 3),
            });
        }
        draw_legend(&legend_area, &legend)?;
        root.present().map_err(err)?;
    }
    finished(svg)
}
