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

/// Colours for the codings `nstepN` whose N is not in [`CODING_STYLES`]
/// (Paul Tol's muted and dark colours): none is one of the table's, black
/// (the measurement), a grey or a near-white, so each reads on white.
const NSTEP_COLOURS: [RGBColor; 7] = [
    RGBColor(51, 34, 136),
    RGBColor(136, 34, 85),
    RGBColor(153, 153, 51),
    RGBColor(17, 119, 51),
    RGBColor(170, 68, 153),
    RGBColor(140, 81, 10),
    RGBColor(200, 0, 60),
];

/// The filled or stroked markers a coding may have (the open circle is the
/// measurement's).
const NSTEP_MARKERS: [Marker; 7] = [
    Marker::Circle,
    Marker::Square,
    Marker::Diamond,
    Marker::TriangleUp,
    Marker::TriangleDown,
    Marker::Cross,
    Marker::Plus,
];

/// The style of `nstepN` for an N not in [`CODING_STYLES`], a function of
/// N alone: the k-th such N (k = 0 for N = 1) takes colour k mod 7 and
/// marker (k + ⌊k/7⌋) mod 7, so the first 49 untabulated N (every N up to
/// 52) have pairwise different (colour, marker), and none shares a colour
/// with a tabulated coding.
fn nstep_style(n: u64) -> (RGBColor, Marker) {
    let tabulated_below = CODING_STYLES
        .iter()
        .filter_map(|(c, _, _)| c.strip_prefix("nstep")?.parse::<u64>().ok())
        .filter(|&t| t < n)
        .count() as u64;
    let k = n.saturating_sub(1 + tabulated_below);
    let (len_c, len_m) = (NSTEP_COLOURS.len() as u64, NSTEP_MARKERS.len() as u64);
    let colour = NSTEP_COLOURS[(k % len_c) as usize];
    let marker = NSTEP_MARKERS[((k + k / len_c) % len_m) as usize];
    (colour, marker)
}

/// A coding's style, if `name` is a coding: the table's for the codings in
/// [`CODING_STYLES`], and for any other `nstepN` one of its own, the same in
/// every chart and page (see [`nstep_style`]).
pub fn coding_style(name: &str) -> Option<Style> {
    let name = name.trim().to_ascii_lowercase();
    let (colour, marker) = match CODING_STYLES.iter().find(|(c, _, _)| *c == name) {
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

/// The style of a named series: its coding's, the measurement's, or the
/// `other`-th of the neutral styles.
pub(super) fn series_style(name: &str, other: &mut usize) -> Style {
    if is_measurement(name) {
        return MEASUREMENT;
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
    match observer {
        Observer::JuddVos => "Judd–Vos 1978 2°",
        Observer::Cie1931 => "CIE 1931 2°",
    }
}
