//! The faults a simulator can be told to inject (`--fault KIND[@DELAY][:RATE]`,
//! `POST /api/mock/faults`): what each does, how often it fires, how it is
//! written, and the line noise of a garbled reply. Pure: the simulated
//! units (`sim::unit`) decide where each applies.

use std::str::FromStr;

use super::model::Rng;

/// The kinds of injectable faults (`--fault KIND[:RATE]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FaultKind {
    /// A `D5` gets no reply at all.
    NoAnswer,
    /// A `D5` reply stops after about half the spectrum.
    Truncate,
    /// A `D5` reply has some characters replaced by line noise.
    Garble,
    /// Junk (a stale partial report) lands in the host's input buffer after
    /// the `D2` reply, before the next command: tests the flush.
    Stale,
    /// A measurement ends with [`MockConfig::error_code`](super::config::MockConfig::error_code) (default 18, whose
    /// spectral buffer stays stale) instead of its real code.
    ErrorCode,
    /// The port closes during a measurement: the cable pulled. The simulator stops.
    CablePull,
    /// A `D5` reply's first byte comes late: after the fault's own delay
    /// (`slow@2500ms`), else after [`MockConfig::slow_ms`](super::config::MockConfig::slow_ms).
    Slow,
    /// A `D5` reply carries an extra, empty CR LF after its header (harmless
    /// to a correct parser).
    DoubleCrlf,
    /// A `D5` reply stops after about half the spectrum and the unit then
    /// answers nothing until power-cycled: a cable cut behind a USB adapter
    /// (the port stays open, the line goes quiet, nothing signals a hang-up).
    LinkDies,
}

/// How often a fault fires at each point where it applies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FaultRate {
    Always,
    /// Independently each time, with this probability (seeded).
    Probability(f64),
    /// The next N times, then never.
    Times(u32),
}

/// One injected fault: `KIND`, `KIND:0.25` (probability), `KIND:once`,
/// `KIND:3x`; a `slow` fault may carry its delay, `slow@2500ms:once`
/// (also `slow@2.5s`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fault {
    pub kind: FaultKind,
    pub rate: FaultRate,
    /// The delay of a [`FaultKind::Slow`] reply, ms; `None` uses [`MockConfig::slow_ms`](super::config::MockConfig::slow_ms).
    pub delay_ms: Option<u64>,
}

impl Fault {
    pub fn always(kind: FaultKind) -> Fault {
        Fault {
            kind,
            rate: FaultRate::Always,
            delay_ms: None,
        }
    }

    pub fn times(kind: FaultKind, n: u32) -> Fault {
        Fault {
            kind,
            rate: FaultRate::Times(n),
            delay_ms: None,
        }
    }

    /// A [`FaultKind::Slow`] fault whose replies come `delay_ms` late.
    pub fn slow(delay_ms: u64, rate: FaultRate) -> Fault {
        Fault {
            kind: FaultKind::Slow,
            rate,
            delay_ms: Some(delay_ms),
        }
    }
}

/// The fault kinds and the rate syntax, for error messages and `--help`.
pub const FAULT_SYNTAX: &str = "KIND[:RATE] with KIND one of no-answer, truncate, garble, stale, error-code, \
     cable-pull, slow, double-crlf, link-dies, and RATE a probability 0–1, `once` or `Nx`; `slow` takes its delay \
     as slow@MS ms or slow@S s, e.g. slow@2500ms:once";

/// The longest `slow` delay accepted: ten minutes, far past any timeout.
const MAX_SLOW_MS: u64 = 600_000;

/// `2500ms`, `2.5s`: a delay with its unit.
fn parse_delay(s: &str) -> Result<u64, String> {
    let bad = || format!("delay `{s}`: write it with its unit, e.g. 2500ms or 2.5s");
    let ms = if let Some(v) = s.strip_suffix("ms") {
        v.trim().parse::<u64>().map_err(|_| bad())?
    } else if let Some(v) = s.strip_suffix('s') {
        let secs: f64 = v.trim().parse().map_err(|_| bad())?;
        if !(secs.is_finite() && secs >= 0.0) {
            return Err(bad());
        }
        (secs * 1000.0).round().min(u64::MAX as f64) as u64
    } else {
        return Err(bad());
    };
    if ms > MAX_SLOW_MS {
        return Err(format!("delay `{s}` is over the limit of {} s", MAX_SLOW_MS / 1000));
    }
    Ok(ms)
}

impl FromStr for FaultKind {
    type Err = String;
    fn from_str(s: &str) -> Result<FaultKind, String> {
        Ok(match s {
            "no-answer" => FaultKind::NoAnswer,
            "truncate" => FaultKind::Truncate,
            "garble" => FaultKind::Garble,
            "stale" => FaultKind::Stale,
            "error-code" => FaultKind::ErrorCode,
            "cable-pull" => FaultKind::CablePull,
            "slow" => FaultKind::Slow,
            "double-crlf" => FaultKind::DoubleCrlf,
            "link-dies" => FaultKind::LinkDies,
            _ => {
                return Err(format!(
                    "unknown fault `{s}`: use no-answer, truncate, garble, stale, error-code, cable-pull, slow, \
                     double-crlf or link-dies"
                ))
            }
        })
    }
}

impl FromStr for Fault {
    type Err = String;
    fn from_str(s: &str) -> Result<Fault, String> {
        let (kind, rate) = match s.split_once(':') {
            Some((k, r)) => (k, Some(r)),
            None => (s, None),
        };
        let (kind, delay) = match kind.split_once('@') {
            Some((k, d)) => (k, Some(d)),
            None => (kind, None),
        };
        let kind: FaultKind = kind.parse()?;
        let delay_ms = match delay {
            None => None,
            Some(d) if kind == FaultKind::Slow => Some(parse_delay(d)?),
            Some(_) => return Err(format!("only `slow` takes a delay (`@…`), not `{s}`")),
        };
        let rate = match rate {
            None => FaultRate::Always,
            Some("once") => FaultRate::Times(1),
            Some(r) if r.ends_with('x') => FaultRate::Times(
                r[..r.len() - 1]
                    .parse()
                    .map_err(|_| format!("fault rate `{r}`: write e.g. 3x for the next three times"))?,
            ),
            Some(r) => {
                let p: f64 = r
                    .parse()
                    .map_err(|_| format!("fault rate `{r}`: a probability 0–1, `once` or `Nx`"))?;
                if !(0.0..=1.0).contains(&p) {
                    return Err(format!("fault rate {p} is not a probability in 0–1"));
                }
                FaultRate::Probability(p)
            }
        };
        Ok(Fault { kind, rate, delay_ms })
    }
}

/// The fault of `kind` that fires now among `faults`, if any. Every
/// matching fault is counted down; the first that fires is returned.
pub(super) fn fire(faults: &mut [Fault], rng: &mut Rng, kind: FaultKind) -> Option<Fault> {
    let mut first = None;
    for fault in faults.iter_mut().filter(|f| f.kind == kind) {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fault_specs_parse() {
        assert_eq!("garble".parse::<Fault>().unwrap(), Fault::always(FaultKind::Garble));
        assert_eq!(
            "truncate:once".parse::<Fault>().unwrap(),
            Fault::times(FaultKind::Truncate, 1)
        );
        assert_eq!("slow:3x".parse::<Fault>().unwrap(), Fault::times(FaultKind::Slow, 3));
        assert_eq!(
            "slow@2500ms:once".parse::<Fault>().unwrap(),
            Fault::slow(2500, FaultRate::Times(1))
        );
        assert_eq!(
            "slow@1.5s".parse::<Fault>().unwrap(),
            Fault::slow(1500, FaultRate::Always)
        );
        assert!("slow@2500".parse::<Fault>().unwrap_err().contains("2500ms"));
        assert!("slow@1e9s".parse::<Fault>().unwrap_err().contains("limit"));
        assert!("garble@10ms".parse::<Fault>().unwrap_err().contains("only `slow`"));
        assert_eq!(
            "link-dies:once".parse::<Fault>().unwrap(),
            Fault::times(FaultKind::LinkDies, 1)
        );
        assert_eq!(
            "no-answer:0.25".parse::<Fault>().unwrap().rate,
            FaultRate::Probability(0.25)
        );
        assert!("garble:2".parse::<Fault>().is_err());
        assert!("smoke".parse::<Fault>().unwrap_err().contains("no-answer"));
    }

    #[test]
    fn a_counted_fault_fires_its_times_then_never() {
        let mut rng = Rng::new(1);
        let mut faults = vec![Fault::times(FaultKind::Garble, 2), Fault::always(FaultKind::Slow)];
        assert!(fire(&mut faults, &mut rng, FaultKind::Truncate).is_none());
        assert!(fire(&mut faults, &mut rng, FaultKind::Garble).is_some());
        assert!(fire(&mut faults, &mut rng, FaultKind::Garble).is_some());
        assert!(fire(&mut faults, &mut rng, FaultKind::Garble).is_none());
        assert!(fire(&mut faults, &mut rng, FaultKind::Slow).is_some());
    }

    #[test]
    fn garbling_puts_noise_only_past_the_start() {
        let mut rng = Rng::new(7);
        let clean = b"00,0\r\n2.817E-01\r\n0380.,1.203E-05\r\n".to_vec();
        let mut bytes = clean.clone();
        garble(&mut rng, &mut bytes, 17);
        assert_eq!(bytes[..16], clean[..16], "the header is left alone");
        assert_ne!(bytes, clean);
    }
}
