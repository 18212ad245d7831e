//! Area lights against closed-form truth: the irradiance from a uniform
//! Lambertian rectangle (configuration factors), with light sampling alone
//! and with light and BSDF sampling combined by MIS.
//!
//! Monte Carlo tolerances are the stated percentage plus 4 reported standard
//! errors (seeds are fixed, so the outcome is deterministic).

use std::f64::consts::PI;
use std::path::PathBuf;

use glam::DVec3;
use lightbooth::colorimetry::{Cmf, KM_LM_PER_W};
use lightbooth::render::geometry::Shape;
use lightbooth::render::scene::{Emitter, Material, Primitive, Radiometer, Target};
use lightbooth::render::{render, Coding, RenderSettings, Scene};
use lightbooth::spectrum::{Grid, SpectralUnit, Spectrum};

/// Configuration factor from a differential area to a parallel rectangle
/// a × b at distance c, the element's normal through a corner (Howell, "A
/// Catalog of Radiation Heat Transfer Configuration Factors", B-3):
/// F = 1/(2π) [X/√(1+X²)·atan(Y/√(1+X²)) + Y/√(1+Y²)·atan(X/√(1+Y²))],
/// X = a/c, Y = b/c.
fn form_factor_parallel_corner(a: f64, b: f64, c: f64) -> f64 {
    let (x, y) = (a / c, b / c);
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * PI)
}

/// The configuration factor from a differential area at p with unit normal n
/// to a planar polygon, by the contour integral (Lambert; Sparrow 1963):
/// F = 1/(2π) Σᵢ γᵢ · n·(Rᵢ × Rᵢ₊₁)/|Rᵢ × Rᵢ₊₁|, Rᵢ = vᵢ − p, γᵢ the angle
/// between Rᵢ and Rᵢ₊₁ (vertices ordered counter-clockwise seen from p).
fn contour_form_factor(p: DVec3, n: DVec3, vertices: &[DVec3]) -> f64 {
    let mut sum = 0.0;
    for i in 0..vertices.len() {
        let (r1, r2) = (vertices[i] - p, vertices[(i + 1) % vertices.len()] - p);
        let c = r1.cross(r2);
        let gamma = r1.angle_between(r2);
        sum += gamma * n.dot(c) / c.length();
    }
    (sum / (2.0 * PI)).abs()
}

fn flat(unit: SpectralUnit, v: f64) -> Spectrum {
    Spectrum::constant(Grid::one_nm(), unit, v).unwrap()
}

/// Luminance of a flat spectral radiance `l` W/(sr·m²·nm): 683·Σ L ȳ Δλ.
fn luminance_of_flat(l: f64) -> f64 {
    let ybar = &Cmf::of(lightbooth::render::coding::OBSERVER).on_grid(&Grid::one_nm())[1];
    KM_LM_PER_W * l * ybar.iter().sum::<f64>()
}

/// A receiver quad (ρ flat) in the plane y = 0 and an emitting rectangle
/// (two triangles, emitting toward the receiver), seen by a radiometer with
/// a 0.01° field at the origin.
fn scene(rect: [DVec3; 4], radiance: f64, rho: f64, receiver_normal: DVec3) -> Scene {
    let (u, v) = if receiver_normal == DVec3::Y {
        (DVec3::X, DVec3::Z)
    } else {
        (DVec3::X, DVec3::Y)
    };
    let materials = vec![
        Material::lambertian("receiver", flat(SpectralUnit::Reflectance, rho)),
        Material::lambertian("black", flat(SpectralUnit::Reflectance, 0.0)),
    ];
    let mut primitives = vec![Primitive {
        shape: Shape::quad(-u * 0.05 - v * 0.05, u * 0.1, v * 0.1),
        material: 0,
        emitter: None,
    }];
    for tri in [[0, 1, 2], [0, 2, 3]] {
        primitives.push(Primitive {
            shape: Shape::triangle(rect[tri[0]], rect[tri[1]], rect[tri[2]]).unwrap(),
            material: 1,
            emitter: Some(0),
        });
    }
    Scene {
        name: "area light".into(),
        path: PathBuf::from("area_light.toml"),
        materials,
        primitives,
        solids: vec![],
        lights: vec![],
        emitters: vec![Emitter {
            name: "panel".into(),
            radiance: flat(SpectralUnit::SpectralRadiance, radiance),
            two_sided: false,
            rgb: None,
            spot: None,
        }],
        radiometer: Radiometer {
            position: receiver_normal * 0.2 + (u + v) * 0.02,
            field_deg: 0.01,
        },
        target_list: vec![Target {
            id: "receiver".into(),
            point: DVec3::ZERO,
        }],
        camera: None,
        files: vec![],
        cielab_white: None,
        bvh: Default::default(),
    }
}

fn settings(bounces: u32, samples: u64) -> RenderSettings {
    RenderSettings {
        codings: vec![Coding::Rgb, Coding::NStep(9), Coding::Spectral],
        samples,
        max_bounces: Some(bounces),
        russian_roulette_from: None,
        target_relative_se: None,
        ..RenderSettings::default()
    }
}

/// A receiver under a parallel emitting rectangle centred over it: the
/// irradiance is E = π·L·F with F = 4·F_corner(a/2, b/2, c) (Howell B-3, by
/// symmetry), so the receiver's luminance is ρ·E/π = ρ·F·Y_L. With 0
/// bounces only light samples count; with 3 bounces the bounce directions
/// that hit the panel share the estimate by MIS — both must give the truth
/// to 0.5 %.
#[test]
fn irradiance_from_a_parallel_rectangle_matches_the_configuration_factor() {
    let (a, b, c) = (0.3, 0.2, 0.25);
    let (radiance, rho) = (0.01, 0.7);
    // Ordered so that the normal (p1 − p0) × (p2 − p0) is −y (downward).
    let rect = [
        DVec3::new(-a / 2.0, c, -b / 2.0),
        DVec3::new(a / 2.0, c, -b / 2.0),
        DVec3::new(a / 2.0, c, b / 2.0),
        DVec3::new(-a / 2.0, c, b / 2.0),
    ];
    let n = (rect[1] - rect[0]).cross(rect[2] - rect[0]).normalize();
    assert!((n + DVec3::Y).length() < 1e-12, "emits toward the receiver: {n}");
    let s = scene(rect, radiance, rho, DVec3::Y);
    let f = 4.0 * form_factor_parallel_corner(a / 2.0, b / 2.0, c);
    // The contour integral is an independent route to the same factor.
    assert!((contour_form_factor(DVec3::ZERO, DVec3::Y, &rect) / f - 1.0).abs() < 1e-12);
    let truth = rho * f * luminance_of_flat(radiance);
    for bounces in [0, 3] {
        let r = render(&s, &settings(bounces, 1 << 16), None, None).unwrap();
        for (coding, c) in &r.targets[0].codings {
            let tol = 0.005 * truth + 4.0 * c.luminance_se_cd_m2;
            assert!(
                (c.luminance_cd_m2 - truth).abs() < tol,
                "{coding}, {bounces} bounces: {} ± {} vs {truth}",
                c.luminance_cd_m2,
                c.luminance_se_cd_m2
            );
            assert!(
                c.luminance_se_cd_m2 < 0.002 * truth,
                "{coding}: SE {}",
                c.luminance_se_cd_m2
            );
        }
    }
}

/// A receiver facing a perpendicular rectangle (a wall beside it): the
/// configuration factor from Howell B-2's closed form, checked against the
/// contour integral (Sparrow 1963), and the render against it.
#[test]
fn irradiance_from_a_perpendicular_rectangle_matches_the_configuration_factor() {
    let (a, b, c) = (0.2, 0.15, 0.1);
    let (radiance, rho) = (0.02, 0.5);
    // The receiver at the origin faces +z; the rectangle stands in the plane
    // x = c, spanning y ∈ [−a/2, a/2] along the line where the two planes
    // meet and z ∈ [0, b] away from the receiver's plane, emitting toward −x.
    let rect = [
        DVec3::new(c, -a / 2.0, 0.0),
        DVec3::new(c, -a / 2.0, b),
        DVec3::new(c, a / 2.0, b),
        DVec3::new(c, a / 2.0, 0.0),
    ];
    let n = (rect[1] - rect[0]).cross(rect[2] - rect[0]).normalize();
    assert!((n + DVec3::X).length() < 1e-12, "emits toward the receiver: {n}");
    // Howell B-2 (element in a plane perpendicular to the rectangle, opposite
    // a corner of its edge on the line where the planes meet): for a
    // rectangle of height h (away from the element's plane) and width w
    // (along the line) at distance c, X = h/w, Y = c/w,
    // F = 1/(2π) [atan(1/Y) − Y/√(X² + Y²)·atan(1/√(X² + Y²))].
    // The rectangle here is two such halves of width a/2.
    let half = a / 2.0;
    let (x, y) = (b / half, c / half);
    let r = (x * x + y * y).sqrt();
    let f = 2.0 * ((1.0 / y).atan() - y / r * (1.0 / r).atan()) / (2.0 * PI);
    let by_contour = contour_form_factor(DVec3::ZERO, DVec3::Z, &rect);
    assert!(
        (by_contour / f - 1.0).abs() < 1e-9,
        "contour {by_contour} vs Howell {f}"
    );
    let s = scene(rect, radiance, rho, DVec3::Z);
    let truth = rho * f * luminance_of_flat(radiance);
    for bounces in [0, 2] {
        let r = render(&s, &settings(bounces, 1 << 16), None, None).unwrap();
        for (coding, cr) in &r.targets[0].codings {
            let tol = 0.005 * truth + 4.0 * cr.luminance_se_cd_m2;
            assert!(
                (cr.luminance_cd_m2 - truth).abs() < tol,
                "{coding}, {bounces} bounces: {} ± {} vs {truth}",
                cr.luminance_cd_m2,
                cr.luminance_se_cd_m2
            );
        }
    }
}
