//! What both simulated firmwares (the PR-650's [`super::device`] and the
//! PR-655/PR-670's [`super::pr655_device`]) do alike: decide whether an
//! injected fault fires, put line noise into a reply, and sleep without
//! missing a stop request.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use super::model::Rng;
use super::{lock, Fault, FaultKind, FaultRate, Shared};

/// Read slice of the simulators: how often they check for stop and power-cycle requests.
pub(super) const POLL: Duration = Duration::from_millis(10);

/// The fault of `kind` that fires now, if any. Every matching fault is
/// counted down; the first that fires is returned.
pub(super) fn fired(shared: &Mutex<Shared>, rng: &mut Rng, kind: FaultKind) -> Option<Fault> {
    let mut shared = lock(shared);
    let mut first = None;
    for fault in shared.faults.iter_mut().filter(|f| f.kind == kind) {
        let fires = match &mut fault.rate {
            FaultRate::Always => true,
            FaultRate::Probability(p) => rng.uniform() < *p,
            FaultRate::Times(n) if *n > 0 => {
                *n -= 1;
                true
            }
            FaultRate::Times(_) => false,
        };
        if fires && first.is_none() {
            first = Some(*fault);
        }
    }
    if first.is_some() {
        tracing::info!(?kind, "simulated instrument: injecting fault");
    }
    first
}

/// Line noise from byte `start` on: three characters of the data replaced by
/// bytes that cannot be part of a report. (A digit turned into another digit
/// cannot be detected without a checksum, which neither protocol sends.)
pub(super) fn garble(rng: &mut Rng, bytes: &mut [u8], start: usize) {
    const NOISE: &[u8] = b"#?~\x7f\xff\x00\xa5";
    let start = start.min(bytes.len());
    for _ in 0..3 {
        if bytes.len() <= start {
            break;
        }
        let i = start + (rng.next_u32() as usize) % (bytes.len() - start);
        if bytes[i].is_ascii_digit() || bytes[i] == b'.' || bytes[i] == b',' {
            bytes[i] = NOISE[(rng.next_u32() as usize) % NOISE.len()];
        } else {
            bytes[i.saturating_sub(1)] = b'#';
        }
    }
}

/// Sleeps `ms` of wall time, waking for a stop request.
pub(super) fn sleep_ms(stop: &AtomicBool, ms: f64) {
    let end = Instant::now() + Duration::from_secs_f64(ms.max(0.0) / 1000.0);
    while !stop.load(Ordering::Relaxed) {
        let now = Instant::now();
        if now >= end {
            break;
        }
        std::thread::sleep((end - now).min(POLL));
    }
}

/// What the injected faults leave of a spectrum reply.
pub(super) enum Faulted {
    /// No answer at all.
    Silent,
    Send(Vec<u8>),
    /// Send the (cut) reply, then the link dies: silent until power-cycled.
    SendThenDie(Vec<u8>),
}

/// Applies the spectrum reply's faults, in the order both simulators use:
/// no answer, slow (after the fault's delay or `slow_ms`), garble (from
/// byte `garble_start`), double CR LF after the header, truncate, link dies.
pub(super) fn fault_spectrum_reply(
    shared: &Mutex<Shared>,
    rng: &mut Rng,
    stop: &AtomicBool,
    slow_ms: u64,
    mut bytes: Vec<u8>,
    garble_start: usize,
) -> Faulted {
    if fired(shared, rng, FaultKind::NoAnswer).is_some() {
        return Faulted::Silent;
    }
    if let Some(slow) = fired(shared, rng, FaultKind::Slow) {
        sleep_ms(stop, slow.delay_ms.unwrap_or(slow_ms) as f64);
    }
    if fired(shared, rng, FaultKind::Garble).is_some() {
        garble(rng, &mut bytes, garble_start);
    }
    if fired(shared, rng, FaultKind::DoubleCrlf).is_some() {
        let header_end = bytes.iter().position(|b| *b == b'\n').map_or(0, |i| i + 1);
        bytes.splice(header_end..header_end, *b"\r\n");
    }
    if fired(shared, rng, FaultKind::Truncate).is_some() {
        bytes.truncate(bytes.len() / 2);
    }
    if fired(shared, rng, FaultKind::LinkDies).is_some() {
        bytes.truncate(bytes.len() / 2);
        return Faulted::SendThenDie(bytes);
    }
    Faulted::Send(bytes)
}
