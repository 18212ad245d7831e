//! The serial port to an instrument: port settings, flushing, writes with a
//! timeout, and the reads that neither hang nor cut a slow reply short.
//!
//! Blocking I/O: a [`SerialLink`] belongs to one thread (the daemon's
//! instrument task, or `lightbooth measure`), which serialises every command to it.
//!
//! The read of a reply (`docs/src/instruments/pr650-protocol.md` §6.4): first wait up
//! to a long timeout for the first byte (the instrument is silent while it
//! measures), then read until the expected number of lines has arrived,
//! giving up only when no byte comes for a gap timeout. A fixed short
//! per-read timeout truncates spectra when the link pauses mid-reply
//! (PsychoPy's bug). Reads poll in short slices so a [`CancellationToken`] is
//! honoured promptly.

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use serialport::{ClearBuffer, DataBits, FlowControl, Parity, SerialPort, StopBits};

use super::lines::{complete_lines, split_lines, trim_to_lines, Terminator};
use crate::{InstrumentError, WaitPhase};
use tokio_util::sync::CancellationToken;

/// Longest slice of a blocking read, so cancellation and deadlines are
/// checked at least this often.
const POLL_SLICE: Duration = Duration::from_millis(20);

/// A reply longer than this is garbage, not a report (a `D5` is 1734 bytes).
const MAX_REPLY_BYTES: usize = 16 * 1024;

/// Serial settings. The PR-650 needs 9600 baud, 8N1, no flow control (§1, \[confirmed\]).
#[derive(Clone, Debug)]
pub struct LinkSettings {
    pub baud: u32,
    pub terminator: Terminator,
    /// How long a write may block (a hung USB adapter must not hang us; PsychoPy #1698).
    pub write_timeout_ms: u64,
    /// Pause between the bytes of a command, for adapters or units that "get
    /// upset if hurried" (PsychoPy). 0 = whole-command writes, which PTB and mgl use.
    pub byte_delay_ms: u64,
    /// Character framing: 8N1 for every model but the LS-100/CS-100A (7E2).
    pub framing: Framing,
    /// RTS/CTS hardware flow control (the CS-2000 and the CR-250 ask for it).
    pub flow_control: bool,
}

/// How each character goes on the wire: data bits, parity, stop bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Framing {
    pub data_bits: DataBits,
    pub parity: Parity,
    pub stop_bits: StopBits,
}

impl Framing {
    /// 8 data bits, no parity, 1 stop bit: every model but the Minolta meters.
    pub const EIGHT_N_ONE: Framing = Framing {
        data_bits: DataBits::Eight,
        parity: Parity::None,
        stop_bits: StopBits::One,
    };
    /// 7 data bits, even parity, 2 stop bits: the LS-100 and the CS-100A.
    pub const SEVEN_E_TWO: Framing = Framing {
        data_bits: DataBits::Seven,
        parity: Parity::Even,
        stop_bits: StopBits::Two,
    };
}

impl std::fmt::Display for Framing {
    /// `8N1`, `7E2`, `8N2`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let bits = match self.data_bits {
            DataBits::Five => 5,
            DataBits::Six => 6,
            DataBits::Seven => 7,
            DataBits::Eight => 8,
        };
        let parity = match self.parity {
            Parity::None => 'N',
            Parity::Odd => 'O',
            Parity::Even => 'E',
        };
        let stop = match self.stop_bits {
            StopBits::One => 1,
            StopBits::Two => 2,
        };
        write!(f, "{bits}{parity}{stop}")
    }
}

impl LinkSettings {
    /// How every supported model talks: 9600 baud, 8N1, commands ended by
    /// `terminator`; a write blocks no longer than the command timeout, and
    /// 5 s at the most.
    pub fn at_9600_baud(terminator: Terminator, command_timeout_ms: u64, byte_delay_ms: u64) -> LinkSettings {
        LinkSettings {
            baud: 9600,
            terminator,
            write_timeout_ms: command_timeout_ms.min(5_000),
            byte_delay_ms,
            framing: Framing::EIGHT_N_ONE,
            flow_control: false,
        }
    }
}

impl Default for LinkSettings {
    fn default() -> LinkSettings {
        LinkSettings {
            baud: 9600,
            terminator: Terminator::Lf,
            write_timeout_ms: 2000,
            byte_delay_ms: 0,
            framing: Framing::EIGHT_N_ONE,
            flow_control: false,
        }
    }
}

/// An open serial port to one instrument.
pub struct SerialLink {
    port: Box<dyn SerialPort>,
    path: String,
    settings: LinkSettings,
}

impl SerialLink {
    /// Opens `path` at the instrument's settings and asserts DTR and RTS.
    /// Setting modem lines fails on a pty and on some USB adapters; that is
    /// logged as a warning, not an error (a unit that needs DTR will then
    /// simply not answer, which the caller reports).
    pub fn open(path: &str, settings: &LinkSettings) -> Result<SerialLink, InstrumentError> {
        let open = |framing: Framing| {
            serialport::new(path, settings.baud)
                .data_bits(framing.data_bits)
                .parity(framing.parity)
                .stop_bits(framing.stop_bits)
                .flow_control(if settings.flow_control {
                    FlowControl::Hardware
                } else {
                    FlowControl::None
                })
                .timeout(POLL_SLICE)
                .open()
        };
        let port = match open(settings.framing) {
            Ok(port) => port,
            // A Linux pseudo-terminal refuses 7 data bits and parity (EINVAL):
            // only a simulator is on a pty, so fall back to 8 bits without
            // parity at the same baud and stop bits, and say so.
            Err(e) if settings.framing.data_bits != DataBits::Eight && is_pseudo_terminal(path) => {
                let fallback = Framing {
                    data_bits: DataBits::Eight,
                    parity: Parity::None,
                    ..settings.framing
                };
                tracing::warn!(port = path, wanted = %settings.framing, using = %fallback, error = %e,
                    "a pseudo-terminal cannot take this framing; falling back (a real serial port gets the instrument's)");
                open(fallback)
            }
            .map_err(|e| InstrumentError::Open {
                port: path.to_string(),
                reason: e.to_string(),
            })?,
            Err(e) => {
                return Err(InstrumentError::Open {
                    port: path.to_string(),
                    reason: e.to_string(),
                })
            }
        };
        // Some kernels take 7 data bits or parity on a pty without an error
        // and keep 8N: read the framing back, so a fallback is never silent.
        let actual = port.data_bits().and_then(|data_bits| {
            Ok(Framing {
                data_bits,
                parity: port.parity()?,
                stop_bits: port.stop_bits()?,
            })
        });
        match actual {
            Ok(actual) if actual != settings.framing => tracing::warn!(port = path, wanted = %settings.framing,
                using = %actual, "the port did not take this framing (a pseudo-terminal keeps 8 bits without \
                parity; a real serial port gets the instrument's)"),
            Ok(_) => {}
            Err(e) => tracing::debug!(port = path, error = %e, "cannot read the framing back"),
        }
        let mut link = SerialLink {
            port,
            path: path.to_string(),
            settings: settings.clone(),
        };
        // §1: keep DTR and RTS asserted; one client only got data with DTR up.
        if let Err(e) = link.port.write_data_terminal_ready(true) {
            tracing::warn!(port = path, error = %e, "cannot assert DTR (normal on a pty or some USB adapters); continuing");
        }
        if let Err(e) = link.port.write_request_to_send(true) {
            tracing::warn!(port = path, error = %e, "cannot assert RTS (normal on a pty or some USB adapters); continuing");
        }
        tracing::info!(port = path, baud = settings.baud, framing = %settings.framing,
            rts_cts = settings.flow_control, "serial port open");
        Ok(link)
    }

    pub fn path(&self) -> &str {
        &self.path
    }

    /// Names an I/O error: a vanished far end (POLLHUP, EIO, EOF: the cable
    /// pulled, the adapter unplugged) is [`InstrumentError::PortClosed`].
    /// Some calls (tcdrain behind `flush`) report a hang-up only as a generic
    /// failure, so an unclear error is followed by a short probe read, which
    /// on a hung-up line fails the same clear way.
    fn io_error(&mut self, e: std::io::Error) -> InstrumentError {
        if is_hangup(&e) {
            return InstrumentError::PortClosed {
                port: self.path.clone(),
            };
        }
        let _ = self.port.set_timeout(Duration::from_millis(1));
        let probe = self.port.read(&mut [0u8; 1]);
        let _ = self.port.set_timeout(POLL_SLICE);
        match probe {
            Ok(0) => InstrumentError::PortClosed {
                port: self.path.clone(),
            },
            Err(p) if is_hangup(&p) => InstrumentError::PortClosed {
                port: self.path.clone(),
            },
            _ => InstrumentError::Io {
                port: self.path.clone(),
                source: e,
            },
        }
    }

    /// Throws away whatever is waiting in the input buffer (§6.3: before every
    /// command). Returns how many bytes were discarded.
    pub fn flush_input(&mut self) -> Result<usize, InstrumentError> {
        let waiting = self.port.bytes_to_read().unwrap_or(0) as usize;
        if let Err(e) = self.port.clear(ClearBuffer::Input) {
            tracing::warn!(port = %self.path, error = %e, "cannot clear the input buffer; draining by reading");
        }
        // Some adapters ignore the clear: read out what is left without waiting.
        let mut drained = 0;
        let mut buf = [0u8; 256];
        while self.port.bytes_to_read().unwrap_or(0) > 0 {
            match self.port.read(&mut buf) {
                Ok(0) => break,
                Ok(n) => drained += n,
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => break,
                Err(e) => return Err(self.io_error(e)),
            }
        }
        let discarded = waiting.max(drained);
        if discarded > 0 {
            tracing::debug!(port = %self.path, bytes = discarded, "discarded stale input before a command");
        }
        Ok(discarded)
    }

    /// Writes one command (the text without terminator) and its terminator:
    /// in one write, or a byte per write `byte_delay_ms` apart.
    pub fn send(&mut self, command: &str) -> Result<(), InstrumentError> {
        let mut bytes = command.as_bytes().to_vec();
        bytes.extend_from_slice(self.settings.terminator.bytes());
        let pacing = (self.settings.byte_delay_ms != 0).then(|| Duration::from_millis(self.settings.byte_delay_ms));
        self.write_timed(command, &bytes, pacing)
    }

    /// Writes `bytes` one per write, `delay` apart, with no terminator: the
    /// PR-655's `PHOTO`, whose letters "must be sent as single characters".
    pub fn send_bytes_singly(&mut self, bytes: &[u8], delay: Duration) -> Result<(), InstrumentError> {
        let shown = String::from_utf8_lossy(bytes).into_owned();
        self.write_timed(&shown, bytes, Some(delay))
    }

    /// Writes `bytes` within the write timeout: all at once, or with
    /// `pacing` one byte per write, each followed by that pause. A write
    /// that blocks past the timeout is a [`WaitPhase::FirstByte`] timeout
    /// naming `shown`.
    fn write_timed(&mut self, shown: &str, bytes: &[u8], pacing: Option<Duration>) -> Result<(), InstrumentError> {
        self.port
            .set_timeout(Duration::from_millis(self.settings.write_timeout_ms))
            .map_err(|e| InstrumentError::Io {
                port: self.path.clone(),
                source: e.into(),
            })?;
        let result = match pacing {
            None => self.port.write_all(bytes).and_then(|_| self.port.flush()),
            Some(delay) => bytes.iter().try_for_each(|b| {
                self.port.write_all(std::slice::from_ref(b))?;
                self.port.flush()?;
                std::thread::sleep(delay);
                Ok(())
            }),
        };
        let _ = self.port.set_timeout(POLL_SLICE);
        match result {
            Ok(()) => Ok(()),
            Err(e) if e.kind() == std::io::ErrorKind::TimedOut => Err(InstrumentError::Timeout {
                command: shown.to_string(),
                phase: WaitPhase::FirstByte,
                waited_ms: self.settings.write_timeout_ms,
            }),
            Err(e) => Err(self.io_error(e)),
        }
    }

    /// One read of at most one [`POLL_SLICE`]: `Some(n)` bytes, or `None`
    /// when the slice passed in silence. End of file (the far end gone) is
    /// [`InstrumentError::PortClosed`]; a read interrupted by a signal is
    /// simply read again.
    fn read_chunk(&mut self, buf: &mut [u8]) -> Result<Option<usize>, InstrumentError> {
        loop {
            match self.port.read(buf) {
                Ok(0) => {
                    return Err(InstrumentError::PortClosed {
                        port: self.path.clone(),
                    })
                }
                Ok(n) => return Ok(Some(n)),
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => return Ok(None),
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(self.io_error(e)),
            }
        }
    }

    /// The two-phase read of a reply whose length (in non-empty lines) its
    /// first line decides: `expected_lines` sees the first complete line (a
    /// PR-655 spectrum is a header and 101 lines, or an error status alone;
    /// a PR-650 reply's length is known before it starts). Bytes after the
    /// last expected line (a chunk read past it) are dropped with a log
    /// line; the next command flushes anyway.
    pub fn read_reply(
        &mut self,
        command: &str,
        expected_lines: &dyn Fn(&[u8]) -> usize,
        first_byte_timeout: Duration,
        gap_timeout: Duration,
        cancel: &CancellationToken,
    ) -> Result<Vec<u8>, InstrumentError> {
        let mut reply = Vec::with_capacity(2048);
        let mut buf = [0u8; 512];
        let start = Instant::now();
        let mut last_byte = start;
        let mut expected: Option<usize> = None;
        loop {
            if cancel.is_cancelled() {
                return Err(InstrumentError::Cancelled);
            }
            match self.read_chunk(&mut buf)? {
                Some(n) => {
                    reply.extend_from_slice(&buf[..n]);
                    last_byte = Instant::now();
                    let complete = complete_lines(&reply);
                    if expected.is_none() && complete >= 1 {
                        let first = split_lines(&reply).first().copied().unwrap_or_default();
                        expected = Some(expected_lines(first).max(1));
                    }
                    if let Some(lines) = expected {
                        if complete >= lines {
                            return Ok(trim_to_lines(reply, lines));
                        }
                    }
                    if reply.len() > MAX_REPLY_BYTES {
                        return Err(InstrumentError::Protocol {
                            command: command.to_string(),
                            detail: format!(
                                "more than {MAX_REPLY_BYTES} bytes without the expected {} lines",
                                expected.unwrap_or(1)
                            ),
                        });
                    }
                }
                None if reply.is_empty() => {
                    if start.elapsed() >= first_byte_timeout {
                        return Err(no_first_byte(command, start));
                    }
                }
                None => {
                    if last_byte.elapsed() >= gap_timeout {
                        return Err(InstrumentError::Truncated {
                            command: command.to_string(),
                            lines: complete_lines(&reply),
                            expected: expected.unwrap_or(1),
                            gap_ms: gap_timeout.as_millis() as u64,
                        });
                    }
                }
            }
        }
    }

    /// Reads a reply that has no line end (the PR-655's banner): up to
    /// `max_bytes`, ending when `max_bytes` arrived or the line has been quiet
    /// for `quiet` after the first byte. A [`WaitPhase::FirstByte`] timeout
    /// when nothing came within `first_byte_timeout`.
    pub fn read_unterminated(
        &mut self,
        command: &str,
        max_bytes: usize,
        first_byte_timeout: Duration,
        quiet: Duration,
        cancel: &CancellationToken,
    ) -> Result<Vec<u8>, InstrumentError> {
        let mut reply = Vec::with_capacity(max_bytes);
        let mut buf = [0u8; 64];
        let start = Instant::now();
        let mut last_byte = start;
        loop {
            if cancel.is_cancelled() {
                return Err(InstrumentError::Cancelled);
            }
            let room = (max_bytes - reply.len()).min(buf.len());
            match self.read_chunk(&mut buf[..room])? {
                Some(n) => {
                    reply.extend_from_slice(&buf[..n]);
                    last_byte = Instant::now();
                    if reply.len() >= max_bytes {
                        return Ok(reply);
                    }
                }
                None if reply.is_empty() => {
                    if start.elapsed() >= first_byte_timeout {
                        return Err(no_first_byte(command, start));
                    }
                }
                None => {
                    if last_byte.elapsed() >= quiet {
                        return Ok(reply);
                    }
                }
            }
        }
    }

    /// Reads until a complete line satisfies `is_answer` (other lines, such as
    /// a late report, are skipped). Gives up when the line has been silent for
    /// `silence` (since the call, or since the last byte) or after `overall`.
    /// The error is a [`WaitPhase::FirstByte`] timeout when not one byte came,
    /// else a [`WaitPhase::MidReply`] one.
    pub fn read_until_line(
        &mut self,
        command: &str,
        is_answer: &dyn Fn(&[u8]) -> bool,
        silence: Duration,
        overall: Duration,
        cancel: &CancellationToken,
    ) -> Result<(), InstrumentError> {
        let start = Instant::now();
        let mut last_byte: Option<Instant> = None;
        let mut pending: Vec<u8> = Vec::new();
        let mut buf = [0u8; 512];
        while start.elapsed() < overall && last_byte.unwrap_or(start).elapsed() < silence {
            if cancel.is_cancelled() {
                return Err(InstrumentError::Cancelled);
            }
            let Some(n) = self.read_chunk(&mut buf)? else { continue };
            last_byte = Some(Instant::now());
            pending.extend_from_slice(&buf[..n]);
            if let Some(end) = pending.iter().rposition(|b| *b == b'\r' || *b == b'\n') {
                let found = split_lines(&pending[..=end]).into_iter().any(is_answer);
                pending.drain(..=end);
                if found {
                    return Ok(());
                }
            }
            if pending.len() > MAX_REPLY_BYTES {
                pending.clear();
            }
        }
        Err(InstrumentError::Timeout {
            command: command.to_string(),
            phase: if last_byte.is_some() {
                WaitPhase::MidReply
            } else {
                WaitPhase::FirstByte
            },
            waited_ms: start.elapsed().as_millis() as u64,
        })
    }

    /// Reads and discards until the line has been quiet for `quiet`, or
    /// `max` has passed: resynchronisation after garbage, a timeout or a
    /// cancelled measurement whose late reply may still come.
    pub fn drain_until_quiet(&mut self, quiet: Duration, max: Duration) -> Result<usize, InstrumentError> {
        let start = Instant::now();
        let mut last = Instant::now();
        let mut total = 0;
        let mut buf = [0u8; 512];
        while last.elapsed() < quiet && start.elapsed() < max {
            if let Some(n) = self.read_chunk(&mut buf)? {
                total += n;
                last = Instant::now();
            }
        }
        if total > 0 {
            tracing::debug!(port = %self.path, bytes = total, "drained late or stray bytes");
        }
        Ok(total)
    }
}

/// Nothing came for `command` since `start`: a [`WaitPhase::FirstByte`] timeout.
fn no_first_byte(command: &str, start: Instant) -> InstrumentError {
    InstrumentError::Timeout {
        command: command.to_string(),
        phase: WaitPhase::FirstByte,
        waited_ms: start.elapsed().as_millis() as u64,
    }
}

/// The far end has gone: POLLHUP (reported as a broken pipe), EIO, EOF.
fn is_hangup(e: &std::io::Error) -> bool {
    use std::io::ErrorKind::*;
    matches!(e.kind(), BrokenPipe | UnexpectedEof | NotConnected | ConnectionReset)
        || e.raw_os_error() == Some(5)
        || e.to_string().contains("Input/output error")
}

/// Whether `path` is a Unix98 pseudo-terminal's device end (`/dev/pts/N`),
/// where only a simulator can be.
pub fn is_pseudo_terminal(path: &str) -> bool {
    std::fs::canonicalize(path)
        .map(|p| p.starts_with("/dev/pts"))
        .unwrap_or(false)
}
