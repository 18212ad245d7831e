//! What `lightbooth render` says about what it did (issue 46): `--samples`
//! said 1–16777216 but refused 1 and rounded 256 up to 1024 without a word,
//! and `--image` wrote its file without the "wrote FILE" line every other
//! output prints. The real binary is run, as scripts run it.

use std::path::Path;
use std::process::{Command, Output};

fn render(args: &[&str]) -> Output {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/white.toml");
    Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .arg("render")
        .arg(&scene)
        .args(["--codings", "rgb", "--target-se", "0", "--threads", "2"])
        .args(args)
        .output()
        .expect("run lightbooth render")
}

fn paths_of_each_target(out: &Output) -> Vec<u64> {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "render failed: {stderr}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    v["targets"]
        .as_array()
        .expect("targets")
        .iter()
        .map(|t| t["paths"].as_u64().expect("paths"))
        .collect()
}

/// `--samples 256` rendered 1024 paths per target and said nothing.
#[test]
fn render_samples_256_rounded_up_to_1024_says_so() {
    let out = render(&["--samples", "256", "--json"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(paths_of_each_target(&out), vec![1024], "{stderr}");
    assert!(
        stderr.contains("--samples 256 rounded up to 1024 paths per target")
            && stderr.contains("whole batches of 1024"),
        "the rounding is not stated: {stderr}"
    );
    // A whole batch is used as asked, without a note.
    let out = render(&["--samples", "2048", "--json"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(paths_of_each_target(&out), vec![2048], "{stderr}");
    assert!(!stderr.contains("rounded up"), "{stderr}");
}

/// The help says 1–16777216 and `--samples 1` was refused ("need at least
/// one coding and two samples").
#[test]
fn render_samples_1_accepted_as_the_help_says() {
    let out = render(&["--samples", "1", "--json"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(paths_of_each_target(&out), vec![1024], "{stderr}");
    assert!(stderr.contains("--samples 1 rounded up to 1024"), "{stderr}");
}

/// `--image out.png` (and every image file) prints "wrote FILE".
#[test]
fn render_image_prints_wrote_file() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["view.png", "view.pfm", "view.exr"] {
        let file = dir.path().join(name);
        let out = render(&["--samples", "1024", "--spp", "1", "--image", file.to_str().unwrap()]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{name}: {stderr}");
        assert!(file.exists(), "{name} not written");
        assert!(
            stderr
                .lines()
                .any(|l| l.contains("wrote") && l.contains(file.to_str().unwrap())),
            "{name}: no `wrote {}` line: {stderr}",
            file.display()
        );
    }
}

/// `study --samples` and `analyze failure-map --samples` rounded up to
/// whole batches as `render` did, without a word (issue 46). Both say so
/// before they start, here before a scene file that is not there stops
/// them.
#[test]
fn study_and_failure_map_samples_rounded_up_say_so() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("no-such-scene.toml");
    for args in [
        vec![
            "study",
            "--against",
            "reference",
            "--samples",
            "300",
            missing.to_str().unwrap(),
        ],
        vec![
            "analyze",
            "failure-map",
            "--samples",
            "300",
            "--scene",
            missing.to_str().unwrap(),
        ],
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
            .args(&args)
            .output()
            .expect("run lightbooth");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            stderr.contains("--samples 300 rounded up to 1024 paths per target"),
            "{args:?}: {stderr}"
        );
    }
}
