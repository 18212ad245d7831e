//! A ColorCAL MkII session over the shared [`Session`]: open the USB serial
//! port, identify the unit (`IDR`), read its correction matrix (`r01`–`r03`),
//! optionally zero-calibrate (`UZC`), and take single samples as `MES`,
//! whose raw values the matrix turns into XYZ (psychopy-crs
//! `psychopy_crs/colorcal.py:175-182`, `:275-288`). The averaging loop above
//! it is [`crate::averaging`], shared by every model.
//!
//! - Every reply is one body line between `\n\r` and the `>` prompt
//!   ([`protocol::reply_body`]); the session reads up to the body's line end
//!   and the prompt, if it comes later, is flushed before the next command.
//! - A matrix without an inverse (all zeros: an uncalibrated or confused
//!   unit) is refused on opening: its XYZ would be meaningless.
//! - `MES` waits `measure_timeout_ms`, every other command
//!   `command_timeout_ms`; after a garbled, cut or missing reply the session
//!   resynchronises (drain, `IDR` ping, drain) before the next command.
//! - A status other than `OK00` to `MES` is a sample with that typed code and
//!   no values ([`super::codes`]).

use std::time::SystemTime;

use crate::link::{Ping, Request, Session};
use crate::status_word::StatusWord;
use crate::{Identity, InstrumentError, Sample, Spectroradiometer};
use tokio_util::sync::CancellationToken;

use super::codes;
use super::protocol::{self, Command, Matrix};
use super::ColorCalSettings;

/// What the session needs to know of a ColorCAL command: `MES` measures,
/// and every reply has one body line.
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

/// A connected ColorCAL MkII.
pub struct ColorCal {
    session: Session,
    /// The correction matrix `r01`–`r03`: XYZ = matrix · raw.
    matrix: Matrix,
}

impl ColorCal {
    /// Opens `port`, identifies the unit, reads its matrix and, when the
    /// settings ask, zero-calibrates it.
    pub fn open(port: &str, settings: &ColorCalSettings) -> Result<ColorCal, InstrumentError> {
        settings.validate().map_err(InstrumentError::Settings)?;
        let identity = Identity::new(settings.capabilities(), codes::quality_hint);
        let ping = Ping {
            command: Command::Identify.text(),
            is_answer: Box::new(|line| line.trim_ascii().starts_with(b"OK00,1,")),
        };
        let session = Session::open(port, &settings.link(), settings.timing(), identity, ping)?;
        let mut unit = ColorCal {
            session,
            matrix: [[0.0; 3]; 3],
        };
        unit.identify()?;
        unit.matrix = unit.read_matrix()?;
        if settings.zero_calibrate {
            unit.zero_calibrate()?;
        }
        let info = unit.session.info();
        tracing::info!(port, model = %info.model, serial = ?info.serial, firmware = ?info.firmware,
            matrix = ?unit.matrix, "instrument ready");
        Ok(unit)
    }

    /// `IDR`: serial number and firmware (ROM and build).
    fn identify(&mut self) -> Result<(), InstrumentError> {
        let command = Command::Identify;
        match self
            .session
            .query(&command, &CancellationToken::new(), protocol::parse_identification)
            .map_err(|e| not_a_colorcal(e, &command))?
        {
            Ok(id) => {
                let info = self.session.info_mut();
                info.serial = Some(id.serial);
                info.firmware = Some(format!("ROM {} build {}", id.rom, id.build));
                Ok(())
            }
            Err(status) => Err(InstrumentError::Refused {
                command: command.text(),
                code: codes::quality_code(status),
            }),
        }
    }

    /// `r01`–`r03`, the matrix PsychoPy uses; refused when it has no inverse.
    fn read_matrix(&mut self) -> Result<Matrix, InstrumentError> {
        let mut matrix = [[0.0; 3]; 3];
        for (n, row) in (1u8..=3).zip(matrix.iter_mut()) {
            let command = Command::MatrixRow(n);
            match self
                .session
                .query(&command, &CancellationToken::new(), protocol::parse_matrix_row)?
            {
                Ok(values) => *row = values,
                Err(status) => {
                    return Err(InstrumentError::Refused {
                        command: command.text(),
                        code: codes::quality_code(status),
                    })
                }
            }
        }
        if protocol::inverse(&matrix).is_none() {
            return Err(InstrumentError::Protocol {
                command: "r01–r03".into(),
                detail: format!(
                    "the correction matrix {matrix:?} has no inverse (an uncalibrated unit?): its XYZ would be \
                     meaningless; have the ColorCAL recalibrated by CRS"
                ),
            });
        }
        Ok(matrix)
    }

    /// `UZC`; `ER11` (light on the sensor) is a typed refusal.
    fn zero_calibrate(&mut self) -> Result<(), InstrumentError> {
        let command = Command::ZeroCalibrate;
        let status = self
            .session
            .query(&command, &CancellationToken::new(), protocol::parse_status_reply)?;
        tracing::info!(%status, "zero calibration");
        if status != StatusWord::SUCCESS {
            return Err(InstrumentError::Refused {
                command: command.text(),
                code: codes::quality_code(status),
            });
        }
        Ok(())
    }

    /// The matrix read from the unit on opening.
    pub fn matrix(&self) -> &Matrix {
        &self.matrix
    }
}

/// An `IDR` that gets no answer on opening: most likely not a ColorCAL on
/// this port, or one that needs re-plugging.
fn not_a_colorcal(e: InstrumentError, command: &Command) -> InstrumentError {
    match e {
        InstrumentError::NoReply { waited_ms, .. } => InstrumentError::Silent {
            model: super::MODEL_NAME,
            command: command.text(),
            attempts: 1,
            waited_ms,
            advice: "check that the ColorCAL is plugged in and that this is its port (ls /dev/ttyACM*), then \
                     re-plug its USB cable",
        },
        other => other,
    }
}

impl Spectroradiometer for ColorCal {
    fn identity(&self) -> &Identity {
        self.session.identity()
    }

    fn take_sample(&mut self, index: usize, cancel: &CancellationToken) -> Result<Sample, InstrumentError> {
        let command = Command::Measure;
        let reply = self.session.measure(&command, cancel)?;
        let time = SystemTime::now();
        let raw = match protocol::parse_raw_measurement(&reply) {
            Ok(Ok(raw)) => raw,
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
        let xyz = protocol::apply(&self.matrix, raw);
        tracing::info!(index, ?raw, ?xyz, "sample");
        Ok(Sample {
            index,
            time,
            code: codes::quality_code(StatusWord::SUCCESS),
            radiance: None,
            luminance: Some(xyz[1]),
            instrument_xyz: Some(xyz),
        })
    }
}
