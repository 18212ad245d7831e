//! RGB colour spaces, with their matrices derived from primaries and white
//! point rather than copied from tables.
//!
//! Derivation (e.g. SMPTE RP 177-1993): put the primaries' XYZ at unit
//! luminance in the columns of P, solve P·s = W for the white's XYZ (Y = 1),
//! and scale each column by s. Then RGB (1, 1, 1) is the white with Y = 1.
//!
//! ```
//! use lightbooth_science::colorimetry::rgb::RgbSpace;
//! let m = RgbSpace::SRGB.rgb_to_xyz();
//! assert!((m.row(1).x - 0.2126).abs() < 1e-4); // Rec. 709 luminance weights
//! ```

use glam::{DMat3, DVec3};

use super::{Chromaticity, Xyz};

/// Three primaries and a white point, all as CIE 1931 x, y.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RgbSpace {
    pub name: &'static str,
    pub red: Chromaticity,
    pub green: Chromaticity,
    pub blue: Chromaticity,
    pub white: Chromaticity,
}

const fn xy(x: f64, y: f64) -> Chromaticity {
    Chromaticity { x, y }
}

impl RgbSpace {
    /// RADIANCE's default primaries (`color.h`: CIE_x_r … CIE_y_w) with its
    /// equal-energy white: what RADIANCE's RGB rendering means. RADIANCE
    /// writes the white as x = y = 0.3333, not 1/3; that rounding moves its
    /// luminance weights by 3e-5, and we keep it so our numbers are RADIANCE's.
    pub const RADIANCE: RgbSpace = RgbSpace {
        name: "radiance",
        red: xy(0.640, 0.330),
        green: xy(0.290, 0.600),
        blue: xy(0.150, 0.060),
        white: xy(0.3333, 0.3333),
    };

    /// sRGB (IEC 61966-2-1): Rec. 709 primaries, D65 white (0.3127, 0.3290).
    pub const SRGB: RgbSpace = RgbSpace {
        name: "srgb",
        red: xy(0.640, 0.330),
        green: xy(0.300, 0.600),
        blue: xy(0.150, 0.060),
        white: xy(0.3127, 0.3290),
    };

    /// Linear RGB → XYZ; RGB (1, 1, 1) maps to the white with Y = 1.
    pub fn rgb_to_xyz(&self) -> DMat3 {
        let col = |c: Chromaticity| DVec3::from(c.to_xyz(1.0).to_array());
        let p = DMat3::from_cols(col(self.red), col(self.green), col(self.blue));
        let s = p.inverse() * DVec3::from(self.white.to_xyz(1.0).to_array());
        DMat3::from_cols(p.x_axis * s.x, p.y_axis * s.y, p.z_axis * s.z)
    }

    /// XYZ → linear RGB, the inverse of [`Self::rgb_to_xyz`].
    pub fn xyz_to_rgb(&self) -> DMat3 {
        self.rgb_to_xyz().inverse()
    }

    /// The white point's XYZ at luminance `y_lum`.
    pub fn white_xyz(&self, y_lum: f64) -> Xyz {
        self.white.to_xyz(y_lum)
    }
}

/// Applies a 3×3 matrix to XYZ or RGB triples.
pub fn apply(m: &DMat3, v: [f64; 3]) -> [f64; 3] {
    (*m * DVec3::from(v)).to_array()
}

/// The sRGB transfer function (IEC 61966-2-1): linear [0, 1] → encoded [0, 1].
pub fn srgb_encode(linear: f64) -> f64 {
    let c = linear.clamp(0.0, 1.0);
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assert_matrix(m: DMat3, want: [[f64; 3]; 3], tol: f64, what: &str) {
        for (r, row) in want.iter().enumerate() {
            for (c, w) in row.iter().enumerate() {
                let got = m.row(r)[c];
                assert!((got - w).abs() < tol, "{what}[{r}][{c}] = {got}, published {w}");
            }
        }
    }

    /// IEC 61966-2-1:1999 §5.2 publishes the sRGB matrix to four digits
    /// (0.4124 0.3576 0.1805 / 0.2126 0.7152 0.0722 / 0.0193 0.1192 0.9505)
    /// and its inverse (first row 3.2406 −1.5372 −0.4986). The standard
    /// rounded its own derivation, so agreement is to its last digit (±3e-4).
    #[test]
    fn srgb_matrix_matches_iec_61966_2_1() {
        let m = RgbSpace::SRGB.rgb_to_xyz();
        assert_matrix(
            m,
            [
                [0.4124, 0.3576, 0.1805],
                [0.2126, 0.7152, 0.0722],
                [0.0193, 0.1192, 0.9505],
            ],
            3e-4,
            "sRGB vs IEC 61966-2-1",
        );
        let inv = RgbSpace::SRGB.xyz_to_rgb();
        assert_matrix(
            inv,
            [
                [3.2406, -1.5372, -0.4986],
                [-0.9689, 1.8758, 0.0415],
                [0.0557, -0.2040, 1.0570],
            ],
            1e-3,
            "sRGB inverse vs IEC 61966-2-1",
        );
    }

    /// RADIANCE's `color.h` publishes the luminance row of its RGB→XYZ
    /// matrix for these primaries and equal-energy white as CIE_rf =
    /// 0.265074126, CIE_gf = 0.670114631, CIE_bf = 0.064811243 (the
    /// weights of its `bright()` macro).
    #[test]
    fn radiance_matrix_matches_radiance_luminance_weights() {
        let m = RgbSpace::RADIANCE.rgb_to_xyz();
        let y = m.row(1);
        assert!((y.x - 0.265074126).abs() < 1e-9, "{}", y.x);
        assert!((y.y - 0.670114631).abs() < 1e-9, "{}", y.y);
        assert!((y.z - 0.064811243).abs() < 1e-9, "{}", y.z);
        // White (1,1,1) → the equal-energy white at Y = 1; each primary keeps its chromaticity.
        let w = Xyz::from_array(apply(&m, [1.0, 1.0, 1.0]));
        assert!((w.y - 1.0).abs() < 1e-12);
        assert!((w.chromaticity().x - 0.3333).abs() < 1e-12 && (w.chromaticity().y - 0.3333).abs() < 1e-12);
        let red = Xyz::from_array(apply(&m, [1.0, 0.0, 0.0])).chromaticity();
        assert!((red.x - 0.640).abs() < 1e-12 && (red.y - 0.330).abs() < 1e-12);
    }

    #[test]
    fn srgb_transfer_function_is_continuous_at_the_knee() {
        let below = srgb_encode(0.003_130_8);
        let above = srgb_encode(0.003_130_8 + 1e-12);
        assert!((below - above).abs() < 1e-6);
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-15);
    }
}
