//! `lightbooth analyze …`: analyses of spectra alone, and the automatic
//! choice of render settings for a scene (`analyze auto`).

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use clap::{Args, Subcommand};

use lightbooth::lab::study::failure_map::{failure_map, Crossing, FailureMap, FailureMapSettings};
use lightbooth::nstep::nstep_error;
use lightbooth::reference_data::{reflectances, ReflectanceSet};
use lightbooth::spectrum::{table::SpectraTable, Grid, SpectralUnit, Spectrum};

#[derive(Subcommand, Debug)]
pub enum AnalyzeCommand {
    /// The study's Fig. 7: N-step reconstruction error of colour signals for N = 1…81,
    /// normalised so N = 1 is 1.0.
    NstepError(NstepErrorArgs),
    /// Where each coding crosses ΔE*ab = 2 and rms_rel = 5 %: ColorChecker × {A, D65, F2, F11}
    /// (exact, direct light) and CYLINDER with its card's reflectance scaled 0.25–1 (rendered per seed).
    FailureMap(FailureMapArgs),
    /// The cheapest settings (nstepN, bounces, samples) that meet a tolerance against the
    /// converged spectral answer for this scene, why, and a render that checks it.
    Auto(AutoArgs),
}

#[derive(Args, Debug)]
pub struct AutoArgs {
    /// The scene file.
    scene: std::path::PathBuf,
    /// `de00=1,rms=0.02` (rms also as `2%`), or the short form `1,2%` (ΔE00, rms_rel).
    #[arg(long, default_value = "de00=1,rms=0.02")]
    tolerance: String,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Skip the verification render against the converged spectral reference.
    #[arg(long)]
    no_verify: bool,
    /// Also render the speed/accuracy candidates and write the chart (SVG) here.
    #[arg(long)]
    svg: Option<std::path::PathBuf>,
    /// The whole choice (and verification, candidates) as JSON.
    #[arg(long)]
    json: bool,
}

#[derive(Args, Debug)]
pub struct FailureMapArgs {
    /// The CYLINDER scene (default: scenes/cylinder.toml here, else in the source tree).
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Monte Carlo seeds 1…N for the interreflection sweep, 2–64.
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u64).range(..=64))]
    seeds: u64,
    /// Radiometer paths per target per render (rounded up to whole
    /// batches of 1024, and the output says so).
    #[arg(long, default_value_t = 4096,
          value_parser = clap::value_parser!(u64).range(1..=lightbooth::render::scene::MAX_SAMPLES_PER_TARGET))]
    samples: u64,
    /// Print the whole map as JSON instead of the summary tables.
    #[arg(long)]
    json: bool,
    /// Write every number to this CSV file (long form).
    #[arg(long)]
    csv: Option<PathBuf>,
    /// Write the charts (SVG) into this directory.
    #[arg(long)]
    svg_dir: Option<PathBuf>,
}

#[derive(Args, Debug)]
pub struct NstepErrorArgs {
    /// colorchecker, munsell, natural, or a CSV of reflectances (380–780 nm at least).
    #[arg(long)]
    reflectances: String,
    /// A, D65, F2, F11, E, or FILE.csv[:COLUMN] (relative power, 380–780 nm at least).
    #[arg(long)]
    illuminant: String,
    /// `{"n":[…],"error":[…]}` instead of a table.
    #[arg(long)]
    json: bool,
}

pub fn run(cmd: AnalyzeCommand) -> anyhow::Result<()> {
    match cmd {
        AnalyzeCommand::NstepError(args) => nstep_error_cmd(args),
        AnalyzeCommand::FailureMap(args) => failure_map_cmd(args),
        AnalyzeCommand::Auto(args) => auto_cmd(args),
    }
}

fn auto_cmd(args: AutoArgs) -> anyhow::Result<()> {
    use lightbooth::lab::study::auto::{candidate_set, choose_settings, reference_render, verify, Tolerance};
    let tol: Tolerance = args.tolerance.parse()?;
    let scene = lightbooth::render::load_scene(&args.scene)?;
    let choice = choose_settings(&scene, &tol, args.seed, None)?;
    let reference = if args.no_verify && args.svg.is_none() {
        None
    } else {
        Some(reference_render(&scene, &choice, None)?)
    };
    let verification = match &reference {
        Some(r) if !args.no_verify => Some(verify(&scene, &choice, r, None)?),
        _ => None,
    };
    let candidates = match (&args.svg, &reference) {
        (Some(path), Some(r)) => {
            let bounces: Vec<u32> = [0, choice.bounces, choice.bounces + 2]
                .into_iter()
                .collect::<std::collections::BTreeSet<_>>()
                .into_iter()
                .collect();
            let set = candidate_set(&scene, &choice, r, &bounces, 2, None)?;
            std::fs::write(path, &set.svg)?;
            Some(set)
        }
        _ => None,
    };
    if args.json {
        let out = serde_json::json!({
            "choice": choice,
            "verification": verification,
            "candidates": candidates,
        });
        println!("{}", serde_json::to_string_pretty(&out)?);
        return Ok(());
    }
    println!(
        "{}: {} with {} bounces and {} samples per target (tolerance {tol})",
        choice.scene, choice.coding, choice.bounces, choice.samples
    );
    for r in &choice.reasons {
        println!("  - {r}");
    }
    println!(
        "  predicted: spectral ΔE00 ≤ {:.3}, rms_rel ≤ {:.3} % (spectral {:.3} % + bounces {:.3} % + noise {:.3} %); \
         choosing took {:.2} s",
        choice.predicted.spectral_de00,
        100.0 * choice.predicted.rms_rel_bound,
        100.0 * choice.predicted.spectral_rel_y,
        100.0 * choice.predicted.bounce_tail_rel,
        100.0 * choice.predicted.relative_se,
        choice.choosing_seconds
    );
    if let Some(v) = &verification {
        println!(
            "verification against spectral (white: target {}): rms_rel {:.3} %, ΔE00 mean {:.3} max {:.3}, \
             {:.2} s (reference {:.2} s), noise alone {:.3} % → {}",
            v.white_target,
            100.0 * v.rms_rel,
            v.mean_de00,
            v.max_de00,
            v.wall_seconds,
            v.reference_wall_seconds,
            100.0 * v.noise_rms_rel,
            if v.meets {
                "meets the tolerance"
            } else {
                "DOES NOT meet the tolerance"
            }
        );
    }
    if let (Some(set), Some(path)) = (&candidates, &args.svg) {
        println!(
            "{:<22} {:>9} {:>9} {:>8} {:>7}  front",
            "candidate", "seconds", "rms_rel%", "maxΔE00", "error"
        );
        for c in &set.candidates {
            println!(
                "{:<22} {:>9.3} {:>9.3} {:>8.3} {:>7.3}  {}",
                c.label,
                c.wall_seconds,
                100.0 * c.rms_rel,
                c.max_de00,
                c.error,
                if c.on_front { "*" } else { "" }
            );
        }
        println!(
            "auto on the Pareto front (within timing noise {:.3} s and error noise): {}; chart: {}",
            set.timing_noise_seconds,
            set.auto_on_front_within_noise,
            path.display()
        );
    }
    Ok(())
}

fn nstep_error_cmd(args: NstepErrorArgs) -> anyhow::Result<()> {
    let grid = Grid::analysis();
    let refl: Vec<Spectrum> = match args.reflectances.parse::<ReflectanceSet>() {
        Ok(set) => reflectances(set).iter().map(|(_, s)| s.clone()).collect(),
        Err(_) if args.reflectances.ends_with(".csv") => {
            let table = SpectraTable::read(std::path::Path::new(&args.reflectances))?;
            table.require_range(380.0, 780.0)?;
            table
                .spectra(SpectralUnit::Reflectance)?
                .into_iter()
                .map(|(_, s)| s.resample(&grid))
                .collect::<Result<_, _>>()?
        }
        Err(e) => anyhow::bail!("{e}, or a FILE.csv"),
    };
    let illuminant = super::load_illuminant(&args.illuminant)?;
    if !illuminant.grid().covers(380.0, 780.0) {
        anyhow::bail!(
            "illuminant {}: its grid {} does not cover 380–780 nm",
            args.illuminant,
            illuminant.grid()
        );
    }
    let illuminant = illuminant.resample(&grid)?;
    let curve = nstep_error(&refl, &illuminant).map_err(anyhow::Error::msg)?;
    if args.json {
        println!("{}", serde_json::to_string(&curve)?);
    } else {
        println!("{:>3} {:>10}", "N", "error");
        for (n, e) in curve.n.iter().zip(&curve.error) {
            println!("{n:>3} {e:>10.6}");
        }
    }
    Ok(())
}

fn failure_map_cmd(args: FailureMapArgs) -> anyhow::Result<()> {
    let scene = args.scene.unwrap_or_else(|| {
        let here = PathBuf::from("scenes/cylinder.toml");
        if here.exists() {
            here
        } else {
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/cylinder.toml")
        }
    });
    let mut settings = FailureMapSettings::cylinder(&scene);
    settings.seeds = (1..=args.seeds).collect();
    settings.samples = args.samples;
    if let Some(note) = lightbooth::render::samples_rounding_note("--samples", args.samples) {
        eprintln!("{note}");
    }
    let start = Instant::now();
    let map = failure_map(&settings, None)?;
    eprintln!("failure map: {:.2} s", start.elapsed().as_secs_f64());
    if let Some(path) = &args.csv {
        std::fs::write(path, map.to_csv()).with_context(|| format!("writing {}", path.display()))?;
    }
    if let Some(dir) = &args.svg_dir {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        for (name, svg) in map.svgs().map_err(anyhow::Error::msg)? {
            let path = dir.join(name);
            std::fs::write(&path, svg).with_context(|| format!("writing {}", path.display()))?;
        }
    }
    if args.json {
        println!("{}", serde_json::to_string(&map)?);
    } else {
        print_failure_map(&map);
    }
    Ok(())
}

fn print_failure_map(map: &FailureMap) {
    let ip = &map.illuminant_patch;
    println!(
        "Patches failing ΔE*ab > {} against spectral (of 24), direct light, exact:",
        ip.threshold_de
    );
    print!("{:<10}", "coding");
    for m in &ip.illuminants {
        print!("{:>6}", m.illuminant);
    }
    println!("   least saturated failing patch per illuminant");
    for (ci, coding) in ip.codings.iter().enumerate() {
        print!("{coding:<10}");
        for m in &ip.illuminants {
            print!("{:>6}", m.summary[ci].failing);
        }
        let least: Vec<String> = ip
            .illuminants
            .iter()
            .map(|m| {
                m.summary[ci]
                    .least_saturated_failing
                    .clone()
                    .unwrap_or_else(|| "-".into())
            })
            .collect();
        println!("   {}", least.join(" | "));
    }
    let ir = &map.interreflection;
    let seeds = ir.settings.seeds.len();
    println!(
        "\nInterreflection ({}, card scaled; mean ± SD over {seeds} seeds, {} paths/target):",
        ir.settings.scene.display(),
        ir.settings.samples
    );
    print!("{:<10}", "coding");
    for s in &ir.settings.scales {
        print!("{:>22}", format!("rms_rel % s={s}"));
    }
    println!("{:>16}{:>16}", "crosses 5 % at", "crosses ΔE 2 at");
    for c in &ir.codings {
        print!("{:<10}", c.coding);
        for p in &c.points {
            print!(
                "{:>22}",
                format!("{:.3} ± {:.3}", 100.0 * p.rms_rel.mean, 100.0 * p.rms_rel.sd)
            );
        }
        let show = |x: Crossing| match x {
            Crossing::Never => "never".to_string(),
            Crossing::AtOrBelow { scale } => format!("≤ {scale}"),
            Crossing::At { scale } => format!("{scale:.3}"),
        };
        println!("{:>16}{:>16}", show(c.rms_rel_crossing), show(c.de_crossing));
    }
    print!("{:<10}", "coding");
    for s in &ir.settings.scales {
        print!("{:>22}", format!("mean ΔE*ab s={s}"));
    }
    println!();
    for c in &ir.codings {
        print!("{:<10}", c.coding);
        for p in &c.points {
            print!("{:>22}", format!("{:.3} ± {:.3}", p.mean_de76.mean, p.mean_de76.sd));
        }
        println!();
    }
}
