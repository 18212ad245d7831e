//! The simulated Colorimetry Research CR-250/CR-300's firmware: the word
//! protocol of `docs/src/instruments/cr250.md` on the master end of the
//! pty, spoken as colour-specio 0.4.1's `CRSpectrometer` uses it.
//!
//! - Commands end in LF (a CR is ignored); every reply is
//!   `OK:<code>:<command>:<argument>` or `ER:<code>:<command>:<message>`,
//!   lines ended by LF (the line end is not public: a choice), written in
//!   **one burst** at once: specio reads each reply within 25 ms, and reads
//!   the lines after a spectrum's header only from what has already come.
//! - A reply whose argument is a positive number is followed by nothing
//!   (specio would read that many more lines if bytes were waiting).
//! - `RC InstrumentType` → 2; `RC Model` → `CR-250`/`CR-300`; `RC ID`,
//!   `RC Firmware`, `RS Aperture` (`1/2 deg`, a choice); `SM ExposureMode`,
//!   `SM Speed 0–3`, `SM ExposureX 1–50` and their `RS` (speed as a word:
//!   `Slow`, `Normal`, `Fast`, `2x Fast`); anything else `ER:-500`.
//! - `M` measures for the modelled time, then answers `OK:0:M:Measurement done`
//!   (the text is a choice; specio needs the fourth field), or `ER:100`
//!   (too dark) or `ER:-306` (too bright) with no data, or the `error-code`
//!   fault's code. Bytes that arrive meanwhile wait.
//! - `RM Spectrum` → `OK:0:RM Spectrum:380,780,<step>` and one value per
//!   line (W/(sr·m²·nm)), through the injected faults; `RM XYZ` → `X,Y,Z`
//!   (CIE 1931 2°, 683 lm/W) of the same noisy spectrum; `RM Exposure` →
//!   `<ms> ms`. Before any good measurement they answer
//!   `ER:-999:<command>:No measurement data` (a choice: the code is not public).
//! - Optics and timing ([`super::model::InstrumentModel::for_cr250`]): the
//!   model's grid, a slit of twice its step, a detector 10× as sensitive
//!   as the PR-650's, automatic exposures up to 5, 2.5, 1.5 and 0.75 s for
//!   the four speeds, and 0.3 s plus twice the exposure per measurement,
//!   inside specio's allowances (70, 21, 14, 7 s).

use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};

use serialport::TTYPort;

use super::config::MockConfig;
use super::faults::FaultKind;
use super::unit::{Firmware, Next, Shared, Unit};
use crate::cr250::Model;
use lightbooth_science::colorimetry::{xyz_from_radiance, Observer};
use lightbooth_science::spectrum::{SpectralUnit, Spectrum};

/// The longest automatic exposure at each speed, ms (a choice within specio's allowances).
const MAX_EXPOSURE_MS: [f64; 4] = [5_000.0, 2_500.0, 1_500.0, 750.0];

#[derive(Clone, Debug)]
struct Stored {
    values: Vec<f64>,
    exposure_ms: f64,
}

struct Setup {
    speed: u8,
    exposure_x: u8,
    auto_exposure: bool,
}

pub(super) struct Device {
    cfg: MockConfig,
    model: Model,
    unit: Unit,
    line: Vec<u8>,
    setup: Setup,
    last: Option<Stored>,
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
            line: Vec::new(),
            setup: Setup {
                speed: 1,
                exposure_x: 1,
                auto_exposure: true,
            },
            last: None,
        }
    }

    fn ok(&mut self, command: &str, argument: &str) {
        self.unit.write(format!("OK:0:{command}:{argument}\n").as_bytes());
    }

    fn error(&mut self, code: i32, command: &str, message: &str) {
        self.unit.write(format!("ER:{code}:{command}:{message}\n").as_bytes());
    }

    fn command(&mut self, raw: &[u8]) -> Next {
        let text = String::from_utf8_lossy(raw).trim().to_string();
        tracing::debug!(command = %text, "simulated {} received", self.model.name());
        let words: Vec<&str> = text.split_whitespace().collect();
        match words.as_slice() {
            ["RC", "InstrumentType"] => self.ok("RC InstrumentType", "2"),
            ["RC", "Model"] => self.ok("RC Model", self.model.name()),
            ["RC", "ID"] => {
                let serial = self.cfg.serial.clone();
                self.ok("RC ID", &serial)
            }
            ["RC", "Firmware"] => self.ok("RC Firmware", "1.5.2"),
            ["RS", "Aperture"] => self.ok("RS Aperture", "1/2 deg"),
            ["SM", "ExposureMode", v] => match v.parse::<u8>() {
                Ok(0) => {
                    self.setup.auto_exposure = true;
                    self.ok("SM ExposureMode", "0")
                }
                _ => self.error(-518, "SM ExposureMode", "Invalid exposure mode"),
            },
            ["SM", "Speed", v] => match v.parse::<u8>() {
                Ok(n @ 0..=3) => {
                    self.setup.speed = n;
                    self.ok("SM Speed", v)
                }
                _ => self.error(-519, "SM Speed", "Invalid exposure value"),
            },
            ["RS", "Speed"] => {
                let word = ["Slow", "Normal", "Fast", "2x Fast"][usize::from(self.setup.speed)];
                self.ok("RS Speed", word)
            }
            ["SM", "ExposureX", v] => match v.parse::<u8>() {
                Ok(n @ 1..=50) => {
                    self.setup.exposure_x = n;
                    self.ok("SM ExposureX", v)
                }
                _ => self.error(-514, "SM ExposureX", "Invalid exposure multiplier"),
            },
            ["RS", "ExposureX"] => {
                let n = self.setup.exposure_x.to_string();
                self.ok("RS ExposureX", &n)
            }
            ["M"] => return self.measure(),
            ["RM", "Spectrum"] => self.spectrum(),
            ["RM", "XYZ"] => match self.last.clone() {
                Some(last) => match self.xyz(&last.values) {
                    Some([x, y, z]) => self.ok("RM XYZ", &format!("{x:.6e},{y:.6e},{z:.6e}")),
                    None => self.error(-999, "RM XYZ", "No measurement data"),
                },
                None => self.error(-999, "RM XYZ", "No measurement data"),
            },
            ["RM", "Exposure"] => match self.last.clone() {
                Some(last) => self.ok("RM Exposure", &format!("{:.1} ms", last.exposure_ms)),
                None => self.error(-999, "RM Exposure", "No measurement data"),
            },
            _ => self.error(-500, &text, "Invalid command"),
        }
        Next::Continue
    }

    /// `M`: takes the modelled time (the unit averages `ExposureX` exposures).
    fn measure(&mut self) -> Next {
        let truth = self.unit.shared().truth_1nm.clone();
        let mut model = self.cfg.model.clone();
        model.max_integration_ms = MAX_EXPOSURE_MS[usize::from(self.setup.speed.min(3))];
        let reading = match model.reading(&truth, 0) {
            Ok(r) => r,
            Err(e) => {
                tracing::error!(error = %e, "simulated {}: cannot model the target", self.model.name());
                self.error(-305, "M", "Light intensity not measurable");
                return Next::Continue;
            }
        };
        let duration_ms = reading.duration_ms * f64::from(self.setup.exposure_x);
        self.unit.shared().measurements += 1;
        self.unit.shared().last_measurement_ms = Some(duration_ms);
        if self
            .unit
            .cable_pulled_during(duration_ms, "USB cable pulled mid-measurement")
        {
            return Next::Unplugged;
        }
        self.unit.sleep_scaled(duration_ms);
        let code = if self.unit.fires(FaultKind::ErrorCode) {
            self.cfg.error_status
        } else {
            match reading.code {
                19 => -306,
                10 | 18 => 100,
                _ => 0,
            }
        };
        if code != 0 {
            self.last = None;
            let message = crate::cr250::codes::quality_code(code).message;
            self.error(code, "M", &message);
            return Next::AfterMeasurement;
        }
        let mut values = Vec::new();
        for _ in 0..self.setup.exposure_x {
            let one = model.sample(&reading, &mut self.unit.rng);
            if values.is_empty() {
                values = one;
            } else {
                values.iter_mut().zip(one).for_each(|(v, o)| *v += o);
            }
        }
        let n = f64::from(self.setup.exposure_x);
        values.iter_mut().for_each(|v| *v /= n);
        self.last = Some(Stored {
            values,
            exposure_ms: reading.integration_ms,
        });
        self.ok("M", "Measurement done");
        Next::AfterMeasurement
    }

    fn spectrum(&mut self) {
        let Some(last) = self.last.clone() else {
            self.error(-999, "RM Spectrum", "No measurement data");
            return;
        };
        let grid = self.model.grid();
        let step = grid.step_nm().unwrap_or(1.0);
        let mut text = format!("OK:0:RM Spectrum:380,780,{step:.0}\n");
        for v in &last.values {
            text.push_str(&format!("{v:.6e}\n"));
        }
        self.unit.send_spectrum(text.into_bytes(), 19);
    }

    fn xyz(&self, values: &[f64]) -> Option<[f64; 3]> {
        let spectrum = Spectrum::new(self.model.grid(), SpectralUnit::SpectralRadiance, values.to_vec()).ok()?;
        let xyz = xyz_from_radiance(&spectrum, Observer::Cie1931).ok()?;
        Some([xyz.x, xyz.y, xyz.z])
    }
}

impl Firmware for Device {
    fn unit(&mut self) -> &mut Unit {
        &mut self.unit
    }

    fn power_on(&mut self) {
        self.line.clear();
        self.last = None;
        self.setup = Setup {
            speed: 1,
            exposure_x: 1,
            auto_exposure: true,
        };
    }

    fn byte(&mut self, b: u8, _burst: bool) -> Next {
        match b {
            b'\n' => {
                let line = std::mem::take(&mut self.line);
                if line.iter().all(u8::is_ascii_whitespace) {
                    return Next::Continue;
                }
                self.command(&line)
            }
            b'\r' => Next::Continue,
            _ => {
                if self.line.len() < 4096 {
                    self.line.push(b);
                }
                Next::Continue
            }
        }
    }

    fn forget_line(&mut self) {
        self.line.clear();
    }

    fn listening(&mut self) -> bool {
        !self.unit.shared().link_dead
    }
}
