//! The PR-650 driver against the simulated PR-650, in process, over a real
//! pty: accuracy within the simulator's noise model, and every injected fault
//! ending in a typed error or a successful retry, never a hang (all waits are
//! bounded by the short timeouts below), never a bad sample in the mean, and
//! the port usable afterwards.

use std::path::Path;
use std::time::{Duration, Instant};

use lightbooth::colorimetry::{xyz_from_radiance, Cmf, Observer, KM_LM_PER_W};
use lightbooth::instrument::link::Terminator;
use lightbooth::instrument::pr650::protocol::as_sent;
use lightbooth::instrument::sim::{spawn_mock, Fault, FaultKind, MockConfig, MockHandle};
use lightbooth::instrument::{
    open_pr650, AveragedMeasurement, InstrumentError, Pr650Settings, QualityKind, Sample, Spectroradiometer,
};
use lightbooth::reference_data::{illuminant, Illuminant};
use lightbooth::spectrum::{Grid, SpectralUnit, Spectrum};
use tokio_util::sync::CancellationToken;

/// D65 as an absolute radiance of about 100 cd/m² (1.4e-5 W/(sr·m²·nm) per table unit).
fn d65_radiance() -> Spectrum {
    let d65 = illuminant(Illuminant::D65);
    let values = d65.values().iter().map(|v| v * 1.4e-5).collect();
    Spectrum::new(d65.grid().clone(), SpectralUnit::SpectralRadiance, values).unwrap()
}

fn fast_mock(faults: Vec<Fault>) -> MockHandle {
    let mut cfg = MockConfig::new(d65_radiance());
    cfg.speed = 0.0;
    cfg.pace_output = false;
    cfg.remote_window_ms = None;
    cfg.faults = faults;
    cfg.seed = 42;
    // A slow reply arrives after one and a half times the test's command
    // timeout: late for its command, and early in the resynchronisation
    // ping's wait (one command timeout of silence), which then finds the unit alive.
    cfg.slow_ms = 3 * test_settings().command_timeout_ms / 2;
    spawn_mock(cfg).unwrap()
}

/// Short, bounded timeouts: no test can wait longer than a few of these.
fn test_settings() -> Pr650Settings {
    Pr650Settings {
        command_timeout_ms: 400,
        measure_timeout_ms: 1500,
        gap_timeout_ms: 200,
        resync_quiet_ms: 50,
        remote_mode_attempts: 2,
        retries: 2,
        ..Pr650Settings::default()
    }
}

fn open(mock: &MockHandle, settings: &Pr650Settings) -> Box<dyn Spectroradiometer> {
    open_pr650(mock.device_path().to_str().unwrap(), settings).unwrap()
}

fn measure(pr650: &mut dyn Spectroradiometer, n: usize) -> (Result<AveragedMeasurement, InstrumentError>, Vec<Sample>) {
    let mut seen = Vec::new();
    let result = pr650.measure_averaged(n, &CancellationToken::new(), &mut |s| seen.push(s.clone()));
    (result, seen)
}

/// The mean holds exactly the good samples, and every good sample is within
/// the model's noise of the model's truth.
fn assert_sound(m: &AveragedMeasurement, mock: &MockHandle, n: usize) {
    let good: Vec<&Sample> = m.good_samples().collect();
    assert_eq!(good.len(), n);
    for s in &m.samples {
        assert_eq!(
            s.radiance.is_some(),
            s.code.is_ok(),
            "a bad sample must carry no spectrum"
        );
    }
    for i in 0..m.mean.as_ref().unwrap().values().len() {
        let avg = good
            .iter()
            .map(|s| s.radiance.as_ref().unwrap().values()[i])
            .sum::<f64>()
            / n as f64;
        assert!((avg - m.mean.as_ref().unwrap().values()[i]).abs() <= 1e-12 * avg.abs().max(1.0));
    }
    let reading = mock.expected_reading().unwrap();
    for (i, ((mean, e), sigma)) in m
        .mean
        .as_ref()
        .unwrap()
        .values()
        .iter()
        .zip(&reading.expected)
        .zip(&reading.sigma)
        .enumerate()
    {
        // Five standard errors of the mean, plus the 4-significant-digit rounding of the wire format.
        let tol = 5.0 * sigma / (n as f64).sqrt() + (as_sent(*e) - e).abs() + 5e-4 * e;
        assert!((mean - e).abs() <= tol, "{} nm: {mean} vs {e} ± {tol}", 380 + 4 * i);
    }
}

#[test]
fn five_samples_match_the_model_truth_with_realistic_spread() {
    let mock = fast_mock(vec![]);
    let mut pr650 = open(&mock, &test_settings());
    assert_eq!(pr650.info().model, "PR-650");
    assert_eq!(pr650.info().serial.as_deref(), Some("60954303"));
    assert_eq!(pr650.info().grid, Grid::pr650());
    let (m, seen) = measure(pr650.as_mut(), 5);
    let m = m.unwrap();
    assert_eq!(seen.len(), 5, "on_sample sees every sample as it is taken");
    assert_sound(&m, &mock, 5);
    // One measurement read two ways: D2's Y agrees with the Y of D5's spectrum
    // (both sent to four significant digits).
    for s in m.good_samples() {
        let y = xyz_from_radiance(s.radiance.as_ref().unwrap(), Observer::Cie1931)
            .unwrap()
            .y;
        let reported = s.luminance.unwrap();
        assert!((reported / y - 1.0).abs() < 2e-3, "D2 says {reported}, D5 gives {y}");
    }
    // Realistic spread: the per-wavelength sample variances average to the model's
    // σ² (chi-square with 4 × 101 degrees of freedom: ratio 1 ± 0.07 at one SD).
    let reading = mock.expected_reading().unwrap();
    let ratio: f64 =
        m.sd.iter()
            .zip(&reading.sigma)
            .map(|(sd, s)| (sd / s).powi(2))
            .sum::<f64>()
            / reading.sigma.len() as f64;
    assert!((0.6..1.4).contains(&ratio), "variance ratio {ratio}");
    // Luminance CV against the model's: σ_Y = Km·Δλ·√Σ ȳ²σ², over Y. Five samples
    // estimate an SD only roughly (χ² with 4 degrees of freedom): a factor of 6 either way.
    let cmf = Cmf::of(Observer::Cie1931);
    let var_y: f64 = Grid::pr650()
        .wavelengths()
        .iter()
        .zip(&reading.sigma)
        .map(|(nm, s)| (cmf.at(*nm)[1] * s).powi(2))
        .sum();
    let model_cv = KM_LM_PER_W * 4.0 * var_y.sqrt() / m.luminance_cd_m2;
    let cv_ratio = m.luminance_cv / model_cv;
    assert!(
        (1.0 / 6.0..6.0).contains(&cv_ratio),
        "CV {} vs model {model_cv}",
        m.luminance_cv
    );
    assert!((m.luminance_cd_m2 - 100.0).abs() < 10.0, "Y {}", m.luminance_cd_m2);
    assert!(
        (m.x.unwrap() - 0.3127).abs() < 0.002 && (m.y.unwrap() - 0.3290).abs() < 0.002,
        "{} {}",
        m.x.unwrap(),
        m.y.unwrap()
    );
}

#[test]
fn faults_once_are_retried_and_the_mean_stays_clean() {
    for kind in [
        FaultKind::NoAnswer,
        FaultKind::Truncate,
        FaultKind::Garble,
        FaultKind::ErrorCode,
        FaultKind::Slow,
    ] {
        let mock = fast_mock(vec![]);
        let mut pr650 = open(&mock, &test_settings());
        mock.set_faults(vec![Fault::times(kind, 1)]);
        let (m, seen) = measure(pr650.as_mut(), 5);
        let m = m.unwrap_or_else(|e| panic!("{kind:?}: {e}"));
        assert_sound(&m, &mock, 5);
        assert_eq!(mock.measurements(), 6, "{kind:?}: one sample was lost and retaken");
        if kind == FaultKind::ErrorCode {
            assert_eq!(seen.len(), 6, "the bad sample is reported");
            let bad: Vec<&Sample> = m.samples.iter().filter(|s| !s.code.is_ok()).collect();
            assert_eq!(bad.len(), 1);
            assert_eq!(bad[0].code.code, 18);
            assert_eq!(bad[0].code.kind, QualityKind::LowLight);
            assert!(bad[0].radiance.is_none() && bad[0].luminance.is_none());
        } else {
            assert_eq!(seen.len(), 5, "{kind:?}: a lost reply is not a sample");
        }
    }
}

#[test]
fn persistent_faults_give_typed_errors_and_leave_the_port_usable() {
    let settings = test_settings();
    type IsExpected = fn(&InstrumentError) -> bool;
    let cases: [(FaultKind, IsExpected); 4] = [
        (FaultKind::NoAnswer, |e| matches!(e, InstrumentError::NoReply { .. })),
        (FaultKind::Truncate, |e| matches!(e, InstrumentError::Truncated { .. })),
        (FaultKind::Garble, |e| matches!(e, InstrumentError::Protocol { .. })),
        (FaultKind::ErrorCode, |e| {
            matches!(
                e,
                InstrumentError::Quality {
                    code: 18,
                    good: 0,
                    needed: 5,
                    ..
                }
            )
        }),
    ];
    for (kind, expected) in cases {
        let mock = fast_mock(vec![]);
        let mut pr650 = open(&mock, &settings);
        mock.set_faults(vec![Fault::always(kind)]);
        let (result, seen) = measure(pr650.as_mut(), 5);
        let err = result.expect_err("a persistent fault cannot give a measurement");
        assert!(expected(&err), "{kind:?}: {err:?}");
        assert!(
            seen.iter().all(|s| !s.code.is_ok()),
            "{kind:?}: no good sample can have been taken"
        );
        assert!(!err.to_string().is_empty());
        // The fault goes away: the same session measures again.
        mock.set_faults(vec![]);
        let (m, _) = measure(pr650.as_mut(), 5);
        assert_sound(&m.unwrap_or_else(|e| panic!("{kind:?} afterwards: {e}")), &mock, 5);
    }
}

#[test]
fn slow_replies_inside_the_timeout_pass_and_outside_it_time_out() {
    // A longer timeout than elsewhere, so a quarter of it (250 ms) is ample
    // margin for scheduling jitter on a loaded machine.
    let settings = Pr650Settings {
        command_timeout_ms: 1000,
        retries: 0,
        ..test_settings()
    };
    for (slow_ms, ok) in [
        (settings.command_timeout_ms * 3 / 4, true),
        (settings.command_timeout_ms * 2, false),
    ] {
        let mut cfg = MockConfig::new(d65_radiance());
        cfg.speed = 0.0;
        cfg.pace_output = false;
        cfg.remote_window_ms = None;
        cfg.slow_ms = slow_ms;
        let mock = spawn_mock(cfg).unwrap();
        let mut pr650 = open(&mock, &settings);
        mock.set_faults(vec![Fault::always(FaultKind::Slow)]);
        let (result, _) = measure(pr650.as_mut(), 2);
        match result {
            Ok(m) => {
                assert!(
                    ok,
                    "{slow_ms} ms is outside a {} ms timeout",
                    settings.command_timeout_ms
                );
                assert_sound(&m, &mock, 2);
                assert_eq!(mock.measurements(), 2, "no retry was needed");
            }
            Err(e) => {
                assert!(!ok, "{slow_ms} ms should pass: {e}");
                assert!(
                    matches!(e, InstrumentError::NoReply { command: ref c, .. } if c == "D5"),
                    "{e:?}"
                );
            }
        }
        mock.set_faults(vec![]);
        let (m, _) = measure(pr650.as_mut(), 2);
        assert_sound(&m.unwrap(), &mock, 2);
    }
}

#[test]
fn stale_bytes_before_a_command_are_flushed_and_blank_lines_ignored() {
    let mock = fast_mock(vec![
        Fault::always(FaultKind::Stale),
        Fault::always(FaultKind::DoubleCrlf),
    ]);
    let mut pr650 = open(&mock, &test_settings());
    let (m, _) = measure(pr650.as_mut(), 5);
    assert_sound(&m.unwrap(), &mock, 5);
}

#[test]
fn a_pulled_cable_is_a_typed_error() {
    let mock = fast_mock(vec![]);
    let mut pr650 = open(&mock, &test_settings());
    mock.set_faults(vec![Fault::always(FaultKind::CablePull)]);
    let (result, seen) = measure(pr650.as_mut(), 5);
    let err = result.unwrap_err();
    assert!(matches!(err, InstrumentError::PortClosed { .. }), "{err:?}");
    assert!(err.to_string().contains("cable"), "{err}");
    assert!(seen.is_empty(), "a measurement cut by the cable is not recorded");
    assert!(mock.is_unplugged());
}

#[test]
fn a_missed_remote_window_says_power_cycle_and_a_power_cycle_fixes_it() {
    let mut cfg = MockConfig::new(d65_radiance());
    cfg.speed = 0.0;
    cfg.pace_output = false;
    cfg.remote_window_ms = Some(300);
    let mock = spawn_mock(cfg).unwrap();
    std::thread::sleep(Duration::from_millis(400));
    let mut settings = test_settings();
    settings.command_timeout_ms = 150;
    let err = match open_pr650(mock.device_path().to_str().unwrap(), &settings) {
        Err(e) => e,
        Ok(_) => panic!("the window had closed"),
    };
    assert!(
        matches!(err, InstrumentError::NotInRemoteMode { attempts: 2 }),
        "{err:?}"
    );
    assert!(err.to_string().contains("off and on again"), "{err}");
    mock.power_cycle();
    let mut pr650 = open(&mock, &settings);
    let (m, _) = measure(pr650.as_mut(), 1);
    assert_sound(&m.unwrap(), &mock, 1);
}

#[test]
fn cancelling_mid_measurement_leaves_the_port_usable() {
    let mut cfg = MockConfig::new(d65_radiance());
    cfg.speed = 0.2; // a measurement of ~1.9 s simulated takes ~0.4 s
    cfg.pace_output = false;
    cfg.remote_window_ms = None;
    let mock = spawn_mock(cfg).unwrap();
    let mut settings = test_settings();
    settings.measure_timeout_ms = 3000;
    let mut pr650 = open(&mock, &settings);
    let cancel = CancellationToken::new();
    let canceller = {
        let cancel = cancel.clone();
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(100));
            cancel.cancel();
        })
    };
    let result = pr650.measure_averaged(5, &cancel, &mut |_| {});
    canceller.join().unwrap();
    assert!(matches!(result, Err(InstrumentError::Cancelled)), "{result:?}");
    let (m, _) = measure(pr650.as_mut(), 1);
    assert_sound(&m.unwrap(), &mock, 1);
}

#[test]
fn header_variants_and_every_terminator_work() {
    for terminator in [Terminator::Lf, Terminator::Cr, Terminator::Crlf] {
        let mut cfg = MockConfig::new(d65_radiance());
        cfg.speed = 0.0;
        cfg.pace_output = false;
        cfg.remote_window_ms = None;
        cfg.header_bare_cr = true;
        let mock = spawn_mock(cfg).unwrap();
        let settings = Pr650Settings {
            terminator,
            byte_delay_ms: u64::from(terminator == Terminator::Cr),
            ..test_settings()
        };
        let mut pr650 = open(&mock, &settings);
        let (m, _) = measure(pr650.as_mut(), 2);
        assert_sound(&m.unwrap(), &mock, 2);
    }
}

#[test]
fn a_sync_failure_turns_sync_off_and_retakes_the_sample() {
    let mut cfg = MockConfig::new(d65_radiance());
    cfg.speed = 0.0;
    cfg.pace_output = false;
    cfg.remote_window_ms = None;
    cfg.flicker_hz = Some(60.0);
    cfg.unsyncable = true;
    let mock = spawn_mock(cfg).unwrap();
    let settings = Pr650Settings {
        sync: true,
        ..test_settings()
    };
    let mut pr650 = open(&mock, &settings);
    let (m, seen) = measure(pr650.as_mut(), 3);
    let m = m.unwrap();
    assert_eq!(seen.len(), 4);
    assert_eq!(seen[0].code.code, 7);
    assert_eq!(seen[0].code.kind, QualityKind::Sync);
    assert_sound(&m, &mock, 3);
}

#[test]
fn low_light_and_overload_come_from_the_model_limits() {
    for (scale, code) in [(3e-3, 18), (3e-4, 10), (200.0, 19)] {
        let mock = fast_mock(vec![]);
        let dim: Vec<f64> = d65_radiance().values().iter().map(|v| v * scale).collect();
        mock.set_truth(
            Spectrum::new(
                illuminant(Illuminant::D65).grid().clone(),
                SpectralUnit::SpectralRadiance,
                dim,
            )
            .unwrap(),
        )
        .unwrap();
        assert_eq!(mock.expected_reading().unwrap().code, code);
        let mut pr650 = open(
            &mock,
            &Pr650Settings {
                retries: 0,
                ..test_settings()
            },
        );
        let (result, seen) = measure(pr650.as_mut(), 1);
        match result.unwrap_err() {
            InstrumentError::Quality { code: c, .. } => assert_eq!(c, i32::from(code)),
            e => panic!("{e:?}"),
        }
        assert_eq!(seen.len(), 1);
        assert!(seen[0].radiance.is_none());
    }
}

#[test]
fn paced_replies_at_a_low_speed_arrive_whole() {
    let mut cfg = MockConfig::new(d65_radiance());
    cfg.speed = 0.02; // 9600-baud pacing and measurement times at 1/50
    cfg.remote_window_ms = None;
    let mock = spawn_mock(cfg).unwrap();
    let mut pr650 = open(&mock, &test_settings());
    let (m, _) = measure(pr650.as_mut(), 2);
    assert_sound(&m.unwrap(), &mock, 2);
}

/// Regression: a link that died mid-reply (the unit silent after a cut `D5`,
/// the port still open) took more than 60 s to report, because every
/// resynchronisation ping waited a whole measurement's timeout. With the
/// shipped settings (`instruments/pr650.toml`), a dead instrument is
/// reported within 10 s of the last byte it sent, and a pulled cable at once.
#[test]
fn a_link_that_dies_mid_reply_is_reported_within_10_s_of_its_last_byte() {
    let shipped =
        Pr650Settings::from_toml_file(&Path::new(env!("CARGO_MANIFEST_DIR")).join("instruments/pr650.toml")).unwrap();
    for kind in [FaultKind::LinkDies, FaultKind::CablePull] {
        let mock = fast_mock(vec![]);
        let mut pr650 = open(&mock, &shipped);
        // Two good samples first, then the link dies in the third.
        let (m, _) = measure(pr650.as_mut(), 2);
        assert_sound(&m.unwrap(), &mock, 2);
        mock.set_faults(vec![Fault::times(kind, 1)]);
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let result = pr650.measure_averaged(5, &CancellationToken::new(), &mut |_| {});
            let _ = tx.send((result.map(|_| ()), Instant::now()));
        });
        // Bounded: a driver that still waits minutes fails here, not by hanging.
        let (result, reported_at) = rx
            .recv_timeout(Duration::from_secs(30))
            .unwrap_or_else(|_| panic!("{kind:?}: no error within 30 s of the link dying"));
        let err = result.expect_err("a dead link cannot give a measurement");
        let last_byte = mock.last_byte_at().expect("the unit sent bytes before dying");
        let silent_for = reported_at.duration_since(last_byte);
        eprintln!("{kind:?}: reported {silent_for:?} after the last byte");
        // The requirement is 10 s; 1 s of margin for a loaded test machine.
        assert!(
            silent_for < Duration::from_secs(11),
            "{kind:?}: reported {silent_for:?} after the last byte: {err}"
        );
        match kind {
            FaultKind::LinkDies => {
                assert!(mock.is_link_dead());
                assert!(matches!(err, InstrumentError::Unresponsive { .. }), "{kind:?}: {err:?}");
                assert!(err.to_string().contains("cable"), "{err}");
            }
            _ => assert!(matches!(err, InstrumentError::PortClosed { .. }), "{kind:?}: {err:?}"),
        }
    }
}
