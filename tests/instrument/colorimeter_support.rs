//! What the colorimeter tests (`colorcal`, `ls100`) share: the target the
//! simulators are aimed at, its truth computed here from the CIE 1931 table
//! (not with lightbooth's colorimetry, which the simulators use), the
//! simulator processes and the public clients, every wait bounded.

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use lightbooth::spectrum::{Grid, SpectralUnit, Spectrum};
use serde_json::Value;

pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The target: a smooth spectral radiance, W/(sr·m²·nm) at 1 nm, 380–780
/// nm, a broad hump on a tilted floor (about 36 cd/m², x ≈ 0.37).
pub fn radiance_at(nm: f64) -> f64 {
    2.0e-4 + 1.5e-7 * (nm - 380.0) + 3.0e-4 * (-((nm - 560.0) / 120.0).powi(2)).exp()
}

/// The target scaled by `scale`, as a spectrum for an in-process simulator.
pub fn target(scale: f64) -> Spectrum {
    let values = (380..=780).map(|nm| scale * radiance_at(f64::from(nm))).collect();
    Spectrum::new(Grid::one_nm(), SpectralUnit::SpectralRadiance, values).unwrap()
}

/// The target as `nm,radiance` CSV in `dir`, for a simulator process.
pub fn write_target(dir: &Path) -> PathBuf {
    let path = dir.join("target.csv");
    let mut text = String::from("nm,radiance\n");
    for nm in 380..=780 {
        text.push_str(&format!("{nm},{:e}\n", radiance_at(f64::from(nm))));
    }
    std::fs::write(&path, text).unwrap();
    path
}

/// The target's X, Y, Z (cd/m²): 683 lm/W · Σ x̄ȳz̄(λ) L(λ) · 1 nm, read
/// from `crates/science/src/reference_data/cie1931_2deg_cmf.csv` here.
pub fn truth_xyz(scale: f64) -> [f64; 3] {
    let text = std::fs::read_to_string(root().join("crates/science/src/reference_data/cie1931_2deg_cmf.csv")).unwrap();
    let mut xyz = [0.0; 3];
    for line in text.lines().skip(1).filter(|l| !l.trim().is_empty()) {
        let v: Vec<f64> = line.split(',').map(|f| f.trim().parse().unwrap()).collect();
        if (380.0..=780.0).contains(&v[0]) {
            let l = scale * radiance_at(v[0]);
            for i in 0..3 {
                xyz[i] += 683.0 * v[i + 1] * l;
            }
        }
    }
    xyz
}

pub fn chromaticity(xyz: [f64; 3]) -> (f64, f64) {
    let s = xyz[0] + xyz[1] + xyz[2];
    (xyz[0] / s, xyz[1] / s)
}

/// A simulator process; killed when dropped.
pub struct Simulator {
    child: Child,
    pub port: String,
}

impl Drop for Simulator {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// `lightbooth <subcommand> --spectrum TARGET <extra>`, its device path read
/// from its first stdout line (within 20 s).
pub fn start_simulator(subcommand: &str, target: &Path, extra: &[&str]) -> Simulator {
    let mut child = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .arg(subcommand)
        .arg("--spectrum")
        .arg(target)
        .args(extra)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let stdout = child.stdout.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut first = String::new();
        let _ = BufReader::new(stdout).read_line(&mut first);
        let _ = tx.send(first);
    });
    let first = match rx.recv_timeout(Duration::from_secs(20)) {
        Ok(line) => line,
        Err(_) => {
            let _ = child.kill();
            panic!("{subcommand} printed no device path within 20 s");
        }
    };
    let port = first.trim().to_string();
    assert!(
        port.starts_with("/dev/"),
        "{subcommand} printed {first:?}, not a device path"
    );
    Simulator { child, port }
}

/// Runs `command` to its end within `limit`, killing it past that; its
/// stdout, or a failure with both streams.
pub fn run_bounded(mut command: Command, what: &str, limit: Duration) -> String {
    let mut child = command.stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
    let mut out_pipe = child.stdout.take().unwrap();
    let mut err_pipe = child.stderr.take().unwrap();
    let out_thread = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = out_pipe.read_to_string(&mut s);
        s
    });
    let err_thread = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = err_pipe.read_to_string(&mut s);
        s
    });
    let started = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if started.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{what} did not finish within {} s", limit.as_secs());
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let (out, err) = (out_thread.join().unwrap(), err_thread.join().unwrap());
    assert!(
        status.success(),
        "{what} failed ({status})\nstdout: {out}\nstderr: {err}"
    );
    out
}

/// A public client script in `tests/python` with the venv's Python
/// (`tests/setup.sh` makes it, with psychopy-crs and psychopy-minolta), its
/// JSON report.
pub fn python_client(script: &str, args: &[&str], limit: Duration) -> Value {
    let python = root().join("target/py/bin/python");
    assert!(
        python.exists(),
        "{} is missing: run tests/setup.sh (it makes the tests' Python venv with psychopy-crs and psychopy-minolta)",
        python.display()
    );
    let mut command = Command::new(python);
    command
        .arg(root().join("tests/python").join(script))
        .args(args)
        .env("PYTHONPATH", root().join("tests/python"));
    let out = run_bounded(command, script, limit);
    serde_json::from_str(out.trim()).unwrap_or_else(|e| panic!("{script} printed no JSON ({e}): {out}"))
}

/// `lightbooth measure --json` with `args`, its JSON.
pub fn lightbooth_measure(args: &[&str]) -> Value {
    let mut command = Command::new(env!("CARGO_BIN_EXE_lightbooth"));
    command.arg("measure").arg("--json").args(args);
    let out = run_bounded(command, "lightbooth measure", Duration::from_secs(60));
    serde_json::from_str(out.trim()).unwrap_or_else(|e| panic!("measure printed no JSON ({e}): {out}"))
}

pub fn number(report: &Value, pointer: &str) -> f64 {
    report
        .pointer(pointer)
        .and_then(Value::as_f64)
        .unwrap_or_else(|| panic!("no number at {pointer} in {report}"))
}

/// `got` within `fraction` of `truth`, or a failure naming `what`.
pub fn assert_within(got: f64, truth: f64, fraction: f64, what: &str) {
    assert!(
        (got / truth - 1.0).abs() <= fraction,
        "{what}: {got} is not within {} % of the truth {truth}",
        fraction * 100.0
    );
}
