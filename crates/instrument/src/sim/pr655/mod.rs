//! The simulated PR-655/PR-670's firmware: the byte-level state machine on
//! the master end of the pty, after `docs/src/instruments/pr655-670-protocol.md`;
//! the simulator thread ([`super::unit::run`]) feeds it the host's bytes.
//! Every behaviour the sheet leaves uncertain is a switch in
//! [`Pr655Switches`] (its section 13); the defaults are the first choice
//! listed there, except where the sheet's section 1 grades a client habit
//! as working on real units: those the default accepts (what a real unit
//! accepts), and the stricter reading is a switch.
//!
//! - Local mode ignores every byte but the `PHOTO` sequence, in any pacing
//!   (PsychoPy writes its letters with no pause, §1); strict mode takes its
//!   letters only one per read (a burst is ignored, 13.2).
//! - The banner ` REMOTE MODE` has no line end and comes after a latency.
//! - Commands end in CR or LF (PsychoPy ends them in LF, §1; optionally CR
//!   only), upper case (optionally any case);
//!   an unknown one is `-1000`; `Q` leaves remote mode at once, no reply.
//! - Replies come in one burst at USB speed, CR LF per line, status first.
//! - Measurements go through the same [`super::model::InstrumentModel`] as
//!   the PR-650's (on this model's grid and slit): its low light is `-8`,
//!   its overload `-2`; auto sync (`SS1`) on a source it cannot sync to
//!   ends in `-10` or `-1` ([`SyncFailure`]).
//! - A measurement ([`measurement`]) takes the sheet's 13.7 time: a base time,
//!   sync detection under `SS1`, and each cycle's exposure and dark exposure
//!   (smart dark skips repeated darks); `SS1`/`SS3` round the exposure up to
//!   whole periods of the source. [`super::MockHandle::last_measurement_ms`]
//!   reports it; the simulator sleeps it times [`MockConfig::speed`].
//! - Reports ([`reports`]) 1–7 (but 5 is the spectrum), 11, 12, 13, 14, 110, 111, 114,
//!   116, 117, 120, 601 and 602 are computed from one stored measurement and
//!   setup, so the views agree (section 6). Report 11, the scotopic
//!   luminance, weights the reported spectrum with the CIE 1951 V′(λ) table
//!   embedded beside this file (`cie1951_scotopic_1nm.csv`, provenance in its
//!   header). Not simulated: 8/9 (raw detector counts), the RAM and SD card
//!   reports and recalls (`R`, 401–412); they answer `-2000` or `-1000`.
//! - `ZEnableReset` arms the resets; `ZResetPreferences` and `ZResetSetup`
//!   then switch the unit off (4, 11.14): no reply, the simulator stops and
//!   the pty closes, as a USB device vanishes. Unarmed, they get `-1000`.

mod measurement;
mod reports;
pub mod switches;

use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};

use serialport::TTYPort;

use super::config::MockConfig;
use super::unit::{Firmware, Next, Shared, Unit};
use crate::pr655::protocol as wire;
use crate::pr655::Model;
use switches::{Pr655Switches, StrayTerminator};

/// One measurement, as the `D` reports resend it.
#[derive(Clone, Debug)]
struct Stored {
    status: i32,
    values: Vec<f64>,
    /// CIE 1931 XYZ, Y in cd/m².
    xyz: [f64; 3],
    exposure_ms: f64,
}

/// The setup the unit keeps for the session (power-on defaults).
#[derive(Clone, Copy, Debug)]
struct Setup {
    si_units: bool,
    exposure_ms: u32,
    cycles: u32,
    observer: u32,
    sync: u32,
    /// `SK`: the frequency user sync (`SS3`) locks to.
    user_sync_hz: u32,
    /// `SD1` (PR-670): smart dark.
    smart_dark: bool,
}

impl Default for Setup {
    fn default() -> Setup {
        Setup {
            si_units: false,
            exposure_ms: 0,
            cycles: 1,
            observer: 2,
            sync: 0,
            user_sync_hz: 60,
            smart_dark: false,
        }
    }
}

pub(super) struct Device {
    cfg: MockConfig,
    sw: Pr655Switches,
    unit: Unit,
    /// What a power cycle resets.
    state: PowerOnState,
}

/// The firmware's state from power-on: a power cycle sets it back to
/// [`Default`], so power-on and a new unit cannot disagree.
#[derive(Default)]
struct PowerOnState {
    remote: bool,
    /// Letters of `PHOTO` matched so far.
    photo: usize,
    /// The previous byte completed `PHOTO` (a CR/LF now is a stray terminator).
    just_entered: bool,
    echo: bool,
    /// `ZEnableReset` was sent: the reset commands are armed.
    reset_enabled: bool,
    line: Vec<u8>,
    setup: Setup,
    /// The last measurement, and the last good one.
    last: Option<Stored>,
    last_good: Option<Stored>,
    /// The exposure of the last dark measurement taken (smart dark reuses it, 5 `SD`).
    last_dark_exposure_ms: Option<f64>,
}

impl Device {
    pub(super) fn new(
        cfg: MockConfig,
        sw: Pr655Switches,
        port: TTYPort,
        keepalive: TTYPort,
        shared: Arc<Mutex<Shared>>,
        stop: Arc<AtomicBool>,
    ) -> Device {
        // The whole reply in one burst: USB, not 9600 baud (section 9).
        let unit = Unit::new(sw.model.name(), &cfg, port, keepalive, shared, stop, false);
        Device {
            cfg,
            sw,
            unit,
            state: PowerOnState::default(),
        }
    }

    /// Feeds one byte of `PHOTO`; true when it completed the sequence.
    fn photo_byte(&mut self, b: u8, burst: bool) -> bool {
        if self.sw.strict_photo && burst {
            self.state.photo = 0;
            return false;
        }
        let b = if self.sw.case_insensitive {
            b.to_ascii_uppercase()
        } else {
            b
        };
        if b == wire::REMOTE_ENTRY[self.state.photo] {
            self.state.photo += 1;
        } else {
            self.state.photo = usize::from(b == wire::REMOTE_ENTRY[0]);
        }
        if self.state.photo == wire::REMOTE_ENTRY.len() {
            self.state.photo = 0;
            return true;
        }
        false
    }

    /// One byte from the host; `burst` when it came with others in one read.
    fn receive(&mut self, b: u8, burst: bool) -> Next {
        if !self.state.remote {
            // 13.3: local mode ignores everything but PHOTO.
            tracing::trace!(byte = %(b as char).escape_debug(), burst, "simulated instrument in local mode");
            if self.photo_byte(b, burst) {
                self.enter_remote();
            }
            return Next::Continue;
        }
        if self.state.echo {
            self.unit.write(&[b]);
        }
        let just_entered = std::mem::take(&mut self.state.just_entered);
        let ends_line = b == b'\r' || (b == b'\n' && self.sw.accept_lf);
        if ends_line || b == b'\n' {
            if just_entered && self.state.line.is_empty() {
                match self.sw.stray_terminator {
                    StrayTerminator::Ignore => {}
                    StrayTerminator::EmptyLine => self.unit.write(b"\r\n"),
                    StrayTerminator::IllegalCommand => self.status_reply(-1000),
                }
                return Next::Continue;
            }
            if !ends_line || self.state.line.is_empty() {
                return Next::Continue; // the LF of CR LF, or an LF that does not end commands
            }
            let line = std::mem::take(&mut self.state.line);
            let next = self.command(&line);
            if self.state.echo {
                self.unit.write(b">");
            }
            return next;
        }
        if self.state.line.len() < 256 {
            self.state.line.push(b);
        }
        // `Q` needs no terminator (2.2); `PHOTO` again comes without one (13.2).
        let upper = self.state.line.to_ascii_uppercase();
        let upper = if self.sw.case_insensitive {
            upper
        } else {
            self.state.line.clone()
        };
        if upper == b"Q" {
            self.state.line.clear();
            tracing::info!("simulated instrument: Q, back to local mode");
            self.state.remote = false;
            self.state.photo = 0;
        } else if upper == wire::REMOTE_ENTRY && !(self.sw.strict_photo && burst) {
            self.state.line.clear();
            if self.sw.photo_only_once {
                tracing::info!("simulated instrument: PHOTO again, in remote mode already: no reply");
            } else {
                self.enter_remote();
            }
        }
        Next::Continue
    }

    fn enter_remote(&mut self) {
        if self.sw.no_banner {
            tracing::info!("simulated instrument: PHOTO, but the no-banner switch is on");
            return;
        }
        self.unit.sleep_ms(self.sw.banner_latency_ms as f64);
        self.unit.write(wire::BANNER);
        self.state.remote = true;
        self.state.just_entered = true;
        self.state.line.clear();
        tracing::info!(model = self.sw.model.name(), "simulated instrument in remote mode");
    }

    fn status_reply(&mut self, status: i32) {
        let bytes = wire::format_status_reply(status, self.sw.status_style);
        self.unit.write(&bytes);
    }

    fn command(&mut self, raw: &[u8]) -> Next {
        let text = String::from_utf8_lossy(raw).trim().to_string();
        tracing::debug!(command = %text, "simulated instrument received");
        if let Some(next) = self.reset_command(&text) {
            return next;
        }
        if !self.sw.case_insensitive && text.bytes().any(|b| b.is_ascii_lowercase()) {
            self.status_reply(-1000);
            return Next::Continue;
        }
        let text = text.to_ascii_uppercase();
        let (letter, args) = text.split_at(text.chars().next().map_or(0, char::len_utf8));
        match letter {
            "M" => {
                let Ok(code) = args.parse::<u16>() else {
                    self.status_reply(-1000);
                    return Next::Continue;
                };
                if !self.measure() {
                    return Next::Unplugged;
                }
                if code == 0 {
                    let status = self.state.last.as_ref().map_or(0, |s| s.status);
                    self.status_reply(status);
                } else {
                    self.report(code, true);
                }
                return Next::AfterMeasurement;
            }
            "D" => match args.parse::<u16>() {
                Ok(code) => self.report(code, false),
                Err(_) => self.status_reply(-1000),
            },
            "S" => {
                let status = self.set(args);
                self.status_reply(status);
            }
            "F" => match self.flicker_in_sync_range() {
                Some(hz) => {
                    let reply = format!(
                        "{},{hz:.2} Hertz (Period = {:.0} milliseconds)\r\n",
                        wire::format_status(0, self.sw.status_style),
                        1000.0 / hz
                    );
                    self.unit.write(reply.as_bytes());
                }
                None => self.status_reply(-3),
            },
            "I" => self.status_reply(0),
            "E" => {
                tracing::warn!("simulated instrument: echo on (a driver should never send E)");
                self.state.echo = true;
            }
            _ => self.status_reply(-1000),
        }
        Next::Continue
    }

    /// The `Z…` commands (4), spelt in mixed case as the manual paraphrase
    /// gives them: `ZEnableReset` answers `Reset Commands Enabled` and arms
    /// the resets; `ZResetPreferences` and `ZResetSetup`, once armed, "shut
    /// down the instrument after they are executed" (11.14): no reply, and the
    /// USB device disappears with the unit ([`Self::switch_off`]). Before
    /// `ZEnableReset` they answer `-1000`: the sheet says only that they must
    /// be enabled, not how a refusal reads (a simulator choice). None for any
    /// other command.
    fn reset_command(&mut self, text: &str) -> Option<Next> {
        let any_case = self.sw.case_insensitive;
        let is = |name: &str| {
            if any_case {
                text.eq_ignore_ascii_case(name)
            } else {
                text == name
            }
        };
        if is("ZEnableReset") {
            tracing::warn!("simulated instrument: reset commands enabled (a driver should never send Z…)");
            self.state.reset_enabled = true;
            let style = self.sw.status_style;
            self.unit
                .write(&wire::format_text_report("Reset Commands Enabled", style));
            return Some(Next::Continue);
        }
        if !(is("ZResetPreferences") || is("ZResetSetup")) {
            return None;
        }
        if !self.state.reset_enabled {
            tracing::info!(command = text, "simulated instrument: reset refused, not enabled");
            self.status_reply(-1000);
            return Some(Next::Continue);
        }
        self.unit.switch_off(text);
        Some(Next::Unplugged)
    }

    /// One `S⟨letter⟩⟨value⟩`: the status to answer (section 5, 7).
    fn set(&mut self, args: &str) -> i32 {
        let (letter, value) = args.split_at(args.chars().next().map_or(0, char::len_utf8));
        let Ok(v) = value.trim().parse::<u32>() else {
            return -1001;
        };
        let pr670 = self.sw.model == Model::Pr670;
        match letter {
            "U" if v <= 1 => self.state.setup.si_units = v == 1,
            "U" => return -1009,
            "E" if v == 0 || self.sw.model.exposure_range_ms().contains(&v) => {
                self.state.setup.exposure_ms = v;
                self.unit.shared().integration_ms = v;
            }
            "E" => return -1010,
            "N" if (1..=99).contains(&v) => self.state.setup.cycles = v,
            "N" => return -1012,
            "O" if v == 2 || v == 10 => self.state.setup.observer = v,
            "O" => return -1015,
            "S" if matches!(v, 0 | 1 | 3) => self.state.setup.sync = v,
            "S" => return -1019,
            "K" if (20..=400).contains(&v) => self.state.setup.user_sync_hz = v,
            "K" => return -1023,
            "F" | "H" | "G" | "D" if !pr670 => return -1035,
            "F" if v <= 3 => {}
            "F" => return -1008,
            "H" if v <= 1 => {}
            "H" => return -1026,
            "G" if v <= 3 => {}
            "G" => return -1011,
            "D" if v <= 1 => self.state.setup.smart_dark = v == 1,
            "D" => return -1017,
            _ => return -1000,
        }
        0
    }
}

impl Firmware for Device {
    fn unit(&mut self) -> &mut Unit {
        &mut self.unit
    }

    fn power_on(&mut self) {
        self.state = PowerOnState::default();
    }

    fn byte(&mut self, b: u8, burst: bool) -> Next {
        self.receive(b, burst)
    }

    fn forget_line(&mut self) {
        self.state.line.clear();
    }

    /// A dead link ignores every read whole, until power-cycled.
    fn listening(&mut self) -> bool {
        !self.unit.shared().link_dead
    }
}
