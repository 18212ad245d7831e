//! The charts drawn and read back: every chart's SVG checked for its
//! axes, legend, markers and colours.

use super::drawn::*;
use super::*;
use lightbooth_science::spectrum::Grid;

fn texts(svg: &str) -> Vec<(f64, f64, String)> {
    elements(svg, "text")
        .into_iter()
        .map(|(a, c)| (num(&a, "x"), num(&a, "y"), c))
        .collect()
}

fn series(name: &str, points: &[(f64, f64)]) -> LineSeriesData {
    LineSeriesData {
        name: name.into(),
        points: points.to_vec(),
        errors: None,
    }
}

fn scatter(name: &str, points: &[(f64, f64)]) -> ScatterSeries {
    ScatterSeries {
        name: name.into(),
        points: points.to_vec(),
        connect: false,
    }
}

/// The CYLINDER profile plotted target k at x = k − 1 under an axis that
/// said 1–21: the first point must sit on the first target's tick.
#[test]
fn profile_ticks_are_not_shifted_by_one() {
    let targets: Vec<String> = ["h01", "h02", "h03"].map(String::from).to_vec();
    let svg = profile_chart(
        "profile",
        &targets,
        "target",
        "Y (cd/m²)",
        &[series("measured", &[(1.0, 1.0), (2.0, 4.0), (3.0, 9.0)])],
    )
    .unwrap();
    let t = texts(&svg);
    let tick = |id: &str| {
        t.iter()
            .find(|(_, _, c)| c == id)
            .unwrap_or_else(|| panic!("no tick {id}"))
            .0
    };
    // The measurement's markers: black open circles, in x order.
    let marks: Vec<f64> = elements(&svg, "circle")
        .iter()
        .filter(|(a, _)| attr(a, "stroke").as_deref() == Some("#000000") && num(a, "r") == MEASUREMENT_PX as f64)
        .map(|(a, _)| num(a, "cx"))
        .filter(|x| *x < (W - LEGEND_W) as f64)
        .collect();
    assert_eq!(marks.len(), 3, "{svg}");
    for (id, x) in ["h01", "h02", "h03"].iter().zip(&marks) {
        assert!(
            (tick(id) - x).abs() <= 1.0,
            "{id} tick at {} but its point at {x}",
            tick(id)
        );
    }
}

/// One target (WHITE's patch) made a zero-width x range whose ticks all read "0.0".
#[test]
fn single_target_scene_ticks_are_not_all_zero() {
    let targets = vec!["patch".to_string()];
    let svg = profile_chart(
        "white",
        &targets,
        "target",
        "Y (cd/m²)",
        &[series("measured", &[(1.0, 34.48)]), series("rgb", &[(1.0, 34.55)])],
    )
    .unwrap();
    let t = texts(&svg);
    assert!(
        t.iter().any(|(_, _, c)| c == "patch"),
        "the target is named on its tick"
    );
    let numbers: Vec<&String> = t
        .iter()
        .map(|(_, _, c)| c)
        .filter(|c| c.parse::<f64>().is_ok())
        .collect();
    let distinct: std::collections::BTreeSet<&String> = numbers.iter().copied().collect();
    assert!(distinct.len() >= 3, "y ticks {numbers:?}");
    assert!(!numbers.iter().any(|c| c.as_str() == "0.0"), "{numbers:?}");
    // A line chart of one point: distinct ticks on both axes too.
    let one = line_chart("one", "x (s)", "y (cd/m²)", &[series("rgb", &[(0.0, 0.0)])], false).unwrap();
    let numbers: std::collections::BTreeSet<String> = texts(&one)
        .into_iter()
        .map(|t| t.2)
        .filter(|c| c.parse::<f64>().is_ok())
        .collect();
    assert!(numbers.len() >= 3, "{numbers:?}");
}

/// The image viewer's pixel-probe chart (radiances of a few 1e-4
/// W/(sr·m²·nm)) labelled its ticks 3e-4, 3e-4, 2e-4, 2e-4, …: one
/// mantissa digit for ticks 5e-5 apart.
#[test]
fn small_radiance_tick_labels_repeated() {
    let span = 5.5e-4;
    let labels: Vec<String> = (0..=11).map(|i| tick_label(i as f64 * 5e-5, span)).collect();
    let mut unique = labels.clone();
    unique.dedup();
    assert_eq!(unique, labels, "{labels:?}");
    assert_eq!(tick_label(3.5e-4, span), "0.00035");
    assert_eq!(tick_label(2e5, 1e6), "200000");
    // The probe chart's lowest tick read 0e0, then 7e-21 (a float residue
    // of 0): zero, with its axis' decimals.
    assert_eq!(tick_label(0.0, span), "0.00000");
    assert_eq!(tick_label(7e-21, 4.5e-4), "0.00000");
}

/// The ColorCAL display profile's primaries chart drew the display's
/// gamut in the same grey as the sRGB gamut: its own colour and width, and
/// the legend naming both.
#[test]
fn display_gamut_in_the_same_grey_as_srgb() {
    let triangle = vec![(0.62, 0.34), (0.31, 0.58), (0.155, 0.07), (0.62, 0.34)];
    let svg = chromaticity_chart(
        "display profile 1: primaries (red, green, blue) and white, measured as XYZ",
        Observer::Cie1931,
        &[
            ScatterSeries {
                name: "display gamut (measured red, green, blue)".into(),
                points: triangle,
                connect: true,
            },
            scatter("white (all channels at full drive)", &[(0.3127, 0.329)]),
        ],
    )
    .unwrap();
    keep_for_a_look("display-gamut", &svg);
    assert_readable("display-gamut", &svg);
    let legend: Vec<String> = texts(&svg).into_iter().map(|t| t.2).collect();
    let legend = legend.join(" ");
    assert!(
        legend.contains("sRGB gamut") && legend.contains("display gamut"),
        "{legend}"
    );
    // The triangle's sides in the whole-diagram panel: 2 px, in a colour
    // that is no grey (the gamuts') and not the zoomed region's red.
    let grey = |hex: &str| hex.len() == 7 && hex[1..3] == hex[3..5] && hex[3..5] == hex[5..7];
    let zoom = colour_hex(RGBColor(200, 0, 0));
    let sides = elements(&svg, "polyline")
        .into_iter()
        .filter(|(a, _)| {
            let stroke = attr(a, "stroke").unwrap_or_default();
            !grey(&stroke) && stroke != zoom
        })
        .filter(|(a, _)| num(a, "stroke-width") == 2.0)
        .filter(|(a, _)| points_of(a).len() >= 2 && points_of(a).iter().all(|p| p.0 < 440.0))
        .count();
    assert!(sides >= 1, "the display's gamut is not drawn in its own colour:\n{svg}");
}

/// Every marker's box (left, top, right, bottom) in the plot areas:
/// circles, filled polygons and squares under 20 px, and the 3 px strokes
/// of crosses and pluses.
fn marker_boxes(svg: &str) -> Vec<(f64, f64, f64, f64)> {
    let mut boxes = Vec::new();
    for (a, _) in elements(svg, "circle") {
        let (x, y, r) = (num(&a, "cx"), num(&a, "cy"), num(&a, "r"));
        let w = if attr(&a, "fill").as_deref() == Some("none") {
            num(&a, "stroke-width") / 2.0
        } else {
            0.0
        };
        if r > 2.0 {
            boxes.push((x - r - w, y - r - w, x + r + w, y + r + w));
        }
    }
    let bbox = |pts: &[(f64, f64)]| {
        pts.iter().fold(
            (f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY),
            |b, p| (b.0.min(p.0), b.1.min(p.1), b.2.max(p.0), b.3.max(p.1)),
        )
    };
    for (a, _) in elements(svg, "polygon") {
        let b = bbox(&points_of(&a));
        if b.2 - b.0 < 20.0 && b.3 - b.1 < 20.0 {
            boxes.push(b);
        }
    }
    for (a, _) in elements(svg, "rect") {
        let (x, y, w, h) = (num(&a, "x"), num(&a, "y"), num(&a, "width"), num(&a, "height"));
        if w < 20.0 && h < 20.0 {
            boxes.push((x, y, x + w, y + h));
        }
    }
    for (a, _) in elements(svg, "polyline") {
        if num(&a, "stroke-width") == 3.0 {
            boxes.push(bbox(&points_of(&a)));
        }
    }
    boxes
}

/// Markers touched the plot's edge (WHITE's and RED's zoomed nstep3, the
/// 100 % diamond of Fig. 5) although the book says none does: over data
/// like the study's, every marker of every chart kind lies wholly inside
/// its plot area, at least 10 px clear of the edge.
#[test]
fn markers_touch_the_plot_edge() {
    let clear = |name: &str, svg: &str| {
        keep_for_a_look(name, svg);
        assert_readable(name, svg);
        let areas = plot_areas(svg);
        assert!(!areas.is_empty(), "{name}: no plot area found");
        let boxes = marker_boxes(svg);
        assert!(!boxes.is_empty(), "{name}: no markers found");
        for b in boxes {
            let centre = ((b.0 + b.2) / 2.0, (b.1 + b.3) / 2.0);
            // The legend's glyphs are right of every plot.
            let Some(area) = areas
                .iter()
                .find(|a| centre.0 >= a.0 - 20.0 && centre.0 <= a.2 + 20.0 && centre.1 <= a.3 + 20.0)
            else {
                continue;
            };
            let gap = (b.0 - area.0).min(area.2 - b.2).min(b.1 - area.1).min(area.3 - b.3);
            assert!(
                gap >= 10.0,
                "{name}: the marker at {b:?} is {gap} px from the edge of the plot {area:?}"
            );
        }
    };
    // WHITE's comparison on the chromaticity diagram: the measurement and
    // the codings, nstep3 the farthest (the zoomed panel's extremes).
    let white = [
        scatter("rgb", &[(0.3342, 0.3431)]),
        scatter("srgb", &[(0.3361, 0.3449)]),
        scatter("nstep3", &[(0.3472, 0.3368)]),
        scatter("nstep9", &[(0.3356, 0.3462)]),
        scatter("nstep27", &[(0.3351, 0.3455)]),
        scatter("spectral", &[(0.3350, 0.3456)]),
        scatter("measured", &[(0.3349, 0.3457)]),
    ];
    clear(
        "edge-white-xy",
        &chromaticity_chart("white: chromaticity", Observer::JuddVos, &white).unwrap(),
    );
    let red = [
        scatter("rgb", &[(0.5721, 0.3322)]),
        scatter("nstep3", &[(0.5403, 0.3405)]),
        scatter("spectral", &[(0.5702, 0.3330)]),
        scatter("measured", &[(0.5699, 0.3332)]),
    ];
    clear(
        "edge-red-xy",
        &chromaticity_chart("red: chromaticity", Observer::JuddVos, &red).unwrap(),
    );
    // WHITE's luminance per target: one target, nstep3 the brightest.
    let targets = vec!["patch".to_string()];
    clear(
        "edge-white-profile",
        &profile_chart(
            "white: luminance",
            &targets,
            "target",
            "Y (cd/m²)",
            &[
                series("measured", &[(1.0, 34.48)]),
                series("rgb", &[(1.0, 34.55)]),
                series("nstep3", &[(1.0, 36.9)]),
                series("spectral", &[(1.0, 34.50)]),
            ],
        )
        .unwrap(),
    );
    // Fig. 5: an approximation seen every time (100 %) and one at chance.
    let bar = |group: &str, coding: &str, d: f64, pc: f64| DiscriminationBar {
        group: group.into(),
        coding: coding.into(),
        d_prime: d,
        interval: (d * 0.8, d * 1.2),
        upper_bounded: pc < 100.0,
        percent_correct: pc,
    };
    clear(
        "edge-fig5",
        &discrimination_chart(
            "Fig. 5",
            "differencing",
            &[
                bar("white", "nstep3", 6.0, 100.0),
                bar("white", "nstep9", 0.3, 36.0),
                bar("cylinder", "nstep3", 4.0, 97.0),
                bar("cylinder", "nstep9", 0.1, 30.0),
            ],
        )
        .unwrap(),
    );
    // A speed chart (log–log) and a linear scatter.
    let speed: Vec<ScatterSeries> = [("rgb", 0.5, 2.1), ("nstep3", 0.55, 2.5), ("spectral", 1.1, 0.102)]
        .iter()
        .map(|&(c, t, de)| scatter(c, &[(t, de)]))
        .collect();
    for (name, log) in [("edge-speed-log", (true, true)), ("edge-speed-linear", (false, false))] {
        clear(name, &scatter_chart("speed", "t (s)", "ΔE00", &speed, log).unwrap());
    }
}

/// The spectrum chart wrote its unit W·sr⁻¹·m⁻²·nm⁻¹ where the pages,
/// the book and the other charts write W/(sr·m²·nm): one spelling.
#[test]
fn spectrum_unit_written_two_ways() {
    let wl: Vec<f64> = (0..41).map(|i| 380.0 + 10.0 * i as f64).collect();
    let mean = vec![1e-3; wl.len()];
    let svg = spectrum_chart("patch", &wl, Some(&mean), None, &[]).unwrap();
    let descs: Vec<String> = texts(&svg).into_iter().map(|t| t.2).collect();
    assert!(
        descs.iter().any(|t| t == "spectral radiance (W/(sr·m²·nm))"),
        "{descs:?}"
    );
    assert!(!svg.contains("sr⁻¹"), "the other spelling");
}

/// Tick formats were mixed across the charts (0.0020 on one axis, 2.5e-4
/// and 5e-5 on others): one formatter for every axis, plain decimals where
/// they fit, and every tick of an axis with the same decimals.
#[test]
fn tick_formats_mixed_across_axes() {
    for span in [2.5e-3, 5.5e-4, 4.5e-4, 5e-5, 2e-5, 0.02, 0.9, 34.0, 1.2e4, 9e5] {
        let labels: Vec<String> = (0..=10).map(|i| tick_label(i as f64 * span / 10.0, span)).collect();
        assert!(labels.iter().all(|l| !l.contains('e')), "span {span}: {labels:?}");
        let decimals: std::collections::BTreeSet<usize> = labels
            .iter()
            .map(|l| l.split_once('.').map_or(0, |(_, d)| d.len()))
            .collect();
        assert_eq!(decimals.len(), 1, "span {span}: {labels:?}");
        for (i, l) in labels.iter().enumerate() {
            let v: f64 = l.parse().unwrap();
            assert!(
                (v - i as f64 * span / 10.0).abs() <= span / 10.0,
                "span {span}: {labels:?}"
            );
        }
    }
    for v in [1e-4, 1e-3, 2e-5, 5e-4] {
        assert!(!log_tick_label(v).contains('e'), "{v}: {}", log_tick_label(v));
    }
    assert_eq!(log_tick_label(1e-4), "0.0001");
    // On the charts themselves: a spectrum of radiances of a few 1e-4 and
    // one of a few 1e-3 (the probe chart's and a measurement's).
    let wl: Vec<f64> = (0..41).map(|i| 380.0 + 10.0 * i as f64).collect();
    for scale in [2.5e-4, 2.5e-3, 5e-5] {
        let mean: Vec<f64> = wl.iter().map(|w| scale * (w - 370.0) / 410.0).collect();
        let svg = spectrum_chart("patch", &wl, Some(&mean), None, &[]).unwrap();
        let y_ticks: Vec<String> = elements(&svg, "text")
            .into_iter()
            .filter(|(a, c)| attr(a, "text-anchor").as_deref() == Some("end") && c.parse::<f64>().is_ok())
            .map(|(_, c)| c)
            .collect();
        assert!(y_ticks.len() >= 3, "{scale}: {y_ticks:?}");
        assert!(y_ticks.iter().all(|t| !t.contains('e')), "{scale}: {y_ticks:?}");
        let decimals: std::collections::BTreeSet<usize> = y_ticks
            .iter()
            .map(|l| l.split_once('.').map_or(0, |(_, d)| d.len()))
            .collect();
        assert_eq!(decimals.len(), 1, "{scale}: {y_ticks:?}");
    }
}

/// A tick read 0.30000000000000004 (plotters' default f64 formatting).
#[test]
fn tick_labels_have_no_float_noise() {
    assert_eq!(tick_label(0.30000000000000004, 0.5), "0.30");
    assert_eq!(tick_label(0.1 + 0.2, 0.05), "0.300");
    assert_eq!(tick_label(-1e-17, 0.5), "0.00");
    assert_eq!(log_tick_label(0.30000000000000004), "0.3");
    assert_eq!(log_tick_label(20.000000000000004), "20");
    let data = [
        scatter("measured", &[(0.3, 0.3), (0.33, 0.36)]),
        scatter("rgb", &[(0.31, 0.34)]),
    ];
    let charts = [
        chromaticity_chart("xy", Observer::JuddVos, &data).unwrap(),
        scatter_chart("s", "t (s)", "ΔE", &data, (false, false)).unwrap(),
        scatter_chart("s", "t (s)", "ΔE", &data, (true, true)).unwrap(),
        line_chart(
            "l",
            "x",
            "y",
            &[series("rgb", &[(0.1, 0.3), (0.2, 0.30000000000000004)])],
            false,
        )
        .unwrap(),
    ];
    for svg in &charts {
        for (_, _, c) in texts(svg) {
            if let Some((_, decimals)) = c.split_once('.') {
                if c.parse::<f64>().is_ok() {
                    assert!(decimals.len() <= 4, "tick `{c}`");
                }
            }
        }
    }
}

fn colour_hex(c: RGBColor) -> String {
    format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2)
}

/// The Cornell box's light (9e5 cd/m²) flattened its walls (2e3–2e4)
/// to a line at zero on a linear axis: beyond two decades the profile's
/// y axis is logarithmic, and says so.
#[test]
fn cornell_light_beside_its_walls_gets_a_log_axis() {
    let targets: Vec<String> = ["wall", "ceiling", "light"].map(String::from).to_vec();
    let wide = profile_chart(
        "p",
        &targets,
        "target",
        "Y (cd/m²)",
        &[series("spectral", &[(1.0, 3.0e3), (2.0, 5.0e2), (3.0, 9.0e5)])],
    )
    .unwrap();
    assert!(wide.contains("Y (cd/m²) (log scale)"), "{wide}");
    let narrow = profile_chart(
        "p",
        &targets,
        "target",
        "Y (cd/m²)",
        &[series("spectral", &[(1.0, 3.0e3), (2.0, 5.0e2), (3.0, 9.0e3)])],
    )
    .unwrap();
    assert!(!narrow.contains("log scale"));
}

/// nstep3 was pink in one chart and green in the next: colours went by
/// series position.
#[test]
fn nstep3_has_the_same_colour_in_every_chart() {
    let pink = colour_hex(coding_style("nstep3").unwrap().colour);
    let rgb = colour_hex(coding_style("rgb").unwrap().colour);
    let alone = [scatter("measured", &[(0.31, 0.33)]), scatter("nstep3", &[(0.32, 0.34)])];
    let behind = [
        scatter("measured", &[(0.31, 0.33)]),
        scatter("srgb", &[(0.30, 0.33)]),
        scatter("nstep9", &[(0.31, 0.32)]),
        scatter("nstep3", &[(0.32, 0.34)]),
    ];
    let bars = |names: &[&str]| -> Vec<Bar> {
        names
            .iter()
            .map(|n| Bar {
                label: n.to_string(),
                value: 1.0,
                sd: None,
            })
            .collect()
    };
    let charts = [
        chromaticity_chart("a", Observer::JuddVos, &alone).unwrap(),
        chromaticity_chart("b", Observer::Cie1931, &behind).unwrap(),
        scatter_chart("c", "t (s)", "ΔE", &alone, (true, true)).unwrap(),
        scatter_chart("d", "t (s)", "ΔE", &behind, (false, false)).unwrap(),
        bar_chart("e", "ΔE", &bars(&["nstep3"])).unwrap(),
        bar_chart("f", "ΔE", &bars(&["srgb", "nstep81", "nstep3"])).unwrap(),
        profile_chart("g", &["patch".into()], "t", "Y", &[series("nstep3", &[(1.0, 1.0)])]).unwrap(),
        line_chart(
            "h",
            "s",
            "y",
            &[series("spectral", &[(0.0, 1.0)]), series("nstep3", &[(1.0, 2.0)])],
            false,
        )
        .unwrap(),
    ];
    for (i, svg) in charts.iter().enumerate() {
        assert!(svg.contains(&pink), "chart {i} draws nstep3 without {pink}");
        // No chart here has rgb: its colour must not be handed to another series.
        assert!(!svg.contains(&rgb), "chart {i} uses rgb's {rgb} for another series");
    }
    // The dashboard's and the report's CSS read the same table.
    assert!(coding_css().contains(&format!("--coding-nstep3:{}", pink.to_ascii_lowercase())));
    // An N not in the table has a style of its own, not its neighbour's.
    assert_ne!(coding_style("nstep4"), coding_style("nstep3"));
    assert_eq!(coding_style("nstep4"), coding_style("NStep4"));
    assert_eq!(coding_style("cie"), None);
}

/// The measurement is drawn after every coding, larger and in black.
#[test]
fn measurement_is_drawn_last_and_largest() {
    let data = [
        scatter("measured", &[(0.31, 0.33)]),
        scatter("nstep27", &[(0.311, 0.331)]),
        scatter("spectral", &[(0.312, 0.332)]),
    ];
    let svg = scatter_chart("s", "t (s)", "ΔE", &data, (false, false)).unwrap();
    let plot_right = (W - LEGEND_W) as f64;
    let circles: Vec<(String, String)> = elements(&svg, "circle")
        .into_iter()
        .filter(|(a, _)| num(a, "cx") < plot_right)
        .collect();
    let last = circles.last().expect("markers");
    assert_eq!(attr(&last.0, "stroke").as_deref(), Some("#000000"));
    assert!(circles.iter().all(|(a, _)| num(a, "r") <= num(&last.0, "r")));
    assert!(num(&last.0, "r") > MARKER_PX as f64);
}

/// Legends were drawn inside the plot, over the data.
#[test]
fn legend_is_outside_the_plot_area() {
    let data = [
        scatter("measured", &[(0.31, 0.33), (0.40, 0.45)]),
        scatter("nstep3", &[(0.32, 0.34), (0.41, 0.44)]),
    ];
    for svg in [
        scatter_chart("s", "t (s)", "ΔE", &data, (false, false)).unwrap(),
        line_chart("l", "x", "y", &[series("nstep3", &[(0.0, 1.0), (1.0, 2.0)])], false).unwrap(),
    ] {
        let plot_right = (W - LEGEND_W) as f64;
        let legend = texts(&svg).into_iter().find(|t| t.2 == "nstep3").expect("legend entry");
        assert!(legend.0 > plot_right, "legend text at x = {}", legend.0);
        // Every grid line (the plot area) ends left of the legend column.
        for (a, _) in elements(&svg, "line") {
            assert!(
                num(&a, "x2").max(num(&a, "x1")) <= plot_right,
                "grid line into the legend: {a}"
            );
        }
    }
    let xy = chromaticity_chart("xy", Observer::JuddVos, &data).unwrap();
    let width = num(&elements(&xy, "svg")[0].0, "width");
    let legend = texts(&xy).into_iter().find(|t| t.2 == "nstep3").unwrap();
    assert!(legend.0 > width - LEGEND_W as f64);
}

/// The spectrum chart added one legend entry per raw sample, all but the
/// first with an empty name.
#[test]
fn no_empty_legend_entries() {
    let wl: Vec<f64> = Grid::pr650().wavelengths().to_vec();
    let mean: Vec<f64> = wl.iter().map(|w| 1e-3 * (w / 780.0)).collect();
    let sd = vec![1e-5; wl.len()];
    let samples = vec![mean.clone(), mean.clone(), mean.clone()];
    let svg = spectrum_chart("patch", &wl, Some(&mean), Some(&sd), &samples).unwrap();
    let t = texts(&svg);
    assert!(t.iter().all(|(_, _, c)| !c.is_empty()), "an empty text element");
    assert_eq!(t.iter().filter(|(_, _, c)| c.starts_with("raw samples")).count(), 1);
    // The legend column holds exactly the three entries' swatches.
    let swatches = elements(&svg, "polyline")
        .iter()
        .chain(elements(&svg, "rect").iter())
        .filter(|(a, _)| {
            num(a, "x") > (W - LEGEND_W) as f64
                || attr(a, "points").is_some_and(|p| {
                    p.split(',')
                        .next()
                        .and_then(|x| x.parse::<f64>().ok())
                        .is_some_and(|x| x > (W - LEGEND_W) as f64)
                })
        })
        .count();
    assert_eq!(swatches, 3, "{svg}");
}

/// Bar charts had an empty slot after the last bar.
#[test]
fn bar_chart_has_no_trailing_empty_slot() {
    let bars: Vec<Bar> = ["rgb", "srgb", "nstep3"]
        .iter()
        .map(|n| Bar {
            label: n.to_string(),
            value: 1.0,
            sd: Some(0.1),
        })
        .collect();
    let svg = bar_chart("b", "ΔE*ab (CIELAB units)", &bars).unwrap();
    let rects: Vec<(f64, f64)> = elements(&svg, "rect")
        .iter()
        .filter(|(a, _)| attr(a, "fill").as_deref() != Some("#FFFFFF"))
        .map(|(a, _)| (num(a, "x"), num(a, "x") + num(a, "width")))
        .collect();
    assert_eq!(rects.len(), 3);
    let lines = elements(&svg, "line");
    let left = lines.iter().map(|(a, _)| num(a, "x1")).fold(f64::INFINITY, f64::min);
    let right = lines.iter().map(|(a, _)| num(a, "x2")).fold(0.0, f64::max);
    let (gap_left, gap_right) = (rects[0].0 - left, right - rects[2].1);
    assert!(
        (gap_left - gap_right).abs() <= 3.0,
        "margins {gap_left} and {gap_right} px"
    );
}

/// The x,y diagram drew Judd–Vos points on the CIE 1931 locus under a
/// "CIE 1931" title: the locus and the title follow the observer.
#[test]
fn chromaticity_locus_and_title_follow_the_observer() {
    let data = [scatter("measured", &[(0.33, 0.48)])];
    let jv = chromaticity_chart("xy", Observer::JuddVos, &data).unwrap();
    let c31 = chromaticity_chart("xy", Observer::Cie1931, &data).unwrap();
    assert!(jv.contains("Judd–Vos 1978 2°") && !jv.contains("CIE 1931 2°"));
    assert!(c31.contains("CIE 1931 2°") && !c31.contains("Judd–Vos"));
    let locus_jv = spectral_locus(Observer::JuddVos);
    let locus_31 = spectral_locus(Observer::Cie1931);
    // The whole locus, 380 (or the table's first row) to 700 nm.
    for l in [&locus_jv, &locus_31] {
        assert!(l.first().unwrap().0 <= 385.0 && l.last().unwrap().0 >= 695.0);
    }
    // The observers differ most in the blue (Judd's correction below 460 nm).
    let at = |l: &[(f64, (f64, f64))], nm: f64| l.iter().find(|p| p.0 == nm).unwrap().1;
    let (a, b) = (at(&locus_jv, 420.0), at(&locus_31, 420.0));
    assert!((a.0 - b.0).abs() + (a.1 - b.1).abs() > 1e-3, "{a:?} vs {b:?}");
    // Both gamuts are drawn and named, distinctly (one dashed).
    assert!(jv.contains("sRGB gamut") && jv.contains("RADIANCE RGB gamut"));
}

/// The "500" nm label sat among the y axis' tick labels on every
/// chromaticity chart (drawn 34 px left of its locus point, 4 px right of
/// the axis): every wavelength label lies inside the plot area, right of
/// the y axis and above the x axis, beside its own locus point.
#[test]
fn locus_500_nm_label_among_the_y_ticks() {
    for observer in [Observer::JuddVos, Observer::Cie1931] {
        let svg = chromaticity_chart("xy", observer, &[scatter("measured", &[(0.31, 0.33)])]).unwrap();
        keep_for_a_look(&format!("chromaticity-{}", observer.label().replace(' ', "-")), &svg);
        assert_readable("chromaticity", &svg);
        let panel = 440.0;
        let numbers: Vec<(String, f64, f64, f64)> = elements(&svg, "text")
            .into_iter()
            .filter_map(|(a, c)| {
                Some((
                    attr(&a, "text-anchor")?,
                    num(&a, "x"),
                    num(&a, "y"),
                    c.parse::<f64>().ok()?,
                ))
            })
            .filter(|t| t.1 < panel)
            .collect();
        let x_ticks: Vec<(f64, f64)> = numbers.iter().filter(|t| t.0 == "middle").map(|t| (t.3, t.1)).collect();
        let y_ticks: Vec<(f64, f64)> = numbers.iter().filter(|t| t.0 == "end").map(|t| (t.3, t.2)).collect();
        assert!(x_ticks.len() >= 3 && y_ticks.len() >= 3, "{x_ticks:?} {y_ticks:?}");
        let fit = |ticks: &[(f64, f64)]| {
            let (a, b) = (ticks[0], ticks[ticks.len() - 1]);
            let slope = (b.1 - a.1) / (b.0 - a.0);
            move |v: f64| a.1 + slope * (v - a.0)
        };
        let (px, py) = (fit(&x_ticks), fit(&y_ticks));
        // The y axis is right of its tick labels' right ends, the x axis
        // above its labels' tops.
        let y_axis = numbers
            .iter()
            .filter(|t| t.0 == "end")
            .map(|t| t.1)
            .fold(f64::NEG_INFINITY, f64::max);
        let x_axis = numbers
            .iter()
            .filter(|t| t.0 == "middle")
            .map(|t| t.2)
            .fold(f64::INFINITY, f64::min);
        let locus = spectral_locus(observer);
        for nm in [500.0, 460.0, 480.0, 520.0, 540.0, 560.0, 580.0, 600.0, 620.0] {
            let text = format!("{nm:.0}");
            let (x, y, _) = texts(&svg)
                .into_iter()
                .find(|t| t.2 == text && t.0 < panel)
                .unwrap_or_else(|| panic!("no {text} label"));
            let b = label_box(x, y, &text);
            assert!(
                b.0 > y_axis + 2.0 && b.3 < x_axis,
                "{observer:?}: the {text} nm label at {b:?} is outside the plot (y axis at x {y_axis}, x labels at y {x_axis})"
            );
            let p = locus.iter().find(|l| l.0 == nm).unwrap().1;
            let (cx, cy) = (px(p.0), py(p.1));
            let dx = (b.0 - cx).max(cx - b.2).max(0.0);
            let dy = (b.1 - cy).max(cy - b.3).max(0.0);
            assert!(
                dx.hypot(dy) <= 12.0,
                "{observer:?}: the {text} nm label at {b:?} is {} px from its point ({cx:.0}, {cy:.0})",
                dx.hypot(dy)
            );
        }
    }
}

/// nstep1, nstep2, nstep3 and nstep5 were identical pink triangles (an N
/// not in the table took the nearest tabulated N's style): every coding of
/// a sweep must differ from every other in colour or marker, the table's
/// codings keep their styles, and no colour is too light to read on white.
#[test]
fn every_coding_has_its_own_style() {
    let key = |name: &str| {
        let s = coding_style(name).unwrap_or_else(|| panic!("{name} is a coding"));
        (s.colour.0, s.colour.1, s.colour.2, s.marker)
    };
    let table = ["rgb", "srgb", "spectral"].map(String::from);
    let sweep = [1, 2, 3, 4, 5, 7, 9, 15, 27, 81].map(|n| format!("nstep{n}"));
    let small = (1..=32).map(|n| format!("nstep{n}"));
    let names: Vec<String> = table
        .iter()
        .cloned()
        .chain(sweep.iter().cloned())
        .chain(small)
        .collect();
    for (i, a) in names.iter().enumerate() {
        for b in &names[i + 1..] {
            if a != b {
                assert_ne!(key(a), key(b), "{a} and {b} are drawn alike");
            }
        }
        let (r, g, b, _) = key(a);
        let luminance = 0.2126 * r as f64 + 0.7152 * g as f64 + 0.0722 * b as f64;
        assert!(luminance < 180.0, "{a} ({r}, {g}, {b}) is too light on white");
        assert_ne!((r, g, b), (0, 0, 0), "{a} takes the measurement's black");
    }
    // The table's styles are as they were (the CSS reads them too).
    assert_eq!(key("nstep3"), (204, 121, 167, Marker::TriangleUp));
    assert_eq!(key("nstep9"), (86, 180, 233, Marker::TriangleDown));
    assert_eq!(key("nstep27"), (0, 114, 178, Marker::Circle));
    assert_eq!(key("nstep81"), (0, 158, 115, Marker::Cross));
    assert_eq!(key("rgb"), (213, 94, 0, Marker::Square));
    // An untabulated N never borrows a tabulated coding's colour, so it
    // differs from it in colour, not only in marker.
    for n in (1..=100).filter(|n| ![3, 9, 27, 81].contains(n)) {
        let (r, g, b, _) = key(&format!("nstep{n}"));
        for (name, c, _) in CODING_STYLES {
            assert_ne!((r, g, b), (c.0, c.1, c.2), "nstep{n} has {name}'s colour");
        }
    }
}

/// A label's estimated box from a `<text>` the chart wrote (plotters writes
/// a text's top-left corner and `font-size` px / 1.24).
fn label_box(x: f64, y: f64, text: &str) -> (f64, f64, f64, f64) {
    let (w, h) = super::scatter::label_extent(text);
    (x, y, x + w as f64, y + h as f64)
}

/// A sweep's points crowd each other (nstep3 … nstep81 at nearly the same
/// time and error): no two labels may overlap, no label may cover another
/// point's marker, and every label that found no room is in the key.
#[test]
fn crowded_point_labels_do_not_overlap() {
    let mut data = Vec::new();
    let mut labels = Vec::new();
    for (k, coding) in ["nstep27", "nstep3", "nstep9"].iter().enumerate() {
        let points: Vec<(f64, f64)> = (0..12)
            .map(|j| {
                let t = 0.1 * 1.08f64.powi(j + 3 * k as i32);
                (t, 0.5 * 1.06f64.powi(j - 2 * k as i32))
            })
            .collect();
        labels.push((0..points.len()).map(|j| format!("L{k}-{j} p")).collect::<Vec<_>>());
        data.push(scatter(coding, &points));
    }
    // A far point whose label fits beside it.
    data.push(scatter("nstep81", &[(5.0, 0.01)]));
    labels.push(vec!["alone".into()]);
    let svg = scatter_chart_labelled("crowd", "t (s, log scale)", "ΔE", &data, &labels, (true, true)).unwrap();
    let all = texts(&svg);
    let drawn: Vec<(f64, f64, f64, f64)> = all
        .iter()
        .filter(|(_, _, t)| t.starts_with('L') || t.starts_with('[') || t == "alone")
        .filter(|(x, _, _)| *x < (W - LEGEND_W) as f64)
        .map(|(x, y, t)| label_box(*x, *y, t))
        .collect();
    assert!(drawn.len() >= 8, "some labels are beside their points: {}", drawn.len());
    for (i, a) in drawn.iter().enumerate() {
        for b in &drawn[i + 1..] {
            assert!(!boxes_overlap(*a, *b), "labels at {a:?} and {b:?} overlap");
        }
    }
    // nstep27's markers are circles: no label covers one.
    for (attrs, _) in elements(&svg, "circle") {
        let (cx, cy, r) = (num(&attrs, "cx"), num(&attrs, "cy"), num(&attrs, "r"));
        let marker = (cx - r, cy - r, cx + r, cy + r);
        for b in &drawn {
            assert!(
                !boxes_overlap(marker, *b),
                "label {b:?} covers the marker at ({cx}, {cy})"
            );
        }
    }
    assert!(
        all.iter().any(|(_, _, t)| t == "alone"),
        "the lone point keeps its label"
    );
    // Every label is on the chart or in the key.
    let words: String = all.iter().map(|(_, _, t)| t.as_str()).collect::<Vec<_>>().join(" ");
    for l in labels.iter().flatten() {
        assert!(words.contains(l.as_str()), "label {l} is nowhere");
    }
    assert!(words.contains("did not fit"), "the crowd needs a key");
}

/// A mean ΔE00 of 0 (a coding that reproduces the reference exactly) has no
/// place on a log axis: drawn hollow on the lower edge and said so, while
/// the other values are not clamped (the axis reaches their decades).
#[test]
fn zero_values_sit_hollow_on_a_log_axis_edge() {
    let data = [
        scatter("spectral", &[(0.5, 0.0), (1.0, 0.0)]),
        scatter("rgb", &[(0.2, 2e-5), (0.4, 0.3)]),
    ];
    let svg = scatter_chart(
        "zero",
        "t (s)",
        "mean ΔE00 (CIEDE2000 units, log scale)",
        &data,
        (true, true),
    )
    .unwrap();
    let words: String = texts(&svg).into_iter().map(|t| t.2).collect::<Vec<_>>().join(" ");
    assert!(words.contains("2 points with mean ΔE00 = 0"), "{words}");
    assert!(words.contains("hollow on the lower edge"), "{words}");
    // 2e-5 is drawn where it is, not at a floor of 1e-4.
    assert!(words.contains("0.00001"), "the axis reaches 2e-5's decade: {words}");
    // The spectral coding's two points are outlines (paths), not filled squares.
    let grey = colour_hex(coding_style("spectral").unwrap().colour);
    assert!(
        svg.matches(&format!("stroke=\"{grey}\"")).count() >= 2,
        "hollow markers in {grey}"
    );
    // Without zeros there is no note.
    let positive = [scatter("rgb", &[(0.2, 2e-5), (0.4, 0.3)])];
    let svg = scatter_chart("zero", "t (s)", "ΔE", &positive, (true, true)).unwrap();
    assert!(!svg.contains("hollow"));
}

/// Every decade a log axis covers has a labelled tick; an axis covering
/// less than a decade labels 1, 2 and 5 steps (not one lonely tick).
#[test]
fn log_axes_label_every_decade() {
    let ticks = |lo: f64, hi: f64| -> Vec<String> {
        let data = [scatter("rgb", &[(1.0, lo), (2.0, hi)])];
        let svg = scatter_chart("log", "t (s)", "ΔE", &data, (false, true)).unwrap();
        texts(&svg).into_iter().map(|t| t.2).collect()
    };
    let wide = ticks(3e-4, 40.0);
    for decade in ["0.0001", "0.001", "0.01", "0.1", "1", "10", "100"] {
        assert!(wide.contains(&decade.to_string()), "no tick {decade} in {wide:?}");
    }
    // Minor ticks are not labelled on a wide axis.
    assert!(
        !wide.contains(&"0.2".to_string()) && !wide.contains(&"3".to_string()),
        "{wide:?}"
    );
    let narrow = ticks(0.22, 0.45);
    for tick in ["0.1", "0.2", "0.5", "1"] {
        assert!(narrow.contains(&tick.to_string()), "no tick {tick} in {narrow:?}");
    }
}

/// A chart is no Markdown: a backtick in its text (here a title copied from
/// an error message) is refused in debug builds, so a test drawing it fails.
#[test]
#[cfg(debug_assertions)]
#[should_panic(expected = "Markdown backtick")]
fn backticks_in_chart_text_are_refused() {
    let _ = line_chart("field `coding`", "x", "y", &[series("rgb", &[(0.0, 1.0)])], false);
}

#[test]
fn charts_without_backticks_are_drawn() {
    let svg = line_chart("field coding", "x", "y", &[series("rgb", &[(0.0, 1.0)])], false).unwrap();
    assert!(svg.contains("field coding") && !svg.contains('`'));
}

/// Whether an element with `points` starts left of the legend column.
fn in_plot(attrs: &str) -> bool {
    let points = attr(attrs, "points").unwrap_or_default();
    let x: f64 = points
        .split([',', ' '])
        .next()
        .and_then(|x| x.parse().ok())
        .unwrap_or(f64::NAN);
    x < (W - LEGEND_W) as f64
}

/// A pixel's 401-wavelength spectrum with its ±1 SE: one translucent band
/// and a line, not 401 error bars with markers; three RGB channels keep
/// their error bars.
#[test]
fn many_point_errors_are_a_band() {
    let wl: Vec<f64> = (0..401).map(|i| 380.0 + i as f64).collect();
    let spectrum = LineSeriesData {
        name: "nstep27".into(),
        points: wl.iter().map(|w| (*w, 1e-3 * (1.0 + (w / 40.0).sin()))).collect(),
        errors: Some(vec![1e-4; wl.len()]),
    };
    let y = "spectral radiance (W/(sr·m²·nm)), mean ± 1 SE";
    let svg = line_chart("probe", "wavelength (nm)", y, &[spectrum], false).unwrap();
    let blue = colour_hex(coding_style("nstep27").unwrap().colour);
    let bands: Vec<_> = elements(&svg, "polygon")
        .into_iter()
        .filter(|(a, _)| attr(a, "fill").as_deref() == Some(blue.as_str()))
        .collect();
    assert_eq!(bands.len(), 1, "one band polygon");
    let opacity = num(&bands[0].0, "opacity");
    assert!(opacity > 0.0 && opacity < 0.5, "the band is translucent: {opacity}");
    // 401 × 2 + 2 vertices: upper edge there, lower edge back.
    let vertices = attr(&bands[0].0, "points").unwrap().split_whitespace().count();
    assert_eq!(vertices, 802);
    // No error bars (2-point paths) and no markers (circles) in its colour.
    let bars = elements(&svg, "polyline")
        .into_iter()
        .filter(|(a, _)| attr(a, "stroke").as_deref() == Some(blue.as_str()))
        .filter(|(a, _)| attr(a, "points").unwrap_or_default().split_whitespace().count() == 2)
        .filter(|(a, _)| in_plot(a))
        .count();
    assert_eq!(bars, 0, "error bars drawn");
    assert_eq!(elements(&svg, "circle").len(), 0, "markers drawn");
    assert!(
        texts(&svg).iter().any(|t| t.2.contains("±1 SE")),
        "the legend names the band"
    );

    let channels = LineSeriesData {
        name: "rgb".into(),
        points: vec![(1.0, 0.2), (2.0, 0.3), (3.0, 0.1)],
        errors: Some(vec![0.01; 3]),
    };
    let svg = line_chart("probe", "channel", "linear RGB, mean ± 1 SE", &[channels], false).unwrap();
    let orange = colour_hex(coding_style("rgb").unwrap().colour);
    let bars = elements(&svg, "polyline")
        .into_iter()
        .filter(|(a, _)| attr(a, "stroke").as_deref() == Some(orange.as_str()))
        .filter(|(a, _)| attr(a, "points").unwrap_or_default().split_whitespace().count() == 2)
        .filter(|(a, _)| in_plot(a))
        .count();
    // A bar and its two caps per channel.
    assert_eq!(bars, 9, "three error bars with caps");
}

#[test]
fn colour_bar_ticks_start_at_zero_end_at_the_scale_top_and_stay_few() {
    let colour_bar_ticks =
        |max: f64| -> Vec<f64> { colour_bar_ticks(max).iter().map(|v| (v * 1e9).round() / 1e9).collect() };
    assert_eq!(colour_bar_ticks(2.5), [0.0, 0.5, 1.0, 1.5, 2.0, 2.5]);
    assert_eq!(colour_bar_ticks(1.0), [0.0, 0.2, 0.4, 0.6, 0.8, 1.0]);
    // A nice tick within 8 % of the top gives way to the top itself.
    assert_eq!(colour_bar_ticks(0.83), [0.0, 0.2, 0.4, 0.6, 0.83]);
    assert_eq!(colour_bar_ticks(0.0), [0.0]);
    assert_eq!(colour_bar_ticks(f64::NAN), [0.0]);
    for max in [0.0123, 0.7, 3.3, 17.0, 4.2e3] {
        let t = colour_bar_ticks(max);
        assert!(t.len() <= 7 && t.len() >= 3, "{max}: {t:?}");
        assert_eq!((t[0], *t.last().unwrap()), (0.0, max));
        assert!(t.windows(2).all(|w| w[1] > w[0]), "{max}: {t:?}");
    }
}

#[test]
fn false_colour_figure_refuses_an_empty_map() {
    let m = FalseColourMap {
        png: &[],
        width: 0,
        height: 3,
        scale_max: 1.0,
        quantity: "ΔE00",
        title: "t",
        notes: &[],
    };
    assert!(false_colour_map_svg(&m).unwrap_err().contains("no pixels"));
}

/// The distance (px) from `p` to the segment `a`–`b`.
fn distance_to_segment(p: (f64, f64), a: (f64, f64), b: (f64, f64)) -> f64 {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let len2 = dx * dx + dy * dy;
    let t = if len2 == 0.0 {
        0.0
    } else {
        (((p.0 - a.0) * dx + (p.1 - a.1) * dy) / len2).clamp(0.0, 1.0)
    };
    (p.0 - a.0 - t * dx).hypot(p.1 - a.1 - t * dy)
}

/// The zoomed chromaticity panel clamped every vertex of the gamut
/// triangles to the zoom box instead of clipping the lines: a diagonal ran
/// from corner to corner through the data (nstep3 looked as if it sat on
/// the gamut's edge) and false edges ran along the frame. Here the data sit
/// on both gamuts' red–green edge, so the box cuts both triangles: every
/// grey segment the panel draws must lie inside the box and on a true edge
/// of a gamut.
#[test]
fn zoomed_chromaticity_panel_draws_no_false_gamut_edges() {
    let data = [(0.46, 0.455), (0.48, 0.47)];
    let svg = chromaticity_chart("WHITE: chromaticity", Observer::JuddVos, &[scatter("measured", &data)]).unwrap();
    keep_for_a_look("chromaticity-zoom", &svg);
    assert_readable("chromaticity-zoom", &svg);
    // The zoomed panel is the second of two 440 px panels.
    let (left, right) = (440.0, 880.0);
    let in_panel = |x: f64| x > left && x < right;
    // The data's pixels from the measurement's markers (full size there).
    let mut marks: Vec<(f64, f64)> = elements(&svg, "circle")
        .iter()
        .filter(|(a, _)| num(a, "r") == MEASUREMENT_PX as f64 && in_panel(num(a, "cx")))
        .map(|(a, _)| (num(a, "cx"), num(a, "cy")))
        .collect();
    marks.sort_by(|a, b| a.0.total_cmp(&b.0));
    assert_eq!(marks.len(), 2, "the two measured points in the zoomed panel");
    let sx = (marks[1].0 - marks[0].0) / (data[1].0 - data[0].0);
    let sy = (marks[1].1 - marks[0].1) / (data[1].1 - data[0].1);
    let to_px = |p: (f64, f64)| (marks[0].0 + sx * (p.0 - data[0].0), marks[0].1 + sy * (p.1 - data[0].1));
    // The zoom box as the chart computes it: the data's bounds padded 5 %,
    // made square about their centre.
    let (xs, ys) = (
        super::axes::bounds(data.iter().map(|p| p.0)),
        super::axes::bounds(data.iter().map(|p| p.1)),
    );
    let half = ((xs.1 - xs.0).max(ys.1 - ys.0) / 2.0).max(0.005);
    let (cx, cy) = ((xs.0 + xs.1) / 2.0, (ys.0 + ys.1) / 2.0);
    let (x0, y1) = to_px((cx - half, cy - half));
    let (x1, y0) = to_px((cx + half, cy + half));
    let edges: Vec<((f64, f64), (f64, f64))> = [RgbSpace::SRGB, RgbSpace::RADIANCE]
        .iter()
        .flat_map(|s| {
            let v = [(s.red.x, s.red.y), (s.green.x, s.green.y), (s.blue.x, s.blue.y)];
            (0..3).map(move |k| (v[k], v[(k + 1) % 3]))
        })
        .map(|(a, b)| (to_px(a), to_px(b)))
        .collect();
    let grey = colour_hex(RGBColor(100, 100, 100));
    let mut segments = 0;
    for (attrs, _) in elements(&svg, "polyline") {
        if attr(&attrs, "stroke").as_deref() != Some(grey.as_str()) {
            continue;
        }
        let pts = points_of(&attrs);
        if !pts.iter().all(|p| in_panel(p.0)) {
            continue;
        }
        for w in pts.windows(2) {
            segments += 1;
            for p in w {
                assert!(
                    p.0 >= x0 - 2.0 && p.0 <= x1 + 2.0 && p.1 >= y0 - 2.0 && p.1 <= y1 + 2.0,
                    "a gamut line at {p:?} outside the zoom box ({x0:.0}, {y0:.0})–({x1:.0}, {y1:.0})"
                );
            }
            let on_an_edge = edges
                .iter()
                .any(|(a, b)| w.iter().all(|p| distance_to_segment(*p, *a, *b) < 3.0));
            assert!(
                on_an_edge,
                "the segment {:?}–{:?} lies on no gamut edge: a false edge",
                w[0], w[1]
            );
        }
    }
    assert!(
        segments >= 2,
        "the gamuts' red–green edges cross the zoom box: {segments} segments"
    );
}

/// A speed chart's series, their labels and their timings' spreads.
type SpeedChartData = (Vec<ScatterSeries>, Vec<Vec<String>>, Vec<Vec<(f64, f64)>>);

/// The study's speed chart as `lab::study::report::speed_chart` builds it
/// from a CYLINDER study's sweeps (figures of that shape: the N sweep's
/// twelve codings at nearly one render time, the bounce sweep's points
/// crowding the converged end): one series per coding, each point labelled
/// with what its sweep varied, and the Pareto front. Returns the series,
/// their labels and their spreads.
fn study_speed_series() -> SpeedChartData {
    // (sweep label, coding, seconds, mean ΔE00)
    let mut points: Vec<(String, &str, f64, f64)> = Vec::new();
    for (coding, t, de) in [
        ("rgb", 0.45, 1.5),
        ("srgb", 0.46, 1.2),
        ("nstep3", 0.52, 1.8),
        ("nstep9", 0.58, 0.35),
        ("nstep27", 0.7, 0.07),
        ("nstep81", 0.95, 0.04),
        ("spectral", 1.2, 0.04),
    ] {
        points.push((coding.to_string(), coding, t, de));
    }
    for (samples, t, de) in [
        (256, 0.3, 0.12),
        (1024, 1.2, 0.05),
        (4096, 4.8, 0.03),
        (16384, 19.0, 0.02),
    ] {
        points.push((format!("{samples} p"), "spectral", t, de));
    }
    for (b, t, de) in [
        (0, 0.3, 5.0),
        (1, 0.5, 2.0),
        (2, 0.7, 0.8),
        (3, 0.85, 0.3),
        (4, 0.95, 0.12),
        (5, 1.0, 0.06),
        (6, 1.05, 0.045),
        (7, 1.1, 0.042),
        (8, 1.12, 0.041),
    ] {
        points.push((format!("{b} b"), "spectral", t, de));
    }
    for (n, t, de) in [
        (1, 0.44, 8.0),
        (2, 0.46, 4.0),
        (3, 0.5, 1.8),
        (5, 0.5, 0.9),
        (7, 0.52, 0.5),
        (9, 0.57, 0.35),
        (15, 0.6, 0.15),
        (20, 0.62, 0.1),
        (27, 0.69, 0.07),
        (40, 0.75, 0.05),
        (54, 0.82, 0.045),
        (81, 0.97, 0.04),
    ] {
        let coding = STUDY_N_SWEEP.iter().find(|c| **c == format!("nstep{n}")).unwrap();
        points.push((coding.to_string(), coding, t, de));
    }
    let mut codings: Vec<&str> = Vec::new();
    for p in &points {
        if !codings.contains(&p.1) {
            codings.push(p.1);
        }
    }
    let mut series = Vec::new();
    let mut labels = Vec::new();
    let mut spreads = Vec::new();
    for c in codings {
        let mine: Vec<_> = points.iter().filter(|p| p.1 == c).collect();
        series.push(scatter(c, &mine.iter().map(|p| (p.2, p.3)).collect::<Vec<_>>()));
        labels.push(mine.iter().map(|p| p.0.clone()).collect());
        spreads.push(mine.iter().map(|p| (p.2 * 0.97, p.2 * 1.04)).collect());
    }
    // The front: no other point both faster and more accurate.
    let mut front: Vec<(f64, f64)> = points
        .iter()
        .map(|p| (p.2, p.3))
        .filter(|&(t, e)| !points.iter().any(|q| q.2 <= t && q.3 <= e && (q.2 < t || q.3 < e)))
        .collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0));
    series.push(ScatterSeries {
        name: "Pareto front".into(),
        points: front,
        connect: true,
    });
    (series, labels, spreads)
}

/// The codings of the study's N sweep (`lab::study::run`'s sweeps).
const STUDY_N_SWEEP: [&str; 12] = [
    "nstep1", "nstep2", "nstep3", "nstep5", "nstep7", "nstep9", "nstep15", "nstep20", "nstep27", "nstep40", "nstep54",
    "nstep81",
];

/// The centre of every marker a chart draws in its plot area (left of the
/// legend column): circles, squares, filled polygons, and the strokes of
/// crosses, pluses and asterisks (not whiskers: horizontal, 2 px; not
/// lines of more than two points; not the grey leaders or black ticks).
fn marker_centres(svg: &str, plot_right: f64) -> Vec<(f64, f64)> {
    let mut centres: Vec<(f64, f64)> = Vec::new();
    let leader = colour_hex(RGBColor(150, 150, 150));
    let mut add = |c: (f64, f64)| {
        if c.0 < plot_right
            && !centres
                .iter()
                .any(|d| (d.0 - c.0).abs() <= 2.0 && (d.1 - c.1).abs() <= 2.0)
        {
            centres.push(c);
        }
    };
    for (a, _) in elements(svg, "circle") {
        add((num(&a, "cx"), num(&a, "cy")));
    }
    for (a, _) in elements(svg, "rect") {
        let (w, h) = (num(&a, "width"), num(&a, "height"));
        if w < 20.0 && h < 20.0 {
            add((num(&a, "x") + w / 2.0, num(&a, "y") + h / 2.0));
        }
    }
    let bbox_centre = |pts: &[(f64, f64)]| {
        let (x0, x1) = pts
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| (l.min(p.0), h.max(p.0)));
        let (y0, y1) = pts
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| (l.min(p.1), h.max(p.1)));
        ((x0 + x1) / 2.0, (y0 + y1) / 2.0, x1 - x0, y1 - y0)
    };
    for (a, _) in elements(svg, "polygon") {
        let (cx, cy, w, h) = bbox_centre(&points_of(&a));
        if w < 20.0 && h < 20.0 {
            add((cx, cy));
        }
    }
    for (a, _) in elements(svg, "polyline") {
        let pts = points_of(&a);
        let width = num(&a, "stroke-width");
        let whisker = pts.len() == 2 && pts[0].1 == pts[1].1 && width == 2.0;
        let stroke = attr(&a, "stroke").unwrap_or_default();
        // Not the leaders, nor the axes' black tick marks.
        if pts.len() != 2 || whisker || stroke == leader || stroke == "#000000" {
            continue;
        }
        let (cx, cy, w, h) = bbox_centre(&pts);
        if w < 20.0 && h < 20.0 {
            add((cx, cy));
        }
    }
    centres
}

/// A log axis' pixel of a value, fitted to its labelled ticks: `ticks` are
/// (value, pixel).
fn log_axis_map(ticks: &[(f64, f64)]) -> impl Fn(f64) -> f64 {
    let (a, b) = (
        ticks.iter().min_by(|p, q| p.0.total_cmp(&q.0)).copied().unwrap(),
        ticks.iter().max_by(|p, q| p.0.total_cmp(&q.0)).copied().unwrap(),
    );
    let slope = (b.1 - a.1) / (b.0.log10() - a.0.log10());
    move |v: f64| a.1 + slope * (v.log10() - a.0.log10())
}

/// Writes a chart the tests drew to `target/tmp/charts/NAME.svg`, for a look.
fn keep_for_a_look(name: &str, svg: &str) {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/tmp/charts");
    if std::fs::create_dir_all(&dir).is_ok() {
        let _ = std::fs::write(dir.join(format!("{name}.svg")), svg);
    }
}

/// The speed-against-accuracy chart labelled the wrong marker: "spectral"
/// sat beside nstep81's × and spectral's + was half cut off at the axis
/// (a scene's chart), and in the study's chart labels piled up while
/// nstep2 and nstep54 were drawn alike (and nstep20 and nstep81 as two
/// green crosses). Over the study's twelve N-step codings (and the rest of
/// its speed chart) no two codings share a colour or a marker, and on both
/// charts every label points at its own point: the marker nearest to it is
/// its point's, or a leader line from its point's marker ends at it; no
/// marker reaches beyond the axes.
#[test]
fn speed_chart_labels_point_at_their_own_markers_and_no_two_codings_share_a_style() {
    // A scene's chart: one point per coding, nstep81 and spectral side by
    // side, spectral's ΔE just above a decade.
    let scene: Vec<ScatterSeries> = [
        ("rgb", 0.5, 2.1),
        ("srgb", 0.52, 1.6),
        ("nstep3", 0.55, 2.5),
        ("nstep9", 0.6, 0.9),
        ("nstep27", 0.75, 0.45),
        ("nstep81", 1.05, 0.108),
        ("spectral", 1.1, 0.102),
    ]
    .iter()
    .map(|&(c, t, de)| scatter(c, &[(t, de)]))
    .collect();
    let scene_labels: Vec<Vec<String>> = scene.iter().map(|s| vec![s.name.clone()]).collect();
    let scene_spreads: Vec<Vec<(f64, f64)>> = scene
        .iter()
        .map(|s| vec![(s.points[0].0 * 0.97, s.points[0].0 * 1.04)])
        .collect();
    let svg = scatter_chart_with_spread(
        "cylinder: speed against accuracy",
        "render time (s, log scale)",
        "mean ΔE*ab (CIELAB units, log scale)",
        &scene,
        &scene_labels,
        &scene_spreads,
        (true, true),
    )
    .unwrap();
    keep_for_a_look("speed-scene", &svg);
    assert_readable("speed-scene", &svg);
    let scene_svg = svg;

    let (series, labels, spreads) = study_speed_series();
    let svg = scatter_chart_with_spread(
        "CYLINDER: speed against accuracy (p = paths per target, b = bounces)",
        "render time (s, log scale)",
        "mean ΔE00 (CIEDE2000 units, log scale)",
        &series,
        &labels,
        &spreads,
        (true, true),
    )
    .unwrap();
    keep_for_a_look("speed-study", &svg);
    assert_readable("speed-study", &svg);
    labels_point_at_their_own_points(&scene_svg, &scene, &scene_labels);
    labels_point_at_their_own_points(&svg, &series, &labels);

    // spectral on the lowest ΔE, nstep81 a marker's width right of it and
    // nstep27 left: above spectral is the only free place beside it, as
    // near nstep81's × as its own +.
    let edge: Vec<ScatterSeries> = [
        ("rgb", 0.5, 2.1),
        ("nstep27", 0.88, 0.102),
        ("spectral", 1.0, 0.102),
        ("nstep81", 1.07, 0.102),
    ]
    .iter()
    .map(|&(c, t, de)| scatter(c, &[(t, de)]))
    .collect();
    let edge_labels: Vec<Vec<String>> = edge.iter().map(|s| vec![s.name.clone()]).collect();
    let svg = scatter_chart_labelled(
        "edge",
        "t (s, log scale)",
        "ΔE (log scale)",
        &edge,
        &edge_labels,
        (true, true),
    )
    .unwrap();
    keep_for_a_look("speed-edge", &svg);
    assert_readable("speed-edge", &svg);
    labels_point_at_their_own_points(&svg, &edge, &edge_labels);

    // The styles: twelve markers and twelve colours for the N sweep, and
    // nothing shared with rgb, srgb or spectral.
    let style = |c: &str| coding_style(c).unwrap_or_else(|| panic!("{c} is a coding"));
    for (i, a) in STUDY_N_SWEEP.iter().enumerate() {
        for b in &STUDY_N_SWEEP[i + 1..] {
            assert_ne!(style(a).marker, style(b).marker, "{a} and {b} share a marker");
            assert_ne!(style(a).colour, style(b).colour, "{a} and {b} share a colour");
        }
    }
    let all: Vec<&str> = STUDY_N_SWEEP
        .iter()
        .copied()
        .chain(["rgb", "srgb", "spectral"])
        .collect();
    for (i, a) in all.iter().enumerate() {
        for b in &all[i + 1..] {
            assert!(
                style(a).colour != style(b).colour || style(a).marker != style(b).marker,
                "{a} and {b} are drawn alike"
            );
        }
    }
}

/// On a log–log scatter chart: every label on the chart (or its number
/// from the key) is nearest to one of its own points' markers, or a leader
/// from such a marker ends at it; labels do not overlap; at least half are
/// on the chart; no marker reaches beyond the axes.
fn labels_point_at_their_own_points(svg: &str, series: &[ScatterSeries], labels: &[Vec<String>]) {
    let plot_right = (W - LEGEND_W) as f64;
    // Each point's pixel, from the axes' labelled ticks.
    let numbers: Vec<(String, f64, f64, f64)> = elements(svg, "text")
        .into_iter()
        .filter_map(|(a, c)| {
            Some((
                attr(&a, "text-anchor")?,
                num(&a, "x"),
                num(&a, "y"),
                c.parse::<f64>().ok()?,
            ))
        })
        .filter(|t| t.3 > 0.0)
        .collect();
    let x_ticks: Vec<(f64, f64)> = numbers.iter().filter(|t| t.0 == "middle").map(|t| (t.3, t.1)).collect();
    let y_ticks: Vec<(f64, f64)> = numbers.iter().filter(|t| t.0 == "end").map(|t| (t.3, t.2)).collect();
    assert!(x_ticks.len() >= 2 && y_ticks.len() >= 2, "{x_ticks:?} {y_ticks:?}");
    let (px, py) = (log_axis_map(&x_ticks), log_axis_map(&y_ticks));
    // Where each label's points are (a label may be on two points: nstep3
    // of the coding sweep and of the N sweep).
    let mut owners: Vec<(String, (f64, f64))> = Vec::new();
    for (s, ls) in series.iter().zip(labels) {
        for (p, l) in s.points.iter().zip(ls) {
            owners.push((l.clone(), (px(p.0), py(p.1))));
        }
    }
    // The numbers in the key: "[k] label (series)".
    let key: Vec<(String, String)> = texts(svg)
        .into_iter()
        .filter(|t| t.0 > plot_right && t.2.starts_with('['))
        .filter_map(|t| {
            let (number, rest) = t.2.split_once(' ')?;
            let label = rest.rsplit_once(" (")?.0;
            Some((number.to_string(), label.to_string()))
        })
        .collect();
    let markers = marker_centres(svg, plot_right);
    let leaders: Vec<Vec<(f64, f64)>> = elements(svg, "polyline")
        .into_iter()
        .filter(|(a, _)| attr(a, "stroke").as_deref() == Some(colour_hex(RGBColor(150, 150, 150)).as_str()))
        .map(|(a, _)| points_of(&a))
        .collect();
    let dist = |a: (f64, f64), b: (f64, f64)| (a.0 - b.0).hypot(a.1 - b.1);
    let box_dist = |p: (f64, f64), b: (f64, f64, f64, f64)| {
        let dx = (b.0 - p.0).max(p.0 - b.2).max(0.0);
        let dy = (b.1 - p.1).max(p.1 - b.3).max(0.0);
        dx.hypot(dy)
    };
    let nearest = |from: &dyn Fn((f64, f64)) -> f64| {
        markers
            .iter()
            .copied()
            .min_by(|a, b| from(*a).total_cmp(&from(*b)))
            .unwrap()
    };
    let all_labels: Vec<&String> = labels.iter().flatten().collect();
    let mut on_chart = 0;
    let mut boxes = Vec::new();
    for (x, y, text) in texts(svg).into_iter().filter(|t| t.0 < plot_right) {
        let label = if text.starts_with('[') {
            match key.iter().find(|(n, _)| *n == text) {
                Some((_, l)) => l.clone(),
                None => panic!("the number {text} is not in the key"),
            }
        } else if all_labels.contains(&&text) {
            text.clone()
        } else {
            continue;
        };
        on_chart += 1;
        let b = label_box(x, y, &text);
        boxes.push(b);
        let mine: Vec<(f64, f64)> = owners.iter().filter(|o| o.0 == label).map(|o| o.1).collect();
        let leader = leaders.iter().find(|l| box_dist(*l.last().unwrap(), b) <= 2.0);
        let marker = match leader {
            Some(l) => nearest(&|m| dist(m, l[0])),
            None => nearest(&|m| box_dist(m, b)),
        };
        assert!(
            mine.iter().any(|p| dist(*p, marker) <= 3.0),
            "label {text:?} ({label}) at ({x}, {y}) points at the marker at {marker:?}, not at its point {mine:?}{}",
            if leader.is_some() { " (by its leader)" } else { "" }
        );
    }
    assert!(
        on_chart * 2 >= all_labels.len(),
        "{on_chart} of {} labels on the chart",
        all_labels.len()
    );
    for (i, a) in boxes.iter().enumerate() {
        for b in &boxes[i + 1..] {
            assert!(!boxes_overlap(*a, *b), "labels at {a:?} and {b:?} overlap");
        }
    }
    // No marker sticks out of the plot: each is inside the axes' range.
    let (x_lo, x_hi) = (
        px(x_ticks.iter().map(|t| t.0).fold(f64::INFINITY, f64::min)),
        px(x_ticks.iter().map(|t| t.0).fold(0.0, f64::max)),
    );
    let (y_hi, y_lo) = (
        py(y_ticks.iter().map(|t| t.0).fold(f64::INFINITY, f64::min)),
        py(y_ticks.iter().map(|t| t.0).fold(0.0, f64::max)),
    );
    for (_, p) in &owners {
        let r = MARKER_PX as f64 + 1.0;
        assert!(
            p.0 - r >= x_lo - 1.0 && p.0 + r <= x_hi + 1.0 && p.1 - r >= y_lo - 1.0 && p.1 + r <= y_hi + 1.0,
            "the marker at {p:?} reaches beyond the axes ({x_lo}–{x_hi}, {y_lo}–{y_hi})"
        );
    }
}

/// The whole chromaticity diagram wrote "460" on the corner of the
/// RADIANCE RGB gamut's dashed line (outward from white the label left the
/// plot, so it went inward, onto the gamuts' blue corners): no wavelength
/// label's box meets a gamut's line, the locus or another label.
#[test]
fn locus_460_nm_label_on_the_radiance_gamut_corner() {
    let grey = colour_hex(RGBColor(100, 100, 100));
    for observer in [Observer::JuddVos, Observer::Cie1931] {
        let svg = chromaticity_chart("xy", observer, &[scatter("measured", &[(0.31, 0.33)])]).unwrap();
        keep_for_a_look(&format!("locus-labels-{}", observer.label().replace(' ', "-")), &svg);
        let panel = 440.0;
        let labels: Vec<TextBox> = texts_drawn(&svg)
            .into_iter()
            .filter(|t| {
                t.x < panel
                    && t.content.len() == 3
                    && t.content.parse::<u32>().is_ok_and(|nm| (460..=620).contains(&nm))
            })
            .collect();
        assert_eq!(labels.len(), 9, "{observer:?}: the nine wavelength labels");
        let segments: Vec<(String, Px, Px)> = lines_drawn(&svg)
            .into_iter()
            .filter(|l| l.points.iter().all(|p| p.0 < panel))
            .filter(|l| l.stroke == grey || (l.stroke == "#000000" && l.points.len() > 2))
            .flat_map(|l| {
                let what = if l.stroke == grey {
                    "a gamut's line"
                } else {
                    "the locus"
                };
                l.points
                    .windows(2)
                    .map(|w| (what.to_string(), w[0], w[1]))
                    .collect::<Vec<_>>()
            })
            .collect();
        assert!(segments.len() > 20, "{observer:?}: the locus and the gamuts are drawn");
        for (i, t) in labels.iter().enumerate() {
            for (what, a, b) in &segments {
                assert!(
                    !segment_meets_box(*a, *b, t.bbox),
                    "{observer:?}: the {} nm label at {:?} lies on {what} ({a:?}–{b:?})",
                    t.content,
                    t.bbox
                );
            }
            for u in &labels[i + 1..] {
                assert!(
                    !boxes_overlap(t.bbox, u.bbox),
                    "{observer:?}: the {} and {} nm labels overlap",
                    t.content,
                    u.content
                );
            }
        }
    }
}

/// Asserts that a line of `colour` runs through the pixels `at`, vertex by
/// vertex (1.5 px for rounding), every vertex inside the plot.
fn assert_line_through(name: &str, svg: &str, plot: &Plot, colour: &str, at: &[Px]) {
    let lines: Vec<Line> = lines_drawn(svg)
        .into_iter()
        .filter(|l| l.stroke == colour && l.points.len() == at.len())
        .collect();
    let runs = |l: &Line| {
        l.points
            .iter()
            .zip(at)
            .all(|(p, q)| (p.0 - q.0).abs() <= 1.5 && (p.1 - q.1).abs() <= 1.5)
    };
    let line = lines
        .iter()
        .find(|l| runs(l))
        .unwrap_or_else(|| panic!("{name}: no {colour} line through {at:?}; {colour} lines: {lines:?}"));
    for p in &line.points {
        assert!(
            plot.holds(*p),
            "{name}: the {colour} line's vertex {p:?} is outside the plot {:?}",
            plot.area
        );
    }
}

/// Asserts that a marker of `colour` is drawn at each pixel of `at`
/// (2.5 px: a triangle's box is centred 1 px off its point), inside the
/// plot; returns those markers.
fn assert_marks_at(name: &str, svg: &str, plot: &Plot, colour: &str, at: &[Px]) -> Vec<Mark> {
    let marks = marks_drawn(svg);
    at.iter()
        .map(|p| {
            let m = marks
                .iter()
                .find(|m| m.colour == colour && (m.at.0 - p.0).abs() <= 2.5 && (m.at.1 - p.1).abs() <= 2.5)
                .unwrap_or_else(|| panic!("{name}: no {colour} marker at {p:?}"));
            assert!(
                plot.holds((m.bbox.0, m.bbox.1)) && plot.holds((m.bbox.2, m.bbox.3)),
                "{name}: the {colour} marker {:?} leaves the plot {:?}",
                m.bbox,
                plot.area
            );
            m.clone()
        })
        .collect()
}

/// Asserts that the legend entry `entry` shows a glyph in `colour`, and only that colour.
fn assert_legend(name: &str, svg: &str, entry: &str, colour: &str) {
    // The chart legends wrap their names at 18 characters; the grid's does not.
    let first = if texts_drawn(svg).iter().any(|t| t.content == entry) {
        entry.to_string()
    } else {
        wrap(entry, 18)[0].clone()
    };
    let colours = legend_colours(svg, &first);
    assert_eq!(
        colours,
        [colour],
        "{name}: the legend's {entry:?} is drawn in {colours:?}, not {colour}"
    );
}

/// The single plot of a chart.
fn the_plot(name: &str, svg: &str) -> Plot {
    let mut plots = plots_drawn(svg);
    assert_eq!(plots.len(), 1, "{name}: one plot with its axes");
    plots.remove(0)
}

/// Line charts (linear and log x) and profiles (linear and log y) draw each
/// series as a line through its points and a marker on each, where the
/// axes' tick labels put them; the highest value is the topmost marker; the
/// legend shows each series in its colour; ticks rise along their axes.
#[test]
fn line_and_profile_charts_draw_each_series_through_its_points() {
    let rgb = colour_hex(coding_style("rgb").unwrap().colour);
    let pink = colour_hex(coding_style("nstep3").unwrap().colour);
    let a = [(0.1, 3.0), (0.5, 1.0), (2.0, 0.4)];
    let b = [(0.1, 2.0), (0.5, 2.5), (2.0, 1.5)];
    let mut with_errors = series("rgb", &a);
    with_errors.errors = Some(vec![0.1, 0.2, 0.1]);
    for log_x in [false, true] {
        let name = format!("line-log-{log_x}");
        let svg = line_chart("speed", "time (s)", "ΔE", &[with_errors, series("nstep3", &b)], log_x).unwrap();
        with_errors = series("rgb", &a);
        keep_for_a_look(&name, &svg);
        assert_readable(&name, &svg);
        let plot = the_plot(&name, &svg);
        let (px, py) = (plot.x.map(), plot.y.map());
        for (colour, data) in [(&rgb, &a), (&pink, &b)] {
            let at: Vec<Px> = data.iter().map(|p| (px(p.0), py(p.1))).collect();
            assert_line_through(&name, &svg, &plot, colour, &at);
            let marks = assert_marks_at(&name, &svg, &plot, colour, &at);
            // The highest value is the topmost marker; x = a left of x = b.
            let top = data
                .iter()
                .enumerate()
                .max_by(|p, q| p.1 .1.total_cmp(&q.1 .1))
                .unwrap()
                .0;
            assert!(
                marks.iter().all(|m| m.at.1 >= marks[top].at.1),
                "{name}: the highest {colour} value is not on top"
            );
            assert!(marks.windows(2).all(|w| w[0].at.0 < w[1].at.0), "{name}: x order lost");
        }
        assert_legend(&name, &svg, "rgb", &rgb);
        assert_legend(&name, &svg, "nstep3", &pink);
    }
    // Profiles: targets in order on the x axis, linear and (Cornell) log y.
    let targets: Vec<String> = ["wall", "ceiling", "light"].map(String::from).to_vec();
    for (tag, ys) in [("linear", [30.0, 12.0, 45.0]), ("log", [3.0e3, 5.0e2, 9.0e5])] {
        let name = format!("profile-{tag}");
        let data: Vec<(f64, f64)> = ys.iter().enumerate().map(|(i, y)| (i as f64 + 1.0, *y)).collect();
        let measured: Vec<(f64, f64)> = data.iter().map(|p| (p.0, p.1 * 1.1)).collect();
        let svg = profile_chart(
            "profile",
            &targets,
            "target",
            "Y (cd/m²)",
            &[series("measured", &measured), series("nstep3", &data)],
        )
        .unwrap();
        keep_for_a_look(&name, &svg);
        assert_readable(&name, &svg);
        let plot = the_plot(&name, &svg);
        let names: Vec<&str> = plot.x.ticks.iter().map(|t| t.0.content.as_str()).collect();
        assert_eq!(names, ["wall", "ceiling", "light"], "{name}: targets in order");
        let py = plot.y.map();
        for (colour, d) in [(&pink, &data), (&"#000000".to_string(), &measured)] {
            let at: Vec<Px> = d
                .iter()
                .map(|p| (plot.x_slot(&targets[p.0 as usize - 1]), py(p.1)))
                .collect();
            assert_line_through(&name, &svg, &plot, colour, &at);
            assert_marks_at(&name, &svg, &plot, colour, &at);
        }
        assert_legend(&name, &svg, "nstep3", &pink);
        assert_legend(&name, &svg, "measured", "#000000");
    }
}

/// A line chart on a log x axis (a Pareto chart of render times) drew a
/// point at a whole decade (0.1 s) on the plot's left edge, its marker half
/// outside, and a profile's log y axis did the same with a value on a
/// decade (a wall at 1000 cd/m²): the scatter chart's margin
/// (`LOG_MARGIN`) applies to every log axis, so each marker lies inside.
#[test]
fn log_axis_point_on_a_decade_sits_half_outside_the_plot() {
    let charts = [
        (
            "line-log-x-decade",
            line_chart(
                "p",
                "time (s)",
                "ΔE",
                &[series("rgb", &[(0.1, 3.0), (10.0, 1.0)])],
                true,
            )
            .unwrap(),
        ),
        (
            "profile-log-y-decade",
            profile_chart(
                "p",
                &["wall".into(), "light".into()],
                "target",
                "Y (cd/m²)",
                &[series("rgb", &[(1.0, 1000.0), (2.0, 1.0e6)])],
            )
            .unwrap(),
        ),
    ];
    let orange = colour_hex(coding_style("rgb").unwrap().colour);
    for (name, svg) in &charts {
        keep_for_a_look(name, svg);
        let plot = the_plot(name, svg);
        let marks: Vec<Mark> = marks_drawn(svg)
            .into_iter()
            .filter(|m| m.colour == orange && plot.holds(m.at))
            .collect();
        assert_eq!(marks.len(), 2, "{name}: both points drawn");
        for m in marks {
            assert!(
                plot.holds((m.bbox.0, m.bbox.1)) && plot.holds((m.bbox.2, m.bbox.3)),
                "{name}: the marker {:?} reaches out of the plot {:?}",
                m.bbox,
                plot.area
            );
        }
    }
}

/// A spectrum draws its mean as a black line through every sample, from
/// the plot's left edge (the first wavelength) to its right edge (the
/// last), its peak the topmost point, each raw sample as a blue line and
/// the ±1 SD band around the mean; a reflectance draws ρ, the line ρ = 1
/// edge to edge, and a red dot on each value outside [0, 1]. Each legend
/// entry shows its own colour.
#[test]
fn spectrum_and_reflectance_charts_draw_their_curves_where_they_are() {
    let wl: Vec<f64> = (0..41).map(|i| 380.0 + 10.0 * i as f64).collect();
    let mean: Vec<f64> = wl
        .iter()
        .map(|w| 1e-3 * (-((w - 550.0) / 60.0).powi(2)).exp() + 2e-4)
        .collect();
    let sd = vec![2e-5; wl.len()];
    let samples = vec![
        mean.iter().map(|m| m * 0.95).collect::<Vec<f64>>(),
        mean.iter().map(|m| m * 1.05).collect(),
    ];
    let svg = spectrum_chart("patch", &wl, Some(&mean), Some(&sd), &samples).unwrap();
    let name = "spectrum";
    keep_for_a_look(name, &svg);
    assert_readable(name, &svg);
    let plot = the_plot(name, &svg);
    let (px, py) = (plot.x.map(), plot.y.map());
    let at = |ys: &[f64]| -> Vec<Px> { wl.iter().zip(ys).map(|(w, y)| (px(*w), py(*y))).collect() };
    assert_line_through(name, &svg, &plot, "#000000", &at(&mean));
    let line = at(&mean);
    assert!(
        (line[0].0 - plot.area.0).abs() <= 1.5,
        "{name}: 380 nm is not on the left edge: {:?} {:?}",
        line[0],
        plot.area
    );
    assert!(
        (line[40].0 - plot.area.2).abs() <= 1.5,
        "{name}: 780 nm is not on the right edge: {:?} {:?}",
        line[40],
        plot.area
    );
    let peak = line.iter().min_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
    assert!(
        (peak.0 - px(550.0)).abs() <= 1.5,
        "{name}: the peak is drawn at {peak:?}, not at 550 nm"
    );
    let blue = colour_hex(RGBColor(86, 180, 233));
    for s in &samples {
        assert_line_through(name, &svg, &plot, &blue, &at(s));
    }
    // The band: the mean ± 1 SD at every wavelength.
    let band = elements(&svg, "polygon")
        .into_iter()
        .find(|(a, _)| attr(a, "fill").as_deref() == Some("#CDCDCD"))
        .map(|(a, _)| points_of(&a))
        .expect("the ±1 SD band");
    let edge: Vec<f64> = mean.iter().zip(&sd).map(|(m, s)| m + s).collect();
    for (p, q) in band.iter().zip(at(&edge)) {
        assert!(
            (p.0 - q.0).abs() <= 1.5 && (p.1 - q.1).abs() <= 1.5,
            "{name}: the band's upper edge at {p:?}, not {q:?}"
        );
    }
    assert_legend(name, &svg, "mean", "#000000");
    assert_legend(name, &svg, "raw samples (2)", &blue);
    assert_legend(name, &svg, "±1 SD", "#CDCDCD");

    let rho: Vec<f64> = wl.iter().map(|w| 0.2 + 0.85 * (w - 380.0) / 400.0).collect();
    let u = vec![0.01; wl.len()];
    let svg = reflectance_chart("tile", &wl, &rho, &u).unwrap();
    let name = "reflectance";
    keep_for_a_look(name, &svg);
    assert_readable(name, &svg);
    let plot = the_plot(name, &svg);
    let (px, py) = (plot.x.map(), plot.y.map());
    let at: Vec<Px> = wl.iter().zip(&rho).map(|(w, r)| (px(*w), py(*r))).collect();
    assert_line_through(name, &svg, &plot, "#000000", &at);
    let one = [(plot.area.0, py(1.0)), (plot.area.2, py(1.0))];
    assert_line_through(name, &svg, &plot, &colour_hex(RGBColor(120, 120, 120)), &one);
    let red = colour_hex(RGBColor(213, 94, 0));
    let above: Vec<Px> = at
        .iter()
        .zip(&rho)
        .filter(|(_, r)| **r > 1.0)
        .map(|(p, _)| *p)
        .collect();
    assert!(!above.is_empty());
    assert_eq!(
        marks_drawn(&svg)
            .iter()
            .filter(|m| m.colour == red && plot.holds(m.at))
            .count(),
        above.len(),
        "{name}: one red dot per value above 1"
    );
    assert_marks_at(name, &svg, &plot, &red, &above);
    assert_legend(name, &svg, "ρ(λ) measured", "#000000");
    assert_legend(
        name,
        &svg,
        &format!("outside [0, 1] ({}), flagged, not clipped", above.len()),
        &red,
    );
}

/// A reflectance above 1 at the last wavelength (780 nm, where a tile's
/// ρ often rises) was flagged with a red dot cut in half by the plot's
/// right edge (the x axis ended on the last wavelength): every flagged dot
/// lies wholly inside the plot.
#[test]
fn flagged_reflectance_dot_at_780_nm_half_outside_the_plot() {
    let wl: Vec<f64> = (0..41).map(|i| 380.0 + 10.0 * i as f64).collect();
    let rho: Vec<f64> = wl
        .iter()
        .map(|w| if *w == 380.0 || *w == 780.0 { 1.04 } else { 0.5 })
        .collect();
    let svg = reflectance_chart("tile", &wl, &rho, &vec![0.01; wl.len()]).unwrap();
    keep_for_a_look("reflectance-edges", &svg);
    let plot = the_plot("reflectance", &svg);
    let red = colour_hex(RGBColor(213, 94, 0));
    let dots: Vec<Mark> = marks_drawn(&svg)
        .into_iter()
        .filter(|m| m.colour == red && m.at.0 < plot.area.2 + 20.0)
        .collect();
    assert_eq!(dots.len(), 2, "{dots:?}");
    for d in dots {
        assert!(
            plot.holds((d.bbox.0, d.bbox.1)) && plot.holds((d.bbox.2, d.bbox.3)),
            "the flagged dot {:?} reaches out of the plot {:?}",
            d.bbox,
            plot.area
        );
    }
}

/// The chromaticity diagram draws the locus through every tabulated
/// wavelength's x,y and the gamuts through their primaries, on the whole
/// diagram's axes (0–0.8, 0–0.9); each series' markers where its x,y are
/// in both panels, inside each; the zoomed region's box around the data;
/// and each legend entry in its own colour.
#[test]
fn chromaticity_chart_draws_locus_gamuts_and_data_where_they_are() {
    let measured = [(0.31, 0.33), (0.35, 0.36)];
    let pink_data = [(0.32, 0.345)];
    let svg = chromaticity_chart(
        "xy",
        Observer::JuddVos,
        &[scatter("measured", &measured), scatter("nstep3", &pink_data)],
    )
    .unwrap();
    let name = "chromaticity";
    keep_for_a_look(name, &svg);
    assert_readable(name, &svg);
    let plots = plots_drawn(&svg);
    assert_eq!(plots.len(), 2, "{name}: the whole diagram and the zoomed panel");
    let (whole, zoom) = (&plots[0], &plots[1]);
    let map = |p: &Plot| {
        let (px, py) = (p.x.map(), p.y.map());
        move |q: (f64, f64)| (px(q.0), py(q.1))
    };
    let (w, z) = (map(whole), map(zoom));
    // The whole diagram's axes end on 0.8 and 0.9: on the plot's edges.
    assert!((w((0.0, 0.0)).0 - whole.area.0).abs() <= 1.5 && (w((0.8, 0.9)).0 - whole.area.2).abs() <= 1.5);
    assert!((w((0.0, 0.0)).1 - whole.area.3).abs() <= 1.5 && (w((0.8, 0.9)).1 - whole.area.1).abs() <= 1.5);
    let mut locus: Vec<Px> = spectral_locus(Observer::JuddVos).iter().map(|l| w(l.1)).collect();
    locus.push(locus[0]);
    assert_line_through(name, &svg, whole, "#000000", &locus);
    let grey = colour_hex(RGBColor(100, 100, 100));
    for (space, solid) in [(RgbSpace::SRGB, true), (RgbSpace::RADIANCE, false)] {
        let v = [
            (space.red.x, space.red.y),
            (space.green.x, space.green.y),
            (space.blue.x, space.blue.y),
        ]
        .map(&w);
        if solid {
            assert_line_through(name, &svg, whole, &grey, &[v[0], v[1], v[2], v[0]]);
        } else {
            // Dashes: each on an edge of the triangle, enough to trace it.
            let dashes: Vec<Line> = lines_drawn(&svg)
                .into_iter()
                .filter(|l| l.stroke == grey && l.width == 2.0 && l.points.iter().all(|p| whole.holds(*p)))
                .collect();
            assert!(dashes.len() > 30, "{name}: {} dashes", dashes.len());
            for d in &dashes {
                let on = (0..3).any(|k| {
                    d.points
                        .iter()
                        .all(|p| distance_to_segment(*p, v[k], v[(k + 1) % 3]) <= 1.5)
                });
                assert!(
                    on,
                    "{name}: the dash {:?} lies on no edge of the RADIANCE gamut {v:?}",
                    d.points
                );
            }
        }
    }
    let pink = colour_hex(coding_style("nstep3").unwrap().colour);
    for (plot, to_px) in [(whole, &w as &dyn Fn((f64, f64)) -> Px), (zoom, &z)] {
        assert_marks_at(name, &svg, plot, "#000000", &measured.map(to_px));
        assert_marks_at(name, &svg, plot, &pink, &pink_data.map(to_px));
    }
    // The zoomed region: a red box on the whole diagram around every point.
    let red = colour_hex(RGBColor(200, 0, 0));
    let boxed = lines_drawn(&svg)
        .into_iter()
        .find(|l| l.stroke == red && l.points.iter().all(|p| whole.holds(*p)))
        .expect("the zoomed region");
    let b = bounding(&boxed.points);
    for p in measured.iter().chain(&pink_data) {
        assert!(
            distance_to_box(w(*p), b) == 0.0 && b.2 - b.0 < 60.0,
            "{name}: {p:?} outside the zoomed region's box {b:?}"
        );
    }
    assert_legend(name, &svg, "sRGB gamut", &grey);
    assert_legend(name, &svg, "RADIANCE RGB gamut", &grey);
    assert_legend(name, &svg, "zoomed region", &red);
    assert_legend(name, &svg, "measured", "#000000");
    assert_legend(name, &svg, "nstep3", &pink);
}

/// A bar chart draws each bar in its coding's colour, centred on its own
/// tick (the ticks in the bars' order), from the x axis (0) up to its value,
/// the tallest the highest, with its ±1 SD whisker from value − SD to
/// value + SD.
#[test]
fn bar_chart_draws_each_bar_to_its_value_over_its_label() {
    let bars = [("srgb", 0.8, 0.1), ("nstep3", 2.4, 0.3), ("rgb", 1.5, 0.2)];
    let svg = bar_chart(
        "mean ΔE",
        "ΔE*ab (CIELAB units)",
        &bars
            .iter()
            .map(|&(l, v, sd)| Bar {
                label: l.into(),
                value: v,
                sd: Some(sd),
            })
            .collect::<Vec<_>>(),
    )
    .unwrap();
    let name = "bars";
    keep_for_a_look(name, &svg);
    assert_readable(name, &svg);
    let plot = the_plot(name, &svg);
    let names: Vec<&str> = plot.x.ticks.iter().map(|t| t.0.content.as_str()).collect();
    assert_eq!(names, ["srgb", "nstep3", "rgb"], "{name}: the bars' labels in order");
    let py = plot.y.map();
    let rects: Vec<(String, PxRect)> = elements(&svg, "rect")
        .into_iter()
        .filter(|(a, _)| attr(a, "fill").as_deref() != Some("#FFFFFF"))
        .map(|(a, _)| {
            let (x, y, w, h) = (num(&a, "x"), num(&a, "y"), num(&a, "width"), num(&a, "height"));
            (attr(&a, "fill").unwrap(), (x, y, x + w, y + h))
        })
        .collect();
    assert_eq!(rects.len(), 3, "{name}: three bars");
    for ((label, v, sd), (fill, r)) in bars.iter().zip(&rects) {
        assert_eq!(
            *fill,
            colour_hex(coding_style(label).unwrap().colour),
            "{name}: {label}'s colour"
        );
        let centre = (r.0 + r.2) / 2.0;
        assert!(
            (centre - plot.x_slot(label)).abs() <= 1.5,
            "{name}: {label}'s bar at {centre}, its tick at {}",
            plot.x_slot(label)
        );
        assert!(
            (r.1 - py(*v)).abs() <= 1.5,
            "{name}: {label}'s bar tops at {} for {v} (at {})",
            r.1,
            py(*v)
        );
        assert!(
            (r.3 - py(0.0)).abs() <= 1.5 && (r.3 - plot.area.3).abs() <= 2.0,
            "{name}: {label}'s bar stands at {}, not on the x axis",
            r.3
        );
        let whisker = [(centre.round(), py(v - sd)), (centre.round(), py(v + sd))];
        let found = lines_drawn(&svg).into_iter().any(|l| {
            l.width == 2.0
                && l.points.len() == 2
                && l.points
                    .iter()
                    .zip(&whisker)
                    .all(|(p, q)| (p.0 - q.0).abs() <= 1.5 && (p.1 - q.1).abs() <= 1.5)
        });
        assert!(found, "{name}: no ±1 SD whisker {whisker:?} on {label}");
    }
    let tallest = rects.iter().min_by(|a, b| a.1 .1.total_cmp(&b.1 .1)).unwrap();
    assert_eq!(
        tallest.0,
        colour_hex(coding_style("nstep3").unwrap().colour),
        "{name}: the highest bar is nstep3's"
    );
}

/// A grid chart draws each value as a cell in its row and column, in the
/// colour of its value against the threshold, its number inside it, an
/// outline when it fails; each row's label beside its row, each column's
/// label over its column; each legend swatch in its value's colour beside
/// its label; no text overlapping another.
#[test]
fn grid_chart_draws_each_value_in_its_own_cell() {
    let rows = ["red".to_string(), "grey".to_string()];
    let cols = ["A rgb".to_string(), "B nstep3".to_string(), "C spectral".to_string()];
    let values = [vec![5.0, 0.5, 1.2], vec![0.25, 20.0, 2.5]];
    let threshold = 2.0;
    let svg = grid_chart("map", &rows, &cols, &values, threshold).unwrap();
    let name = "grid";
    keep_for_a_look(name, &svg);
    assert_readable(name, &svg);
    let texts = texts_drawn(&svg);
    let text = |s: &str| {
        texts
            .iter()
            .filter(|t| t.content == s)
            .cloned()
            .collect::<Vec<TextBox>>()
    };
    let cells: Vec<(String, PxRect)> = elements(&svg, "rect")
        .into_iter()
        .filter(|(a, _)| num(a, "width") == 36.0 && num(a, "height") == 22.0)
        .map(|(a, _)| {
            let (x, y) = (num(&a, "x"), num(&a, "y"));
            (attr(&a, "fill").unwrap(), (x, y, x + 36.0, y + 22.0))
        })
        .collect();
    assert_eq!(cells.len(), 6, "{name}: one cell per value");
    let (left, top) = (cells[0].1 .0, cells[0].1 .1);
    let outlines: Vec<PxRect> = elements(&svg, "rect")
        .into_iter()
        .filter(|(a, _)| attr(a, "fill").as_deref() == Some("none") && attr(a, "stroke").as_deref() == Some("#000000"))
        .map(|(a, _)| {
            (
                num(&a, "x"),
                num(&a, "y"),
                num(&a, "x") + num(&a, "width"),
                num(&a, "y") + num(&a, "height"),
            )
        })
        .collect();
    for (r, row) in values.iter().enumerate() {
        for (c, &v) in row.iter().enumerate() {
            let at = (left + 36.0 * c as f64, top + 22.0 * r as f64);
            let cell = cells
                .iter()
                .find(|(_, b)| b.0 == at.0 && b.1 == at.1)
                .unwrap_or_else(|| panic!("{name}: no cell at row {r}, column {c}"));
            assert_eq!(cell.0, colour_hex(grid_colour(v, threshold)), "{name}: the cell of {v}");
            let number = if v < 10.0 { format!("{v:.1}") } else { format!("{v:.0}") };
            let inside = text(&number).iter().any(|t| {
                let b = t.bbox;
                b.0 >= cell.1 .0 && b.2 <= cell.1 .2 && b.1 >= cell.1 .1 - 1.0 && b.3 <= cell.1 .3 + 1.0
            });
            assert!(inside, "{name}: {number} is not written inside its cell {:?}", cell.1);
            let outlined = outlines
                .iter()
                .any(|o| distance_to_box(((o.0 + o.2) / 2.0, (o.1 + o.3) / 2.0), cell.1) == 0.0);
            assert_eq!(outlined, v > threshold, "{name}: the cell of {v} against {threshold}");
        }
        let label = &text(&rows[r])[0];
        let mid = (label.bbox.1 + label.bbox.3) / 2.0;
        assert!(
            label.bbox.2 <= left && mid > top + 22.0 * r as f64 && mid < top + 22.0 * (r + 1) as f64,
            "{name}: row {:?} at {:?} is not beside its row",
            rows[r],
            label.bbox
        );
    }
    for (c, col) in cols.iter().enumerate() {
        let label = &text(col)[0];
        let mid = (label.bbox.0 + label.bbox.2) / 2.0;
        assert!(
            label.bbox.3 <= top && mid > left + 36.0 * c as f64 && mid < left + 36.0 * (c + 1) as f64,
            "{name}: column {col:?} at {:?} is not over its column",
            label.bbox
        );
    }
    for (v, label) in [
        (0.0, "0"),
        (threshold, "2 (threshold)"),
        (3.0 * threshold, "6 (fails, outlined)"),
    ] {
        assert_legend(name, &svg, label, &colour_hex(grid_colour(v, threshold)));
    }
    assert!(grid_chart("bad", &["r".into()], &[], &[vec![1.0]], 2.0).is_err());
}

/// A scatter chart, on every combination of linear and log axes, draws
/// each series' markers where the axes put its points (the highest value
/// topmost, a smaller x further left, all inside the plot), a connected
/// series' line through its points, and each legend entry in its series'
/// colour.
#[test]
fn scatter_chart_draws_every_series_at_its_points() {
    let blue = colour_hex(coding_style("nstep27").unwrap().colour);
    let grey = colour_hex(OTHER_COLOURS[0]);
    let candidates = [(0.1, 2.0), (1.0, 0.5), (0.3, 0.05), (3.0, 0.02)];
    let front = [(0.1, 2.0), (0.3, 0.05), (3.0, 0.02)];
    let series = [
        scatter("nstep27", &candidates),
        ScatterSeries {
            name: "Pareto front".into(),
            points: front.to_vec(),
            connect: true,
        },
    ];
    for log in [(true, true), (true, false), (false, true), (false, false)] {
        let name = format!("scatter-{}-{}", log.0, log.1);
        let svg = scatter_chart("t", "time (s)", "ΔE", &series, log).unwrap();
        keep_for_a_look(&name, &svg);
        assert_readable(&name, &svg);
        let plot = the_plot(&name, &svg);
        let (px, py) = (plot.x.map(), plot.y.map());
        let at = |d: &[(f64, f64)]| -> Vec<Px> { d.iter().map(|p| (px(p.0), py(p.1))).collect() };
        let marks = assert_marks_at(&name, &svg, &plot, &blue, &at(&candidates));
        assert!(
            marks[0].at.1 < marks[1].at.1 && marks[1].at.1 < marks[3].at.1,
            "{name}: the values' order upwards"
        );
        assert!(
            marks[0].at.0 < marks[2].at.0 && marks[2].at.0 < marks[1].at.0,
            "{name}: the times' order rightwards"
        );
        assert_marks_at(&name, &svg, &plot, &grey, &at(&front));
        assert_line_through(&name, &svg, &plot, &grey, &at(&front));
        assert_legend(&name, &svg, "nstep27", &blue);
        assert_legend(&name, &svg, "Pareto front", &grey);
    }
}

/// The psychometric figure draws each observed point at its ΔE00 and
/// percent correct with its interval as a whisker, the fitted curve as a
/// line through its points, chance as a dashed line across the plot at its
/// percent, and each prediction as a hollow diamond at its point.
#[test]
fn psychometric_chart_draws_points_curve_and_chance_where_they_are() {
    let observed = [
        (0.5, 40.0, 30.0, 50.0),
        (1.0, 70.0, 58.0, 80.0),
        (2.0, 95.0, 88.0, 99.0),
    ];
    let curve: Vec<(f64, f64)> = (0..=10)
        .map(|i| (0.2 * f64::from(i), 100.0 / 3.0 + 6.5 * f64::from(i)))
        .collect();
    let f = Psychometric {
        title: "oddity".into(),
        observed: vec![PsychometricPoints {
            name: "sim1: observed".into(),
            points: observed.to_vec(),
        }],
        curve: Some(("fit: d′ = ΔE00/σ".into(), curve.clone())),
        predicted: vec![(0.3, 36.0, "nstep81".into())],
        chance_percent: 100.0 / 3.0,
    };
    let svg = psychometric_chart(&f).unwrap();
    let name = "psychometric";
    keep_for_a_look(name, &svg);
    assert_readable(name, &svg);
    let plot = the_plot(name, &svg);
    let (px, py) = (plot.x.map(), plot.y.map());
    let grey = colour_hex(OTHER_COLOURS[0]);
    let at: Vec<Px> = observed.iter().map(|p| (px(p.0), py(p.1))).collect();
    assert_marks_at(name, &svg, &plot, &grey, &at);
    for p in &observed {
        assert_line_through(name, &svg, &plot, &grey, &[(px(p.0), py(p.2)), (px(p.0), py(p.3))]);
    }
    let line: Vec<Px> = curve.iter().map(|p| (px(p.0), py(p.1))).collect();
    assert_line_through(name, &svg, &plot, "#000000", &line);
    // Chance: dashes along y = 33.3 %, from edge to edge.
    let dashes: Vec<Line> = lines_drawn(&svg)
        .into_iter()
        .filter(|l| {
            l.width == 1.0
                && l.points.len() == 2
                && l.points
                    .iter()
                    .all(|p| plot.holds(*p) && (p.1 - py(100.0 / 3.0)).abs() <= 1.5)
        })
        .filter(|l| (l.points[0].0 - l.points[1].0).abs() < 10.0)
        .collect();
    let xs = bounding(&dashes.iter().flat_map(|d| d.points.clone()).collect::<Vec<_>>());
    assert!(
        dashes.len() > 20 && xs.0 - plot.area.0 <= 10.0 && plot.area.2 - xs.2 <= 10.0,
        "{name}: chance is not dashed across the plot: {} dashes over {xs:?}",
        dashes.len()
    );
    assert_marks_at(name, &svg, &plot, "#000000", &[(px(0.3), py(36.0))]);
    assert_legend(name, &svg, "sim1: observed", &grey);
    assert_legend(name, &svg, "fit: d′ = ΔE00/σ", "#000000");
    assert_legend(name, &svg, "chance (33 %)", &colour_hex(RGBColor(100, 100, 100)));
}

/// Fig. 5 draws each d′ bar in its coding's colour over its own tick (the
/// groups in order), up to its d′ on the left axis; percent correct as a
/// diamond over its bar at its percent on the right axis; chance dashed at
/// 33.3 % on the right axis; each group's name over the middle of its bars.
#[test]
fn discrimination_chart_draws_bars_and_diamonds_on_their_axes() {
    let bar = |group: &str, coding: &str, d: f64, pc: f64| DiscriminationBar {
        group: group.into(),
        coding: coding.into(),
        d_prime: d,
        interval: (d * 0.8, d * 1.2),
        upper_bounded: true,
        percent_correct: pc,
    };
    let bars = [
        bar("white", "nstep3", 3.0, 90.0),
        bar("white", "nstep9", 0.5, 40.0),
        bar("cylinder", "nstep3", 2.0, 75.0),
        bar("cylinder", "nstep27", 0.2, 35.0),
    ];
    let svg = discrimination_chart("Fig. 5", "differencing", &bars).unwrap();
    let name = "discrimination";
    keep_for_a_look(name, &svg);
    assert_readable(name, &svg);
    let plot = the_plot(name, &svg);
    let y2 = plot.y2.as_ref().expect("the percent-correct axis on the right");
    let (py, py2) = (plot.y.map(), y2.map());
    let names: Vec<&str> = plot.x.ticks.iter().map(|t| t.0.content.as_str()).collect();
    assert_eq!(
        names,
        ["nstep3", "nstep9", "nstep3", "nstep27"],
        "{name}: the bars in their groups' order"
    );
    let rects: Vec<(String, PxRect)> = elements(&svg, "rect")
        .into_iter()
        .filter(|(a, _)| attr(a, "fill").as_deref() != Some("#FFFFFF"))
        .map(|(a, _)| {
            let (x, y, w, h) = (num(&a, "x"), num(&a, "y"), num(&a, "width"), num(&a, "height"));
            (attr(&a, "fill").unwrap(), (x, y, x + w, y + h))
        })
        .collect();
    assert_eq!(rects.len(), 4);
    let mut centres = Vec::new();
    for ((b, (fill, r)), tick) in bars.iter().zip(&rects).zip(&plot.x.ticks) {
        let centre = (r.0 + r.2) / 2.0;
        centres.push(centre);
        assert_eq!(
            *fill,
            colour_hex(coding_style(&b.coding).unwrap().colour),
            "{name}: {}'s colour",
            b.coding
        );
        assert!(
            (centre - tick.1).abs() <= 1.5,
            "{name}: {}'s bar at {centre}, its tick at {}",
            b.coding,
            tick.1
        );
        assert!(
            (r.1 - py(b.d_prime)).abs() <= 1.5 && (r.3 - py(0.0)).abs() <= 1.5,
            "{name}: {}'s bar spans {r:?}",
            b.coding
        );
        assert_marks_at(name, &svg, &plot, "#000000", &[(centre, py2(b.percent_correct))]);
    }
    let chance = lines_drawn(&svg)
        .into_iter()
        .filter(|l| l.stroke == "#5A5A5A" && l.points.iter().all(|p| (p.1 - py2(100.0 / 3.0)).abs() <= 1.5))
        .count();
    assert!(
        chance > 20,
        "{name}: chance is not dashed at 33 % of the right axis ({chance} dashes)"
    );
    for (g, k) in [("white", 0), ("cylinder", 2)] {
        let t = texts_drawn(&svg)
            .into_iter()
            .find(|t| t.content == g)
            .expect("group name");
        let mid = (centres[k] + centres[k + 1]) / 2.0;
        assert!(
            ((t.bbox.0 + t.bbox.2) / 2.0 - mid).abs() <= 2.0 && t.bbox.3 <= py2(100.0) - 7.0,
            "{name}: {g:?} at {:?}, its bars' middle {mid}",
            t.bbox
        );
    }
}

/// The false-colour figure draws the map, and its colour bar's ticks from 0
/// at the bar's bottom to the scale's top at its top, each label beside its
/// tick, rising upwards; no text overlapping another.
#[test]
fn false_colour_bar_ticks_rise_beside_their_marks() {
    let notes = ["values above 2.5 are drawn as 2.5".to_string()];
    let svg = false_colour_map_svg(&FalseColourMap {
        png: &[0u8; 8],
        width: 40,
        height: 30,
        scale_max: 2.5,
        quantity: "ΔE00",
        title: "ΔE00, intended vs shown",
        notes: &notes,
    })
    .unwrap();
    let name = "false-colour";
    keep_for_a_look(name, &svg);
    assert_readable(name, &svg);
    let bar = elements(&svg, "rect")
        .into_iter()
        .find(|(a, _)| attr(a, "fill").as_deref() == Some("url(#scale)"))
        .map(|(a, _)| {
            (
                num(&a, "x"),
                num(&a, "y"),
                num(&a, "x") + num(&a, "width"),
                num(&a, "y") + num(&a, "height"),
            )
        })
        .expect("the colour bar");
    let image = elements(&svg, "image").into_iter().next().expect("the map").0;
    assert!(
        num(&image, "x") + num(&image, "width") < bar.0,
        "the map is left of its bar"
    );
    let ticks: Vec<f64> = elements(&svg, "line").into_iter().map(|(a, _)| num(&a, "y1")).collect();
    let texts = texts_drawn(&svg);
    let mut labelled: Vec<(f64, f64)> = ticks
        .iter()
        .map(|y| {
            let t = texts
                .iter()
                .find(|t| t.bbox.0 >= bar.2 && ((t.bbox.1 + t.bbox.3) / 2.0 - y).abs() <= 4.0)
                .unwrap_or_else(|| panic!("no label beside the tick at y {y}"));
            (t.content.parse::<f64>().unwrap(), *y)
        })
        .collect();
    labelled.sort_by(|a, b| b.1.total_cmp(&a.1));
    assert_eq!(
        labelled.first().map(|t| (t.0, t.1)),
        Some((0.0, bar.3)),
        "0 at the bar's bottom"
    );
    assert_eq!(
        labelled.last().map(|t| (t.0, t.1)),
        Some((2.5, bar.1)),
        "the top at the bar's top"
    );
    assert!(
        labelled.windows(2).all(|w| w[1].0 > w[0].0),
        "ticks rise upwards: {labelled:?}"
    );
}
