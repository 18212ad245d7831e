//! The spectral OpenEXR read by a reader the project did not write:
//! OpenEXR's own Python binding (PyPI `OpenEXR` 3.x, installed by
//! `tests/setup.sh` in the venv `target/py`). Issue 22: the header's text
//! attributes were Latin-1 (`cd/m\xb2`, `W/(sr\xb7m\xb2\xb7nm)`, `2\xb0`),
//! and the binding stopped with `UnicodeDecodeError` before any pixel.

use std::path::{Path, PathBuf};
use std::process::Command;

use lightbooth::export::image::{spectral_channel_name, write_camera_image, EMISSIVE_UNITS, SPECTRAL_UNITS};
use lightbooth::render::camera::{render_camera_image, CameraImage, CameraSettings, Y};
use lightbooth::render::{load_scene, Coding, RenderSettings};

/// The venv's Python with OpenEXR, or a failure saying how to get it.
fn python() -> PathBuf {
    let py = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/py/bin/python");
    let ok = Command::new(&py)
        .args(["-c", "import OpenEXR, numpy"])
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false);
    assert!(
        ok,
        "{} cannot import OpenEXR: run tests/setup.sh (it installs OpenEXR's Python binding in target/py)",
        py.display()
    );
    py
}

/// Opens the file with OpenEXR, prints every attribute (as text) and
/// channel (name, type, shape) and the value of pixel (x=1, y=2) in each
/// channel, as JSON.
const READER: &str = r#"
import json, sys
import OpenEXR
with OpenEXR.File(sys.argv[1], separate_channels=True) as f:
    part = f.parts[0]
    header = {k: str(v) for k, v in part.header.items()}
    channels = {}
    for name, c in part.channels.items():
        px = c.pixels
        channels[name] = {"dtype": str(px.dtype), "shape": list(px.shape), "at_1_2": float(px[2, 1])}
    print(json.dumps({"header": header, "channels": channels}))
"#;

fn tiny_spectral_image() -> CameraImage {
    let scene = load_scene(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cylinder.toml"))).unwrap();
    let mut camera = scene.camera.clone().unwrap();
    camera.width = 6;
    camera.height = 4;
    let settings = CameraSettings {
        codings: vec![Coding::Spectral],
        reference: None,
        se_every_coding: false,
        observer: lightbooth::colorimetry::Observer::JuddVos,
        transport: RenderSettings::default().transport(),
        seed: 1,
        min_spp: 4,
        first_sample: 0,
        max_spp: 8,
        target_relative_se: None,
        time_budget: None,
    };
    render_camera_image(&scene, &camera, &settings, None, None).unwrap()
}

fn read_with_openexr(path: &Path) -> serde_json::Value {
    let out = Command::new(python()).arg("-c").arg(READER).arg(path).output().unwrap();
    assert!(
        out.status.success(),
        "OpenEXR's Python binding cannot read {}:\n{}",
        path.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn spectral_exr_opens_in_openexrs_python_binding_with_every_channel_and_attribute() {
    let img = tiny_spectral_image();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cyl.exr");
    write_camera_image(&img, &path).unwrap();
    let v = read_with_openexr(&path);
    let header = v["header"].as_object().unwrap();
    let channels = v["channels"].as_object().unwrap();

    // Every channel: 401 bands and X Y Z L M S, each with its SE, and paths.
    assert_eq!(channels.len(), 2 * (401 + 6) + 1, "{:?}", channels.keys());
    for (name, c) in channels {
        assert_eq!(c["dtype"], "float32", "{name}");
        assert_eq!(c["shape"], serde_json::json!([4, 6]), "{name}");
    }
    // Pixel (x=1, y=2) as written, in a band, in Y and in its SE.
    let k550 = 550 - 380;
    let name_550 = spectral_channel_name(550.0);
    assert_eq!(
        channels[&name_550]["at_1_2"].as_f64().unwrap() as f32,
        img.mean(1, 2, k550) as f32
    );
    assert!(img.mean(1, 2, 401 + Y) > 0.0);
    assert_eq!(
        channels["Y"]["at_1_2"].as_f64().unwrap() as f32,
        img.mean(1, 2, 401 + Y) as f32
    );
    assert_eq!(
        channels[&format!("SE.{name_550}")]["at_1_2"].as_f64().unwrap() as f32,
        img.standard_error(1, 2, k550) as f32
    );

    // Every attribute lightbooth writes, with its text as written.
    let attr = |k: &str| {
        header
            .get(k)
            .and_then(|v| v.as_str())
            .unwrap_or_else(|| panic!("no `{k}` in {header:?}"))
    };
    assert_eq!(attr("lightbooth.units.spectral"), SPECTRAL_UNITS);
    assert_eq!(SPECTRAL_UNITS, "W/(sr*m^2*nm)");
    assert_eq!(attr("emissiveUnits"), EMISSIVE_UNITS);
    assert_eq!(attr("spectralLayoutVersion"), "1.0");
    assert_eq!(attr("lightbooth.coding"), "spectral");
    assert_eq!(attr("lightbooth.observer"), "judd-vos-1978");
    assert_eq!(attr("lightbooth.units.XYZ"), "cd/m^2 (Y is luminance)");
    assert!(attr("lightbooth.units.LMS").contains("2 deg"));
    assert!(attr("lightbooth.units.SE").contains("standard error"));
    assert_eq!(attr("lightbooth.spectralStep"), "1 nm");
    // Compressed losslessly (the values above are exact).
    assert!(attr("compression").contains("ZIP"), "{}", attr("compression"));
}

/// `--image-step 5`: every fifth 1 nm band (81 channels, 380 … 780 nm), the
/// same values as the 1 nm image's bands there; the file says the step.
#[test]
fn spectral_exr_with_a_5_nm_step_keeps_every_fifth_band_and_says_so() {
    let img = tiny_spectral_image();
    let coarse = img.every_nth_band(5).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cyl5.exr");
    write_camera_image(&coarse, &path).unwrap();
    let v = read_with_openexr(&path);
    let channels = v["channels"].as_object().unwrap();
    assert_eq!(channels.len(), 2 * (81 + 6) + 1);
    assert!(channels.contains_key(&spectral_channel_name(785.0 - 5.0)));
    assert!(!channels.contains_key(&spectral_channel_name(551.0)));
    assert_eq!(
        channels[&spectral_channel_name(555.0)]["at_1_2"].as_f64().unwrap() as f32,
        img.mean(1, 2, 555 - 380) as f32
    );
    assert_eq!(
        channels["Y"]["at_1_2"].as_f64().unwrap() as f32,
        img.mean(1, 2, 401 + Y) as f32
    );
    assert_eq!(v["header"]["lightbooth.spectralStep"], "5 nm");
    assert!(img.every_nth_band(0).is_err());
}
