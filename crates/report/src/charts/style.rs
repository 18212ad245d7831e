//! One colour and one marker per coding ([`CODING_STYLES`]), the
//! measurement's black open circle, and the styles of other series.

use super::*;

/// The shape drawn at a data point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Marker {
    Circle,
    OpenCircle,
    Square,
    Diamond,
    TriangleUp,
    TriangleDown,
    Cross,
    Plus,
    TriangleLeft,
    TriangleRight,
    Star,
    Hexagon,
    Asterisk,
}

/// How one series is drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Style {
    pub colour: RGBColor,
    pub marker: Marker,
    /// Marker radius in px.
    pub size: i32,
}

/// One colour and marker per coding, the same in every chart, page and
/// report (Okabe & Ito 2008 colours; black is kept for the measurement).
pub const CODING_STYLES: [(&str, RGBColor, Marker); 7] = [
    ("rgb", RGBColor(213, 94, 0), Marker::Square),
    ("srgb", RGBColor(230, 159, 0), Marker::Diamond),
    ("nstep3", RGBColor(204, 121, 167), Marker::TriangleUp),
    ("nstep9", RGBColor(86, 180, 233), Marker::TriangleDown),
    ("nstep27", RGBColor(0, 114, 178), Marker::Circle),
    ("nstep81", RGBColor(0, 158, 115), Marker::Cross),
    ("spectral", RGBColor(90, 90, 90), Marker::Plus),
];

/// The measurement (or the study's truth): black, open, larger, drawn last.
pub const MEASUREMENT: Style = Style {
    colour: RGBColor(0, 0, 0),
    marker: Marker::OpenCircle,
    size: MEASUREMENT_PX,
};

/// Series that are neither a coding nor the measurement (a Pareto front,
/// a sweep, a threshold): greys and the one Okabe–Ito colour no coding uses.
pub(super) const OTHER_COLOURS: [RGBColor; 3] =
    [RGBColor(110, 110, 110), RGBColor(240, 200, 40), RGBColor(170, 170, 170)];

/// The study's other N-step codings (its N sweep: 1, 2, 3, 5, 7, 9, 15, 20,
/// 27, 40, 54, 81; `lab::study::run`), drawn in one chart with the table's:
/// with [`CODING_STYLES`]' nstep3, nstep9, nstep27 and nstep81 the twelve
/// codings of the sweep have twelve different markers and twelve different
/// colours (Paul Tol's muted and dark colours here, none an Okabe–Ito
/// colour of the table), so no two are told apart by a shade alone.
pub const SWEEP_STYLES: [(&str, RGBColor, Marker); 8] = [
    ("nstep1", RGBColor(51, 34, 136), Marker::Square),
    ("nstep2", RGBColor(136, 34, 85), Marker::Diamond),
    ("nstep5", RGBColor(153, 153, 51), Marker::TriangleLeft),
    ("nstep7", RGBColor(17, 119, 51), Marker::TriangleRight),
    ("nstep15", RGBColor(170, 68, 153), Marker::Star),
    ("nstep20", RGBColor(140, 81, 10), Marker::Hexagon),
    ("nstep40", RGBColor(200, 0, 60), Marker::Asterisk),
    ("nstep54", RGBColor(68, 170, 153), Marker::Plus),
];

/// Colours for the codings `nstepN` in neither table (Paul Tol's muted and
/// dark colours, as [`SWEEP_STYLES`]): none is one of [`CODING_STYLES`]',
/// black (the measurement), a grey or a near-white, so each reads on white.
const NSTEP_COLOURS: [RGBColor; 8] = [
    RGBColor(51, 34, 136),
    RGBColor(136, 34, 85),
    RGBColor(153, 153, 51),
    RGBColor(17, 119, 51),
    RGBColor(170, 68, 153),
    RGBColor(140, 81, 10),
    RGBColor(200, 0, 60),
    RGBColor(68, 170, 153),
];

/// The filled or stroked markers a coding may have (the open circle is the
/// measurement's).
const NSTEP_MARKERS: [Marker; 12] = [
    Marker::Circle,
    Marker::Square,
    Marker::Diamond,
    Marker::TriangleUp,
    Marker::TriangleDown,
    Marker::Cross,
    Marker::Plus,
    Marker::TriangleLeft,
    Marker::TriangleRight,
    Marker::Star,
    Marker::Hexagon,
    Marker::Asterisk,
];

/// The N of the codings `nstepN` in the two tables.
fn tabulated_n() -> impl Iterator<Item = u64> {
    CODING_STYLES
        .iter()
        .chain(SWEEP_STYLES.iter())
        .filter_map(|(c, _, _)| c.strip_prefix("nstep")?.parse::<u64>().ok())
}

/// The style of `nstepN` for an N in neither table, a function of N alone:
/// the k-th such N (k = 0 for the smallest) takes the k-th (colour, marker)
/// pair of [`NSTEP_COLOURS`] × [`NSTEP_MARKERS`] that [`SWEEP_STYLES`] does
/// not use, pair j being (colour j mod 8, marker (⌊j/8⌋ + j mod 8) mod 12). The
/// first 96 pairs are all different (for each colour, j ↦ marker runs
/// through the twelve markers), 88 remain after the sweep's, more than the
/// 69 other N of 1 ≤ N ≤ 81: every N-step coding has its own style.
fn nstep_style(n: u64) -> (RGBColor, Marker) {
    let tabulated_below = tabulated_n().filter(|&t| t < n).count() as u64;
    let k = n.saturating_sub(1 + tabulated_below) as usize;
    let (len_c, len_m) = (NSTEP_COLOURS.len(), NSTEP_MARKERS.len());
    let pairs: Vec<(RGBColor, Marker)> = (0..len_c * len_m)
        .map(|j| (NSTEP_COLOURS[j % len_c], NSTEP_MARKERS[(j / len_c + j % len_c) % len_m]))
        .filter(|pair| !SWEEP_STYLES.iter().any(|(_, c, m)| (*c, *m) == *pair))
        .collect();
    pairs[k % pairs.len()]
}

/// A coding's style, if `name` is a coding: the tables' for the codings in
/// [`CODING_STYLES`] and [`SWEEP_STYLES`], and for any other `nstepN` one of its own, the same in
/// every chart and page (see [`nstep_style`]).
pub fn coding_style(name: &str) -> Option<Style> {
    let name = name.trim().to_ascii_lowercase();
    let (colour, marker) = match CODING_STYLES
        .iter()
        .chain(SWEEP_STYLES.iter())
        .find(|(c, _, _)| *c == name)
    {
        Some(&(_, colour, marker)) => (colour, marker),
        None => nstep_style(name.strip_prefix("nstep")?.parse().ok()?),
    };
    Some(Style {
        colour,
        marker,
        size: MARKER_PX,
    })
}

/// A coding's colour as CSS writes it (`#rrggbb`), if `name` is a coding.
pub fn coding_colour_hex(name: &str) -> Option<String> {
    coding_style(name).map(|s| format!("#{:02x}{:02x}{:02x}", s.colour.0, s.colour.1, s.colour.2))
}

/// Whether a series is the measurement (or the study's truth).
pub(super) fn is_measurement(name: &str) -> bool {
    let n = name.to_ascii_lowercase();
    n.starts_with("measured") || n.starts_with("measurement") || n.starts_with("truth")
}

/// A display's own gamut on a chromaticity diagram (a display profile's
/// measured primaries): a purple line 2 px wide with square corners, apart
/// from the grey sRGB and RADIANCE gamuts it is drawn among.
pub const DISPLAY_GAMUT: Style = Style {
    colour: RGBColor(118, 42, 131),
    marker: Marker::Square,
    size: MARKER_PX,
};

/// Whether a series is a display's own gamut ([`DISPLAY_GAMUT`]): its name
/// starts with "display gamut".
pub(super) fn is_display_gamut(name: &str) -> bool {
    name.to_ascii_lowercase().starts_with("display gamut")
}

/// The style of a named series: its coding's, the measurement's, or the
/// `other`-th of the neutral styles.
pub(super) fn series_style(name: &str, other: &mut usize) -> Style {
    if is_measurement(name) {
        return MEASUREMENT;
    }
    if is_display_gamut(name) {
        return DISPLAY_GAMUT;
    }
    if let Some(style) = display_channel_style(name) {
        return style;
    }
    coding_style(name).unwrap_or_else(|| {
        let colour = OTHER_COLOURS[*other % OTHER_COLOURS.len()];
        let marker = [Marker::Square, Marker::Diamond, Marker::Circle][*other % 3];
        *other += 1;
        Style {
            colour,
            marker,
            size: MARKER_PX,
        }
    })
}

/// A display channel's series (`red`, `green measured`, `blue fit v^2.2`,
/// `black`, `white, measured`, `black + R + G + B`) in its own colour, so a
/// display profile's charts read at a glance: measured points as squares,
/// spectra and fitted curves as plain lines, the additivity sum in orange.
pub(super) fn display_channel_style(name: &str) -> Option<Style> {
    let first = name.split([' ', ',']).next()?;
    let colour = if name.contains(" + ") {
        RGBColor(230, 159, 0)
    } else {
        match first {
            "red" => RGBColor(213, 40, 30),
            "green" => RGBColor(0, 150, 60),
            "blue" => RGBColor(30, 80, 210),
            "black" => RGBColor(90, 90, 90),
            "white" => RGBColor(0, 0, 0),
            _ => return None,
        }
    };
    let points = name.contains("measured") && !name.contains(" + ");
    Some(Style {
        colour,
        marker: Marker::Square,
        size: if points { MARKER_PX } else { 0 },
    })
}

/// The coding table as CSS custom properties and classes, for the dashboard
/// and the report (`--coding-nstep3: #cc79a7` …, `.coding-nstep3 { color }`).
pub fn coding_css() -> String {
    let mut css = String::from(":root{");
    for (c, RGBColor(r, g, b), _) in CODING_STYLES {
        css.push_str(&format!("--coding-{c}:#{r:02x}{g:02x}{b:02x};"));
    }
    css.push_str("--coding-measured:#000000}");
    for (c, _, _) in CODING_STYLES {
        css.push_str(&format!(".coding-{c}{{color:var(--coding-{c});font-weight:600}}"));
    }
    css
}

/// The observer's name as charts print it.
pub fn observer_name(observer: Observer) -> &'static str {
    observer.label()
}
