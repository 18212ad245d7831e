//! The Colorimetry Research CR-250 and CR-300: lightbooth's driver against
//! the simulator in process over a real pty (each model's spectrum on its
//! own grid within the model's noise, the unit's XYZ beside it, a
//! colorimeter refused, each light-level and sync code typed with its
//! meaning, link faults retried or typed, a silent port, a pulled cable),
//! and colour-specio's own `CRSpectrometer` measuring through `lightbooth
//! mock-cr250` with its default flags (it waits only 25 ms for a reply).

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use lightbooth::instrument::cr250::{open_cr250, Cr250Settings, Model};
use lightbooth::instrument::sim::{spawn_mock, Fault, FaultKind, MockConfig, MockHandle};
use lightbooth::instrument::{AveragedMeasurement, InstrumentError, QualityKind, Spectroradiometer};
use lightbooth::spectrum::SpectralUnit;
use tokio_util::sync::CancellationToken;

use crate::common::pr655_wire::d65_radiance;

fn mock(model: Model, faults: Vec<Fault>) -> MockHandle {
    let mut cfg = MockConfig::cr250(d65_radiance(), model);
    cfg.speed = 0.0;
    cfg.faults = faults;
    cfg.seed = 5;
    cfg.slow_ms = 600;
    spawn_mock(cfg).unwrap()
}

fn settings(model: Model) -> Cr250Settings {
    Cr250Settings {
        command_timeout_ms: 400,
        measure_timeout_ms: Some(3_000),
        gap_timeout_ms: 200,
        resync_quiet_ms: 50,
        ..Cr250Settings::for_model(model)
    }
}

fn open(mock: &MockHandle, settings: &Cr250Settings) -> Result<Box<dyn Spectroradiometer>, InstrumentError> {
    open_cr250(mock.device_path().to_str().unwrap(), settings)
}

fn measure(unit: &mut dyn Spectroradiometer, n: usize) -> Result<AveragedMeasurement, InstrumentError> {
    unit.measure_averaged(n, &CancellationToken::new(), &mut |_| {})
}

/// The mean agrees with the simulator's noise-free reading within 5σ/√n
/// (plus the 7 significant digits on the wire), on the model's grid.
fn assert_sound(m: &AveragedMeasurement, mock: &MockHandle, model: Model) {
    let mean = m.mean.as_ref().expect("a spectrum");
    assert_eq!(mean.grid(), &model.grid());
    assert_eq!(mean.unit(), SpectralUnit::SpectralRadiance);
    let reading = mock.expected_reading().unwrap();
    let n = m.good_samples().count() as f64;
    for ((v, e), sigma) in mean.values().iter().zip(&reading.expected).zip(&reading.sigma) {
        let tol = 5.0 * sigma / n.sqrt() + 1e-6 * e.abs();
        assert!((v - e).abs() <= tol, "{v} vs {e} ± {tol}");
    }
    for s in m.good_samples() {
        let [_, y, _] = s.instrument_xyz.expect("the unit's XYZ");
        assert_eq!(Some(y), s.luminance);
    }
}

#[test]
fn each_model_measures_on_its_own_grid() {
    for (model, points) in [(Model::Cr250, 101), (Model::Cr300, 401)] {
        let mock = mock(model, vec![]);
        let mut unit = open(&mock, &settings(model)).unwrap();
        assert_eq!(unit.info().model, model.name());
        assert_eq!(unit.info().serial.as_deref(), Some("25010042"));
        let m = measure(unit.as_mut(), 3).unwrap();
        assert_eq!(m.mean.as_ref().unwrap().values().len(), points);
        assert_sound(&m, &mock, model);
    }
    let mock = mock(Model::Cr300, vec![]);
    let e = open(&mock, &settings(Model::Cr250)).err().expect("the wrong model");
    assert!(e.to_string().contains("--model cr300"), "{e}");
}

#[test]
fn every_light_level_and_sync_code_is_typed_with_its_meaning_and_never_averaged() {
    for (code, kind, words) in [
        (100, QualityKind::LowLight, "too dark"),
        (-303, QualityKind::Other, "fluctuates"),
        (-304, QualityKind::LowLight, "too low"),
        (-305, QualityKind::Other, "not measurable"),
        (-306, QualityKind::Overload, "too high"),
        (101, QualityKind::Sync, "constant"),
        (102, QualityKind::Sync, "auto-sync"),
        (103, QualityKind::Sync, "too low"),
    ] {
        let mut cfg = MockConfig::cr250(d65_radiance(), Model::Cr250);
        cfg.speed = 0.0;
        cfg.error_status = code;
        cfg.faults = vec![Fault::times(FaultKind::ErrorCode, 1)];
        let mock = spawn_mock(cfg).unwrap();
        let mut unit = open(&mock, &settings(Model::Cr250)).unwrap();
        let mut seen = Vec::new();
        let m = unit
            .measure_averaged(1, &CancellationToken::new(), &mut |s| seen.push(s.code.clone()))
            .unwrap();
        assert_eq!((seen[0].code, seen[0].kind), (code, kind), "{code}");
        assert!(seen[0].message.contains(words), "{code}: {}", seen[0].message);
        assert_eq!(m.samples.len(), 2);
        assert_sound(&m, &mock, Model::Cr250);
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
        let mock = mock(Model::Cr250, vec![Fault::times(kind, 1)]);
        let mut unit = open(&mock, &settings(Model::Cr250)).unwrap();
        let m = measure(unit.as_mut(), 2).unwrap_or_else(|e| panic!("{kind:?}: {e}"));
        assert_sound(&m, &mock, Model::Cr250);
        mock.set_faults(vec![Fault::always(kind)]);
        let e = measure(unit.as_mut(), 1).expect_err("an always-faulty spectrum gives no data");
        assert!(
            e.is_retryable_link_fault() || matches!(e, InstrumentError::Unresponsive { .. }),
            "{kind:?}: {e}"
        );
        mock.set_faults(vec![]);
        let m = measure(unit.as_mut(), 1).unwrap_or_else(|e| panic!("{kind:?}: port unusable afterwards: {e}"));
        assert_sound(&m, &mock, Model::Cr250);
    }
}

#[test]
fn a_silent_port_and_a_pulled_cable_are_reported() {
    let (_master, slave) = serialport::TTYPort::pair().unwrap();
    let path = serialport::SerialPort::name(&slave).unwrap();
    let started = Instant::now();
    let e = open_cr250(&path, &settings(Model::Cr250)).err().expect("no unit");
    assert!(started.elapsed() < Duration::from_secs(3), "{:?}", started.elapsed());
    assert!(matches!(e, InstrumentError::NoReply { .. }), "{e}");

    let mut cfg = MockConfig::cr250(d65_radiance(), Model::Cr250);
    cfg.speed = 0.1;
    cfg.faults = vec![Fault::always(FaultKind::CablePull)];
    let mock = spawn_mock(cfg).unwrap();
    let mut unit = open(&mock, &settings(Model::Cr250)).unwrap();
    let e = measure(unit.as_mut(), 1).unwrap_err();
    assert!(matches!(e, InstrumentError::PortClosed { .. }), "{e}");
}

// ---- colour-specio's CRSpectrometer against `lightbooth mock-cr250` ---------

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

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
        .arg("mock-cr250")
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
    assert!(port.starts_with("/dev/"), "mock-cr250 printed {first:?}");
    (Simulator(child), port)
}

fn specio(port: &str, truth: &Path) -> serde_json::Value {
    let python = root().join("target/py312/bin/python");
    assert!(
        python.exists(),
        "{} is missing: run tests/setup.sh (it makes the Python 3.12 venv with colour-specio)",
        python.display()
    );
    let mut child = Command::new(python)
        .arg(root().join("tests/python/specio_cr_client.py"))
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
            panic!("colour-specio's CRSpectrometer did not finish within 120 s on {port}");
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

/// colour-specio's class with the simulator's default flags: it reads the
/// type, model, serial, firmware and speed, measures twice (`M`, then
/// `RM Spectrum`'s header and its value lines, read within 25 ms each, and
/// `RM Exposure`), and colour-science's XYZ of what it got is within 3 % in
/// Y and 0.003 in x, y of colour-science's XYZ of the target.
#[test]
fn colour_specio_cr_spectrometer_measures_through_mock_cr250_with_default_flags() {
    let dir = tempfile::tempdir().unwrap();
    let truth = write_truth(dir.path());
    for (flag, model, points, step) in [("cr250", "CR-250", 101, 4.0), ("cr300", "CR-300", 401, 1.0)] {
        let (_sim, port) = start_simulator(&truth, &["--model", flag]);
        let report = specio(&port, &truth);
        eprintln!("{report}");
        assert_eq!(report["model"], model, "{report}");
        assert_eq!(report["serial"], "25010042", "{report}");
        assert_eq!(report["instrument_type"], "SPECTRORADIOMETER", "{report}");
        assert_eq!(report["speed"], "NORMAL", "{report}");
        assert_eq!(report["spectrum_points"], points, "{report}");
        assert_eq!(report["spectrum_step_nm"], step, "{report}");
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
