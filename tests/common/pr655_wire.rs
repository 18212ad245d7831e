//! The PR-655/PR-670 simulators' side of the wire, for tests that talk to a
//! simulator's pty directly (byte-level checks) and for its truth.

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use lightbooth::reference_data::{illuminant, Illuminant};
use lightbooth::spectrum::{SpectralUnit, Spectrum};

/// D65 scaled to about 100 cd/m²: the simulated target both PR-655/670
/// test files measure.
pub fn d65_radiance() -> Spectrum {
    let d65 = illuminant(Illuminant::D65);
    let values = d65.values().iter().map(|v| v * 1.4e-5).collect();
    Spectrum::new(d65.grid().clone(), SpectralUnit::SpectralRadiance, values).unwrap()
}

/// Sends `command` with CR and reads its reply lines (the simulator answers in one burst).
pub fn ask(port: &mut Box<dyn serialport::SerialPort>, command: &str) -> Vec<String> {
    port.write_all(format!("{command}\r").as_bytes()).unwrap();
    let mut reply = Vec::new();
    let mut buf = [0u8; 4096];
    let t0 = Instant::now();
    // Until 100 ms without a byte (PTB's end-of-reply rule, with margin).
    let mut last = Instant::now();
    while t0.elapsed() < Duration::from_secs(3) && (reply.is_empty() || last.elapsed() < Duration::from_millis(100)) {
        if let Ok(n) = port.read(&mut buf) {
            reply.extend_from_slice(&buf[..n]);
            last = Instant::now();
        }
    }
    String::from_utf8_lossy(&reply)
        .lines()
        .map(|l| l.trim().to_string())
        .filter(|l| !l.is_empty())
        .collect()
}
