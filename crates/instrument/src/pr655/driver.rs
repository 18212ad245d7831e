//! A PR-655/PR-670 session: open the USB serial port, enter remote mode,
//! identify, set up, and take single samples as `M5` (measure, send the
//! spectrum) followed by `D2` (the same measurement's XYZ). The averaging
//! loop above it is [`crate::averaging`], shared by every model.
//!
//! Practice from `docs/src/instruments/pr655-670-protocol.md` that this follows:
//! - remote mode as the working clients enter it (section 0): `Q` first on
//!   the PR-670 (it answers `PHOTO` only once), then `P`,`H`,`O`,`T`,`O` as
//!   five separate writes with no terminator, then the 12-byte banner
//!   ` REMOTE MODE`, read until 12 bytes or idle since it has no line end;
//! - the unit is identified before it is trusted (11.5): `D111` must name
//!   the model the settings file names, then `D110` (serial), `D114`
//!   (firmware), `D120` (grid) and `D602` (setup, logged);
//! - the input buffer is flushed before every command; commands end in CR;
//! - an error status comes alone (3.2): a sample with that code and no
//!   spectrum, never stale data;
//! - values stay per nm on the native grid (8.2), never multiplied by the step;
//! - only `M5` waits for a whole measurement; every other command waits
//!   `command_timeout_ms` for its first byte, and a reply that stops
//!   mid-way is cut off after `gap_timeout_ms`. After a link fault the port
//!   is resynchronised (drain, `D111` ping, drain: the shared [`Session`]'s
//!   exchange and resynchronisation, as the PR-650's), so a dead link is
//!   reported [`InstrumentError::Unresponsive`] within `gap + resync quiet +
//!   command timeout` of its last byte (5.2 s with the shipped settings).
//!   The ping waits a whole measurement only after an `M5` that was
//!   cancelled or timed out, when the unit may still be measuring;
//! - `Q` leaves remote mode when the session ends.

use std::time::{Duration, SystemTime};

use crate::link::{Ping, Request, Session};
use crate::{Identity, InstrumentError, QualityCode, QualityKind, Sample, Spectroradiometer};
use lightbooth_science::spectrum::{SpectralUnit, Spectrum};
use tokio_util::sync::CancellationToken;

use super::codes;
use super::protocol::{self, Command, ProtocolError, SetupParam};
use super::{Model, Pr655Settings};

/// How long the PR-670 is left alone after `Q` before `PHOTO` (PTB: 0.5 s).
const AFTER_QUIT: Duration = Duration::from_millis(500);

/// What the session needs to know of a PR-655/670 command: `M⟨code⟩`
/// measures, and a spectrum's length follows its first line's status.
impl Request for Command {
    fn text(&self) -> String {
        Command::text(self)
    }

    fn measures(&self) -> bool {
        matches!(self, Command::Measure(_))
    }

    fn reply_lines(&self, first_line: &[u8], grid_len: usize) -> usize {
        Command::reply_lines(self, first_line, grid_len)
    }
}

/// A connected PR-655 or PR-670 in remote mode.
pub struct Pr655 {
    session: Session,
    settings: Pr655Settings,
    model: Model,
    /// Whether `SS1` is on (sync found by `F`).
    synced: bool,
}

impl Pr655 {
    /// Opens `port`, enters remote mode, identifies the unit and sends the setup.
    pub fn open(port: &str, settings: &Pr655Settings) -> Result<Pr655, InstrumentError> {
        settings.validate().map_err(InstrumentError::Settings)?;
        let model = settings.model();
        let identity = Identity::new(settings.capabilities(), codes::quality_hint);
        let name = model.name();
        let ping = Ping {
            command: Command::Report(protocol::REPORT_MODEL).text(),
            is_answer: Box::new(move |line| matches!(protocol::parse_text_report(line), Ok(Ok(ref m)) if m == name)),
        };
        let session = Session::open(port, &settings.link(), settings.timing(), identity, ping)?;
        let mut unit = Pr655 {
            session,
            settings: settings.clone(),
            model,
            synced: false,
        };
        unit.enter_remote_mode()?;
        unit.identify()?;
        unit.send_setup()?;
        let info = unit.session.info();
        tracing::info!(port, model = %info.model, serial = ?info.serial,
            firmware = ?info.firmware, grid = %info.grid, "instrument ready");
        Ok(unit)
    }

    /// Section 0 steps 2–4.
    fn enter_remote_mode(&mut self) -> Result<(), InstrumentError> {
        let quiet = self.session.timing().resync_quiet;
        if self.settings.quit_before_entry() {
            tracing::info!(
                model = self.model.name(),
                "sending Q before PHOTO (the unit answers PHOTO only once)"
            );
            self.session.link().send_bytes_singly(b"Q", Duration::ZERO)?;
            std::thread::sleep(AFTER_QUIT);
        }
        let attempts = self.settings.remote_mode_attempts;
        let mut last_reply: Option<Vec<u8>> = None;
        for attempt in 1..=attempts {
            self.session.drain()?;
            let link = self.session.link();
            link.flush_input()?;
            tracing::info!(attempt, attempts, "PHOTO: entering remote mode");
            link.send_bytes_singly(
                &protocol::REMOTE_ENTRY,
                Duration::from_millis(self.settings.remote_entry_delay_ms),
            )?;
            match link.read_unterminated(
                "PHOTO",
                protocol::BANNER.len(),
                Duration::from_millis(self.settings.banner_timeout_ms),
                quiet,
                &CancellationToken::new(),
            ) {
                Ok(reply) if protocol::is_banner(&reply) => {
                    // A CR LF after the banner (as on the PR-705) must not be taken as a reply.
                    self.session.drain()?;
                    tracing::info!(attempt, "in remote mode");
                    return Ok(());
                }
                Ok(reply) => {
                    tracing::warn!(attempt, reply = %String::from_utf8_lossy(&reply).escape_debug(), "not the banner");
                    last_reply = Some(reply);
                }
                Err(InstrumentError::Timeout { .. }) => tracing::warn!(attempt, "no banner"),
                Err(e) => return Err(e),
            }
        }
        match last_reply {
            Some(reply) => Err(InstrumentError::Protocol {
                command: "PHOTO".into(),
                detail: protocol::parse_banner(&reply)
                    .err()
                    .map(|e| e.to_string())
                    .unwrap_or_default(),
            }),
            None => Err(InstrumentError::NoBanner {
                model: self.model.name(),
                attempts,
                waited_ms: self.settings.banner_timeout_ms,
            }),
        }
    }

    /// A one-line text report; an error status is a typed refusal.
    fn text_report(&mut self, code: u16) -> Result<String, InstrumentError> {
        let command = Command::Report(code);
        match self
            .session
            .query(&command, &CancellationToken::new(), protocol::parse_text_report)?
        {
            Ok(text) => Ok(text),
            Err(status) => Err(InstrumentError::Refused {
                command: command.text(),
                code: codes::quality_code(status),
            }),
        }
    }

    /// `D111` must name the configured model (11.5: a wrong port may answer
    /// anything); `D110`, `D114`, `D120` and `D602` are informative.
    fn identify(&mut self) -> Result<(), InstrumentError> {
        let name = self.text_report(protocol::REPORT_MODEL)?;
        match Model::from_name(&name) {
            Some(found) if found == self.model => {}
            Some(found) => {
                return Err(InstrumentError::Settings(format!(
                    "the instrument on this port says it is a {}, but the settings file is for the {}: \
                     use instruments/{}.toml",
                    found.name(),
                    self.model.name(),
                    found.name().to_ascii_lowercase().replace('-', "")
                )))
            }
            None => {
                return Err(InstrumentError::Protocol {
                    command: "D111".into(),
                    detail: format!(
                        "the model reply `{}` is neither PR-655 nor PR-670; is this the instrument's port?",
                        name.escape_debug()
                    ),
                })
            }
        }
        // PTB keeps the first 8 characters of a serial that "may contain trailing blanks".
        match self.text_report(protocol::REPORT_SERIAL) {
            Ok(serial) => {
                self.session.info_mut().serial = Some(serial.chars().take(8).collect::<String>().trim().to_string())
            }
            Err(e) => tracing::warn!(error = %e, "no serial number"),
        }
        match self.text_report(protocol::REPORT_FIRMWARE) {
            Ok(version) => self.session.info_mut().firmware = Some(version),
            Err(e) => tracing::warn!(error = %e, "no firmware version"),
        }
        let command = Command::Report(protocol::REPORT_HARDWARE);
        let timeout = self.session.timing().command;
        match self.session.exchange(&command, timeout, &CancellationToken::new()) {
            Ok(reply) => {
                let grid = &self.session.info().grid;
                match protocol::parse_hardware_config(&reply) {
                    Ok(Ok(config)) if config.grid().as_ref() == Some(grid) => {
                        tracing::info!(grid = %grid, "hardware configuration confirms the native grid")
                    }
                    // The grid is confirmed by every client (8, [C]); report 120 only by the manual.
                    Ok(Ok(config)) => tracing::warn!(?config, grid = %grid,
                        "report 120 disagrees with the model's grid; keeping the model's"),
                    Ok(Err(status)) => tracing::warn!(status, "no hardware configuration"),
                    Err(e) => tracing::warn!(error = %e, "unreadable hardware configuration"),
                }
            }
            Err(e) => tracing::warn!(error = %e, "no hardware configuration"),
        }
        match self.text_report(protocol::REPORT_SETUP_TEXT) {
            Ok(_) => {}
            Err(e) => tracing::warn!(error = %e, "no setup report"),
        }
        self.session.resync_if_needed(&CancellationToken::new())
    }

    /// One setup command; a non-zero status is a typed refusal.
    fn set(&mut self, param: SetupParam, cancel: &CancellationToken) -> Result<(), InstrumentError> {
        let command = Command::Setup(param);
        let status = self.session.query(&command, cancel, protocol::parse_status_reply)?;
        tracing::info!(setup = %command.text(), status, "setup");
        if status != 0 {
            return Err(InstrumentError::Refused {
                command: command.text(),
                code: codes::quality_code(status),
            });
        }
        Ok(())
    }

    /// SI units, the exposure, one cycle per measurement (lightbooth
    /// averages itself and keeps every sample), the 2° observer, sync.
    fn send_setup(&mut self) -> Result<(), InstrumentError> {
        let cancel = CancellationToken::new();
        self.set(SetupParam::Units(1), &cancel)?;
        self.set(SetupParam::Exposure(self.settings.exposure_ms), &cancel)?;
        self.set(SetupParam::Cycles(1), &cancel)?;
        self.set(SetupParam::Observer(2), &cancel)?;
        self.set(SetupParam::Sync(0), &cancel)?;
        if self.settings.sync {
            // PTB and BrainardLab: `F` first, `SS1` only when it found a frequency.
            let command = Command::SyncFrequency;
            let reply = self
                .session
                .exchange(&command, self.session.timing().measure, &cancel)?;
            match protocol::parse_sync_frequency(&reply) {
                Ok((_, Some(hz))) => {
                    tracing::info!(hz, "source flicker found; measuring with sync");
                    self.set(SetupParam::Sync(1), &cancel)?;
                    self.synced = true;
                }
                Ok((status, None)) => tracing::info!(status, "no sync frequency; measuring without sync"),
                Err(e) => return Err(self.session.protocol_error(&command.text(), &e)),
            }
        }
        Ok(())
    }

    /// `D2` of the measurement whose good spectrum `M5` just sent: its Y.
    fn read_luminance(&mut self, cancel: &CancellationToken) -> Result<f64, InstrumentError> {
        let d2 = Command::Report(protocol::REPORT_XYZ);
        // The spectrum came with a good status: an error to `D2` of the
        // same measurement means the link or the unit is confused.
        let xyz = self.session.query(&d2, cancel, |reply| {
            protocol::parse_xyz_report(reply)?.map_err(|status| ProtocolError::Malformed {
                line: 1,
                text: protocol::format_status(status, protocol::StatusStyle::FiveDigits),
                expected: "the XYZ of the measurement whose spectrum just came",
            })
        })?;
        Ok(xyz.y)
    }

    /// A measurement's error status, typed. With auto sync on, −1 ("light
    /// source not constant") is the unit failing to sync, as PTB's
    /// `PR670measspd` reads it (sheet 7, 13.9): typed as a sync failure, so
    /// the advice is the sync advice and [`Spectroradiometer::after_bad_sample`]
    /// turns sync off.
    fn measurement_code(&self, status: i32) -> QualityCode {
        let code = codes::quality_code(status);
        if self.synced && status == -1 {
            return QualityCode {
                kind: QualityKind::Sync,
                message: format!("{} (auto sync could not lock to it)", code.message),
                ..code
            };
        }
        code
    }
}

impl Drop for Pr655 {
    /// Leaves remote mode (`Q`, no reply), so the unit's own keys work again.
    fn drop(&mut self) {
        if let Err(e) = self.session.link().send_bytes_singly(b"Q", Duration::ZERO) {
            tracing::debug!(error = %e, "could not send Q on closing");
        }
    }
}

impl Spectroradiometer for Pr655 {
    fn identity(&self) -> &Identity {
        self.session.identity()
    }

    fn take_sample(&mut self, index: usize, cancel: &CancellationToken) -> Result<Sample, InstrumentError> {
        // One measurement: `M5` (the spectrum), then `D2` of the same measurement.
        let m5 = Command::Measure(protocol::REPORT_SPECTRUM);
        let reply = self.session.measure(&m5, cancel)?;
        let time = SystemTime::now();
        let report = match protocol::parse_spectral_report(&reply, &self.session.info().grid) {
            Ok(Ok(report)) => report,
            Ok(Err(status)) => {
                let code = self.measurement_code(status);
                tracing::info!(index, code = code.code, kind = ?code.kind, "sample with an error status");
                return Ok(Sample {
                    index,
                    time,
                    code,
                    radiance: None,
                    luminance: None,
                    instrument_xyz: None,
                });
            }
            Err(e) => return Err(self.session.protocol_error(&m5.text(), &e)),
        };
        let grid = self.session.info().grid.clone();
        let spectrum = Spectrum::new(grid, SpectralUnit::SpectralRadiance, report.values).map_err(|e| {
            InstrumentError::Protocol {
                command: m5.text(),
                detail: e.to_string(),
            }
        })?;
        let luminance = Some(self.read_luminance(cancel)?);
        tracing::info!(index, luminance_cd_m2 = ?luminance, "sample");
        Ok(Sample {
            index,
            time,
            code: codes::quality_code(0),
            radiance: Some(spectrum),
            luminance,
            instrument_xyz: None,
        })
    }

    /// PTB: after a sync failure with sync on, measure without sync from now on.
    fn after_bad_sample(&mut self, code: &QualityCode, cancel: &CancellationToken) -> Result<(), InstrumentError> {
        let sync_failure = code.kind == QualityKind::Sync || code.code == -1;
        if sync_failure && self.synced {
            tracing::info!(code = code.code, "sync failed; turning sync off");
            self.set(SetupParam::Sync(0), cancel)?;
            self.synced = false;
        }
        Ok(())
    }
}
