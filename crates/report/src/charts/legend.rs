//! Legends in their own column right of the plot, never over data.

use super::*;

/// What a legend entry shows beside its name.
#[derive(Clone, Copy)]
pub(super) enum Glyph {
    Line(RGBColor, u32),
    Dashed(RGBColor),
    Marker(Style),
    /// The marker's outline only: what a hollow point in the plot means.
    HollowMarker(Style),
    LineMarker(Style),
    Band(RGBColor),
}

pub(super) struct LegendEntry {
    pub(super) name: String,
    pub(super) glyph: Glyph,
}

/// Splits `name` into lines of at most `width` characters at spaces.
pub(super) fn wrap(name: &str, width: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    for word in name.split_whitespace() {
        match lines.last_mut() {
            Some(l) if l.chars().count() + 1 + word.chars().count() <= width => {
                l.push(' ');
                l.push_str(word);
            }
            _ => lines.push(word.to_string()),
        }
    }
    lines
}

/// The legend in its own column (`area`, beside the plot): entries with an
/// empty name are skipped, so no legend shows a nameless swatch. Returns
/// the y (px) below its last entry.
pub(super) fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[LegendEntry],
) -> Result<i32, String> {
    let font = ("sans-serif", LEGEND_PX).into_font();
    let mut y = 40;
    for e in entries.iter().filter(|e| !e.name.trim().is_empty()) {
        let (x0, x1, ym) = (8, 34, y + LEGEND_PX as i32 / 2);
        match e.glyph {
            Glyph::Line(c, w) => area.draw(&PathElement::new(vec![(x0, ym), (x1, ym)], c.stroke_width(w))),
            Glyph::Dashed(c) => {
                for k in 0..3 {
                    area.draw(&PathElement::new(
                        vec![(x0 + 10 * k, ym), (x0 + 10 * k + 6, ym)],
                        c.stroke_width(2),
                    ))
                    .map_err(err)?;
                }
                Ok(())
            }
            Glyph::Marker(s) => with_marker!(s, |mk| area.draw(&mk(((x0 + x1) / 2, ym)))),
            Glyph::HollowMarker(s) => {
                for path in marker_outline(s) {
                    let at: Vec<(i32, i32)> = path.iter().map(|&(dx, dy)| ((x0 + x1) / 2 + dx, ym + dy)).collect();
                    area.draw(&PathElement::new(at, s.colour.stroke_width(2)))
                        .map_err(err)?;
                }
                Ok(())
            }
            Glyph::LineMarker(s) => {
                area.draw(&PathElement::new(vec![(x0, ym), (x1, ym)], s.colour.stroke_width(2)))
                    .map_err(err)?;
                with_marker!(s, |mk| area.draw(&mk(((x0 + x1) / 2, ym))))
            }
            Glyph::Band(c) => area.draw(&Rectangle::new([(x0, ym - 6), (x1, ym + 6)], c.filled())),
        }
        .map_err(err)?;
        for line in wrap(&e.name, 18) {
            area.draw(&Text::new(line, (x1 + 8, y), font.clone())).map_err(err)?;
            y += LEGEND_PX as i32 + 3;
        }
        y += 6;
    }
    Ok(y)
}

/// The font of notes under the legend (a key to numbered points, what a
/// hollow marker means).
const NOTE_PX: u32 = 13;

/// Notes in the legend column from `y` down: an optional heading, then each
/// note wrapped to the column. Returns the y below the last.
pub(super) fn draw_notes<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    mut y: i32,
    heading: &str,
    notes: &[String],
) -> Result<i32, String> {
    let font = ("sans-serif", NOTE_PX).into_font();
    y += 10;
    let lines = wrap(heading, 26).into_iter().chain(notes.iter().flat_map(|n| {
        let mut lines = wrap(n, 26);
        if let Some(last) = lines.last_mut() {
            last.push('\n');
        }
        lines
    }));
    for line in lines {
        let gap = line.ends_with('\n');
        area.draw(&Text::new(line.trim_end().to_string(), (8, y), font.clone()))
            .map_err(err)?;
        y += NOTE_PX as i32 + 1 + if gap { 4 } else { 0 };
    }
    Ok(y)
}
