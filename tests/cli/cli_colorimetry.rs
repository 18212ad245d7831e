//! The colorimetry command line as scripts call it: the real binary, real
//! files, JSON parsed back.

use std::path::Path;
use std::process::Command;

use serde_json::Value;

fn lightbooth(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .args(args)
        .output()
        .expect("run lightbooth");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// D65 as an absolute radiance (0.01 W/(sr·m²·nm) per unit of the table) and
/// two patches under it, written as a lab would.
fn write_fixture(dir: &Path) -> std::path::PathBuf {
    let d65 = lightbooth::reference_data::illuminant(lightbooth::reference_data::Illuminant::D65);
    let cc = lightbooth::reference_data::reflectances(lightbooth::reference_data::ReflectanceSet::ColorChecker);
    let white: Vec<f64> = d65.values().iter().map(|v| v * 0.01).collect();
    let red: Vec<f64> = white.iter().zip(cc[14].1.values()).map(|(a, b)| a * b).collect();
    let green: Vec<f64> = white.iter().zip(cc[13].1.values()).map(|(a, b)| a * b).collect();
    let path = dir.join("booth.csv");
    let file = std::fs::File::create(&path).unwrap();
    lightbooth::spectrum::table::write_csv(file, d65.grid(), &[("white", &white), ("red", &red), ("green", &green)])
        .unwrap();
    path
}

#[test]
fn color_json_has_every_field_and_the_d65_white_point() {
    let dir = tempfile::tempdir().unwrap();
    let csv = write_fixture(dir.path());
    let (ok, stdout, stderr) = lightbooth(&[
        "color",
        csv.to_str().unwrap(),
        "--cmf",
        "cie1931",
        "--white",
        "white",
        "--reference",
        "white",
        "--json",
    ]);
    assert!(ok, "{stderr}");
    let rows: Value = serde_json::from_str(&stdout).unwrap();
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 3);
    let white = &rows[0];
    for field in ["name", "X", "Y", "Z", "x", "y", "u", "v", "L", "a", "b", "dE76", "dE00"] {
        assert!(white.get(field).is_some(), "missing {field} in {white}");
    }
    // CIE 15:2004: D65 white point (0.3127, 0.3290) with the 1931 observer.
    assert!((white["x"].as_f64().unwrap() - 0.3127).abs() < 1e-4);
    assert!((white["y"].as_f64().unwrap() - 0.3290).abs() < 1e-4);
    assert!((white["L"].as_f64().unwrap() - 100.0).abs() < 1e-9);
    assert_eq!(white["dE00"].as_f64().unwrap(), 0.0);
    // Y is luminance: 683 · Σ 0.01·D65·ȳ·5.
    let expected_y = 683.0 * 0.01 * 100.0 * 100.0 / lightbooth_y_normaliser();
    assert!((white["Y"].as_f64().unwrap() - expected_y).abs() < 1e-6 * expected_y);
    assert!(rows[1]["dE76"].as_f64().unwrap() > 10.0, "red differs from white");
}

/// 100 / Σ D65·ȳ·Δλ, the CIE relative normaliser, so the absolute Y of
/// 0.01·D65 can be written from the relative one.
fn lightbooth_y_normaliser() -> f64 {
    use lightbooth::colorimetry::{Cmf, Observer};
    let d65 = lightbooth::reference_data::illuminant(lightbooth::reference_data::Illuminant::D65);
    let s = Cmf::of(Observer::Cie1931).integrate(d65.values(), d65.grid(), 5.0);
    100.0 * 100.0 / s[1]
}

#[test]
fn color_without_white_leaves_cielab_out() {
    let dir = tempfile::tempdir().unwrap();
    let csv = write_fixture(dir.path());
    let (ok, stdout, _) = lightbooth(&["color", csv.to_str().unwrap(), "--json"]);
    assert!(ok);
    let rows: Value = serde_json::from_str(&stdout).unwrap();
    assert!(rows[0].get("L").is_none() && rows[0].get("dE00").is_none());
    assert!(rows[0].get("u").is_some());
}

#[test]
fn malformed_csv_fails_with_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.csv");
    std::fs::write(&path, "nm,patch\n380,0.1\n385,0,2\n").unwrap();
    let (ok, _, stderr) = lightbooth(&["color", path.to_str().unwrap()]);
    assert!(!ok);
    assert!(stderr.contains("bad.csv:3: 3 cells where the header has 2"), "{stderr}");
    std::fs::write(&path, "nm,patch\n380,0.1\n385,oops\n").unwrap();
    let (ok, _, stderr) = lightbooth(&["color", path.to_str().unwrap()]);
    assert!(!ok);
    assert!(
        stderr.contains("bad.csv:3: column 2 (patch): `oops` is not a number"),
        "{stderr}"
    );
    let (ok, _, stderr) = lightbooth(&["color", path.to_str().unwrap().replace("bad", "missing").as_str()]);
    assert!(!ok && stderr.contains("missing.csv: no such file"), "{stderr}");
}

#[test]
fn unknown_white_column_lists_the_columns() {
    let dir = tempfile::tempdir().unwrap();
    let csv = write_fixture(dir.path());
    let (ok, _, stderr) = lightbooth(&["color", csv.to_str().unwrap(), "--white", "spectralon"]);
    assert!(!ok);
    assert!(
        stderr.contains("no such column") && stderr.contains("white, red, green"),
        "{stderr}"
    );
}

#[test]
fn nstep_error_json_shows_f11_falling_more_slowly_than_d65() {
    let curve = |illuminant: &str| -> (Vec<u64>, Vec<f64>) {
        let (ok, stdout, stderr) = lightbooth(&[
            "analyze",
            "nstep-error",
            "--reflectances",
            "colorchecker",
            "--illuminant",
            illuminant,
            "--json",
        ]);
        assert!(ok, "{stderr}");
        let v: Value = serde_json::from_str(&stdout).unwrap();
        let n = v["n"].as_array().unwrap().iter().map(|x| x.as_u64().unwrap()).collect();
        let e = v["error"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        (n, e)
    };
    let (n, d65) = curve("D65");
    let (_, f11) = curve("F11");
    assert_eq!(n, (1..=81).collect::<Vec<u64>>());
    assert_eq!(d65[0], 1.0);
    assert_eq!(f11[0], 1.0);
    // Summed over the useful range N = 2…27, F11's remaining error is larger.
    let sum = |e: &[f64]| e[1..27].iter().sum::<f64>();
    assert!(sum(&f11) > sum(&d65), "F11 {} vs D65 {}", sum(&f11), sum(&d65));
}

#[test]
fn nstep_error_accepts_a_reflectance_file_and_rejects_a_short_grid() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("paints.csv");
    std::fs::write(&path, "nm,a,b\n380,0.1,0.8\n580,0.5,0.2\n780,0.9,0.1\n").unwrap();
    let (ok, stdout, stderr) = lightbooth(&[
        "analyze",
        "nstep-error",
        "--reflectances",
        path.to_str().unwrap(),
        "--illuminant",
        "A",
        "--json",
    ]);
    assert!(ok, "{stderr}");
    assert!(stdout.starts_with("{\"n\":[1,"));
    std::fs::write(&path, "nm,a\n400,0.1\n700,0.5\n").unwrap();
    let (ok, _, stderr) = lightbooth(&[
        "analyze",
        "nstep-error",
        "--reflectances",
        path.to_str().unwrap(),
        "--illuminant",
        "A",
    ]);
    assert!(!ok && stderr.contains("does not cover 380–780 nm"), "{stderr}");
}

/// A CSV column: its header and its value at each wavelength (nm).
type Column<'a> = (&'a str, fn(u32) -> f64);

/// Writes a CSV of `columns` on `nm` and returns its path.
fn write_csv(dir: &Path, file: &str, nm: impl Iterator<Item = u32>, columns: &[Column]) -> String {
    let mut text = String::from("nm");
    for (name, _) in columns {
        text.push_str(&format!(",{name}"));
    }
    text.push('\n');
    for w in nm {
        text.push_str(&w.to_string());
        for (_, f) in columns {
            text.push_str(&format!(",{:e}", f(w)));
        }
        text.push('\n');
    }
    let p = dir.join(file);
    std::fs::write(&p, text).unwrap();
    p.display().to_string()
}

/// Only 380 and 780 nm, or 400–695 nm, used to give a plausible-looking but
/// wrong XYZ (a silent sum over what was there); now it is an error naming
/// the file, the grid found and the range needed.
#[test]
fn color_grid_not_covering_the_integration_range_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let two = write_csv(dir.path(), "two.csv", [380, 780].into_iter(), &[("white", |_| 0.9)]);
    let short = write_csv(dir.path(), "short.csv", (400..=695).step_by(5), &[("white", |_| 0.9)]);
    for (file, found) in [(&two, "380–780 nm at 400 nm"), (&short, "400–695 nm")] {
        for unit in ["radiance", "reflectance"] {
            let (ok, stdout, stderr) = lightbooth(&["color", file, "--unit", unit, "--json"]);
            assert!(!ok, "{file} --unit {unit} was accepted: {stdout}");
            assert!(stderr.contains(file.as_str()), "{stderr}");
            assert!(stderr.contains(found), "should give the grid found ({found}): {stderr}");
            assert!(stderr.contains("380–780 nm at a step of at most 10 nm"), "{stderr}");
        }
    }
    // The same white on a covering 5 nm grid is fine.
    let full = write_csv(dir.path(), "full.csv", (380..=780).step_by(5), &[("white", |_| 0.9)]);
    let (ok, stdout, stderr) = lightbooth(&["color", &full, "--unit", "reflectance", "--json"]);
    assert!(ok, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert!((v[0]["Y"].as_f64().unwrap() - 90.0).abs() < 1e-9, "{v}");
}

/// 1e308 radiances used to give `"X": null` with exit 0.
#[test]
fn color_overflowing_values_are_an_error_not_inf_or_nan() {
    let dir = tempfile::tempdir().unwrap();
    let big = write_csv(dir.path(), "big.csv", (380..=780).step_by(5), &[("big", |_| 1e308)]);
    let (ok, stdout, stderr) = lightbooth(&["color", &big, "--json"]);
    assert!(!ok, "accepted: {stdout}");
    assert!(!stdout.contains("null"), "{stdout}");
    assert!(stderr.contains("big.csv") && stderr.contains("overflows"), "{stderr}");
}

/// A radiance CSV read as a reflectance is named as light, not only as "a
/// value outside [0, 1]".
#[test]
fn radiance_csv_used_as_reflectance_is_named_as_light() {
    let dir = tempfile::tempdir().unwrap();
    let by_header = write_csv(
        dir.path(),
        "lamp.csv",
        (380..=780).step_by(5),
        &[("radiance_W_sr_m2_nm", |nm| 0.5 + f64::from(nm) / 400.0)],
    );
    let by_size = write_csv(dir.path(), "booth.csv", (380..=780).step_by(5), &[("patch", |_| 120.0)]);
    for file in [&by_header, &by_size] {
        let (ok, _, stderr) = lightbooth(&["color", file, "--unit", "reflectance"]);
        assert!(!ok);
        assert!(
            stderr.contains(file.as_str()) && stderr.contains("looks like a radiance"),
            "{stderr}"
        );
        assert!(stderr.contains("--unit radiance"), "{stderr}");
    }
    // The same files are fine as radiance.
    assert!(lightbooth(&["color", &by_size, "--unit", "radiance"]).0);
}

/// The embedded tables of the CIE observers and the Stockman & Sharpe cone
/// fundamentals agree with colour-science's copies (an independent
/// transcription of the same CVRL files, in the colour-specio venv that
/// `tests/setup.sh` makes) to 1e-6 at every row they ship, and each
/// observer's embedded grid is what `PROVENANCE.md` says (380 or 390 nm to
/// 780 nm at 1 nm; Judd–Vos at 5 nm is CVRL's own and not in colour-science).
#[test]
fn the_observers_tables_agree_with_colour_science_to_1e_6() {
    use lightbooth::colorimetry::{Cmf, ConeFundamentals, Observer};
    let python = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/py312/bin/python");
    assert!(
        python.exists(),
        "{} is missing: run `bash tests/setup.sh`, which makes the colour-specio venv with colour-science",
        python.display()
    );
    let out = Command::new(&python)
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/colour_observers.py"))
        .output()
        .expect("run colour_observers.py");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let tables: Value = serde_json::from_slice(&out.stdout).unwrap();
    // colour-science's value at `nm` (null, CVRL's blank, is 0).
    let theirs = |key: &str, nm: f64| -> [f64; 3] {
        let t = &tables[key];
        let i = t["wavelength_nm"]
            .as_array()
            .unwrap()
            .iter()
            .position(|w| (w.as_f64().unwrap() - nm).abs() < 1e-9)
            .unwrap_or_else(|| panic!("{key}: colour-science has no row at {nm} nm"));
        std::array::from_fn(|c| t["values"][i][c].as_f64().unwrap_or(0.0))
    };
    let mut checked = 0;
    for (observer, first_nm) in [
        (Observer::Cie1931, 380.0),
        (Observer::Cie1964Ten, 380.0),
        (Observer::Cie2015Two, 390.0),
        (Observer::Cie2015Ten, 390.0),
    ] {
        let cmf = Cmf::of(observer);
        let w = cmf.grid().wavelengths();
        assert_eq!(
            (w[0], w[w.len() - 1], w.len()),
            (first_nm, 780.0, (781.0 - first_nm) as usize),
            "{observer}"
        );
        for &nm in w {
            let (ours, theirs) = (cmf.at(nm), theirs(observer.name(), nm));
            for c in 0..3 {
                assert!(
                    (ours[c] - theirs[c]).abs() <= 1e-6,
                    "{observer} at {nm} nm, column {c}: {ours:?} vs {theirs:?}"
                );
            }
            checked += 1;
        }
    }
    for (cones, key) in [
        (ConeFundamentals::StockmanSharpe2, "stockman-sharpe-2"),
        (ConeFundamentals::StockmanSharpe10, "stockman-sharpe-10"),
    ] {
        let ours = cones.on_1nm_grid();
        for (i, nm) in (390..=780).enumerate() {
            let theirs = theirs(key, nm as f64);
            for c in 0..3 {
                let v = ours[c][i + 10];
                assert!(
                    (v - theirs[c]).abs() <= 1e-6,
                    "{key} at {nm} nm, cone {c}: {v} vs {}",
                    theirs[c]
                );
            }
            checked += 1;
        }
        assert_eq!(ours[0][..10], [0.0; 10], "{key}: below 390 nm is 0");
    }
    println!("{checked} rows agree with colour-science {}", tables["colour_version"]);
}

/// `color --observer` takes every observer by its name, and each gives its
/// own white point (CIE 15:2018 Table 9.1: D65 is x₁₀ = 0.31382, y₁₀ =
/// 0.33100 in the 1964 10° observer; x = 0.31272 in CIE 1931 2°).
#[test]
fn color_takes_every_observer_by_name_and_names_it_in_the_json() {
    let dir = tempfile::tempdir().unwrap();
    let csv = write_fixture(dir.path());
    let mut white_x = Vec::new();
    for name in ["judd-vos-1978", "cie-1931", "cie-1964-10", "cie-2015-2", "cie-2015-10"] {
        let (ok, stdout, stderr) = lightbooth(&["color", csv.to_str().unwrap(), "--observer", name, "--json"]);
        assert!(ok, "{name}: {stderr}");
        let rows: Value = serde_json::from_str(&stdout).unwrap();
        let rows = rows.as_array().unwrap();
        assert!(rows.iter().all(|r| r["observer"] == name), "{stdout}");
        let white = rows
            .iter()
            .find(|r| r["name"] == "white")
            .unwrap_or_else(|| panic!("{stdout}"));
        white_x.push((name, white["x"].as_f64().unwrap()));
    }
    let x = |n: &str| white_x.iter().find(|(m, _)| *m == n).unwrap().1;
    assert!((x("cie-1931") - 0.31272).abs() < 2e-4, "{white_x:?}");
    assert!((x("cie-1964-10") - 0.31382).abs() < 2e-4, "{white_x:?}");
    let (ok, _, stderr) = lightbooth(&["color", csv.to_str().unwrap(), "--observer", "cie-2006"]);
    assert!(!ok && stderr.contains("cie-2015-10"), "{stderr}");
}
