//! `lightbooth stimulus` and `lightbooth display-resolution` against a
//! display whose truth is known: the simulated CRT (crates/science/src/display/simulated.rs).
//! The profile is fitted to the CRT's exact spectra (no instrument noise),
//! so what is tested is the conversion; the truth is always the simulated
//! display's own spectra integrated with the CMFs, never the converter's
//! matrices.

use std::path::{Path, PathBuf};
use std::process::Command;

use exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Encoding, FlatSamples, Image, Layer, LayerAttributes, SmallVec, Text,
    WritableImage,
};
use lightbooth::colorimetry::{ciede2000, xyz_from_radiance, Lab, Observer, Xyz};
use lightbooth::display::profile::TransferModel;
use lightbooth::display::stimulus::{convert, quantisation_bound_de00, GamutPolicy};
use lightbooth::display::{
    fit_profile, CalibrationPlan, Converter, DisplayProfile, FrameBuffer, MeasuredPatch, SimulatedDisplay,
};
use lightbooth::export::exr_read::read_xyz_exr;
use lightbooth::export::image::spectral_channel_name;
use lightbooth::spectrum::Grid;
use serde_json::Value;

/// The profile of the simulated CRT, fitted to its exact 1 nm spectra.
fn exact_profile(display: &SimulatedDisplay) -> DisplayProfile {
    let patches: Vec<MeasuredPatch> = CalibrationPlan::new(8)
        .unwrap()
        .patches
        .iter()
        .enumerate()
        .map(|(i, p)| {
            MeasuredPatch::spectrum(
                p.drive,
                Grid::one_nm().wavelengths().to_vec(),
                display.spectrum(p.drive).into_values(),
                Some(i as i64 + 1),
            )
        })
        .collect();
    fit_profile(&patches, Observer::JuddVos).unwrap()
}

/// XYZ the simulated display truly shows for a drive.
fn truth_xyz(display: &SimulatedDisplay, drive: [f64; 3]) -> [f64; 3] {
    xyz_from_radiance(&display.spectrum(drive), Observer::JuddVos)
        .unwrap()
        .to_array()
}

fn de00(white: [f64; 3], a: [f64; 3], b: [f64; 3]) -> f64 {
    let w = Xyz::from_array(white);
    ciede2000(
        Lab::from_xyz(Xyz::from_array(a), w),
        Lab::from_xyz(Xyz::from_array(b), w),
    )
}

fn channel(name: &str, values: Vec<f32>) -> AnyChannel<FlatSamples> {
    AnyChannel {
        name: Text::from(name),
        sample_data: FlatSamples::F32(values),
        quantize_linearly: true,
        sampling: exr::math::Vec2(1, 1),
    }
}

/// Writes an EXR with the named planes and, optionally, `lightbooth.observer`.
fn write_exr(path: &Path, size: (usize, usize), planes: Vec<(String, Vec<f32>)>, observer: Option<&str>) {
    let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for (name, v) in planes {
        channels.push(channel(&name, v));
    }
    let mut attributes = LayerAttributes::default();
    if let Some(o) = observer {
        attributes
            .other
            .insert(Text::from("lightbooth.observer"), AttributeValue::Text(Text::from(o)));
    }
    let layer = Layer::new(size, attributes, Encoding::FAST_LOSSLESS, AnyChannels::sort(channels));
    Image::from_layer(layer).write().non_parallel().to_file(path).unwrap();
}

/// A 4 × 3 image of the display's own colours at 8-bit drives (so every
/// pixel is in gamut and its 8-bit codes are known), written as X, Y, Z.
const DRIVES: [[u32; 3]; 12] = [
    [0, 0, 0],
    [255, 255, 255],
    [255, 0, 0],
    [0, 255, 0],
    [0, 0, 255],
    [128, 128, 128],
    [200, 60, 30],
    [20, 180, 90],
    [64, 32, 220],
    [250, 240, 10],
    [10, 10, 12],
    [100, 200, 150],
];

fn xyz_image(dir: &Path, display: &SimulatedDisplay, extra: Option<[f64; 3]>) -> (PathBuf, Vec<[f64; 3]>) {
    let mut xyz: Vec<[f64; 3]> = DRIVES
        .iter()
        .map(|d| truth_xyz(display, d.map(|c| f64::from(c) / 255.0)))
        .collect();
    if let Some(x) = extra {
        xyz[11] = x;
    }
    let planes = ["X", "Y", "Z"]
        .iter()
        .enumerate()
        .map(|(k, n)| (n.to_string(), xyz.iter().map(|p| p[k] as f32).collect()))
        .collect();
    let path = dir.join("image.exr");
    write_exr(&path, (4, 3), planes, Some("judd-vos-1978"));
    // What the file holds (f32).
    let stored = xyz.iter().map(|p| p.map(|v| f64::from(v as f32))).collect();
    (path, stored)
}

fn write_profile(dir: &Path, profile: &DisplayProfile) -> PathBuf {
    let path = dir.join("profile.json");
    // As GET /api/display-profiles/{id} returns it: the row around the profile.
    let row = serde_json::json!({"id": 1, "name": "simulated CRT", "created_at": 0.0, "note": "", "profile": profile});
    std::fs::write(&path, serde_json::to_string_pretty(&row).unwrap()).unwrap();
    path
}

fn lightbooth(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .args(args)
        .output()
        .unwrap()
}

fn read_png16(path: &Path) -> (u32, u32, Vec<[u16; 3]>) {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.bit_depth, png::BitDepth::Sixteen);
    assert_eq!(info.color_type, png::ColorType::Rgb);
    let px = buf[..info.buffer_size()]
        .chunks(6)
        .map(|c| [0, 1, 2].map(|k| u16::from_be_bytes([c[2 * k], c[2 * k + 1]])))
        .collect();
    (info.width, info.height, px)
}

#[test]
fn in_gamut_colours_pass_every_gamut_policy_unchanged() {
    let display = SimulatedDisplay::crt().unwrap();
    let profile = exact_profile(&display);
    let xyz: Vec<[f64; 3]> = DRIVES
        .iter()
        .map(|d| truth_xyz(&display, d.map(|c| f64::from(c) / 255.0 * 0.98)))
        .collect();
    let fb = FrameBuffer::new(16).unwrap();
    let clip = convert(&profile, &xyz, fb, GamutPolicy::Clip, TransferModel::Gamma).unwrap();
    for policy in [GamutPolicy::Clip, GamutPolicy::Scale, GamutPolicy::Fail] {
        let s = convert(&profile, &xyz, fb, policy, TransferModel::Gamma).unwrap();
        assert_eq!(s.gamut.out_of_gamut, 0, "{policy:?}");
        assert_eq!(s.gamut.scale_factor, 1.0, "{policy:?}");
        assert_eq!(s.codes, clip.codes, "{policy:?}");
        // Unchanged: the intended colour is the original (to the matrices' rounding).
        for (i, o) in s.delta_e00_intended.iter().zip(&s.delta_e00_original) {
            assert!((i - o).abs() < 1e-9, "{policy:?}: {i} vs {o}");
        }
    }
}

#[test]
fn clip_scale_and_fail_treat_a_known_out_of_gamut_pixel() {
    let display = SimulatedDisplay::crt().unwrap();
    let profile = exact_profile(&display);
    let conv = Converter::new(&profile).unwrap();
    // Half the display's colours, plus one pixel 1.6 × as bright as full red
    // at the same chromaticity (linear RGB [1.6, 0.48, 0.16]).
    let mut xyz: Vec<[f64; 3]> = DRIVES
        .iter()
        .map(|d| truth_xyz(&display, d.map(|c| f64::from(c) / 255.0)))
        .map(|x| conv.linear(x))
        .map(|l| conv.xyz(l.map(|t| 0.5 * t)))
        .collect();
    let bright = [1.6, 0.48, 0.16];
    xyz.push(conv.xyz(bright));
    let n = xyz.len();
    let fb = FrameBuffer::new(16).unwrap();

    let err = convert(&profile, &xyz, fb, GamutPolicy::Fail, TransferModel::Gamma)
        .unwrap_err()
        .to_string();
    assert!(err.contains(&format!("1 of {n} colours")), "{err}");
    assert!(err.contains(&format!("colour {}", n - 1)), "{err}");

    let clip = convert(&profile, &xyz, fb, GamutPolicy::Clip, TransferModel::Gamma).unwrap();
    assert_eq!(clip.gamut.out_of_gamut, 1);
    let worst = clip.gamut.worst.unwrap();
    assert_eq!(worst.index, n - 1);
    assert!((worst.excess - 0.6).abs() < 1e-6, "{worst:?}");
    // Clipped to [1, 0.48, 0.16]: the display shows full red's channel with the others as asked.
    let want = truth_xyz(&display, [1.0, 0.48f64.powf(1.0 / 2.2), 0.16f64.powf(1.0 / 2.15)]);
    let white = truth_xyz(&display, [1.0; 3]);
    assert!(
        de00(white, clip.shown[n - 1], want) < 0.01,
        "{:?} vs {want:?}",
        clip.shown[n - 1]
    );

    let scale = convert(&profile, &xyz, fb, GamutPolicy::Scale, TransferModel::Gamma).unwrap();
    assert!(
        (scale.gamut.scale_factor - 1.0 / 1.6).abs() < 1e-6,
        "{}",
        scale.gamut.scale_factor
    );
    // The bright pixel becomes full red at its chromaticity; the others are scaled by 1/1.6.
    let want = truth_xyz(&display, [1.0, 0.3f64.powf(1.0 / 2.2), 0.1f64.powf(1.0 / 2.15)]);
    assert!(de00(white, scale.shown[n - 1], want) < 0.01);
    let gammas = display.gammas();
    let grey = truth_xyz(
        &display,
        [0, 1, 2].map(|c| (0.5 * (128.0f64 / 255.0).powf(gammas[c]) / 1.6).powf(1.0 / gammas[c])),
    );
    assert!(
        de00(white, scale.shown[5], grey) < 0.01,
        "{:?} vs {grey:?}",
        scale.shown[5]
    );
}

#[test]
fn round_trips_at_8_bits_stay_under_the_stated_quantisation_bound() {
    let display = SimulatedDisplay::crt().unwrap();
    let profile = exact_profile(&display);
    let white = truth_xyz(&display, [1.0; 3]);
    let bound8 = quantisation_bound_de00(&profile, FrameBuffer::new(8).unwrap(), TransferModel::Gamma).unwrap();
    let bound10 = quantisation_bound_de00(&profile, FrameBuffer::new(10).unwrap(), TransferModel::Gamma).unwrap();
    let bound12 = quantisation_bound_de00(&profile, FrameBuffer::new(12).unwrap(), TransferModel::Gamma).unwrap();
    eprintln!("quantisation bound ΔE00: 8 bits {bound8:.4}, 10 bits {bound10:.4}, 12 bits {bound12:.4}");
    // Half a code shrinks 4× per two bits; the bound follows.
    assert!(bound10 < bound8 / 3.0 && bound12 < bound10 / 3.0);
    // Colours off the bound's 33-level grid: a Weyl sequence through the drive cube.
    let xyz: Vec<[f64; 3]> = (1..=2000)
        .map(|i| {
            let f = |a: f64| (f64::from(i) * a).fract();
            [f(0.618_033_988_7), f(0.754_877_666_2), f(0.569_840_290_9)]
        })
        .map(|d| truth_xyz(&display, d))
        .collect();
    for (bits, bound) in [(8, bound8), (10, bound10), (12, bound12)] {
        let fb = FrameBuffer::new(bits).unwrap();
        let s = convert(&profile, &xyz, fb, GamutPolicy::Fail, TransferModel::Gamma).unwrap();
        let worst = s
            .codes
            .iter()
            .zip(&xyz)
            .map(|(c, x)| de00(white, *x, truth_xyz(&display, c.map(|v| fb.drive(v)))))
            .fold(0.0, f64::max);
        eprintln!("{bits} bits: worst round trip ΔE00 {worst:.4} (bound {bound:.4})");
        assert!(
            worst <= bound,
            "{bits} bits: round trip ΔE00 {worst} above the bound {bound}"
        );
    }
}

#[test]
fn stimulus_writes_the_codes_as_16_bit_png_and_raw_and_reports_the_delta_e_the_display_shows() {
    let dir = tempfile::tempdir().unwrap();
    let display = SimulatedDisplay::crt().unwrap();
    let profile = exact_profile(&display);
    let profile_path = write_profile(dir.path(), &profile);
    let (image, xyz) = xyz_image(dir.path(), &display, None);
    let white = truth_xyz(&display, [1.0; 3]);
    for bits in [8u32, 10, 12] {
        let out = dir.path().join(format!("codes{bits}.png"));
        let report = dir.path().join(format!("report{bits}.json"));
        let map = dir.path().join(format!("map{bits}.png"));
        let o = lightbooth(&[
            "stimulus",
            image.to_str().unwrap(),
            "--display",
            profile_path.to_str().unwrap(),
            "--bits",
            &bits.to_string(),
            "--out",
            out.to_str().unwrap(),
            "--report",
            report.to_str().unwrap(),
            "--map",
            map.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(stdout.contains("ΔE00 intended vs shown: mean"), "{stdout}");
        let (w, h, px) = read_png16(&out);
        assert_eq!((w, h), (4, 3));
        let max = (1u32 << bits) - 1;
        let codes: Vec<[u32; 3]> = px.iter().map(|p| p.map(|v| u32::from(v) >> (16 - bits))).collect();
        for (p, c) in px.iter().zip(&codes) {
            // MSB-aligned: the low 16 − bits bits are zero.
            assert!(p.iter().all(|v| u32::from(*v) & ((1 << (16 - bits)) - 1) == 0), "{p:?}");
            assert!(c.iter().all(|v| *v <= max));
        }
        for (d, c) in DRIVES.iter().zip(&codes) {
            for (dk, ck) in d.iter().zip(c) {
                let exact = f64::from(*dk) / 255.0 * f64::from(max);
                // At drive 0 the power law's infinite slope turns the fit's
                // ~1e-7 of linear output into a few codes of drive: < 1 % of full drive.
                let tolerance = if *dk == 0 { 0.01 * f64::from(max) } else { 1.0 };
                assert!(
                    (f64::from(*ck) - exact).abs() <= tolerance,
                    "{bits} bits: drive {d:?} gave {c:?}"
                );
            }
            if bits == 8 {
                assert_eq!(*c, *d, "8 bits: the display's own 8-bit colours get their own codes");
            }
        }
        if bits != 8 {
            let raw = std::fs::read(dir.path().join(format!("codes{bits}.raw"))).unwrap();
            let side: Value = serde_json::from_str(
                &std::fs::read_to_string(dir.path().join(format!("codes{bits}.raw.json"))).unwrap(),
            )
            .unwrap();
            assert_eq!((side["width"].as_u64(), side["height"].as_u64()), (Some(4), Some(3)));
            assert_eq!(side["bits"].as_u64(), Some(u64::from(bits)));
            assert_eq!(side["channels"], "RGB");
            assert_eq!(side["byte_order"], "little-endian");
            let values: Vec<u32> = raw
                .chunks(2)
                .map(|c| u32::from(u16::from_le_bytes([c[0], c[1]])))
                .collect();
            assert_eq!(values, codes.iter().flatten().copied().collect::<Vec<_>>());
        } else {
            assert!(!dir.path().join("codes8.raw").exists());
        }
        // The report against an independent computation: the codes shown on
        // the simulated display, its spectrum integrated with the CMFs.
        let r: Value = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
        let des: Vec<f64> = codes
            .iter()
            .zip(&xyz)
            .map(|(c, x)| de00(white, *x, truth_xyz(&display, c.map(|v| f64::from(v) / f64::from(max)))))
            .collect();
        let mean = des.iter().sum::<f64>() / des.len() as f64;
        let maxde = des.iter().cloned().fold(0.0, f64::max);
        let got = &r["delta_e00_original_vs_shown"];
        eprintln!(
            "{bits} bits: report mean {} max {}, truth mean {mean} max {maxde}",
            got["mean"], got["max"]
        );
        assert!((got["mean"].as_f64().unwrap() - mean).abs() < 0.01, "{got} vs {mean}");
        assert!((got["max"].as_f64().unwrap() - maxde).abs() < 0.02, "{got} vs {maxde}");
        assert_eq!(r["gamut"]["out_of_gamut"], 0);
        assert!(got["max"].as_f64().unwrap() <= r["quantisation_bound_delta_e00"].as_f64().unwrap() + 0.01);
        let (mw, mh) = {
            let d = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&map).unwrap()));
            let info = d.read_info().unwrap();
            (info.info().width, info.info().height)
        };
        assert_eq!((mw, mh), (4, 3));
        let scale_max = r["map_scale_max_delta_e00"].as_f64().unwrap();
        assert!(scale_max > 0.0);
        // The figure beside the map: the map itself embedded, the bar's
        // viridis ends, and the scale's top labelled with the report's value.
        let figure = map.with_extension("svg");
        assert_eq!(r["map_figure"].as_str(), figure.to_str());
        let svg = std::fs::read_to_string(&figure).unwrap();
        let embedded = svg
            .split("data:image/png;base64,")
            .nth(1)
            .and_then(|s| s.split('"').next())
            .expect("the figure embeds the map as a PNG");
        let embedded = base64::Engine::decode(&base64::engine::general_purpose::STANDARD, embedded).unwrap();
        assert_eq!(embedded, std::fs::read(&map).unwrap(), "the figure embeds the map file");
        assert!(svg.contains("stop-color=\"#440154\"") && svg.contains("stop-color=\"#fde725\""));
        let top = lightbooth::charts::tick_label(scale_max, scale_max);
        assert!(svg.contains(&format!(">{top}</text>")), "no tick {top} in {svg}");
        assert!(
            svg.contains(">0</text>") && svg.contains("Observer: judd-vos-1978"),
            "{svg}"
        );
    }
}

#[test]
fn spectral_channels_are_integrated_with_the_files_observer() {
    let dir = tempfile::tempdir().unwrap();
    let display = SimulatedDisplay::crt().unwrap();
    let drives = [[0.2, 0.7, 0.4], [0.9, 0.1, 0.3]];
    let spectra: Vec<Vec<f64>> = drives.iter().map(|d| display.spectrum(*d).into_values()).collect();
    let planes = Grid::one_nm()
        .wavelengths()
        .iter()
        .enumerate()
        .map(|(i, &nm)| (spectral_channel_name(nm), spectra.iter().map(|s| s[i] as f32).collect()))
        .collect();
    let path = dir.path().join("spectral.exr");
    write_exr(&path, (2, 1), planes, Some("judd-vos-1978"));
    let img = read_xyz_exr(&path, Observer::JuddVos).unwrap();
    assert!(img.source.contains("401 spectral channels"), "{}", img.source);
    for (d, got) in drives.iter().zip(&img.xyz) {
        let want = truth_xyz(&display, *d);
        for (g, w) in got.iter().zip(&want) {
            assert!((g / w - 1.0).abs() < 1e-5, "{got:?} vs {want:?}");
        }
    }
    let err = read_xyz_exr(&path, Observer::Cie1931).unwrap_err();
    assert!(
        err.contains("spectral.exr") && err.contains("judd-vos-1978") && err.contains("cie-1931"),
        "{err}"
    );
}

#[test]
fn stimulus_errors_name_the_file_and_what_is_wrong() {
    let dir = tempfile::tempdir().unwrap();
    let display = SimulatedDisplay::crt().unwrap();
    let profile_path = write_profile(dir.path(), &exact_profile(&display));
    let (image, _) = xyz_image(dir.path(), &display, None);
    let (img, prof) = (image.to_str().unwrap(), profile_path.to_str().unwrap());

    // A file with Y but neither X nor Z nor spectral channels.
    let partial = dir.path().join("partial.exr");
    write_exr(
        &partial,
        (2, 2),
        vec![("Y".into(), vec![1.0; 4]), ("paths".into(), vec![4.0; 4])],
        None,
    );
    let o = lightbooth(&["stimulus", partial.to_str().unwrap(), "--display", prof, "--bits", "8"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(err.contains("partial.exr") && err.contains("no channel X, Z"), "{err}");

    let o = lightbooth(&["stimulus", img, "--display", prof, "--bits", "9"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(err.contains("bit depth 9") && err.contains("8, 10, 12 or 16"), "{err}");

    let not_profile = dir.path().join("not_profile.json");
    std::fs::write(&not_profile, r#"{"id": 3, "profile": {"observer": "judd-vos-1978"}}"#).unwrap();
    let o = lightbooth(&[
        "stimulus",
        img,
        "--display",
        not_profile.to_str().unwrap(),
        "--bits",
        "8",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        err.contains("not_profile.json") && err.contains("not a display profile") && err.contains("`transfer`"),
        "{err}"
    );
    // Everything but the black level and the primaries: named by each kind's fields.
    let t = r#"{"gamma": 2.2, "levels": [0, 1], "measured": [0, 1], "rms_residual": 0}"#;
    std::fs::write(
        &not_profile,
        format!(
            r#"{{"observer": "cie-1931", "transfer": [{t}, {t}, {t}], "measurement_ids": [],
               "additivity": {{"white_xyz": [1, 1, 1], "sum_xyz": [1, 1, 1], "delta_e00": 0}}}}"#
        ),
    )
    .unwrap();
    let o = lightbooth(&[
        "stimulus",
        img,
        "--display",
        not_profile.to_str().unwrap(),
        "--bits",
        "8",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        err.contains("wavelength_nm") && err.contains("black_xyz") && err.contains("black_cd_m2"),
        "{err}"
    );

    // --gamut fail on an image with one out-of-gamut pixel: the count and the worst pixel.
    let conv = Converter::new(&exact_profile(&display)).unwrap();
    let sub = tempfile::tempdir().unwrap();
    let (bright, _) = xyz_image(sub.path(), &display, Some(conv.xyz([0.2, 1.3, 0.2])));
    let o = lightbooth(&[
        "stimulus",
        bright.to_str().unwrap(),
        "--display",
        prof,
        "--bits",
        "8",
        "--gamut",
        "fail",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(err.contains("1 of 12 colours") && err.contains("colour 11"), "{err}");
}

#[test]
fn display_resolution_on_cylinder_reports_every_requested_depth() {
    let dir = tempfile::tempdir().unwrap();
    let display = SimulatedDisplay::crt().unwrap();
    let profile_path = write_profile(dir.path(), &exact_profile(&display));
    let chart = dir.path().join("resolution.svg");
    let o = lightbooth(&[
        "display-resolution",
        concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cylinder.toml"),
        "--display",
        profile_path.to_str().unwrap(),
        "--codings",
        "nstep27,nstep81",
        "--bits",
        "6,8,10,12,16",
        "--samples",
        "256",
        "--json",
        "--chart",
        chart.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    let pair = &v["pairs"][0];
    assert_eq!(
        (pair["a"].as_str(), pair["b"].as_str()),
        (Some("nstep27"), Some("nstep81"))
    );
    let depths = pair["depths"].as_array().unwrap();
    let bits: Vec<u64> = depths.iter().map(|d| d["bits"].as_u64().unwrap()).collect();
    assert_eq!(bits, [6, 8, 10, 12, 16]);
    let targets = v["targets"].as_array().unwrap().len();
    assert_eq!(targets, 21);
    let true_de: Vec<f64> = pair["true_delta_e00"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    for d in depths {
        assert_eq!(d["colours"].as_u64(), Some(targets as u64));
        let (r, u, t) = (
            d["resolved"].as_u64().unwrap(),
            d["unresolved"].as_u64().unwrap(),
            d["to_resolve"].as_u64().unwrap(),
        );
        assert_eq!(r + u, t, "{d}");
    }
    // At 16 bits half a code is far below any rendering difference that
    // matters: every target with a difference above 0.01 is resolved, and
    // the display shows it within the 16-bit quantisation error.
    let d16 = &depths[4];
    let shown16: Vec<f64> = d16["shown_delta_e00"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    for (s, t) in shown16.iter().zip(&true_de) {
        if *t >= 0.01 {
            assert!(
                (s - t).abs() < 0.2 * t + 0.005,
                "16 bits: shown {s} for a true ΔE00 {t}"
            );
        }
    }
    // Against what the display could show (after the same gamut policy),
    // 16 bits loses almost nothing.
    let (shown, intended) = (
        d16["mean_shown_delta_e00"].as_f64().unwrap(),
        d16["mean_intended_delta_e00"].as_f64().unwrap(),
    );
    assert!(
        (shown - intended).abs() < 0.005,
        "16 bits: shown {shown}, intended {intended}"
    );
    let u6 = depths[0]["unresolved"].as_u64().unwrap();
    let u16 = d16["unresolved"].as_u64().unwrap();
    assert!(
        u16 <= u6,
        "more bits resolve no fewer targets: 6 bits {u6}, 16 bits {u16}"
    );
    let svg = std::fs::read_to_string(&chart).unwrap();
    assert!(svg.contains("<svg") && svg.contains("nstep27"), "chart");
}

/// The README's flow: the profile calibrated in the daemon's browser page is
/// read from the daemon's database while the daemon runs. Reading it must not
/// run the store's start-up recovery (which marks running work interrupted).
#[test]
fn a_profile_read_from_a_running_daemons_database_gives_the_same_codes_and_interrupts_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let display = SimulatedDisplay::crt().unwrap();
    let profile = exact_profile(&display);
    let profile_path = write_profile(dir.path(), &profile);
    let (image, _) = xyz_image(dir.path(), &display, None);
    let db = format!("sqlite://{}", dir.path().join("lab.sqlite").display());
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    let (id, running) = rt.block_on(async {
        let store = lightbooth::store::Store::open(&db).await.unwrap();
        let id = store
            .insert_display_profile("simulated CRT", "", &profile)
            .await
            .unwrap();
        let running = store
            .create_measurement(&lightbooth::store::NewMeasurement {
                booth: Default::default(),
                session_id: None,
                scene: None,
                target: None,
                samples: 5,
                settings_json: serde_json::json!({}),
                note: "the daemon is measuring this".into(),
            })
            .await
            .unwrap();
        store.mark_running(running, None).await.unwrap();
        (id, running)
    });
    let from_file = dir.path().join("file.png");
    let from_db = dir.path().join("db.png");
    let o = lightbooth(&[
        "stimulus",
        image.to_str().unwrap(),
        "--display",
        profile_path.to_str().unwrap(),
        "--bits",
        "10",
        "--out",
        from_file.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = lightbooth(&[
        "stimulus",
        image.to_str().unwrap(),
        "--display-db",
        &db,
        "--display-id",
        &id.to_string(),
        "--bits",
        "10",
        "--out",
        from_db.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(read_png16(&from_file), read_png16(&from_db));
    let state = rt.block_on(async {
        let store = lightbooth::store::Store::open_to_read(&db).await.unwrap();
        store.get_measurement(running).await.unwrap().unwrap().summary.state
    });
    assert_eq!(state, lightbooth::store::MeasurementState::Running);
    let o = lightbooth(&[
        "stimulus",
        image.to_str().unwrap(),
        "--display-db",
        &db,
        "--display-id",
        "99",
        "--bits",
        "8",
    ]);
    assert!(!o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("no display profile 99"), "{stderr}");
}

#[test]
fn stimulus_map_must_be_a_png_path_because_its_figure_goes_beside_it() {
    let o = lightbooth(&[
        "stimulus",
        "image.exr",
        "--display",
        "p.json",
        "--bits",
        "8",
        "--map",
        "map.svg",
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("is not a .png path") && err.contains(".svg"), "{err}");
}

/// An image with a layer per coding (`render --image-coding`), through
/// `stimulus` (issue 48): one report for the set and one PNG of codes per
/// coding; the report's ΔE00 against the reference as shown at 8 bits
/// matches the simulated CRT's own spectra for the PNGs' codes (the truth,
/// not the converter's matrices), and its ΔE00 as rendered matches the
/// renderer's own images.
#[test]
fn a_layered_image_is_converted_as_one_set_and_each_coding_is_shown_as_its_codes_say() {
    use lightbooth::export::image::write_camera_images;
    use lightbooth::render::camera::{render_camera_images, CameraSettings, Y};
    use lightbooth::render::{load_scene, Coding, RenderSettings};

    let dir = tempfile::tempdir().unwrap();
    let display = SimulatedDisplay::crt().unwrap();
    let profile = exact_profile(&display);
    let profile_path = write_profile(dir.path(), &profile);
    let scene = load_scene(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cylinder.toml"))).unwrap();
    let mut camera = scene.camera.clone().unwrap();
    (camera.width, camera.height) = (16, 12);
    let settings = CameraSettings {
        codings: vec![Coding::Rgb, Coding::NStep(3), Coding::Spectral],
        reference: None,
        se_every_coding: false,
        observer: Observer::JuddVos,
        transport: RenderSettings::default().transport(),
        seed: 4,
        min_spp: 8,
        first_sample: 0,
        max_spp: 8,
        target_relative_se: None,
        time_budget: None,
    };
    let images = render_camera_images(&scene, &camera, &settings, None, None).unwrap();
    let exr = dir.path().join("cyl.exr");
    write_camera_images(&images, &exr).unwrap();
    let report = dir.path().join("set.json");
    let out = dir.path().join("codes.png");
    let o = lightbooth(&[
        "stimulus",
        exr.to_str().unwrap(),
        "--display",
        profile_path.to_str().unwrap(),
        "--bits",
        "8",
        "--gamut",
        "scale",
        "--out",
        out.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(stdout.contains("3 codings, reference spectral"), "{stdout}");
    let r: Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    let set = &r["set"];
    assert_eq!(set["reference"], "spectral");
    assert_eq!(set["codings"].as_array().unwrap().len(), 3);
    let white = truth_xyz(&display, [1.0, 1.0, 1.0]);
    let shown_of = |coding: &str| -> Vec<[f64; 3]> {
        let (w, h, codes) = read_png16(&dir.path().join(format!("codes.{coding}.png")));
        assert_eq!((w, h), (16, 12));
        codes
            .iter()
            .map(|c| truth_xyz(&display, c.map(|v| f64::from(v >> 8) / 255.0)))
            .collect()
    };
    let reference = shown_of("spectral");
    for (i, coding) in ["rgb", "nstep3"].iter().enumerate() {
        let row = &set["codings"][i];
        assert_eq!(row["coding"], *coding);
        let shown = shown_of(coding);
        let truth = shown
            .iter()
            .zip(&reference)
            .map(|(a, b)| de00(white, *a, *b))
            .sum::<f64>()
            / shown.len() as f64;
        let reported = row["against_reference"]["shown"][0]["delta_e00"]["mean"]
            .as_f64()
            .unwrap();
        assert_eq!(row["against_reference"]["shown"][0]["output"], "8bit");
        println!("{coding}: shown at 8 bits {reported:.4}, the CRT's spectra {truth:.4}");
        assert!(
            (reported - truth).abs() < 0.02 + 0.01 * truth,
            "{coding}: {reported} against {truth}"
        );
        // As rendered: the renderer's own XYZ, the display's white.
        let xyz = |img: &lightbooth::render::camera::CameraImage, p: usize| -> [f64; 3] {
            let k = img.xyz_index();
            [
                img.plane(k)[p] as f64,
                img.plane(k + Y)[p] as f64,
                img.plane(k + 2)[p] as f64,
            ]
        };
        let (a, b) = (&images.images[i], &images.images[2]);
        let rendered = (0..a.samples.len())
            .map(|p| de00(white, xyz(a, p), xyz(b, p)))
            .sum::<f64>()
            / a.samples.len() as f64;
        let reported = row["against_reference"]["rendered"]["mean"].as_f64().unwrap();
        assert!(
            (reported - rendered).abs() < 1e-6 * rendered.max(1.0),
            "{coding}: {reported} against {rendered}"
        );
    }
    assert!(set["codings"][2]["against_reference"].is_null());
    // A map is for one image; the set's is refused, saying why.
    let o = lightbooth(&[
        "stimulus",
        exr.to_str().unwrap(),
        "--display",
        profile_path.to_str().unwrap(),
        "--bits",
        "8",
        "--map",
        dir.path().join("m.png").to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("a layer per coding (rgb, nstep3, spectral)"));
}
