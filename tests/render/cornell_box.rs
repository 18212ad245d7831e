//! The shipped Cornell box (`scenes/cornell_box.toml`) against what is
//! known about it independently: the light's published spectrum, the
//! geometry (the ceiling has no direct light), determinism, and standard
//! errors that mean what they say.

use std::path::Path;

use lightbooth::colorimetry::{Cmf, KM_LM_PER_W};
use lightbooth::render::{load_scene, render, Coding, RenderResult, RenderSettings, Scene};
use lightbooth::spectrum::Grid;

fn cornell() -> Scene {
    load_scene(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell_box.toml")).unwrap()
}

fn settings(codings: &[Coding], samples: u64) -> RenderSettings {
    RenderSettings {
        codings: codings.to_vec(),
        samples,
        target_relative_se: None,
        ..RenderSettings::default()
    }
}

const TARGETS: [&str; 9] = [
    "back_wall",
    "floor_front",
    "red_wall",
    "green_wall",
    "ceiling",
    "short_top",
    "short_front",
    "tall_front",
    "light",
];

#[test]
fn the_cornell_box_has_the_sheets_nine_targets_and_one_area_light() {
    let scene = cornell();
    assert_eq!(scene.targets(), TARGETS);
    assert_eq!(scene.emitters.len(), 1);
    // 5 walls × 2 + 2 blocks × 5 faces × 2 triangles + the light's 2.
    assert_eq!(scene.primitives.len(), 10 + 20 + 2);
    assert_eq!(scene.primitives.iter().filter(|p| p.emitter.is_some()).count(), 2);
    // Millimetres in the file, metres inside: the camera 0.8 m in front.
    assert!((scene.radiometer.position.z + 0.8).abs() < 1e-12);
}

/// The `light` target sees the panel and nothing else (1° field, 11 mm wide
/// on a 130 × 105 mm panel; the panel reflects nothing), so its luminance
/// is the emission itself: 683 lm/W · Σ L(λ)·ȳ(λ)·Δλ, with L the published
/// knots (400: 0, 500: 8, 600: 15.6, 700: 18.4 W/(sr·m²·nm)) interpolated
/// linearly and held outside 400–700 nm, summed here at 1 nm with the
/// Judd–Vos ȳ. Exact up to f32 channel rounding, with zero standard error.
#[test]
fn the_light_target_is_the_published_emission_exactly() {
    let scene = cornell();
    let knots = [(400.0, 0.0), (500.0, 8.0), (600.0, 15.6), (700.0, 18.4)];
    let radiance = |nm: f64| -> f64 {
        if nm <= 400.0 {
            return 0.0;
        }
        if nm >= 700.0 {
            return 18.4;
        }
        let i = knots.iter().rposition(|k| k.0 <= nm).unwrap();
        let ((x0, y0), (x1, y1)) = (knots[i], knots[i + 1]);
        y0 + (y1 - y0) * (nm - x0) / (x1 - x0)
    };
    let grid = Grid::one_nm();
    let ybar = &Cmf::of(lightbooth::render::coding::OBSERVER).on_grid(&grid)[1];
    let truth: f64 = KM_LM_PER_W
        * grid
            .wavelengths()
            .iter()
            .zip(ybar)
            .map(|(nm, y)| radiance(*nm) * y)
            .sum::<f64>();
    let s = RenderSettings {
        targets: Some(vec!["light".into()]),
        ..settings(&[Coding::Spectral, Coding::Rgb, Coding::Srgb], 4096)
    };
    let r = render(&scene, &s, None, None).unwrap();
    for (coding, c) in &r.targets[0].codings {
        assert!(
            (c.luminance_cd_m2 / truth - 1.0).abs() < 2e-6,
            "{coding}: {} vs {truth}",
            c.luminance_cd_m2
        );
        assert_eq!(
            c.luminance_se_cd_m2, 0.0,
            "{coding}: the light's own radiance has no noise"
        );
    }
}

/// The light emits downward only and sits 0.1 mm below the ceiling, so the
/// ceiling gets no direct light; the short block's front faces −z while the
/// light lies behind its plane (z ≥ 227 mm against the face's 65–114 mm),
/// so neither does it. With 0 bounces their radiance is exactly 0, with
/// bounces they are lit by interreflection alone. Every other target sees
/// the light directly.
#[test]
fn the_ceiling_is_lit_by_interreflection_only() {
    let scene = cornell();
    let direct = render(
        &scene,
        &RenderSettings {
            max_bounces: Some(0),
            ..settings(&[Coding::Spectral], 4096)
        },
        None,
        None,
    )
    .unwrap();
    for t in &direct.targets {
        let y = t.codings[0].1.luminance_cd_m2;
        if t.id == "ceiling" || t.id == "short_front" {
            assert_eq!(y, 0.0, "{} sees no direct light", t.id);
        } else {
            assert!(y > 0.0, "{}: {y}", t.id);
        }
    }
    let all = render(&scene, &settings(&[Coding::Spectral], 4096), None, None).unwrap();
    for id in ["ceiling", "short_front"] {
        assert!(all.target(id).unwrap().codings[0].1.luminance_cd_m2 > 0.0, "{id}");
    }
    // The red wall is redder than the white back wall, the green wall greener.
    let xy = |id: &str| {
        let c = &all.target(id).unwrap().codings[0].1;
        (c.x, c.y)
    };
    assert!(xy("red_wall").0 > xy("back_wall").0 + 0.05);
    assert!(xy("green_wall").1 > xy("back_wall").1 + 0.05);
}

/// Every coding renders every target, and a fixed seed gives bit-identical
/// results on 1 and 2 threads (meshes, the area light and MIS included).
#[test]
fn every_coding_renders_every_target_bit_identically_on_one_and_two_threads() {
    let scene = cornell();
    let codings = [
        Coding::Rgb,
        Coding::Srgb,
        Coding::NStep(3),
        Coding::NStep(9),
        Coding::NStep(81),
        Coding::Spectral,
    ];
    let base = settings(&codings, 2048);
    let one = render(
        &scene,
        &RenderSettings {
            threads: Some(1),
            ..base.clone()
        },
        None,
        None,
    )
    .unwrap();
    let two = render(
        &scene,
        &RenderSettings {
            threads: Some(2),
            ..base
        },
        None,
        None,
    )
    .unwrap();
    let json = |r: &RenderResult| serde_json::to_string(&r.targets).unwrap();
    assert_eq!(json(&one), json(&two));
    for t in &one.targets {
        assert_eq!(t.codings.len(), codings.len());
        for (coding, c) in &t.codings {
            assert!(
                c.luminance_cd_m2.is_finite() && c.luminance_cd_m2 > 0.0,
                "{} {coding}",
                t.id
            );
        }
    }
}

/// Honest standard errors with the new primitives and the area light: over
/// 24 seeds × 8 targets, z = (Y − Y_ref)/√(SE² + SE_ref²) against a render
/// with 64 × the paths and another seed has mean ≈ 0 and SD ≈ 1 (the
/// replicate SE has 15 degrees of freedom, so SD(z) ≈ √(15/13) ≈ 1.07).
#[test]
fn cornell_box_standard_errors_are_honest() {
    let scene = cornell();
    let targets: Vec<String> = TARGETS
        .iter()
        .filter(|t| **t != "light")
        .map(|t| t.to_string())
        .collect();
    let base = RenderSettings {
        targets: Some(targets.clone()),
        ..settings(&[Coding::Spectral], 1024)
    };
    let reference = render(
        &scene,
        &RenderSettings {
            samples: 64 * 1024,
            seed: 0xc0ffee,
            ..base.clone()
        },
        None,
        None,
    )
    .unwrap();
    let mut z = Vec::new();
    for seed in 0..24u64 {
        let r = render(
            &scene,
            &RenderSettings {
                seed: 1000 + seed,
                ..base.clone()
            },
            None,
            None,
        )
        .unwrap();
        for (t, rt) in r.targets.iter().zip(&reference.targets) {
            let (c, cr) = (&t.codings[0].1, &rt.codings[0].1);
            z.push(
                (c.luminance_cd_m2 - cr.luminance_cd_m2)
                    / (c.luminance_se_cd_m2.powi(2) + cr.luminance_se_cd_m2.powi(2)).sqrt(),
            );
        }
    }
    let n = z.len() as f64;
    let mean = z.iter().sum::<f64>() / n;
    let sd = (z.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    // For 192 z's, the SE of the mean is ≈ 0.075 and of the SD ≈ 0.055.
    assert!(mean.abs() < 0.3, "mean z {mean} (z: {z:?})");
    assert!((0.8..1.35).contains(&sd), "SD of z {sd} (z: {z:?})");
}
