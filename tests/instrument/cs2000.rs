//! The Konica Minolta CS-2000 family: lightbooth's driver against the
//! simulator in process over a real pty (the spectrum on its 1 nm grid
//! within the model's noise, the unit's own XYZ beside it, the flash never
//! written, each documented error code typed with its meaning, the link
//! faults retried or typed, a unit that needs polling, a pulled cable), and
//! colour-specio's own `CS2000` class measuring through `lightbooth
//! mock-cs2000` with its default flags.

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use lightbooth::instrument::cs2000::{open_cs2000, Cs2000Settings, Model};
use lightbooth::instrument::sim::{spawn_mock, Fault, FaultKind, MockConfig, MockHandle};
use lightbooth::instrument::{AveragedMeasurement, InstrumentError, QualityKind, Spectroradiometer};
use lightbooth::spectrum::{Grid, SpectralUnit};
use tokio_util::sync::CancellationToken;

use crate::common::pr655_wire::d65_radiance;

fn mock(model: Model, faults: Vec<Fault>) -> MockHandle {
    let mut cfg = MockConfig::cs2000(d65_radiance(), model);
    cfg.speed = 0.0;
    cfg.faults = faults;
    cfg.seed = 11;
    cfg.slow_ms = 600;
    spawn_mock(cfg).unwrap()
}

/// Short, bounded timeouts: no test waits longer than a few of these.
fn settings(model: Model) -> Cs2000Settings {
    Cs2000Settings {
        command_timeout_ms: 400,
        measure_timeout_ms: 3_000,
        end_margin_ms: 300,
        poll_interval_ms: 50,
        gap_timeout_ms: 200,
        resync_quiet_ms: 50,
        ..Cs2000Settings::for_model(model)
    }
}

fn open(mock: &MockHandle, settings: &Cs2000Settings) -> Result<Box<dyn Spectroradiometer>, InstrumentError> {
    open_cs2000(mock.device_path().to_str().unwrap(), settings)
}

fn measure(unit: &mut dyn Spectroradiometer, n: usize) -> Result<AveragedMeasurement, InstrumentError> {
    unit.measure_averaged(n, &CancellationToken::new(), &mut |_| {})
}

/// The mean agrees with the simulator's noise-free reading within 5σ/√n at
/// every nm (the reading is the model's, computed from the target apart
/// from the wire), per nm on the 1 nm grid; the unit's own Y is the
/// luminance of its own spectrum.
fn assert_sound(m: &AveragedMeasurement, mock: &MockHandle) {
    let mean = m.mean.as_ref().expect("a spectrum");
    assert_eq!(mean.grid(), &Grid::one_nm());
    assert_eq!(mean.unit(), SpectralUnit::SpectralRadiance);
    let reading = mock.expected_reading().unwrap();
    let n = m.good_samples().count() as f64;
    for ((v, e), sigma) in mean.values().iter().zip(&reading.expected).zip(&reading.sigma) {
        // Hex singles carry 24 bits: a relative 6e-8.
        let tol = 5.0 * sigma / n.sqrt() + 1e-6 * e.abs();
        assert!((v - e).abs() <= tol, "{v} vs {e} ± {tol}");
    }
    for s in m.good_samples() {
        let [_, y, _] = s.instrument_xyz.expect("the unit's own XYZ");
        assert!(
            (y / s.luminance.unwrap() - 1.0).abs() < 1e-5,
            "Y {y} vs Lv {:?}",
            s.luminance
        );
    }
    let [_, y, _] = m.instrument_xyz.unwrap();
    assert!(
        (y / m.luminance_cd_m2 - 1.0).abs() < 0.01,
        "{y} vs {}",
        m.luminance_cd_m2
    );
}

#[test]
fn each_model_measures_its_1nm_spectrum_and_never_writes_the_flash() {
    for model in [Model::Cs2000, Model::Cs2000A, Model::Cs3000] {
        let mock = mock(model, vec![]);
        let mut unit = open(&mock, &settings(model)).unwrap();
        assert_eq!(unit.info().model, model.name());
        assert_eq!(unit.info().serial.as_deref(), Some("20101234"));
        let m = measure(unit.as_mut(), 3).unwrap();
        assert_eq!(m.samples.len(), 3);
        assert_sound(&m, &mock);
        assert_eq!(
            mock.flash_writes(),
            0,
            "{}: the driver wrote the unit's flash",
            model.name()
        );
    }
}

#[test]
fn a_settings_file_for_another_model_of_the_family_is_refused_by_name() {
    let mock = mock(Model::Cs2000A, vec![]);
    let e = open(&mock, &settings(Model::Cs2000)).err().expect("refused");
    let text = e.to_string();
    assert!(text.contains("CS-2000A") && text.contains("--model cs2000a"), "{text}");
}

/// A unit whose estimate is short and whose end line never comes: the
/// driver polls `MEDR,0,0,1` through `ER02` until the data are ready.
#[test]
fn a_unit_that_must_be_polled_through_not_ready_answers_still_measures() {
    let mut cfg = MockConfig::cs2000(d65_radiance(), Model::Cs2000);
    cfg.speed = 0.15; // about 0.3 s per measurement: several ER02 polls
    cfg.short_estimate = true;
    let mock = spawn_mock(cfg).unwrap();
    let s = Cs2000Settings {
        end_margin_ms: 20,
        ..settings(Model::Cs2000)
    };
    let mut unit = open(&mock, &s).unwrap();
    let m = measure(unit.as_mut(), 2).unwrap();
    assert_eq!(m.samples.len(), 2);
    assert_sound(&m, &mock);
}

#[test]
fn every_documented_error_code_is_typed_with_its_meaning_and_never_averaged() {
    for (code, kind, words) in [
        (10, QualityKind::Overload, "too high"),
        (51, QualityKind::Hardware, "temperature"),
        (52, QualityKind::Hardware, "temperature"),
        (71, QualityKind::Sync, "flicker"),
        (83, QualityKind::Other, "measuring spot"),
    ] {
        let mut cfg = MockConfig::cs2000(d65_radiance(), Model::Cs2000);
        cfg.speed = 0.0;
        cfg.error_code = code;
        cfg.faults = vec![Fault::times(FaultKind::ErrorCode, 1)];
        let mock = spawn_mock(cfg).unwrap();
        let mut unit = open(&mock, &settings(Model::Cs2000)).unwrap();
        let mut seen = Vec::new();
        let m = unit
            .measure_averaged(1, &CancellationToken::new(), &mut |s| seen.push(s.code.clone()))
            .unwrap();
        assert_eq!((seen[0].code, seen[0].kind), (i32::from(code), kind), "ER{code}");
        assert!(seen[0].message.contains(words), "ER{code}: {}", seen[0].message);
        assert_eq!(m.samples.len(), 2, "ER{code}: the bad sample is kept, not averaged");
        assert_sound(&m, &mock);
        mock.set_faults(vec![Fault::always(FaultKind::ErrorCode)]);
        match measure(unit.as_mut(), 1).unwrap_err() {
            InstrumentError::Quality { code: c, good: 0, .. } => assert_eq!(c, i32::from(code)),
            other => panic!("ER{code}: expected a quality error, got {other}"),
        }
    }
}

#[test]
fn link_faults_are_retried_or_typed_and_the_port_stays_usable() {
    for kind in [
        FaultKind::NoAnswer,
        FaultKind::Truncate,
        FaultKind::Garble,
        FaultKind::Slow,
    ] {
        let mock = mock(Model::Cs2000, vec![Fault::times(kind, 1)]);
        let mut unit = open(&mock, &settings(Model::Cs2000)).unwrap();
        let m = measure(unit.as_mut(), 2).unwrap_or_else(|e| panic!("{kind:?}: {e}"));
        assert_sound(&m, &mock);
        mock.set_faults(vec![Fault::always(kind)]);
        let e = measure(unit.as_mut(), 1).expect_err("an always-faulty block gives no data");
        assert!(
            e.is_retryable_link_fault() || matches!(e, InstrumentError::Unresponsive { .. }),
            "{kind:?}: {e}"
        );
        mock.set_faults(vec![]);
        let m = measure(unit.as_mut(), 1).unwrap_or_else(|e| panic!("{kind:?}: port unusable afterwards: {e}"));
        assert_sound(&m, &mock);
    }
}

/// Silence: a port where nothing answers is reported within the command
/// timeout, naming what to check.
#[test]
fn a_silent_port_is_reported_with_what_to_check() {
    let (_master, slave) = serialport::TTYPort::pair().unwrap();
    let path = serialport::SerialPort::name(&slave).unwrap();
    let started = Instant::now();
    let e = open_cs2000(&path, &settings(Model::Cs2000)).err().expect("no unit");
    assert!(started.elapsed() < Duration::from_secs(3), "{:?}", started.elapsed());
    let text = e.to_string();
    assert!(matches!(e, InstrumentError::NoReply { .. }), "{text}");
    assert!(text.contains("RMTS,1") && text.contains("remote mode"), "{text}");
}

#[test]
fn a_pulled_usb_cable_mid_measurement_is_a_closed_port() {
    let mut cfg = MockConfig::cs2000(d65_radiance(), Model::Cs2000);
    cfg.speed = 0.1;
    cfg.faults = vec![Fault::always(FaultKind::CablePull)];
    let mock = spawn_mock(cfg).unwrap();
    let mut unit = open(&mock, &settings(Model::Cs2000)).unwrap();
    let e = measure(unit.as_mut(), 1).unwrap_err();
    assert!(matches!(e, InstrumentError::PortClosed { .. }), "{e}");
}

// ---- colour-specio's CS2000 class against `lightbooth mock-cs2000` ----------

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A smooth spectral radiance at 1 nm (about 36 cd/m²), as for PsychoPy's clients.
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

struct Simulator(Child);

impl Drop for Simulator {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn start_simulator(truth: &Path, extra: &[&str]) -> (Simulator, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .arg("mock-cs2000")
        .arg("--spectrum")
        .arg(truth)
        .args(["--speed", "0.2"])
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
    assert!(port.starts_with("/dev/"), "mock-cs2000 printed {first:?}");
    (Simulator(child), port)
}

/// Runs `tests/python/specio_client.py` against `port`: its JSON report.
/// Bounded: two measurements of about half a second, and colour's import.
fn specio(port: &str, truth: &Path) -> serde_json::Value {
    let python = root().join("target/py312/bin/python");
    assert!(
        python.exists(),
        "{} is missing: run tests/setup.sh (it makes the Python 3.12 venv with colour-specio)",
        python.display()
    );
    let mut child = Command::new(python)
        .arg(root().join("tests/python/specio_client.py"))
        .arg(port)
        .arg(truth)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if started.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            panic!("colour-specio's CS2000 did not finish within 120 s on {port}");
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let (mut out, mut err) = (String::new(), String::new());
    child.stdout.take().unwrap().read_to_string(&mut out).unwrap();
    child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    assert!(
        status.success(),
        "colour-specio failed on {port} ({status})\nstdout: {out}\nstderr: {err}"
    );
    serde_json::from_str(out.trim()).unwrap_or_else(|e| panic!("not JSON ({e}): {out}\nstderr: {err}"))
}

fn number(v: &serde_json::Value, key: &str, i: usize) -> f64 {
    v[key][i].as_f64().unwrap_or_else(|| panic!("no {key}[{i}] in {v}"))
}

/// colour-specio's class, with the simulator's default flags: it identifies
/// the unit, reads its speed and sync modes, measures twice (sleeping the
/// announced time, discarding the end line, polling the conditions,
/// fetching the four hex blocks), and colour-science's XYZ of what it got
/// is within 3 % in Y and 0.003 in x, y of colour-science's XYZ of the
/// target (both computed by programs lightbooth did not write).
#[test]
fn colour_specio_cs2000_class_measures_through_mock_cs2000_with_default_flags() {
    let dir = tempfile::tempdir().unwrap();
    let truth = write_truth(dir.path());
    for (flag, model) in [("cs2000", "CS-2000"), ("cs2000a", "CS-2000A")] {
        let (_sim, port) = start_simulator(&truth, &["--model", flag]);
        let report = specio(&port, &truth);
        eprintln!("{report}");
        assert_eq!(report["model"], model, "{report}");
        assert_eq!(report["serial"], "20101234", "{report}");
        assert_eq!(report["speed_mode"], "NORMAL", "{report}");
        assert_eq!(report["sync_mode"], "NO_SYNC", "{report}");
        assert_eq!(report["spectrum_points"], 401, "{report}");
        assert_eq!(report["spectrum_first_nm"], 380.0, "{report}");
        assert_eq!(report["spectrum_last_nm"], 780.0, "{report}");
        let (y, truth_y) = (number(&report, "XYZ", 1), number(&report, "truth_XYZ", 1));
        assert!((y / truth_y - 1.0).abs() < 0.03, "Y {y} vs {truth_y}: {report}");
        for i in 0..2 {
            let (got, want) = (number(&report, "xy", i), number(&report, "truth_xy", i));
            assert!((got - want).abs() < 0.003, "xy[{i}] {got} vs {want}: {report}");
        }
        assert!(report["exposure_s"].as_f64().unwrap() > 0.0, "{report}");
    }
}
