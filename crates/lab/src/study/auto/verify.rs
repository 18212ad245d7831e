//! The chosen settings checked: the reference render, and every coding's
//! result at the chosen settings against it, target by target.

use super::*;

/// The converged `spectral` answer to verify against: the `spectral` coding
/// alone, `choice.reference_bounces` bounces (the bounce tail 8× below the
/// choice's), a
/// different seed from the choice (independent noise), and a relative SE goal
/// of a quarter of the choice's, so the reference's own noise adds ≤ 3 % to
/// the comparison's in quadrature.
pub fn reference_render(
    scene: &Scene,
    choice: &AutoChoice,
    cancel: Option<&CancellationToken>,
) -> Result<RenderResult, AutoError> {
    let goal = choice.sample_choice.goal_relative_se / 4.0;
    Ok(render(
        scene,
        &RenderSettings {
            codings: vec![Coding::Spectral],
            samples: PILOT_SAMPLES,
            max_bounces: Some(choice.reference_bounces),
            russian_roulette_from: None,
            seed: choice.seed.wrapping_add(1_000_003),
            target_relative_se: Some(goal),
            max_samples: 1 << 24,
            ..RenderSettings::default()
        },
        None,
        cancel,
    )?)
}

/// The choice rendered and compared with the converged reference.
#[derive(Clone, Debug, Serialize)]
pub struct Verification {
    /// The CIELAB white: the brightest target of the reference (for a scene
    /// with one target, that target).
    pub white_target: String,
    pub rms_rel: f64,
    pub mean_de00: f64,
    pub max_de00: f64,
    /// Wall time of the choice's render.
    pub wall_seconds: f64,
    pub reference_wall_seconds: f64,
    /// Largest relative SE of Y of the choice's render and of the reference.
    pub relative_se: f64,
    pub reference_relative_se: f64,
    /// The rms_rel that noise alone gives: sqrt(mean over targets of
    /// (SE_choice² + SE_ref²) / Y²).
    pub noise_rms_rel: f64,
    /// rms_rel ≤ tolerance and max ΔE00 ≤ tolerance.
    pub meets: bool,
    pub points: Vec<PointDifference>,
}

/// Compares a render of one coding with the reference, target by target.
pub(super) fn compare_with_reference(
    result: &RenderResult,
    reference: &RenderResult,
) -> Result<(String, Vec<PointDifference>, f64), AutoError> {
    fn spectral(t: &lightbooth_render::TargetResult) -> Result<&lightbooth_render::CodingResult, AutoError> {
        t.coding("spectral")
            .ok_or_else(|| AutoError::Scene("a reference without the spectral coding".into()))
    }
    let mut white = (String::new(), Xyz::new(0.0, 0.0, 0.0));
    for t in &reference.targets {
        let c = spectral(t)?;
        if c.luminance_cd_m2 > white.1.y {
            white = (t.id.clone(), Xyz::from_array(c.xyz));
        }
    }
    let mut points = Vec::new();
    let mut noise2 = 0.0;
    for t in &result.targets {
        let r = reference
            .target(&t.id)
            .ok_or_else(|| AutoError::Scene(format!("target `{}` missing from the reference", t.id)))?;
        let (rc, c) = (spectral(r)?, &t.codings[0].1);
        points.push(compare_point(
            Xyz::from_array(rc.xyz),
            Xyz::from_array(c.xyz),
            white.1,
            OBSERVER,
        ));
        noise2 += (c.luminance_se_cd_m2.powi(2) + rc.luminance_se_cd_m2.powi(2)) / rc.luminance_cd_m2.powi(2);
    }
    if points.is_empty() {
        return Err(AutoError::Scene("no targets to compare".into()));
    }
    let noise = (noise2 / points.len() as f64).sqrt();
    Ok((white.0, points, noise))
}

/// Renders the choice and compares it with `reference` (from
/// [`reference_render`], or any converged `spectral` render of the scene).
pub fn verify(
    scene: &Scene,
    choice: &AutoChoice,
    reference: &RenderResult,
    cancel: Option<&CancellationToken>,
) -> Result<Verification, AutoError> {
    let r = render(scene, &choice.settings(), None, cancel)?;
    let (white_target, points, noise_rms_rel) = compare_with_reference(&r, reference)?;
    let s = summarize(&points);
    let max_de00 = points.iter().map(|p| p.de00).fold(0.0, f64::max);
    Ok(Verification {
        white_target,
        rms_rel: s.rms_rel,
        mean_de00: s.mean_de00,
        max_de00,
        wall_seconds: r.wall_seconds,
        reference_wall_seconds: reference.wall_seconds,
        relative_se: r.max_relative_se(),
        reference_relative_se: reference.max_relative_se(),
        noise_rms_rel,
        meets: s.rms_rel <= choice.tolerance.rms_rel && max_de00 <= choice.tolerance.de00,
        points,
    })
}
