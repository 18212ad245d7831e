//! The simulated PR-655/PR-670's firmware: the byte-level state machine on
//! the master end of the pty, after `docs/src/instruments/pr655-670-protocol.md`.
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
//! - A measurement takes the sheet's 13.7 time (`Timing`): a base time,
//!   sync detection under `SS1`, and each cycle's exposure and dark exposure
//!   (smart dark skips repeated darks); `SS1`/`SS3` round the exposure up to
//!   whole periods of the source. [`super::MockHandle::last_measurement_ms`]
//!   reports it; the simulator sleeps it times [`MockConfig::speed`].
//! - Reports 1–7 (but 5 is the spectrum), 11, 12, 13, 14, 110, 111, 114,
//!   116, 117, 120, 601 and 602 are computed from one stored measurement and
//!   setup, so the views agree (section 6). Report 11, the scotopic
//!   luminance, weights the reported spectrum with the CIE 1951 V′(λ) table
//!   embedded beside this file (`cie1951_scotopic_1nm.csv`, provenance in its
//!   header). Not simulated: 8/9 (raw detector counts), the RAM and SD card
//!   reports and recalls (`R`, 401–412); they answer `-2000` or `-1000`.
//! - `ZEnableReset` arms the resets; `ZResetPreferences` and `ZResetSetup`
//!   then switch the unit off (4, 11.14): no reply, the simulator stops and
//!   the pty closes, as a USB device vanishes. Unarmed, they get `-1000`.

use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use serialport::{SerialPort, TTYPort};

use super::model::Rng;
use super::{lock, BusyInput, Fault, FaultKind, MockConfig, Shared};
use crate::colorimetry::{xyz_from_radiance, Observer};
use crate::instrument::pr655::protocol::{self as wire, LineStyle, Model, StatusStyle};
use crate::spectrum::{SpectralUnit, Spectrum};

use super::firmware::POLL;

/// What a stray CR or LF right after `PHOTO` produces (13.2, 12.3).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum StrayTerminator {
    #[default]
    Ignore,
    /// An empty CR LF line.
    EmptyLine,
    /// `-1000` (illegal command).
    IllegalCommand,
}

/// What `D⟨code⟩` answers after a failed measurement (12.9, 13.9).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AfterFailure {
    /// The failed measurement's status alone.
    #[default]
    Error,
    /// The last good measurement's data, as the PR-650 does.
    Stale,
    /// `-2000`: no such data.
    NoData,
}

/// The status of an `SS1` (auto sync) measurement of a source the unit
/// cannot sync to (13.9 lists −1 / −10: PTB's `PR670measspd` handles both as
/// a sync failure; the status table reads −10 "cannot auto-sync to the light
/// source" and −1 "light source not constant").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SyncFailure {
    /// −10: cannot auto-sync to the light source.
    #[default]
    CannotAutoSync,
    /// −1: light source not constant.
    NotConstant,
}

impl SyncFailure {
    /// The status the measurement ends with.
    pub fn status(self) -> i32 {
        match self {
            SyncFailure::CannotAutoSync => -10,
            SyncFailure::NotConstant => -1,
        }
    }
}

/// The behaviours of section 13 the sources disagree on, each selectable.
#[derive(Clone, Debug, PartialEq, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Pr655Switches {
    /// 13.1: which model (grid, exposure range, PR-670-only setup commands).
    pub model: Model,
    /// 13.2: `PHOTO` letters count only when each arrives in its own read
    /// (off by default: a real unit answers PsychoPy, whose letters arrive
    /// with no pause between them, §1).
    pub strict_photo: bool,
    /// 13.2: time from the last `O` to the banner, ms of wall time (not
    /// scaled by speed, so a late banner, 13.10, is late at any speed).
    pub banner_latency_ms: u64,
    /// 13.10: no banner at all (the unit does not answer `PHOTO`).
    pub no_banner: bool,
    /// 13.2: a stray CR/LF after `PHOTO`.
    pub stray_terminator: StrayTerminator,
    /// 13.2: a second `PHOTO` while in remote mode gets no banner (the PR-670's way).
    pub photo_only_once: bool,
    /// 13.4: LF ends a command as well as CR (on by default: a real unit
    /// answers PsychoPy's LF-terminated commands, §1).
    pub accept_lf: bool,
    /// 13.4: lower-case commands are accepted.
    pub case_insensitive: bool,
    /// 13.5: `00000`/`-0008` or `0000`/`-8`.
    pub status_style: StatusStyle,
    /// 13.8: the 16th byte of a spectral line.
    pub line_style: LineStyle,
    /// 13.9: `D` after a failed measurement.
    pub after_failure: AfterFailure,
    /// The status of an [`FaultKind::ErrorCode`] measurement (13.9: −8, −2, −1, −10, −12).
    pub error_status: i32,
    /// 13.9: what an `SS1` measurement of an unsyncable source ends with.
    pub sync_failure: SyncFailure,
    /// 13.7: the time auto sync (`SS1`) spends finding the source's
    /// frequency before each measurement, ms at speed 1. No source gives it
    /// (9: durations are undocumented); the default, 1000 ms, is a simulator
    /// choice: twenty periods at the slowest syncable frequency (20 Hz, 7).
    pub sync_detection_ms: u64,
    /// What `D114` answers.
    pub firmware: String,
}

impl Default for Pr655Switches {
    fn default() -> Pr655Switches {
        Pr655Switches::for_model(Model::Pr655)
    }
}

impl Pr655Switches {
    /// The defaults for `model` (a PR-670 answers `PHOTO` once): section
    /// 13's first choices, but `PHOTO` in any pacing and LF-terminated
    /// commands accepted, as real units accept them (section 1).
    pub fn for_model(model: Model) -> Pr655Switches {
        Pr655Switches {
            model,
            strict_photo: false,
            banner_latency_ms: 300,
            no_banner: false,
            stray_terminator: StrayTerminator::Ignore,
            photo_only_once: model == Model::Pr670,
            accept_lf: true,
            case_insensitive: false,
            status_style: StatusStyle::FiveDigits,
            line_style: LineStyle::TrailingSpace,
            after_failure: AfterFailure::Error,
            error_status: -8,
            sync_failure: SyncFailure::CannotAutoSync,
            sync_detection_ms: 1000,
            firmware: "2.22D".into(),
        }
    }
}

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
fn scotopic_efficiency(grid: &crate::spectrum::Grid) -> Vec<f64> {
    static TABLE: std::sync::OnceLock<Spectrum> = std::sync::OnceLock::new();
    let v_prime = TABLE.get_or_init(|| {
        crate::spectrum::table::SpectraTable::parse(
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
fn scotopic_luminance(grid: &crate::spectrum::Grid, radiance: &[f64]) -> f64 {
    let step = grid.step_nm().unwrap_or(1.0);
    let weighted: f64 = scotopic_efficiency(grid).iter().zip(radiance).map(|(v, l)| v * l).sum();
    SCOTOPIC_KM_LM_PER_W * weighted * step
}

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
    port: Option<TTYPort>,
    /// The device end kept open so the pty survives the host closing and reopening it.
    keepalive: Option<TTYPort>,
    shared: Arc<Mutex<Shared>>,
    stop: Arc<AtomicBool>,
    rng: Rng,
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

/// The frequencies sync can lock to (7, −3: "below 20 Hz, above 400 Hz").
const SYNC_RANGE_HZ: std::ops::RangeInclusive<f64> = 20.0..=400.0;

/// Where the time of one `M⟨code⟩` goes, ms at speed 1: section 13.7's
/// model, "a configurable base time, plus cycles × (exposure + dark exposure
/// unless smart dark applies), plus sync detection when `SS1`". Each dark
/// exposure is as long as the exposure (the shutter closes for a dark reading
/// of the same integration, 9). The transfer of the reply is not included
/// (USB speed, 9).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Timing {
    /// Shutter moves and computation, once per measurement ([`super::model::InstrumentModel::base_time_ms`]).
    base_ms: f64,
    /// `SS1`: finding the source's frequency ([`Pr655Switches::sync_detection_ms`]).
    sync_detection_ms: f64,
    /// One cycle's exposure, after sync a whole number of the source's periods.
    exposure_ms: f64,
    /// Exposures taken (`SN`); none when auto sync failed.
    cycles: u32,
    /// Dark exposures taken: one per cycle, or with smart dark one only when
    /// the exposure differs from the last dark's, else none.
    darks: u32,
}

impl Timing {
    fn total_ms(&self) -> f64 {
        self.base_ms + self.sync_detection_ms + f64::from(self.cycles + self.darks) * self.exposure_ms
    }
}

/// `SS1`/`SS3` set the exposure "to a whole number of periods" (5, `SS`):
/// the next whole number up, at least one period, at most as many as fit the
/// model's longest exposure.
fn synced_exposure_ms(exposure_ms: f64, hz: f64, max_ms: f64) -> f64 {
    let period_ms = 1000.0 / hz;
    // 1e-9: an exposure that already is whole periods stays as it is.
    let periods = (exposure_ms / period_ms - 1e-9).ceil().max(1.0);
    let most = (max_ms / period_ms).floor().max(1.0);
    periods.min(most) * period_ms
}

/// What a handler wants next.
enum Next {
    Continue,
    /// A measurement ended; bytes received meanwhile are handled per [`BusyInput`].
    AfterMeasurement,
    Unplugged,
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
        let rng = Rng::new(cfg.seed);
        Device {
            cfg,
            sw,
            port: Some(port),
            keepalive: Some(keepalive),
            shared,
            stop,
            rng,
            remote: false,
            photo: 0,
            just_entered: false,
            echo: false,
            reset_enabled: false,
            line: Vec::new(),
            setup: Setup::default(),
            last: None,
            last_good: None,
            last_dark_exposure_ms: None,
        }
    }

    fn power_on(&mut self) {
        tracing::info!(model = self.sw.model.name(), "simulated instrument: power cycle");
        self.remote = false;
        self.photo = 0;
        self.just_entered = false;
        self.echo = false;
        self.reset_enabled = false;
        self.line.clear();
        self.setup = Setup::default();
        self.last = None;
        self.last_good = None;
        self.last_dark_exposure_ms = None;
        let mut shared = lock(&self.shared);
        shared.integration_ms = 0;
        shared.link_dead = false;
    }

    pub(super) fn run(mut self) {
        let mut buf = [0u8; 256];
        while !self.stop.load(Ordering::Relaxed) {
            if std::mem::take(&mut lock(&self.shared).power_cycle_requested) {
                self.power_on();
            }
            let Some(port) = self.port.as_mut() else { break };
            let _ = port.set_timeout(POLL);
            let n = match port.read(&mut buf) {
                Ok(n) => n,
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => continue,
                Err(e) => {
                    tracing::debug!(error = %e, "simulated instrument: read failed");
                    std::thread::sleep(POLL);
                    continue;
                }
            };
            if std::mem::take(&mut lock(&self.shared).power_cycle_requested) {
                self.power_on();
            }
            if lock(&self.shared).link_dead {
                continue; // silent until power-cycled
            }
            let burst = n > 1;
            let mut i = 0;
            while i < n {
                match self.byte(buf[i], burst) {
                    Next::Continue => i += 1,
                    Next::AfterMeasurement => {
                        i += 1;
                        if self.cfg.busy_input == BusyInput::Drop {
                            i = n;
                            if let Some(port) = self.port.as_mut() {
                                let _ = port.clear(serialport::ClearBuffer::Input);
                            }
                            self.line.clear();
                        }
                    }
                    Next::Unplugged => return,
                }
            }
        }
    }

    /// Feeds one byte of `PHOTO`; true when it completed the sequence.
    fn photo_byte(&mut self, b: u8, burst: bool) -> bool {
        if self.sw.strict_photo && burst {
            self.photo = 0;
            return false;
        }
        let b = if self.sw.case_insensitive {
            b.to_ascii_uppercase()
        } else {
            b
        };
        if b == wire::REMOTE_ENTRY[self.photo] {
            self.photo += 1;
        } else {
            self.photo = usize::from(b == wire::REMOTE_ENTRY[0]);
        }
        if self.photo == wire::REMOTE_ENTRY.len() {
            self.photo = 0;
            return true;
        }
        false
    }

    fn byte(&mut self, b: u8, burst: bool) -> Next {
        if !self.remote {
            // 13.3: local mode ignores everything but PHOTO.
            tracing::trace!(byte = %(b as char).escape_debug(), burst, "simulated instrument in local mode");
            if self.photo_byte(b, burst) {
                self.enter_remote();
            }
            return Next::Continue;
        }
        if self.echo {
            self.write(&[b]);
        }
        let just_entered = std::mem::take(&mut self.just_entered);
        let ends_line = b == b'\r' || (b == b'\n' && self.sw.accept_lf);
        if ends_line || b == b'\n' {
            if just_entered && self.line.is_empty() {
                match self.sw.stray_terminator {
                    StrayTerminator::Ignore => {}
                    StrayTerminator::EmptyLine => self.write(b"\r\n"),
                    StrayTerminator::IllegalCommand => self.status_reply(-1000),
                }
                return Next::Continue;
            }
            if !ends_line || self.line.is_empty() {
                return Next::Continue; // the LF of CR LF, or an LF that does not end commands
            }
            let line = std::mem::take(&mut self.line);
            let next = self.command(&line);
            if self.echo {
                self.write(b">");
            }
            return next;
        }
        if self.line.len() < 256 {
            self.line.push(b);
        }
        // `Q` needs no terminator (2.2); `PHOTO` again comes without one (13.2).
        let upper = self.line.to_ascii_uppercase();
        let upper = if self.sw.case_insensitive {
            upper
        } else {
            self.line.clone()
        };
        if upper == b"Q" {
            self.line.clear();
            tracing::info!("simulated instrument: Q, back to local mode");
            self.remote = false;
            self.photo = 0;
        } else if upper == wire::REMOTE_ENTRY && !(self.sw.strict_photo && burst) {
            self.line.clear();
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
        self.sleep_ms(self.sw.banner_latency_ms as f64);
        self.write(wire::BANNER);
        self.remote = true;
        self.just_entered = true;
        self.line.clear();
        tracing::info!(model = self.sw.model.name(), "simulated instrument in remote mode");
    }

    fn status_reply(&mut self, status: i32) {
        let bytes = wire::format_status_reply(status, self.sw.status_style);
        self.write(&bytes);
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
                    let status = self.last.as_ref().map_or(0, |s| s.status);
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
            "F" => match self.cfg.flicker_hz.filter(|hz| SYNC_RANGE_HZ.contains(hz)) {
                Some(hz) => {
                    let reply = format!(
                        "{},{hz:.2} Hertz (Period = {:.0} milliseconds)\r\n",
                        wire::format_status(0, self.sw.status_style),
                        1000.0 / hz
                    );
                    self.write(reply.as_bytes());
                }
                None => self.status_reply(-3),
            },
            "I" => self.status_reply(0),
            "E" => {
                tracing::warn!("simulated instrument: echo on (a driver should never send E)");
                self.echo = true;
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
            self.reset_enabled = true;
            let style = self.sw.status_style;
            self.write(&wire::format_text_report("Reset Commands Enabled", style));
            return Some(Next::Continue);
        }
        if !(is("ZResetPreferences") || is("ZResetSetup")) {
            return None;
        }
        if !self.reset_enabled {
            tracing::info!(command = text, "simulated instrument: reset refused, not enabled");
            self.status_reply(-1000);
            return Some(Next::Continue);
        }
        self.switch_off(text);
        Some(Next::Unplugged)
    }

    /// The USB device vanishes (the unit switched off, or its cable pulled):
    /// both ends of the pty close and the simulator stops.
    fn switch_off(&mut self, why: &str) {
        tracing::info!(why, "simulated instrument: the USB device vanishes");
        lock(&self.shared).unplugged = true;
        self.port = None;
        self.keepalive = None;
    }

    /// One `S⟨letter⟩⟨value⟩`: the status to answer (section 5, 7).
    fn set(&mut self, args: &str) -> i32 {
        let (letter, value) = args.split_at(args.chars().next().map_or(0, char::len_utf8));
        let Ok(v) = value.trim().parse::<u32>() else {
            return -1001;
        };
        let pr670 = self.sw.model == Model::Pr670;
        match letter {
            "U" if v <= 1 => self.setup.si_units = v == 1,
            "U" => return -1009,
            "E" if v == 0 || self.sw.model.exposure_range_ms().contains(&v) => {
                self.setup.exposure_ms = v;
                lock(&self.shared).integration_ms = v;
            }
            "E" => return -1010,
            "N" if (1..=99).contains(&v) => self.setup.cycles = v,
            "N" => return -1012,
            "O" if v == 2 || v == 10 => self.setup.observer = v,
            "O" => return -1015,
            "S" if matches!(v, 0 | 1 | 3) => self.setup.sync = v,
            "S" => return -1019,
            "K" if (20..=400).contains(&v) => self.setup.user_sync_hz = v,
            "K" => return -1023,
            "F" | "H" | "G" | "D" if !pr670 => return -1035,
            "F" if v <= 3 => {}
            "F" => return -1008,
            "H" if v <= 1 => {}
            "H" => return -1026,
            "G" if v <= 3 => {}
            "G" => return -1011,
            "D" if v <= 1 => self.setup.smart_dark = v == 1,
            "D" => return -1017,
            _ => return -1000,
        }
        0
    }

    /// The frequency auto sync (`SS1`) locks to: the source's flicker when it
    /// is in 20–400 Hz (7, −3). None for a steady source (no period to find:
    /// a simulator choice, the sheet leaves `SS1` on a steady source open,
    /// 12.10), one outside that band, or one marked [`MockConfig::unsyncable`].
    fn auto_sync_hz(&self) -> Option<f64> {
        if self.cfg.unsyncable {
            return None;
        }
        self.cfg.flicker_hz.filter(|hz| SYNC_RANGE_HZ.contains(hz))
    }

    /// One measurement, taking [`Timing::total_ms`] scaled by the speed.
    /// Returns false if the cable was pulled.
    fn measure(&mut self) -> bool {
        let truth = lock(&self.shared).truth_1nm.clone();
        let model = &self.cfg.model;
        let mut reading = match model.reading(&truth, self.setup.exposure_ms) {
            Ok(r) => r,
            Err(e) => {
                tracing::error!(error = %e, "simulated instrument: cannot model the target");
                return true;
            }
        };
        let auto_sync = self.setup.sync == 1;
        let lock_hz = match self.setup.sync {
            1 => self.auto_sync_hz(),
            3 => Some(f64::from(self.setup.user_sync_hz)),
            _ => None,
        };
        let sync_failed = auto_sync && lock_hz.is_none();
        let mut exposure_ms = reading.integration_ms;
        if let Some(hz) = lock_hz {
            let longest = f64::from(*self.sw.model.exposure_range_ms().end());
            exposure_ms = synced_exposure_ms(reading.integration_ms, hz, longest);
            // The detector model takes whole milliseconds; the timing keeps the exact periods.
            match model.reading(&truth, exposure_ms.round().max(1.0) as u32) {
                Ok(r) => reading = r,
                Err(e) => tracing::error!(error = %e, "simulated instrument: cannot model the target"),
            }
        }
        let cycles = if sync_failed { 0 } else { self.setup.cycles.max(1) };
        let darks = if cycles == 0 {
            0
        } else if self.setup.smart_dark {
            u32::from(self.last_dark_exposure_ms != Some(exposure_ms))
        } else {
            cycles
        };
        let timing = Timing {
            base_ms: model.base_time_ms,
            sync_detection_ms: if auto_sync {
                self.sw.sync_detection_ms as f64
            } else {
                0.0
            },
            exposure_ms,
            cycles,
            darks,
        };
        let total_ms = timing.total_ms();
        tracing::debug!(?timing, total_ms, sync_hz = ?lock_hz, "simulated measurement time");
        if self.fires(FaultKind::CablePull) {
            self.sleep_scaled(total_ms / 2.0);
            self.switch_off("USB cable pulled");
            return false;
        }
        lock(&self.shared).last_measurement_ms = Some(total_ms);
        self.sleep_scaled(total_ms);
        if darks > 0 {
            self.last_dark_exposure_ms = Some(exposure_ms);
        }
        let mut status = match reading.code {
            0 => 0,
            19 => -2,
            _ => -8,
        };
        if sync_failed {
            tracing::info!(
                status = self.sw.sync_failure.status(),
                "simulated instrument: cannot auto-sync"
            );
            status = self.sw.sync_failure.status();
        }
        if self.fires(FaultKind::ErrorCode) {
            status = self.sw.error_status;
        }
        let stored = if status == 0 {
            // Averaging `cycles` readings divides the noise by √cycles.
            let cycles = f64::from(self.setup.cycles.max(1));
            let mut values = vec![0.0; reading.expected.len()];
            for _ in 0..self.setup.cycles.max(1) {
                for (acc, v) in values.iter_mut().zip(self.cfg.model.sample(&reading, &mut self.rng)) {
                    *acc += v / cycles;
                }
            }
            let xyz = Spectrum::new(
                self.cfg.model.grid.clone(),
                SpectralUnit::SpectralRadiance,
                values.clone(),
            )
            .ok()
            .and_then(|s| xyz_from_radiance(&s, Observer::Cie1931).ok())
            .map_or([0.0; 3], |x| x.to_array());
            Stored {
                status,
                values,
                xyz,
                exposure_ms,
            }
        } else {
            Stored {
                status,
                values: Vec::new(),
                xyz: [0.0; 3],
                exposure_ms,
            }
        };
        if status == 0 {
            self.last_good = Some(stored.clone());
        }
        self.last = Some(stored);
        lock(&self.shared).measurements += 1;
        true
    }

    /// The measurement report `code` describes: per 13.9 after a failure.
    fn report_source(&self) -> Result<Stored, i32> {
        match (&self.last, self.sw.after_failure) {
            (None, _) => Err(-2000),
            (Some(s), _) if s.status == 0 => Ok(s.clone()),
            (Some(s), AfterFailure::Error) => Err(s.status),
            (Some(_), AfterFailure::NoData) => Err(-2000),
            (Some(s), AfterFailure::Stale) => self.last_good.clone().ok_or(s.status),
        }
    }

    /// Report `code`; `fresh` when it follows this very measurement (`M`),
    /// whose failure is then always its own status.
    fn report(&mut self, code: u16, fresh: bool) {
        let style = self.sw.status_style;
        let model = self.sw.model;
        match code {
            wire::REPORT_SERIAL => return self.write(&wire::format_text_report(&self.cfg.serial.clone(), style)),
            wire::REPORT_MODEL => return self.write(&wire::format_text_report(model.name(), style)),
            wire::REPORT_FIRMWARE => return self.write(&wire::format_text_report(&self.sw.firmware.clone(), style)),
            wire::REPORT_HARDWARE => return self.write(&wire::format_hardware_config(model, style)),
            wire::REPORT_SETUP_TEXT => {
                let s = self.setup;
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
                return self.write(&wire::format_text_report(&text, style));
            }
            // 601: the setup as codes. The PR-670 gets the 16 fields the
            // manual describes, the PR-655 the 13 captured from a real one (6.1).
            601 => {
                let s = self.setup;
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
                return self.write(&wire::format_text_report(&text, style));
            }
            14 => {
                let text = match (self.setup.sync, self.cfg.flicker_hz) {
                    (1, Some(hz)) => format!("Auto Sync,{hz:.2} Hertz"),
                    (3, _) => format!("User Sync,{}.00 Hertz", self.setup.user_sync_hz),
                    _ => "None,0.00 Hertz".to_string(),
                };
                return self.write(&wire::format_text_report(&text, style));
            }
            116 => return self.write(&wire::format_text_report("0,MS-75,Primary,Luminance,Radiance", style)),
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
                return self.write(reply.as_bytes());
            }
            _ => {}
        }
        let source = if fresh {
            match &self.last {
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
        let scale = if self.setup.si_units { 1.0 } else { 1.0 / 3.426_259 };
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
                self.write(format!("{status},0,{lum},{fields}\r\n").as_bytes());
            }
            // 11: scotopic luminance, in the same unit system as Y (8.2).
            11 => {
                let scotopic = scotopic_luminance(&model.grid(), &stored.values) * scale;
                let reply = format!("{status},0,{}\r\n", wire::format_float(scotopic, 2));
                self.write(reply.as_bytes());
            }
            wire::REPORT_XYZ => {
                self.write(&wire::format_xyz_report([x, y, z], style));
                if self.fires(FaultKind::Stale) {
                    // Lands in the host's buffer before its next command.
                    self.write(b"00000,0,5.440e+002,1.8");
                }
            }
            13 => {
                let reply = format!("{status},Normal,{:.0} msec\r\n", stored.exposure_ms);
                self.write(reply.as_bytes());
            }
            wire::REPORT_SPECTRUM => {
                let grid = model.grid();
                let bytes = wire::format_spectral_report(&grid, &stored.values, style, self.sw.line_style);
                let start = bytes.iter().position(|b| *b == b'\n').map_or(0, |i| i + 1);
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
                        tracing::info!("simulated instrument: the link died mid-reply; silent until power-cycled");
                        lock(&self.shared).link_dead = true;
                    }
                }
            }
            _ => self.status_reply(-2000),
        }
    }

    fn fires(&mut self, kind: FaultKind) -> bool {
        self.fired(kind).is_some()
    }

    /// The fault of `kind` that fires now, if any ([`super::firmware::fired`]).
    fn fired(&mut self, kind: FaultKind) -> Option<Fault> {
        super::firmware::fired(&self.shared, &mut self.rng, kind)
    }

    fn sleep_scaled(&self, ms: f64) {
        self.sleep_ms(ms * self.cfg.speed);
    }

    /// Sleeps `ms` of wall time, waking for a stop request.
    fn sleep_ms(&self, ms: f64) {
        super::firmware::sleep_ms(&self.stop, ms)
    }

    /// The whole reply in one burst: USB, not 9600 baud (section 9).
    fn write(&mut self, bytes: &[u8]) {
        let Some(port) = self.port.as_mut() else { return };
        let _ = port.set_timeout(Duration::from_millis(500));
        if let Err(e) = port.write_all(bytes).and_then(|_| port.flush()) {
            tracing::debug!(error = %e, "simulated instrument: host not reading; reply dropped");
            return;
        }
        lock(&self.shared).last_byte_at = Some(Instant::now());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sync rounds the exposure up to whole periods of the source (sheet 5, `SS`).
    #[test]
    fn sync_sets_the_exposure_to_whole_periods_within_the_longest_exposure() {
        let period = 1000.0 / 60.0;
        assert!(
            (synced_exposure_ms(100.0, 60.0, 6000.0) - 100.0).abs() < 1e-9,
            "6 periods already"
        );
        assert!((synced_exposure_ms(101.0, 60.0, 6000.0) - 7.0 * period).abs() < 1e-9);
        assert!(
            (synced_exposure_ms(3.0, 60.0, 6000.0) - period).abs() < 1e-9,
            "at least one period"
        );
        assert!((synced_exposure_ms(5990.0, 20.0, 6000.0) - 6000.0).abs() < 1e-9);
        assert!(
            (synced_exposure_ms(5990.0, 7.0, 6000.0) - 42.0 * 1000.0 / 7.0).abs() < 1e-9,
            "capped"
        );
    }

    /// 13.7: base + sync detection + cycles × exposure + darks × exposure.
    #[test]
    fn measurement_time_is_base_plus_sync_detection_plus_exposures_and_darks() {
        let t = Timing {
            base_ms: 1500.0,
            sync_detection_ms: 1000.0,
            exposure_ms: 50.0,
            cycles: 3,
            darks: 1,
        };
        assert_eq!(t.total_ms(), 1500.0 + 1000.0 + 4.0 * 50.0);
    }
}
