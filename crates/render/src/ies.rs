//! IES LM-63 photometric files (type C): parsing and interpolation of the
//! luminous intensity distribution in candela.
//!
//! Why our own parser: the maintained crate that reads IES files
//! (`eulumdat`) is AGPL-3.0, which lightbooth (MIT OR Apache-2.0) cannot
//! link. LM-63 is a small format; this parser reads LM-63-1995/2002/2019
//! headers, `TILT=NONE`, and type C photometry, and names the file and the
//! line of every problem.
//!
//! Conventions (LM-63-2002 §3):
//! - vertical angle γ is measured from the nadir, which is the luminaire's
//!   aim axis here (0° = straight along the aim), in degrees;
//! - horizontal angle C is the azimuth about that axis;
//! - candela = file value × candela multiplier × ballast factor ×
//!   ballast-lamp photometric factor.
//!
//! Horizontal symmetry follows the last horizontal angle: 0 (rotationally
//! symmetric), 90 (quadrant symmetric), 180 (bilateral about C = 0–180) or
//! 360 (full). Between tabulated angles the intensity is interpolated
//! bilinearly in (C, γ); beyond the last vertical angle it is zero.

use std::path::Path;

/// A type C photometric distribution in candela.
#[derive(Clone, Debug)]
pub struct IesDistribution {
    /// Vertical angles γ in degrees, increasing.
    vertical_deg: Vec<f64>,
    /// Horizontal angles C in degrees, increasing.
    horizontal_deg: Vec<f64>,
    /// `candela_cd[h][v]`, scaled by the file's multipliers.
    candela_cd: Vec<Vec<f64>>,
    /// The vertical step when the vertical angles are uniform (the usual
    /// goniophotometer table): the bin is then found by division.
    vertical_step_deg: Option<f64>,
}

/// A problem in an IES file, with the file and (when known) the line.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}{}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
pub struct IesError {
    pub file: String,
    pub line: Option<usize>,
    pub message: String,
}

impl IesDistribution {
    /// Reads and parses an IES file.
    pub fn read(path: &Path) -> Result<IesDistribution, IesError> {
        let text = super::input_file::read_text(path).map_err(|e| IesError {
            file: path.display().to_string(),
            line: None,
            message: format!("cannot read the file: {}", e.reason),
        })?;
        IesDistribution::parse(&text, &path.display().to_string())
    }

    /// Parses IES LM-63 text; `file` names it in errors.
    pub fn parse(text: &str, file: &str) -> Result<IesDistribution, IesError> {
        let err = |line: Option<usize>, message: String| IesError {
            file: file.to_string(),
            line,
            message,
        };
        let lines: Vec<&str> = text.lines().collect();
        let tilt = lines
            .iter()
            .position(|l| l.trim_start().to_ascii_uppercase().starts_with("TILT="))
            .ok_or_else(|| err(None, "no `TILT=` line: not an IES LM-63 file".into()))?;
        let tilt_value = lines[tilt].trim().split_once('=').map(|x| x.1.trim()).unwrap_or("");
        if !tilt_value.eq_ignore_ascii_case("NONE") {
            return Err(err(
                Some(tilt + 1),
                format!("TILT={tilt_value} is not supported (only TILT=NONE)"),
            ));
        }
        // Every number after TILT, with the line it came from.
        let mut numbers: Vec<(f64, usize)> = Vec::new();
        for (i, l) in lines.iter().enumerate().skip(tilt + 1) {
            for tok in l
                .split(|c: char| c.is_whitespace() || c == ',')
                .filter(|t| !t.is_empty())
            {
                let v: f64 = match tok.parse::<f64>() {
                    Ok(v) if v.is_finite() => v,
                    Ok(_) => return Err(err(Some(i + 1), format!("`{tok}` is not a finite number"))),
                    Err(_) => return Err(err(Some(i + 1), format!("`{tok}` is not a number"))),
                };
                numbers.push((v, i + 1));
            }
        }
        let available = numbers.len();
        let mut it = numbers.into_iter();
        let last_line = lines.len();
        let mut next = |what: &str| -> Result<(f64, usize), IesError> {
            it.next()
                .ok_or_else(|| err(Some(last_line), format!("the file ends before {what}")))
        };
        let _lamps = next("the number of lamps")?;
        let _lumens = next("lumens per lamp")?;
        let (multiplier, _) = next("the candela multiplier")?;
        let (n_vert, l_nv) = next("the number of vertical angles")?;
        let (n_horiz, l_nh) = next("the number of horizontal angles")?;
        let (ptype, l_pt) = next("the photometric type")?;
        let _units = next("the units type")?;
        for what in ["width", "length", "height"] {
            next(what)?;
        }
        let (ballast, _) = next("the ballast factor")?;
        let (ballast_lamp, _) = next("the ballast-lamp photometric factor")?;
        let _watts = next("input watts")?;
        if ptype != 1.0 {
            return Err(err(
                Some(l_pt),
                format!("photometric type {ptype}: only type C (1) is supported"),
            ));
        }
        let count = |v: f64, line: usize, what: &str| -> Result<usize, IesError> {
            if v >= 1.0 && v.fract() == 0.0 {
                Ok(v as usize)
            } else {
                Err(err(Some(line), format!("the number of {what} angles is {v}")))
            }
        };
        let nv = count(n_vert, l_nv, "vertical")?;
        let nh = count(n_horiz, l_nh, "horizontal")?;
        // The angles and the nh × nv candela table must all be in the file:
        // counts beyond what it holds are an error, not an allocation.
        let needed = nh
            .checked_add(1)
            .and_then(|n| n.checked_mul(nv))
            .and_then(|n| n.checked_add(nh));
        if needed.is_none_or(|n| n > available) {
            return Err(err(
                Some(l_nh),
                format!(
                    "{nv} vertical × {nh} horizontal angles need more numbers than the file's {available}: \
                     the counts do not match the table"
                ),
            ));
        }
        for (v, what) in [
            (multiplier, "candela multiplier"),
            (ballast, "ballast factor"),
            (ballast_lamp, "ballast-lamp photometric factor"),
        ] {
            if v <= 0.0 {
                return Err(err(None, format!("the {what} is {v}; it must be positive")));
            }
        }
        let mut take =
            |n: usize, what: &str| -> Result<Vec<(f64, usize)>, IesError> { (0..n).map(|_| next(what)).collect() };
        let vertical = take(nv, "all vertical angles")?;
        let horizontal = take(nh, "all horizontal angles")?;
        let scale = multiplier * ballast * ballast_lamp;
        let mut candela_cd = Vec::with_capacity(nh);
        for _ in 0..nh {
            let row = take(nv, "all candela values")?;
            for (v, line) in &row {
                if *v < 0.0 {
                    return Err(err(Some(*line), format!("negative candela value {v}")));
                }
            }
            let mut scaled = Vec::with_capacity(nv);
            for (v, line) in &row {
                let cd = v * scale;
                if !cd.is_finite() {
                    return Err(err(
                        Some(*line),
                        format!(
                            "candela value {v} × the multipliers ({scale:e}) is not a finite number: the \
                             numbers overflow; check the candela multiplier and the ballast factors"
                        ),
                    ));
                }
                scaled.push(cd);
            }
            candela_cd.push(scaled);
        }
        let increasing = |a: &[(f64, usize)], what: &str| -> Result<Vec<f64>, IesError> {
            for w in a.windows(2) {
                if w[1].0 <= w[0].0 {
                    return Err(err(
                        Some(w[1].1),
                        format!("{what} angles must increase: {} after {}", w[1].0, w[0].0),
                    ));
                }
            }
            Ok(a.iter().map(|x| x.0).collect())
        };
        let vertical_deg = increasing(&vertical, "vertical")?;
        let horizontal_deg = increasing(&horizontal, "horizontal")?;
        if vertical_deg[0] < 0.0 || vertical_deg[nv - 1] > 180.0 {
            return Err(err(Some(vertical[0].1), "vertical angles must lie in 0–180°".into()));
        }
        let (h0, hl) = (horizontal_deg[0], horizontal_deg[nh - 1]);
        if h0 != 0.0 || !(nh == 1 || [90.0, 180.0, 360.0].contains(&hl)) {
            return Err(err(
                Some(horizontal[0].1),
                format!("horizontal angles {h0}–{hl}°: type C needs 0 (symmetric), 0–90, 0–180 or 0–360"),
            ));
        }
        let step = (vertical_deg[nv - 1] - vertical_deg[0]) / (nv.max(2) - 1) as f64;
        let uniform = nv >= 2
            && vertical_deg
                .iter()
                .enumerate()
                .all(|(i, v)| (v - (vertical_deg[0] + step * i as f64)).abs() < 1e-9);
        Ok(IesDistribution {
            vertical_deg,
            horizontal_deg,
            candela_cd,
            vertical_step_deg: uniform.then_some(step),
        })
    }

    /// The luminous intensity in cd at vertical angle `gamma_deg` (from the
    /// aim axis) and horizontal angle `c_deg`.
    pub fn candela(&self, gamma_deg: f64, c_deg: f64) -> f64 {
        let v = &self.vertical_deg;
        if gamma_deg < v[0] || gamma_deg > v[v.len() - 1] {
            return 0.0;
        }
        let h = &self.horizontal_deg;
        if h.len() == 1 {
            if let Some(step) = self.vertical_step_deg {
                // The same linear interpolation, with the bin found by division.
                let x = (gamma_deg - v[0]) / step;
                let i = (x as usize).min(v.len() - 2);
                let f = x - i as f64;
                let row = &self.candela_cd[0];
                return row[i] + f * (row[i + 1] - row[i]);
            }
            return interpolate(v, &self.candela_cd[0], gamma_deg);
        }
        // Fold C into the tabulated range by the file's symmetry.
        let mut c = c_deg.rem_euclid(360.0);
        let last = h[h.len() - 1];
        if last == 90.0 {
            c = match c {
                c if c <= 90.0 => c,
                c if c <= 180.0 => 180.0 - c,
                c if c <= 270.0 => c - 180.0,
                c => 360.0 - c,
            };
        } else if last == 180.0 && c > 180.0 {
            c = 360.0 - c;
        }
        let j = h.partition_point(|&x| x <= c).clamp(1, h.len() - 1);
        let t = ((c - h[j - 1]) / (h[j] - h[j - 1])).clamp(0.0, 1.0);
        let a = interpolate(v, &self.candela_cd[j - 1], gamma_deg);
        let b = interpolate(v, &self.candela_cd[j], gamma_deg);
        a + t * (b - a)
    }

    /// The largest tabulated intensity, cd.
    pub fn peak_cd(&self) -> f64 {
        self.candela_cd.iter().flatten().fold(0.0, |m, &v| m.max(v))
    }

    /// True when the table has a single horizontal angle.
    pub fn is_rotationally_symmetric(&self) -> bool {
        self.horizontal_deg.len() == 1
    }
}

/// Linear interpolation of a table at `x` (inside its range).
fn interpolate(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    lightbooth_science::spectrum::interpolate_clamped(xs, ys, x)
}

/// Writes a rotationally symmetric type C LM-63-2002 file from candela
/// values at the given vertical angles (used to ship the booth's MR16 file
/// and by tests).
pub fn write_symmetric_lm63(keywords: &[(&str, &str)], vertical_deg: &[f64], candela_cd: &[f64]) -> String {
    let mut s = String::from("IESNA:LM-63-2002\n");
    for (k, v) in keywords {
        s.push_str(&format!("[{k}] {v}\n"));
    }
    s.push_str("TILT=NONE\n");
    s.push_str(&format!("1 -1 1 {} 1 1 2 0 0 0\n1 1 0\n", vertical_deg.len()));
    let row = |vals: &[f64]| vals.iter().map(|v| format!("{v}")).collect::<Vec<_>>().join(" ") + "\n";
    s.push_str(&row(vertical_deg));
    s.push_str("0\n");
    s.push_str(&row(candela_cd));
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn symmetric() -> IesDistribution {
        let v: Vec<f64> = (0..=45).map(|i| 2.0 * i as f64).collect();
        let cd: Vec<f64> = v.iter().map(|g| 100.0 - g).collect();
        IesDistribution::parse(&write_symmetric_lm63(&[("TEST", "x")], &v, &cd), "t.ies").unwrap()
    }

    #[test]
    fn symmetric_tables_interpolate_linearly_in_gamma() {
        let d = symmetric();
        assert!(d.is_rotationally_symmetric());
        assert!((d.candela(0.0, 0.0) - 100.0).abs() < 1e-12);
        assert!((d.candela(13.0, 77.0) - 87.0).abs() < 1e-12);
        assert_eq!(d.candela(91.0, 0.0), 0.0);
        assert_eq!(d.peak_cd(), 100.0);
    }

    #[test]
    fn full_tables_interpolate_in_c_and_fold_by_symmetry() {
        // Quadrant symmetric: C = 0 → 10 cd, C = 90 → 30 cd at every γ.
        let text = "IESNA:LM-63-2002\nTILT=NONE\n1 -1 2.0 2 2 1 2 0 0 0\n1 1 0\n0 90\n0 90\n5 5\n15 15\n";
        let d = IesDistribution::parse(text, "q.ies").unwrap();
        assert!((d.candela(10.0, 45.0) - 20.0).abs() < 1e-12);
        assert!((d.candela(10.0, 135.0) - 20.0).abs() < 1e-12);
        assert!((d.candela(10.0, 180.0) - 10.0).abs() < 1e-12);
        assert!((d.candela(10.0, 270.0) - 30.0).abs() < 1e-12);
        assert!((d.candela(10.0, 300.0) - (10.0 + 20.0 * 60.0 / 90.0)).abs() < 1e-12);
    }

    #[test]
    fn errors_name_the_file_and_line() {
        let e =
            IesDistribution::parse("IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 2 1 3 2 0 0 0\n1 1 0\n", "b.ies").unwrap_err();
        assert!(e.to_string().starts_with("b.ies:3: photometric type 3"), "{e}");
        let e = IesDistribution::parse(
            "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 2 1 1 2 0 0 0\n1 1 0\n0 x\n",
            "c.ies",
        )
        .unwrap_err();
        assert_eq!(e.to_string(), "c.ies:5: `x` is not a number");
        let e = IesDistribution::parse("IESNA:LM-63-2002\nTILT=INCLUDE\n", "d.ies").unwrap_err();
        assert!(e.to_string().contains("d.ies:2"), "{e}");
    }
}
