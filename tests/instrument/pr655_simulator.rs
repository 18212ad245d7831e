//! The simulated PR-655/PR-670 at byte level, over its real pty (no
//! driver): the measurement time of the protocol sheet's section 13.7 (sync
//! detection, whole sync periods, darks and smart dark), report 11 (scotopic
//! luminance) against the definitions of the photometric units, and the
//! `Z…` reset commands that switch the unit off.

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use lightbooth::instrument::pr655::{open_pr655, Model, Pr655Settings};
use lightbooth::instrument::sim::{spawn_mock, MockConfig, MockHandle, Pr655Switches};
use lightbooth::instrument::InstrumentError;
use lightbooth::spectrum::{Grid, SpectralUnit, Spectrum};

use crate::common::pr655_wire;
use pr655_wire::{ask, d65_radiance};

/// A narrow line: a Gaussian of σ = 1 nm at `nm`, about 100 cd/m² near 555 nm.
fn line_radiance(nm: f64) -> Spectrum {
    let grid = Grid::one_nm();
    let values = grid
        .wavelengths()
        .iter()
        .map(|w| 0.06 * (-0.5 * ((w - nm) / 1.0).powi(2)).exp())
        .collect();
    Spectrum::new(grid, SpectralUnit::SpectralRadiance, values).unwrap()
}

fn simulator(model: Model, truth: Spectrum, flicker_hz: Option<f64>) -> MockHandle {
    let switches = Pr655Switches {
        banner_latency_ms: 20,
        ..Pr655Switches::for_model(model)
    };
    let mut cfg = MockConfig::pr655(truth, switches);
    cfg.speed = 0.0;
    cfg.seed = 11;
    cfg.flicker_hz = flicker_hz;
    spawn_mock(cfg).unwrap()
}

/// The simulator's base time (shutter and computation), ms at speed 1.
fn base_ms(model: Model) -> f64 {
    MockConfig::pr655(d65_radiance(), Pr655Switches::for_model(model))
        .model
        .base_time_ms
}

/// Opens the pty and enters remote mode as the sheet's section 0 does.
fn remote(mock: &MockHandle) -> Box<dyn serialport::SerialPort> {
    let mut port = serialport::new(mock.device_path().to_str().unwrap(), 9600)
        .timeout(Duration::from_millis(50))
        .open()
        .unwrap();
    for b in b"PHOTO" {
        port.write_all(&[*b]).unwrap();
        // Strict mode takes the letters only one per read (13.2).
        std::thread::sleep(Duration::from_millis(40));
    }
    let mut banner = Vec::new();
    let t0 = Instant::now();
    let mut buf = [0u8; 64];
    while banner.len() < 12 && t0.elapsed() < Duration::from_secs(3) {
        if let Ok(n) = port.read(&mut buf) {
            banner.extend_from_slice(&buf[..n]);
        }
    }
    assert_eq!(banner, b" REMOTE MODE");
    port
}

/// The third comma field of a one-line report (after status and units), as a number.
fn third_field(line: &str) -> f64 {
    line.split(',').nth(2).unwrap().trim().parse().unwrap()
}

/// 13.7: auto sync adds its detection time and rounds the exposure up to
/// whole periods (110 ms at 60 Hz → 7 periods, `D13` says 117 msec); `SN3`
/// takes three exposures and three darks; smart dark (`SD1`, PR-670) takes
/// one dark and none at all for a repeat at the same exposure; a steady
/// source under `SS1` ends in −10 after the detection time alone.
#[test]
fn the_measurement_time_counts_sync_detection_whole_periods_exposures_and_darks() {
    let model = Model::Pr670;
    let base = base_ms(model);
    let detection = Pr655Switches::for_model(model).sync_detection_ms as f64;
    let mock = simulator(model, d65_radiance(), Some(60.0));
    let mut port = remote(&mock);
    let close = |got: Option<f64>, want: f64| {
        let got = got.unwrap();
        assert!(
            (got - want).abs() < 1e-6,
            "measurement time {got} ms, expected {want} ms"
        );
    };

    assert_eq!(ask(&mut port, "SE110"), vec!["00000"]);
    assert_eq!(ask(&mut port, "M0"), vec!["00000"]);
    close(mock.last_measurement_ms(), base + 2.0 * 110.0);

    assert_eq!(ask(&mut port, "SS1"), vec!["00000"]);
    assert_eq!(ask(&mut port, "M0"), vec!["00000"]);
    let seven_periods = 7.0 * 1000.0 / 60.0;
    close(mock.last_measurement_ms(), base + detection + 2.0 * seven_periods);
    assert_eq!(ask(&mut port, "D13"), vec!["00000,Normal,117 msec"]);
    assert_eq!(ask(&mut port, "D14"), vec!["00000,Auto Sync,60.00 Hertz"]);

    assert_eq!(ask(&mut port, "SS0"), vec!["00000"]);
    assert_eq!(ask(&mut port, "SN3"), vec!["00000"]);
    assert_eq!(ask(&mut port, "M0"), vec!["00000"]);
    close(mock.last_measurement_ms(), base + 6.0 * 110.0);

    assert_eq!(ask(&mut port, "SD1"), vec!["00000"]);
    assert_eq!(ask(&mut port, "SE120"), vec!["00000"]);
    assert_eq!(ask(&mut port, "M0"), vec!["00000"]);
    close(mock.last_measurement_ms(), base + 4.0 * 120.0);
    assert_eq!(ask(&mut port, "M0"), vec!["00000"]);
    close(mock.last_measurement_ms(), base + 3.0 * 120.0);

    // A steady source: nothing to sync to.
    let steady = simulator(model, d65_radiance(), None);
    let mut port = remote(&steady);
    assert_eq!(ask(&mut port, "F"), vec!["-0003"]);
    assert_eq!(ask(&mut port, "SS1"), vec!["00000"]);
    assert_eq!(ask(&mut port, "M5"), vec!["-0010"]);
    close(steady.last_measurement_ms(), base + detection);
}

/// Report 11 against the definitions of the units, not against the
/// simulator's own path: K′m = 1700 lm/W was chosen so that scotopic and
/// photopic efficacy agree at 555 nm (1700 · V′(555) = 1700 · 0.402 = 683 ·
/// V(555), CIE 1951), so a narrow line there has scotopic luminance = its
/// luminance; at the V′(λ) peak (507 nm, V′ = 1) the ratio is 1700 / (683 ·
/// V(507)) with V(507) = 0.4443 from the CIE 1931 ȳ table. Within 2 %: the
/// slit blurs the line over V′'s slope (about 0.7 % at 555 nm).
#[test]
fn scotopic_luminance_matches_the_definition_of_the_scotopic_units() {
    for model in [Model::Pr655, Model::Pr670] {
        for (nm, ratio) in [(555.0, 1700.0 * 0.402 / 683.0), (507.0, 1700.0 / (683.0 * 0.444_309_6))] {
            let mock = simulator(model, line_radiance(nm), None);
            let mut port = remote(&mock);
            assert_eq!(ask(&mut port, "D11"), vec!["-2000"], "no measurement yet");
            assert_eq!(ask(&mut port, "SU1"), vec!["00000"]);
            assert_eq!(ask(&mut port, "M0"), vec!["00000"]);
            let d11 = ask(&mut port, "D11");
            assert_eq!(d11.len(), 1, "{d11:?}");
            assert!(d11[0].starts_with("00000,0,"), "{d11:?}");
            let scotopic = third_field(&d11[0]);
            let photopic = third_field(&ask(&mut port, "D1")[0]);
            let got = scotopic / photopic;
            assert!(
                (got / ratio - 1.0).abs() < 0.02,
                "{model:?} line at {nm} nm: S/P {got}, expected {ratio}"
            );
            // fL after SU0, like Y (8.2): the same factor for both.
            assert_eq!(ask(&mut port, "SU0"), vec!["00000"]);
            let scotopic_fl = third_field(&ask(&mut port, "D11")[0]);
            let photopic_fl = third_field(&ask(&mut port, "D1")[0]);
            assert!((scotopic_fl / photopic_fl / got - 1.0).abs() < 2e-3);
            assert!((scotopic / scotopic_fl - 3.426).abs() < 0.01);
        }
    }
}

/// Sheet 4 and 11.14: `ZResetPreferences` / `ZResetSetup` are refused until
/// `ZEnableReset` (answered `Reset Commands Enabled`); then a reset gets no
/// reply and switches the unit off, so its USB port vanishes: the host end
/// sees a hang-up, never data, and the driver then opening that port gets a
/// typed error naming it.
#[test]
fn reset_commands_are_refused_until_enabled_then_switch_the_unit_off_and_its_port_vanishes() {
    let mock = simulator(Model::Pr655, d65_radiance(), None);
    let path = mock.device_path().to_str().unwrap().to_string();
    let mut port = remote(&mock);
    assert_eq!(ask(&mut port, "ZResetSetup"), vec!["-1000"], "not enabled yet");
    assert_eq!(ask(&mut port, "ZResetPreferences"), vec!["-1000"], "not enabled yet");
    assert_eq!(ask(&mut port, "D111"), vec!["00000,PR-655"], "still on");
    assert!(!mock.is_unplugged());
    assert_eq!(ask(&mut port, "ZEnableReset"), vec!["00000,Reset Commands Enabled"]);

    port.write_all(b"ZResetSetup\r").unwrap();
    let t0 = Instant::now();
    while !mock.is_unplugged() && t0.elapsed() < Duration::from_secs(3) {
        std::thread::sleep(Duration::from_millis(10));
    }
    assert!(mock.is_unplugged(), "the unit switched off");
    let mut buf = [0u8; 64];
    let mut got = Vec::new();
    let hung_up = loop {
        match port.read(&mut buf) {
            Ok(0) => break true,
            Ok(n) => got.extend_from_slice(&buf[..n]),
            Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {
                if t0.elapsed() > Duration::from_secs(3) {
                    break false;
                }
            }
            Err(_) => break true,
        }
    };
    assert!(hung_up, "the host end sees the port vanish");
    assert!(
        got.is_empty(),
        "a reset has no reply: {:?}",
        String::from_utf8_lossy(&got)
    );
    drop(port);

    let settings = Pr655Settings {
        command_timeout_ms: 400,
        banner_timeout_ms: 600,
        remote_entry_delay_ms: 40,
        ..Pr655Settings::for_model(Model::Pr655)
    };
    let e = open_pr655(&path, &settings).err().expect("the port is gone");
    assert!(
        matches!(e, InstrumentError::Open { .. } | InstrumentError::PortClosed { .. }),
        "{e}"
    );
    assert!(e.to_string().contains(&path), "{e}");
}
