//! Benchmark (not a test): lightbooth's own overhead for a five-sample PR-650
//! measurement, and what fraction it adds to the instrument's own time.
//!
//! The simulated PR-650 runs at `--speed 0` (no integration time, no 9600-baud
//! pacing), so the wall time of `measure_averaged(5)` is the driver's work
//! (flushes, writes, reads, parsing, averaging) plus the simulator's and the
//! pty's: an upper bound on the driver's overhead. The instrument's own time
//! at `--speed 1` comes from the same simulator model: per sample, the
//! measurement time plus the wire time of the commands and the `M0`, `D5`
//! and `D2` replies at 9600 baud.
//!
//! Run: `cargo bench --bench pr650_overhead` (prints median and quartiles).

use std::time::{Duration, Instant};

use lightbooth::instrument::sim::{spawn_mock, MockConfig};
use lightbooth::instrument::{open_pr650, Pr650Settings};
use lightbooth::reference_data::{illuminant, Illuminant};
use lightbooth::spectrum::{SpectralUnit, Spectrum};
use tokio_util::sync::CancellationToken;

const SAMPLES: usize = 5;
const RUNS: usize = 30;
/// One byte at 9600 baud 8N1, ms.
const BYTE_MS: f64 = 10.0 / 9.6;

fn main() {
    let d65 = illuminant(Illuminant::D65);
    let values = d65.values().iter().map(|v| v * 1.4e-5).collect(); // about 100 cd/m²
    let truth = Spectrum::new(d65.grid().clone(), SpectralUnit::SpectralRadiance, values).unwrap();
    let mut cfg = MockConfig::new(truth);
    cfg.speed = 0.0;
    cfg.pace_output = false;
    cfg.remote_window_ms = None;
    let mock = spawn_mock(cfg).expect("pty");
    let mut pr650 = open_pr650(mock.device_path().to_str().unwrap(), &Pr650Settings::default()).expect("open");
    let cancel = CancellationToken::new();
    pr650.measure_averaged(SAMPLES, &cancel, &mut |_| {}).expect("warm-up");

    let mut times: Vec<Duration> = (0..RUNS)
        .map(|_| {
            let start = Instant::now();
            pr650.measure_averaged(SAMPLES, &cancel, &mut |_| {}).expect("measure");
            start.elapsed()
        })
        .collect();
    times.sort();
    let ms = |d: Duration| d.as_secs_f64() * 1000.0;
    let median = ms(times[RUNS / 2]);

    let reading = mock.expected_reading().unwrap();
    // Per sample on the wire: "M0\n" + "000\r\n", "D5\n" + 1734 bytes, "D2\n" + 36 bytes.
    let wire_bytes = (3 + 5) + (3 + 1734) + (3 + 36);
    let instrument_ms = SAMPLES as f64 * (reading.duration_ms + wire_bytes as f64 * BYTE_MS);
    println!("pr650_overhead: {SAMPLES}-sample measurement at --speed 0, {RUNS} runs");
    println!(
        "  driver + simulator overhead: median {median:.2} ms (quartiles {:.2}–{:.2} ms, min {:.2} ms)",
        ms(times[RUNS / 4]),
        ms(times[3 * RUNS / 4]),
        ms(times[0])
    );
    println!(
        "  instrument's own time at --speed 1: {instrument_ms:.0} ms ({:.0} ms measuring + {:.0} ms on the wire per sample)",
        reading.duration_ms,
        wire_bytes as f64 * BYTE_MS
    );
    println!(
        "  overhead added: {:.3} % (goal: under 1 %)",
        100.0 * median / instrument_ms
    );
}
