//! The simulated Konica Minolta CS-2000/CS-2000A/CS-3000's firmware: the
//! line protocol of `docs/src/instruments/cs2000.md` on the master end of
//! the pty, spoken as colour-specio 0.4.1's `CS2000` class uses it.
//!
//! - Commands end in LF (a CR before it is ignored); replies are one line
//!   ending in LF only (specio cuts one byte off each line), in one burst at
//!   USB speed. An unknown command is `ER00`.
//! - Before `RMTS,1` only `RMTS` and `IDDR` are answered; everything else is
//!   `ER00` (what a real unit does before remote mode is not public: a choice).
//! - `IDDR` → `OK00,CS-2000,<variation>,<serial>` (variation 1 CS-2000,
//!   2 CS-2000A; the CS-3000 answers `CS-3000,3`, a choice: its code is not public).
//! - `MEAS,1` → `OK00,<s>` at once, `s` the whole seconds the measurement
//!   will take at the simulator's speed, rounded up (an estimate that is
//!   never short, so a client that sleeps it, as specio does, finds the data
//!   ready); then, while it runs, `MEDR,0,0,1` is `ER02`; when it ends, a
//!   second line `OK00`, or the measurement's error (`ER10` over range, or
//!   the `error-code` fault's code), which `MEDR,0,0,1` then repeats.
//!   `MEAS,0` aborts (`OK00`). With [`MockConfig::short_estimate`] it
//!   announces 0 s and sends no end line: a client must poll.
//! - `MEDR,0,0,1` → `OK00,<speed mode>,<ND mode>,<integration µs>,<sync mode>`
//!   (specio reads field 2; the others are a choice). `MEDR,1,<1|0>,<1–4>`:
//!   the spectral blocks (100, 100, 100, 101 values; 1 = hex singles, 0 =
//!   decimal), through the injected faults. `MEDR,2,0,…` → `OK00,Le,Lv,X,Y,Z,x,y`
//!   of the same noisy spectrum (CIE 1931 2°, 683 lm/W). Before any
//!   measurement `MEDR` is `ER02` (a choice).
//! - `SPMR`/`SCMR` read the speed and sync modes, `SPMS`/`SCMS` write them
//!   "to flash": they survive a power cycle, and each write is counted
//!   ([`super::MockHandle::flash_writes`]) so a test can show the driver
//!   never writes them.
//! - The optics ([`super::model::InstrumentModel::for_cs2000`]): 1 nm
//!   sampling, a 5 nm slit, the detector of the shared model, 10× as
//!   sensitive as the PR-650's; a measurement takes 1.5 s plus twice the
//!   integration time (light and dark), which puts its span near the 2 s to
//!   about 4 min of normal mode that Konica Minolta's catalogue gives.

use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use serialport::TTYPort;

use super::config::MockConfig;
use super::faults::FaultKind;
use super::unit::{Firmware, Next, Shared, Unit};
use crate::cs2000::protocol::{encode_hex_f32, BLOCK_LENGTHS};
use crate::cs2000::Model;
use lightbooth_science::colorimetry::{xyz_from_radiance, Observer};
use lightbooth_science::spectrum::{SpectralUnit, Spectrum};

/// A measurement that has ended: its code and, when good, its data.
#[derive(Clone, Debug)]
struct Stored {
    /// 0 for `OK00`, else the `ERnn` number.
    code: u8,
    values: Vec<f64>,
    integration_us: f64,
}

/// A measurement in progress.
#[derive(Clone, Debug)]
struct Running {
    ends_at: Instant,
    result: Stored,
    /// A cable-pull fault: the unit vanishes at this moment.
    pulled_at: Option<Instant>,
    /// Whether its end is announced with a second line.
    end_line: bool,
}

/// The settings the unit keeps in flash (power cycles keep them).
#[derive(Clone, Debug)]
struct Flash {
    /// `SPMR` fields: speed mode, then its parameters (`0,2`: normal, ND auto).
    speed: String,
    /// `SCMR` fields (`0`: no sync).
    sync: String,
}

#[derive(Default)]
struct PowerOnState {
    remote: bool,
    line: Vec<u8>,
    running: Option<Running>,
    last: Option<Stored>,
}

pub(super) struct Device {
    cfg: MockConfig,
    model: Model,
    unit: Unit,
    flash: Flash,
    state: PowerOnState,
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
            cfg,
            model,
            unit,
            flash: Flash {
                speed: "0,2".into(),
                sync: "0".into(),
            },
            state: PowerOnState::default(),
        }
    }

    fn reply(&mut self, text: &str) {
        let mut bytes = text.as_bytes().to_vec();
        bytes.push(b'\n');
        self.unit.write(&bytes);
    }

    fn command(&mut self, raw: &[u8]) -> Next {
        let text = String::from_utf8_lossy(raw).trim().to_string();
        tracing::debug!(command = %text, "simulated {} received", self.model.name());
        let fields: Vec<&str> = text.split(',').collect();
        let name = fields[0];
        if !self.state.remote && !matches!(name, "RMTS" | "IDDR") {
            self.reply("ER00");
            return Next::Continue;
        }
        match (name, &fields[1..]) {
            ("RMTS", ["1"]) => {
                self.state.remote = true;
                self.reply("OK00");
            }
            ("RMTS", ["0"]) => {
                self.state.remote = false;
                self.reply("OK00");
            }
            ("IDDR", []) => {
                let name = match self.model {
                    Model::Cs3000 => "CS-3000",
                    Model::Cs2000 | Model::Cs2000A => "CS-2000",
                };
                let reply = format!("OK00,{name},{},{}", self.model.variation(), self.cfg.serial);
                self.reply(&reply);
            }
            ("MEAS", ["1"]) if self.state.running.is_some() => self.reply("ER00"),
            ("MEAS", ["1"]) => self.start_measurement(),
            ("MEAS", ["0"]) => {
                self.state.running = None;
                self.reply("OK00");
            }
            ("MEDR", [kind, format, block]) => self.data(kind, format, block),
            ("SPMR", []) => {
                let reply = format!("OK00,{}", self.flash.speed);
                self.reply(&reply);
            }
            ("SCMR", []) => {
                let reply = format!("OK00,{}", self.flash.sync);
                self.reply(&reply);
            }
            ("SPMS", [mode, rest @ ..]) if matches!(*mode, "0" | "1" | "2" | "3" | "4") && !rest.is_empty() => {
                self.flash.speed = fields[1..].join(",");
                self.write_flash("SPMS");
            }
            ("SCMS", [mode, ..]) if matches!(*mode, "0" | "1" | "2") => {
                self.flash.sync = fields[1..].join(",");
                self.write_flash("SCMS");
            }
            ("SPMS" | "SCMS" | "MEDR" | "MEAS" | "RMTS", _) => self.reply("ER17"),
            _ => self.reply("ER00"),
        }
        Next::Continue
    }

    fn write_flash(&mut self, what: &str) {
        tracing::warn!(
            command = what,
            "simulated {}: a setting written to flash",
            self.model.name()
        );
        self.unit.shared().flash_writes += 1;
        self.reply("OK00");
    }

    /// `MEAS,1`: the reading, its time, and the announcement.
    fn start_measurement(&mut self) {
        let truth = self.unit.shared().truth_1nm.clone();
        let reading = match self.cfg.model.reading(&truth, 0) {
            Ok(r) => r,
            Err(e) => {
                tracing::error!(error = %e, "simulated {}: cannot model the target", self.model.name());
                self.reply("ER00");
                return;
            }
        };
        self.unit.shared().measurements += 1;
        self.unit.shared().last_measurement_ms = Some(reading.duration_ms);
        // The detector's low-light codes (10, 18) are not the CS-2000's: it
        // measures dim targets, noisily. Only saturation is an error (ER10).
        let code = if self.unit.fires(FaultKind::ErrorCode) {
            self.cfg.error_code
        } else if reading.code == 19 {
            10
        } else {
            0
        };
        let values = if code == 0 {
            self.cfg.model.sample(&reading, &mut self.unit.rng)
        } else {
            Vec::new()
        };
        let wall_ms = reading.duration_ms * self.cfg.speed;
        let now = Instant::now();
        let ends_at = now + Duration::from_secs_f64(wall_ms / 1000.0);
        let pulled_at = self
            .unit
            .fires(FaultKind::CablePull)
            .then(|| now + Duration::from_secs_f64(wall_ms / 2000.0));
        self.state.running = Some(Running {
            ends_at,
            result: Stored {
                code,
                values,
                integration_us: reading.integration_ms * 1000.0,
            },
            pulled_at,
            end_line: !self.cfg.short_estimate,
        });
        let announced = if self.cfg.short_estimate {
            0
        } else {
            (wall_ms / 1000.0).ceil() as u64
        };
        self.reply(&format!("OK00,{announced}"));
    }

    /// `MEDR,<kind>,<format>,<block>`.
    fn data(&mut self, kind: &str, format: &str, block: &str) {
        if self.state.running.is_some() {
            self.reply("ER02");
            return;
        }
        let Some(last) = self.state.last.clone() else {
            self.reply("ER02");
            return;
        };
        if last.code != 0 {
            self.reply(&format!("ER{:02}", last.code));
            return;
        }
        match (kind, format, block.parse::<usize>()) {
            ("0", _, _) => {
                let reply = format!(
                    "OK00,{},{:.0},{}",
                    self.flash.speed, last.integration_us, self.flash.sync
                );
                self.reply(&reply);
            }
            ("1", "0" | "1", Ok(n @ 1..=4)) => {
                let start: usize = BLOCK_LENGTHS[..n - 1].iter().sum();
                let values = &last.values[start..start + BLOCK_LENGTHS[n - 1]];
                let hex = format == "1";
                let mut text = String::from("OK00");
                for v in values {
                    text.push(',');
                    text.push_str(&if hex { encode_hex_f32(*v) } else { format!("{v:.6e}") });
                }
                text.push('\n');
                self.unit.send_spectrum(text.into_bytes(), 5);
            }
            ("2", _, _) => match self.colorimetry(&last.values) {
                Some(reply) => self.reply(&reply),
                None => self.reply("ER00"),
            },
            _ => self.reply("ER17"),
        }
    }

    /// `OK00,Le,Lv,X,Y,Z,x,y` of the stored spectrum.
    fn colorimetry(&self, values: &[f64]) -> Option<String> {
        let spectrum = Spectrum::new(self.model.grid(), SpectralUnit::SpectralRadiance, values.to_vec()).ok()?;
        let xyz = xyz_from_radiance(&spectrum, Observer::Cie1931).ok()?;
        let le: f64 = values.iter().sum(); // 1 nm steps
        let sum = xyz.x + xyz.y + xyz.z;
        let (x, y) = if sum > 0.0 {
            (xyz.x / sum, xyz.y / sum)
        } else {
            (0.0, 0.0)
        };
        Some(format!(
            "OK00,{le:.6e},{:.6e},{:.6e},{:.6e},{:.6e},{x:.6},{y:.6}",
            xyz.y, xyz.x, xyz.y, xyz.z
        ))
    }
}

impl Firmware for Device {
    fn unit(&mut self) -> &mut Unit {
        &mut self.unit
    }

    fn power_on(&mut self) {
        self.state = PowerOnState::default();
    }

    fn byte(&mut self, b: u8, _burst: bool) -> Next {
        match b {
            b'\n' => {
                let line = std::mem::take(&mut self.state.line);
                if line.iter().all(u8::is_ascii_whitespace) {
                    return Next::Continue;
                }
                self.command(&line)
            }
            b'\r' => Next::Continue,
            _ => {
                if self.state.line.len() < 4096 {
                    self.state.line.push(b);
                }
                Next::Continue
            }
        }
    }

    fn forget_line(&mut self) {
        self.state.line.clear();
    }

    fn listening(&mut self) -> bool {
        !self.unit.shared().link_dead
    }

    /// The measurement in progress ends (the second line) or its cable is pulled.
    fn tick(&mut self) -> Next {
        let now = Instant::now();
        let Some(running) = self.state.running.as_ref() else {
            return Next::Continue;
        };
        if running.pulled_at.is_some_and(|t| now >= t) {
            self.unit.switch_off("USB cable pulled mid-measurement");
            return Next::Unplugged;
        }
        if now < running.ends_at {
            return Next::Continue;
        }
        let Some(Running { result, end_line, .. }) = self.state.running.take() else {
            return Next::Continue;
        };
        let code = result.code;
        self.state.last = Some(result);
        if !end_line {
            return Next::Continue;
        }
        if code == 0 {
            self.reply("OK00");
        } else {
            self.reply(&format!("ER{code:02}"));
        }
        Next::Continue
    }
}
