//! End to end over a real pty, as an operator runs it: `lightbooth mock-pr650`
//! in one process, `lightbooth measure` in another, the JSON parsed back and
//! compared with the simulator's model of what the instrument sees.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

use serde_json::Value;

use lightbooth::colorimetry::{Cmf, Observer, KM_LM_PER_W};
use lightbooth::instrument::pr650::protocol::as_sent;
use lightbooth::instrument::sim::model::InstrumentModel;
use lightbooth::spectrum::table::SpectraTable;
use lightbooth::spectrum::SpectralUnit;

/// The simulator process; killed (by its own handle) when dropped.
struct Mock {
    child: Child,
    path: String,
}

impl Drop for Mock {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn spawn_mock(args: &[&str]) -> Mock {
    let mut child = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .arg("mock-pr650")
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("run lightbooth mock-pr650");
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let path = line.trim().to_string();
    assert!(
        path.starts_with("/dev/"),
        "first line must be the device path, got `{path}`"
    );
    Mock { child, path }
}

fn measure(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .arg("measure")
        .args(args)
        .output()
        .expect("run lightbooth measure");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A tungsten-like lamp patch at 1 nm, as a renderer or a lab file gives it.
fn write_target(dir: &Path) -> PathBuf {
    let path = dir.join("patch.csv");
    let mut text = String::from("nm,other,lamp\n");
    for nm in 380..=780 {
        let t = (nm - 380) as f64 / 400.0;
        // Rising like a 2856 K lamp, with a narrow bump at 546 nm the 8 nm slit must smooth.
        let bump = 4e-4 * (-((nm as f64 - 546.0) / 2.0).powi(2)).exp();
        text.push_str(&format!("{nm},0.0,{:.6e}\n", 2e-4 + 1.6e-3 * t * t + bump));
    }
    std::fs::write(&path, text).unwrap();
    path
}

fn write_settings(dir: &Path, extra: &str) -> PathBuf {
    let path = dir.join("pr650.toml");
    std::fs::write(
        &path,
        format!(
            "command_timeout_ms = 500\nmeasure_timeout_ms = 2000\ngap_timeout_ms = 300\nresync_quiet_ms = 50\n\
             remote_mode_attempts = 2\n{extra}"
        ),
    )
    .unwrap();
    path
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
}

#[test]
fn measure_against_the_mock_gives_its_truth_within_the_noise_model() {
    let dir = tempfile::tempdir().unwrap();
    let target = write_target(dir.path());
    let spec = format!("{}:lamp", target.display());
    let mock = spawn_mock(&[
        "--spectrum",
        &spec,
        "--speed",
        "0",
        "--no-pace",
        "--remote-window-s",
        "60",
        "--seed",
        "7",
    ]);
    let config = write_settings(dir.path(), "");
    let (ok, stdout, stderr) = measure(&["--port", &mock.path, "--config", config.to_str().unwrap(), "--json"]);
    assert!(ok, "{stderr}");
    let json: Value = serde_json::from_str(&stdout).unwrap();
    for field in [
        "wavelength_nm",
        "radiance",
        "radiance_sd",
        "samples",
        "Y",
        "x",
        "y",
        "luminance_cv",
        "instrument",
    ] {
        assert!(json.get(field).is_some(), "missing {field}");
    }
    assert_eq!(json["instrument"]["model"], "PR-650");
    assert_eq!(json["instrument"]["serial"], "60954303");
    let nm = floats(&json["wavelength_nm"]);
    assert_eq!((nm.len(), nm[0], nm[1], nm[100]), (101, 380.0, 384.0, 780.0));

    // The independent truth: the instrument model applied to the same file.
    let truth = SpectraTable::read(&target)
        .unwrap()
        .spectrum("lamp", SpectralUnit::SpectralRadiance)
        .unwrap();
    let reading = InstrumentModel::default().reading(&truth, 0).unwrap();
    assert_eq!(reading.code, 0);
    let mean = floats(&json["radiance"]);
    let sd = floats(&json["radiance_sd"]);
    let samples = json["samples"].as_array().unwrap();
    assert_eq!(samples.len(), 5);
    let n = samples.len() as f64;
    for i in 0..101 {
        let e = reading.expected[i];
        // Five standard errors of the mean from the model's σ, plus the wire format's rounding.
        let tol = 5.0 * reading.sigma[i] / n.sqrt() + (as_sent(e) - e).abs() + 5e-4 * e;
        assert!((mean[i] - e).abs() <= tol, "{} nm: {} vs {e} ± {tol}", nm[i], mean[i]);
    }
    // Per nm, not per 4 nm band: a flat-ish region reads its own level, not four times it.
    assert!((mean[50] / reading.expected[50] - 1.0).abs() < 0.05);
    // Realistic spread: the samples differ, by about the model's σ.
    let ratio = sd.iter().zip(&reading.sigma).map(|(s, m)| (s / m).powi(2)).sum::<f64>() / 101.0;
    assert!((0.6..1.4).contains(&ratio), "variance ratio {ratio}");
    let first = floats(&samples[0]["radiance"]);
    let second = floats(&samples[1]["radiance"]);
    assert_ne!(first, second, "repeat samples must differ");
    for s in samples {
        assert_eq!(s["code"], 0);
        assert!(s["time"].as_f64().unwrap() > 1.6e9);
    }
    // Luminance CV against the model's σ_Y = Km·Δλ·√Σ ȳ²σ² over Y (five samples: within a factor of 6).
    let cmf = Cmf::of(Observer::Cie1931);
    let var_y: f64 = nm
        .iter()
        .zip(&reading.sigma)
        .map(|(w, s)| (cmf.at(*w)[1] * s).powi(2))
        .sum();
    let model_cv = KM_LM_PER_W * 4.0 * var_y.sqrt() / json["Y"].as_f64().unwrap();
    let cv = json["luminance_cv"].as_f64().unwrap();
    assert!(
        (1.0 / 6.0..6.0).contains(&(cv / model_cv)),
        "CV {cv} vs model {model_cv}"
    );
}

#[test]
fn csv_output_has_the_mean_sd_and_every_sample() {
    let dir = tempfile::tempdir().unwrap();
    let mock = spawn_mock(&["--speed", "0", "--no-pace", "--remote-window-s", "0"]);
    let config = write_settings(dir.path(), "samples = 3\n");
    let (ok, stdout, stderr) = measure(&["--port", &mock.path, "--config", config.to_str().unwrap(), "--csv"]);
    assert!(ok, "{stderr}");
    let table = SpectraTable::parse(&stdout, "stdout").unwrap();
    let names: Vec<&str> = table.names().collect();
    assert_eq!(names, ["radiance", "radiance_sd", "sample_0", "sample_1", "sample_2"]);
    assert_eq!(table.grid().len(), 101);
}

#[test]
fn instrument_and_port_errors_exit_non_zero_with_a_clear_message() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_settings(dir.path(), "retries = 1\n");
    let config = config.to_str().unwrap();

    let (ok, _, stderr) = measure(&["--port", "/dev/does-not-exist", "--config", config]);
    assert!(!ok);
    assert!(
        stderr.contains("cannot open serial port /dev/does-not-exist"),
        "{stderr}"
    );

    let mock = spawn_mock(&[
        "--speed",
        "0",
        "--no-pace",
        "--remote-window-s",
        "0",
        "--fault",
        "error-code",
        "--error-code",
        "19",
    ]);
    let (ok, stdout, stderr) = measure(&["--port", &mock.path, "--config", config, "--json"]);
    assert!(!ok && stdout.is_empty(), "no partial measurement may be printed");
    assert!(
        stderr.contains("overload") && stderr.contains("neutral-density"),
        "{stderr}"
    );

    let mock = spawn_mock(&[
        "--speed",
        "0",
        "--no-pace",
        "--remote-window-s",
        "0",
        "--fault",
        "garble",
    ]);
    let (ok, stdout, stderr) = measure(&["--port", &mock.path, "--config", config, "--json"]);
    assert!(!ok && stdout.is_empty());
    assert!(stderr.contains("garbled reply to `D5`"), "{stderr}");
}

/// User + system CPU time of a process so far, from `/proc/PID/stat`, in seconds.
fn cpu_seconds(pid: u32) -> f64 {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).expect("read /proc/PID/stat");
    // Fields after the command name (which may hold spaces) start after the last ')'.
    let fields: Vec<&str> = stat[stat.rfind(')').unwrap() + 2..].split_whitespace().collect();
    // utime and stime are fields 14 and 15 of the whole line, 12 and 13 here.
    let ticks: f64 = fields[11].parse::<f64>().unwrap() + fields[12].parse::<f64>().unwrap();
    // Clock ticks per second (100 on Linux), as `getconf CLK_TCK` reports it.
    let hz: f64 = Command::new("getconf")
        .arg("CLK_TCK")
        .output()
        .ok()
        .and_then(|o| String::from_utf8_lossy(&o.stdout).trim().parse().ok())
        .unwrap_or(100.0);
    ticks / hz
}

/// Regression: with standard input closed (`</dev/null`, `nohup`, CI) the
/// simulator's power-switch loop polled a disconnected channel, which returns
/// at once: one core at 100 %. An idle simulator must sleep.
#[test]
fn mock_pr650_with_stdin_closed_does_not_spin() {
    let mock = spawn_mock(&["--speed", "0", "--remote-window-s", "0"]); // stdin is /dev/null
    let pid = mock.child.id();
    std::thread::sleep(std::time::Duration::from_millis(300)); // start-up work is not idling
    let before = cpu_seconds(pid);
    let wall = std::time::Duration::from_secs(2);
    std::thread::sleep(wall);
    let used = cpu_seconds(pid) - before;
    // Idle, it wakes 5 times a second (power switch) and 100 times a second
    // (the device's read slice): well under 1 % of a core. A spinning loop
    // takes a whole core, or on a loaded 2-core machine still a large share.
    assert!(
        used < 0.1 * wall.as_secs_f64(),
        "the idle simulator used {used:.2} s of CPU in {wall:?} with stdin closed"
    );
}

/// The PR-655 and PR-670 end to end, as an operator runs them: `lightbooth
/// mock-pr655|mock-pr670` in one process, `lightbooth measure --model …` in
/// another. The spectrum comes on the model's own grid (101 or 201 points),
/// per nm, and the JSON says which instrument took it.
#[test]
fn a_pr655_and_a_pr670_measure_from_the_command_line_on_their_own_grids() {
    for (model, points, step) in [("pr655", 101, 4.0), ("pr670", 201, 2.0)] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
            .args([&format!("mock-{model}"), "--speed", "0", "--banner-latency-ms", "20"])
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut line)
            .unwrap();
        let mock = Mock {
            child,
            path: line.trim().to_string(),
        };
        let (ok, stdout, stderr) = measure(&["--model", model, "--port", &mock.path, "--samples", "2", "--json"]);
        assert!(ok, "{model}: {stderr}");
        let v: Value = serde_json::from_str(&stdout).unwrap();
        let nm: Vec<f64> = serde_json::from_value(v["wavelength_nm"].clone()).unwrap();
        assert_eq!(nm.len(), points, "{model}");
        assert_eq!((nm[0], nm[1] - nm[0], nm[points - 1]), (380.0, step, 780.0), "{model}");
        let expected_model = if model == "pr655" { "PR-655" } else { "PR-670" };
        assert_eq!(v["instrument"]["model"], expected_model);
        assert_eq!(v["instrument"]["serial"], "67065106");
        // D65 at ~100 cd/m² is the simulators' default target.
        let y = v["Y"].as_f64().unwrap();
        assert!((95.0..105.0).contains(&y), "{model}: Y = {y}");
    }
    // A --model that contradicts the settings file is refused by name.
    let (ok, _, stderr) = measure(&[
        "--model",
        "pr670",
        "--config",
        concat!(env!("CARGO_MANIFEST_DIR"), "/instruments/pr655.toml"),
        "--port",
        "/dev/null",
    ]);
    assert!(!ok);
    assert!(stderr.contains("PR-655 settings file"), "{stderr}");
}
