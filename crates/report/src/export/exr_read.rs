//! Reading back the OpenEXR camera images lightbooth writes
//! ([`crate::export::image`]) as an XYZ image, for the stimulus conversion.
//!
//! XYZ comes from the `X`, `Y`, `Z` channels when the file has them;
//! otherwise from the spectral channels `S0.<λ>nm` (Fichet et al. 2021),
//! integrated with the colour-matching functions of the observer the file
//! names (`lightbooth.observer`) or, when it names none, the caller's. The
//! channels' spectrum is taken as piecewise constant: every 1 nm wavelength
//! of 380–780 nm takes the value of the nearest channel — exact for the
//! 1 nm `spectral` cube and the `nstepN` bands' own reconstruction (each
//! band's mean over its width), an approximation for other layouts.

use std::path::Path;

use exr::prelude::{AttributeValue, FlatSamples, ReadChannels, ReadLayers};

use lightbooth_science::colorimetry::{xyz_from_radiance, Observer};
use lightbooth_science::spectrum::{Grid, SpectralUnit, Spectrum};

/// An XYZ image, rows top to bottom, cd/m² (Y luminance).
#[derive(Clone, Debug)]
pub struct XyzImage {
    pub width: u32,
    pub height: u32,
    pub xyz: Vec<[f64; 3]>,
    /// The observer of the XYZ.
    pub observer: Observer,
    /// Where the XYZ came from: `X,Y,Z channels` or `N spectral channels, …`.
    pub source: String,
}

/// The wavelength of a spectral channel name `S0.550,000000nm` (also with a
/// `.` decimal separator), or `None` for any other channel.
pub fn spectral_channel_nm(name: &str) -> Option<f64> {
    let v = name.strip_prefix("S0.")?.strip_suffix("nm")?;
    v.replace(',', ".").parse().ok()
}

/// One part of an OpenEXR file as the `exr` crate reads it.
type ExrLayer = exr::prelude::Layer<exr::prelude::AnyChannels<FlatSamples>>;

/// A text attribute of the layer.
fn text_attribute(layer: &ExrLayer, key: &str) -> Option<String> {
    layer
        .attributes
        .other
        .iter()
        .find(|(k, _)| k.as_slice() == key.as_bytes())
        .and_then(|(_, v)| match v {
            AttributeValue::Text(t) => Some(t.to_string()),
            _ => None,
        })
}

/// The file's first part, checked to be for `observer` when it names one.
fn open(path: &Path, observer: Observer) -> Result<ExrLayer, String> {
    let file = path.display();
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .non_parallel()
        .from_file(path)
        .map_err(|e| format!("{file}: reading OpenEXR: {e}"))?;
    let layer = image.layer_data;
    if let Some(name) = text_attribute(&layer, "lightbooth.observer") {
        let file_observer: Observer = name
            .parse()
            .map_err(|e| format!("{file}: attribute lightbooth.observer: {e}"))?;
        if file_observer != observer {
            return Err(format!(
                "{file}: the image's XYZ are for observer {file_observer} (attribute lightbooth.observer) \
                 but the display profile's are for {observer}; render the image with --observer {observer} \
                 or use a profile fitted with {file_observer}"
            ));
        }
    }
    Ok(layer)
}

/// The codings of a layered camera image (`lightbooth render
/// --image-coding rgb,nstep9,spectral --image FILE.exr`: a layer per
/// coding, `nstep9.X`, …), each as XYZ, in the file's order
/// (`lightbooth.codings`), with the reference it names
/// (`lightbooth.reference`).
#[derive(Clone, Debug)]
pub struct XyzLayers {
    pub layers: Vec<(String, XyzImage)>,
    pub reference: Option<String>,
}

/// Reads `path`'s coding layers as XYZ in `observer` from their `X`, `Y`,
/// `Z` channels; `Ok(None)` when the file has no layer with all three (a
/// single image: [`read_xyz_exr`]).
pub fn read_xyz_exr_layers(path: &Path, observer: Observer) -> Result<Option<XyzLayers>, String> {
    let file = path.display();
    let layer = open(path, observer)?;
    let (w, h) = (layer.size.0, layer.size.1);
    let channels = &layer.channel_data.list;
    let names: Vec<String> = channels.iter().map(|c| c.name.to_string()).collect();
    let has = |n: &str| names.iter().any(|m| m == n);
    let mut prefixes: Vec<String> = names
        .iter()
        .filter_map(|n| n.strip_suffix(".X"))
        .filter(|p| !p.is_empty() && !p.ends_with("SE") && has(&format!("{p}.Y")) && has(&format!("{p}.Z")))
        .map(String::from)
        .collect();
    if prefixes.is_empty() {
        return Ok(None);
    }
    if let Some(order) = text_attribute(&layer, "lightbooth.codings") {
        let order: Vec<&str> = order.split(',').collect();
        prefixes.sort_by_key(|p| order.iter().position(|o| o == p).unwrap_or(usize::MAX));
    }
    let plane = |name: &str| -> Result<Vec<f64>, String> {
        let c = channels
            .iter()
            .find(|c| c.name.to_string() == name)
            .expect("listed above");
        let v: Vec<f64> = c.sample_data.values_as_f32().map(f64::from).collect();
        if v.len() != w * h {
            return Err(format!(
                "{file}: channel {name} is subsampled; expected {w} × {h} values"
            ));
        }
        Ok(v)
    };
    let mut layers = Vec::with_capacity(prefixes.len());
    for p in prefixes {
        let (x, y, z) = (
            plane(&format!("{p}.X"))?,
            plane(&format!("{p}.Y"))?,
            plane(&format!("{p}.Z"))?,
        );
        layers.push((
            p.clone(),
            XyzImage {
                width: w as u32,
                height: h as u32,
                xyz: (0..w * h).map(|i| [x[i], y[i], z[i]]).collect(),
                observer,
                source: format!("{p}.X,{p}.Y,{p}.Z channels"),
            },
        ));
    }
    let reference = text_attribute(&layer, "lightbooth.reference");
    if let Some(r) = &reference {
        if !layers.iter().any(|(p, _)| p == r) {
            return Err(format!(
                "{file}: attribute lightbooth.reference names {r}, which is not one of its layers ({})",
                layers.iter().map(|(p, _)| p.as_str()).collect::<Vec<_>>().join(", ")
            ));
        }
    }
    Ok(Some(XyzLayers { layers, reference }))
}

/// Reads `path` as XYZ in `observer` (see the module doc); errors name the
/// file and what is missing or in conflict.
pub fn read_xyz_exr(path: &Path, observer: Observer) -> Result<XyzImage, String> {
    let file = path.display();
    let layer = open(path, observer)?;
    let layer = &layer;
    let (w, h) = (layer.size.0, layer.size.1);
    let channels = &layer.channel_data.list;
    let values = |s: &FlatSamples| -> Vec<f64> { s.values_as_f32().map(f64::from).collect() };
    let find = |n: &str| channels.iter().find(|c| c.name.to_string() == n);
    let n = w * h;
    if let (Some(x), Some(y), Some(z)) = (find("X"), find("Y"), find("Z")) {
        let (x, y, z) = (values(&x.sample_data), values(&y.sample_data), values(&z.sample_data));
        if x.len() != n || y.len() != n || z.len() != n {
            return Err(format!(
                "{file}: channels X, Y, Z are subsampled; expected {w} × {h} values"
            ));
        }
        return Ok(XyzImage {
            width: w as u32,
            height: h as u32,
            xyz: (0..n).map(|i| [x[i], y[i], z[i]]).collect(),
            observer,
            source: "X,Y,Z channels".into(),
        });
    }
    let mut spectral: Vec<(f64, Vec<f64>)> = channels
        .iter()
        .filter_map(|c| Some((spectral_channel_nm(&c.name.to_string())?, values(&c.sample_data))))
        .collect();
    if spectral.is_empty() {
        let have: Vec<String> = channels.iter().map(|c| c.name.to_string()).collect();
        let missing: Vec<&str> = ["X", "Y", "Z"].into_iter().filter(|c| find(c).is_none()).collect();
        return Err(format!(
            "{file}: no channel {} and no spectral channels S0.<λ>nm to integrate; the file has: {}",
            missing.join(", "),
            have.join(", ")
        ));
    }
    if let Some((nm, v)) = spectral.iter().find(|(_, v)| v.len() != n) {
        return Err(format!(
            "{file}: spectral channel at {nm} nm has {} values for {w} × {h} pixels",
            v.len()
        ));
    }
    spectral.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Each channel's XYZ per unit value: the integral of the CMFs over the
    // 1 nm wavelengths nearest to it.
    let grid = Grid::one_nm();
    let mut weights = Vec::with_capacity(spectral.len());
    let nearest = |nm: f64| {
        spectral
            .iter()
            .enumerate()
            .min_by(|a, b| (a.1 .0 - nm).abs().total_cmp(&(b.1 .0 - nm).abs()))
            .map(|(k, _)| k)
            .unwrap_or(0)
    };
    let owner: Vec<usize> = grid.wavelengths().iter().map(|&nm| nearest(nm)).collect();
    for k in 0..spectral.len() {
        let basis: Vec<f64> = owner.iter().map(|&o| if o == k { 1.0 } else { 0.0 }).collect();
        let s = Spectrum::new(grid.clone(), SpectralUnit::SpectralRadiance, basis).map_err(|e| e.to_string())?;
        weights.push(xyz_from_radiance(&s, observer).map_err(|e| e.to_string())?.to_array());
    }
    let xyz = (0..n)
        .map(|i| {
            let mut acc = [0.0; 3];
            for (w, (_, v)) in weights.iter().zip(&spectral) {
                for (a, wc) in acc.iter_mut().zip(w) {
                    *a += wc * v[i];
                }
            }
            acc
        })
        .collect();
    Ok(XyzImage {
        width: w as u32,
        height: h as u32,
        xyz,
        observer,
        source: format!(
            "{} spectral channels ({}–{} nm) integrated with the {observer} observer",
            spectral.len(),
            spectral[0].0,
            spectral[spectral.len() - 1].0
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spectral_channel_names_parse_with_either_decimal_separator() {
        assert_eq!(spectral_channel_nm("S0.550,000000nm"), Some(550.0));
        assert_eq!(spectral_channel_nm("S0.382.5nm"), Some(382.5));
        assert_eq!(spectral_channel_nm("SE.S0.550,000000nm"), None);
        assert_eq!(spectral_channel_nm("Y"), None);
    }
}
