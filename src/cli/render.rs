//! `lightbooth render SCENE.toml`: the built-in renderer, every colour coding
//! in one pass, measured at the scene's targets by the simulated radiometer.
//! `lightbooth render SCENE.rad --radiometer X,Y,Z --target NAME=X,Y,Z …`
//! renders a RADIANCE scene file, which has no radiometer or targets of its own.

use std::io::IsTerminal;
use std::path::PathBuf;

use anyhow::Context;
use clap::Args;

use lightbooth::colorimetry::Observer;
use lightbooth::colorimetry::Xyz;
use lightbooth::export::image::write_camera_images;
use lightbooth::render::camera::{render_camera_images, CameraProgress, CameraSettings, PairedDifference};
use lightbooth::render::scene::{
    load_radiance_scene, RadianceView, MAX_BOUNCES, MAX_PIXEL_SAMPLES, MAX_SAMPLES_PER_TARGET,
};
use lightbooth::render::sensor::render_camera;
use lightbooth::render::{
    load_scene, render, samples_rounding_note, Coding, LightSampling, RenderResult, RenderSettings, SamplerKind,
    DEFAULT_ROULETTE_FROM,
};

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// The scene file: TOML, or a RADIANCE .rad file (then with --radiometer and --target).
    scene: PathBuf,
    /// For a .rad scene: the radiometer's position X,Y,Z in metres (the .rad's coordinates).
    #[arg(long, value_parser = parse_point, allow_hyphen_values = true)]
    radiometer: Option<[f64; 3]>,
    /// For a .rad scene: a measurement target NAME=X,Y,Z (a point on a surface, m); repeat for more.
    #[arg(long = "target", value_parser = parse_target, allow_hyphen_values = true)]
    target: Vec<(String, [f64; 3])>,
    /// For a .rad scene: the radiometer's full field angle, degrees.
    #[arg(long, default_value_t = 1.0, value_parser = field_angle)]
    field_deg: f64,
    /// Colour codings, comma-separated: rgb, srgb, nstepN (1 ≤ N ≤ 81), spectral.
    #[arg(long, value_delimiter = ',', value_parser = parse_coding,
          default_value = "rgb,srgb,nstep3,nstep9,nstep27,nstep81,spectral")]
    codings: Vec<Coding>,
    /// Radiometer paths per target (the first round with --target-se),
    /// 1–16777216, traced in whole batches of 1024: a count between is
    /// rounded up, and the output says so.
    #[arg(long, default_value_t = RenderSettings::default().samples,
          value_parser = clap::value_parser!(u64).range(1..=MAX_SAMPLES_PER_TARGET))]
    samples: u64,
    /// Cap paths at this many indirect bounces, 0–64 (`--bounces 5` emulates
    /// RADIANCE -ab 5; the output then says "truncated at N bounces").
    /// Default: no cap, Russian roulette ends the paths (unbiased).
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=i64::from(MAX_BOUNCES)))]
    bounces: Option<u32>,
    /// Random seed: the same seed gives the same numbers on any number of threads.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Only these targets (comma-separated ids).
    #[arg(long, value_delimiter = ',')]
    targets: Option<Vec<String>>,
    /// Worker threads, 1–1024 (default: one per core).
    #[arg(long, value_parser = super::threads)]
    threads: Option<usize>,
    /// Unbiased Russian roulette from this bounce on, 0–64, or `never` (only
    /// with --bounces).
    #[arg(long, default_value_t = RouletteFrom(Some(DEFAULT_ROULETTE_FROM)), value_parser = parse_roulette)]
    russian_roulette_from: RouletteFrom,
    /// Also render the scene's [camera] view: .pfm (linear HDR), .png
    /// (tone-mapped sRGB), or, in every --image-coding with XYZ, LMS and
    /// standard errors, .exr (spectral OpenEXR, a layer per coding), .mat
    /// (MATLAB) or .bsq (ENVI, with .hdr; a file per coding).
    #[arg(long)]
    image: Option<PathBuf>,
    /// The --image's size in pixels, WIDTHxHEIGHT (1–16384 each; default
    /// the scene's [camera]); the camera's vertical field of view is kept.
    #[arg(long, value_parser = parse_image_size)]
    image_size: Option<(u32, u32)>,
    /// Paths per pixel for --image (the cap with --image-se), 1–65536.
    #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u32).range(1..=i64::from(MAX_PIXEL_SAMPLES)))]
    spp: u32,
    /// The codings of --image, comma-separated, every one rendered from the
    /// same paths: spectral (401 1 nm bands), nstepN, rgb or srgb. Each is
    /// compared with the reference (the last, or --image-reference): ΔE00
    /// per pixel, with the difference's own noise from the paired paths.
    #[arg(long, alias = "coding", value_delimiter = ',', default_value = "spectral", value_parser = parse_coding)]
    image_coding: Vec<Coding>,
    /// The --image-coding every other is compared with, and whose SE(Y)
    /// --image-se stops on (default: the last listed).
    #[arg(long, value_parser = parse_coding)]
    image_reference: Option<Coding>,
    /// With --image-se: stop a pixel only when every coding's SE(Y) meets
    /// it, not only the reference's.
    #[arg(long)]
    image_se_every_coding: bool,
    /// The spectral grid of an --image file in the `spectral` coding, nm
    /// (1–100): every Nth 1 nm band (380, 385, … 780 nm with 5, the
    /// instrument's grid), their own values, not averaged; X, Y, Z, L, M, S
    /// still from all 401 bands. Default 1 (all 401 bands).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=100))]
    image_step: u32,
    /// Render --image in passes until every pixel's standard error of Y (in
    /// the reference coding, or every coding with --image-se-every-coding)
    /// is below this fraction of its Y (or --spp paths, or --time-budget); 0: exactly --spp.
    #[arg(long, default_value_t = 0.0, value_parser = super::fraction)]
    image_se: f64,
    /// Stop --image's passes after this many seconds (checked between passes).
    #[arg(long)]
    time_budget: Option<f64>,
    /// After the render, render all codings and each coding alone with
    /// exactly --samples paths per target, 3 times each in rotated order
    /// after a warm-up, and report the median wall times and their spread
    /// (`coding_wall_seconds`, `coding_cost` in the JSON): the cost of each coding.
    #[arg(long)]
    time_each_coding: bool,
    /// Random numbers: sobol (scrambled, stratified; SE from batch means) or independent.
    #[arg(long, default_value = "sobol", value_parser = parse_sampler)]
    sampler: SamplerKind,
    /// How each vertex's direct-light estimate chooses its one light: power
    /// (probability proportional to luminous flux) or uniform (1/n).
    #[arg(long, default_value = "power", value_parser = parse_light_sampler)]
    light_sampler: LightSampling,
    /// Keep sampling each target until the standard error of Y is below this
    /// fraction of Y in every coding, up to --max-samples; 0: exactly --samples.
    #[arg(long, default_value_t = 0.003, value_parser = super::fraction)]
    target_se: f64,
    /// Cap on paths per target with --target-se, 1–16777216 (rounded up to
    /// whole batches of 1024, as --samples).
    #[arg(long, default_value_t = RenderSettings::default().max_samples,
          value_parser = clap::value_parser!(u64).range(1..=MAX_SAMPLES_PER_TARGET))]
    max_samples: u64,
    /// The observer of every XYZ, x,y and Y: judd-vos-1978 (the study's), cie-1931, cie-1964-10, cie-2015-2 or cie-2015-10.
    #[arg(long, default_value = "judd-vos-1978")]
    observer: Observer,
    /// Print the results as JSON.
    #[arg(long)]
    json: bool,
}

fn parse_point(s: &str) -> Result<[f64; 3], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|c| c.trim().parse::<f64>().map_err(|_| format!("`{c}` is not a number")))
        .collect::<Result<_, _>>()?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok([x, y, z]),
        _ => Err(format!("`{s}`: expected X,Y,Z (three finite numbers, metres)")),
    }
}

fn parse_target(s: &str) -> Result<(String, [f64; 3]), String> {
    let (name, point) = s.split_once('=').ok_or_else(|| format!("`{s}`: expected NAME=X,Y,Z"))?;
    if name.trim().is_empty() {
        return Err(format!("`{s}`: the target needs a name before `=`"));
    }
    Ok((name.trim().to_string(), parse_point(point)?))
}

fn parse_image_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X', '×'])
        .ok_or_else(|| format!("`{s}`: expected WIDTHxHEIGHT in pixels, e.g. 960x540"))?;
    let side = |v: &str, what: &str| match v.trim().parse::<u32>() {
        Ok(n) if (1..=16384).contains(&n) => Ok(n),
        _ => Err(format!(
            "`{s}`: the {what} `{v}` is not a whole number of pixels from 1 to 16384"
        )),
    };
    Ok((side(w, "width")?, side(h, "height")?))
}

fn field_angle(s: &str) -> Result<f64, String> {
    super::finite_in(s, 1e-6, 180.0, "degrees, the full angle of the field")
}

/// `--russian-roulette-from`: a bounce, or `never`.
#[derive(Clone, Copy, Debug)]
struct RouletteFrom(Option<u32>);

impl std::fmt::Display for RouletteFrom {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.0 {
            Some(b) => write!(f, "{b}"),
            None => f.write_str("never"),
        }
    }
}

fn parse_roulette(s: &str) -> Result<RouletteFrom, String> {
    if s == "never" {
        return Ok(RouletteFrom(None));
    }
    match s.parse::<u32>() {
        Ok(b) if b <= MAX_BOUNCES => Ok(RouletteFrom(Some(b))),
        _ => Err(format!("`{s}`: expected a bounce 0–{MAX_BOUNCES} or `never`")),
    }
}

fn parse_coding(s: &str) -> Result<Coding, String> {
    s.parse()
}

fn parse_light_sampler(s: &str) -> Result<LightSampling, String> {
    s.parse()
}

fn parse_sampler(s: &str) -> Result<SamplerKind, String> {
    match s {
        "sobol" => Ok(SamplerKind::Sobol),
        "independent" => Ok(SamplerKind::Independent),
        _ => Err(format!("unknown sampler `{s}`: sobol or independent")),
    }
}

pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    let is_rad = args.scene.extension().is_some_and(|e| e.eq_ignore_ascii_case("rad"));
    let scene = if is_rad {
        let radiometer = args.radiometer.with_context(|| {
            format!(
                "{}: a RADIANCE scene has no radiometer: give --radiometer X,Y,Z (m) and at least one \
                 --target NAME=X,Y,Z",
                args.scene.display()
            )
        })?;
        let view = RadianceView {
            radiometer: radiometer.into(),
            field_deg: args.field_deg,
            targets: args.target.iter().map(|(n, p)| (n.clone(), (*p).into())).collect(),
        };
        load_radiance_scene(&args.scene, &view)?
    } else {
        if args.radiometer.is_some() || !args.target.is_empty() {
            anyhow::bail!(
                "--radiometer and --target are for .rad scenes; {} gives its own [radiometer] and [[target]]",
                args.scene.display()
            );
        }
        load_scene(&args.scene)?
    };
    let image_codings = args
        .image_coding
        .iter()
        .map(|c| c.to_string())
        .collect::<Vec<_>>()
        .join(",");
    if args.image_step > 1 && !args.image_coding.contains(&Coding::Spectral) {
        anyhow::bail!(
            "--image-step {} picks bands of the 1 nm `spectral` coding; --image-coding is {image_codings}",
            args.image_step,
        );
    }
    if let Some(r) = args.image_reference {
        if !args.image_coding.contains(&r) {
            anyhow::bail!("--image-reference {r} is not one of --image-coding {image_codings}: add it there");
        }
    }
    if let Some(twice) = args
        .image_coding
        .iter()
        .enumerate()
        .find(|(i, c)| args.image_coding[..*i].contains(c))
    {
        anyhow::bail!("--image-coding names {} twice ({image_codings})", twice.1);
    }
    if args.bounces.is_none() && args.russian_roulette_from.0.is_none() {
        anyhow::bail!(
            "--russian-roulette-from never needs --bounces N: without roulette or a cap a path in a closed scene never ends"
        );
    }
    for note in [
        samples_rounding_note("--samples", args.samples),
        (args.target_se > 0.0)
            .then(|| samples_rounding_note("--max-samples", args.max_samples))
            .flatten(),
    ]
    .into_iter()
    .flatten()
    {
        eprintln!("{note}");
    }
    let settings = RenderSettings {
        codings: args.codings.clone(),
        samples: args.samples,
        max_bounces: args.bounces,
        seed: args.seed,
        russian_roulette_from: args.russian_roulette_from.0,
        targets: args.targets.clone(),
        threads: args.threads,
        sampler: args.sampler,
        light_sampler: args.light_sampler,
        target_relative_se: (args.target_se > 0.0).then_some(args.target_se),
        max_samples: args.max_samples,
        observer: args.observer,
    };
    let bar = progress_bar("{elapsed_precise} [{wide_bar}] {percent}% paths, eta {eta}");
    let progress = |done: u64, total: u64| {
        bar.set_length(total);
        bar.set_position(done);
    };
    let result = render(&scene, &settings, Some(&progress), None)?;
    bar.finish_and_clear();

    // The cost of each coding: every coding rendered alone, and all together,
    // with the same fixed path count (`--samples` per target, no adaptive
    // rounds), so the times compare like with like.
    let mut coding_times: Vec<(String, lightbooth::render::cost::TimedRender)> = Vec::new();
    if args.time_each_coding {
        let fixed = RenderSettings {
            target_relative_se: None,
            ..settings.clone()
        };
        let mut names = vec!["all".to_string()];
        let mut runs = vec![fixed.clone()];
        for c in &settings.codings {
            names.push(c.to_string());
            runs.push(RenderSettings {
                codings: vec![*c],
                ..fixed.clone()
            });
        }
        let timed =
            lightbooth::render::cost::time_renders(&scene, &runs, lightbooth::render::cost::TIMING_REPEATS, None)?;
        coding_times = names.into_iter().zip(timed).collect();
    }
    let mut image_json: Option<serde_json::Value> = None;
    if let Some(path) = &args.image {
        let mut camera = scene
            .camera
            .clone()
            .with_context(|| format!("{} has no [camera] for --image", args.scene.display()))?;
        if let Some((width, height)) = args.image_size {
            camera.width = width;
            camera.height = height;
        }
        let camera = &camera;
        let transport = settings.transport();
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        let preview = matches!(ext.as_str(), "pfm" | "png") && args.image_se == 0.0 && args.time_budget.is_none();
        if preview {
            let img = render_camera(&scene, camera, Coding::Srgb, args.spp, &transport, settings.seed, None)?;
            img.write(path)?;
            eprintln!(
                "image: {} × {} in srgb, {} paths per pixel; wrote {}",
                camera.width,
                camera.height,
                args.spp,
                path.display()
            );
        } else {
            let budget = match args.time_budget {
                Some(t) if !(t.is_finite() && t > 0.0) => anyhow::bail!("--time-budget {t}: need seconds > 0"),
                t => t.map(std::time::Duration::from_secs_f64),
            };
            let cam_settings = CameraSettings {
                codings: args.image_coding.clone(),
                reference: args.image_reference,
                se_every_coding: args.image_se_every_coding,
                observer: settings.observer,
                transport,
                seed: settings.seed,
                min_spp: args.spp.min(16),
                first_sample: 0,
                max_spp: args.spp,
                target_relative_se: (args.image_se > 0.0).then_some(args.image_se),
                time_budget: budget,
            };
            let cam_bar = progress_bar("{elapsed_precise} [{wide_bar}] {msg}");
            let report = |p: CameraProgress| {
                cam_bar.set_length(p.pixels);
                cam_bar.set_position(p.pixels_done);
                cam_bar.set_message(format!(
                    "pass {}: {}/{} pixels done, {} paths",
                    p.pass, p.pixels_done, p.pixels, p.paths
                ));
            };
            let images = render_camera_images(&scene, camera, &cam_settings, Some(&report), None)?;
            cam_bar.finish_and_clear();
            // What the summary and the JSON say of the render, taken before
            // the images go to the writer (which takes them by value: no
            // copy of a seven-coding image).
            let reference = images.reference_image();
            let (width, height, reference_coding) = (reference.width, reference.height, reference.coding);
            let codings: Vec<String> = images.images.iter().map(|i| i.coding.to_string()).collect();
            let done = format!(
                "{} passes, {} paths, {:.1} s, stopped: {:?}",
                reference.passes, reference.paths, reference.elapsed_seconds, reference.stop
            );
            let mut summary = serde_json::json!({
                "width": width,
                "height": height,
                "codings": codings,
                "reference": reference_coding.to_string(),
                "passes": reference.passes,
                "paths": reference.paths,
                "elapsed_seconds": reference.elapsed_seconds,
                "stop": reference.stop,
            });
            // A white only where there is something to compare with the reference.
            let white = match images.images.len() {
                1 => None,
                _ => image_white(&args, &scene, &settings, reference_coding)?,
            };
            let differences: Vec<PairedDifference> = match &white {
                Some((xyz, _)) => (0..images.images.len())
                    .filter(|&c| c != images.reference)
                    .map(|c| images.difference(c, *xyz))
                    .collect(),
                None => Vec::new(),
            };
            let written = if matches!(ext.as_str(), "pfm" | "png") {
                images.reference_image().to_srgb().write(path)?;
                eprintln!(
                    "image: {width} × {height} in srgb from the {reference_coding} coding, {done}; wrote {}",
                    path.display()
                );
                vec![path.display().to_string()]
            } else {
                let images = images
                    .every_nth_band(args.image_step as usize)
                    .map_err(|e| anyhow::anyhow!("--image-step: {e}"))?;
                let written = write_camera_images(&images, path).map_err(anyhow::Error::msg)?;
                let files: Vec<String> = written.iter().map(|p| p.display().to_string()).collect();
                let described: Vec<String> = images
                    .images
                    .iter()
                    .map(|img| match lightbooth::export::image::spectral_step_nm(img) {
                        Some(step) if img.coding == Coding::Spectral => {
                            format!(
                                "{} ({} bands, every {step} nm)",
                                img.coding, img.quantities.coding_channels
                            )
                        }
                        _ => img.coding.to_string(),
                    })
                    .collect();
                eprintln!(
                    "image: {width} × {height} in {}, {done}; wrote {}",
                    described.join(", "),
                    files.join(", ")
                );
                files
            };
            match &white {
                Some((xyz, source)) => {
                    eprintln!(
                        "image ΔE00 against {reference_coding} (CIELAB white: {source}, Y {:.4} cd/m²; paired: from the same paths):",
                        xyz.y
                    );
                    for d in &differences {
                        eprintln!("  {}", difference_line(d));
                    }
                }
                None if codings.len() > 1 => eprintln!(
                    "image ΔE00: none, {} declares no [cielab_white] to compare the codings in",
                    args.scene.display()
                ),
                None => {}
            }
            summary["files"] = serde_json::json!(written);
            summary["white"] = serde_json::json!(white
                .as_ref()
                .map(|(xyz, source)| serde_json::json!({"XYZ": xyz.to_array(), "source": source})));
            summary["differences"] = serde_json::json!(differences);
            summary["noise_method"] = IMAGE_NOISE_METHOD.into();
            image_json = Some(summary);
        }
    }

    if args.json {
        let mut v = serde_json::to_value(&result)?;
        if let Some(image) = image_json {
            v["image"] = image;
        }
        if !coding_times.is_empty() {
            let m: serde_json::Map<String, serde_json::Value> = coding_times
                .iter()
                .map(|(k, t)| (k.clone(), serde_json::json!(t.median_seconds())))
                .collect();
            v["coding_wall_seconds"] = serde_json::Value::Object(m);
            let cost: serde_json::Map<String, serde_json::Value> =
                coding_times.iter().map(|(k, t)| (k.clone(), t.cost_json())).collect();
            v["coding_cost"] = serde_json::Value::Object(cost);
            v["cost_definition"] = lightbooth::lab::study::run::COST_DEFINITION.into();
        }
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        print_table(&result);
        if !coding_times.is_empty() {
            println!("cost: {}", lightbooth::render::cost::TIMING_METHOD);
        }
        for (c, t) in coding_times {
            println!(
                "{c} alone: {} rays, {} paths, {:.3} s ({:.3}–{:.3} s)",
                t.result.rays,
                t.result.paths,
                t.median_seconds(),
                t.fastest_seconds(),
                t.slowest_seconds()
            );
        }
    }
    Ok(())
}

/// A progress bar on a terminal's stderr, hidden otherwise.
fn progress_bar(template: &str) -> indicatif::ProgressBar {
    if std::io::stderr().is_terminal() {
        let b = indicatif::ProgressBar::new(0);
        b.set_style(
            indicatif::ProgressStyle::with_template(template)
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    } else {
        indicatif::ProgressBar::hidden()
    }
}

fn print_table(r: &RenderResult) {
    println!(
        "{} ({}): {} paths in {:.3} s ({:.3e} paths/s, {:.3e} rays/s); observer {}",
        r.scene, r.scene_file, r.paths, r.wall_seconds, r.paths_per_second, r.rays_per_second, r.observer
    );
    println!(
        "{:<10} {:<9} {:>12} {:>9} {:>8} {:>8}",
        "target", "coding", "Y cd/m²", "SE %", "x", "y"
    );
    for t in &r.targets {
        for (name, c) in &t.codings {
            println!(
                "{:<10} {:<9} {:>12.4} {:>9.3} {:>8.4} {:>8.4}",
                t.id,
                name,
                c.luminance_cd_m2,
                100.0 * c.luminance_se_cd_m2 / c.luminance_cd_m2.abs().max(f64::MIN_POSITIVE),
                c.x,
                c.y
            );
        }
    }
    if let Some(note) = &r.truncation_note {
        println!("note: {note}");
    }
    if !r.synthesised_spectra.is_empty() {
        println!(
            "note: {} — for {}",
            r.synthesis_method.unwrap_or_default(),
            r.synthesised_spectra.join(", ")
        );
    }
    for (name, d) in &r.deviation_from_spectral {
        println!(
            "{name} vs spectral: mean ΔY/Y {:+.2} %, rms {:.2} %",
            100.0 * d.mean_rel,
            100.0 * d.rms_rel
        );
    }
}

/// How the image differences' noise is found, beside the numbers.
const IMAGE_NOISE_METHOD: &str = "se_mean: standard error of the mean ΔE00 from the paired paths (an upper bound); \
noise_paired: RMS over pixels of the ΔE00 the paths' noise alone puts between the two codings' pixel means, \
rendered from the same paths; noise_independent: the same had each coding been rendered from its own paths \
(local quadratic form of ΔE00 in XYZ)";

/// One coding against the reference, in a line.
fn difference_line(d: &PairedDifference) -> String {
    format!(
        "{:<9} mean {:.4} ± {:.2e} (SE), p95 {:.4}, max {:.4}; noise {:.2e} paired, {:.2e} from independent paths",
        d.coding, d.mean, d.se_mean, d.p95, d.max, d.noise_paired, d.noise_independent
    )
}

/// The CIELAB white of the image's ΔE00, from the scene's `[cielab_white]`
/// and where it came from: a target white is rendered here, in the
/// reference coding with the run's settings (no booth measurement is at
/// hand on the command line); `None` when the scene declares none.
fn image_white(
    args: &RenderArgs,
    scene: &lightbooth::render::Scene,
    settings: &RenderSettings,
    reference: Coding,
) -> anyhow::Result<Option<(Xyz, String)>> {
    use lightbooth::lab::compare::white::{scene_white, SceneWhite};
    if scene.cielab_white.is_none() {
        return Ok(None);
    }
    match scene_white(&args.scene, scene, settings.observer).map_err(anyhow::Error::msg)? {
        SceneWhite::Fixed { xyz, source } => Ok(Some((xyz, source))),
        SceneWhite::Target {
            scene_id,
            scene_path,
            target,
        } => {
            let white_scene = if scene_path == args.scene {
                scene.clone()
            } else {
                load_scene(&scene_path)?
            };
            let one = RenderSettings {
                codings: vec![reference],
                targets: Some(vec![target.clone()]),
                ..settings.clone()
            };
            let r = render(&white_scene, &one, None, None)?;
            let c = r
                .targets
                .first()
                .and_then(|t| t.coding(&reference.to_string()))
                .with_context(|| format!("{}: the white's target {target} was not rendered", scene_path.display()))?;
            Ok(Some((
                Xyz::from_array(c.xyz),
                format!("{scene_id}'s target {target} as rendered here in {reference}"),
            )))
        }
    }
}
