//! The stimulus as files: frame-buffer codes as a 16-bit PNG and (for 10
//! and 12 bits) raw little-endian `u16` with a JSON sidecar, and the ΔE00
//! of every pixel as a false-colour PNG.
//!
//! - PNG: 16-bit RGB, rows top to bottom, each code MSB-aligned,
//!   `code << (16 − bits)` (an 8-bit code 255 is stored as 65280), so the
//!   file's top bits are the frame buffer's; the reader shifts right by
//!   `16 − bits` to get the codes back.
//! - Raw: the codes themselves (0 … 2^bits − 1, not shifted) as `u16`
//!   little-endian, pixel-interleaved R, G, B, rows top to bottom; the
//!   sidecar `<file>.json` gives width, height, bits, channel order, sample
//!   type and byte order.
//! - ΔE00 map: 8-bit RGB, viridis (van der Walt & Smith's perceptually
//!   ordered map, matplotlib) from 0 at the dark end to `scale_max` at the
//!   yellow end, values above clamped; the map is interpolated linearly in
//!   sRGB between viridis at 11 stops (0, 0.1, …, 1) — an approximation of
//!   the 256-entry table, within a few code values of it. Its scale (a
//!   colour bar with ticks) is drawn by `charts::false_colour_map_svg`.

use std::io::BufWriter;
use std::path::Path;

use serde::Serialize;

/// Viridis at 0, 0.1, …, 1 (matplotlib's table at those points).
pub const VIRIDIS: [[u8; 3]; 11] = [
    [0x44, 0x01, 0x54],
    [0x48, 0x24, 0x75],
    [0x41, 0x44, 0x87],
    [0x35, 0x5f, 0x8d],
    [0x2a, 0x78, 0x8e],
    [0x21, 0x91, 0x8c],
    [0x22, 0xa8, 0x84],
    [0x44, 0xbf, 0x70],
    [0x7a, 0xd1, 0x51],
    [0xbd, 0xdf, 0x26],
    [0xfd, 0xe7, 0x25],
];

/// The viridis colour of `f` in 0–1 (clamped).
pub fn viridis(f: f64) -> [u8; 3] {
    let f = if f.is_finite() { f.clamp(0.0, 1.0) } else { 1.0 };
    let x = f * 10.0;
    let i = (x.floor() as usize).min(9);
    let w = x - i as f64;
    [0, 1, 2].map(|c| {
        let (a, b) = (f64::from(VIRIDIS[i][c]), f64::from(VIRIDIS[i + 1][c]));
        (a + w * (b - a)).round() as u8
    })
}

fn png_writer(
    path: &Path,
    width: u32,
    height: u32,
    depth: png::BitDepth,
) -> Result<png::Writer<BufWriter<std::fs::File>>, String> {
    let file = std::fs::File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut enc = png::Encoder::new(BufWriter::new(file), width, height);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(depth);
    enc.write_header().map_err(|e| format!("{}: {e}", path.display()))
}

/// The codes as a 16-bit RGB PNG, MSB-aligned (see the module doc).
pub fn write_codes_png(path: &Path, width: u32, height: u32, bits: u32, codes: &[[u32; 3]]) -> Result<(), String> {
    let shift = 16 - bits;
    let mut data = Vec::with_capacity(codes.len() * 6);
    for px in codes {
        for &c in px {
            data.extend_from_slice(&((c << shift) as u16).to_be_bytes());
        }
    }
    let mut w = png_writer(path, width, height, png::BitDepth::Sixteen)?;
    w.write_image_data(&data)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    w.finish().map_err(|e| format!("{}: {e}", path.display()))
}

/// The sidecar of a raw code file.
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct RawSidecar {
    pub width: u32,
    pub height: u32,
    pub bits: u32,
    /// `RGB`, pixel-interleaved.
    pub channels: String,
    /// `u16`.
    pub sample: String,
    /// `little-endian`.
    pub byte_order: String,
    /// `top-to-bottom`.
    pub rows: String,
    /// The codes as they are: 0 … 2^bits − 1, not shifted.
    pub alignment: String,
}

/// The codes as raw little-endian `u16` and its sidecar `<path>.json`; returns the sidecar's path.
pub fn write_codes_raw(
    path: &Path,
    width: u32,
    height: u32,
    bits: u32,
    codes: &[[u32; 3]],
) -> Result<std::path::PathBuf, String> {
    let mut data = Vec::with_capacity(codes.len() * 6);
    for px in codes {
        for &c in px {
            data.extend_from_slice(&(c as u16).to_le_bytes());
        }
    }
    std::fs::write(path, data).map_err(|e| format!("{}: {e}", path.display()))?;
    let sidecar = RawSidecar {
        width,
        height,
        bits,
        channels: "RGB".into(),
        sample: "u16".into(),
        byte_order: "little-endian".into(),
        rows: "top-to-bottom".into(),
        alignment: format!("codes as they are, 0-{}, not shifted", (1u32 << bits) - 1),
    };
    let mut name = path.as_os_str().to_owned();
    name.push(".json");
    let side = std::path::PathBuf::from(name);
    let text = serde_json::to_string_pretty(&sidecar).map_err(|e| e.to_string())?;
    std::fs::write(&side, text).map_err(|e| format!("{}: {e}", side.display()))?;
    Ok(side)
}

/// ΔE00 per pixel as a viridis PNG scaled 0 … `scale_max`.
/// Returns the PNG's bytes (for a figure with its colour bar,
/// `charts::false_colour_map_svg`).
pub fn write_delta_e_map(
    path: &Path,
    width: u32,
    height: u32,
    delta_e: &[f64],
    scale_max: f64,
) -> Result<Vec<u8>, String> {
    let data: Vec<u8> = delta_e.iter().flat_map(|&d| viridis(d / scale_max)).collect();
    let mut bytes = Vec::new();
    let mut enc = png::Encoder::new(&mut bytes, width, height);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut w = enc.write_header().map_err(|e| format!("{}: {e}", path.display()))?;
    w.write_image_data(&data)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    w.finish().map_err(|e| format!("{}: {e}", path.display()))?;
    std::fs::write(path, &bytes).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn viridis_runs_from_purple_to_yellow_through_its_stops() {
        assert_eq!(viridis(0.0), [0x44, 0x01, 0x54]);
        assert_eq!(viridis(0.5), [0x21, 0x91, 0x8c]);
        assert_eq!(viridis(1.0), [0xfd, 0xe7, 0x25]);
        assert_eq!(viridis(7.0), viridis(1.0));
        // Perceptually ordered: the green channel (most of the lightness) rises monotonically.
        let g: Vec<u8> = (0..=100).map(|i| viridis(f64::from(i) / 100.0)[1]).collect();
        assert!(g.windows(2).all(|p| p[1] >= p[0]), "{g:?}");
    }
}
