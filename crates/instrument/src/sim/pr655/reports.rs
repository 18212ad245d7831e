//! The simulated PR-655/PR-670's reports (section 6 of
//! `docs/src/instruments/pr655-670-protocol.md`): every one computed from
//! the one stored measurement and the setup, so the views agree, and what
//! `D⟨code⟩` answers after a failed measurement (13.9).

use super::switches::AfterFailure;
use super::{Device, Stored};
use crate::pr655::protocol as wire;
use crate::pr655::Model;
use crate::sim::faults::FaultKind;
use lightbooth_science::spectrum::{SpectralUnit, Spectrum};

/// The colorimetric views of one XYZ that reports 1, 3, 4, 6, 7 and 12
/// send: CIE 1931 x, y; CIE 1976 u′, v′; CIE 1960 v = ⅔·v′ (u = u′); the
/// correlated colour temperature by McCamy's (1992) cubic in x, y, and its
/// Duv from the Planckian locus in CIE 1960 uv by Krystek's (1985) rational
/// approximation. Both are approximations (McCamy is within a few K from
/// 2856 to 6500 K); a simulator's choice, the instrument's own is unknown.
struct Views {
    x: f64,
    y: f64,
    u_prime: f64,
    v_prime: f64,
    v_1960: f64,
    cct_k: f64,
    duv: f64,
}

impl Views {
    fn of([x, y, z]: [f64; 3]) -> Views {
        let sum = x + y + z;
        let (cx, cy) = if sum > 0.0 { (x / sum, y / sum) } else { (0.0, 0.0) };
        let d = -2.0 * cx + 12.0 * cy + 3.0;
        let (u_prime, v_prime) = if d != 0.0 {
            (4.0 * cx / d, 9.0 * cy / d)
        } else {
            (0.0, 0.0)
        };
        let n = (cx - 0.3320) / (0.1858 - cy);
        let cct_k = 449.0 * n.powi(3) + 3525.0 * n * n + 6823.3 * n + 5520.33;
        let t = cct_k;
        let u_locus = (0.860_117_757 + 1.541_182_54e-4 * t + 1.286_412_12e-7 * t * t)
            / (1.0 + 8.424_202_35e-4 * t + 7.081_451_63e-7 * t * t);
        let v_locus = (0.317_398_726 + 4.228_062_45e-5 * t + 4.204_816_91e-8 * t * t)
            / (1.0 - 2.897_418_16e-5 * t + 1.614_560_53e-7 * t * t);
        let v_1960 = 2.0 / 3.0 * v_prime;
        let duv = ((u_prime - u_locus).powi(2) + (v_1960 - v_locus).powi(2)).sqrt() * (v_1960 - v_locus).signum();
        Views {
            x: cx,
            y: cy,
            u_prime,
            v_prime,
            v_1960,
            cct_k,
            duv,
        }
    }
}

/// K′m, the maximum luminous efficacy for scotopic vision, lm/W: 1700 as in
/// CIE 1951 (1700.06 under the 1979 candela definition, 0.004 % apart).
const SCOTOPIC_KM_LM_PER_W: f64 = 1700.0;

/// The CIE 1951 scotopic luminous efficiency V′(λ) at each of `grid`'s
/// wavelengths (the embedded 1 nm table's own rows on the 2 and 4 nm grids),
/// 0 outside 380–780 nm.
fn scotopic_efficiency(grid: &lightbooth_science::spectrum::Grid) -> Vec<f64> {
    static TABLE: std::sync::OnceLock<Spectrum> = std::sync::OnceLock::new();
    let v_prime = TABLE.get_or_init(|| {
        lightbooth_science::spectrum::table::SpectraTable::parse(
            include_str!("cie1951_scotopic_1nm.csv"),
            "cie1951_scotopic_1nm.csv",
        )
        .and_then(|t| t.spectrum("v_prime", SpectralUnit::RelativePower))
        .unwrap_or_else(|e| panic!("embedded data is corrupt: {e}"))
    });
    grid.wavelengths()
        .iter()
        .map(|nm| v_prime.value_at(*nm).unwrap_or(0.0))
        .collect()
}

/// Scotopic luminance, cd/m² (scotopic): K′m · Σ V′(λ) L(λ) Δλ over the
/// reported per-nm radiance, the sum-times-step rule the sheet gives for the
/// instrument's integrated values (8.1).
fn scotopic_luminance(grid: &lightbooth_science::spectrum::Grid, radiance: &[f64]) -> f64 {
    let step = grid.step_nm().unwrap_or(1.0);
    let weighted: f64 = scotopic_efficiency(grid).iter().zip(radiance).map(|(v, l)| v * l).sum();
    SCOTOPIC_KM_LM_PER_W * weighted * step
}

impl Device {
    /// The measurement report `code` describes: per 13.9 after a failure.
    fn report_source(&self) -> Result<Stored, i32> {
        match (&self.state.last, self.sw.after_failure) {
            (None, _) => Err(-2000),
            (Some(s), _) if s.status == 0 => Ok(s.clone()),
            (Some(s), AfterFailure::Error) => Err(s.status),
            (Some(_), AfterFailure::NoData) => Err(-2000),
            (Some(s), AfterFailure::Stale) => self.state.last_good.clone().ok_or(s.status),
        }
    }

    /// Report `code`; `fresh` when it follows this very measurement (`M`),
    /// whose failure is then always its own status.
    pub(super) fn report(&mut self, code: u16, fresh: bool) {
        let style = self.sw.status_style;
        let model = self.sw.model;
        match code {
            wire::REPORT_SERIAL => {
                return self
                    .unit
                    .write(&wire::format_text_report(&self.cfg.serial.clone(), style))
            }
            wire::REPORT_MODEL => return self.unit.write(&wire::format_text_report(model.name(), style)),
            wire::REPORT_FIRMWARE => {
                return self
                    .unit
                    .write(&wire::format_text_report(&self.sw.firmware.clone(), style))
            }
            wire::REPORT_HARDWARE => return self.unit.write(&wire::format_hardware_config(model, style)),
            wire::REPORT_SETUP_TEXT => {
                let s = self.state.setup;
                let text = format!(
                    "MS-75,None,None,None,1 deg,{},{},{} msec,Normal,{} cycles,{} deg,No Smart Dark,{},Standard Sensitivity,60.00 Hertz",
                    if s.si_units { "SI" } else { "English" },
                    if s.exposure_ms == 0 { "Adaptive" } else { "Fixed" },
                    s.exposure_ms,
                    s.cycles,
                    s.observer,
                    match s.sync {
                        1 => "Auto Sync",
                        3 => "User Sync",
                        _ => "No Sync",
                    }
                );
                return self.unit.write(&wire::format_text_report(&text, style));
            }
            // 601: the setup as codes. The PR-670 gets the 16 fields the
            // manual describes, the PR-655 the 13 captured from a real one (6.1).
            601 => {
                let s = self.state.setup;
                let text = match model {
                    Model::Pr670 => format!(
                        "0,-1,-1,-1,0,{},{},{},0,{},{},0,{},0,60.00",
                        u8::from(s.si_units),
                        u8::from(s.exposure_ms != 0),
                        s.exposure_ms,
                        s.cycles,
                        s.observer,
                        s.sync
                    ),
                    Model::Pr655 => format!(
                        "0,-1,-1,-1,0,{},0,{},1,{},{},0.00",
                        u8::from(s.si_units),
                        s.exposure_ms,
                        s.cycles,
                        s.observer
                    ),
                };
                return self.unit.write(&wire::format_text_report(&text, style));
            }
            14 => {
                let text = match (self.state.setup.sync, self.cfg.flicker_hz) {
                    (1, Some(hz)) => format!("Auto Sync,{hz:.2} Hertz"),
                    (3, _) => format!("User Sync,{}.00 Hertz", self.state.setup.user_sync_hz),
                    _ => "None,0.00 Hertz".to_string(),
                };
                return self.unit.write(&wire::format_text_report(&text, style));
            }
            116 => {
                return self
                    .unit
                    .write(&wire::format_text_report("0,MS-75,Primary,Luminance,Radiance", style))
            }
            // One line per aperture: the PR-670's four, the PR-655's one (6, report 117).
            117 => {
                let names: &[&str] = match model {
                    Model::Pr670 => &["1 deg", "1/2 deg", "1/4 deg", "1/8 deg"],
                    Model::Pr655 => &["1 deg"],
                };
                let status = wire::format_status(0, style);
                let reply: String = names
                    .iter()
                    .enumerate()
                    .map(|(i, n)| format!("{status},{i},{n},0.00\r\n"))
                    .collect();
                return self.unit.write(reply.as_bytes());
            }
            _ => {}
        }
        let source = if fresh {
            match &self.state.last {
                Some(s) if s.status != 0 => Err(s.status),
                Some(s) => Ok(s.clone()),
                None => Err(-2000),
            }
        } else {
            self.report_source()
        };
        let stored = match source {
            Ok(s) => s,
            Err(status) => return self.status_reply(status),
        };
        // Y in cd/m² after SU1, in fL after SU0 (1 fL = 3.426 cd/m²).
        let scale = if self.state.setup.si_units {
            1.0
        } else {
            1.0 / 3.426_259
        };
        let [x, y, z] = stored.xyz.map(|v| v * scale);
        let status = wire::format_status(0, style);
        match code {
            // Codes 1, 3, 4, 6, 7, 12: views of the one measurement (6, consistency relations).
            1 | 3 | 4 | 6 | 7 | 12 => {
                let v = Views::of([x, y, z]);
                let lum = wire::format_float(y, 2);
                let fields = match code {
                    1 => format!("{:.4},{:.4}", v.x, v.y),
                    3 => format!("{:.4},{:.4}", v.u_prime, v.v_prime),
                    4 => format!("{:.0},{:.4}", v.cct_k, v.duv),
                    6 => format!("{:.4},{:.4},{:.4},{:.4}", v.x, v.y, v.u_prime, v.v_prime),
                    7 => format!("{:.4},{:.4}", v.u_prime, v.v_1960),
                    _ => format!("{:.4},{:.4},{:.4},{:.4}", v.x, v.y, v.u_prime, v.v_1960),
                };
                self.unit.write(format!("{status},0,{lum},{fields}\r\n").as_bytes());
            }
            // 11: scotopic luminance, in the same unit system as Y (8.2).
            11 => {
                let scotopic = scotopic_luminance(&model.grid(), &stored.values) * scale;
                let reply = format!("{status},0,{}\r\n", wire::format_float(scotopic, 2));
                self.unit.write(reply.as_bytes());
            }
            wire::REPORT_XYZ => {
                self.unit.write(&wire::format_xyz_report([x, y, z], style));
                if self.unit.fires(FaultKind::Stale) {
                    // Lands in the host's buffer before its next command.
                    self.unit.write(b"00000,0,5.440e+002,1.8");
                }
            }
            13 => {
                let reply = format!("{status},Normal,{:.0} msec\r\n", stored.exposure_ms);
                self.unit.write(reply.as_bytes());
            }
            wire::REPORT_SPECTRUM => {
                let grid = model.grid();
                let bytes = wire::format_spectral_report(&grid, &stored.values, style, self.sw.line_style);
                // Past the header: noise in the data lines.
                let start = bytes.iter().position(|b| *b == b'\n').map_or(0, |i| i + 1);
                self.unit.send_spectrum(bytes, start);
            }
            _ => self.status_reply(-2000),
        }
    }
}
