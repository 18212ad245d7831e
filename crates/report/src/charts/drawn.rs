//! What a chart drew, read back from its SVG (tests only): its texts with
//! the boxes a viewer gives them, its lines, its markers and its axes'
//! ticks, so that a test checks what a figure shows (a line inside the
//! plot, a label at its own marker), not only that some text is there.
//!
//! Plotters writes one element per line: `<text x y dy text-anchor
//! font-size [transform]>content</text>`, `<polyline stroke stroke-width
//! points>`, `<circle>`, `<rect>`, `<polygon>`; an axis tick is a black
//! 1 px mark 5 px long beside its label.

/// A box in px: (left, top, right, bottom).
pub(super) type PxRect = (f64, f64, f64, f64);
pub(super) type Px = (f64, f64);

/// Every `<tag …>content</tag>` (or self-closed) of an SVG: (attributes, trimmed content).
pub(super) fn elements(svg: &str, tag: &str) -> Vec<(String, String)> {
    let open = format!("<{tag} ");
    let mut out = Vec::new();
    let mut rest = svg;
    while let Some(i) = rest.find(&open) {
        rest = &rest[i + open.len()..];
        let end = rest.find('>').unwrap();
        let attrs = rest[..end].to_string();
        let content = if attrs.ends_with('/') {
            String::new()
        } else {
            let close = format!("</{tag}>");
            let c = rest.find(&close).unwrap();
            rest[end + 1..c].trim().to_string()
        };
        out.push((attrs, content));
    }
    out
}

pub(super) fn attr(attrs: &str, name: &str) -> Option<String> {
    let key = format!(" {name}=\"");
    let i = format!(" {attrs}").find(&key)? + key.len() - 1;
    let v = &attrs[i..];
    Some(v[..v.find('"')?].to_string())
}

pub(super) fn num(attrs: &str, name: &str) -> f64 {
    attr(attrs, name).and_then(|v| v.parse().ok()).unwrap_or(f64::NAN)
}

/// The (x, y) pairs of an element's `points` attribute.
pub(super) fn points_of(attrs: &str) -> Vec<Px> {
    attr(attrs, "points")
        .unwrap_or_default()
        .split_whitespace()
        .filter_map(|p| {
            let (x, y) = p.split_once(',')?;
            Some((x.parse().ok()?, y.parse().ok()?))
        })
        .collect()
}

/// A text as drawn: where, what, and the box it covers.
#[derive(Clone, Debug)]
pub(super) struct TextBox {
    pub(super) x: f64,
    pub(super) content: String,
    /// Its estimated box: 0.6 em a character, the font size plus 2 px tall
    /// (as `scatter::label_extent`), placed by its anchor, `dy` and rotation.
    pub(super) bbox: PxRect,
}

/// Every text of a chart with its box.
pub(super) fn texts_drawn(svg: &str) -> Vec<TextBox> {
    elements(svg, "text")
        .into_iter()
        .filter(|(_, c)| !c.is_empty())
        .map(|(a, content)| {
            let (x, y) = (num(&a, "x"), num(&a, "y"));
            let size = num(&a, "font-size");
            let (w, h) = (content.chars().count() as f64 * 0.6 * size, size.ceil() + 2.0);
            let left = match attr(&a, "text-anchor").as_deref() {
                Some("middle") => x - w / 2.0,
                Some("end") => x - w,
                _ => x,
            };
            let top = match attr(&a, "dy").as_deref() {
                Some("0.76em") => y,
                Some("0.5ex") => y - h / 2.0,
                Some("-0.5ex") => y - h,
                _ => y - 0.8 * size,
            };
            let mut bbox = (left, top, left + w, top + h);
            // `rotate(a, cx, cy)`: the box's corners turned about (cx, cy).
            if let Some(r) = attr(&a, "transform").and_then(|t| {
                let v: Vec<f64> = t
                    .strip_prefix("rotate(")?
                    .trim_end_matches(')')
                    .split(',')
                    .filter_map(|s| s.trim().parse().ok())
                    .collect();
                (v.len() == 3).then(|| (v[0].to_radians(), v[1], v[2]))
            }) {
                let (s, c) = r.0.sin_cos();
                let turn = |p: Px| {
                    let (dx, dy) = (p.0 - r.1, p.1 - r.2);
                    (r.1 + dx * c - dy * s, r.2 + dx * s + dy * c)
                };
                let corners = [(bbox.0, bbox.1), (bbox.2, bbox.1), (bbox.0, bbox.3), (bbox.2, bbox.3)].map(turn);
                bbox = bounding(&corners);
            }
            TextBox { x, content, bbox }
        })
        .collect()
}

/// A drawn line (a `<polyline>`): its colour, width and vertices.
#[derive(Clone, Debug)]
pub(super) struct Line {
    pub(super) stroke: String,
    pub(super) width: f64,
    pub(super) points: Vec<Px>,
}

pub(super) fn lines_drawn(svg: &str) -> Vec<Line> {
    elements(svg, "polyline")
        .into_iter()
        .map(|(a, _)| Line {
            stroke: attr(&a, "stroke").unwrap_or_default(),
            width: num(&a, "stroke-width"),
            points: points_of(&a),
        })
        .collect()
}

/// A marker: its centre, colour (fill, or stroke when hollow) and box.
#[derive(Clone, Debug)]
pub(super) struct Mark {
    pub(super) at: Px,
    pub(super) colour: String,
    pub(super) bbox: PxRect,
}

/// Every marker a chart drew: circles, squares and filled polygons under
/// 20 px, the 3 px strokes of crosses and pluses (one mark per centre),
/// and hollow outlines (closed 2 px polylines under 20 px).
pub(super) fn marks_drawn(svg: &str) -> Vec<Mark> {
    let mut marks: Vec<Mark> = Vec::new();
    let mut add = |bbox: PxRect, colour: String| {
        let at = ((bbox.0 + bbox.2) / 2.0, (bbox.1 + bbox.3) / 2.0);
        if bbox.2 - bbox.0 >= 20.0 || bbox.3 - bbox.1 >= 20.0 {
            return;
        }
        match marks
            .iter_mut()
            .find(|m| m.colour == colour && (m.at.0 - at.0).abs() <= 1.5 && (m.at.1 - at.1).abs() <= 1.5)
        {
            Some(m) => {
                m.bbox = bounding(&[
                    (m.bbox.0, m.bbox.1),
                    (m.bbox.2, m.bbox.3),
                    (bbox.0, bbox.1),
                    (bbox.2, bbox.3),
                ])
            }
            None => marks.push(Mark { at, colour, bbox }),
        }
    };
    for (a, _) in elements(svg, "circle") {
        let (x, y, r) = (num(&a, "cx"), num(&a, "cy"), num(&a, "r"));
        let fill = attr(&a, "fill").unwrap_or_default();
        let colour = if fill == "none" {
            attr(&a, "stroke").unwrap_or_default()
        } else {
            fill
        };
        add((x - r, y - r, x + r, y + r), colour);
    }
    for (a, _) in elements(svg, "rect") {
        let (x, y, w, h) = (num(&a, "x"), num(&a, "y"), num(&a, "width"), num(&a, "height"));
        add((x, y, x + w, y + h), attr(&a, "fill").unwrap_or_default());
    }
    for (a, _) in elements(svg, "polygon") {
        add(bounding(&points_of(&a)), attr(&a, "fill").unwrap_or_default());
    }
    for l in lines_drawn(svg) {
        let closed = l.points.len() > 3 && l.points.first() == l.points.last();
        if (l.width == 3.0 && l.points.len() == 2) || (l.width == 2.0 && closed) {
            add(bounding(&l.points), l.stroke);
        }
    }
    marks
}

pub(super) fn bounding(points: &[Px]) -> PxRect {
    points.iter().fold(
        (f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY),
        |b, p| (b.0.min(p.0), b.1.min(p.1), b.2.max(p.0), b.3.max(p.1)),
    )
}

pub(super) fn boxes_overlap(a: PxRect, b: PxRect) -> bool {
    a.0 < b.2 && b.0 < a.2 && a.1 < b.3 && b.1 < a.3
}

/// The distance (px) from `p` to the box `b` (0 inside it).
pub(super) fn distance_to_box(p: Px, b: PxRect) -> f64 {
    let dx = (b.0 - p.0).max(p.0 - b.2).max(0.0);
    let dy = (b.1 - p.1).max(p.1 - b.3).max(0.0);
    dx.hypot(dy)
}

/// Whether the segment `a`–`b` passes through the box `r`.
pub(super) fn segment_meets_box(a: Px, b: Px, r: PxRect) -> bool {
    super::clip_segment(a, b, r).is_some()
}

/// Which side of the plot an axis is on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Side {
    Left,
    Right,
    Bottom,
}

/// One axis of a plot: its ticks (label, pixel along the axis) in pixel
/// order, and where its line is (x of a vertical axis, y of a horizontal).
#[derive(Clone, Debug)]
pub(super) struct Axis {
    pub(super) side: Side,
    pub(super) at: f64,
    pub(super) ticks: Vec<(TextBox, f64)>,
}

impl Axis {
    /// The ticks whose labels are numbers: (value, pixel).
    pub(super) fn numbers(&self) -> Vec<(f64, f64)> {
        self.ticks
            .iter()
            .filter_map(|(t, px)| Some((t.content.parse::<f64>().ok()?, *px)))
            .collect()
    }

    /// The pixel of a value, fitted to the labelled ticks, linear or
    /// logarithmic (whichever the ticks follow); panics unless every tick
    /// lies within 1.5 px of the fit.
    pub(super) fn map(&self) -> impl Fn(f64) -> f64 {
        let ticks = self.numbers();
        assert!(
            ticks.len() >= 2,
            "{:?} axis has {} numbered ticks",
            self.side,
            ticks.len()
        );
        let fit = |f: fn(f64) -> f64| {
            let (a, b) = (ticks[0], ticks[ticks.len() - 1]);
            let slope = (b.1 - a.1) / (f(b.0) - f(a.0));
            let worst = ticks
                .iter()
                .map(|t| (a.1 + slope * (f(t.0) - f(a.0)) - t.1).abs())
                .fold(0.0, |w: f64, d| if d.is_nan() { f64::INFINITY } else { w.max(d) });
            (worst, move |v: f64| a.1 + slope * (f(v) - f(a.0)))
        };
        let linear = fit(|v| v);
        let log = fit(|v| if v > 0.0 { v.log10() } else { f64::NAN });
        let (worst, map) = if log.0 < linear.0 { log } else { linear };
        assert!(
            worst <= 1.5,
            "{:?} axis: ticks {ticks:?} fit no linear or log scale ({worst} px off)",
            self.side
        );
        map
    }
}

/// Every axis of a chart: the black 5 px tick marks, grouped by the axis
/// line (black, over 100 px) they hang from, each with the text nearest
/// its outer end.
pub(super) fn axes_drawn(svg: &str) -> Vec<Axis> {
    let texts = texts_drawn(svg);
    let black: Vec<(Px, Px)> = lines_drawn(svg)
        .into_iter()
        .filter(|l| l.stroke == "#000000" && l.width == 1.0 && l.points.len() == 2)
        .map(|l| (l.points[0], l.points[1]))
        .filter(|(a, b)| a.0 == b.0 || a.1 == b.1)
        .collect();
    let length = |(a, b): &(Px, Px)| (a.0 - b.0).abs() + (a.1 - b.1).abs();
    let axis_lines: Vec<&(Px, Px)> = black.iter().filter(|l| length(l) > 100.0).collect();
    // The axis line an end of a tick mark touches, across the mark.
    let touches = |p: Px, mark_is_vertical: bool| {
        axis_lines.iter().position(|(a, b)| {
            let b = bounding(&[*a, *b]);
            if mark_is_vertical {
                b.1 == b.3 && (p.1 - b.1).abs() <= 1.0 && p.0 >= b.0 - 1.0 && p.0 <= b.2 + 1.0
            } else {
                b.0 == b.2 && (p.0 - b.0).abs() <= 1.0 && p.1 >= b.1 - 1.0 && p.1 <= b.3 + 1.0
            }
        })
    };
    let mut axes: Vec<(usize, Axis)> = Vec::new();
    for mark in black.iter().filter(|l| length(l) == 5.0) {
        let vertical = mark.0 .0 == mark.1 .0;
        let (line, inner, outer) = match (touches(mark.0, vertical), touches(mark.1, vertical)) {
            (Some(k), None) => (k, mark.0, mark.1),
            (None, Some(k)) => (k, mark.1, mark.0),
            _ => continue,
        };
        let side = if vertical {
            Side::Bottom
        } else if outer.0 < inner.0 {
            Side::Left
        } else {
            Side::Right
        };
        let Some(label) = texts
            .iter()
            .filter(|t| distance_to_box(outer, t.bbox) <= 12.0)
            .min_by(|p, q| distance_to_box(outer, p.bbox).total_cmp(&distance_to_box(outer, q.bbox)))
        else {
            continue;
        };
        let along = if vertical { inner.0 } else { inner.1 };
        let at = if vertical { inner.1 } else { inner.0 };
        match axes.iter_mut().find(|(k, x)| *k == line && x.side == side) {
            Some((_, x)) => x.ticks.push((label.clone(), along)),
            None => axes.push((
                line,
                Axis {
                    side,
                    at,
                    ticks: vec![(label.clone(), along)],
                },
            )),
        }
    }
    let mut axes: Vec<Axis> = axes.into_iter().map(|(_, x)| x).collect();
    for x in &mut axes {
        x.ticks.sort_by(|p, q| p.1.total_cmp(&q.1));
    }
    axes
}

/// What every chart must show, whatever it draws: every text inside the
/// figure, no two texts overlapping, and every numbered axis' tick labels
/// increasing along it (left to right, bottom to top) and placed on one
/// linear or log scale.
pub(super) fn assert_readable(name: &str, svg: &str) {
    let svg_attrs = &elements(svg, "svg")[0].0;
    let (w, h) = (num(svg_attrs, "width"), num(svg_attrs, "height"));
    let texts = texts_drawn(svg);
    for t in &texts {
        let b = t.bbox;
        assert!(
            b.0 >= -1.0 && b.1 >= -1.0 && b.2 <= w + 1.0 && b.3 <= h + 1.0,
            "{name}: the text {:?} at {b:?} leaves the {w}×{h} figure",
            t.content
        );
    }
    for (i, a) in texts.iter().enumerate() {
        for b in &texts[i + 1..] {
            assert!(
                !boxes_overlap(a.bbox, b.bbox),
                "{name}: the texts {:?} {:?} and {:?} {:?} overlap",
                a.content,
                a.bbox,
                b.content,
                b.bbox
            );
        }
    }
    for axis in axes_drawn(svg) {
        let numbers = axis.numbers();
        if numbers.len() < axis.ticks.len() {
            continue; // an axis of named slots: its order is the test's
        }
        // Ticks are in pixel order: values rise rightwards, and upwards.
        let rising = numbers.windows(2).all(|p| match axis.side {
            Side::Bottom => p[1].0 > p[0].0,
            _ => p[1].0 < p[0].0,
        });
        assert!(
            rising,
            "{name}: the {:?} axis' tick labels are out of order: {numbers:?}",
            axis.side
        );
        let _ = axis.map();
    }
}

/// Each plot area of a chart (left, top, right, bottom): the long black
/// axis lines plotters draws along its left and bottom edges.
pub(super) fn plot_areas(svg: &str) -> Vec<(f64, f64, f64, f64)> {
    let lines: Vec<Vec<(f64, f64)>> = elements(svg, "polyline")
        .into_iter()
        .filter(|(a, _)| attr(a, "stroke").as_deref() == Some("#000000"))
        .map(|(a, _)| points_of(&a))
        .filter(|p| p.len() == 2)
        .collect();
    let verticals: Vec<&Vec<(f64, f64)>> = lines
        .iter()
        .filter(|p| p[0].0 == p[1].0 && (p[0].1 - p[1].1).abs() > 100.0)
        .collect();
    let horizontals: Vec<&Vec<(f64, f64)>> = lines
        .iter()
        .filter(|p| p[0].1 == p[1].1 && (p[0].0 - p[1].0).abs() > 100.0)
        .collect();
    horizontals
        .iter()
        .filter_map(|h| {
            let (left, right) = (h[0].0.min(h[1].0), h[0].0.max(h[1].0));
            let v = verticals
                .iter()
                .filter(|v| (v[0].0 - left).abs() <= 2.0)
                .min_by(|a, b| a[0].1.min(a[1].1).total_cmp(&b[0].1.min(b[1].1)))?;
            Some((left, v[0].1.min(v[1].1), right, h[0].1))
        })
        .collect()
}

/// A plot of a chart: its area (left, top, right, bottom) and its axes.
pub(super) struct Plot {
    pub(super) area: PxRect,
    pub(super) x: Axis,
    pub(super) y: Axis,
    /// A second y axis on the right, if any.
    pub(super) y2: Option<Axis>,
}

impl Plot {
    /// Whether a pixel lies inside the plot area (1.5 px for rounding).
    pub(super) fn holds(&self, p: Px) -> bool {
        let a = self.area;
        p.0 >= a.0 - 1.5 && p.0 <= a.2 + 1.5 && p.1 >= a.1 - 1.5 && p.1 <= a.3 + 1.5
    }

    /// The pixel of a named tick of the x axis (a slot: a target, a bar).
    pub(super) fn x_slot(&self, name: &str) -> f64 {
        self.x
            .ticks
            .iter()
            .find(|t| t.0.content == name)
            .unwrap_or_else(|| panic!("no x tick {name:?}"))
            .1
    }
}

/// Every plot of a chart with the axes along its left, bottom and right edges.
pub(super) fn plots_drawn(svg: &str) -> Vec<Plot> {
    let axes = axes_drawn(svg);
    plot_areas(svg)
        .into_iter()
        .filter_map(|area| {
            let on = |side: Side, at: f64| {
                axes.iter()
                    .find(|x| {
                        x.side == side
                            && (x.at - at).abs() <= 2.0
                            && x.ticks
                                .iter()
                                .all(|t| t.1 >= area.0 - 2.0 && t.1 <= area.2 + 2.0 || side != Side::Bottom)
                    })
                    .cloned()
            };
            Some(Plot {
                area,
                x: on(Side::Bottom, area.3)?,
                y: on(Side::Left, area.0)?,
                y2: on(Side::Right, area.2),
            })
        })
        .collect()
}

/// The colours of the glyph (line, marker or swatch) a legend draws left
/// of its entry `name`, at the entry's height.
pub(super) fn legend_colours(svg: &str, name: &str) -> Vec<String> {
    let texts = texts_drawn(svg);
    let t = texts
        .iter()
        .filter(|t| t.content == name)
        .max_by(|a, b| a.x.total_cmp(&b.x))
        .unwrap_or_else(|| panic!("no legend entry {name:?}"));
    let mid = (t.bbox.1 + t.bbox.3) / 2.0;
    let beside = |b: PxRect| {
        b.2 <= t.bbox.0 && b.0 >= t.bbox.0 - 40.0 && (b.1 + b.3) / 2.0 >= mid - 4.0 && (b.1 + b.3) / 2.0 <= mid + 4.0
    };
    let mut colours: Vec<String> = lines_drawn(svg)
        .into_iter()
        .filter(|l| beside(bounding(&l.points)))
        .map(|l| l.stroke)
        .chain(
            marks_drawn(svg)
                .into_iter()
                .filter(|m| beside(m.bbox))
                .map(|m| m.colour),
        )
        .chain(elements(svg, "rect").into_iter().filter_map(|(a, _)| {
            let (x, y, w, h) = (num(&a, "x"), num(&a, "y"), num(&a, "width"), num(&a, "height"));
            beside((x, y, x + w, y + h)).then(|| attr(&a, "fill").unwrap_or_default())
        }))
        .collect();
    colours.sort();
    colours.dedup();
    colours
}
