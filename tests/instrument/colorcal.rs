//! The CRS ColorCAL MkII: PsychoPy's own `ColorCAL` class (psychopy-crs
//! 0.0.2) and lightbooth's driver measure through the simulator on a real
//! pty, against the target's XYZ computed here from the CIE 1931 table; and
//! the driver's fault suite on the simulator: silence, garbage, a reply cut
//! mid-line, a dead link, and the documented status words typed.

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use lightbooth::instrument::colorcal::protocol::{self, Command};
use lightbooth::instrument::colorcal::{codes, open_colorcal, ColorCalSettings};
use lightbooth::instrument::sim::{spawn_mock, Fault, FaultKind, MockConfig, MockHandle};
use lightbooth::instrument::{AveragedMeasurement, InstrumentError, QualityKind, Reading, Spectroradiometer};
use serialport::SerialPort;
use tokio_util::sync::CancellationToken;

use crate::colorimeter_support::*;

/// PsychoPy's class, the simulator with its default flags (real time).
#[test]
fn psychopy_colorcal_class_measures_through_mock_colorcal_with_default_flags() {
    let dir = tempfile::tempdir().unwrap();
    let target_csv = write_target(dir.path());
    let sim = start_simulator("mock-colorcal", &target_csv, &[]);
    let cmf = root().join("crates/science/src/reference_data/cie1931_2deg_cmf.csv");
    let report = python_client(
        "colorcal_client.py",
        &[&sim.port, target_csv.to_str().unwrap(), cmf.to_str().unwrap()],
        Duration::from_secs(90),
    );
    eprintln!("{report}");
    assert_eq!(report["serial"], "10003154", "{report}");
    assert_eq!(
        report["needs_zero_calibration"], false,
        "build 905 keeps a factory zero: {report}"
    );
    // The matrix it read is the simulator's, non-diagonal (its first row PTB's example).
    assert_eq!(number(&report, "/matrix/0/1"), -0.204, "{report}");
    let truth = truth_xyz(1.0);
    // The script's own truth and this one agree (both from the CIE table).
    assert_within(
        number(&report, "/truth_XYZ_cd_m2/1"),
        truth[1],
        1e-6,
        "the script's truth",
    );
    assert_within(number(&report, "/XYZ_cd_m2/1"), truth[1], 0.03, "PsychoPy's Y");
    assert_within(number(&report, "/second_Y_cd_m2"), truth[1], 0.03, "PsychoPy's getLum");
    let (x, y) = chromaticity(truth);
    assert!((number(&report, "/xy/0") - x).abs() < 0.003, "x: {report}");
    assert!((number(&report, "/xy/1") - y).abs() < 0.003, "y: {report}");
}

fn mock(scale: f64, faults: Vec<Fault>) -> MockHandle {
    let mut cfg = MockConfig::colorcal(target(scale));
    cfg.speed = 0.0;
    cfg.seed = 11;
    cfg.faults = faults;
    // Late for MES, early in the resynchronisation ping's wait.
    cfg.slow_ms = 2_000;
    spawn_mock(cfg).unwrap()
}

/// Short, bounded timeouts: no test waits longer than a few of these.
fn settings() -> ColorCalSettings {
    ColorCalSettings {
        command_timeout_ms: 400,
        measure_timeout_ms: 1_500,
        gap_timeout_ms: 200,
        resync_quiet_ms: 50,
        samples: 3,
        retries: 2,
        ..ColorCalSettings::default()
    }
}

fn open(mock: &MockHandle, settings: &ColorCalSettings) -> Result<Box<dyn Spectroradiometer>, InstrumentError> {
    open_colorcal(mock.device_path().to_str().unwrap(), settings)
}

fn measure(unit: &mut dyn Spectroradiometer, n: usize) -> Result<AveragedMeasurement, InstrumentError> {
    unit.measure_averaged(n, &CancellationToken::new(), &mut |_| {})
}

/// The mean is the target's XYZ within 3 % (x, y within 0.003), from good
/// samples only, each with its own XYZ and no spectrum.
fn assert_true_to_target(m: &AveragedMeasurement, scale: f64) {
    let truth = truth_xyz(scale);
    assert_within(m.luminance_cd_m2, truth[1], 0.03, "the driver's Y");
    let (x, y) = chromaticity(truth);
    assert!(
        (m.x.unwrap() - x).abs() < 0.003 && (m.y.unwrap() - y).abs() < 0.003,
        "{:?} {:?}",
        m.x,
        m.y
    );
    assert!(m.mean.is_none(), "a colorimeter gives no spectrum");
    for s in &m.samples {
        assert_eq!(
            s.instrument_xyz.is_some(),
            s.code.is_ok(),
            "a bad sample carries no XYZ"
        );
        assert!(s.radiance.is_none());
    }
}

#[test]
fn the_driver_measures_the_targets_xyz_through_the_simulator() {
    let mock = mock(1.0, vec![]);
    let mut unit = open(&mock, &settings()).unwrap();
    assert_eq!(unit.info().model, "ColorCAL MkII");
    assert_eq!(unit.info().serial.as_deref(), Some("10003154"));
    assert!(matches!(unit.capabilities().reading, Reading::Tristimulus { .. }));
    let m = measure(unit.as_mut(), 5).unwrap();
    assert_eq!(m.good_samples().count(), 5);
    assert_true_to_target(&m, 1.0);
    // Five noisy samples averaged: they differ, and the mean is theirs.
    let ys: Vec<f64> = m.good_samples().map(|s| s.instrument_xyz.unwrap()[1]).collect();
    assert!(ys.windows(2).any(|w| w[0] != w[1]), "{ys:?}");
    assert!((ys.iter().sum::<f64>() / 5.0 - m.luminance_cd_m2).abs() < 1e-9);
    assert!(m.luminance_cv > 0.0 && m.luminance_cv < 0.01, "{}", m.luminance_cv);
}

/// One fault of `kind` loses one sample; the series still ends with every
/// sample good and true to the target, and the simulator measured once more.
#[test]
fn a_lost_reply_costs_one_sample_and_the_session_goes_on() {
    for kind in [
        FaultKind::NoAnswer,
        FaultKind::Garble,
        FaultKind::Truncate,
        FaultKind::Stale,
        FaultKind::Slow,
    ] {
        let mock = mock(1.0, vec![Fault::times(kind, 1)]);
        let mut unit = open(&mock, &settings()).unwrap();
        let m = measure(unit.as_mut(), 3).unwrap_or_else(|e| panic!("{kind:?}: {e}"));
        assert_eq!(m.good_samples().count(), 3, "{kind:?}");
        assert_true_to_target(&m, 1.0);
        // Stale junk is flushed before the next command (one more measurement
        // only if it landed after that flush and garbled the next reply).
        let expected = if kind == FaultKind::Stale { 3..=4 } else { 4..=4 };
        assert!(
            expected.contains(&mock.measurements()),
            "{kind:?}: {} measurements taken",
            mock.measurements()
        );
    }
}

/// Garbage on every reply: a typed protocol error naming MES, after the
/// allowed retries; the session is usable once the line is clean.
#[test]
fn garbage_every_time_is_a_protocol_error_and_the_session_survives() {
    let mock = mock(1.0, vec![Fault::always(FaultKind::Garble)]);
    let mut unit = open(&mock, &settings()).unwrap();
    match measure(unit.as_mut(), 2) {
        Err(InstrumentError::Protocol { command, detail }) => assert_eq!(command, "MES", "{detail}"),
        other => panic!("expected a protocol error, got {other:?}"),
    }
    mock.set_faults(vec![]);
    assert_true_to_target(&measure(unit.as_mut(), 2).unwrap(), 1.0);
}

/// A reply cut mid-line every time: typed as truncated.
#[test]
fn a_reply_cut_mid_line_is_truncated() {
    let mock = mock(1.0, vec![Fault::always(FaultKind::Truncate)]);
    let mut unit = open(&mock, &settings()).unwrap();
    match measure(unit.as_mut(), 1) {
        Err(InstrumentError::Truncated { command, .. }) => assert_eq!(command, "MES"),
        other => panic!("expected a truncated reply, got {other:?}"),
    }
}

/// Silence: a unit that never answers MES times out (bounded), and a link
/// that dies mid-reply is reported unresponsive, naming the cut reply.
#[test]
fn silence_is_a_timeout_and_a_dead_link_is_unresponsive() {
    let mock1 = mock(1.0, vec![Fault::always(FaultKind::NoAnswer)]);
    let mut unit = open(&mock1, &settings()).unwrap();
    let started = Instant::now();
    match measure(unit.as_mut(), 1) {
        Err(InstrumentError::Timeout { command, .. }) => assert_eq!(command, "MES"),
        other => panic!("expected a timeout, got {other:?}"),
    }
    assert!(started.elapsed() < Duration::from_secs(15), "{:?}", started.elapsed());

    let mock2 = mock(1.0, vec![Fault::times(FaultKind::LinkDies, 1)]);
    let mut unit = open(&mock2, &settings()).unwrap();
    match measure(unit.as_mut(), 2) {
        Err(InstrumentError::Unresponsive { after, command, .. }) => {
            assert_eq!((after.as_str(), command.as_str()), ("MES", "IDR"))
        }
        other => panic!("expected an unresponsive unit, got {other:?}"),
    }
    assert!(mock2.is_link_dead());
}

/// No simulator on the port at all: a typed error that says what to check.
#[test]
fn a_silent_port_on_opening_says_what_to_check() {
    let (_master, slave) = serialport::TTYPort::pair().unwrap();
    let path = slave.name().unwrap();
    match open_colorcal(&path, &settings()) {
        Err(e @ InstrumentError::Silent { .. }) => assert!(e.to_string().contains("ttyACM"), "{e}"),
        Err(other) => panic!("expected a silent unit, got {other}"),
        Ok(_) => panic!("opened a port nobody answers"),
    }
}

/// `ER11` (the documented refusal of a zero calibration with light on the
/// sensor) is a typed refusal with its meaning; in the dark `UZC` succeeds.
#[test]
fn zero_calibration_in_light_is_refused_with_er11() {
    let bright = mock(1.0, vec![]);
    let zeroing = ColorCalSettings {
        zero_calibrate: true,
        ..settings()
    };
    match open(&bright, &zeroing) {
        Err(InstrumentError::Refused { command, code }) => {
            assert_eq!(command, "UZC");
            assert_eq!((code.code, code.kind), (111, QualityKind::LowLight));
            assert!(
                code.message.starts_with("ER11") && code.message.contains("covered"),
                "{}",
                code.message
            );
        }
        Err(other) => panic!("expected ER11, got {other}"),
        Ok(_) => panic!("zero-calibrated in the light"),
    }
    let dark = mock(0.0, vec![]);
    assert!(open(&dark, &zeroing).is_ok());
}

/// What the simulator answers on the wire, as a client reads it: a whole
/// reply in one write, and `ER00` to an unknown command (`r99`), which the
/// codes type with its meaning.
#[test]
fn the_simulator_answers_in_one_write_and_er00_to_an_unknown_command() {
    let mock = mock(1.0, vec![]);
    let mut port = serialport::new(mock.device_path().to_str().unwrap(), 115_200)
        .timeout(Duration::from_millis(50))
        .open()
        .unwrap();
    let mut ask = |command: &str| -> Vec<u8> {
        port.write_all(format!("{command}\r").as_bytes()).unwrap();
        let mut reply = Vec::new();
        let start = Instant::now();
        let mut buf = [0u8; 256];
        while !reply.ends_with(b">") && start.elapsed() < Duration::from_secs(3) {
            if let Ok(n) = port.read(&mut buf) {
                reply.extend_from_slice(&buf[..n]);
            }
        }
        reply
    };
    let id = ask("IDR");
    assert!(
        id.starts_with(b"\n\rOK00,1,101,100.10,10003154,905\n\r>"),
        "{:?}",
        String::from_utf8_lossy(&id)
    );
    let unknown = ask("r99");
    let status = protocol::parse_status_reply(&unknown).unwrap();
    let code = codes::quality_code(status);
    assert_eq!((code.code, code.kind), (100, QualityKind::Other));
    assert!(code.message.contains("unknown command"));
    let row = ask(&Command::MatrixRow(1).text());
    assert_eq!(
        protocol::parse_matrix_row(&row).unwrap().unwrap(),
        [0.8053, -0.204, -0.0642]
    );
}

/// `lightbooth measure --model colorcal --json` through `mock-colorcal`.
#[test]
fn measure_model_colorcal_reports_xyz_and_no_spectrum() {
    let dir = tempfile::tempdir().unwrap();
    let target_csv = write_target(dir.path());
    let sim = start_simulator("mock-colorcal", &target_csv, &["--speed", "0"]);
    let json = lightbooth_measure(&["--model", "colorcal", "--port", &sim.port, "--samples", "3"]);
    assert_eq!(json["reading"], "XYZ", "{json}");
    assert_eq!(json["observer"], "cie-1931", "{json}");
    assert_eq!(json["instrument"]["model"], "ColorCAL MkII", "{json}");
    assert_eq!(json["radiance"].as_array().map(Vec::len), Some(0), "{json}");
    assert_eq!(json["samples"].as_array().map(Vec::len), Some(3), "{json}");
    let truth = truth_xyz(1.0);
    assert_within(number(&json, "/Y"), truth[1], 0.03, "measure's Y");
    let (x, _) = chromaticity(truth);
    assert!((number(&json, "/x") - x).abs() < 0.003, "{json}");
}
