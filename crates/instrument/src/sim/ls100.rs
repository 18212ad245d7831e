//! The simulated Konica Minolta LS-100 / CS-100A firmware (in communication
//! mode, as after switching on with F held), on the shared
//! [`super::unit`] machinery. Its writes are not paced by the unit (whose
//! pacing is the PR-650's 9600 baud): each reply waits its own wire time at
//! 4800 baud, 11 bits a character (7E2), scaled by `--speed`, then goes out
//! whole.
//!
//! Protocol (sources in [`crate::ls100::protocol`]): commands
//! ended by CR LF (a lone CR or LF is accepted); `MDS,nn` → `OK00`, `MES` →
//! `OK00, L` (LS-100) or `OK00, L, x, y` (CS-100A, 28 bytes with CR LF),
//! `CLE` → `OK00`; `ER00` to an unknown command, `ER01` to a bad `MDS`.
//!
//! The line: a pseudo-terminal carries neither 7 data bits nor parity, so
//! the simulator checks only what it can, the host's 4800 baud and 2 stop
//! bits; a host set otherwise gets no reply (a real meter would see framing
//! errors), and the simulator logs why.
//!
//! What it sees: the target's true luminance and chromaticity (CIE 1931 2°,
//! 683 lm/W, from its spectral radiance), with 0.1 % Gaussian noise on the
//! luminance and 0.0003 on x and y (seeded). Choices where no public source
//! says (documented in `docs/src/instruments/ls100.md`):
//! - `MES` takes [`MEASURE_MS`] (800 ms at `--speed 1`);
//! - the luminance field is six characters with five significant digits,
//!   x and y four decimals without the leading zero (`.3920`);
//! - `ER10` (measuring range over) above [`MAX_LUMINANCE`] cd/m², the most
//!   the six-character field holds;
//! - `MDS` accepts 00, 01 and 04–09 (the codes the public sources name).
//!
//! Faults (`--fault`) apply to the `MES` reply: no-answer, slow, garble,
//! double-crlf, truncate, link-dies, stale, cable-pull, and `error-code`
//! (`ER` + the configured code, default `ER10`).

use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};

use serialport::{StopBits, TTYPort};

use super::config::MockConfig;
use super::faults::FaultKind;
use super::unit::{Firmware, Next, Shared, Unit};
use crate::ls100::protocol::{self as wire, Command, Received, KNOWN_MODES, MAX_LUMINANCE};
use crate::ls100::Model;
use crate::status_word::StatusWord;
use lightbooth_science::colorimetry::{xyz_from_radiance, Observer};

/// How long `MES` takes at speed 1, ms (a choice: no public source says).
pub const MEASURE_MS: f64 = 800.0;

/// One character at 4800 baud, 7E2 (11 bits on the wire), ms.
const CHAR_MS: f64 = 11.0 / 4.8;

/// The baud rate the meter talks at.
const BAUD: u32 = 4800;

/// The longest command line kept; longer input is garbage and dropped.
const MAX_LINE: usize = 64;

pub(super) struct Device {
    unit: Unit,
    model: Model,
    line: Vec<u8>,
    /// `ERnn` of an `error-code` fault.
    error_code: u8,
    /// Whether the last host line setting was already reported as wrong.
    warned_line: bool,
}

impl Device {
    pub(super) fn new(
        cfg: MockConfig,
        model: Model,
        port: TTYPort,
        keepalive: TTYPort,
        shared: Arc<Mutex<Shared>>,
        stop: Arc<AtomicBool>,
    ) -> Device {
        let unit = Unit::new(model.name(), &cfg, port, keepalive, shared, stop, false);
        Device {
            unit,
            model,
            line: Vec::new(),
            error_code: cfg.error_code,
            warned_line: false,
        }
    }

    /// Whether the host set 4800 baud and 2 stop bits (all a pty can show).
    fn host_line_matches(&mut self) -> bool {
        match self.unit.host_line() {
            Some((BAUD, StopBits::Two)) | None => true,
            Some((baud, stop)) => {
                if !self.warned_line {
                    tracing::warn!(
                        baud,
                        ?stop,
                        "simulated {}: the host is not at 4800 baud with 2 stop bits; \
                        a real meter would see framing errors, so no reply",
                        self.model.name()
                    );
                    self.warned_line = true;
                }
                false
            }
        }
    }

    /// A line at 4800 baud: its wire time passes, then it goes out whole.
    fn reply(&mut self, line: &str) {
        let bytes = format!("{line}\r\n").into_bytes();
        self.unit.sleep_scaled(bytes.len() as f64 * CHAR_MS);
        self.unit.write(&bytes);
    }

    fn command(&mut self, line: &[u8]) -> Next {
        if self.unit.shared().link_dead || !self.host_line_matches() {
            return Next::Continue;
        }
        match wire::parse_command(line) {
            Received::Command(Command::SetMode(mode)) if KNOWN_MODES.contains(&mode) => self.reply("OK00"),
            Received::Command(Command::SetMode(_)) | Received::BadSetting => self.reply("ER01"),
            Received::Command(Command::ClearMemory) => self.reply("OK00"),
            Received::Command(Command::Measure) => return self.measure(),
            Received::Unknown => {
                tracing::debug!(line = %String::from_utf8_lossy(line).escape_debug(),
                    "simulated {}: unknown command", self.model.name());
                self.reply("ER00");
            }
        }
        Next::Continue
    }

    /// The target's true luminance and chromaticity.
    fn truth(&self) -> (f64, (f64, f64)) {
        let truth = self.unit.shared().truth_1nm.clone();
        match xyz_from_radiance(&truth, Observer::Cie1931) {
            Ok(xyz) => {
                let c = xyz.chromaticity();
                (xyz.y, (c.x, c.y))
            }
            Err(e) => {
                tracing::warn!(error = %e, "simulated meter: the target has no XYZ; reading zero");
                (0.0, (0.0, 0.0))
            }
        }
    }

    fn measure(&mut self) -> Next {
        if self.unit.cable_pulled_during(MEASURE_MS, "cable pulled during MES") {
            return Next::Unplugged;
        }
        self.unit.sleep_scaled(MEASURE_MS);
        self.unit.shared().measurements += 1;
        let line = if self.unit.fires(FaultKind::ErrorCode) {
            StatusWord::Er(self.error_code).to_string()
        } else {
            let (y, (cx, cy)) = self.truth();
            let rng = &mut self.unit.rng;
            let y = (y * (1.0 + 0.001 * rng.gaussian())).max(0.0);
            let xy = (cx + 0.0003 * rng.gaussian(), cy + 0.0003 * rng.gaussian());
            match wire::format_luminance(y).filter(|_| y <= MAX_LUMINANCE) {
                Some(l) => {
                    wire::format_measurement(StatusWord::SUCCESS, &l, (self.model == Model::Cs100a).then_some(xy))
                }
                None => "ER10".into(),
            }
        };
        tracing::debug!(line, "simulated {}: MES", self.model.name());
        let bytes = format!("{line}\r\n").into_bytes();
        self.unit.sleep_scaled(bytes.len() as f64 * CHAR_MS);
        // Garble only the values: after `OK00,`.
        self.unit.send_spectrum(bytes, 5);
        if self.unit.fires(FaultKind::Stale) {
            self.unit.write(b"OK00, 9");
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
