//! The scene's light sources as the file states them: point luminaires
//! (`[[light]]`, from an IES file or a plain `intensity_cd` with an
//! optional cone) and the emission of area lights (`emission = { … }` on a
//! `[[polygon]]` or `[[mesh]]`).
//!
//! Point-luminaire spectra are normalised to 1 cd: 683 lm/W · Σ S(λ)·V(λ)·1 nm
//! = 1, so the luminaire's candela (`intensity_cd`, an IES file's table)
//! hold. An emission given as `luminance_cd_m2 = L` is normalised the same
//! way to 683 · Σ L(λ)·V(λ)·1 nm = L; `radiance` is taken as it is.
//!
//! V(λ) is the CIE 1924 photopic function, tabulated as CIE 1931's ȳ: the
//! function that defines the candela, the lumen and the cd/m² (CIE S 017,
//! ISO 23539), whatever observer the analysis uses (the renderer's XYZ of a
//! target are in the analysis observer, Judd–Vos by default; a lamp's
//! candela are not).

use glam::DVec3;

use super::file::{EmissionFile, LightFile};
use super::spectra::luminous_1nm;
use super::{positive, unit, Emitter, LightDistribution, Loader, PointLight, SceneError};
use crate::ies::IesDistribution;
use crate::input_file::{read_text, unquoted};
use lightbooth_science::spectrum::{Grid, SpectralUnit, Spectrum};

pub(super) fn load_light(l: &mut Loader, lf: &LightFile, i: usize) -> Result<PointLight, SceneError> {
    let key = |k: &str| format!("light[{i}].{k}");
    let stray = |k: &str, present: bool, why: &str| {
        if present {
            Err(l.err(key(k), why.to_string()))
        } else {
            Ok(())
        }
    };
    let (distribution, intensity_scale) = match (&lf.ies, lf.intensity_cd) {
        (Some(_), Some(_)) | (None, None) => {
            return Err(l.err(
                key("ies"),
                "give exactly one of `ies` (an IES LM-63 file) and `intensity_cd` (a plain luminaire)",
            ))
        }
        (Some(ies), None) => {
            stray(
                "cone_deg",
                lf.cone_deg.is_some(),
                "only used with `intensity_cd`: the IES file gives the distribution",
            )?;
            stray(
                "falloff_deg",
                lf.falloff_deg.is_some(),
                "only used with `intensity_cd`: the IES file gives the distribution",
            )?;
            if lf.aim.is_none() {
                return Err(l.err(key("aim"), "an IES luminaire needs `aim` (the direction of γ = 0)"));
            }
            let ies_path = l.dir.join(ies);
            let text = read_text(&ies_path).map_err(|e| l.err(key("ies"), e.to_string()))?;
            let table = IesDistribution::parse(&text, &ies_path.display().to_string()).map_err(|e| {
                if l.quoting.may_quote(&ies_path) {
                    l.err(key("ies"), e.to_string())
                } else {
                    let at = e.line.map(|n| format!(":{n}")).unwrap_or_default();
                    l.err(
                        key("ies"),
                        format!("{}{at}: {}", e.file, unquoted("not a usable IES LM-63 file")),
                    )
                }
            })?;
            l.files.push(ies_path);
            if !table.is_rotationally_symmetric() && lf.c0.is_none() {
                return Err(l.err(
                    key("c0"),
                    "the IES table is not rotationally symmetric: give the C = 0 direction",
                ));
            }
            let scale = positive(lf.intensity_scale.unwrap_or(1.0), l, &key("intensity_scale"))?;
            (LightDistribution::Ies(table), scale)
        }
        (None, Some(cd)) => {
            stray(
                "c0",
                lf.c0.is_some(),
                "only used with `ies` (the C = 0 plane of an IES table)",
            )?;
            stray(
                "intensity_scale",
                lf.intensity_scale.is_some(),
                "scales an IES file's candela; with `intensity_cd`, write the intensity itself",
            )?;
            let intensity_cd = positive(cd, l, &key("intensity_cd"))?;
            let cone_deg = match lf.cone_deg {
                Some(c) if c.is_finite() && c > 0.0 && c <= 180.0 => c,
                Some(c) => return Err(l.err(key("cone_deg"), format!("must be in (0, 180], is {c}"))),
                None => {
                    stray(
                        "falloff_deg",
                        lf.falloff_deg.is_some(),
                        "only used with `cone_deg` (an isotropic light has no edge)",
                    )?;
                    stray(
                        "aim",
                        lf.aim.is_some(),
                        "an isotropic light (no `cone_deg`) has no aim; give `cone_deg` for a spot",
                    )?;
                    180.0
                }
            };
            let falloff_deg = lf.falloff_deg.unwrap_or(0.0);
            if !(0.0..=cone_deg).contains(&falloff_deg) {
                return Err(l.err(
                    key("falloff_deg"),
                    format!("must be in [0, cone_deg = {cone_deg}], is {falloff_deg}"),
                ));
            }
            if lf.cone_deg.is_some() && lf.aim.is_none() {
                return Err(l.err(key("aim"), "a cone needs `aim` (the direction of its axis)"));
            }
            let cone = LightDistribution::Cone {
                intensity_cd,
                cone_deg,
                falloff_deg,
            };
            (cone, 1.0)
        }
    };
    // An isotropic light has no aim; its (unused) axis is +y.
    let aim = match lf.aim {
        Some(a) => unit(a, l, &key("aim"))?,
        None => DVec3::Y,
    };
    let c0 = match lf.c0 {
        Some(c) => {
            let c = DVec3::from(c);
            let perp = c - aim * c.dot(aim);
            unit(perp.to_array(), l, &key("c0"))?
        }
        None => crate::geometry::basis(aim).0,
    };
    let mut spd = l.spd_1nm(lf.blackbody_k, lf.spd.as_ref(), &key)?;
    if let Some(f) = &lf.filter {
        let t = l.spectrum(f, SpectralUnit::Transmittance, &key("filter"))?;
        let t = t
            .resample(&Grid::one_nm())
            .map_err(|e| l.err(key("filter"), e.to_string()))?;
        for (s, f) in spd.iter_mut().zip(t.values()) {
            *s *= f;
        }
    }
    // Normalise to 1 cd: 683 · Σ S(λ) V(λ) Δλ = 1, Δλ = 1 nm. A photometric
    // input: V(λ) (CIE 1931 ȳ), not the analysis observer.
    let lum = luminous_1nm(&spd);
    if lum.is_nan() || lum <= 0.0 {
        return Err(l.err(key("spd"), "the spectrum has no luminous power"));
    }
    let spectrum_per_cd = Spectrum::new(
        Grid::one_nm(),
        SpectralUnit::RelativePower,
        spd.iter().map(|s| s / lum).collect(),
    )
    .map_err(|e| l.err(key("spd"), e.to_string()))?;
    Ok(PointLight {
        id: lf.id.clone(),
        position: DVec3::from(lf.position),
        aim,
        c0,
        distribution,
        intensity_scale,
        spectrum_per_cd,
    })
}

/// The emitter of `polygon[i]` / `mesh[i]` (`at`), whose emission is `e`.
pub(super) fn load_emitter(
    l: &mut Loader,
    e: &EmissionFile,
    at: &str,
    name: String,
    two_sided: bool,
) -> Result<Emitter, SceneError> {
    let key = |k: &str| format!("{at}.emission.{k}");
    let grid = Grid::one_nm();
    let values = match (&e.radiance, e.luminance_cd_m2) {
        (Some(r), None) => {
            for (k, present) in [("spd", e.spd.is_some()), ("blackbody_k", e.blackbody_k.is_some())] {
                if present {
                    return Err(l.err(
                        key(k),
                        "only used with `luminance_cd_m2`; `radiance` is the whole emission",
                    ));
                }
            }
            let s = l.spectrum(r, SpectralUnit::SpectralRadiance, &key("radiance"))?;
            s.resample(&grid)
                .map_err(|e| l.err(key("radiance"), e.to_string()))?
                .into_values()
        }
        (None, Some(lum)) => {
            let lum = positive(lum, l, &key("luminance_cd_m2"))?;
            let shape = l.spd_1nm(e.blackbody_k, e.spd.as_ref(), &key)?;
            // Scale so that 683 · Σ L(λ) V(λ) · 1 nm = the luminance: a
            // photometric input, in V(λ) (CIE 1931 ȳ), not the analysis observer.
            let y = luminous_1nm(&shape);
            if y.is_nan() || y <= 0.0 {
                return Err(l.err(key("spd"), "the spectrum has no luminous power"));
            }
            shape.iter().map(|s| s * lum / y).collect()
        }
        _ => {
            return Err(l.err(
                format!("{at}.emission"),
                "give exactly one of `radiance = \"FILE.csv:COLUMN\"` (W/(sr·m²·nm)) and \
                 `luminance_cd_m2` (with `spd` or `blackbody_k`)",
            ))
        }
    };
    if values.iter().any(|v| *v < 0.0) {
        return Err(l.err(key("radiance"), "an emitted radiance cannot be negative"));
    }
    let radiance = Spectrum::new(grid, SpectralUnit::SpectralRadiance, values)
        .map_err(|err| l.err(format!("{at}.emission"), err.to_string()))?;
    Ok(Emitter {
        name,
        radiance,
        two_sided,
        rgb: None,
        spot: None,
    })
}
