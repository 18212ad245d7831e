//! The speed-against-accuracy chart (issue 22): its log axes showed a single
//! labelled tick, and it plotted one wall time per coding with no spread.

use std::path::Path;

use lightbooth::charts::{scatter_chart, scatter_chart_with_spread, ScatterSeries};

fn scatter(name: &str, points: &[(f64, f64)]) -> ScatterSeries {
    ScatterSeries {
        name: name.into(),
        points: points.to_vec(),
        connect: false,
    }
}

/// The text of every `<text …>…</text>` element.
fn texts(svg: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = svg;
    while let Some(i) = rest.find("<text ") {
        rest = &rest[i..];
        let open_end = rest.find('>').unwrap();
        let close = rest.find("</text>").unwrap();
        out.push(rest[open_end + 1..close].trim().to_string());
        rest = &rest[close..];
    }
    out
}

/// A tick label's value when it is a whole decade (0.01, 1, 10, 1e-5).
fn decade(label: &str) -> Option<f64> {
    let v: f64 = label.parse().ok()?;
    (v > 0.0 && (v.log10() - v.log10().round()).abs() < 1e-9).then_some(v)
}

#[test]
fn speed_chart_log_axes_have_at_least_two_labelled_decades() {
    // The CYLINDER figures: times 0.47–0.97 s, ΔE 0.2–0.6, each
    // within one decade (plotters labelled one tick on each).
    let series = [
        scatter("rgb", &[(0.97, 0.6)]),
        scatter("srgb", &[(0.47, 0.21)]),
        scatter("spectral", &[(0.64, 0.25)]),
    ];
    let spread = vec![vec![(0.9, 1.02)], vec![(0.45, 0.5)], vec![(0.6, 0.7)]];
    let x_desc = format!("render time (s): {}", lightbooth::render::cost::TIMING_AXIS);
    let svg = scatter_chart_with_spread(
        "CYLINDER: speed against accuracy",
        &x_desc,
        "mean ΔE00 (CIEDE2000 units, floor 1e-4)",
        &series,
        &[],
        &spread,
        (true, true),
    )
    .unwrap();
    // For a look: target/tmp/speed_chart.svg.
    std::fs::write(Path::new(env!("CARGO_TARGET_TMPDIR")).join("speed_chart.svg"), &svg).unwrap();
    let labels = texts(&svg);
    let decades: Vec<f64> = labels.iter().filter_map(|l| decade(l)).collect();
    // x: 0.1 and 1 (and 10); y: 0.1 and 1.
    assert!(decades.len() >= 4, "{labels:?}");
    assert!(
        labels.iter().any(|l| l == "0.2") && labels.iter().any(|l| l == "0.5"),
        "{labels:?}"
    );
    for (lo, hi) in [(0.02, 0.07), (1e-3, 1.5e-3), (3.0, 30.0), (1e-5, 1e-1)] {
        let svg = scatter_chart("t", "s", "e", &[scatter("a", &[(lo, lo), (hi, hi)])], (true, true)).unwrap();
        let labels = texts(&svg);
        let n = labels.iter().filter_map(|l| decade(l)).count();
        assert!(n >= 4, "{lo}–{hi}: {labels:?}");
    }
}

/// The timing's spread is drawn: one whisker per point that has one, and
/// the method is in the axis title the caller gives.
#[test]
fn speed_chart_draws_each_timings_spread() {
    let series = [scatter("rgb", &[(0.5, 0.6)]), scatter("srgb", &[(0.2, 0.3)])];
    let plain = scatter_chart("t", "s", "e", &series, (true, true)).unwrap();
    let spread = vec![vec![(0.4, 0.7)], vec![(0.15, 0.25)]];
    let x_desc = format!("render time (s): {}", lightbooth::render::cost::TIMING_AXIS);
    let with = scatter_chart_with_spread("t", &x_desc, "e", &series, &[], &spread, (true, true)).unwrap();
    let count = |svg: &str| svg.matches("<polyline").count() + svg.matches("<path").count();
    assert_eq!(count(&with), count(&plain) + 2);
    assert!(with.contains("median of 3 repeats, whiskers fastest–slowest"));
}
