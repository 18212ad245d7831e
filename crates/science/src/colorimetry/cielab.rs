//! CIELAB (CIE 1976 L*a*b*) and colour differences ΔE*ab and CIEDE2000.
//!
//! CIELAB needs a reference white; lightbooth never assumes one. The study
//! converts the measurement and every rendering with the same white per scene.
//!
//! ```
//! use lightbooth_science::colorimetry::{ciede2000, delta_e76, Lab};
//! let a = Lab { l: 50.0, a: 2.6772, b: -79.7751 };
//! let b = Lab { l: 50.0, a: 0.0, b: -82.7485 };
//! assert!((ciede2000(a, b) - 2.0425).abs() < 1e-4); // Sharma et al. (2005), pair 1
//! assert!(delta_e76(a, b) > ciede2000(a, b));
//! ```

use serde::Serialize;

use super::Xyz;

/// CIE 1976 L*, a*, b*.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Lab {
    #[serde(rename = "L")]
    pub l: f64,
    pub a: f64,
    pub b: f64,
}

// CIE 15:2004 §8.2.1, in the exact rational form (CIE 15 rounds these to
// 0.008856 and 903.3; the rational form makes f(t) continuous).
const EPSILON: f64 = 216.0 / 24389.0;
const KAPPA: f64 = 24389.0 / 27.0;

fn f(t: f64) -> f64 {
    if t > EPSILON {
        t.cbrt()
    } else {
        (KAPPA * t + 16.0) / 116.0
    }
}

impl Lab {
    /// CIELAB of `xyz` relative to the reference white `white` (same scale:
    /// both absolute in cd/m², or both relative).
    pub fn from_xyz(xyz: Xyz, white: Xyz) -> Lab {
        let fx = f(xyz.x / white.x);
        let fy = f(xyz.y / white.y);
        let fz = f(xyz.z / white.z);
        Lab {
            l: 116.0 * fy - 16.0,
            a: 500.0 * (fx - fy),
            b: 200.0 * (fy - fz),
        }
    }

    /// Chroma C*ab.
    pub fn chroma(self) -> f64 {
        self.a.hypot(self.b)
    }
}

/// ΔE*ab (CIE 1976): Euclidean distance in CIELAB.
pub fn delta_e76(p: Lab, q: Lab) -> f64 {
    ((p.l - q.l).powi(2) + (p.a - q.a).powi(2) + (p.b - q.b).powi(2)).sqrt()
}

/// CIEDE2000 ΔE00 with kL = kC = kH = 1 (CIE 142-2001), implemented as in
/// Sharma, Wu & Dalal, "The CIEDE2000 color-difference formula:
/// implementation notes, supplementary test data, and mathematical
/// observations", Color Res. Appl. 30(1), 21–30 (2005), equations 1–22.
pub fn ciede2000(p: Lab, q: Lab) -> f64 {
    const POW25_7: f64 = 6_103_515_625.0; // 25^7
    let c_bar = 0.5 * (p.chroma() + q.chroma());
    let c7 = c_bar.powi(7);
    let g = 0.5 * (1.0 - (c7 / (c7 + POW25_7)).sqrt());
    let a1 = (1.0 + g) * p.a;
    let a2 = (1.0 + g) * q.a;
    let c1 = a1.hypot(p.b);
    let c2 = a2.hypot(q.b);
    // Hue angles in degrees in [0, 360); zero for a neutral colour (eq. 4).
    let hue = |b: f64, a: f64| {
        if b == 0.0 && a == 0.0 {
            0.0
        } else {
            b.atan2(a).to_degrees().rem_euclid(360.0)
        }
    };
    let h1 = hue(p.b, a1);
    let h2 = hue(q.b, a2);

    let dl = q.l - p.l;
    let dc = c2 - c1;
    let dh_angle = if c1 * c2 == 0.0 {
        0.0
    } else {
        let d = h2 - h1;
        if d > 180.0 {
            d - 360.0
        } else if d < -180.0 {
            d + 360.0
        } else {
            d
        }
    };
    let dh = 2.0 * (c1 * c2).sqrt() * (dh_angle.to_radians() / 2.0).sin();

    let l_bar = 0.5 * (p.l + q.l);
    let c_bar_p = 0.5 * (c1 + c2);
    let h_bar = if c1 * c2 == 0.0 {
        h1 + h2
    } else if (h1 - h2).abs() <= 180.0 {
        0.5 * (h1 + h2)
    } else if h1 + h2 < 360.0 {
        0.5 * (h1 + h2 + 360.0)
    } else {
        0.5 * (h1 + h2 - 360.0)
    };
    let t = 1.0 - 0.17 * (h_bar - 30.0).to_radians().cos()
        + 0.24 * (2.0 * h_bar).to_radians().cos()
        + 0.32 * (3.0 * h_bar + 6.0).to_radians().cos()
        - 0.20 * (4.0 * h_bar - 63.0).to_radians().cos();
    let d_theta = 30.0 * (-((h_bar - 275.0) / 25.0).powi(2)).exp();
    let c7p = c_bar_p.powi(7);
    let r_c = 2.0 * (c7p / (c7p + POW25_7)).sqrt();
    let l50 = (l_bar - 50.0).powi(2);
    let s_l = 1.0 + 0.015 * l50 / (20.0 + l50).sqrt();
    let s_c = 1.0 + 0.045 * c_bar_p;
    let s_h = 1.0 + 0.015 * c_bar_p * t;
    let r_t = -(2.0 * d_theta).to_radians().sin() * r_c;
    let (x, y, z) = (dl / s_l, dc / s_c, dh / s_h);
    (x * x + y * y + z * z + r_t * y * z).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// All 34 pairs of Sharma, Wu & Dalal (2005), Table 1: L1 a1 b1, L2 a2 b2, ΔE00.
    const SHARMA: [[f64; 7]; 34] = [
        [50.0000, 2.6772, -79.7751, 50.0000, 0.0000, -82.7485, 2.0425],
        [50.0000, 3.1571, -77.2803, 50.0000, 0.0000, -82.7485, 2.8615],
        [50.0000, 2.8361, -74.0200, 50.0000, 0.0000, -82.7485, 3.4412],
        [50.0000, -1.3802, -84.2814, 50.0000, 0.0000, -82.7485, 1.0000],
        [50.0000, -1.1848, -84.8006, 50.0000, 0.0000, -82.7485, 1.0000],
        [50.0000, -0.9009, -85.5211, 50.0000, 0.0000, -82.7485, 1.0000],
        [50.0000, 0.0000, 0.0000, 50.0000, -1.0000, 2.0000, 2.3669],
        [50.0000, -1.0000, 2.0000, 50.0000, 0.0000, 0.0000, 2.3669],
        [50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0009, 7.1792],
        [50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0010, 7.1792],
        [50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0011, 7.2195],
        [50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0012, 7.2195],
        [50.0000, -0.0010, 2.4900, 50.0000, 0.0009, -2.4900, 4.8045],
        [50.0000, -0.0010, 2.4900, 50.0000, 0.0010, -2.4900, 4.8045],
        [50.0000, -0.0010, 2.4900, 50.0000, 0.0011, -2.4900, 4.7461],
        [50.0000, 2.5000, 0.0000, 50.0000, 0.0000, -2.5000, 4.3065],
        [50.0000, 2.5000, 0.0000, 73.0000, 25.0000, -18.0000, 27.1492],
        [50.0000, 2.5000, 0.0000, 61.0000, -5.0000, 29.0000, 22.8977],
        [50.0000, 2.5000, 0.0000, 56.0000, -27.0000, -3.0000, 31.9030],
        [50.0000, 2.5000, 0.0000, 58.0000, 24.0000, 15.0000, 19.4535],
        [50.0000, 2.5000, 0.0000, 50.0000, 3.1736, 0.5854, 1.0000],
        [50.0000, 2.5000, 0.0000, 50.0000, 3.2972, 0.0000, 1.0000],
        [50.0000, 2.5000, 0.0000, 50.0000, 1.8634, 0.5757, 1.0000],
        [50.0000, 2.5000, 0.0000, 50.0000, 3.2592, 0.3350, 1.0000],
        [60.2574, -34.0099, 36.2677, 60.4626, -34.1751, 39.4387, 1.2644],
        [63.0109, -31.0961, -5.8663, 62.8187, -29.7946, -4.0864, 1.2630],
        [61.2901, 3.7196, -5.3901, 61.4292, 2.2480, -4.9620, 1.8731],
        [35.0831, -44.1164, 3.7933, 35.0232, -40.0716, 1.5901, 1.8645],
        [22.7233, 20.0904, -46.6940, 23.0331, 14.9730, -42.5619, 2.0373],
        [36.4612, 47.8580, 18.3852, 36.2715, 50.5065, 21.2231, 1.4146],
        [90.8027, -2.0831, 1.4410, 91.1528, -1.6435, 0.0447, 1.4441],
        [90.9257, -0.5406, -0.9208, 88.6381, -0.8985, -0.7239, 1.5381],
        [6.7747, -0.2908, -2.4247, 5.8714, -0.0985, -2.2286, 0.6377],
        [2.0776, 0.0795, -1.1350, 0.9033, -0.0636, -0.5514, 0.9082],
    ];

    #[test]
    fn ciede2000_matches_all_34_sharma_pairs() {
        for (i, r) in SHARMA.iter().enumerate() {
            let p = Lab {
                l: r[0],
                a: r[1],
                b: r[2],
            };
            let q = Lab {
                l: r[3],
                a: r[4],
                b: r[5],
            };
            let forward = ciede2000(p, q);
            let backward = ciede2000(q, p);
            assert!((forward - r[6]).abs() < 1e-4, "pair {}: {forward} vs {}", i + 1, r[6]);
            assert!((backward - r[6]).abs() < 1e-4, "pair {} reversed: {backward}", i + 1);
        }
    }

    #[test]
    fn the_reference_white_is_l100_and_neutral() {
        let white = Xyz::new(95.047, 100.0, 108.883);
        let lab = Lab::from_xyz(white, white);
        assert!((lab.l - 100.0).abs() < 1e-12 && lab.a.abs() < 1e-12 && lab.b.abs() < 1e-12);
        let grey = Lab::from_xyz(white.scaled(0.18), white);
        // Y/Yn = 0.18 → L* = 116·0.18^(1/3) − 16 = 49.496
        assert!((grey.l - 49.4961).abs() < 1e-4, "{}", grey.l);
        // Below the linear segment's knee: L* = κ·Y/Yn.
        let dark = Lab::from_xyz(white.scaled(0.001), white);
        assert!((dark.l - KAPPA * 0.001).abs() < 1e-9);
    }
}
