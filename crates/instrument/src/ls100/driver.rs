//! An LS-100 / CS-100A session over the shared [`Session`]: open the port
//! at 4800 baud 7E2 (8N2 on a pseudo-terminal, logged), the `MDS,04`
//! handshake that both sets absolute mode and stands in for the identity
//! query the meters lack, and single samples as `MES`. The averaging loop
//! above it is [`crate::averaging`], shared by every model.
//!
//! - The handshake is tried `handshake_attempts` times (PsychoPy tries 10,
//!   psychopy-minolta `minolta.py:154`); silence means the meter is off or
//!   not in communication mode (switched on without F held, mi.py:27-29).
//! - `MES` waits `measure_timeout_ms`; its reply is one line. An `ERnn` is a
//!   sample with that typed code and no value; `OK11`–`OK13` (range
//!   warnings) a sample with its code, not averaged ([`super::codes`]).
//! - The CS-100A's Y, x, y become XYZ (X = xY/y, Z = (1 − x − y)Y/y).
//! - After a garbled, cut or missing reply the session resynchronises
//!   (drain, `MDS,04` ping answered `OK00`, drain) before the next command.

use std::time::SystemTime;

use crate::link::{Ping, Request, Session};
use crate::status_word::StatusWord;
use crate::{Identity, InstrumentError, Sample, Spectroradiometer};
use tokio_util::sync::CancellationToken;

use super::codes;
use super::protocol::{self, Command};
use super::{Ls100Settings, Model};

/// What the session needs to know of a meter command: `MES` measures, and
/// every reply is one line.
impl Request for Command {
    fn text(&self) -> String {
        Command::text(self)
    }

    fn measures(&self) -> bool {
        matches!(self, Command::Measure)
    }

    fn reply_lines(&self, _first_line: &[u8], _grid_len: usize) -> usize {
        1
    }
}

/// A connected LS-100 or CS-100A in communication mode.
pub struct Ls100 {
    session: Session,
    model: Model,
}

impl Ls100 {
    /// Opens `port` and sends the `MDS,04` handshake.
    pub fn open(port: &str, settings: &Ls100Settings) -> Result<Ls100, InstrumentError> {
        settings.validate().map_err(InstrumentError::Settings)?;
        let model = settings.model();
        let identity = Identity::new(settings.capabilities(), codes::quality_hint);
        let ping = Ping {
            command: Command::SetMode(protocol::ABSOLUTE_MODE).text(),
            is_answer: Box::new(|line| StatusWord::parse(line) == Some(StatusWord::SUCCESS)),
        };
        let session = Session::open(port, &settings.link(), settings.timing(), identity, ping)?;
        let mut unit = Ls100 { session, model };
        unit.handshake(settings.handshake_attempts)?;
        tracing::info!(
            port,
            model = model.name(),
            "instrument ready (identified by its MDS,04 answer and the settings' model)"
        );
        Ok(unit)
    }

    /// `MDS,04` until it is answered; an `ERnn` is a typed refusal.
    fn handshake(&mut self, attempts: u32) -> Result<(), InstrumentError> {
        let command = Command::SetMode(protocol::ABSOLUTE_MODE);
        let cancel = CancellationToken::new();
        let mut waited_ms = 0;
        for attempt in 1..=attempts {
            match self.session.query(&command, &cancel, protocol::parse_status_reply) {
                Ok(status) if status.is_ok() => {
                    self.session.in_step();
                    return Ok(());
                }
                Ok(status) => {
                    return Err(InstrumentError::Refused {
                        command: command.text(),
                        code: codes::quality_code(status),
                    })
                }
                Err(InstrumentError::NoReply { waited_ms: w, .. }) => {
                    tracing::warn!(attempt, attempts, "no answer to MDS,04");
                    waited_ms = w;
                }
                Err(e) if e.is_retryable_link_fault() && attempt < attempts => {
                    tracing::warn!(attempt, attempts, error = %e, "bad answer to MDS,04; trying again");
                    self.session.drain()?;
                }
                Err(e) => return Err(e),
            }
        }
        Err(InstrumentError::Silent {
            model: self.model.name(),
            command: command.text(),
            attempts,
            waited_ms,
            advice: "switch the meter off, then on again while holding F (communication mode: `[` shows at the \
                     bottom right of the display), check the cable and that this is its port",
        })
    }
}

impl Spectroradiometer for Ls100 {
    fn identity(&self) -> &Identity {
        self.session.identity()
    }

    fn take_sample(&mut self, index: usize, cancel: &CancellationToken) -> Result<Sample, InstrumentError> {
        let command = Command::Measure;
        let reply = self.session.measure(&command, cancel)?;
        let time = SystemTime::now();
        let measured = match protocol::parse_measurement(&reply, self.model) {
            Ok(Ok(measured)) => measured,
            Ok(Err(status)) => {
                let code = codes::quality_code(status);
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
            Err(e) => return Err(self.session.protocol_error(&command.text(), &e)),
        };
        let code = codes::quality_code(measured.status);
        if !code.is_ok() {
            tracing::info!(
                index,
                code = code.code,
                value = measured.luminance,
                "sample with a range warning; not averaged"
            );
            return Ok(Sample {
                index,
                time,
                code,
                radiance: None,
                luminance: None,
                instrument_xyz: None,
            });
        }
        let instrument_xyz = match self.model {
            Model::Ls100 => None,
            Model::Cs100a => Some(measured.xyz().ok_or_else(|| {
                self.session.protocol_error(
                    &command.text(),
                    &format!(
                        "chromaticity y = {:?} is not positive: no XYZ",
                        measured.xy.map(|c| c.1)
                    ),
                )
            })?),
        };
        tracing::info!(index, luminance = measured.luminance, xy = ?measured.xy, "sample");
        Ok(Sample {
            index,
            time,
            code,
            radiance: None,
            luminance: Some(measured.luminance),
            instrument_xyz,
        })
    }
}
