//! Camera images as files for other tools: multi-channel OpenEXR, ENVI
//! (`.hdr` + raw BSQ) and MATLAB `.mat`, chosen by the file's extension.
//!
//! Channel layout (all `f32`, rows top to bottom), used by the stimulus
//! conversion and any spectral EXR reader:
//! - the coding's bands as emissive spectral channels by the convention of
//!   Fichet, Pacanowski & Wilkie, "An OpenEXR Layout for Spectral Images",
//!   JCGT 10(3), 2021: `S0.<λ>nm` with λ in nm written with six decimals
//!   and a comma as decimal separator (`S0.550,000000nm`), the value being
//!   spectral radiance in W/(sr·m²·nm) (for `nstepN`, the band mean at the
//!   band's centre wavelength); the RGB codings write `R`, `G`, `B` instead;
//! - `X`, `Y`, `Z` (Y luminance in cd/m²) and `L`, `M`, `S` (see
//!   [`lightbooth_render::camera`] for their scale);
//! - the standard error of every channel of the mean as a second layer,
//!   `SE.<name>` (`SE.S0.550,000000nm`, `SE.Y`), and the paths per pixel
//!   as `paths`.
//!
//! Header attributes: `spectralLayoutVersion` = "1.0" and `emissiveUnits` =
//! "W.m^-2.sr^-1" (the spec's spelling for spectral radiance; the per-nm is
//! implied by the channel's wavelength), plus lightbooth's own
//! `lightbooth.units.*` (`W/(sr*m^2*nm)`, `cd/m^2`), `lightbooth.coding`,
//! `lightbooth.observer` and `lightbooth.spectralStep` (`1 nm`, or `5 nm`
//! with `--image-step 5`). Every attribute's text is plain ASCII. The pixels
//! are ZIP-compressed scan lines (lossless).
//!
//! ENVI: one band per coding channel, band-sequential float32
//! little-endian (`data type = 4`, `byte order = 0`), with `wavelength`,
//! `wavelength units = nm` and the units in `data units`; the standard
//! error as a second image `<name>_se.bsq`. MAT: `radiance` (H × W × N
//! single), `radiance_se`, `XYZ`, `LMS`, `paths` (H × W), `wavelength_nm`,
//! `units`, `coding`.
//!
//! Several codings of one render ([`CameraImages`], `--image-coding
//! rgb,srgb,nstep9,spectral`) go in one file, a layer per coding:
//! - EXR: OpenEXR's `layer.channel` naming, the coding's name as the layer
//!   (`nstep9.X`, `nstep9.SE.X`, `spectral.S0.550,000000nm`, `rgb.R`), one
//!   `paths` channel (the codings share their paths), and the attributes
//!   `lightbooth.codings` (in the file's order) and `lightbooth.reference`;
//! - MAT: each single-coding variable prefixed by its coding
//!   (`nstep9_radiance`, `nstep9_radiance_se`, `nstep9_XYZ`, `nstep9_LMS`,
//!   `nstep9_wavelength_nm`, `nstep9_units`), one `paths`, and `codings`
//!   (one row per coding) and `reference`;
//! - ENVI: a file pair per coding, `<stem>.<coding>.bsq` (+ `.hdr`) and its
//!   `<stem>.<coding>_se.bsq`.

use std::io::Write;
use std::path::{Path, PathBuf};

use exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Encoding, FlatSamples, Image, Layer, LayerAttributes, SmallVec, Text,
    WritableImage,
};

use crate::export::mat::MatFile;
use lightbooth_render::camera::{CameraImage, CameraImages};

/// The units of the spectral channels, in ASCII: OpenEXR's text attributes
/// have no declared encoding, and readers (OpenEXR's own Python binding)
/// decode them as UTF-8; the Latin-1 `²`, `·` and `°` the writer once
/// produced made the whole header unreadable there.
pub const SPECTRAL_UNITS: &str = "W/(sr*m^2*nm)";
/// The value of the `emissiveUnits` attribute (Fichet et al. 2021).
pub const EMISSIVE_UNITS: &str = "W.m^-2.sr^-1";
pub const SPECTRAL_LAYOUT_VERSION: &str = "1.0";

/// A spectral channel's name: `S0.550,000000nm`.
pub fn spectral_channel_name(nm: f64) -> String {
    format!("S0.{nm:.6}nm").replace('.', ",").replacen("S0,", "S0.", 1)
}

/// The names of the coding's channels, in the image's order.
pub fn coding_channel_names(image: &CameraImage) -> Vec<String> {
    match &image.quantities.wavelengths_nm {
        Some(w) => w.iter().map(|&nm| spectral_channel_name(nm)).collect(),
        None => ["R", "G", "B"].map(String::from).to_vec(),
    }
}

/// Every quantity's name: the coding's channels, X, Y, Z, L, M, S.
pub fn quantity_names(image: &CameraImage) -> Vec<String> {
    let mut names = coding_channel_names(image);
    names.extend(["X", "Y", "Z", "L", "M", "S"].map(String::from));
    names
}

/// Writes the image as `.exr`, `.mat` or ENVI (`.bsq`, with `.hdr` beside it).
pub fn write_camera_image(image: &CameraImage, path: &Path) -> Result<Vec<PathBuf>, String> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    match ext.as_str() {
        "exr" => write_exr(image, path).map(|()| vec![path.to_path_buf()]),
        "mat" => write_mat(image, path).map(|()| vec![path.to_path_buf()]),
        "bsq" => write_envi(image, path),
        other => Err(format!(
            "{}: unknown spectral image type `.{other}`: use .exr, .mat or .bsq (ENVI)",
            path.display()
        )),
    }
}

/// An attribute's text, which must be ASCII (see [`SPECTRAL_UNITS`]): the
/// `exr` crate writes each `char` as one Latin-1 byte.
fn text(s: &str) -> Result<AttributeValue, String> {
    if !s.is_ascii() {
        return Err(format!("OpenEXR attribute text `{s}` is not ASCII"));
    }
    Ok(AttributeValue::Text(Text::from(s)))
}

/// The spacing of an image's spectral channels, nm (`None`: RGB, or one band).
pub fn spectral_step_nm(image: &CameraImage) -> Option<f64> {
    match image.quantities.wavelengths_nm.as_deref() {
        Some([a, b, ..]) => Some(b - a),
        _ => None,
    }
}

/// Multi-channel OpenEXR, one part, scan lines compressed losslessly with
/// ZIP (16 lines a block: OpenEXR's `ZIP_COMPRESSION`, which every reader has).
pub fn write_exr(image: &CameraImage, path: &Path) -> Result<(), String> {
    let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    push_image_channels(&mut channels, image, "");
    let mut other = vec![("lightbooth.coding".to_string(), image.coding.to_string())];
    other.extend(common_attributes(image));
    if image.quantities.wavelengths_nm.is_some() {
        other.extend(spectral_attributes());
        if let Some(step) = spectral_step_nm(image) {
            other.push(("lightbooth.spectralStep".into(), format!("{step} nm")));
        }
    } else {
        other.push((
            "lightbooth.units.RGB".into(),
            format!("linear {} with Y in cd/m^2", image.coding),
        ));
    }
    write_exr_part(path, image, channels, other)
}

/// Every quantity of `image` and its standard error as channels, each name
/// after `prefix` (`""`, or the coding's layer as `nstep9.`).
fn push_image_channels(channels: &mut SmallVec<[AnyChannel<FlatSamples>; 4]>, image: &CameraImage, prefix: &str) {
    for (k, name) in quantity_names(image).iter().enumerate() {
        channels.push(linear_channel(&format!("{prefix}{name}"), image.plane(k)));
        channels.push(linear_channel(&format!("{prefix}SE.{name}"), image.se_plane(k)));
    }
}

/// The attributes every camera image file has: its observer and units.
fn common_attributes(image: &CameraImage) -> Vec<(String, String)> {
    [
        ("lightbooth.observer", image.observer.to_string()),
        ("lightbooth.units.XYZ", "cd/m^2 (Y is luminance)".to_string()),
        (
            "lightbooth.units.LMS",
            "cd/m^2-scaled cone excitations (L + M = CIE 2006 2 deg luminance)".to_string(),
        ),
        (
            "lightbooth.units.SE",
            "standard error of the pixel's mean, same units as the channel".to_string(),
        ),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v))
    .collect()
}

/// The attributes of a file with spectral channels (Fichet et al. 2021).
fn spectral_attributes() -> Vec<(String, String)> {
    [
        ("spectralLayoutVersion", SPECTRAL_LAYOUT_VERSION),
        ("emissiveUnits", EMISSIVE_UNITS),
        ("lightbooth.units.spectral", SPECTRAL_UNITS),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v.to_string()))
    .collect()
}

/// One OpenEXR part of `image`'s size: the channels, `paths` (the image's
/// paths per pixel, which every coding of one render shares) and the text
/// attributes, ZIP-compressed scan lines.
fn write_exr_part(
    path: &Path,
    image: &CameraImage,
    mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]>,
    other: Vec<(String, String)>,
) -> Result<(), String> {
    channels.push(linear_channel(
        "paths",
        image.samples.iter().map(|&n| n as f32).collect(),
    ));
    let mut attributes = LayerAttributes::default();
    for (k, v) in other {
        attributes.other.insert(Text::from(k.as_str()), text(&v)?);
    }
    let layer = Layer::new(
        (image.width as usize, image.height as usize),
        attributes,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels),
    );
    Image::from_layer(layer)
        .write()
        .non_parallel()
        .to_file(path)
        .map_err(|e| format!("{}: writing OpenEXR: {e}", path.display()))
}

fn linear_channel(name: &str, values: Vec<f32>) -> AnyChannel<FlatSamples> {
    AnyChannel {
        name: Text::from(name),
        sample_data: FlatSamples::F32(values),
        // Radiometric values: quantised linearly if ever lossy-compressed.
        quantize_linearly: true,
        sampling: exr::math::Vec2(1, 1),
    }
}

/// The image's coding channels as column-major H × W × N (MATLAB order).
fn column_major(image: &CameraImage, first: usize, count: usize, se: bool) -> Vec<f32> {
    let (w, h) = (image.width as usize, image.height as usize);
    let mut out = Vec::with_capacity(w * h * count);
    for k in first..first + count {
        let plane = if se { image.se_plane(k) } else { image.plane(k) };
        for x in 0..w {
            for y in 0..h {
                out.push(plane[y * w + x]);
            }
        }
    }
    out
}

/// MATLAB Level 5 MAT-file.
pub fn write_mat(image: &CameraImage, path: &Path) -> Result<(), String> {
    let (w, h, n) = (
        image.width as usize,
        image.height as usize,
        image.quantities.coding_channels,
    );
    let x0 = image.xyz_index();
    let mut mat = MatFile::new();
    mat.single_array("radiance", &[h, w, n], &column_major(image, 0, n, false))?;
    mat.single_array("radiance_se", &[h, w, n], &column_major(image, 0, n, true))?;
    mat.single_array("XYZ", &[h, w, 3], &column_major(image, x0, 3, false))?;
    mat.single_array("LMS", &[h, w, 3], &column_major(image, x0 + 3, 3, false))?;
    let mut paths = vec![0.0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            paths[x * h + y] = image.samples[y * w + x] as f32;
        }
    }
    mat.single_array("paths", &[h, w], &paths)?;
    let wl = image.quantities.wavelengths_nm.clone().unwrap_or_default();
    mat.column("wavelength_nm", &wl)?;
    let units = match image.quantities.wavelengths_nm {
        Some(_) => SPECTRAL_UNITS.to_string(),
        None => format!("linear {} with Y in cd/m2", image.coding),
    };
    mat.text("units", &units)?;
    mat.text("coding", &image.coding.to_string())?;
    std::fs::write(path, mat.into_bytes()).map_err(|e| format!("{}: {e}", path.display()))
}

/// The ENVI header text for `bands` float32 BSQ bands.
pub fn envi_header(image: &CameraImage, description: &str) -> String {
    let names = coding_channel_names(image);
    let mut hdr = format!(
        "ENVI\ndescription = {{{description}}}\nsamples = {}\nlines = {}\nbands = {}\nheader offset = 0\n\
         file type = ENVI Standard\ndata type = 4\ninterleave = bsq\nbyte order = 0\n",
        image.width,
        image.height,
        names.len()
    );
    if let Some(w) = &image.quantities.wavelengths_nm {
        let list: Vec<String> = w.iter().map(|v| format!("{v:.3}")).collect();
        hdr.push_str("wavelength units = nm\n");
        hdr.push_str(&format!("wavelength = {{{}}}\n", list.join(", ")));
        hdr.push_str("data units = W/(sr m^2 nm)\n");
    } else {
        hdr.push_str(&format!("data units = linear {} with Y in cd/m^2\n", image.coding));
    }
    hdr.push_str(&format!("band names = {{{}}}\n", names.join(", ")));
    hdr
}

/// ENVI: `path` (.bsq) + its `.hdr`, and the SE image `<stem>_se.bsq` + `.hdr`.
pub fn write_envi(image: &CameraImage, path: &Path) -> Result<Vec<PathBuf>, String> {
    let n = image.quantities.coding_channels;
    let se_path = path.with_file_name(format!(
        "{}_se.bsq",
        path.file_stem().and_then(|s| s.to_str()).unwrap_or("image")
    ));
    let mut written = Vec::new();
    for (data_path, se, what) in [
        (path.to_path_buf(), false, "lightbooth camera image, spectral radiance"),
        (se_path, true, "lightbooth camera image, standard error of the mean"),
    ] {
        let io = |e: std::io::Error| format!("{}: {e}", data_path.display());
        let mut out = std::io::BufWriter::new(std::fs::File::create(&data_path).map_err(io)?);
        for k in 0..n {
            let plane = if se { image.se_plane(k) } else { image.plane(k) };
            for v in plane {
                out.write_all(&v.to_le_bytes()).map_err(io)?;
            }
        }
        out.flush().map_err(io)?;
        let hdr_path = data_path.with_extension("hdr");
        let desc = format!("{what}, coding {}", image.coding);
        std::fs::write(&hdr_path, envi_header(image, &desc)).map_err(|e| format!("{}: {e}", hdr_path.display()))?;
        written.push(data_path);
        written.push(hdr_path);
    }
    Ok(written)
}

/// The start of the name of a download's private folder in the system's
/// temporary folder: `lightbooth-image-<pid>-<image>-<ns>`, removed after
/// the download; [`remove_stale_export_folders`] removes those a killed
/// process left.
pub const EXPORT_FOLDER_PREFIX: &str = "lightbooth-image-";

/// The private folder, in `parent`, of process `pid`'s export of image `id`.
pub fn export_folder(parent: &Path, pid: u32, id: i64, nanos: u128) -> PathBuf {
    parent.join(format!("{EXPORT_FOLDER_PREFIX}{pid}-{id}-{nanos}"))
}

/// Creates `dir` readable only by its owner (0700): the system's temporary
/// folder is shared by every user, and an export holds a whole image.
pub fn create_private_folder(dir: &Path) -> Result<(), String> {
    let mut private = std::fs::DirBuilder::new();
    #[cfg(unix)]
    std::os::unix::fs::DirBuilderExt::mode(&mut private, 0o700);
    private.create(dir).map_err(|e| format!("{}: {e}", dir.display()))
}

/// Removes from `parent` the export folders ([`export_folder`]) of
/// processes that no longer exist (a daemon killed during an export leaves
/// its folder: 20 and 29 in two runs of the kill test of issue 32); returns
/// those removed. A folder of a live process, even of another program that
/// reuses a pid, is left alone; so is everything where `/proc` cannot tell
/// (not Linux). The daemon calls it at start-up.
pub fn remove_stale_export_folders(parent: &Path) -> Vec<PathBuf> {
    if !Path::new("/proc/self").exists() {
        return Vec::new();
    }
    let Ok(entries) = std::fs::read_dir(parent) else {
        return Vec::new();
    };
    let mut removed = Vec::new();
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(pid) = name
            .to_str()
            .and_then(|n| n.strip_prefix(EXPORT_FOLDER_PREFIX))
            .and_then(|rest| rest.split('-').next())
            .and_then(|pid| pid.parse::<u32>().ok())
        else {
            continue;
        };
        let is_dir = entry.file_type().is_ok_and(|t| t.is_dir());
        if is_dir && pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists() {
            let path = entry.path();
            if std::fs::remove_dir_all(&path).is_ok() {
                removed.push(path);
            }
        }
    }
    removed
}

/// Writes every coding of `images` in one file, a layer per coding (see the
/// module doc), by the extension as [`write_camera_image`]; a render of one
/// coding is written exactly as [`write_camera_image`] writes it.
pub fn write_camera_images(images: &CameraImages, path: &Path) -> Result<Vec<PathBuf>, String> {
    if let [image] = images.images.as_slice() {
        return write_camera_image(image, path);
    }
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    match ext.as_str() {
        "exr" => write_layered_exr(images, path).map(|()| vec![path.to_path_buf()]),
        "mat" => write_layered_mat(images, path).map(|()| vec![path.to_path_buf()]),
        "bsq" => {
            let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("image");
            let mut written = Vec::new();
            for image in &images.images {
                written.extend(write_envi(
                    image,
                    &path.with_file_name(format!("{stem}.{}.bsq", image.coding)),
                )?);
            }
            Ok(written)
        }
        other => Err(format!(
            "{}: unknown spectral image type `.{other}`: use .exr, .mat or .bsq (ENVI)",
            path.display()
        )),
    }
}

/// The codings of `images` as one comma list, in their order.
fn coding_list(images: &CameraImages) -> String {
    images
        .images
        .iter()
        .map(|i| i.coding.to_string())
        .collect::<Vec<_>>()
        .join(",")
}

/// One OpenEXR part with a layer per coding.
fn write_layered_exr(images: &CameraImages, path: &Path) -> Result<(), String> {
    let first = &images.images[0];
    let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for image in &images.images {
        push_image_channels(&mut channels, image, &format!("{}.", image.coding));
    }
    let mut other = vec![
        ("lightbooth.codings".to_string(), coding_list(images)),
        (
            "lightbooth.reference".to_string(),
            images.reference_image().coding.to_string(),
        ),
        (
            "lightbooth.paths".to_string(),
            "every coding's pixel from the same paths (the paths channel)".to_string(),
        ),
    ];
    other.extend(common_attributes(first));
    if images.images.iter().any(|i| i.quantities.wavelengths_nm.is_some()) {
        other.extend(spectral_attributes());
    }
    for image in &images.images {
        if let Some(step) = spectral_step_nm(image) {
            other.push((
                format!("lightbooth.spectralStep.{}", image.coding),
                format!("{step} nm"),
            ));
        }
    }
    write_exr_part(path, first, channels, other)
}

/// A MAT-file with every coding's variables, prefixed by the coding.
fn write_layered_mat(images: &CameraImages, path: &Path) -> Result<(), String> {
    let first = &images.images[0];
    let (w, h) = (first.width as usize, first.height as usize);
    let mut mat = MatFile::new();
    for image in &images.images {
        let n = image.quantities.coding_channels;
        let x0 = image.xyz_index();
        let p = image.coding.to_string();
        mat.single_array(&format!("{p}_radiance"), &[h, w, n], &column_major(image, 0, n, false))?;
        mat.single_array(
            &format!("{p}_radiance_se"),
            &[h, w, n],
            &column_major(image, 0, n, true),
        )?;
        mat.single_array(&format!("{p}_XYZ"), &[h, w, 3], &column_major(image, x0, 3, false))?;
        mat.single_array(&format!("{p}_XYZ_se"), &[h, w, 3], &column_major(image, x0, 3, true))?;
        mat.single_array(&format!("{p}_LMS"), &[h, w, 3], &column_major(image, x0 + 3, 3, false))?;
        let wl = image.quantities.wavelengths_nm.clone().unwrap_or_default();
        mat.column(&format!("{p}_wavelength_nm"), &wl)?;
        let units = match image.quantities.wavelengths_nm {
            Some(_) => SPECTRAL_UNITS.to_string(),
            None => format!("linear {} with Y in cd/m2", image.coding),
        };
        mat.text(&format!("{p}_units"), &units)?;
    }
    let mut paths = vec![0.0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            paths[x * h + y] = first.samples[y * w + x] as f32;
        }
    }
    mat.single_array("paths", &[h, w], &paths)?;
    let codings: Vec<String> = images.images.iter().map(|i| i.coding.to_string()).collect();
    mat.text_rows("codings", &codings)?;
    mat.text("reference", &images.reference_image().coding.to_string())?;
    std::fs::write(path, mat.into_bytes()).map_err(|e| format!("{}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    /// Regression: the folder an image is exported into (EXR, MAT) was
    /// created with the umask's mode (0755) under the shared temporary
    /// folder, although the code said private.
    #[cfg(unix)]
    #[test]
    fn image_export_folder_created_world_readable() {
        use std::os::unix::fs::PermissionsExt;
        let parent = tempfile::tempdir().unwrap();
        let dir = parent.path().join("export");
        create_private_folder(&dir).unwrap();
        let mode = std::fs::metadata(&dir).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o700, "{mode:04o}");
    }

    use super::*;

    /// The bug (issue 32): a daemon killed during EXR exports left its
    /// `lightbooth-image-*` folders in `$TMPDIR` for ever (20 and 29 in two
    /// runs). At start-up the daemon removes those of gone processes, and
    /// only those.
    #[test]
    fn export_folders_of_a_killed_daemon_stayed_in_the_temporary_folder() {
        let tmp = tempfile::tempdir().unwrap();
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let gone = child.id();
        child.wait().unwrap();
        let left = export_folder(tmp.path(), gone, 7, 123);
        std::fs::create_dir(&left).unwrap();
        std::fs::write(left.join("image.exr"), b"half written").unwrap();
        let mine = export_folder(tmp.path(), std::process::id(), 8, 456);
        std::fs::create_dir(&mine).unwrap();
        let init = export_folder(tmp.path(), 1, 9, 789);
        std::fs::create_dir(&init).unwrap();
        let other = tmp.path().join("lightbooth-notes");
        std::fs::create_dir(&other).unwrap();
        assert_eq!(remove_stale_export_folders(tmp.path()), vec![left.clone()]);
        assert!(!left.exists(), "the gone process's folder is removed");
        assert!(
            mine.exists() && init.exists() && other.exists(),
            "live processes' folders and others stay"
        );
    }

    #[test]
    fn spectral_channel_names_follow_fichet_2021() {
        assert_eq!(spectral_channel_name(550.0), "S0.550,000000nm");
        assert_eq!(spectral_channel_name(382.5), "S0.382,500000nm");
    }
}
