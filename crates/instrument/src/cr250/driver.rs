//! A CR-250/CR-300 session: open the USB serial port (115200 baud,
//! RTS/CTS), identify the unit (`RC InstrumentType` must be 2, a
//! spectroradiometer; `RC Model` must be the settings' model; `RC ID`,
//! `RC Firmware`), set automatic exposure (`SM ExposureMode 0`), its speed
//! (`SM Speed`) and one exposure per measurement (`SM ExposureX 1`:
//! lightbooth averages itself and keeps every sample), as colour-specio
//! does on connect. One sample is `M` (the reply comes when it ends, within
//! the speed's allowance), `RM Spectrum` (a header naming the grid, then one
//! value per line, checked against the model's grid) and `RM XYZ` (the
//! unit's own X, Y, Z, kept beside the spectrum). An `ER` reply to `M` is a
//! sample with that code and no spectrum; an `ER` reply to anything else is
//! a typed refusal. After a link fault the session resynchronises with
//! `RC Model` as its ping.

use std::time::SystemTime;

use crate::link::{lines, Ping, Request, Session};
use crate::reply::ProtocolError;
use crate::{Identity, InstrumentError, Sample, Spectroradiometer};
use lightbooth_science::spectrum::{SpectralUnit, Spectrum};
use tokio_util::sync::CancellationToken;

use super::codes;
use super::protocol::{self, Command, Reply};
use super::{Cr250Settings, Model};

impl Request for Command {
    fn text(&self) -> String {
        Command::text(self)
    }

    fn measures(&self) -> bool {
        matches!(self, Command::Measure)
    }

    /// `RM Spectrum`: its header and the values it announces.
    fn reply_lines(&self, first_line: &[u8], _grid_len: usize) -> usize {
        match self {
            Command::Spectrum => 1 + protocol::spectrum_lines(first_line).unwrap_or(0),
            _ => 1,
        }
    }
}

/// A connected CR-250 or CR-300.
pub struct Cr250 {
    session: Session,
    settings: Cr250Settings,
}

impl Cr250 {
    pub fn open(port: &str, settings: &Cr250Settings) -> Result<Cr250, InstrumentError> {
        settings.validate().map_err(InstrumentError::Settings)?;
        let identity = Identity::new(settings.capabilities(), codes::quality_hint);
        let ping = Ping {
            command: Command::Model.text(),
            is_answer: Box::new(|line| protocol::parse_reply(line).is_ok_and(|r| r.ok && r.command == "RC Model")),
        };
        let session = Session::open(port, &settings.link(), settings.timing(), identity, ping)?;
        let mut unit = Cr250 {
            session,
            settings: settings.clone(),
        };
        unit.session.drain()?;
        unit.identify()?;
        let cancel = CancellationToken::new();
        unit.ordinary(&Command::AutoExposure, &cancel)?;
        unit.ordinary(&Command::Speed(unit.settings.speed), &cancel)?;
        unit.ordinary(&Command::ExposureX(1), &cancel)?;
        let info = unit.session.info();
        tracing::info!(port, model = %info.model, serial = ?info.serial, firmware = ?info.firmware, "instrument ready");
        Ok(unit)
    }

    /// A one-line command whose reply must be `OK`: its argument.
    fn ordinary(&mut self, command: &Command, cancel: &CancellationToken) -> Result<String, InstrumentError> {
        let reply: Reply = self.session.query(command, cancel, protocol::parse_reply)?;
        if reply.ok {
            Ok(reply.argument)
        } else {
            Err(InstrumentError::Refused {
                command: command.text(),
                code: codes::quality_code(reply.code),
            })
        }
    }

    fn identify(&mut self) -> Result<(), InstrumentError> {
        let cancel = CancellationToken::new();
        let kind = self.ordinary(&Command::InstrumentType, &cancel)?;
        if kind.trim() != "2" {
            let what = match kind.trim() {
                "0" => "a photometer",
                "1" => "a colorimeter",
                _ => "not a spectroradiometer",
            };
            return Err(InstrumentError::Settings(format!(
                "the Colorimetry Research instrument on this port is {what} (RC InstrumentType {}): lightbooth \
                 drives the CR-250 and CR-300 spectroradiometers of the family",
                kind.trim()
            )));
        }
        let name = self.ordinary(&Command::Model, &cancel)?;
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
                    command: Command::Model.text(),
                    detail: format!(
                        "the unit calls itself `{}`, not a CR-250 or CR-300",
                        name.escape_debug()
                    ),
                })
            }
        }
        let serial = self.ordinary(&Command::Id, &cancel)?;
        self.session.info_mut().serial = Some(serial.trim().to_string());
        match self.ordinary(&Command::Firmware, &cancel) {
            Ok(v) => self.session.info_mut().firmware = Some(v.trim().to_string()),
            Err(e) => tracing::warn!(error = %e, "no firmware version"),
        }
        self.session.resync_if_needed(&cancel)
    }

    /// `RM Spectrum`: the header's grid must be the model's.
    fn read_spectrum(&mut self, cancel: &CancellationToken) -> Result<Spectrum, InstrumentError> {
        let command = Command::Spectrum;
        let grid = self.session.info().grid.clone();
        let values = self.session.query(&command, cancel, |bytes| {
            let all = lines::split_lines(bytes);
            let reply = protocol::parse_reply(bytes)?;
            if !reply.ok {
                return Err(ProtocolError::Malformed {
                    line: 1,
                    text: format!("ER:{}", reply.code),
                    expected: "the spectrum of the measurement that just ended",
                });
            }
            let (start, end, step) =
                protocol::parse_spectrum_header(&reply.argument).ok_or(ProtocolError::Malformed {
                    line: 1,
                    text: reply.argument.clone(),
                    expected: "<start>,<end>,<step> in nm",
                })?;
            if (start, step) != (grid.first_nm(), grid.step_nm().unwrap_or(0.0)) || end != grid.last_nm() {
                return Err(ProtocolError::Malformed {
                    line: 1,
                    text: reply.argument.clone(),
                    expected: "the model's grid (CR-250: 380,780,4; CR-300: 380,780,1)",
                });
            }
            if all.len() < 1 + grid.len() {
                return Err(ProtocolError::Truncated {
                    got: all.len().saturating_sub(1),
                    expected: grid.len(),
                });
            }
            protocol::parse_values(&all[1..=grid.len()])
        })?;
        Spectrum::new(grid, SpectralUnit::SpectralRadiance, values).map_err(|e| InstrumentError::Protocol {
            command: command.text(),
            detail: e.to_string(),
        })
    }
}

impl Spectroradiometer for Cr250 {
    fn identity(&self) -> &Identity {
        self.session.identity()
    }

    fn take_sample(&mut self, index: usize, cancel: &CancellationToken) -> Result<Sample, InstrumentError> {
        let command = Command::Measure;
        let bytes = self.session.measure(&command, cancel)?;
        let time = SystemTime::now();
        let reply = protocol::parse_reply(&bytes).map_err(|e| self.session.protocol_error(&command.text(), &e))?;
        if !reply.ok {
            let code = codes::quality_code(reply.code);
            if reply.code == -500 {
                return Err(InstrumentError::Refused {
                    command: command.text(),
                    code,
                });
            }
            tracing::info!(index, code = code.code, kind = ?code.kind, "sample with an error code");
            return Ok(Sample {
                index,
                time,
                code,
                radiance: None,
                luminance: None,
                instrument_xyz: None,
            });
        }
        let spectrum = self.read_spectrum(cancel)?;
        let xyz_text = self.ordinary(&Command::Xyz, cancel)?;
        let xyz = protocol::parse_xyz(&xyz_text).ok_or_else(|| {
            self.session.protocol_error(
                &Command::Xyz.text(),
                &format!("`{}` is not X,Y,Z", xyz_text.escape_debug()),
            )
        })?;
        tracing::info!(index, luminance_cd_m2 = xyz[1], "sample");
        Ok(Sample {
            index,
            time,
            code: codes::quality_code(0),
            radiance: Some(spectrum),
            luminance: Some(xyz[1]),
            instrument_xyz: Some(xyz),
        })
    }
}
