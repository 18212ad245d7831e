//! A PR-650 session: open the port, enter remote mode, set up, identify, and
//! take single samples as `M0` followed by `D5` and `D2` (the averaging loop
//! above it is [`crate::instrument::averaging`], shared by every model).
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
//!   drain) before the next command, so the session stays usable;
//! - only `M0` waits for a whole measurement (`measure_timeout_ms`); the
//!   handshake, the reports and the resynchronisation ping wait
//!   `command_timeout_ms`, so a unit that falls silent mid-reply (a cable cut
//!   behind the adapter) is reported [`InstrumentError::Unresponsive`] within
//!   `gap_timeout_ms + resync_quiet_ms + command_timeout_ms` of its last byte
//!   (5.2 s with the shipped settings). The ping waits a whole measurement
//!   only after a cancelled `M0`, when the unit may still be measuring.

use std::time::{Duration, SystemTime};

use crate::instrument::transport::SerialLink;
use crate::instrument::{
    CancelToken, Capabilities, InstrumentError, InstrumentInfo, QualityCode, QualityKind, Sample, Spectroradiometer,
    WaitPhase,
};
use crate::spectrum::{Grid, SpectralUnit, Spectrum};

use super::protocol::{self, Command, ProtocolError, Setup, SyncSetting};
use super::Pr650Settings;

/// The PR-650 has no model query; this is what [`InstrumentInfo::model`] says.
pub const MODEL: &str = "PR-650";

/// Backlight level sent as the remote-mode handshake: low, so the LCD adds
/// little stray light to a dark booth (PTB sends `b3`, djsperka `B1`; both answer `000`).
const HANDSHAKE_BACKLIGHT: u8 = 1;

/// A connected PR-650 in remote mode.
pub struct Pr650 {
    link: SerialLink,
    settings: Pr650Settings,
    info: InstrumentInfo,
    capabilities: Capabilities,
    setup: Setup,
    /// Set after a link fault or a cancel: the unit may still be measuring or
    /// sending, so the next command must resynchronise first.
    needs_resync: bool,
    /// Set when an `M0` was cancelled: the unit may go on measuring for up to
    /// a whole measurement, so the resynchronisation ping may wait that long.
    may_be_measuring: bool,
    /// The command and error of the exchange that last failed, for the report
    /// if the unit then stops answering.
    last_fault: Option<(String, String)>,
}

impl Pr650 {
    /// Opens `port`, enters remote mode, sends the setup, and identifies the unit.
    pub fn open(port: &str, settings: &Pr650Settings) -> Result<Pr650, InstrumentError> {
        settings.validate().map_err(InstrumentError::Settings)?;
        let link = SerialLink::open(port, &settings.link())?;
        let mut pr650 = Pr650 {
            link,
            settings: settings.clone(),
            info: InstrumentInfo {
                model: MODEL.into(),
                serial: None,
                firmware: None,
                grid: Grid::pr650(),
            },
            capabilities: settings.capabilities(),
            setup: Setup {
                integration_ms: settings.integration_ms,
                ..Setup::default()
            },
            needs_resync: false,
            may_be_measuring: false,
            last_fault: None,
        };
        pr650.enter_remote_mode()?;
        pr650.send_setup(&CancelToken::new())?;
        if settings.sync {
            pr650.find_sync_frequency()?;
        }
        pr650.identify();
        tracing::info!(port, model = %pr650.info.model, serial = ?pr650.info.serial, grid = %pr650.info.grid, "PR-650 ready");
        Ok(pr650)
    }

    /// Flush, send, read: one command and its reply.
    fn exchange(
        &mut self,
        command: &Command,
        first_byte_timeout: Duration,
        cancel: &CancelToken,
    ) -> Result<Vec<u8>, InstrumentError> {
        let text = command.text();
        let result = (|| {
            self.link.flush_input()?;
            tracing::debug!(command = %text, "→ PR-650");
            self.link.send(&text)?;
            let lines = command.reply_lines(self.info.grid.len());
            self.link
                .read_reply(&text, lines, first_byte_timeout, self.settings.gap_timeout(), cancel)
        })();
        // Silence to an ordinary command means nobody is listening (off, local
        // mode, wrong port); silence after `M0` may just be a long measurement.
        let result = match result {
            Err(InstrumentError::Timeout {
                command,
                phase: WaitPhase::FirstByte,
                waited_ms,
            }) if command != "M0" => Err(InstrumentError::NoReply { command, waited_ms }),
            other => other,
        };
        match &result {
            Ok(reply) => tracing::debug!(command = %text, bytes = reply.len(), "← PR-650"),
            Err(e) => {
                tracing::debug!(command = %text, error = %e, "PR-650 exchange failed");
                if e.is_retryable_link_fault() || matches!(e, InstrumentError::Cancelled) {
                    self.needs_resync = true;
                    self.last_fault = Some((text.clone(), e.to_string()));
                }
                if matches!(command, Command::MeasureAndHold) && matches!(e, InstrumentError::Cancelled) {
                    self.may_be_measuring = true;
                }
            }
        }
        result
    }

    fn protocol_error(&mut self, command: &Command, e: ProtocolError) -> InstrumentError {
        self.needs_resync = true;
        let e = InstrumentError::Protocol {
            command: command.text(),
            detail: e.to_string(),
        };
        self.last_fault = Some((command.text(), e.to_string()));
        e
    }

    /// §1: the unit answers only if a command arrives within ~5 s of power-on.
    /// Several quick tries help with some USB adapters (PTB's cable note).
    fn enter_remote_mode(&mut self) -> Result<(), InstrumentError> {
        let attempts = self.settings.remote_mode_attempts;
        let ping = Command::Backlight(HANDSHAKE_BACKLIGHT);
        for attempt in 1..=attempts {
            tracing::info!(attempt, attempts, "PR-650: remote-mode handshake");
            match self.exchange(&ping, self.settings.command_timeout(), &CancelToken::new()) {
                Ok(reply) => match protocol::parse_ack(&reply) {
                    Ok(status) => {
                        if status != 0 {
                            tracing::warn!(status, "PR-650: unexpected handshake status; continuing");
                        }
                        self.needs_resync = false;
                        tracing::info!(attempt, "PR-650 in remote mode");
                        return Ok(());
                    }
                    Err(e) => tracing::warn!(attempt, error = %e, "PR-650: garbled handshake reply"),
                },
                Err(e) if e.is_retryable_link_fault() => tracing::warn!(attempt, error = %e, "PR-650: no handshake"),
                Err(e) => return Err(e),
            }
            self.link.drain_until_quiet(
                Duration::from_millis(self.settings.resync_quiet_ms),
                self.settings.command_timeout(),
            )?;
        }
        Err(InstrumentError::NotInRemoteMode { attempts })
    }

    fn send_setup(&mut self, cancel: &CancelToken) -> Result<(), InstrumentError> {
        let command = Command::Setup(self.setup);
        let reply = self.exchange(&command, self.settings.command_timeout(), cancel)?;
        let status = protocol::parse_setup_status(&reply).map_err(|e| self.protocol_error(&command, e))?;
        tracing::info!(setup = %command.text(), status, "PR-650 setup");
        if status != 0 {
            return Err(InstrumentError::Setup {
                command: command.text(),
                status,
                meaning: protocol::setup_status_meaning(status),
            });
        }
        Ok(())
    }

    /// §6.6: `F`; sync on if the unit found a frequency, else off.
    fn find_sync_frequency(&mut self) -> Result<(), InstrumentError> {
        let reply = self.exchange(
            &Command::SyncFrequency,
            self.settings.measure_timeout(),
            &CancelToken::new(),
        )?;
        match protocol::parse_sync_frequency(&reply) {
            Ok((0, Some(hz))) => {
                tracing::info!(hz, "PR-650: source flicker found; measuring with sync");
                self.setup.sync = SyncSetting::LastF;
                self.send_setup(&CancelToken::new())
            }
            Ok((code, _)) => {
                tracing::info!(code, "PR-650: no sync frequency; measuring without sync");
                Ok(())
            }
            Err(e) => Err(self.protocol_error(&Command::SyncFrequency, e)),
        }
    }

    /// `D110` (serial) and `D120` (spectral configuration). Neither is
    /// essential: on a failure the session keeps its defaults and resynchronises.
    fn identify(&mut self) {
        let cancel = CancelToken::new();
        match self.exchange(
            &Command::Report(protocol::REPORT_SERIAL),
            self.settings.command_timeout(),
            &cancel,
        ) {
            Ok(reply) => match protocol::parse_serial(&reply) {
                Ok(serial) => self.info.serial = Some(serial),
                Err(e) => tracing::warn!(error = %e, "PR-650: unreadable serial number"),
            },
            Err(e) => tracing::warn!(error = %e, "PR-650: no serial number"),
        }
        match self.exchange(
            &Command::Report(protocol::REPORT_CONFIG),
            self.settings.command_timeout(),
            &cancel,
        ) {
            Ok(reply) => match protocol::parse_spectral_config(&reply).map(|c| (c, c.grid())) {
                Ok((config, Some(grid))) => {
                    tracing::info!(grid = %grid, bandwidth_nm = config.bandwidth_nm, "PR-650 spectral configuration");
                    self.info.grid = grid;
                }
                Ok((config, None)) => tracing::warn!(
                    ?config,
                    "PR-650: inconsistent configuration; assuming 380–780 nm at 4 nm"
                ),
                Err(e) => tracing::warn!(error = %e, "PR-650: unreadable configuration; assuming 380–780 nm at 4 nm"),
            },
            Err(e) => tracing::warn!(error = %e, "PR-650: no configuration; assuming 380–780 nm at 4 nm"),
        }
        if self.needs_resync {
            if let Err(e) = self.resync(&cancel) {
                tracing::warn!(error = %e, "PR-650: resynchronisation after identification failed");
            }
        }
    }

    /// After a fault or cancel: wait out whatever the unit is still sending
    /// (a late report, a cancelled `M0` that finishes and acknowledges), ping
    /// it until a `000` comes back, then drain again. A ping met by silence
    /// for `command_timeout_ms` (a whole measurement after a cancelled `M0`)
    /// means the unit has stopped answering: [`InstrumentError::Unresponsive`].
    fn resync(&mut self, cancel: &CancelToken) -> Result<(), InstrumentError> {
        tracing::info!("PR-650: resynchronising");
        let quiet = Duration::from_millis(self.settings.resync_quiet_ms);
        self.link.drain_until_quiet(quiet, self.settings.command_timeout())?;
        self.link.flush_input()?;
        let ping = Command::Backlight(HANDSHAKE_BACKLIGHT).text();
        tracing::debug!(command = %ping, "→ PR-650 (resync)");
        self.link.send(&ping)?;
        // Skip lines (a late report, a late `M0` ack) until the ping's `000`,
        // for up to a whole measurement while bytes keep coming; silence ends
        // the wait sooner unless the unit may still be measuring.
        let silence = if self.may_be_measuring {
            self.settings.measure_timeout()
        } else {
            self.settings.command_timeout()
        };
        let is_ack = |line: &[u8]| line.trim_ascii() == b"000";
        match self
            .link
            .read_until_line(&ping, &is_ack, silence, self.settings.measure_timeout(), cancel)
        {
            Ok(()) => {}
            Err(InstrumentError::Timeout {
                command,
                phase: WaitPhase::FirstByte,
                waited_ms,
            }) => {
                let (after, reason) = self
                    .last_fault
                    .clone()
                    .unwrap_or_else(|| ("?".into(), "an earlier fault".into()));
                tracing::warn!(
                    after,
                    reason,
                    waited_ms,
                    "PR-650: no reply to the resynchronisation ping"
                );
                return Err(InstrumentError::Unresponsive {
                    after,
                    reason,
                    command,
                    waited_ms,
                });
            }
            Err(e) => return Err(e),
        }
        // The ping's own `000` may follow a late `M0` ack.
        self.link.drain_until_quiet(quiet, self.settings.command_timeout())?;
        self.needs_resync = false;
        self.may_be_measuring = false;
        self.last_fault = None;
        tracing::info!("PR-650: back in step");
        Ok(())
    }

    /// One measurement: `M0`, then `D5` and `D2` of the same measurement.
    pub fn measure_once(&mut self, index: usize, cancel: &CancelToken) -> Result<Sample, InstrumentError> {
        if self.needs_resync {
            self.resync(cancel)?;
        }
        let m0 = Command::MeasureAndHold;
        let ack = self.exchange(&m0, self.settings.measure_timeout(), cancel)?;
        // What M0 answers on failure is [uncertain]; PTB only waits for any
        // bytes. Accept any status number, reject non-numeric garbage.
        let ack_status = protocol::parse_ack(&ack).map_err(|e| self.protocol_error(&m0, e))?;
        if ack_status != 0 {
            tracing::debug!(
                ack_status,
                "PR-650: non-zero M0 acknowledgement (the report's code decides)"
            );
        }
        let time = SystemTime::now();

        let d5 = Command::Report(protocol::REPORT_SPECTRUM);
        let reply = self.exchange(&d5, self.settings.command_timeout(), cancel)?;
        let report =
            protocol::parse_spectral_report(&reply, &self.info.grid).map_err(|e| self.protocol_error(&d5, e))?;

        let d2 = Command::Report(protocol::REPORT_XYZ);
        let reply = self.exchange(&d2, self.settings.command_timeout(), cancel)?;
        let xyz = protocol::parse_xyz_report(&reply).map_err(|e| self.protocol_error(&d2, e))?;
        if xyz.code != report.code {
            return Err(self.protocol_error(
                &d2,
                ProtocolError::Malformed {
                    line: 1,
                    text: format!("code {:02} (D5 said {:02})", xyz.code, report.code),
                    expected: "the same quality code as the spectrum of the same measurement",
                },
            ));
        }

        let code = protocol::quality_code(report.code);
        let unit = match report.unit_flag {
            0 => SpectralUnit::SpectralRadiance,
            1 => SpectralUnit::SpectralIrradiance,
            flag => {
                tracing::warn!(flag, "PR-650 reports uncalibrated data; keeping it as relative power");
                SpectralUnit::RelativePower
            }
        };
        let radiance = if code.is_ok() {
            let spectrum =
                Spectrum::new(self.info.grid.clone(), unit, report.values).map_err(|e| InstrumentError::Protocol {
                    command: d5.text(),
                    detail: e.to_string(),
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
        })
    }

    /// §4 (PTB): codes 7/8 with sync on → sync off for the rest of the session.
    fn react_to_code(&mut self, code: &QualityCode, cancel: &CancelToken) -> Result<(), InstrumentError> {
        if code.kind == QualityKind::Sync && self.setup.sync != SyncSetting::Off {
            tracing::info!(code = code.code, "PR-650: sync failed; turning sync off");
            self.setup.sync = SyncSetting::Off;
            self.send_setup(cancel)?;
        }
        Ok(())
    }
}

impl Spectroradiometer for Pr650 {
    fn info(&self) -> &InstrumentInfo {
        &self.info
    }

    fn capabilities(&self) -> &Capabilities {
        &self.capabilities
    }

    fn take_sample(&mut self, index: usize, cancel: &CancelToken) -> Result<Sample, InstrumentError> {
        self.measure_once(index, cancel)
    }

    fn after_bad_sample(&mut self, code: &QualityCode, cancel: &CancelToken) -> Result<(), InstrumentError> {
        self.react_to_code(code, cancel)
    }

    fn quality_hint(&self, kind: QualityKind) -> &'static str {
        protocol::quality_hint(kind)
    }
}
