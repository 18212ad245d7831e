//! What every simulated unit is made of, whatever its firmware: the pty's
//! master end (and its device end, kept open), the state it shares with its
//! [`super::MockHandle`], the stop flag, and its noise and fault generator.
//! On that, the work both firmwares (the PR-650's [`super::pr650`], the
//! PR-655/PR-670's [`super::pr655`]) do alike: the read loop that feeds a
//! [`Firmware`] byte by byte ([`run`]: power cycles, input that arrives
//! while measuring), writing replies (paced at 9600 baud or in one burst),
//! sleeping without missing a stop request, injected faults firing and
//! what they make of a spectrum reply, and the port closing when the cable
//! is pulled or the unit switches off.

use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use serialport::{SerialPort, TTYPort};

use super::config::{BusyInput, MockConfig};
use super::faults::{self, Fault, FaultKind};
use super::model::Rng;
use lightbooth_science::spectrum::Spectrum;

/// Read slice of the simulators: how often they check for stop and power-cycle requests.
const POLL: Duration = Duration::from_millis(10);

/// One byte at 9600 baud, 8N1 (10 bits on the wire), in ms.
const BYTE_TIME_MS: f64 = 10.0 / 9.6;

/// State shared between a [`super::MockHandle`] and its simulator thread,
/// behind one `Mutex`: the thread takes it briefly at each command, never
/// while sleeping.
#[derive(Debug)]
pub(super) struct Shared {
    pub(super) truth_1nm: Spectrum,
    pub(super) faults: Vec<Fault>,
    pub(super) power_cycle_requested: bool,
    pub(super) measurements: u64,
    pub(super) unplugged: bool,
    /// Set by a [`FaultKind::LinkDies`] fault: the unit answers nothing until power-cycled.
    pub(super) link_dead: bool,
    /// When the last byte of a reply went out.
    pub(super) last_byte_at: Option<Instant>,
    pub(super) integration_ms: u32,
    /// The simulated PR-655/PR-670's last measurement time at speed 1, ms.
    pub(super) last_measurement_ms: Option<f64>,
    /// Settings written to the simulated unit's flash memory (CS-2000 `SPMS`, `SCMS`).
    pub(super) flash_writes: u64,
}

impl Shared {
    /// Power-on state for a unit aimed at `truth_1nm`, with `faults` to inject.
    pub(super) fn new(truth_1nm: Spectrum, faults: Vec<Fault>) -> Shared {
        Shared {
            truth_1nm,
            faults,
            power_cycle_requested: false,
            measurements: 0,
            unplugged: false,
            link_dead: false,
            last_byte_at: None,
            integration_ms: 0,
            last_measurement_ms: None,
            flash_writes: 0,
        }
    }
}

pub(super) fn lock(shared: &Mutex<Shared>) -> MutexGuard<'_, Shared> {
    // A panic in the simulator thread must not take the handle down with it.
    shared.lock().unwrap_or_else(|p| p.into_inner())
}

/// What a firmware's byte handler wants next.
pub(super) enum Next {
    Continue,
    /// A measurement ended; bytes received meanwhile are handled per [`BusyInput`].
    AfterMeasurement,
    /// The cable was pulled or the unit switched off: stop.
    Unplugged,
}

/// A simulated instrument's firmware: its own state machine over a [`Unit`].
pub(super) trait Firmware {
    fn unit(&mut self) -> &mut Unit;
    /// A power cycle: the firmware's own state back to power-on (the
    /// unit's shared state is reset before, by [`run`]).
    fn power_on(&mut self);
    /// Handles one received byte; `burst` when it came with others in one read.
    fn byte(&mut self, b: u8, burst: bool) -> Next;
    /// Forgets a partly received command (input dropped after a measurement).
    fn forget_line(&mut self);
    /// Whether the bytes of this read are handled at all (a firmware may
    /// instead decide byte by byte).
    fn listening(&mut self) -> bool {
        true
    }
    /// Called between reads (at least every poll): what the firmware does
    /// on its own, such as ending a measurement that runs while it listens.
    fn tick(&mut self) -> Next {
        Next::Continue
    }
}

/// The simulator thread: reads what the host sends and feeds it to
/// `firmware` until stopped or unplugged.
pub(super) fn run(mut firmware: impl Firmware) {
    let mut buf = [0u8; 256];
    while !firmware.unit().stop.load(Ordering::Relaxed) {
        if firmware.unit().power_cycle_requested() {
            firmware.unit().power_on();
            firmware.power_on();
        }
        if let Next::Unplugged = firmware.tick() {
            return;
        }
        let Some(n) = firmware.unit().read(&mut buf) else { break };
        // A power cycle requested while the read was blocked comes before these bytes.
        if firmware.unit().power_cycle_requested() {
            firmware.unit().power_on();
            firmware.power_on();
        }
        if n == 0 || !firmware.listening() {
            continue;
        }
        let burst = n > 1;
        let mut i = 0;
        while i < n {
            match firmware.byte(buf[i], burst) {
                Next::Continue => i += 1,
                Next::AfterMeasurement => {
                    i += 1;
                    if firmware.unit().busy_input == BusyInput::Drop {
                        i = n;
                        firmware.unit().clear_input();
                        firmware.forget_line();
                    }
                }
                Next::Unplugged => return,
            }
        }
    }
}

/// The hardware of one simulated unit, as its firmware uses it.
pub(super) struct Unit {
    /// The model's name, for the log (`PR-650`, `PR-655`, `PR-670`).
    pub(super) name: &'static str,
    port: Option<TTYPort>,
    /// The device end kept open so the pty survives the host closing and
    /// reopening it (a real unit does not notice the host's port closing).
    keepalive: Option<TTYPort>,
    /// Target, faults and counters shared with the [`super::MockHandle`];
    /// locked briefly per command, never across a sleep or a write.
    shared: Arc<Mutex<Shared>>,
    /// Set by the handle to stop this thread; checked between reads and during sleeps.
    stop: Arc<AtomicBool>,
    /// The noise and fault-rate generator.
    pub(super) rng: Rng,
    speed: f64,
    /// Replies go out a line at a time at 9600 baud (scaled by speed), not in one burst.
    paced: bool,
    busy_input: BusyInput,
    slow_ms: u64,
}

impl Unit {
    /// The unit `cfg` describes on the pty's `port` (its master end).
    /// `paced`: replies at 9600 baud, as on the PR-650's RS-232.
    pub(super) fn new(
        name: &'static str,
        cfg: &MockConfig,
        port: TTYPort,
        keepalive: TTYPort,
        shared: Arc<Mutex<Shared>>,
        stop: Arc<AtomicBool>,
        paced: bool,
    ) -> Unit {
        Unit {
            name,
            port: Some(port),
            keepalive: Some(keepalive),
            shared,
            stop,
            rng: Rng::new(cfg.seed),
            speed: cfg.speed,
            paced,
            busy_input: cfg.busy_input,
            slow_ms: cfg.slow_ms,
        }
    }

    /// The state shared with the handle, locked.
    pub(super) fn shared(&self) -> MutexGuard<'_, Shared> {
        lock(&self.shared)
    }

    fn power_cycle_requested(&self) -> bool {
        std::mem::take(&mut self.shared().power_cycle_requested)
    }

    /// Power-on for what the unit shares with the handle: adaptive
    /// integration again, and a link that died answers again.
    fn power_on(&mut self) {
        tracing::info!("simulated {}: power cycle", self.name);
        let mut shared = self.shared();
        shared.integration_ms = 0;
        shared.link_dead = false;
    }

    /// One read of what the host sent, 0 bytes when nothing came within a
    /// poll; `None` once the port is gone.
    fn read(&mut self, buf: &mut [u8]) -> Option<usize> {
        let name = self.name;
        let port = self.port.as_mut()?;
        let _ = port.set_timeout(POLL);
        match port.read(buf) {
            Ok(n) => Some(n),
            Err(e) if e.kind() == std::io::ErrorKind::TimedOut => Some(0),
            Err(e) => {
                tracing::debug!(error = %e, "simulated {name}: read failed");
                std::thread::sleep(POLL);
                Some(0)
            }
        }
    }

    /// The baud rate and stop bits the host set on its end of the pty: all
    /// a simulator can check of the line (a pty takes neither 7 data bits
    /// nor parity). `None` when they cannot be read.
    pub(super) fn host_line(&self) -> Option<(u32, serialport::StopBits)> {
        let port = self.keepalive.as_ref()?;
        Some((port.baud_rate().ok()?, port.stop_bits().ok()?))
    }

    /// Discards what the host sent meanwhile.
    fn clear_input(&mut self) {
        if let Some(port) = self.port.as_mut() {
            let _ = port.clear(serialport::ClearBuffer::Input);
        }
    }

    /// Whether a fault of `kind` fires now (and counts it down).
    pub(super) fn fires(&mut self, kind: FaultKind) -> bool {
        self.fired(kind).is_some()
    }

    /// The fault of `kind` that fires now, if any ([`faults::fire`]).
    fn fired(&mut self, kind: FaultKind) -> Option<Fault> {
        let fault = faults::fire(&mut lock(&self.shared).faults, &mut self.rng, kind);
        if fault.is_some() {
            tracing::info!(?kind, "simulated {}: injecting fault", self.name);
        }
        fault
    }

    /// Sleeps `ms` of instrument time (scaled by speed), waking for a stop request.
    pub(super) fn sleep_scaled(&self, ms: f64) {
        self.sleep_ms(ms * self.speed);
    }

    /// Sleeps `ms` of wall time, waking for a stop request.
    pub(super) fn sleep_ms(&self, ms: f64) {
        let end = Instant::now() + Duration::from_secs_f64(ms.max(0.0) / 1000.0);
        while !self.stop.load(Ordering::Relaxed) {
            let now = Instant::now();
            if now >= end {
                break;
            }
            std::thread::sleep((end - now).min(POLL));
        }
    }

    /// Sends bytes: paced, a line at a time at 9600 baud (scaled by speed),
    /// so no pause inside a reply exceeds a line's time (≪ 0.5 s, PR-650
    /// §7.3); else the whole reply in one burst (USB).
    pub(super) fn write(&mut self, bytes: &[u8]) {
        let pace = self.paced && self.speed > 0.0;
        let chunks: Vec<&[u8]> = if pace {
            bytes.split_inclusive(|b| *b == b'\n').collect()
        } else {
            vec![bytes]
        };
        for chunk in chunks {
            let Some(port) = self.port.as_mut() else { return };
            let _ = port.set_timeout(Duration::from_millis(500));
            if let Err(e) = port.write_all(chunk).and_then(|_| port.flush()) {
                tracing::debug!(error = %e, "simulated {}: host not reading; reply dropped", self.name);
                return;
            }
            self.shared().last_byte_at = Some(Instant::now());
            if pace {
                self.sleep_scaled(chunk.len() as f64 * BYTE_TIME_MS);
            }
        }
    }

    /// Sends a spectrum reply through the faults that apply to it, in the
    /// order both simulators use: no answer, slow (after the fault's delay or
    /// [`MockConfig::slow_ms`]), garble (from byte `garble_start`), a double
    /// CR LF after the header, truncate, and the link dying after half of it
    /// (silent until power-cycled).
    pub(super) fn send_spectrum(&mut self, mut bytes: Vec<u8>, garble_start: usize) {
        if self.fires(FaultKind::NoAnswer) {
            return;
        }
        if let Some(slow) = self.fired(FaultKind::Slow) {
            self.sleep_ms(slow.delay_ms.unwrap_or(self.slow_ms) as f64);
        }
        if self.fires(FaultKind::Garble) {
            faults::garble(&mut self.rng, &mut bytes, garble_start);
        }
        if self.fires(FaultKind::DoubleCrlf) {
            let header_end = bytes.iter().position(|b| *b == b'\n').map_or(0, |i| i + 1);
            bytes.splice(header_end..header_end, *b"\r\n");
        }
        if self.fires(FaultKind::Truncate) {
            bytes.truncate(bytes.len() / 2);
        }
        if self.fires(FaultKind::LinkDies) {
            bytes.truncate(bytes.len() / 2);
            self.write(&bytes);
            tracing::info!(
                "simulated {}: the link died mid-reply; silent until power-cycled",
                self.name
            );
            self.shared().link_dead = true;
            return;
        }
        self.write(&bytes);
    }

    /// A measurement of `duration_ms` (instrument time) during which a
    /// cable-pull fault may fire: then half of it passes and the unit is
    /// gone ([`Unit::switch_off`]). True when it was pulled.
    pub(super) fn cable_pulled_during(&mut self, duration_ms: f64, why: &str) -> bool {
        if !self.fires(FaultKind::CablePull) {
            return false;
        }
        self.sleep_scaled(duration_ms / 2.0);
        self.switch_off(why);
        true
    }

    /// The unit vanishes from the host (its cable pulled, or a USB unit
    /// switched off): both ends of the pty close and the simulator stops.
    pub(super) fn switch_off(&mut self, why: &str) {
        tracing::info!(why, "simulated {}: the port closes", self.name);
        self.shared().unplugged = true;
        self.port = None;
        self.keepalive = None;
    }
}
