//! Asking ports who they are, in parallel, each under a hard deadline.
//!
//! One thread per port. A port's deadline (default 2 s) is measured with
//! `Instant` from the thread's start and bounds everything on it: the open
//! is non-blocking (`O_NONBLOCK`, as serialport opens), every write and
//! every read waits at most what is left (reads in slices of at most
//! 20 ms), and `flush` (tcdrain, which can wait forever on a stuck line) is
//! never called. [`probe_ports`] waits for the reports until the deadline
//! plus [`MARGIN`]; a thread that has not reported by then is reported as
//! [`ProbeResult::Overran`] and left to finish its last bounded slice
//! (it cannot outlive the deadline by more than one slice and a close).
//!
//! Before opening, a port is checked without disturbing its holder (a
//! plain `open` with `O_NONBLOCK`, `TIOCGEXCL`, and a non-blocking `flock`
//! such as serialport and pyserial's `exclusive=True` take): a port that
//! another program holds is reported busy and never opened by serialport
//! (whose failed open would clear the holder's `TIOCEXCL` on close). As
//! root, `TIOCEXCL` does not stop an `open`, so `TIOCGEXCL` is what tells.
//! A program that holds a port without either lock (pyserial's default) is
//! not seen: close it before probing.
//!
//! When several families are asked on one port (nothing suggested one),
//! they are asked in [`Family::UNKNOWN_PORT_ORDER`], each within its share
//! of the time left ([`Family::weight`]); a reply already under way may use
//! the rest of the deadline. A family that answers as itself ends the probe.

use std::io::{Read, Write};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use serialport::{SerialPort, TTYPort};

use super::identity::{self, show, Family, Identity, IdentityError};
use crate::pr655::Model as Pr655Model;

/// How long [`probe_ports`] waits past the deadline for a thread's report.
pub const MARGIN: Duration = Duration::from_millis(500);

/// Longest single read, so the deadline is checked at least this often.
const SLICE: Duration = Duration::from_millis(20);

/// A reply that has started is complete once the line has been quiet this long.
const QUIET: Duration = Duration::from_millis(100);

/// Pause between the letters of `PHOTO`, each its own write (PTB: 50 ms).
const PHOTO_LETTER_GAP: Duration = Duration::from_millis(50);

/// At most this many received bytes are kept to show.
const KEPT_BYTES: usize = 256;

/// One port to ask, and whom.
#[derive(Clone, Debug)]
pub struct ProbeTarget {
    pub path: String,
    /// The families to ask in turn, or why none is.
    pub plan: Result<Vec<Family>, &'static str>,
}

/// What asking a port found, each with what to do.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ProbeResult {
    #[error("{}", identified(.0))]
    Identified(Identity),
    #[error("not probed: {reason}")]
    NotProbed { reason: &'static str },
    #[error(
        "busy: held by another program (lightbooth serve, PsychoPy, a terminal program…). Close it, then probe again"
    )]
    Busy,
    #[error(
        "permission denied: join the `dialout` group (`sudo usermod -aG dialout $USER`), then log out and in again"
    )]
    PermissionDenied,
    #[error("no such device: the port has gone (unplugged?). List the ports again")]
    Missing,
    #[error("not a serial port (not a terminal device): name a /dev/tty… device")]
    NotSerial,
    #[error("cannot open: {reason}")]
    OpenFailed { reason: String },
    #[error("I/O error: {reason}. Re-plug the instrument and probe again")]
    Io { reason: String },
    #[error("no answer within {} s: check power, cable and the instrument's remote mode", seconds(.waited_ms))]
    Silent { waited_ms: u64 },
    #[error("{}", unrecognised(.first_bytes, .asked, *.pr650_reply))]
    Unrecognised {
        /// The first bytes received, escaped.
        first_bytes: String,
        /// What each family's parser said.
        asked: Vec<(Family, String)>,
        /// The reply has the form of a PR-650's report (`qq,U,Y,x,y`): the
        /// PR-650 answers any line so, and has no identity command.
        pr650_reply: bool,
    },
    #[error("the probe did not finish within {} s (it is abandoned): re-plug the instrument", seconds(.waited_ms))]
    Overran { waited_ms: u64 },
}

/// `1.9` for 1900 ms.
fn seconds(ms: &u64) -> String {
    format!("{:.1}", *ms as f64 / 1000.0)
}

/// `PR-670 serial 67065106`.
fn identified(id: &Identity) -> String {
    let serial = match &id.serial {
        Some(s) => format!("serial {s}"),
        None => "(no serial number)".into(),
    };
    let firmware = id.firmware.as_deref().map(|f| format!(", {f}")).unwrap_or_default();
    format!("{} {serial}{firmware}", id.model)
}

/// What an unrecognised answer means, the likeliest reading first and what
/// each family's parser said last (the bug, issue 46: a PR-650 was told that
/// it "answered … as a CS-2000: … is not OK00").
fn unrecognised(first_bytes: &str, asked: &[(Family, String)], pr650_reply: bool) -> String {
    let advice = if pr650_reply {
        "its reply has the form of a PR-650's report (`qq,U,Y,x,y`): probably a PR-650, which has no identity \
         command; name it with --instrument instruments/pr650.toml"
    } else {
        "a PR-650 or an LS-100/CS-100A has no identity command and is not recognised this way (name it with \
         --instrument FILE); otherwise check the baud rate and the cable: another device may be on the port"
    };
    let said: Vec<String> = asked
        .iter()
        .map(|(f, why)| format!("as a {}: {why}", f.name()))
        .collect();
    let said = if said.is_empty() {
        String::new()
    } else {
        format!(" (each family's reading: {})", said.join("; "))
    };
    format!("answered `{first_bytes}`, but no instrument that identifies itself: {advice}{said}")
}

impl ProbeResult {
    /// A short stable name for JSON: `identified`, `busy`, `silent`…
    pub fn status(&self) -> &'static str {
        match self {
            ProbeResult::Identified(_) => "identified",
            ProbeResult::NotProbed { .. } => "not-probed",
            ProbeResult::Busy => "busy",
            ProbeResult::PermissionDenied => "permission-denied",
            ProbeResult::Missing => "missing",
            ProbeResult::NotSerial => "not-serial",
            ProbeResult::OpenFailed { .. } => "open-failed",
            ProbeResult::Io { .. } => "io-error",
            ProbeResult::Silent { .. } => "silent",
            ProbeResult::Unrecognised { .. } => "unrecognised",
            ProbeResult::Overran { .. } => "overran",
        }
    }
}

/// A port's result and how long its probe took.
#[derive(Clone, Debug)]
pub struct ProbeOutcome {
    pub path: String,
    pub result: ProbeResult,
    pub elapsed: Duration,
}

/// Probes every target in parallel, each within `deadline`; returns within
/// `deadline` + [`MARGIN`] whatever the ports do, one outcome per target in
/// the targets' order.
pub fn probe_ports(targets: &[ProbeTarget], deadline: Duration) -> Vec<ProbeOutcome> {
    let start = Instant::now();
    let (tx, rx) = mpsc::channel::<(usize, ProbeResult, Duration)>();
    let mut results: Vec<Option<(ProbeResult, Duration)>> = vec![None; targets.len()];
    let mut handles = Vec::new();
    for (i, target) in targets.iter().enumerate() {
        let families = match &target.plan {
            Ok(families) => families.clone(),
            Err(reason) => {
                results[i] = Some((ProbeResult::NotProbed { reason }, Duration::ZERO));
                continue;
            }
        };
        let (tx, path) = (tx.clone(), target.path.clone());
        let spawned = std::thread::Builder::new()
            .name(format!("probe {path}"))
            .spawn(move || {
                let began = Instant::now();
                let result = probe_port(&path, &families, began + deadline);
                let _ = tx.send((i, result, began.elapsed()));
            });
        match spawned {
            Ok(handle) => handles.push((i, handle)),
            Err(e) => {
                results[i] = Some((
                    ProbeResult::OpenFailed {
                        reason: format!("cannot start a probing thread: {e}"),
                    },
                    Duration::ZERO,
                ))
            }
        }
    }
    drop(tx);
    let give_up = start + deadline + MARGIN;
    while results.iter().any(Option::is_none) {
        let left = give_up.saturating_duration_since(Instant::now());
        match rx.recv_timeout(left) {
            Ok((i, result, elapsed)) => results[i] = Some((result, elapsed)),
            Err(_) => break,
        }
    }
    // Threads that reported are ending: join them. Any other is left to end
    // its last bounded slice on its own (see the module doc).
    for (i, handle) in handles {
        if results[i].is_some() {
            let _ = handle.join();
        }
    }
    let waited = start.elapsed();
    targets
        .iter()
        .zip(results)
        .map(|(target, r)| {
            let (result, elapsed) = r.unwrap_or((
                ProbeResult::Overran {
                    waited_ms: waited.as_millis() as u64,
                },
                waited,
            ));
            ProbeOutcome {
                path: target.path.clone(),
                result,
                elapsed,
            }
        })
        .collect()
}

/// One port: checked, opened, asked family by family until `end`.
pub fn probe_port(path: &str, families: &[Family], end: Instant) -> ProbeResult {
    let began = Instant::now();
    if let Err(result) = check_free(path) {
        return result;
    }
    let Some(first) = families.first() else {
        return ProbeResult::NotProbed {
            reason: "no family to ask",
        };
    };
    let port = match serialport::new(path, first.baud()).timeout(SLICE).open_native() {
        Ok(port) => port,
        Err(e) => return open_error(e),
    };
    let mut wire = Wire {
        port,
        heard: Vec::new(),
        end,
    };
    let mut asked = Vec::new();
    for (k, family) in families.iter().enumerate() {
        let now = Instant::now();
        if now >= end {
            break;
        }
        let weights: u32 = families[k..].iter().map(|f| f.weight()).sum();
        let share = (end - now).mul_f64(f64::from(family.weight()) / f64::from(weights.max(1)));
        let slice_end = now + share;
        if let Err(e) = wire.port.set_baud_rate(family.baud()) {
            tracing::debug!(port = path, error = %e, "cannot set the baud rate (normal on some ptys)");
        }
        let answer = match family {
            Family::ColorimetryResearch => ask_colorimetry_research(&mut wire, slice_end),
            Family::ColorCal => ask_colorcal(&mut wire, slice_end),
            Family::Cs2000 => ask_cs2000(&mut wire, slice_end),
            Family::Pr655 => ask_pr655(&mut wire, slice_end),
        };
        match answer {
            Ok(identity) => return ProbeResult::Identified(identity),
            Err(Asked::Io(reason)) => return ProbeResult::Io { reason },
            Err(Asked::Silent) => {}
            Err(Asked::Not(e)) => asked.push((*family, e.to_string())),
        }
    }
    if wire.heard.is_empty() {
        ProbeResult::Silent {
            waited_ms: began.elapsed().as_millis() as u64,
        }
    } else {
        ProbeResult::Unrecognised {
            first_bytes: show(&wire.heard),
            asked,
            pr650_reply: crate::pr650::protocol::parse_yxy_report(&wire.heard).is_ok(),
        }
    }
}

/// How one family's questions ended, short of an identity.
enum Asked {
    /// Not a byte came.
    Silent,
    /// Bytes came that are not this family's identity.
    Not(IdentityError),
    /// The port failed.
    Io(String),
}

impl From<IdentityError> for Asked {
    fn from(e: IdentityError) -> Asked {
        match e {
            IdentityError::Empty => Asked::Silent,
            e => Asked::Not(e),
        }
    }
}

/// The open port and the port's deadline.
struct Wire {
    port: TTYPort,
    /// Everything received (the first [`KEPT_BYTES`]), for the message.
    heard: Vec<u8>,
    end: Instant,
}

impl Wire {
    /// Writes `bytes` within the deadline; each byte its own write, `gap`
    /// apart, when `gap` is given.
    fn send(&mut self, bytes: &[u8], gap: Option<Duration>) -> Result<(), Asked> {
        let chunks: Vec<&[u8]> = match gap {
            Some(_) => bytes.chunks(1).collect(),
            None => vec![bytes],
        };
        for (k, chunk) in chunks.iter().enumerate() {
            let mut rest = *chunk;
            while !rest.is_empty() {
                let left = self.end.saturating_duration_since(Instant::now());
                if left.is_zero() {
                    return Err(Asked::Silent);
                }
                let _ = self.port.set_timeout(left.min(SLICE));
                match self.port.write(rest) {
                    Ok(n) => rest = &rest[n..],
                    Err(e) if matches!(e.kind(), std::io::ErrorKind::TimedOut | std::io::ErrorKind::Interrupted) => {}
                    Err(e) => return Err(Asked::Io(e.to_string())),
                }
            }
            if let Some(gap) = gap.filter(|_| k + 1 < chunks.len()) {
                std::thread::sleep(gap.min(self.end.saturating_duration_since(Instant::now())));
            }
        }
        Ok(())
    }

    /// Reads a reply: waits for its first byte until `first_byte_by`, then
    /// until `complete` says it is whole, the line has been quiet for
    /// [`QUIET`], or the port's deadline. Returns what came (maybe nothing).
    fn receive(&mut self, first_byte_by: Instant, complete: &dyn Fn(&[u8]) -> bool) -> Result<Vec<u8>, Asked> {
        let mut reply = Vec::new();
        let mut buf = [0u8; 256];
        let mut last_byte: Option<Instant> = None;
        loop {
            let now = Instant::now();
            let limit = match last_byte {
                None => first_byte_by.min(self.end),
                Some(t) => (t + QUIET).min(self.end),
            };
            if now >= limit {
                return Ok(reply);
            }
            let _ = self.port.set_timeout((limit - now).min(SLICE));
            match self.port.read(&mut buf) {
                Ok(0) => return Err(Asked::Io("end of file: the far end closed".into())),
                Ok(n) => {
                    let room = KEPT_BYTES.saturating_sub(self.heard.len());
                    self.heard.extend_from_slice(&buf[..n.min(room)]);
                    if reply.len() < 16 * 1024 {
                        reply.extend_from_slice(&buf[..n]);
                    }
                    last_byte = Some(Instant::now());
                    if complete(&reply) {
                        return Ok(reply);
                    }
                }
                Err(e) if matches!(e.kind(), std::io::ErrorKind::TimedOut | std::io::ErrorKind::Interrupted) => {}
                Err(e) => return Err(Asked::Io(e.to_string())),
            }
        }
    }

    /// Throws away what is waiting (a late reply to another family's question).
    fn discard_input(&mut self) {
        let _ = self.port.clear(serialport::ClearBuffer::Input);
    }

    /// One command and its one-line reply.
    fn exchange(&mut self, command: &[u8], by: Instant, complete: &dyn Fn(&[u8]) -> bool) -> Result<Vec<u8>, Asked> {
        self.discard_input();
        self.send(command, None)?;
        self.receive(by, complete)
    }
}

/// `RC Model`, then `RC ID` (`colorimetry_research.py:62-70`).
fn ask_colorimetry_research(wire: &mut Wire, by: Instant) -> Result<Identity, Asked> {
    let reply = wire.exchange(b"RC Model\n", by, &identity::has_complete_line)?;
    let model = identity::parse_cr_answer(&reply, "RC Model")?;
    let serial = wire
        .exchange(b"RC ID\n", wire.end, &identity::has_complete_line)
        .ok()
        .and_then(|r| identity::parse_cr_answer(&r, "RC ID").ok());
    Ok(identity::cr_identity(model, serial))
}

/// `IDR`, the reply ended by its `>` prompt.
fn ask_colorcal(wire: &mut Wire, by: Instant) -> Result<Identity, Asked> {
    let reply = wire.exchange(b"IDR\n", by, &identity::colorcal_reply_complete)?;
    Ok(identity::parse_colorcal_identity(&reply)?)
}

/// `RMTS,1`, then `IDDR`; no `IDDR` when `RMTS,1` got no reply at all.
fn ask_cs2000(wire: &mut Wire, by: Instant) -> Result<Identity, Asked> {
    let reply = wire.exchange(b"RMTS,1\n", by, &identity::has_complete_line)?;
    match identity::parse_cs2000_remote(&reply) {
        Ok(()) => {}
        // A CS-2000 that refuses remote mode still says who it is.
        Err(IdentityError::Refused { .. }) => {}
        Err(e) => return Err(e.into()),
    }
    let reply = wire.exchange(b"IDDR\n", wire.end, &identity::has_complete_line)?;
    Ok(identity::parse_cs2000_identity(&reply)?)
}

/// `PHOTO` a letter at a time and its banner, `D111`, `D110`, then `Q`.
/// Without a banner `D111` is still asked while time is left: a PR-670
/// already in remote mode answers `PHOTO` with nothing (it answers it once).
fn ask_pr655(wire: &mut Wire, by: Instant) -> Result<Identity, Asked> {
    wire.discard_input();
    wire.send(b"PHOTO", Some(PHOTO_LETTER_GAP))?;
    let banner = wire.receive(by, &identity::banner_complete)?;
    let entered = identity::is_pr655_banner(&banner);
    if !entered && !banner.is_empty() {
        return Err(Asked::Not(IdentityError::NotThisFamily {
            got: show(&banner),
            expected: "the banner ` REMOTE MODE` (a PR-655/670's answer to PHOTO)",
        }));
    }
    // A CR LF after the banner (as on the PR-705) must not be read as the reply.
    let by = if entered {
        wire.end
    } else {
        by.max(Instant::now() + QUIET).min(wire.end)
    };
    let reply = wire.exchange(b"D111\r", by, &identity::has_complete_line);
    let model = reply.and_then(|r| Ok(identity::parse_pr655_model(&r)?));
    let result = match model {
        Ok(model) => {
            let serial = wire
                .exchange(b"D110\r", wire.end, &identity::has_complete_line)
                .ok()
                .and_then(|r| identity::parse_pr655_serial(&r));
            Ok(pr655_identity(model, serial))
        }
        Err(e) => Err(e),
    };
    if entered || result.is_ok() {
        // Leave remote mode as the unit was found; `Q` has no reply.
        let _ = wire.send(b"Q", None);
    }
    result
}

fn pr655_identity(model: Pr655Model, serial: Option<String>) -> Identity {
    Identity {
        family: Family::Pr655,
        model: model.name().to_string(),
        serial,
        firmware: None,
    }
}

/// serialport's open error, named.
fn open_error(e: serialport::Error) -> ProbeResult {
    match e.kind() {
        serialport::ErrorKind::NoDevice => ProbeResult::Busy,
        serialport::ErrorKind::Io(std::io::ErrorKind::PermissionDenied) => ProbeResult::PermissionDenied,
        serialport::ErrorKind::Io(std::io::ErrorKind::NotFound) => ProbeResult::Missing,
        _ => ProbeResult::OpenFailed { reason: e.to_string() },
    }
}

/// Whether the port can be opened and no other program holds it, checked
/// without changing anything: a plain non-blocking open, `TIOCGEXCL`, a
/// non-blocking `flock` (released at once), close.
#[cfg(target_os = "linux")]
fn check_free(path: &str) -> Result<(), ProbeResult> {
    use std::os::unix::ffi::OsStrExt;
    let c_path = std::ffi::CString::new(std::path::Path::new(path).as_os_str().as_bytes()).map_err(|_| {
        ProbeResult::OpenFailed {
            reason: "the path contains a NUL byte".into(),
        }
    })?;
    // SAFETY: a valid NUL-terminated path; the fd is closed below on every path.
    let fd = unsafe {
        libc::open(
            c_path.as_ptr(),
            libc::O_RDWR | libc::O_NOCTTY | libc::O_NONBLOCK | libc::O_CLOEXEC,
        )
    };
    if fd < 0 {
        let e = std::io::Error::last_os_error();
        return Err(match e.raw_os_error() {
            Some(libc::EBUSY) => ProbeResult::Busy,
            Some(libc::EACCES) | Some(libc::EPERM) => ProbeResult::PermissionDenied,
            Some(libc::ENOENT) | Some(libc::ENODEV) | Some(libc::ENXIO) => ProbeResult::Missing,
            _ => ProbeResult::OpenFailed { reason: e.to_string() },
        });
    }
    let verdict = (|| {
        // SAFETY: `fd` is open; isatty only reads it.
        if unsafe { libc::isatty(fd) } != 1 {
            return Err(ProbeResult::NotSerial);
        }
        let mut exclusive: libc::c_int = 0;
        // SAFETY: TIOCGEXCL writes one int through the pointer.
        if unsafe { libc::ioctl(fd, libc::TIOCGEXCL, &mut exclusive as *mut libc::c_int) } == 0 && exclusive != 0 {
            return Err(ProbeResult::Busy);
        }
        // SAFETY: flock on an open fd; released by the close below.
        if unsafe { libc::flock(fd, libc::LOCK_EX | libc::LOCK_NB) } != 0 {
            let e = std::io::Error::last_os_error();
            if e.raw_os_error() == Some(libc::EWOULDBLOCK) {
                return Err(ProbeResult::Busy);
            }
        }
        Ok(())
    })();
    // SAFETY: closes the fd opened above, once.
    unsafe { libc::close(fd) };
    verdict
}

/// Elsewhere serialport's own exclusive open says when a port is held.
#[cfg(not(target_os = "linux"))]
fn check_free(_path: &str) -> Result<(), ProbeResult> {
    Ok(())
}
