//! The simulated PR-650's firmware: the byte-level state machine on the
//! master end of the pty. One thread runs [`Device::run`]; it reads bytes,
//! assembles commands, and answers as the instrument would.

use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use serialport::{SerialPort, TTYPort};

use super::model::Rng;
use super::{lock, BeforeFirstMeasurement, BusyInput, Fault, FaultKind, MockConfig, Shared};
use crate::colorimetry::{xyz_from_radiance, Observer};
use crate::instrument::pr650::protocol as wire;
use crate::spectrum::{SpectralUnit, Spectrum};

use super::firmware::POLL;

/// One byte at 9600 baud, 8N1 (10 bits on the wire), in ms.
const BYTE_TIME_MS: f64 = 10.0 / 9.6;

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
    port: Option<TTYPort>,
    /// The device end kept open so the pty survives the host closing and
    /// reopening it (a real unit does not notice the host's port closing).
    keepalive: Option<TTYPort>,
    /// Target, faults and counters shared with the [`super::MockHandle`];
    /// locked briefly per command, never across a sleep or a write.
    shared: Arc<Mutex<Shared>>,
    /// Set by the handle to stop this thread; checked between reads and during sleeps.
    stop: Arc<AtomicBool>,
    rng: Rng,
    powered_at: Instant,
    remote: bool,
    local: bool,
    echo: bool,
    line: Vec<u8>,
    last_was_cr: bool,
    settings: Settings,
    stored: Option<Stored>,
}

/// What a command handler wants next.
enum Next {
    Continue,
    /// The measurement is done; handle bytes received meanwhile per [`BusyInput`].
    AfterMeasurement,
    /// The cable was pulled: stop.
    Unplugged,
}

impl Device {
    pub(super) fn new(
        cfg: MockConfig,
        port: TTYPort,
        keepalive: TTYPort,
        shared: Arc<Mutex<Shared>>,
        stop: Arc<AtomicBool>,
    ) -> Device {
        let rng = Rng::new(cfg.seed);
        Device {
            cfg,
            port: Some(port),
            keepalive: Some(keepalive),
            shared,
            stop,
            rng,
            powered_at: Instant::now(),
            remote: false,
            local: false,
            echo: false,
            line: Vec::new(),
            last_was_cr: false,
            settings: Settings::default(),
            stored: None,
        }
    }

    fn power_on(&mut self) {
        tracing::info!("simulated PR-650: power cycle");
        self.powered_at = Instant::now();
        self.remote = false;
        self.local = false;
        self.echo = false;
        self.line.clear();
        self.settings = Settings::default();
        self.stored = None;
        let mut shared = lock(&self.shared);
        shared.integration_ms = 0;
        shared.link_dead = false;
    }

    pub(super) fn run(mut self) {
        let mut buf = [0u8; 256];
        while !self.stop.load(Ordering::Relaxed) {
            let cycle = std::mem::take(&mut lock(&self.shared).power_cycle_requested);
            if cycle {
                self.power_on();
            }
            let Some(port) = self.port.as_mut() else { break };
            let _ = port.set_timeout(POLL);
            let n = match port.read(&mut buf) {
                Ok(n) => n,
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => continue,
                Err(e) => {
                    tracing::debug!(error = %e, "simulated PR-650: read failed");
                    std::thread::sleep(POLL);
                    continue;
                }
            };
            // A power cycle requested while the read was blocked comes before these bytes.
            let cycle = std::mem::take(&mut lock(&self.shared).power_cycle_requested);
            if cycle {
                self.power_on();
            }
            let mut i = 0;
            while i < n {
                match self.byte(buf[i]) {
                    Next::Continue => i += 1,
                    Next::AfterMeasurement => {
                        i += 1;
                        if self.cfg.busy_input == BusyInput::Drop {
                            i = n;
                            self.drain_input();
                        }
                    }
                    Next::Unplugged => return,
                }
            }
        }
    }

    fn drain_input(&mut self) {
        if let Some(port) = self.port.as_mut() {
            let _ = port.clear(serialport::ClearBuffer::Input);
        }
        self.line.clear();
    }

    fn byte(&mut self, b: u8) -> Next {
        if !self.remote && !self.local {
            if let Some(window) = self.cfg.remote_window_ms {
                if self.powered_at.elapsed() > Duration::from_millis(window) {
                    tracing::info!("simulated PR-650: no command within the power-on window; local mode");
                    self.local = true;
                }
            }
        }
        if self.local || lock(&self.shared).link_dead {
            return Next::Continue; // ignores the port until power-cycled
        }
        if self.echo {
            self.write(&[b]);
        }
        if b == b'\r' || b == b'\n' {
            let pair = b == b'\n' && self.last_was_cr;
            self.last_was_cr = b == b'\r';
            if pair || self.line.iter().all(u8::is_ascii_whitespace) {
                self.line.clear();
                return Next::Continue;
            }
            let command = std::mem::take(&mut self.line).to_ascii_uppercase();
            self.remote = true;
            let next = self.command(String::from_utf8_lossy(&command).trim());
            if self.echo {
                self.write(b">");
            }
            return next;
        }
        self.last_was_cr = false;
        if self.line.len() < 256 {
            self.line.push(b);
        }
        Next::Continue
    }

    fn command(&mut self, text: &str) -> Next {
        tracing::debug!(command = text, "simulated PR-650 received");
        let (letter, args) = text.split_at(text.chars().next().map_or(0, char::len_utf8));
        match letter {
            "B" if matches!(args, "" | "0" | "1" | "2" | "3") => self.write(b"000\r\n"),
            "S" => {
                let status = setup_status(args);
                if status == 0 {
                    let fields: Vec<&str> = args.split(',').collect();
                    self.settings.sync_on = !fields.get(4).unwrap_or(&"").is_empty();
                    self.settings.integration_ms = fields.get(5).and_then(|f| f.parse().ok()).unwrap_or(0);
                    lock(&self.shared).integration_ms = self.settings.integration_ms;
                }
                self.settings.last_status = status;
                self.write(format!("{status:02}\r\n").as_bytes());
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
                    self.write(b"000\r\n");
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
                Some(hz) => self.write(format!("00,{hz:.2}\r\n").as_bytes()),
                None => self.write(b"20\r\n"),
            },
            "E" => {
                tracing::warn!("simulated PR-650: echo mode on (a driver should never send E)");
                self.echo = true;
            }
            _ => tracing::debug!(command = text, "simulated PR-650: unknown command ignored"),
        }
        Next::Continue
    }

    /// Whether a fault of `kind` fires now (and counts it down).
    fn fires(&mut self, kind: FaultKind) -> bool {
        self.fired(kind).is_some()
    }

    /// The fault of `kind` that fires now, if any ([`super::firmware::fired`]).
    fn fired(&mut self, kind: FaultKind) -> Option<Fault> {
        super::firmware::fired(&self.shared, &mut self.rng, kind)
    }

    /// Sleeps `ms` of instrument time (scaled by speed), waking for a stop request.
    fn sleep_scaled(&self, ms: f64) {
        self.sleep_ms(ms * self.cfg.speed);
    }

    /// Sleeps `ms` of wall time, waking for a stop request.
    fn sleep_ms(&self, ms: f64) {
        super::firmware::sleep_ms(&self.stop, ms)
    }

    /// One measurement. Returns false if the cable was pulled.
    fn measure(&mut self) -> bool {
        let truth = lock(&self.shared).truth_1nm.clone();
        let reading = match self.cfg.model.reading(&truth, self.settings.integration_ms) {
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
        if self.fires(FaultKind::CablePull) {
            self.sleep_scaled(reading.duration_ms / 2.0);
            tracing::info!("simulated PR-650: cable pulled");
            lock(&self.shared).unplugged = true;
            self.port = None;
            self.keepalive = None;
            return false;
        }
        self.sleep_scaled(reading.duration_ms);
        let mut code = reading.code;
        if self.settings.sync_on && self.cfg.unsyncable {
            code = 7;
        }
        if self.fires(FaultKind::ErrorCode) {
            code = self.cfg.error_code;
        }
        if code == 0 {
            let values = self.cfg.model.sample(&reading, &mut self.rng);
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
            self.stored = Some(Stored {
                code,
                values,
                integral,
                xyz,
            });
        } else {
            // §3: on a failed measurement the spectral buffer is not updated;
            // D5 resends the previous spectrum under the new code, Y is 0.
            let mut stored = self.stored.take().unwrap_or_else(|| zeros(self.cfg.model.grid.len()));
            stored.code = code;
            stored.xyz = [0.0; 3];
            self.stored = Some(stored);
        }
        lock(&self.shared).measurements += 1;
        true
    }

    fn report(&mut self, code: u16) {
        let grid = self.cfg.model.grid.clone();
        match code {
            wire::REPORT_SERIAL => {
                let serial = format!("{:<8}", self.cfg.serial);
                self.write(format!("{serial}\r\n").as_bytes());
                return;
            }
            wire::REPORT_CONFIG => {
                let bytes = wire::format_spectral_config(&grid, self.cfg.model.slit_fwhm_nm);
                self.write(&bytes);
                return;
            }
            wire::REPORT_SETUP_STATUS => {
                let status = self.settings.last_status;
                self.write(format!("{status:02}\r\n").as_bytes());
                return;
            }
            _ => {}
        }
        let stored = match (&self.stored, self.cfg.before_first) {
            (Some(s), _) => s.clone(),
            (None, BeforeFirstMeasurement::StaleZeros) => zeros(grid.len()),
            (None, BeforeFirstMeasurement::NoReply) => return,
        };
        let [x, y, z] = stored.xyz;
        match code {
            wire::REPORT_YXY => {
                let sum = x + y + z;
                let (cx, cy) = if sum > 0.0 { (x / sum, y / sum) } else { (0.0, 0.0) };
                self.write(&wire::format_yxy_report(stored.code, 0, y, cx, cy));
            }
            wire::REPORT_XYZ => {
                self.write(&wire::format_xyz_report(stored.code, 0, x, y, z));
                if self.fires(FaultKind::Stale) {
                    // Lands in the host's buffer before its next command.
                    self.write(b"00,0\r\n2.817E-01\r\n0380.,1.2");
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
                let start = 17;
                match super::firmware::fault_spectrum_reply(
                    &self.shared,
                    &mut self.rng,
                    &self.stop,
                    self.cfg.slow_ms,
                    bytes,
                    start,
                ) {
                    super::firmware::Faulted::Silent => {}
                    super::firmware::Faulted::Send(bytes) => self.write(&bytes),
                    super::firmware::Faulted::SendThenDie(bytes) => {
                        self.write(&bytes);
                        tracing::info!("simulated PR-650: the link died mid-reply; silent until power-cycled");
                        lock(&self.shared).link_dead = true;
                    }
                }
            }
            _ => tracing::debug!(code, "simulated PR-650: report code not simulated; no reply"),
        }
    }

    /// Sends bytes, paced at 9600 baud (scaled by speed) a line at a time, so
    /// no pause inside a reply exceeds a line's time (≪ 0.5 s, §7.3).
    fn write(&mut self, bytes: &[u8]) {
        let pace = self.cfg.pace_output && self.cfg.speed > 0.0;
        let chunks: Vec<&[u8]> = if pace {
            bytes.split_inclusive(|b| *b == b'\n').collect()
        } else {
            vec![bytes]
        };
        for chunk in chunks {
            let Some(port) = self.port.as_mut() else { return };
            let _ = port.set_timeout(Duration::from_millis(500));
            if let Err(e) = port.write_all(chunk).and_then(|_| port.flush()) {
                tracing::debug!(error = %e, "simulated PR-650: host not reading; reply dropped");
                return;
            }
            lock(&self.shared).last_byte_at = Some(Instant::now());
            if pace {
                self.sleep_scaled(chunk.len() as f64 * BYTE_TIME_MS);
            }
        }
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
