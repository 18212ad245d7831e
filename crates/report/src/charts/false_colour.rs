//! A false-colour map as a figure: the map's PNG embedded at a readable size,
//! pixels kept square and sharp, beside a colour bar with labelled ticks, a
//! title and notes saying what the colours mean.
//!
//! The bar is an SVG gradient through the same 11 viridis stops the map is
//! interpolated from ([`VIRIDIS`]); SVG gradients interpolate in sRGB as the
//! map does, so the bar shows exactly the map's colours. Written by hand,
//! not with plotters: the SVG backend embeds no raster without the `image`
//! crate, and the figure is one `<image>`, one gradient and some text.
//!
//! ```
//! use lightbooth_report::charts::{false_colour_map_svg, FalseColourMap};
//! let png = [0u8; 8]; // the map's PNG bytes (here only a stand-in)
//! let svg = false_colour_map_svg(&FalseColourMap {
//!     png: &png,
//!     width: 4,
//!     height: 3,
//!     scale_max: 2.5,
//!     quantity: "ΔE00",
//!     title: "ΔE00, intended vs shown",
//!     notes: &["values above 2.5 are drawn as 2.5".to_string()],
//! })
//! .unwrap();
//! assert!(svg.contains("data:image/png;base64,"));
//! assert!(svg.contains(">2.5<"));
//! ```

use base64::Engine as _;

use super::{finished, tick_label, ChartResult, CAPTION_PX, TICK_PX};
use lightbooth_science::display::stimulus_files::VIRIDIS;

/// What [`false_colour_map_svg`] draws.
pub struct FalseColourMap<'a> {
    /// The map as PNG (viridis, 0 at the dark end, `scale_max` at the yellow end).
    pub png: &'a [u8],
    /// The map's size in pixels.
    pub width: u32,
    pub height: u32,
    /// The value at the bar's top (the map's yellow end).
    pub scale_max: f64,
    /// The quantity's name, written above the bar.
    pub quantity: &'a str,
    pub title: &'a str,
    /// Lines under the figure: how the value was computed, what was clamped.
    pub notes: &'a [String],
}

/// The largest box the map is scaled into, px.
const MAP_BOX: (f64, f64) = (640.0, 440.0);
/// The bar's least height, px, so that a flat map still gets a readable scale.
const BAR_MIN_H: f64 = 240.0;
const MARGIN: f64 = 16.0;

/// Ticks on 0…`max`: a 1-2-2.5-5 step giving at most 6 ticks, with `max`
/// itself as the last tick (a nice tick within 8 % of it is dropped so the
/// labels do not collide).
pub fn colour_bar_ticks(max: f64) -> Vec<f64> {
    if !(max.is_finite() && max > 0.0) {
        return vec![0.0];
    }
    let raw = max / 5.0;
    let decade = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * decade)
        .find(|s| max / s <= 5.0 + 1e-9)
        .unwrap_or(10.0 * decade);
    let mut ticks: Vec<f64> = (0..)
        .map(|i| f64::from(i) * step)
        .take_while(|v| *v < max * 0.92)
        .collect();
    ticks.push(max);
    ticks
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// The map and its colour bar as one SVG figure.
pub fn false_colour_map_svg(m: &FalseColourMap) -> ChartResult {
    if m.width == 0 || m.height == 0 {
        return Err(format!("a {}×{} map has no pixels to draw", m.width, m.height));
    }
    let scale = (MAP_BOX.0 / f64::from(m.width)).min(MAP_BOX.1 / f64::from(m.height));
    let (iw, ih) = (f64::from(m.width) * scale, f64::from(m.height) * scale);
    let top = MARGIN + f64::from(CAPTION_PX) + 16.0;
    // Room above the bar for the quantity's name and the top tick's label;
    // the bar ends where the map does.
    let bar_top = top + 30.0;
    let (bar_x, bar_w, bar_h) = (MARGIN + iw + 28.0, 22.0, (ih - 30.0).max(BAR_MIN_H));
    let body_h = (top + ih).max(bar_top + bar_h);
    // Notes are not wrapped: the figure is as wide as the longest (at ~0.55
    // em per character of a sans-serif face).
    let longest = m.notes.iter().map(|n| n.chars().count()).max().unwrap_or(0) as f64;
    let width = (bar_x + bar_w + 90.0).max(2.0 * MARGIN + longest * f64::from(TICK_PX) * 0.55);
    let height = body_h + 14.0 + 20.0 * m.notes.len() as f64 + MARGIN;
    let mut svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{width:.0}\" height=\"{height:.0}\" \
         viewBox=\"0 0 {width:.0} {height:.0}\" font-family=\"sans-serif\">\n\
         <rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n\
         <text x=\"{MARGIN}\" y=\"{:.0}\" font-size=\"{CAPTION_PX}\">{}</text>\n",
        MARGIN + f64::from(CAPTION_PX),
        escape(m.title)
    );
    let data = base64::engine::general_purpose::STANDARD.encode(m.png);
    svg.push_str(&format!(
        "<image x=\"{MARGIN}\" y=\"{top:.1}\" width=\"{iw:.1}\" height=\"{ih:.1}\" \
         preserveAspectRatio=\"none\" style=\"image-rendering:pixelated\" \
         href=\"data:image/png;base64,{data}\"/>\n"
    ));
    svg.push_str("<defs><linearGradient id=\"scale\" x1=\"0\" y1=\"1\" x2=\"0\" y2=\"0\">");
    for (i, [r, g, b]) in VIRIDIS.iter().enumerate() {
        svg.push_str(&format!(
            "<stop offset=\"{:.1}\" stop-color=\"#{r:02x}{g:02x}{b:02x}\"/>",
            i as f64 / (VIRIDIS.len() - 1) as f64
        ));
    }
    svg.push_str("</linearGradient></defs>\n");
    svg.push_str(&format!(
        "<text x=\"{bar_x:.1}\" y=\"{:.1}\" font-size=\"{TICK_PX}\">{}</text>\n\
         <rect x=\"{bar_x:.1}\" y=\"{bar_top:.1}\" width=\"{bar_w}\" height=\"{bar_h:.1}\" \
         fill=\"url(#scale)\" stroke=\"#444\" stroke-width=\"0.8\"/>\n",
        bar_top - 16.0,
        escape(m.quantity)
    ));
    for v in colour_bar_ticks(m.scale_max) {
        let y = bar_top + bar_h * (1.0 - v / m.scale_max.max(f64::MIN_POSITIVE));
        let x = bar_x + bar_w;
        svg.push_str(&format!(
            "<line x1=\"{x:.1}\" y1=\"{y:.1}\" x2=\"{:.1}\" y2=\"{y:.1}\" stroke=\"#444\"/>\
             <text x=\"{:.1}\" y=\"{:.1}\" font-size=\"{TICK_PX}\">{}</text>\n",
            x + 5.0,
            x + 8.0,
            y + f64::from(TICK_PX) * 0.35,
            if v == 0.0 {
                "0".to_string()
            } else {
                tick_label(v, m.scale_max)
            }
        ));
    }
    for (i, note) in m.notes.iter().enumerate() {
        svg.push_str(&format!(
            "<text x=\"{MARGIN}\" y=\"{:.1}\" font-size=\"{TICK_PX}\" fill=\"#333\">{}</text>\n",
            body_h + 28.0 + 20.0 * i as f64,
            escape(note)
        ));
    }
    svg.push_str("</svg>\n");
    finished(svg)
}
