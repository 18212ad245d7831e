//! The Konica Minolta LS-100 and CS-100A: PsychoPy's own `LS100` and
//! `CS100A` classes (psychopy-minolta 0.0.2) and lightbooth's driver measure
//! through the simulator on a real pty, against the target's luminance (and
//! chromaticity) computed here from the CIE 1931 table; and the driver's
//! fault suite on the simulator: silence, garbage, a reply cut mid-line, a
//! dead link, and every documented `ERnn` typed with its meaning.

use std::time::{Duration, Instant};

use serialport::SerialPort;

use lightbooth::instrument::ls100::{open_ls100, Ls100Settings, Model};
use lightbooth::instrument::sim::{spawn_mock, Fault, FaultKind, MockConfig, MockHandle};
use lightbooth::instrument::{AveragedMeasurement, InstrumentError, QualityKind, Reading, Spectroradiometer};
use tokio_util::sync::CancellationToken;

use crate::colorimeter_support::*;

fn psychopy_measures(class: &str, model_flag: &str) -> serde_json::Value {
    let dir = tempfile::tempdir().unwrap();
    let target_csv = write_target(dir.path());
    let sim = start_simulator("mock-ls100", &target_csv, &["--model", model_flag]);
    let cmf = root().join("crates/science/src/reference_data/cie1931_2deg_cmf.csv");
    let report = python_client(
        "minolta_client.py",
        &[class, &sim.port, target_csv.to_str().unwrap(), cmf.to_str().unwrap()],
        Duration::from_secs(90),
    );
    eprintln!("{report}");
    // The client's line: 4800 baud and 2 stop bits kept (8N on the pty, see the script).
    assert_eq!(report["line"][0], 4800, "{report}");
    assert_eq!(report["line"][3], 2, "{report}");
    let truth = truth_xyz(1.0);
    assert_within(number(&report, "/truth_Y_cd_m2"), truth[1], 1e-6, "the script's truth");
    assert_within(number(&report, "/Y_cd_m2"), truth[1], 0.03, "PsychoPy's luminance");
    assert_within(number(&report, "/second_Y_cd_m2"), truth[1], 0.03, "PsychoPy's getLum");
    report
}

/// PsychoPy's `LS100`, the simulator with its default flags (real time).
#[test]
fn psychopy_ls100_class_measures_through_mock_ls100_with_default_flags() {
    psychopy_measures("LS100", "ls100");
}

/// PsychoPy's `CS100A` reads x, y too.
#[test]
fn psychopy_cs100a_class_measures_through_mock_ls100_model_cs100a() {
    let report = psychopy_measures("CS100A", "cs100a");
    let (x, y) = chromaticity(truth_xyz(1.0));
    assert!((number(&report, "/xy/0") - x).abs() < 0.003, "x: {report}");
    assert!((number(&report, "/xy/1") - y).abs() < 0.003, "y: {report}");
}

fn mock(model: Model, scale: f64, faults: Vec<Fault>) -> MockHandle {
    let mut cfg = MockConfig::ls100(target(scale), model);
    cfg.speed = 0.0;
    cfg.seed = 5;
    cfg.faults = faults;
    cfg.slow_ms = 2_000;
    spawn_mock(cfg).unwrap()
}

/// Short, bounded timeouts: no test waits longer than a few of these.
fn settings(model: Model) -> Ls100Settings {
    Ls100Settings {
        command_timeout_ms: 400,
        measure_timeout_ms: 1_500,
        gap_timeout_ms: 200,
        resync_quiet_ms: 50,
        handshake_attempts: 2,
        samples: 3,
        retries: 2,
        ..Ls100Settings::for_model(model)
    }
}

fn open(mock: &MockHandle, settings: &Ls100Settings) -> Result<Box<dyn Spectroradiometer>, InstrumentError> {
    open_ls100(mock.device_path().to_str().unwrap(), settings)
}

fn measure(unit: &mut dyn Spectroradiometer, n: usize) -> Result<AveragedMeasurement, InstrumentError> {
    unit.measure_averaged(n, &CancellationToken::new(), &mut |_| {})
}

fn assert_true_to_target(m: &AveragedMeasurement, model: Model) {
    let truth = truth_xyz(1.0);
    assert_within(m.luminance_cd_m2, truth[1], 0.03, "the driver's luminance");
    assert!(m.mean.is_none(), "a meter gives no spectrum");
    match model {
        Model::Ls100 => assert!(m.x.is_none() && m.instrument_xyz.is_none(), "the LS-100 has no colour"),
        Model::Cs100a => {
            let (x, y) = chromaticity(truth);
            assert!(
                (m.x.unwrap() - x).abs() < 0.003 && (m.y.unwrap() - y).abs() < 0.003,
                "{:?} {:?}",
                m.x,
                m.y
            );
            assert_within(m.instrument_xyz.unwrap()[0], truth[0], 0.03, "the CS-100A's X");
        }
    }
    for s in &m.samples {
        assert_eq!(
            s.luminance.is_some(),
            s.code.is_ok(),
            "a bad sample carries no luminance"
        );
    }
}

#[test]
fn the_driver_measures_the_targets_luminance_through_each_simulator() {
    for model in [Model::Ls100, Model::Cs100a] {
        let mock = mock(model, 1.0, vec![]);
        let mut unit = open(&mock, &settings(model)).unwrap();
        assert_eq!(unit.info().model, model.name());
        assert_eq!(unit.capabilities().reading, model.reading());
        let m = measure(unit.as_mut(), 5).unwrap();
        assert_eq!(m.good_samples().count(), 5, "{model:?}");
        assert_true_to_target(&m, model);
        let ys: Vec<f64> = m.good_samples().map(|s| s.luminance.unwrap()).collect();
        assert!(ys.windows(2).any(|w| w[0] != w[1]), "noisy samples differ: {ys:?}");
        assert!((ys.iter().sum::<f64>() / 5.0 - m.luminance_cd_m2).abs() < 1e-9);
    }
    assert!(matches!(Model::Ls100.reading(), Reading::Luminance { .. }));
}

/// The settings name the wrong model: the reply's fields say which it is.
#[test]
fn a_cs100a_driven_as_an_ls100_is_named() {
    let mock = mock(Model::Cs100a, 1.0, vec![]);
    let mut unit = open(&mock, &settings(Model::Ls100)).unwrap();
    let e = measure(unit.as_mut(), 1).unwrap_err();
    assert!(
        matches!(e, InstrumentError::Protocol { .. }) && e.to_string().contains("cs100a"),
        "{e}"
    );
}

#[test]
fn a_lost_reply_costs_one_sample_and_the_session_goes_on() {
    for kind in [
        FaultKind::NoAnswer,
        FaultKind::Garble,
        FaultKind::Truncate,
        FaultKind::Stale,
        FaultKind::Slow,
    ] {
        let mock = mock(Model::Cs100a, 1.0, vec![Fault::times(kind, 1)]);
        let mut unit = open(&mock, &settings(Model::Cs100a)).unwrap();
        let m = measure(unit.as_mut(), 3).unwrap_or_else(|e| panic!("{kind:?}: {e}"));
        assert_eq!(m.good_samples().count(), 3, "{kind:?}");
        assert_true_to_target(&m, Model::Cs100a);
        let expected = if kind == FaultKind::Stale { 3..=4 } else { 4..=4 };
        assert!(
            expected.contains(&mock.measurements()),
            "{kind:?}: {} measurements",
            mock.measurements()
        );
    }
}

#[test]
fn garbage_every_time_is_a_protocol_error_and_the_session_survives() {
    let mock = mock(Model::Ls100, 1.0, vec![Fault::always(FaultKind::Garble)]);
    let mut unit = open(&mock, &settings(Model::Ls100)).unwrap();
    match measure(unit.as_mut(), 2) {
        Err(InstrumentError::Protocol { command, detail }) => assert_eq!(command, "MES", "{detail}"),
        other => panic!("expected a protocol error, got {other:?}"),
    }
    mock.set_faults(vec![]);
    assert_true_to_target(&measure(unit.as_mut(), 2).unwrap(), Model::Ls100);
}

#[test]
fn a_reply_cut_mid_line_is_truncated() {
    let mock = mock(Model::Cs100a, 1.0, vec![Fault::always(FaultKind::Truncate)]);
    let mut unit = open(&mock, &settings(Model::Cs100a)).unwrap();
    match measure(unit.as_mut(), 1) {
        Err(InstrumentError::Truncated { command, .. }) => assert_eq!(command, "MES"),
        other => panic!("expected a truncated reply, got {other:?}"),
    }
}

#[test]
fn silence_is_a_timeout_and_a_dead_link_is_unresponsive() {
    let mock1 = mock(Model::Ls100, 1.0, vec![Fault::always(FaultKind::NoAnswer)]);
    let mut unit = open(&mock1, &settings(Model::Ls100)).unwrap();
    let started = Instant::now();
    match measure(unit.as_mut(), 1) {
        Err(InstrumentError::Timeout { command, .. }) => assert_eq!(command, "MES"),
        other => panic!("expected a timeout, got {other:?}"),
    }
    assert!(started.elapsed() < Duration::from_secs(15), "{:?}", started.elapsed());

    let mock2 = mock(Model::Ls100, 1.0, vec![Fault::times(FaultKind::LinkDies, 1)]);
    let mut unit = open(&mock2, &settings(Model::Ls100)).unwrap();
    match measure(unit.as_mut(), 2) {
        Err(InstrumentError::Unresponsive { after, command, .. }) => {
            assert_eq!((after.as_str(), command.as_str()), ("MES", "MDS,04"))
        }
        other => panic!("expected an unresponsive unit, got {other:?}"),
    }
}

/// A meter that never answers the handshake (off, or on without F held).
#[test]
fn a_silent_port_on_opening_says_switch_on_with_f_held() {
    let (_master, slave) = serialport::TTYPort::pair().unwrap();
    let path = slave.name().unwrap();
    match open_ls100(&path, &settings(Model::Ls100)) {
        Err(e @ InstrumentError::Silent { .. }) => assert!(e.to_string().contains("holding F"), "{e}"),
        Err(other) => panic!("expected a silent meter, got {other}"),
        Ok(_) => panic!("opened a port nobody answers"),
    }
}

/// Every `ERnn` the public sources list, from a measurement: a sample with
/// the typed code and its meaning, not averaged; the next sample is good.
#[test]
fn every_documented_error_code_is_typed_with_its_meaning() {
    let table = [
        (0, QualityKind::Other, "unknown command"),
        (1, QualityKind::Other, "setting error"),
        (10, QualityKind::Overload, "measuring range over"),
        (11, QualityKind::Other, "memory value error"),
        (19, QualityKind::Overload, "display range over"),
        (20, QualityKind::Hardware, "EEPROM"),
        (30, QualityKind::Hardware, "battery exhausted"),
    ];
    for (n, kind, meaning) in table {
        let mut cfg = MockConfig::ls100(target(1.0), Model::Ls100);
        cfg.speed = 0.0;
        cfg.error_code = n;
        cfg.faults = vec![Fault::times(FaultKind::ErrorCode, 1)];
        let mock = spawn_mock(cfg).unwrap();
        let mut unit = open(&mock, &settings(Model::Ls100)).unwrap();
        let m = measure(unit.as_mut(), 1).unwrap();
        let bad = &m.samples[0];
        assert_eq!((bad.code.code, bad.code.kind), (100 + i32::from(n), kind), "ER{n:02}");
        assert!(bad.code.message.contains(meaning) && bad.code.message.starts_with(&format!("ER{n:02}")));
        assert!(bad.luminance.is_none());
        assert_eq!(m.good_samples().count(), 1);
        assert_true_to_target(&m, Model::Ls100);
    }
    // Out of range for good: a typed quality failure with the model's advice.
    let mut cfg = MockConfig::ls100(target(1.0), Model::Ls100);
    cfg.speed = 0.0;
    cfg.faults = vec![Fault::always(FaultKind::ErrorCode)];
    let mock = spawn_mock(cfg).unwrap();
    let mut unit = open(&mock, &settings(Model::Ls100)).unwrap();
    match measure(unit.as_mut(), 1) {
        Err(e @ InstrumentError::Quality { code: 110, .. }) => assert!(e.to_string().contains("dimmer"), "{e}"),
        other => panic!("expected ER10 as a quality failure, got {other:?}"),
    }
}

/// `lightbooth measure --model ls100|cs100a --json` through `mock-ls100`.
#[test]
fn measure_model_ls100_and_cs100a() {
    let dir = tempfile::tempdir().unwrap();
    let target_csv = write_target(dir.path());
    let truth = truth_xyz(1.0);
    for (flag, reading) in [("ls100", "luminance"), ("cs100a", "XYZ")] {
        let sim = start_simulator("mock-ls100", &target_csv, &["--model", flag, "--speed", "0"]);
        let json = lightbooth_measure(&["--model", flag, "--port", &sim.port, "--samples", "2"]);
        assert_eq!(json["reading"], reading, "{json}");
        assert_within(number(&json, "/Y"), truth[1], 0.03, "measure's Y");
        assert_eq!(json["x"].is_null(), flag == "ls100", "{json}");
    }
}
