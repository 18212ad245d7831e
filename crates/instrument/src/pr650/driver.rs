//! A PR-650 session: open the port, enter remote mode, set up, identify, and
//! take single samples as `M0` followed by `D5` and `D2` (the averaging loop
//! above it is [`crate::averaging`], shared by every model).
//!
//! Practice from `docs/src/instruments/pr650-protocol.md` §6 that this follows:
//! - remote mode must be entered within ~5 s of power-on; the handshake (`B1`)
//!   is retried, and if it never answers the operator is told to power-cycle;
//! - the input buffer is flushed before every command;
//! - one `M0` measurement is read twice, `D5` (spectrum) and `D2` (XYZ), and
//!   the quality code is taken from those reports, not from the `M0` ack;
//! - on codes 10/18 the spectral buffer is stale: the sample is recorded
//!   without a spectrum and never averaged;
//! - values stay per nm on the 4 nm grid (no multiplying by the step);
//! - after a link fault or a cancel the port is resynchronised (drain, ping,
//!   drain) before the next command, so the session stays usable; the
//!   exchange and the resynchronisation are the shared [`Session`]'s, the
//!   ping here `B1`, answered by `000`;
//! - only `M0` waits for a whole measurement (`measure_timeout_ms`); the
//!   handshake, the reports and the resynchronisation ping wait
//!   `command_timeout_ms`, so a unit that falls silent mid-reply (a cable cut
//!   behind the adapter) is reported [`InstrumentError::Unresponsive`] within
//!   `gap_timeout_ms + resync_quiet_ms + command_timeout_ms` of its last byte
//!   (5.2 s with the shipped settings). The ping waits a whole measurement
//!   only after a cancelled `M0`, when the unit may still be measuring.

use std::time::SystemTime;

use crate::link::{Ping, Request, Session};
use crate::{Identity, InstrumentError, QualityCode, QualityKind, Sample, Spectroradiometer};
use lightbooth_science::spectrum::{SpectralUnit, Spectrum};
use tokio_util::sync::CancellationToken;

use super::codes;
use super::protocol::{self, Command, ProtocolError, Setup, SyncSetting};
use super::Pr650Settings;

/// The PR-650 has no model query; this is what [`crate::InstrumentInfo::model`] says.
pub const MODEL: &str = "PR-650";

/// Backlight level sent as the remote-mode handshake and the
/// resynchronisation ping: low, so the LCD adds little stray light to a dark
/// booth (PTB sends `b3`, djsperka `B1`; both answer `000`).
const HANDSHAKE_BACKLIGHT: u8 = 1;

/// What the session needs to know of a PR-650 command: only `M0` measures,
/// and a reply's length is known before it starts.
impl Request for Command {
    fn text(&self) -> String {
        Command::text(self)
    }

    fn measures(&self) -> bool {
        matches!(self, Command::MeasureAndHold)
    }

    fn reply_lines(&self, _first_line: &[u8], grid_len: usize) -> usize {
        Command::reply_lines(self, grid_len)
    }
}

/// A connected PR-650 in remote mode.
pub struct Pr650 {
    session: Session,
    settings: Pr650Settings,
    setup: Setup,
}

impl Pr650 {
    /// Opens `port`, enters remote mode, sends the setup, and identifies the unit.
    pub fn open(port: &str, settings: &Pr650Settings) -> Result<Pr650, InstrumentError> {
        settings.validate().map_err(InstrumentError::Settings)?;
        let identity = Identity::new(settings.capabilities(), codes::quality_hint);
        let ping = Ping {
            command: Command::Backlight(HANDSHAKE_BACKLIGHT).text(),
            is_answer: Box::new(|line| line.trim_ascii() == b"000"),
        };
        let session = Session::open(port, &settings.link(), settings.timing(), identity, ping)?;
        let mut pr650 = Pr650 {
            session,
            settings: settings.clone(),
            setup: Setup {
                integration_ms: settings.integration_ms,
                ..Setup::default()
            },
        };
        pr650.enter_remote_mode()?;
        pr650.send_setup(&CancellationToken::new())?;
        if settings.sync {
            pr650.find_sync_frequency()?;
        }
        pr650.identify();
        let info = pr650.session.info();
        tracing::info!(port, model = %info.model, serial = ?info.serial, grid = %info.grid, "PR-650 ready");
        Ok(pr650)
    }

    /// §1: the unit answers only if a command arrives within ~5 s of power-on.
    /// Several quick tries help with some USB adapters (PTB's cable note).
    fn enter_remote_mode(&mut self) -> Result<(), InstrumentError> {
        let attempts = self.settings.remote_mode_attempts;
        let ping = Command::Backlight(HANDSHAKE_BACKLIGHT);
        let timeout = self.session.timing().command;
        for attempt in 1..=attempts {
            tracing::info!(attempt, attempts, "PR-650: remote-mode handshake");
            match self.session.exchange(&ping, timeout, &CancellationToken::new()) {
                Ok(reply) => match protocol::parse_ack(&reply) {
                    Ok(status) => {
                        if status != 0 {
                            tracing::warn!(status, "PR-650: unexpected handshake status; continuing");
                        }
                        self.session.in_step();
                        tracing::info!(attempt, "PR-650 in remote mode");
                        return Ok(());
                    }
                    Err(e) => tracing::warn!(attempt, error = %e, "PR-650: garbled handshake reply"),
                },
                Err(e) if e.is_retryable_link_fault() => tracing::warn!(attempt, error = %e, "PR-650: no handshake"),
                Err(e) => return Err(e),
            }
            self.session.drain()?;
        }
        Err(InstrumentError::NotInRemoteMode { attempts })
    }

    fn send_setup(&mut self, cancel: &CancellationToken) -> Result<(), InstrumentError> {
        let command = Command::Setup(self.setup);
        let status = self.session.query(&command, cancel, protocol::parse_setup_status)?;
        tracing::info!(setup = %command.text(), status, "PR-650 setup");
        if status != 0 {
            return Err(InstrumentError::Setup {
                command: command.text(),
                status,
                meaning: codes::setup_status_meaning(status),
            });
        }
        Ok(())
    }

    /// §6.6: `F`; sync on if the unit found a frequency, else off.
    fn find_sync_frequency(&mut self) -> Result<(), InstrumentError> {
        let command = Command::SyncFrequency;
        let reply = self
            .session
            .exchange(&command, self.session.timing().measure, &CancellationToken::new())?;
        match protocol::parse_sync_frequency(&reply) {
            Ok((0, Some(hz))) => {
                tracing::info!(hz, "PR-650: source flicker found; measuring with sync");
                self.setup.sync = SyncSetting::LastF;
                self.send_setup(&CancellationToken::new())
            }
            Ok((code, _)) => {
                tracing::info!(code, "PR-650: no sync frequency; measuring without sync");
                Ok(())
            }
            Err(e) => Err(self.session.protocol_error(&command.text(), &e)),
        }
    }

    /// `D110` (serial) and `D120` (spectral configuration). Neither is
    /// essential: on a failure the session keeps its defaults and resynchronises.
    fn identify(&mut self) {
        let cancel = CancellationToken::new();
        let timeout = self.session.timing().command;
        match self
            .session
            .exchange(&Command::Report(protocol::REPORT_SERIAL), timeout, &cancel)
        {
            Ok(reply) => match protocol::parse_serial(&reply) {
                Ok(serial) => self.session.info_mut().serial = Some(serial),
                Err(e) => tracing::warn!(error = %e, "PR-650: unreadable serial number"),
            },
            Err(e) => tracing::warn!(error = %e, "PR-650: no serial number"),
        }
        match self
            .session
            .exchange(&Command::Report(protocol::REPORT_CONFIG), timeout, &cancel)
        {
            Ok(reply) => match protocol::parse_spectral_config(&reply).map(|c| (c, c.grid())) {
                Ok((config, Some(grid))) => {
                    tracing::info!(grid = %grid, bandwidth_nm = config.bandwidth_nm, "PR-650 spectral configuration");
                    self.session.info_mut().grid = grid;
                }
                Ok((config, None)) => tracing::warn!(
                    ?config,
                    "PR-650: inconsistent configuration; assuming 380–780 nm at 4 nm"
                ),
                Err(e) => tracing::warn!(error = %e, "PR-650: unreadable configuration; assuming 380–780 nm at 4 nm"),
            },
            Err(e) => tracing::warn!(error = %e, "PR-650: no configuration; assuming 380–780 nm at 4 nm"),
        }
        if let Err(e) = self.session.resync_if_needed(&cancel) {
            tracing::warn!(error = %e, "PR-650: resynchronisation after identification failed");
        }
    }

    /// `D5` and `D2` of the measurement `M0` just took, checked against each
    /// other: the spectrum (when the code is good), its quality code, and Y.
    fn read_reports(
        &mut self,
        index: usize,
        time: SystemTime,
        cancel: &CancellationToken,
    ) -> Result<Sample, InstrumentError> {
        let d5 = Command::Report(protocol::REPORT_SPECTRUM);
        let grid = self.session.info().grid.clone();
        let report = self
            .session
            .query(&d5, cancel, |reply| protocol::parse_spectral_report(reply, &grid))?;

        let d2 = Command::Report(protocol::REPORT_XYZ);
        let xyz = self.session.query(&d2, cancel, protocol::parse_xyz_report)?;
        if xyz.code != report.code {
            let mismatch = ProtocolError::Malformed {
                line: 1,
                text: format!("code {:02} (D5 said {:02})", xyz.code, report.code),
                expected: "the same quality code as the spectrum of the same measurement",
            };
            return Err(self.session.protocol_error(&d2.text(), &mismatch));
        }

        let code = codes::quality_code(report.code);
        let unit = match report.unit_flag {
            0 => SpectralUnit::SpectralRadiance,
            1 => SpectralUnit::SpectralIrradiance,
            flag => {
                tracing::warn!(flag, "PR-650 reports uncalibrated data; keeping it as relative power");
                SpectralUnit::RelativePower
            }
        };
        let radiance = if code.is_ok() {
            let spectrum = Spectrum::new(self.session.info().grid.clone(), unit, report.values).map_err(|e| {
                InstrumentError::Protocol {
                    command: d5.text(),
                    detail: e.to_string(),
                }
            })?;
            Some(spectrum)
        } else {
            None
        };
        let luminance = (code.is_ok() && xyz.unit_flag == 0).then_some(xyz.y);
        tracing::info!(index, code = code.code, luminance_cd_m2 = ?luminance, "PR-650 sample");
        Ok(Sample {
            index,
            time,
            code,
            radiance,
            luminance,
            instrument_xyz: None,
        })
    }
}

impl Spectroradiometer for Pr650 {
    fn identity(&self) -> &Identity {
        self.session.identity()
    }

    fn take_sample(&mut self, index: usize, cancel: &CancellationToken) -> Result<Sample, InstrumentError> {
        // One measurement: `M0`, then `D5` and `D2` of the same measurement.
        let ack = self.session.measure(&Command::MeasureAndHold, cancel)?;
        // What M0 answers on failure is [uncertain]; PTB only waits for any
        // bytes. Accept any status number, reject non-numeric garbage.
        let ack_status = protocol::parse_ack(&ack).map_err(|e| self.session.protocol_error("M0", &e))?;
        if ack_status != 0 {
            tracing::debug!(
                ack_status,
                "PR-650: non-zero M0 acknowledgement (the report's code decides)"
            );
        }
        self.read_reports(index, SystemTime::now(), cancel)
    }

    /// §4 (PTB): codes 7/8 with sync on → sync off for the rest of the session.
    fn after_bad_sample(&mut self, code: &QualityCode, cancel: &CancellationToken) -> Result<(), InstrumentError> {
        if code.kind == QualityKind::Sync && self.setup.sync != SyncSetting::Off {
            tracing::info!(code = code.code, "PR-650: sync failed; turning sync off");
            self.setup.sync = SyncSetting::Off;
            self.send_setup(cancel)?;
        }
        Ok(())
    }
}
