//! A CS-2000/CS-2000A/CS-3000 session: open the USB serial port (115200
//! baud, RTS/CTS), switch remote mode on (`RMTS,1`), identify (`IDDR`), read
//! (never write) the speed and sync modes the unit keeps in flash, and take
//! single samples. The averaging loop above it is
//! [`crate::averaging`], shared by every model.
//!
//! One sample, as `docs/src/instruments/cs2000.md` describes:
//! 1. `MEAS,1` → `OK00,<s>`: the unit announces its measuring time;
//! 2. the second line, `OK00` (or the measurement's `ERnn`), is awaited for
//!    the announced time plus `end_margin_ms`; if it does not come (a unit
//!    or adapter that drops it), `MEDR,0,0,1` is polled every
//!    `poll_interval_ms` while it answers `ER02` (not ready), as
//!    colour-specio does, within `measure_timeout_ms` of the start;
//! 3. `MEDR,0,0,1` gives the integration time, `MEDR,1,1,1…4` the spectrum
//!    (hex singles, 100 + 100 + 100 + 101 values, W/(sr·m²·nm) at 1 nm, kept
//!    on that grid), and `MEDR,2,0,00` the unit's own Lv and XYZ, kept beside
//!    the spectrum as the sample's `instrument_xyz` (in the observer set on
//!    the unit, 2° by default; lightbooth computes its own colorimetry from
//!    the spectrum).
//!
//! A cancel leaves the unit measuring: the session is marked out of step and
//! the next command first drains and pings (`IDDR`) for up to a whole
//! measurement. A bad measurement (`ER10` over range, `ER71` sync, `ER83`
//! target area, `ER51/52` temperature) is a sample with that code and no
//! spectrum; a refused command (`ER00`, `ER17`) is a typed refusal.

use std::time::{Duration, Instant, SystemTime};

use crate::link::{Ping, Request, Session};
use crate::reply::ProtocolError;
use crate::{Identity, InstrumentError, Sample, Spectroradiometer, WaitPhase};
use lightbooth_science::spectrum::{SpectralUnit, Spectrum};
use tokio_util::sync::CancellationToken;

use super::codes;
use super::protocol::{self, Command, Reply, Status, BLOCK_LENGTHS};
use super::{Cs2000Settings, Model};

impl Request for Command {
    fn text(&self) -> String {
        Command::text(self)
    }

    /// `MEAS,1` answers at once; its second line is awaited by the driver.
    fn measures(&self) -> bool {
        false
    }

    fn reply_lines(&self, _first_line: &[u8], _grid_len: usize) -> usize {
        1
    }
}

/// A connected unit in remote mode.
pub struct Cs2000 {
    session: Session,
    settings: Cs2000Settings,
}

impl Cs2000 {
    /// Opens `port`, switches remote mode on and identifies the unit.
    pub fn open(port: &str, settings: &Cs2000Settings) -> Result<Cs2000, InstrumentError> {
        settings.validate().map_err(InstrumentError::Settings)?;
        let identity = Identity::new(settings.capabilities(), codes::quality_hint);
        let ping = Ping {
            command: Command::Identify.text(),
            is_answer: Box::new(|line| {
                matches!(
                    protocol::parse_reply(line).map(|r| protocol::parse_identity(&r)),
                    Ok(Ok(Ok(_)))
                )
            }),
        };
        let session = Session::open(port, &settings.link(), settings.timing(), identity, ping)?;
        let mut unit = Cs2000 {
            session,
            settings: settings.clone(),
        };
        unit.session.drain()?;
        unit.ordinary(&Command::Remote(true))?;
        unit.identify()?;
        unit.log_flash_settings();
        let info = unit.session.info();
        tracing::info!(port, model = %info.model, serial = ?info.serial, "instrument ready");
        Ok(unit)
    }

    /// One command whose reply must be `OK00`; its fields.
    fn ordinary(&mut self, command: &Command) -> Result<Vec<String>, InstrumentError> {
        let reply = self.reply(command)?;
        match reply.status {
            Status::Ok => Ok(reply.fields),
            Status::Error(n) => Err(InstrumentError::Refused {
                command: command.text(),
                code: codes::command_error(n),
            }),
        }
    }

    /// One command and its parsed reply line, whatever its status.
    fn reply(&mut self, command: &Command) -> Result<Reply, InstrumentError> {
        self.session
            .query(command, &CancellationToken::new(), protocol::parse_reply)
    }

    /// `IDDR` must name the model the settings name.
    fn identify(&mut self) -> Result<(), InstrumentError> {
        let command = Command::Identify;
        let reply = self.reply(&command)?;
        let id = match protocol::parse_identity(&reply) {
            Ok(Ok(id)) => id,
            Ok(Err(Status::Error(n))) => {
                return Err(InstrumentError::Refused {
                    command: command.text(),
                    code: codes::command_error(n),
                })
            }
            Ok(Err(Status::Ok)) => unreachable!("an OK status parses"),
            Err(e) => return Err(self.session.protocol_error(&command.text(), &e)),
        };
        let name = id.model_name();
        let wanted = self.settings.model();
        match Model::from_name(&name) {
            Some(found) if found == wanted => {}
            Some(found) => {
                return Err(InstrumentError::Settings(format!(
                    "the instrument on this port says it is a {}, but the settings are for the {}: use --model {}",
                    found.name(),
                    wanted.name(),
                    found.flag()
                )))
            }
            None => {
                return Err(InstrumentError::Protocol {
                    command: command.text(),
                    detail: format!(
                    "the unit calls itself `{}`, not a CS-2000, CS-2000A or CS-3000; is this the instrument's port?",
                    name.escape_debug()
                ),
                })
            }
        }
        self.session.info_mut().model = wanted.name().into();
        self.session.info_mut().serial = Some(id.serial);
        Ok(())
    }

    /// The speed and sync modes live in the unit's flash: read and logged,
    /// never written (a write wears the flash and changes every later
    /// user's measurements).
    fn log_flash_settings(&mut self) {
        for command in [Command::ReadSpeed, Command::ReadSync] {
            match self.ordinary(&command) {
                Ok(fields) => tracing::info!(command = %command.text(), setting = %fields.join(","),
                    "the unit's own setting (kept in its flash; lightbooth does not change it)"),
                Err(e) => tracing::warn!(command = %command.text(), error = %e, "cannot read the unit's setting"),
            }
        }
        if let Err(e) = self.session.resync_if_needed(&CancellationToken::new()) {
            tracing::warn!(error = %e, "resynchronising after reading the settings");
        }
    }

    /// Sleeps `d`, or less if cancelled.
    fn pause(d: Duration, cancel: &CancellationToken) -> Result<(), InstrumentError> {
        let end = Instant::now() + d;
        while Instant::now() < end {
            if cancel.is_cancelled() {
                return Err(InstrumentError::Cancelled);
            }
            std::thread::sleep((end - Instant::now()).min(Duration::from_millis(20)));
        }
        Ok(())
    }

    /// Steps 2: the end of the measurement. `Ok(None)` when it ended well,
    /// `Ok(Some(code))` when it ended with an error code.
    fn await_end(
        &mut self,
        seconds: u32,
        started: Instant,
        cancel: &CancellationToken,
    ) -> Result<Option<u8>, InstrumentError> {
        let text = Command::Measure.text();
        let wait = Duration::from_secs(u64::from(seconds)) + Duration::from_millis(self.settings.end_margin_ms);
        let gap = self.session.timing().gap;
        match self.session.link().read_reply(&text, &|_| 1, wait, gap, cancel) {
            Ok(bytes) => match protocol::parse_reply(&bytes) {
                Ok(Reply { status: Status::Ok, .. }) => return Ok(None),
                Ok(Reply {
                    status: Status::Error(n),
                    ..
                }) => return Ok(Some(n)),
                Err(e) => return Err(self.session.protocol_error(&text, &e)),
            },
            Err(InstrumentError::Timeout {
                phase: WaitPhase::FirstByte,
                ..
            }) => tracing::info!(seconds, "no end line after the announced time; polling MEDR,0,0,1"),
            Err(e) => {
                self.session.mark_out_of_step(&text, &e, true);
                return Err(e);
            }
        }
        // No end line: ask until the unit is ready (specio's loop).
        let limit = self.session.timing().measure;
        loop {
            let reply = self.reply(&Command::Conditions)?;
            match reply.status {
                Status::Error(2) if started.elapsed() < limit => {
                    Self::pause(Duration::from_millis(self.settings.poll_interval_ms), cancel).inspect_err(|e| {
                        self.session.mark_out_of_step(&text, e, true);
                    })?
                }
                Status::Error(2) => {
                    let e = InstrumentError::Timeout {
                        command: text.clone(),
                        phase: WaitPhase::FirstByte,
                        waited_ms: limit.as_millis() as u64,
                    };
                    self.session.mark_out_of_step(&text, &e, true);
                    return Err(e);
                }
                Status::Error(n) => return Ok(Some(n)),
                Status::Ok => return Ok(None),
            }
        }
    }

    /// A sample with a bad code and no spectrum.
    fn bad_sample(index: usize, n: u8) -> Sample {
        let code = codes::quality_code(n);
        tracing::info!(index, code = code.code, kind = ?code.kind, "sample with an error code");
        Sample {
            index,
            time: SystemTime::now(),
            code,
            radiance: None,
            luminance: None,
            instrument_xyz: None,
        }
    }

    /// A reply's error status on a data command after a good end: the unit
    /// is confused, or the link is.
    fn data_error(command: &Command, status: Status) -> ProtocolError {
        ProtocolError::Malformed {
            line: 1,
            text: status.text(),
            expected: match command {
                Command::Colorimetry => "the colorimetric data of the measurement that just ended",
                Command::Conditions => "the conditions of the measurement that just ended",
                _ => "the spectral data of the measurement that just ended",
            },
        }
    }

    /// Step 3: the ended measurement's data.
    fn read_data(&mut self, index: usize, cancel: &CancellationToken) -> Result<Sample, InstrumentError> {
        let conditions = Command::Conditions;
        let integration_us = self.session.query(&conditions, cancel, |bytes| {
            let reply = protocol::parse_reply(bytes)?;
            protocol::parse_integration_us(&reply)?.map_err(|s| Self::data_error(&Command::Conditions, s))
        })?;
        let mut values = Vec::with_capacity(protocol::SPECTRUM_LEN);
        for block in 1..=BLOCK_LENGTHS.len() as u8 {
            let command = Command::Spectrum { hex: true, block };
            let part = self.session.query(&command, cancel, |bytes| {
                let reply = protocol::parse_reply(bytes)?;
                protocol::parse_spectral_block(&reply, block, true)?.map_err(|s| Self::data_error(&command, s))
            })?;
            values.extend(part);
        }
        let time = SystemTime::now();
        let colorimetry = self.session.query(&Command::Colorimetry, cancel, |bytes| {
            let reply = protocol::parse_reply(bytes)?;
            protocol::parse_colorimetry(&reply)?.map_err(|s| Self::data_error(&Command::Colorimetry, s))
        })?;
        let grid = self.session.info().grid.clone();
        let spectrum =
            Spectrum::new(grid, SpectralUnit::SpectralRadiance, values).map_err(|e| InstrumentError::Protocol {
                command: "MEDR,1,1,1…4".into(),
                detail: e.to_string(),
            })?;
        tracing::info!(
            index,
            integration_us,
            luminance_cd_m2 = colorimetry.luminance_cd_m2,
            "sample"
        );
        Ok(Sample {
            index,
            time,
            code: codes::quality_code(0),
            radiance: Some(spectrum),
            luminance: Some(colorimetry.luminance_cd_m2),
            instrument_xyz: Some(colorimetry.xyz),
        })
    }
}

impl Spectroradiometer for Cs2000 {
    fn identity(&self) -> &Identity {
        self.session.identity()
    }

    fn take_sample(&mut self, index: usize, cancel: &CancellationToken) -> Result<Sample, InstrumentError> {
        self.session.resync_if_needed(cancel)?;
        let started = Instant::now();
        let measure = Command::Measure;
        let reply = self.session.query(&measure, cancel, protocol::parse_reply)?;
        let seconds = match protocol::parse_measuring_seconds(&reply) {
            Ok(Ok(s)) => s,
            Ok(Err(Status::Error(n @ (0 | 17)))) => {
                return Err(InstrumentError::Refused {
                    command: measure.text(),
                    code: codes::command_error(n),
                })
            }
            Ok(Err(Status::Error(n))) => return Ok(Self::bad_sample(index, n)),
            Ok(Err(Status::Ok)) => unreachable!("an OK status parses"),
            Err(e) => return Err(self.session.protocol_error(&measure.text(), &e)),
        };
        tracing::debug!(index, seconds, "measuring");
        if let Some(n) = self.await_end(seconds, started, cancel)? {
            return Ok(Self::bad_sample(index, n));
        }
        self.read_data(index, cancel)
    }
}

impl Drop for Cs2000 {
    /// Remote mode off, so the unit's own keys work again.
    fn drop(&mut self) {
        if let Err(e) = self.session.link().send(&Command::Remote(false).text()) {
            tracing::debug!(error = %e, "could not send RMTS,0 on closing");
        }
    }
}
