//! The measuring camera against the radiometer, and its files read back by
//! independent readers (the `exr` crate's reader, the `matfile` crate, and
//! an ENVI header parse here).

use std::collections::HashMap;
use std::path::Path;

use glam::DVec3;
use lightbooth::export::image::{spectral_channel_name, write_camera_image, EMISSIVE_UNITS, SPECTRAL_UNITS};
use lightbooth::render::camera::{render_camera_image, CameraImage, CameraSettings, Pinhole, Y};
use lightbooth::render::integrator::{radiometer_batch, Prepared, Transport};
use lightbooth::render::scene::Camera;
use lightbooth::render::{load_scene, ChannelLayout, Coding, LightSampling, SamplerKind, Scene};

fn cylinder() -> Scene {
    load_scene(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cylinder.toml"))).unwrap()
}

const TRANSPORT: Transport = Transport {
    max_bounces: Some(5),
    russian_roulette_from: None,
    light_sampler: LightSampling::Power,
};

/// The radiometer's field mean per channel and its standard error, from 16
/// independent batches (independent sampler) of `per_batch` paths.
fn radiometer(scene: &Scene, layout: &ChannelLayout, target: usize, per_batch: u64) -> (Vec<f64>, Vec<f64>) {
    let prep = Prepared::new(scene, layout.clone()).unwrap();
    let n = layout.entries()[0].1.len();
    let batches: Vec<Vec<f64>> = (0..16u64)
        .map(|b| {
            let s = radiometer_batch(
                &prep,
                &TRANSPORT,
                SamplerKind::Independent,
                target,
                7,
                b * per_batch..(b + 1) * per_batch,
            );
            s.channels[..n].iter().map(|v| v / per_batch as f64).collect()
        })
        .collect();
    let mean: Vec<f64> = (0..n)
        .map(|k| batches.iter().map(|b| b[k]).sum::<f64>() / 16.0)
        .collect();
    let se = (0..n)
        .map(|k| (batches.iter().map(|b| (b[k] - mean[k]).powi(2)).sum::<f64>() / 15.0 / 16.0).sqrt())
        .collect();
    (mean, se)
}

/// The camera at the radiometer's position aimed at `target`, 2° across.
fn camera_at_radiometer(scene: &Scene, target: usize, side: u32) -> Camera {
    let position = scene.radiometer.position;
    let point = scene.target_list[target].point;
    let axis = (point - position).normalize();
    let up = if axis.y.abs() > 0.9 { DVec3::X } else { DVec3::Y };
    Camera {
        position,
        look_at: point,
        up,
        fov_deg: 2.0,
        width: side,
        height: side,
    }
}

/// A pixel's spectrum and a radiometer target's agree: on CYLINDER, the mean
/// of the camera pixels whose centres lie inside the radiometer's 1° field
/// equals the radiometer's field mean in every nstep9 band within 3
/// combined standard errors (and over all bands, χ² below its 99.9 % point).
#[test]
fn camera_pixels_inside_the_field_match_the_radiometer_on_cylinder() {
    let scene = cylinder();
    let coding = Coding::NStep(9);
    let layout = ChannelLayout::new(&[coding]);
    for id in ["h02", "h10"] {
        let t = scene.target_list.iter().position(|t| t.id == id).unwrap();
        let camera = camera_at_radiometer(&scene, t, 41);
        let settings = CameraSettings {
            codings: vec![coding],
            reference: None,
            se_every_coding: false,
            observer: layout.observer(),
            transport: TRANSPORT,
            seed: 3,
            min_spp: 32,
            first_sample: 0,
            max_spp: 32,
            target_relative_se: None,
            time_budget: None,
        };
        let img = render_camera_image(&scene, &camera, &settings, None, None).unwrap();
        let pinhole = Pinhole::new(&camera);
        let half_field = scene.radiometer.field_deg / 2.0;
        let inside: Vec<(usize, usize)> = (0..41)
            .flat_map(|y| (0..41).map(move |x| (x, y)))
            .filter(|&(x, y)| pinhole.off_axis_deg(x, y) <= half_field)
            .collect();
        // A 1° disc in 2°/41 px pixels: π·(20.5/2)²/… ≈ 330 pixels.
        assert!((300..360).contains(&inside.len()), "{}", inside.len());
        let k_count = inside.len() as f64;
        let (rad, rad_se) = radiometer(&scene, &layout, t, 2048);
        let mut chi2 = 0.0;
        for band in 0..9 {
            let cam = inside.iter().map(|&(x, y)| img.mean(x, y, band)).sum::<f64>() / k_count;
            let cam_se = inside
                .iter()
                .map(|&(x, y)| img.standard_error(x, y, band).powi(2))
                .sum::<f64>()
                .sqrt()
                / k_count;
            let z = (cam - rad[band]) / (cam_se.powi(2) + rad_se[band].powi(2)).sqrt();
            println!(
                "{id} band {band}: camera {cam:.6e} ± {cam_se:.2e}, radiometer {:.6e} ± {:.2e}, z {z:+.2}",
                rad[band], rad_se[band]
            );
            assert!(rad[band] > 0.0 && cam_se > 0.0);
            assert!(z.abs() < 3.0, "{id} band {band}: z = {z}");
            chi2 += z * z;
        }
        // χ²(9) 99.9 % point: 27.88.
        assert!(chi2 < 27.88, "{id}: χ² = {chi2}");
    }
}

fn tiny_image(coding: Coding, target_se: Option<f64>) -> CameraImage {
    let scene = cylinder();
    let mut camera = scene.camera.clone().unwrap();
    camera.width = 6;
    camera.height = 4;
    let settings = CameraSettings {
        codings: vec![coding],
        reference: None,
        se_every_coding: false,
        observer: ChannelLayout::new(&[coding]).observer(),
        transport: TRANSPORT,
        seed: 1,
        min_spp: 4,
        first_sample: 0,
        max_spp: 16,
        target_relative_se: target_se,
        time_budget: None,
    };
    render_camera_image(&scene, &camera, &settings, None, None).unwrap()
}

/// Regression: an RGB (or sRGB) image's units attribute was written with a
/// Latin-1 `²`, which the ASCII check refuses, so every RGB image's
/// `GET /api/images/{id}/image.exr` answered 500 (Schemathesis found it).
#[test]
fn rgb_image_exr_units_are_ascii() {
    for coding in [Coding::Rgb, Coding::Srgb] {
        let img = tiny_image(coding, Some(0.5));
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("rgb.exr");
        write_camera_image(&img, &path).unwrap_or_else(|e| panic!("{coding}: {e}"));
        let read = exr::prelude::read_all_flat_layers_from_file(&path).unwrap();
        let layer = &read.layer_data[0];
        match layer
            .attributes
            .other
            .get(&exr::prelude::Text::from("lightbooth.units.RGB"))
        {
            Some(exr::meta::attribute::AttributeValue::Text(t)) => {
                assert_eq!(t.to_string(), format!("linear {coding} with Y in cd/m^2"))
            }
            other => panic!("{coding}: lightbooth.units.RGB is {other:?}"),
        }
        let names: Vec<String> = layer.channel_data.list.iter().map(|c| c.name.to_string()).collect();
        for channel in ["R", "G", "B", "SE.R", "Y", "paths"] {
            assert!(
                names.iter().any(|n| n == channel),
                "{coding}: no channel {channel} in {names:?}"
            );
        }
    }
}

/// The EXR read back by the `exr` crate's reader: the spectral channel names
/// of Fichet et al. 2021, X/Y/Z, the SE layer, the units attributes, and
/// every value equal to the in-memory image.
#[test]
fn exr_reads_back_with_names_units_and_values() {
    let img = tiny_image(Coding::Spectral, Some(0.5));
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cyl.exr");
    write_camera_image(&img, &path).unwrap();
    let read = exr::prelude::read_all_flat_layers_from_file(&path).unwrap();
    assert_eq!(read.layer_data.len(), 1);
    let layer = &read.layer_data[0];
    assert_eq!((layer.size.0, layer.size.1), (6, 4));
    let attr = |k: &str| match layer.attributes.other.get(&exr::prelude::Text::from(k)) {
        Some(exr::meta::attribute::AttributeValue::Text(t)) => t.to_string(),
        other => panic!("{k}: {other:?}"),
    };
    assert_eq!(attr("spectralLayoutVersion"), "1.0");
    assert_eq!(attr("emissiveUnits"), EMISSIVE_UNITS);
    assert_eq!(attr("lightbooth.units.spectral"), SPECTRAL_UNITS);
    assert_eq!(attr("lightbooth.coding"), "spectral");
    let channels: HashMap<String, Vec<f32>> = layer
        .channel_data
        .list
        .iter()
        .map(|c| match &c.sample_data {
            exr::prelude::FlatSamples::F32(v) => (c.name.to_string(), v.clone()),
            other => panic!("{}: not f32: {other:?}", c.name),
        })
        .collect();
    // 401 spectral + 6 colorimetric, each with its SE, and the path counts.
    assert_eq!(channels.len(), 2 * (401 + 6) + 1);
    let name_550 = spectral_channel_name(550.0);
    assert_eq!(name_550, "S0.550,000000nm");
    let k550 = 550 - 380;
    for (name, k) in [
        (name_550.clone(), k550),
        ("S0.380,000000nm".to_string(), 0),
        ("S0.780,000000nm".to_string(), 400),
        ("Y".to_string(), 401 + Y),
        ("X".to_string(), 401),
        ("S".to_string(), 401 + 5),
    ] {
        let got = &channels[&name];
        let se = &channels[&format!("SE.{name}")];
        assert_eq!(got, &img.plane(k), "{name}");
        // NaN-free SE equal to the in-memory one (bitwise).
        assert_eq!(
            se.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            img.se_plane(k).iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            "SE.{name}"
        );
    }
    assert!(channels["Y"].iter().any(|&v| v > 0.0));
    // Pixel (x, y) sits at index y·width + x, rows top to bottom.
    assert_eq!(channels["Y"][6 * 2 + 1], img.mean(1, 2, 401 + Y) as f32);
    assert_eq!(
        channels["paths"],
        img.samples.iter().map(|&n| n as f32).collect::<Vec<_>>()
    );
}

fn parse_envi_header(text: &str) -> HashMap<String, String> {
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("ENVI"));
    lines
        .map(|l| {
            let (k, v) = l.split_once(" = ").unwrap_or_else(|| panic!("not `key = value`: {l}"));
            (k.to_string(), v.trim_matches(|c| c == '{' || c == '}').to_string())
        })
        .collect()
}

/// ENVI: the header parses back (size, float32 little-endian BSQ,
/// wavelengths) and the raw file holds band k at offset k·W·H·4.
#[test]
fn envi_header_and_raw_bsq_parse_back() {
    let img = tiny_image(Coding::NStep(9), None);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cyl.bsq");
    let written = write_camera_image(&img, &path).unwrap();
    assert_eq!(written.len(), 4);
    let hdr = parse_envi_header(&std::fs::read_to_string(dir.path().join("cyl.hdr")).unwrap());
    assert_eq!(hdr["samples"], "6");
    assert_eq!(hdr["lines"], "4");
    assert_eq!(hdr["bands"], "9");
    assert_eq!(hdr["data type"], "4");
    assert_eq!(hdr["byte order"], "0");
    assert_eq!(hdr["interleave"], "bsq");
    assert_eq!(hdr["wavelength units"], "nm");
    let wl: Vec<f64> = hdr["wavelength"]
        .split(',')
        .map(|v| v.trim().parse().unwrap())
        .collect();
    assert_eq!(wl.len(), 9);
    // nstep9 on the 81-sample grid: 9 bands of 9 samples (45 nm wide), the
    // first centred at 380 + 4·5 = 400 nm.
    assert_eq!(wl[0], 400.0);
    assert_eq!(wl[8], 760.0);
    let raw = std::fs::read(&path).unwrap();
    assert_eq!(raw.len(), 6 * 4 * 9 * 4);
    let band3: Vec<f32> = raw[3 * 24 * 4..4 * 24 * 4]
        .chunks(4)
        .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
        .collect();
    assert_eq!(band3, img.plane(3));
    assert!(dir.path().join("cyl_se.hdr").exists());
    assert_eq!(
        std::fs::metadata(dir.path().join("cyl_se.bsq")).unwrap().len(),
        raw.len() as u64
    );
}

/// MAT: read back by the `matfile` crate: `radiance` is H × W × N single in
/// MATLAB's column-major order, with `wavelength_nm` and `units`.
#[test]
fn mat_file_holds_the_cube_with_wavelengths_and_units() {
    let img = tiny_image(Coding::NStep(9), None);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cyl.mat");
    write_camera_image(&img, &path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let mat = matfile::MatFile::parse(bytes.as_slice()).unwrap();
    let cube = mat.find_by_name("radiance").unwrap();
    assert_eq!(cube.size(), &vec![4, 6, 9]);
    let matfile::NumericData::Single { real, .. } = cube.data() else {
        panic!("radiance is not single")
    };
    // Element (row 2, column 1, band 3) at 2 + 4·1 + 24·3.
    assert_eq!(real[2 + 4 + 24 * 3], img.mean(1, 2, 3) as f32);
    let wl = mat.find_by_name("wavelength_nm").unwrap();
    assert_eq!(wl.size(), &vec![9, 1]);
    // `units` is a char array (the `matfile` crate reads numeric arrays
    // only): its name and UTF-16 text are in the file.
    let utf16: Vec<u8> = SPECTRAL_UNITS.encode_utf16().flat_map(|u| u.to_le_bytes()).collect();
    assert!(bytes.windows(utf16.len()).any(|w| w == utf16.as_slice()));
    assert!(bytes.windows(5).any(|w| w == b"units"));
    assert_eq!(mat.find_by_name("XYZ").unwrap().size(), &vec![4, 6, 3]);
}

/// With an SE target the render stops once every pixel's SE(Y) meets it,
/// and each pixel's estimate does: checked on the stored image.
#[test]
fn progressive_render_stops_at_the_se_target() {
    let img = tiny_image(Coding::Srgb, Some(0.2));
    let mean_y = (0..4)
        .flat_map(|y| (0..6).map(move |x| (x, y)))
        .map(|(x, y)| img.mean(x, y, 3 + Y))
        .sum::<f64>()
        / 24.0;
    for y in 0..4 {
        for x in 0..6 {
            let n = img.samples[y * 6 + x];
            let (v, se) = (img.mean(x, y, 3 + Y), img.standard_error(x, y, 3 + Y));
            assert!(
                n == 16 || se <= 0.2 * v.abs().max(0.01 * mean_y) * 1.0001,
                "{x},{y}: {v} ± {se}, n {n}"
            );
        }
    }
    assert!(img.samples.iter().all(|&n| (4..=16).contains(&n)));
}
