//! The simulators, with their default flags, measured by a client the
//! project did not write: PsychoPy's own Photo Research classes (PyPI
//! `psychopy-photoresearch`, in the venv `tests/setup.sh` makes under
//! `target/py`; `tests/python/psychopy` stands in for the one PsychoPy module
//! they import, `psychopy.logging`).
//!
//! PsychoPy's `PR655` (its class for the PR-655 and the PR-670) writes
//! `PHOTO` one byte per `write()` with no pause and ends every command with
//! LF; the protocol sheet's section 1 grades both habits as working on real
//! units, so the simulators' defaults must answer it. Each test starts
//! `lightbooth mock-pr655`/`mock-pr670`/`mock-pr650` on a real pty, aimed
//! at a smooth spectrum, and runs `tests/python/psychopy_client.py`, which
//! connects, reads the model and serial, measures, fetches the spectrum and
//! the luminance, and computes the truth itself (683 lm/W · Σ ȳ L Δλ with
//! the CIE 1931 table): the luminance must be within 0.2 % of it, the
//! spectrum correlate with the truth and be per-nm radiance.

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The venv's Python, or a failure saying how to make it.
fn venv_python() -> PathBuf {
    let python = root().join("target/py/bin/python");
    assert!(
        python.exists(),
        "{} is missing: run tests/setup.sh (it makes the tests' Python venv with psychopy-photoresearch)",
        python.display()
    );
    python
}

/// A smooth spectral radiance, W/(sr·m²·nm) at 1 nm, 380–780 nm: a broad
/// hump on a tilted floor (about 36 cd/m²), so the correlation test means
/// something, yet broad enough (σ ≈ 85 nm) that the instruments' slits move
/// the luminance by well under 0.1 %.
fn write_truth(dir: &Path) -> PathBuf {
    let path = dir.join("truth.csv");
    let mut text = String::from("nm,radiance\n");
    for nm in 380..=780 {
        let x = f64::from(nm);
        let value = 2.0e-4 + 1.5e-7 * (x - 380.0) + 3.0e-4 * (-((x - 560.0) / 120.0).powi(2)).exp();
        text.push_str(&format!("{nm},{value:e}\n"));
    }
    std::fs::write(&path, text).unwrap();
    path
}

/// A simulator process; killed when dropped.
struct Simulator {
    child: Child,
    port: String,
}

impl Drop for Simulator {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn start_simulator(subcommand: &str, truth: &Path, extra: &[&str]) -> Simulator {
    let mut child = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .arg(subcommand)
        .arg("--spectrum")
        .arg(truth)
        .args(["--speed", "0.2", "--serial", "SIM12345"])
        .args(extra)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let mut first = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    let port = first.trim().to_string();
    assert!(
        port.starts_with("/dev/"),
        "{subcommand} printed {first:?}, not a device path"
    );
    Simulator { child, port }
}

/// Runs PsychoPy's `class` against `port`; its JSON report. Bounded: the
/// client's own time-outs are 10 s (banner) and 30 s (a measurement).
fn psychopy(class: &str, port: &str, truth: &Path) -> Value {
    let mut child = Command::new(venv_python())
        .arg(root().join("tests/python/psychopy_client.py"))
        .args([class, port])
        .arg(truth)
        .arg(root().join("crates/science/src/reference_data/cie1931_2deg_cmf.csv"))
        .env("PYTHONPATH", root().join("tests/python"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if started.elapsed() > Duration::from_secs(150) {
            let _ = child.kill();
            panic!("PsychoPy's {class} did not finish within 150 s on {port}");
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let (mut out, mut err) = (String::new(), String::new());
    child.stdout.take().unwrap().read_to_string(&mut out).unwrap();
    child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    assert!(
        status.success(),
        "PsychoPy's {class} failed on {port} ({status}); if it cannot import psychopy_photoresearch, run \
         tests/setup.sh\nstdout: {out}\nstderr: {err}"
    );
    serde_json::from_str(out.trim()).unwrap_or_else(|e| panic!("not JSON ({e}): {out}\nstderr: {err}"))
}

fn f(report: &Value, key: &str) -> f64 {
    report[key]
        .as_f64()
        .unwrap_or_else(|| panic!("no number `{key}` in {report}"))
}

/// The checks every client's report passes: luminance within 0.2 % of the
/// truth (twice: `measure` and `getLum`), a spectrum that correlates with
/// the truth to 0.999 and is per-nm radiance (scale 1 within 2 %: the slit
/// and the noise, nothing like the ×4 of power per band).
fn check_measured(report: &Value, model: &str, step_nm: f64) {
    assert_eq!(report["model"], model, "{report}");
    assert_eq!(report["serial"], "SIM12345", "{report}");
    let truth = f(report, "truth_Y_cd_m2");
    for key in ["Y_cd_m2", "second_Y_cd_m2"] {
        let y = f(report, key);
        assert!(
            (y / truth - 1.0).abs() < 0.002,
            "{model}: PsychoPy's {key} {y} cd/m² is not within 0.2 % of the truth {truth}: {report}"
        );
    }
    assert!(f(report, "spectrum_points") >= 100.0, "{report}");
    assert_eq!(f(report, "spectrum_last_nm"), 780.0, "{report}");
    assert_eq!(f(report, "spectrum_step_nm"), step_nm, "{report}");
    let r = f(report, "spectrum_correlation");
    assert!(r > 0.999, "{model}: spectrum correlation {r}: {report}");
    let scale = f(report, "spectrum_scale");
    assert!((scale - 1.0).abs() < 0.02, "{model}: spectrum scale {scale}: {report}");
}

/// The bug: with default flags PsychoPy's PR655 got no banner from
/// `mock-pr655` (its `PHOTO` letters arrive together) and no reply to its
/// LF-terminated commands.
#[test]
fn psychopy_pr655_class_measures_through_mock_pr655_with_default_flags() {
    let dir = tempfile::tempdir().unwrap();
    let truth = write_truth(dir.path());
    let sim = start_simulator("mock-pr655", &truth, &[]);
    let report = psychopy("PR655", &sim.port, &truth);
    eprintln!("{report}");
    check_measured(&report, "PR-655", 4.0);
    // Its XYZ is the same measurement's: Y matches the luminance it read.
    let xyz_y = report["XYZ_cd_m2"][1].as_f64().unwrap();
    assert!((xyz_y / f(&report, "Y_cd_m2") - 1.0).abs() < 0.002, "{report}");
}

#[test]
fn psychopy_pr655_class_measures_through_mock_pr670_with_default_flags() {
    let dir = tempfile::tempdir().unwrap();
    let truth = write_truth(dir.path());
    let sim = start_simulator("mock-pr670", &truth, &[]);
    let report = psychopy("PR655", &sim.port, &truth);
    eprintln!("{report}");
    check_measured(&report, "PR-670", 2.0);
}

/// psychopy-photoresearch also has a `PR650` class (lower-case commands,
/// LF, `b1` as its first command, within the power-on window).
#[test]
fn psychopy_pr650_class_measures_through_mock_pr650_with_default_flags() {
    let dir = tempfile::tempdir().unwrap();
    let truth = write_truth(dir.path());
    let sim = start_simulator("mock-pr650", &truth, &[]);
    let report = psychopy("PR650", &sim.port, &truth);
    eprintln!("{report}");
    check_measured(&report, "PR650", 4.0);
}

/// The stricter readings stay available: with `--strict-photo` PsychoPy's
/// unpaced `PHOTO` gets no banner (what the default used to do).
#[test]
fn strict_photo_flag_keeps_the_old_strict_remote_entry() {
    let dir = tempfile::tempdir().unwrap();
    let truth = write_truth(dir.path());
    let sim = start_simulator("mock-pr655", &truth, &["--strict-photo", "--cr-only"]);
    let mut child = Command::new(venv_python())
        .arg(root().join("tests/python/psychopy_client.py"))
        .args(["PR655", &sim.port])
        .arg(&truth)
        .arg(root().join("crates/science/src/reference_data/cie1931_2deg_cmf.csv"))
        .env("PYTHONPATH", root().join("tests/python"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while child.try_wait().unwrap().is_none() && started.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(100));
    }
    let _ = child.kill();
    let status = child.wait().unwrap();
    assert!(
        !status.success(),
        "a strict simulator answered PsychoPy's unpaced PHOTO and LF commands"
    );
}
