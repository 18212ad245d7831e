//! Numeric flags out of range are clap errors (exit 2, the flag named), never
//! a panic, a hang or a huge allocation: `measure --samples
//! 18446744073709551615` used to try to allocate for that many samples, and
//! `serve --mock-speed inf` was accepted. The real binary is run, as scripts
//! run it; every case fails in argument parsing, before any port, file or
//! database is opened.

use std::process::Command;

fn refused(args: &[&str], flag: &str) {
    let out = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .args(args)
        .output()
        .expect("run lightbooth");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?} should be a usage error: {stderr}");
    assert!(stderr.contains("error:") && stderr.contains(flag), "{args:?}: {stderr}");
    assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
}

const HUGE: &str = "18446744073709551615";

#[test]
fn measure_samples_and_retries_out_of_range_are_clear_errors() {
    for samples in [HUGE, "1000000000", "100", "0", "-1"] {
        refused(
            &["measure", "--port", "/nonexistent", &format!("--samples={samples}")],
            "--samples",
        );
    }
    for retries in [HUGE, "100", "-1"] {
        refused(
            &["measure", "--port", "/nonexistent", &format!("--retries={retries}")],
            "--retries",
        );
    }
}

#[test]
fn mock_speed_inf_nan_or_negative_is_a_clear_error() {
    for speed in ["inf", "NaN", "-1", "1e9", "fast"] {
        refused(&["serve", "--mock", &format!("--mock-speed={speed}")], "--mock-speed");
        refused(&["mock-pr650", &format!("--speed={speed}")], "--speed");
    }
    refused(&["mock-pr650", "--remote-window-s", "inf"], "--remote-window-s");
    refused(&["mock-pr650", "--flicker-hz", "0"], "--flicker-hz");
    refused(&["mock-pr650", "--slow-ms", HUGE], "--slow-ms");
}

#[test]
fn render_study_and_analyze_work_bounds_are_clear_errors() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/white.toml");
    for (flag, value) in [
        ("--samples", HUGE),
        ("--samples", "0"),
        ("--max-samples", "4294967296"),
        ("--bounces", "4000000000"),
        ("--bounces", "65"),
        ("--spp", "0"),
        ("--spp", "1000000"),
        ("--threads", "0"),
        ("--target-se", "nan"),
        ("--target-se", "-0.1"),
        ("--russian-roulette-from", "1000"),
    ] {
        refused(&["render", scene, &format!("{flag}={value}")], flag);
    }
    for (flag, value) in [
        ("--seeds", "0"),
        ("--seeds", "65"),
        ("--samples", HUGE),
        ("--bounces", "4000000000"),
    ] {
        refused(&["study", scene, &format!("{flag}={value}")], flag);
    }
    for (flag, value) in [("--seeds", "65"), ("--samples", HUGE)] {
        refused(&["analyze", "failure-map", &format!("{flag}={value}")], flag);
    }
}

/// Regression: the log carried ANSI colour codes (`ESC[2m…`) into files and
/// pipes; they are for terminals only.
#[test]
fn logs_written_to_a_pipe_carry_no_colour_codes() {
    let dir = tempfile::tempdir().unwrap();
    let db = format!("sqlite://{}", dir.path().join("lab.sqlite").display());
    let out = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .args(["experiment", "list", "--db", &db])
        .env("LIGHTBOOTH_LOG", "debug")
        .output()
        .expect("run lightbooth");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("DEBUG"),
        "the database's queries are logged at debug: {stderr}"
    );
    assert!(!stderr.contains('\u{1b}'), "colour codes in a piped log: {stderr:?}");
}

/// `preview_paths = 0` in the daemon's config file is refused naming the
/// file and the key (a preview of no paths would be a black picture shown
/// as the scene), before any port or database is opened.
#[test]
fn a_config_file_with_preview_paths_0_is_refused_naming_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("daemon.toml");
    std::fs::write(&config, "preview_paths = 0\n").unwrap();
    let db = dir.path().join("lab.sqlite");
    let mut child = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .args(["serve", "--mock", "--bind", "127.0.0.1:0", "--config"])
        .arg(&config)
        .arg("--db")
        .arg(format!("sqlite://{}", db.display()))
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run lightbooth");
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if std::time::Instant::now() > deadline {
            child.kill().unwrap();
            panic!("the daemon started with preview_paths = 0");
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    };
    let mut stderr = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut stderr).unwrap();
    assert!(!status.success(), "{stderr}");
    assert!(
        stderr.contains("daemon.toml") && stderr.contains("key `preview_paths`: 0"),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(!db.exists(), "the database was opened before the config was checked");
}

/// `serve --help` names every model `--mock` simulates (not only the
/// spectroradiometers up to the CS-3000), and the simulated-instrument
/// flags speak of the simulated instrument, whichever model it is, not of
/// a PR-650.
#[test]
fn serve_help_lists_every_mock_model_and_names_no_single_model_for_the_simulator() {
    let out = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .args(["serve", "--help"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let help = String::from_utf8_lossy(&out.stdout);
    // The flag's own text: its lines up to the next flag's.
    let mock = help
        .lines()
        .skip_while(|l| !l.trim_start().starts_with("--mock [<MODEL>]"))
        .skip(1)
        .take_while(|l| !l.trim_start().starts_with('-'))
        .collect::<Vec<_>>()
        .join(" ");
    for model in lightbooth::instrument::MODEL_FLAGS {
        assert!(mock.contains(model), "`--mock` does not list {model}: {mock}");
    }
    assert!(!help.contains("simulated PR-650"), "{help}");
}
