//! Scatter charts: points per series, labelled or with their spread.

use super::*;

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
    scatter_chart_labelled(title, x_desc, y_desc, series, &[], log)
}

/// [`scatter_chart`] with a text label beside points: `labels[i][j]` for
/// point j of series i (missing or empty: no label).
pub fn scatter_chart_labelled(
    title: &str,
    x_desc: &str,
    y_desc: &str,
    series: &[ScatterSeries],
    labels: &[Vec<String>],
    log: (bool, bool),
) -> ChartResult {
    scatter_chart_with_spread(title, x_desc, y_desc, series, labels, &[], log)
}

/// [`scatter_chart_labelled`] with a horizontal whisker through points:
/// `x_spread[i][j] = (low, high)` of point j of series i (a timing's fastest
/// and slowest repeat; missing: none).
///
/// On a log axis a value ≤ 0 has no place: such a point is drawn hollow on
/// the axis' lower (left) edge and a note beside the plot says how many
/// there are; no other value is clamped. Labels are placed where they
/// overlap no other label, marker or whisker (see [`label_places`]); a
/// label that fits nowhere gets a number at its point (or, if even that
/// fits nowhere, its coordinates) and is spelled out in a key under the
/// legend. The chart grows taller when the key needs the room.
pub fn scatter_chart_with_spread(
    title: &str,
    x_desc: &str,
    y_desc: &str,
    series: &[ScatterSeries],
    labels: &[Vec<String>],
    x_spread: &[Vec<(f64, f64)>],
    log: (bool, bool),
) -> ChartResult {
    let mut height = H;
    loop {
        let (svg, needed) = scatter_page(title, (x_desc, y_desc), series, labels, x_spread, log, height)?;
        if needed <= height || height >= 3 * H {
            return finished(svg);
        }
        height = needed.min(3 * H);
    }
}

/// How far (a factor) a log axis reaches beyond its extreme values before
/// it is widened to whole decades: 0.05 of a decade, more than a marker's
/// radius on a chart's few decades.
pub(super) const LOG_MARGIN: f64 = 1.122;

/// The scatter chart on a page `height` px tall; also returns the height
/// its legend column (legend, key, notes) needs.
fn scatter_page(
    title: &str,
    (x_desc, y_desc): (&str, &str),
    series: &[ScatterSeries],
    labels: &[Vec<String>],
    x_spread: &[Vec<(f64, f64)>],
    log: (bool, bool),
    height: u32,
) -> Result<(String, u32), String> {
    let spread_x = x_spread.iter().flatten().flat_map(|&(a, b)| [a, b]);
    let all_x = || series.iter().flat_map(|s| s.points.iter().map(|p| p.0));
    let all_y = || series.iter().flat_map(|s| s.points.iter().map(|p| p.1));
    let xs = bounds(all_x().chain(spread_x.clone()));
    let ys = bounds(all_y());
    // A log axis from the positive values (whole decades, see `log_axis`),
    // reaching a little lower when points ≤ 0 will sit on its lower edge, so
    // that a value exactly on a decade stays off that edge.
    let off_x = if log.0 {
        all_x().filter(|v| *v <= 0.0).count()
    } else {
        0
    };
    let off_y = if log.1 {
        all_y().filter(|v| *v <= 0.0).count()
    } else {
        0
    };
    // Each end a little beyond the extreme value (`LOG_MARGIN`), so that
    // no marker sits on the axis, half of it outside the plot (spectral's +
    // on a ΔE just above a decade was).
    let positive = |vals: &mut dyn Iterator<Item = f64>, off: usize| {
        let (lo, hi) = vals
            .filter(|v| *v > 0.0 && v.is_finite())
            .fold((f64::INFINITY, 0.0f64), |(l, h), v| (l.min(v), h.max(v)));
        (if off > 0 { lo * 0.999 } else { lo / LOG_MARGIN }, hi * LOG_MARGIN)
    };
    let lx = positive(&mut all_x().chain(spread_x), off_x);
    let ly = positive(&mut all_y(), off_y);
    let edge = |(lo, hi): (f64, f64)| Ranged::range(&log_axis(lo, hi)).start;
    let (edge_x, edge_y) = (edge(lx), edge(ly));
    let onto_axis = |(x, y): (f64, f64)| {
        let x = if log.0 && x <= 0.0 { edge_x } else { x };
        let y = if log.1 && y <= 0.0 { edge_y } else { y };
        (x, y)
    };
    let hollow: Vec<Vec<bool>> = series
        .iter()
        .map(|s| {
            s.points
                .iter()
                .map(|p| (log.0 && p.0 <= 0.0) || (log.1 && p.1 <= 0.0))
                .collect()
        })
        .collect();
    let shown: Vec<ScatterSeries> = series
        .iter()
        .map(|s| ScatterSeries {
            name: s.name.clone(),
            points: s.points.iter().map(|&p| onto_axis(p)).collect(),
            connect: s.connect,
        })
        .collect();
    let spreads: Vec<Vec<(f64, f64)>> = x_spread
        .iter()
        .map(|sp| {
            sp.iter()
                .map(|&(a, b)| (onto_axis((a, 1.0)).0, onto_axis((b, 1.0)).0))
                .collect()
        })
        .collect();
    let mut svg = String::new();
    let needed;
    {
        let root = SVGBackend::with_string(&mut svg, (W, height)).into_drawing_area();
        let (plot, legend_area) = page(&root, title)?;
        let key;
        macro_rules! draw {
            ($x:expr, $y:expr, $xf:expr, $yf:expr) => {{
                let mut chart = builder(&plot).build_cartesian_2d($x, $y).map_err(err)?;
                mesh!(chart, x_desc, y_desc)
                    .x_labels(6)
                    .y_labels(6)
                    .x_label_formatter(&$xf)
                    .y_label_formatter(&$yf)
                    .draw()
                    .map_err(err)?;
                let st = styles(series, |s| s.name.as_str());
                for (i, s) in shown.iter().enumerate() {
                    let Some(spread) = spreads.get(i) else { continue };
                    chart
                        .draw_series(s.points.iter().zip(spread).map(|(p, &(a, b))| {
                            PathElement::new(vec![(a, p.1), (b, p.1)], st[i].colour.stroke_width(2))
                        }))
                        .map_err(err)?;
                }
                draw_scatter(&mut chart, &shown, Some(&hollow), true)?;
                let at = |p: (f64, f64)| format!("{}, {}", $xf(&p.0), $yf(&p.1));
                key = draw_labels(&mut chart, &shown, labels, &spreads, &at)?;
            }};
        }
        let lin_x = |v: &f64| tick_label(*v, xs.1 - xs.0);
        let lin_y = |v: &f64| tick_label(*v, ys.1 - ys.0);
        let log_l = |v: &f64| log_tick_label(*v);
        match log {
            (true, true) => draw!(log_axis(lx.0, lx.1), log_axis(ly.0, ly.1), log_l, log_l),
            (true, false) => draw!(log_axis(lx.0, lx.1), ys.0..ys.1, log_l, lin_y),
            (false, true) => draw!(xs.0..xs.1, log_axis(ly.0, ly.1), lin_x, log_l),
            (false, false) => draw!(xs.0..xs.1, ys.0..ys.1, lin_x, lin_y),
        }
        let mut y = draw_legend(&legend_area, &scatter_legend(series))?;
        let mut notes = Vec::new();
        let quantity = |desc: &str| desc.split(" (").next().unwrap_or(desc).trim().to_string();
        for (n, desc, values, side) in [
            (off_x, x_desc, all_x().collect::<Vec<_>>(), "left"),
            (off_y, y_desc, all_y().collect(), "lower"),
        ] {
            if n > 0 {
                let relation = if values.iter().all(|v| *v >= 0.0) {
                    "= 0"
                } else {
                    "≤ 0"
                };
                let points = if n == 1 { "1 point" } else { &format!("{n} points") };
                notes.push(format!(
                    "{points} with {} {relation} (no place on a log scale) drawn hollow on the {side} edge",
                    quantity(desc)
                ));
            }
        }
        if !key.is_empty() {
            y = draw_notes(&legend_area, y, "Labels that did not fit beside their points:", &key)?;
        }
        if !notes.is_empty() {
            y = draw_notes(&legend_area, y, "", &notes)?;
        }
        let column = legend_area.dim_in_pixel().1 as i32;
        needed = (height as i32 + (y + 10 - column).max(0)) as u32;
        root.present().map_err(err)?;
    }
    Ok((svg, needed))
}

/// Text drawn beside points: its font size (px, as plotters takes it) and
/// the box an SVG viewer gives it. Plotters writes `font-size` as px / 1.24;
/// a sans-serif character is at most ~0.6 em wide on average.
pub(super) const LABEL_PX: u32 = 14;

/// The estimated (width, height) in px of `text` drawn at `LABEL_PX`.
pub(super) fn label_extent(text: &str) -> (i32, i32) {
    let em = LABEL_PX as f64 / 1.24;
    (
        (text.chars().count() as f64 * 0.6 * em).ceil() as i32,
        em.ceil() as i32 + 2,
    )
}

/// A text placed at a data point, `offset` px from it: (point, offset, text).
type PlacedText = ((f64, f64), (i32, i32), String);
/// A leader line drawn from a data point: (point, pixel path relative to it).
type Leader = ((f64, f64), Vec<(i32, i32)>);

/// A box in pixels: (left, top, right, bottom).
pub(super) type PxBox = (i32, i32, i32, i32);

fn overlaps(a: PxBox, b: PxBox) -> bool {
    a.0 < b.2 && b.0 < a.2 && a.1 < b.3 && b.1 < a.3
}

/// How many rings of places around a point a label may take; beyond the
/// first a thin leader line joins label and point.
const LABEL_RINGS: i32 = 4;
/// How much farther from the point each ring is (px).
const RING_STEP: i32 = 16;

/// Clearance (px) between a label and any marker but its own, beyond the
/// label's distance from its own: a label is read as belonging to the
/// marker nearest to it ("spectral" written beside nstep81's × was read as
/// nstep81's).
const OWN_MARKER_MARGIN: i32 = 6;

/// How much nearer (px) its own marker than any other a leader line
/// starts: it starts just outside its marker, which may touch another.
const LEADER_MARGIN: i32 = 2;

/// The distance (px) from the point `p` to the box `b` (0 inside it).
fn distance_to_box(p: (i32, i32), b: PxBox) -> f64 {
    let dx = (b.0 - p.0).max(p.0 - b.2).max(0) as f64;
    let dy = (b.1 - p.1).max(p.1 - b.3).max(0) as f64;
    dx.hypot(dy)
}

/// Where to put a text of `extent` beside a point at pixel `at` whose
/// marker has radius `r`: the first of right, left, above, below and the
/// four diagonals, nearest ring first, whose box lies inside `within`,
/// meets none of `taken` and points at its own marker: beside the marker
/// (ring 0), every other marker of `markers` (centre, radius) is farther
/// from the box than its own by [`OWN_MARKER_MARGIN`]; away from it (a
/// leader line joins them), no other marker is that close to the box, and
/// the leader starts nearer its own marker than any other (by
/// [`LEADER_MARGIN`]). `markers` are the others (centre, radius): not its
/// own, nor those its label also serves. Returns that
/// box and its ring, or `None` when every place fails.
pub(super) fn label_places(
    at: (i32, i32),
    r: i32,
    extent: (i32, i32),
    within: PxBox,
    taken: &[PxBox],
    markers: &[((i32, i32), i32)],
) -> Option<(PxBox, i32)> {
    let (w, h) = extent;
    let others = || markers.iter().filter(|(c, _)| *c != at);
    let points_at_its_own = |b: PxBox, ring: i32| {
        if ring == 0 {
            let own = distance_to_box(at, b);
            others().all(|&(c, _)| distance_to_box(c, b) >= own + OWN_MARKER_MARGIN as f64)
        } else {
            let [start, _] = leader(at, r, b);
            let start = (at.0 + start.0, at.1 + start.1);
            let own = ((start.0 - at.0) as f64).hypot((start.1 - at.1) as f64);
            others().all(|&(c, rc)| {
                distance_to_box(c, b) >= (rc + 4 + OWN_MARKER_MARGIN) as f64
                    && ((start.0 - c.0) as f64).hypot((start.1 - c.1) as f64) >= own + LEADER_MARGIN as f64
            })
        }
    };
    (0..LABEL_RINGS).find_map(|ring| {
        let gap = r + 4 + ring * RING_STEP;
        let diag = (gap as f64 * 0.75).ceil() as i32;
        let offsets = [
            (gap, -h / 2),
            (-gap - w, -h / 2),
            (-w / 2, -gap - h),
            (-w / 2, gap),
            (diag, -diag - h),
            (-diag - w, -diag - h),
            (diag, diag),
            (-diag - w, diag),
        ];
        offsets
            .iter()
            .map(|&(dx, dy)| (at.0 + dx, at.1 + dy, at.0 + dx + w, at.1 + dy + h))
            .find(|b| {
                b.0 >= within.0
                    && b.1 >= within.1
                    && b.2 <= within.2
                    && b.3 <= within.3
                    && !taken.iter().any(|t| overlaps(*b, *t))
                    && (ring == 0
                        || leader_dots(at, r, *b)
                            .iter()
                            .all(|d| !taken.iter().any(|t| overlaps(*d, *t))))
                    && points_at_its_own(*b, ring)
            })
            .map(|b| (b, ring))
    })
}

/// The leader line from a point at pixel `at` (marker radius `r`) to its
/// label's box `b`: from just outside the marker to the box's nearest
/// point, relative to `at`.
fn leader(at: (i32, i32), r: i32, b: PxBox) -> [(i32, i32); 2] {
    let end = (
        (at.0.clamp(b.0, b.2) - at.0) as f64,
        (at.1.clamp(b.1, b.3) - at.1) as f64,
    );
    let from = (r + 5) as f64 / end.0.hypot(end.1).max(1.0);
    [
        ((end.0 * from).round() as i32, (end.1 * from).round() as i32),
        (end.0 as i32, end.1 as i32),
    ]
}

/// A leader line as small boxes every few px (absolute), to test it and
/// keep it clear: no leader crosses a marker, a label or another leader.
fn leader_dots(at: (i32, i32), r: i32, b: PxBox) -> Vec<PxBox> {
    let [(x0, y0), (x1, y1)] = leader(at, r, b);
    let n = ((x1 - x0).abs().max((y1 - y0).abs()) / 3).max(1);
    (0..=n)
        .map(|k| {
            let x = at.0 + x0 + (x1 - x0) * k / n;
            let y = at.1 + y0 + (y1 - y0) * k / n;
            (x - 1, y - 1, x + 1, y + 1)
        })
        // Not the point's own marker (its box in `taken` reaches r + 4).
        .filter(|d| (d.0 + 1 - at.0).abs().max((d.1 + 1 - at.1).abs()) > r + 5)
        .collect()
}

/// Draws `labels[i][j]` beside point j of series i where it fits (see
/// [`label_places`], a leader line to a label away from its point); a label that does not gets a number `[k]` at its
/// point, or when even that does not fit, nothing. Returns the key's
/// entries for those labels: `[k] label (series)`, or `label (series) at
/// x, y` (`at` formats a point as the axes do).
fn draw_labels<'a, DB: DrawingBackend + 'a, X: Ranged<ValueType = f64>, Y: Ranged<ValueType = f64>>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    series: &[ScatterSeries],
    labels: &[Vec<String>],
    spreads: &[Vec<(f64, f64)>],
    at: &dyn Fn((f64, f64)) -> String,
) -> Result<Vec<String>, String> {
    let st = styles(series, |s| s.name.as_str());
    let (xr, yr) = chart.plotting_area().get_pixel_range();
    let within = (xr.start, yr.start, xr.end, yr.end);
    // Every marker and whisker is in the way of a label.
    let mut taken: Vec<PxBox> = Vec::new();
    // Every marker: (centre, radius, its series and its label).
    let mut markers: Vec<((i32, i32), i32, usize, &str)> = Vec::new();
    for (i, s) in series.iter().enumerate() {
        let r = st[i].size + 4;
        for (j, p) in s.points.iter().enumerate() {
            let (x, y) = chart.backend_coord(p);
            taken.push((x - r, y - r, x + r, y + r));
            let label = labels.get(i).and_then(|l| l.get(j)).map_or("", |l| l.as_str());
            markers.push(((x, y), st[i].size, i, label));
            if let Some(&(a, b)) = spreads.get(i).and_then(|sp| sp.get(j)) {
                let (xa, xb) = (chart.backend_coord(&(a, p.1)).0, chart.backend_coord(&(b, p.1)).0);
                taken.push((xa.min(xb) - 1, y - 2, xa.max(xb) + 1, y + 2));
            }
        }
    }
    let font = ("sans-serif", LABEL_PX).into_font().color(&RGBColor(40, 40, 40));
    let mut texts: Vec<PlacedText> = Vec::new();
    let mut leaders: Vec<Leader> = Vec::new();
    // A label of series `i` is in the way of no marker of its own series
    // with the same label (two points of one setting nearly coincide).
    let mut place = |p: (f64, f64), r: i32, i: usize, label: &str, text: &str, taken: &mut Vec<PxBox>| {
        let px = chart.backend_coord(&p);
        let others: Vec<((i32, i32), i32)> = markers
            .iter()
            .filter(|m| !(m.2 == i && m.3 == label))
            .map(|m| (m.0, m.1))
            .collect();
        let (b, ring) = label_places(px, r, label_extent(text), within, taken, &others)?;
        taken.push(b);
        texts.push((p, (b.0 - px.0, b.1 - px.1), text.to_string()));
        if ring > 0 {
            taken.extend(leader_dots(px, r, b));
            leaders.push((p, leader(px, r, b).to_vec()));
        }
        Some(())
    };
    let mut unplaced = Vec::new();
    // Points already labelled: (series, label, pixel).
    let mut labelled: Vec<(usize, &str, (i32, i32))> = Vec::new();
    for (i, s) in series.iter().enumerate() {
        for (p, text) in s.points.iter().zip(labels.get(i).into_iter().flatten()) {
            if text.is_empty() {
                continue;
            }
            // One label serves a point of its series with the same label
            // under the same marker (the coding sweep's nstep3 and the N
            // sweep's are one setting).
            let px = chart.backend_coord(p);
            let r = st[i].size;
            if labelled
                .iter()
                .any(|&(k, l, q)| k == i && l == text.as_str() && (q.0 - px.0).abs().max((q.1 - px.1).abs()) <= r + 2)
            {
                continue;
            }
            if place(*p, r, i, text, text, &mut taken).is_some() {
                labelled.push((i, text.as_str(), px));
            } else {
                unplaced.push((*p, r, i, text.as_str(), format!("{text} ({})", s.name)));
            }
        }
    }
    let mut key = Vec::new();
    let mut k = 0;
    for (p, r, i, label, text) in unplaced {
        let number = format!("[{}]", k + 1);
        if place(p, r, i, label, &number, &mut taken).is_some() {
            k += 1;
            key.push(format!("{number} {text}"));
        } else {
            key.push(format!("{text} at {}", at(p)));
        }
    }
    let grey = RGBColor(150, 150, 150).stroke_width(1);
    chart
        .draw_series(
            leaders
                .into_iter()
                .map(|(p, path)| EmptyElement::at(p) + PathElement::new(path, grey)),
        )
        .map_err(err)?;
    chart
        .draw_series(
            texts
                .into_iter()
                .map(|(p, offset, text)| EmptyElement::at(p) + Text::new(text, offset, font.clone())),
        )
        .map_err(err)?;
    Ok(key)
}

pub(super) fn scatter_legend(series: &[ScatterSeries]) -> Vec<LegendEntry> {
    let st = styles(series, |s| s.name.as_str());
    series
        .iter()
        .zip(st)
        .map(|(s, style)| LegendEntry {
            name: s.name.clone(),
            glyph: if s.connect {
                Glyph::LineMarker(style)
            } else {
                Glyph::Marker(style)
            },
        })
        .collect()
}

/// Every series' markers (and lines when `connect`), the measurement last;
/// points flagged in `hollow` (a value ≤ 0 put on a log axis' edge) drawn
/// as the outline of their marker; `full_size: false` draws smaller
/// markers (an overview panel where the data are a cluster).
pub(super) fn draw_scatter<'a, DB: DrawingBackend + 'a, X: Ranged<ValueType = f64>, Y: Ranged<ValueType = f64>>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    series: &[ScatterSeries],
    hollow: Option<&[Vec<bool>]>,
    full_size: bool,
) -> Result<(), String> {
    let st = styles(series, |s| s.name.as_str());
    for (i, s) in measurement_last(series, |s| s.name.as_str()) {
        let mut style = st[i];
        if !full_size {
            style.size = (style.size / 2).max(2);
        }
        if s.connect {
            let width = if is_measurement(&s.name) || is_display_gamut(&s.name) {
                2
            } else {
                1
            };
            draw_clipped_line(chart, &s.points, style.colour.stroke_width(width), None)?;
        }
        let flags = hollow.and_then(|h| h.get(i));
        let is_hollow = |j: usize| flags.and_then(|f| f.get(j)).copied().unwrap_or(false);
        let (open, filled): (Vec<_>, Vec<_>) = s.points.iter().enumerate().partition(|(j, _)| is_hollow(*j));
        let filled: Vec<(f64, f64)> = filled.into_iter().map(|(_, p)| *p).collect();
        draw_markers(chart, &filled, style)?;
        let outline = marker_outline(style);
        let stroke = style.colour.stroke_width(2);
        chart
            .draw_series(
                open.iter()
                    .flat_map(|(_, p)| outline.iter().map(move |path| (**p, path)))
                    .map(|(p, path)| EmptyElement::at(p) + PathElement::new(path.clone(), stroke)),
            )
            .map_err(err)?;
    }
    Ok(())
}

/// A marker drawn hollow, as pixel paths around its centre: the outline of
/// its shape, or for the stroke-only cross and plus, the shape in a ring.
pub(super) fn marker_outline(style: Style) -> Vec<Vec<(i32, i32)>> {
    let s = style.size;
    let tri = (s as f64 * 0.9) as i32;
    let ring = |r: i32| -> Vec<(i32, i32)> {
        (0..=16)
            .map(|k| {
                let a = k as f64 * std::f64::consts::TAU / 16.0;
                ((r as f64 * a.cos()).round() as i32, (r as f64 * a.sin()).round() as i32)
            })
            .collect()
    };
    match style.marker {
        Marker::Circle | Marker::OpenCircle => vec![ring(s)],
        Marker::Square => vec![vec![(-s, -s), (s, -s), (s, s), (-s, s), (-s, -s)]],
        Marker::Diamond => vec![vec![(0, -s - 1), (s + 1, 0), (0, s + 1), (-s - 1, 0), (0, -s - 1)]],
        Marker::TriangleUp => vec![vec![(0, -s - 1), (s + 1, tri), (-s - 1, tri), (0, -s - 1)]],
        Marker::TriangleDown => vec![vec![(0, s + 1), (s + 1, -tri), (-s - 1, -tri), (0, s + 1)]],
        Marker::Cross => vec![vec![(-s, -s), (s, s)], vec![(-s, s), (s, -s)], ring(s + 3)],
        Marker::Plus => vec![
            vec![(-s - 1, 0), (s + 1, 0)],
            vec![(0, -s - 1), (0, s + 1)],
            ring(s + 3),
        ],
        Marker::TriangleLeft => vec![vec![(-s - 1, 0), (tri, -s - 1), (tri, s + 1), (-s - 1, 0)]],
        Marker::TriangleRight => vec![vec![(s + 1, 0), (-tri, -s - 1), (-tri, s + 1), (s + 1, 0)]],
        Marker::Star => {
            let mut p = star_points(s);
            p.push(p[0]);
            vec![p]
        }
        Marker::Hexagon => {
            let mut p = hexagon_points(s);
            p.push(p[0]);
            vec![p]
        }
        Marker::Asterisk => {
            let h = (s as f64 * 0.87).round() as i32;
            let half = (s + 1) / 2;
            vec![
                vec![(0, -s - 1), (0, s + 1)],
                vec![(-h, -half), (h, half)],
                vec![(-h, half), (h, -half)],
                ring(s + 3),
            ]
        }
    }
}
