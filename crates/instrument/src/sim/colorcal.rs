//! The simulated CRS ColorCAL MkII's firmware, on the shared
//! [`super::unit`] machinery with un-paced (USB) writes: every reply goes
//! out in one write, as psychopy-crs needs (it never matches its eol under
//! Python 3 and reads until its time-out, `psychopy_crs/colorcal.py:317`).
//!
//! Protocol (sources in [`crate::colorcal::protocol`]): commands
//! of three letters ended by LF (PsychoPy) or CR (Psychtoolbox), either case;
//! replies `\n\r` + body + `\n\r>`; `IDR`, `r01`–`r09`, `MES`, `UZC`.
//!
//! What it sees: the target's true XYZ, computed from its spectral radiance
//! with the CIE 1931 2° functions and 683 lm/W (a perfect filter set). It
//! sends raw = M⁻¹ · XYZ, each channel with 0.1 % Gaussian noise (seeded),
//! where M is its stored correction matrix ([`CALIBRATION`]), so a client that
//! applies M gets the true XYZ back within the noise and the `%6.2f`
//! rounding (0.005 per channel).
//!
//! Choices where no public source says (documented in
//! `docs/src/instruments/colorcal.md`):
//! - `MES` takes [`MEASURE_MS`] (500 ms at `--speed 1`);
//! - `UZC` answers `ER11` when the true luminance exceeds
//!   [`ZERO_CALIBRATION_MAX_CD_M2`] (0.05 cd/m²), else `OK00`;
//! - an unknown command (`r99` too) is answered `ER00`;
//! - `r04`–`r09` (the two other stored matrices) repeat `r01`–`r03`;
//! - `IDR` says `OK00,1,101,100.10,<serial>,905` (ROM 101, build 905, so
//!   PsychoPy, comparing builds as strings with `877`, needs no zero
//!   calibration).
//!
//! Faults (`--fault`) apply to the `MES` reply: no-answer, slow, garble,
//! double-crlf, truncate, link-dies ([`Unit::send_spectrum`]), stale (a
//! partial late reply lands after it), cable-pull (during the measurement).
//! `error-code` does not apply: no public source documents a status for a
//! failed `MES`.

use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};

use serialport::TTYPort;

use super::config::MockConfig;
use super::faults::FaultKind;
use super::unit::{Firmware, Next, Shared, Unit};
use crate::colorcal::protocol::{self as wire, Command, Identification, Matrix};
use lightbooth_science::colorimetry::{xyz_from_radiance, Observer};

/// The stored correction matrix (`r01`–`r03`): non-diagonal, as a real
/// unit's, with the first row of Psychtoolbox's example reply
/// `OK00, 8053,52040,50642`; every element fits the Minolta format.
pub const CALIBRATION: Matrix = [
    [0.8053, -0.2040, -0.0642],
    [-0.0410, 0.9870, 0.0375],
    [0.0120, -0.0535, 1.1021],
];

/// How long `MES` takes at speed 1, ms (a choice: no public source says).
pub const MEASURE_MS: f64 = 500.0;

/// `UZC` succeeds only below this true luminance, cd/m² (a choice).
pub const ZERO_CALIBRATION_MAX_CD_M2: f64 = 0.05;

/// Relative noise of one raw channel (SD).
const RAW_NOISE: f64 = 0.001;

/// The longest command line kept; longer input is garbage and dropped.
const MAX_LINE: usize = 64;

pub(super) struct Device {
    unit: Unit,
    line: Vec<u8>,
    identification: Identification,
    inverse: Matrix,
}

impl Device {
    pub(super) fn new(
        cfg: MockConfig,
        port: TTYPort,
        keepalive: TTYPort,
        shared: Arc<Mutex<Shared>>,
        stop: Arc<AtomicBool>,
    ) -> Device {
        let unit = Unit::new(crate::colorcal::MODEL_NAME, &cfg, port, keepalive, shared, stop, false);
        Device {
            unit,
            line: Vec::new(),
            identification: Identification {
                rom: "101".into(),
                serial: cfg.serial.clone(),
                build: "905".into(),
            },
            inverse: wire::inverse(&CALIBRATION).expect("the simulated calibration matrix is invertible"),
        }
    }

    /// The target's true XYZ, CIE 1931 2°, cd/m² scale.
    fn true_xyz(&self) -> [f64; 3] {
        let truth = self.unit.shared().truth_1nm.clone();
        match xyz_from_radiance(&truth, Observer::Cie1931) {
            Ok(xyz) => xyz.to_array(),
            Err(e) => {
                tracing::warn!(error = %e, "simulated ColorCAL: the target has no XYZ; reading zeros");
                [0.0; 3]
            }
        }
    }

    fn reply(&mut self, body: &str) {
        let bytes = wire::frame_reply(body);
        self.unit.write(&bytes);
    }

    fn command(&mut self, line: &[u8]) -> Next {
        if self.unit.shared().link_dead {
            return Next::Continue;
        }
        let Some(command) = Command::parse(line) else {
            tracing::debug!(line = %String::from_utf8_lossy(line).escape_debug(), "simulated ColorCAL: unknown command");
            self.reply("ER00");
            return Next::Continue;
        };
        match command {
            Command::Identify => {
                let body = wire::format_identification(&self.identification);
                self.reply(&body);
            }
            Command::MatrixRow(n) => {
                let row = CALIBRATION[usize::from((n - 1) % 3)];
                let body = wire::format_matrix_row(row).unwrap_or_else(|| "ER00".into());
                self.reply(&body);
            }
            Command::ZeroCalibrate => {
                let y = self.true_xyz()[1];
                self.reply(if y > ZERO_CALIBRATION_MAX_CD_M2 { "ER11" } else { "OK00" });
            }
            Command::Measure => return self.measure(),
        }
        Next::Continue
    }

    fn measure(&mut self) -> Next {
        if self.unit.cable_pulled_during(MEASURE_MS, "cable pulled during MES") {
            return Next::Unplugged;
        }
        self.unit.sleep_scaled(MEASURE_MS);
        let xyz = self.true_xyz();
        let raw = wire::apply(&self.inverse, xyz).map(|v| v * (1.0 + RAW_NOISE * self.unit.rng.gaussian()));
        self.unit.shared().measurements += 1;
        let body = wire::format_raw_measurement(raw);
        tracing::debug!(?xyz, body, "simulated ColorCAL: MES");
        // Garble only the numbers: after `\n\rOK00,`.
        self.unit.send_spectrum(wire::frame_reply(&body), 7);
        if self.unit.fires(FaultKind::Stale) {
            self.unit.write(b"\n\rOK00,12");
        }
        Next::AfterMeasurement
    }
}

impl Firmware for Device {
    fn unit(&mut self) -> &mut Unit {
        &mut self.unit
    }

    fn power_on(&mut self) {
        self.line.clear();
    }

    fn byte(&mut self, b: u8, _burst: bool) -> Next {
        if b == b'\r' || b == b'\n' {
            let line = std::mem::take(&mut self.line);
            if line.trim_ascii().is_empty() {
                return Next::Continue;
            }
            return self.command(&line);
        }
        if self.line.len() < MAX_LINE {
            self.line.push(b);
        }
        Next::Continue
    }

    fn forget_line(&mut self) {
        self.line.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_calibration_matrix_is_sent_exactly() {
        for row in CALIBRATION {
            let body = wire::format_matrix_row(row).unwrap();
            let back = wire::parse_matrix_row(&wire::frame_reply(&body)).unwrap().unwrap();
            assert_eq!(back, row);
        }
    }
}
