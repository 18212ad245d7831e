//! `lightbooth stimulus IMAGE.exr --display PROFILE --bits B`: a rendered
//! image as the frame-buffer codes that show it on a measured display, with
//! the gamut and quantisation report (see `lightbooth::display::stimulus`
//! for the model, the ΔE00 white and the quantisation bound, and
//! `lightbooth::display::stimulus_files` for the file layouts).

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;
use serde::Serialize;

use lightbooth::charts::{false_colour_map_svg, tick_label, FalseColourMap};
use lightbooth::display::image_set::{image_set, ImageSet, OUTPUTS};
use lightbooth::display::profile::TransferModel;
use lightbooth::display::stimulus::{convert, quantisation_bound_de00, GamutPolicy, GamutReport, Summary};
use lightbooth::display::stimulus_files::{write_codes_png, write_codes_raw, write_delta_e_map};
use lightbooth::display::{DisplayProfile, FrameBuffer};
use lightbooth::export::exr_read::{read_xyz_exr, read_xyz_exr_layers, XyzLayers};

/// Where the display profile comes from: a JSON file or the daemon's store.
#[derive(Args, Debug, Clone)]
pub struct ProfileSource {
    /// The display profile: a JSON file, as `GET /api/display-profiles/{id}` returns it (the row, or the bare profile).
    #[arg(long, required_unless_present = "display_db")]
    pub display: Option<PathBuf>,
    /// Or the daemon's database (`sqlite://lab.sqlite`) with --display-id.
    #[arg(long, requires = "display_id", conflicts_with = "display")]
    pub display_db: Option<String>,
    /// The stored profile's id in --display-db.
    #[arg(long, requires = "display_db")]
    pub display_id: Option<i64>,
}

#[derive(Args, Debug)]
pub struct StimulusArgs {
    /// The rendered image: an OpenEXR written by `lightbooth render --image FILE.exr`.
    image: PathBuf,
    #[command(flatten)]
    profile: ProfileSource,
    /// Frame-buffer bits per channel: 8, 10, 12 or 16.
    #[arg(long, value_parser = frame_buffer_bits)]
    bits: u32,
    /// Out-of-gamut colours: clip (each channel to 0–1), scale (one factor for
    /// the image; negative channels still clipped) or fail.
    #[arg(long, default_value = "clip")]
    gamut: GamutPolicy,
    /// The transfer function: gamma (the fitted power) or table (the measured levels).
    #[arg(long, default_value = "gamma", value_parser = transfer_model)]
    transfer: TransferModel,
    /// The 16-bit PNG of codes (default: IMAGE's name with `_stimulus_<B>bit.png`).
    /// At 10 and 12 bits also `<name>.raw` (u16 codes) and `<name>.raw.json`.
    /// For an image with a layer per coding, one PNG per coding, `<name>.<coding>.png`.
    #[arg(long)]
    out: Option<PathBuf>,
    /// The report as JSON.
    #[arg(long)]
    report: Option<PathBuf>,
    /// A false-colour (viridis) PNG of each pixel's ΔE00, intended against
    /// shown, from 0 (dark) to the image's largest ΔE00 (yellow); beside it
    /// `<name>.svg`, the map with its colour bar, ticks and notes.
    #[arg(long, value_parser = png_path)]
    map: Option<PathBuf>,
}

fn frame_buffer_bits(s: &str) -> Result<u32, String> {
    let b: u32 = s.trim().parse().map_err(|_| format!("`{s}` is not a number of bits"))?;
    FrameBuffer::new(b).map(|fb| fb.bits).map_err(|e| e.to_string())
}

pub(super) fn transfer_model(s: &str) -> Result<TransferModel, String> {
    match s {
        "gamma" => Ok(TransferModel::Gamma),
        "table" => Ok(TransferModel::Table),
        _ => Err(format!("unknown transfer `{s}`: gamma or table")),
    }
}

/// The transfer's name, as `--transfer` takes it.
fn transfer_name(model: TransferModel) -> &'static str {
    match model {
        TransferModel::Gamma => "gamma",
        TransferModel::Table => "table",
    }
}

/// Parses a display profile file: the stored row (`{"id", …, "profile": {…}}`) or the bare profile.
pub fn parse_profile(text: &str, what: &str) -> anyhow::Result<DisplayProfile> {
    let value: serde_json::Value = serde_json::from_str(text).with_context(|| format!("{what}: not JSON"))?;
    let (inner, key) = match value.get("profile") {
        Some(p) => (p.clone(), "`profile`"),
        None => (value, "the file"),
    };
    let profile = DisplayProfile::from_json(inner).map_err(|e| {
        anyhow::anyhow!(
            "{what}: not a display profile (the JSON of GET /api/display-profiles/{{id}}, or its `profile`): \
             {key}: {e}"
        )
    })?;
    profile.validate().with_context(|| what.to_string())?;
    Ok(profile)
}

/// Loads the profile from its source; returns it and how to name it.
pub fn load_profile(src: &ProfileSource) -> anyhow::Result<(DisplayProfile, String)> {
    if let Some(path) = &src.display {
        let what = path.display().to_string();
        let text = std::fs::read_to_string(path).with_context(|| format!("reading {what}"))?;
        return Ok((parse_profile(&text, &what)?, what));
    }
    let (db, id) = match (&src.display_db, src.display_id) {
        (Some(db), Some(id)) => (db.clone(), id),
        _ => anyhow::bail!("give --display FILE.json, or --display-db URL with --display-id N"),
    };
    if let Some(path) = lightbooth::daemon::db_lock::database_path(&db) {
        anyhow::ensure!(path.exists(), "--display-db {db}: no such database file");
    }
    let rt = tokio::runtime::Builder::new_current_thread().enable_all().build()?;
    let row = rt.block_on(async {
        // Beside a running daemon (the profile was just calibrated in its
        // browser page): no start-up recovery, which would interrupt its work.
        let store = lightbooth::store::Store::open_to_read(&db)
            .await
            .with_context(|| format!("opening {db}"))?;
        store
            .get_display_profile(id)
            .await
            .with_context(|| format!("reading display profile {id} from {db}"))
    })?;
    let row = row.with_context(|| format!("--display-id {id}: no display profile {id} in {db}"))?;
    Ok((row.profile, format!("{db} display profile {id} ({})", row.name)))
}

/// The report written with --report and summarised on the terminal.
#[derive(Serialize)]
struct StimulusReport {
    image: String,
    xyz_source: String,
    width: u32,
    height: u32,
    display_profile: String,
    observer: String,
    bits: u32,
    transfer: &'static str,
    /// The white of every ΔE00 below: the display's (all channels at full drive), XYZ cd/m².
    delta_e00_white: [f64; 3],
    delta_e00_white_is: &'static str,
    gamut: GamutReport,
    /// Intended (after the gamut policy, unquantised) against shown (after quantisation).
    delta_e00_intended_vs_shown: Summary,
    /// The original rendered colour against shown (gamut mapping and quantisation).
    delta_e00_original_vs_shown: Summary,
    /// Worst ΔE00 half a code can cause at this depth (sampled over the drive cube).
    quantisation_bound_delta_e00: f64,
    png: String,
    png_code_alignment: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    raw: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    raw_sidecar: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    map: Option<String>,
    /// The ΔE00 at the map's yellow end (intended vs shown); 0 is its dark end.
    #[serde(skip_serializing_if = "Option::is_none")]
    map_scale_max_delta_e00: Option<f64>,
    /// The map with its colour bar: `<map>.svg`.
    #[serde(skip_serializing_if = "Option::is_none")]
    map_figure: Option<String>,
}

/// `--map` takes a `.png` path: the figure is written beside it as `.svg`.
fn png_path(s: &str) -> Result<PathBuf, String> {
    let p = PathBuf::from(s);
    match p.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case("png") => Ok(p),
        _ => Err(format!(
            "`{s}` is not a .png path: --map writes the map as PNG and the figure with its colour bar beside it as .svg"
        )),
    }
}

fn default_out(image: &Path, bits: u32) -> PathBuf {
    let stem = image.file_stem().and_then(|s| s.to_str()).unwrap_or("image");
    image.with_file_name(format!("{stem}_stimulus_{bits}bit.png"))
}

pub fn run(args: StimulusArgs) -> anyhow::Result<()> {
    let (profile, profile_name) = load_profile(&args.profile)?;
    if let Some(layers) = read_xyz_exr_layers(&args.image, profile.observer).map_err(anyhow::Error::msg)? {
        return run_set(&args, &profile, profile_name, layers);
    }
    let image = read_xyz_exr(&args.image, profile.observer).map_err(anyhow::Error::msg)?;
    let fb = FrameBuffer::new(args.bits)?;
    let stim = convert(&profile, &image.xyz, fb, args.gamut, args.transfer)?;
    let (w, h) = (image.width, image.height);
    let out = args.out.clone().unwrap_or_else(|| default_out(&args.image, args.bits));
    write_codes_png(&out, w, h, args.bits, &stim.codes).map_err(anyhow::Error::msg)?;
    let (raw, raw_sidecar) = if matches!(args.bits, 10 | 12) {
        let raw = out.with_extension("raw");
        let side = write_codes_raw(&raw, w, h, args.bits, &stim.codes).map_err(anyhow::Error::msg)?;
        (Some(raw.display().to_string()), Some(side.display().to_string()))
    } else {
        (None, None)
    };
    let intended = Summary::of(&stim.delta_e00_intended);
    let map_scale = if intended.max > 0.0 { intended.max } else { 1.0 };
    let map_figure = match &args.map {
        Some(map) => {
            let png = write_delta_e_map(map, w, h, &stim.delta_e00_intended, map_scale).map_err(anyhow::Error::msg)?;
            let figure = map.with_extension("svg");
            let notes = [
                format!(
                    "CIEDE2000 of each pixel: the colour intended against the colour the {}-bit codes show.",
                    args.bits
                ),
                format!(
                    "0 is dark, {} (the image's largest) yellow; gamut policy {}.",
                    tick_label(map_scale, map_scale),
                    format!("{:?}", args.gamut).to_lowercase()
                ),
                format!(
                    "White: the display's (all channels at full drive). Observer: {}. Display profile: {}.",
                    profile.observer, profile_name
                ),
            ];
            let svg = false_colour_map_svg(&FalseColourMap {
                png: &png,
                width: w,
                height: h,
                scale_max: map_scale,
                quantity: "ΔE00",
                title: &format!(
                    "ΔE00 intended vs shown: {} at {} bits",
                    args.image
                        .file_name()
                        .map_or(args.image.display().to_string(), |n| n.to_string_lossy().into_owned()),
                    args.bits
                ),
                notes: &notes,
            })
            .map_err(anyhow::Error::msg)?;
            std::fs::write(&figure, svg).with_context(|| format!("writing {}", figure.display()))?;
            Some(figure.display().to_string())
        }
        None => None,
    };
    let white = profile.white_xyz()?;
    let report = StimulusReport {
        image: args.image.display().to_string(),
        xyz_source: image.source.clone(),
        width: w,
        height: h,
        display_profile: profile_name,
        observer: profile.observer.to_string(),
        bits: args.bits,
        transfer: transfer_name(args.transfer),
        delta_e00_white: white.to_array(),
        delta_e00_white_is: "the display's white: all channels at full drive, black included",
        gamut: stim.gamut.clone(),
        delta_e00_intended_vs_shown: intended,
        delta_e00_original_vs_shown: Summary::of(&stim.delta_e00_original),
        quantisation_bound_delta_e00: quantisation_bound_de00(&profile, fb, args.transfer)?,
        png: out.display().to_string(),
        png_code_alignment: format!("16-bit PNG, each code MSB-aligned: code << {}", 16 - args.bits),
        raw,
        raw_sidecar,
        map: args.map.as_ref().map(|p| p.display().to_string()),
        map_scale_max_delta_e00: args.map.as_ref().map(|_| map_scale),
        map_figure,
    };
    if let Some(path) = &args.report {
        std::fs::write(path, serde_json::to_string_pretty(&report)?)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    print_summary(&report);
    Ok(())
}

fn print_summary(r: &StimulusReport) {
    println!(
        "{} ({} × {}, XYZ from {}) on {} at {} bits, transfer {}",
        r.image, r.width, r.height, r.xyz_source, r.display_profile, r.bits, r.transfer
    );
    let g = &r.gamut;
    print!(
        "gamut: {} of {} pixels out ({:.2} %), policy {:?}",
        g.out_of_gamut,
        g.colours,
        100.0 * g.fraction,
        g.policy
    );
    if g.scale_factor != 1.0 {
        print!(", scale factor {:.4}", g.scale_factor);
    }
    if let Some(w) = &g.worst {
        print!(
            "; worst pixel {} (x {}, y {}): channel excess {:.4}, ΔE00 {:.2} when clipped",
            w.index,
            w.index % r.width.max(1) as usize,
            w.index / r.width.max(1) as usize,
            w.excess,
            w.delta_e00_clipped
        );
    }
    println!();
    let line =
        |name: &str, s: &Summary| println!("ΔE00 {name}: mean {:.4}, p95 {:.4}, max {:.4}", s.mean, s.p95, s.max);
    line("intended vs shown", &r.delta_e00_intended_vs_shown);
    line("original vs shown", &r.delta_e00_original_vs_shown);
    println!(
        "quantisation bound at {} bits: ΔE00 {:.4} (white: the display's, Y {:.2} cd/m²)",
        r.bits, r.quantisation_bound_delta_e00, r.delta_e00_white[1]
    );
    let mut files = vec![r.png.clone()];
    files.extend(r.raw.iter().cloned());
    files.extend(r.raw_sidecar.iter().cloned());
    files.extend(r.map.iter().cloned());
    files.extend(r.map_figure.iter().cloned());
    println!("wrote {}", files.join(", "));
}

/// The report of an image with a layer per coding (`--image-coding` of
/// `lightbooth render`): every coding through the display together, each
/// against the reference (see `lightbooth::display::image_set`).
#[derive(Serialize)]
struct SetReport {
    image: String,
    width: u32,
    height: u32,
    display_profile: String,
    observer: String,
    bits: u32,
    transfer: &'static str,
    delta_e00_white_is: &'static str,
    set: ImageSet,
    /// Per coding, the PNG of its codes at `bits`.
    pngs: Vec<(String, String)>,
    png_code_alignment: String,
}

/// `stimulus` on a layered image: the set's report and each coding's codes.
fn run_set(
    args: &StimulusArgs,
    profile: &DisplayProfile,
    profile_name: String,
    layers: XyzLayers,
) -> anyhow::Result<()> {
    let file = args.image.display();
    anyhow::ensure!(
        args.map.is_none(),
        "{file} has a layer per coding ({}): --map draws one image's quantisation; run `stimulus` on a \
         single-coding render for its map (the set's ΔE00 against the reference is in the report)",
        layers
            .layers
            .iter()
            .map(|(c, _)| c.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    );
    let fb = FrameBuffer::new(args.bits)?;
    let reference = match &layers.reference {
        Some(r) => layers
            .layers
            .iter()
            .position(|(c, _)| c == r)
            .expect("checked by the reader"),
        None => layers.layers.len() - 1,
    };
    let (w, h) = (layers.layers[0].1.width, layers.layers[0].1.height);
    let codings: Vec<(String, Vec<[f64; 3]>)> = layers.layers.into_iter().map(|(c, img)| (c, img.xyz)).collect();
    let set = image_set(profile, &codings, reference, args.gamut)?;
    let out = args.out.clone().unwrap_or_else(|| default_out(&args.image, args.bits));
    let mut pngs = Vec::new();
    for ((coding, _), linear) in codings.iter().zip(&set.linear) {
        let codes: Vec<[u32; 3]> = linear
            .iter()
            .map(|l| profile.codes_of_linear(l.map(f64::from), fb, args.transfer))
            .collect();
        let stem = out.file_stem().and_then(|s| s.to_str()).unwrap_or("stimulus");
        let png = out.with_file_name(format!("{stem}.{coding}.png"));
        write_codes_png(&png, w, h, args.bits, &codes).map_err(anyhow::Error::msg)?;
        pngs.push((coding.clone(), png.display().to_string()));
    }
    let report = SetReport {
        image: file.to_string(),
        width: w,
        height: h,
        display_profile: profile_name,
        observer: profile.observer.to_string(),
        bits: args.bits,
        transfer: transfer_name(args.transfer),
        delta_e00_white_is: "the display's white: all channels at full drive, black included",
        set,
        pngs,
        png_code_alignment: format!("16-bit PNG, each code MSB-aligned: code << {}", 16 - args.bits),
    };
    if let Some(path) = &args.report {
        std::fs::write(path, serde_json::to_string_pretty(&report)?)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    let s = &report.set;
    println!(
        "{} ({} × {}, {} codings, reference {}) on {}; gamut policy {:?}: {} of {} colours out",
        report.image,
        w,
        h,
        s.codings.len(),
        s.reference,
        report.display_profile,
        s.policy,
        s.gamut.out_of_gamut,
        s.gamut.colours
    );
    println!(
        "ΔE00 (white: the display's, Y {:.2} cd/m²) against {}, mean / p95 per pixel:",
        s.white[1], s.reference
    );
    let outputs: Vec<&str> = OUTPUTS.iter().map(|o| o.0).collect();
    println!(
        "{:<10} {:>15} {:>15}  {}",
        "coding",
        "rendered",
        "intended",
        outputs.join(" / ")
    );
    for c in &s.codings {
        let Some(a) = &c.against_reference else { continue };
        let shown: Vec<String> = a
            .shown
            .iter()
            .map(|o| format!("{:.3}/{:.3}", o.delta_e00.mean, o.delta_e00.p95))
            .collect();
        println!(
            "{:<10} {:>15} {:>15}  {}",
            c.coding,
            format!("{:.3}/{:.3}", a.rendered.mean, a.rendered.p95),
            format!("{:.3}/{:.3}", a.intended.mean, a.intended.p95),
            shown.join("  ")
        );
    }
    let bounds: Vec<String> = s
        .quantisation_bound
        .iter()
        .map(|(b, v)| format!("{b} bits {v:.3}"))
        .collect();
    println!("quantisation bound (worst half code): {}", bounds.join(", "));
    println!(
        "wrote {}",
        report
            .pngs
            .iter()
            .map(|(_, p)| p.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(())
}
