//! The simulated PR-650's firmware: the byte-level state machine on the
//! master end of the pty, after the checklist of
//! `docs/src/instruments/pr650-protocol.md` §7. The simulator thread
//! ([`super::unit::run`]) feeds it the bytes the host sends; it assembles
//! commands and answers as the instrument would, a line at a time at 9600
//! baud.
//!
//! - A command must come within the power-on window, else the unit stays in
//!   local mode and ignores the port until power-cycled.
//! - Commands end in CR, LF or CR LF and are case-insensitive: `B`, `S`
//!   (each field checked, its status sent), `M` (measure, then ack or send a
//!   report), `D`/`R` (reports 1, 2, 5, 110, 120, 201), `F`, `E` (echo).
//! - A failed measurement leaves the spectral buffer stale: `D5` resends the
//!   last spectrum under the new code.

use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use serialport::TTYPort;

use super::config::{BeforeFirstMeasurement, MockConfig};
use super::faults::FaultKind;
use super::unit::{Firmware, Next, Shared, Unit};
use crate::pr650::protocol as wire;
use lightbooth_science::colorimetry::{xyz_from_radiance, Observer};
use lightbooth_science::spectrum::{SpectralUnit, Spectrum};

/// The data of the last measurement, as `D` reports resend it.
#[derive(Clone, Debug)]
struct Stored {
    code: u8,
    values: Vec<f64>,
    integral: f64,
    xyz: [f64; 3],
}

/// The `S` settings the unit keeps (power-on: adaptive, no sync, status 00).
#[derive(Clone, Copy, Debug, Default)]
struct Settings {
    integration_ms: u32,
    sync_on: bool,
    last_status: u8,
}

pub(super) struct Device {
    cfg: MockConfig,
    unit: Unit,
    powered_at: Instant,
    last_was_cr: bool,
    /// What a power cycle resets.
    state: PowerOnState,
}

/// The firmware's state from power-on: a power cycle sets it back to
/// [`Default`], so power-on and a new unit cannot disagree.
#[derive(Default)]
struct PowerOnState {
    remote: bool,
    local: bool,
    echo: bool,
    line: Vec<u8>,
    settings: Settings,
    stored: Option<Stored>,
}

impl Device {
    pub(super) fn new(
        cfg: MockConfig,
        port: TTYPort,
        keepalive: TTYPort,
        shared: Arc<Mutex<Shared>>,
        stop: Arc<AtomicBool>,
    ) -> Device {
        let paced = cfg.pace_output;
        let unit = Unit::new("PR-650", &cfg, port, keepalive, shared, stop, paced);
        Device {
            cfg,
            unit,
            powered_at: Instant::now(),
            last_was_cr: false,
            state: PowerOnState::default(),
        }
    }

    /// One byte from the host.
    fn receive(&mut self, b: u8) -> Next {
        if !self.state.remote && !self.state.local {
            if let Some(window) = self.cfg.remote_window_ms {
                if self.powered_at.elapsed() > Duration::from_millis(window) {
                    tracing::info!("simulated PR-650: no command within the power-on window; local mode");
                    self.state.local = true;
                }
            }
        }
        if self.state.local || self.unit.shared().link_dead {
            return Next::Continue; // ignores the port until power-cycled
        }
        if self.state.echo {
            self.unit.write(&[b]);
        }
        if b == b'\r' || b == b'\n' {
            let pair = b == b'\n' && self.last_was_cr;
            self.last_was_cr = b == b'\r';
            if pair || self.state.line.iter().all(u8::is_ascii_whitespace) {
                self.state.line.clear();
                return Next::Continue;
            }
            let command = std::mem::take(&mut self.state.line).to_ascii_uppercase();
            self.state.remote = true;
            let next = self.command(String::from_utf8_lossy(&command).trim());
            if self.state.echo {
                self.unit.write(b">");
            }
            return next;
        }
        self.last_was_cr = false;
        if self.state.line.len() < 256 {
            self.state.line.push(b);
        }
        Next::Continue
    }

    fn command(&mut self, text: &str) -> Next {
        tracing::debug!(command = text, "simulated PR-650 received");
        let (letter, args) = text.split_at(text.chars().next().map_or(0, char::len_utf8));
        match letter {
            "B" if matches!(args, "" | "0" | "1" | "2" | "3") => self.unit.write(b"000\r\n"),
            "S" => {
                let status = setup_status(args);
                if status == 0 {
                    let fields: Vec<&str> = args.split(',').collect();
                    self.state.settings.sync_on = !fields.get(4).unwrap_or(&"").is_empty();
                    self.state.settings.integration_ms = fields.get(5).and_then(|f| f.parse().ok()).unwrap_or(0);
                    self.unit.shared().integration_ms = self.state.settings.integration_ms;
                }
                self.state.settings.last_status = status;
                self.unit.write(format!("{status:02}\r\n").as_bytes());
            }
            "M" => {
                let code: u16 = if args.is_empty() {
                    1
                } else {
                    args.parse().unwrap_or(u16::MAX)
                };
                if !matches!(code, 0 | 1 | 2 | 5) {
                    return Next::Continue;
                }
                if !self.measure() {
                    return Next::Unplugged;
                }
                if code == 0 {
                    self.unit.write(b"000\r\n");
                } else {
                    self.report(code);
                }
                return Next::AfterMeasurement;
            }
            "D" | "R" => {
                // `R<n>,<code>` recalls; this unit stores only the last measurement.
                let code = args.rsplit(',').next().unwrap_or("").parse::<u16>().unwrap_or(u16::MAX);
                self.report(code);
            }
            // An "unsyncable" source still shows a frequency; measuring with sync then fails (07).
            "F" => match self.cfg.flicker_hz {
                Some(hz) => self.unit.write(format!("00,{hz:.2}\r\n").as_bytes()),
                None => self.unit.write(b"20\r\n"),
            },
            "E" => {
                tracing::warn!("simulated PR-650: echo mode on (a driver should never send E)");
                self.state.echo = true;
            }
            _ => tracing::debug!(command = text, "simulated PR-650: unknown command ignored"),
        }
        Next::Continue
    }

    /// One measurement. Returns false if the cable was pulled.
    fn measure(&mut self) -> bool {
        let truth = self.unit.shared().truth_1nm.clone();
        let reading = match self.cfg.model.reading(&truth, self.state.settings.integration_ms) {
            Ok(r) => r,
            Err(e) => {
                tracing::error!(error = %e, "simulated PR-650: cannot model the target");
                return true;
            }
        };
        tracing::debug!(
            integration_ms = reading.integration_ms,
            code = reading.code,
            "simulated PR-650 measuring"
        );
        if self.unit.cable_pulled_during(reading.duration_ms, "cable pulled") {
            return false;
        }
        self.unit.sleep_scaled(reading.duration_ms);
        let mut code = reading.code;
        if self.state.settings.sync_on && self.cfg.unsyncable {
            code = 7;
        }
        if self.unit.fires(FaultKind::ErrorCode) {
            code = self.cfg.error_code;
        }
        if code == 0 {
            let values = self.cfg.model.sample(&reading, &mut self.unit.rng);
            let spectrum = Spectrum::new(
                self.cfg.model.grid.clone(),
                SpectralUnit::SpectralRadiance,
                values.clone(),
            );
            let (integral, xyz) = match spectrum {
                Ok(s) => {
                    let xyz = xyz_from_radiance(&s, Observer::Cie1931)
                        .map(|x| x.to_array())
                        .unwrap_or([0.0; 3]);
                    (s.integral().unwrap_or(0.0), xyz)
                }
                Err(_) => (0.0, [0.0; 3]),
            };
            self.state.stored = Some(Stored {
                code,
                values,
                integral,
                xyz,
            });
        } else {
            // §3: on a failed measurement the spectral buffer is not updated;
            // D5 resends the previous spectrum under the new code, Y is 0.
            let mut stored = self
                .state
                .stored
                .take()
                .unwrap_or_else(|| zeros(self.cfg.model.grid.len()));
            stored.code = code;
            stored.xyz = [0.0; 3];
            self.state.stored = Some(stored);
        }
        self.unit.shared().measurements += 1;
        true
    }

    fn report(&mut self, code: u16) {
        let grid = self.cfg.model.grid.clone();
        match code {
            wire::REPORT_SERIAL => {
                let serial = format!("{:<8}", self.cfg.serial);
                self.unit.write(format!("{serial}\r\n").as_bytes());
                return;
            }
            wire::REPORT_CONFIG => {
                let bytes = wire::format_spectral_config(&grid, self.cfg.model.slit_fwhm_nm);
                self.unit.write(&bytes);
                return;
            }
            wire::REPORT_SETUP_STATUS => {
                let status = self.state.settings.last_status;
                self.unit.write(format!("{status:02}\r\n").as_bytes());
                return;
            }
            _ => {}
        }
        let stored = match (&self.state.stored, self.cfg.before_first) {
            (Some(s), _) => s.clone(),
            (None, BeforeFirstMeasurement::StaleZeros) => zeros(grid.len()),
            (None, BeforeFirstMeasurement::NoReply) => return,
        };
        let [x, y, z] = stored.xyz;
        match code {
            wire::REPORT_YXY => {
                let sum = x + y + z;
                let (cx, cy) = if sum > 0.0 { (x / sum, y / sum) } else { (0.0, 0.0) };
                self.unit.write(&wire::format_yxy_report(stored.code, 0, y, cx, cy));
            }
            wire::REPORT_XYZ => {
                self.unit.write(&wire::format_xyz_report(stored.code, 0, x, y, z));
                if self.unit.fires(FaultKind::Stale) {
                    // Lands in the host's buffer before its next command.
                    self.unit.write(b"00,0\r\n2.817E-01\r\n0380.,1.2");
                }
            }
            wire::REPORT_SPECTRUM => {
                let bytes = wire::format_spectral_report(
                    stored.code,
                    0,
                    stored.integral,
                    &grid,
                    &stored.values,
                    self.cfg.header_bare_cr,
                );
                // Past the header (`00,0\r\n2.817E-01\r\n`): noise in the data lines.
                self.unit.send_spectrum(bytes, 17);
            }
            _ => tracing::debug!(code, "simulated PR-650: report code not simulated; no reply"),
        }
    }
}

impl Firmware for Device {
    fn power_on(&mut self) {
        self.powered_at = Instant::now();
        self.state = PowerOnState::default();
    }

    /// A dead link is checked byte by byte (after the power-on window's clock).
    fn byte(&mut self, b: u8, _burst: bool) -> Next {
        self.receive(b)
    }

    fn forget_line(&mut self) {
        self.state.line.clear();
    }

    fn unit(&mut self) -> &mut Unit {
        &mut self.unit
    }
}

fn zeros(len: usize) -> Stored {
    Stored {
        code: 0,
        values: vec![0.0; len],
        integral: 0.0,
        xyz: [0.0; 3],
    }
}

/// The status of an `S` command's fields (§2): 0 OK, 1–8 the first bad field,
/// 50 a bad primary accessory. Empty fields mean "unchanged" and are fine.
fn setup_status(args: &str) -> u8 {
    let fields: Vec<&str> = args.split(',').collect();
    if fields.len() > 8 {
        return 8;
    }
    let num = |s: &str| -> Option<u32> { s.trim().parse().ok() };
    let field = |i: usize| fields.get(i).map(|s| s.trim()).unwrap_or("");
    let in_range = |i: usize, ok: &dyn Fn(u32) -> bool| -> bool {
        let f = field(i);
        f.is_empty() || num(f).is_some_and(ok)
    };
    if !field(0).is_empty() && !in_range(0, &|v| (1..=12).contains(&v)) {
        return 50;
    }
    for i in 1..=3 {
        if !in_range(i, &|v| (2..=12).contains(&v)) {
            return (i + 1) as u8;
        }
    }
    if !in_range(4, &|v| v == 1 || (40..=250).contains(&v)) {
        return 5;
    }
    if !in_range(5, &|v| v == 0 || (10..=6000).contains(&v)) {
        return 6;
    }
    if !in_range(6, &|v| (1..=99).contains(&v)) {
        return 7;
    }
    if !in_range(7, &|v| v <= 1) {
        return 8;
    }
    0
}

#[cfg(test)]
mod tests {
    use super::setup_status;

    #[test]
    fn setup_fields_are_checked_as_documented() {
        for ok in [
            "01,,,,,,01,1",
            "01,,,,1,0,01,1",
            ",,,,,0,1,1",
            "1,,,,,0,,1",
            "1,,,,,250,,1",
        ] {
            assert_eq!(setup_status(ok), 0, "{ok}");
        }
        assert_eq!(setup_status("01,,,,,5,01,1"), 6);
        assert_eq!(setup_status("01,,,,,0,00,1"), 7);
        assert_eq!(setup_status("01,,,,,0,01,2"), 8);
        assert_eq!(setup_status("01,,,,30,0,01,1"), 5);
        assert_eq!(setup_status("13,,,,,0,01,1"), 50);
    }
}
