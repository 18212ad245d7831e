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
