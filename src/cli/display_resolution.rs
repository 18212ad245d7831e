//! `lightbooth display-resolution SCENE --display PROFILE --codings A,B`:
//! the study's display question — at which frame-buffer depth does the
//! display show the scene's targets differently in the two codings? The
//! targets are rendered as `lightbooth render` renders them (a fixed
//! `--samples` paths per target, so the run is bounded), then compared by
//! `lightbooth::display::resolution` (its module doc defines "resolved").

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use serde::Serialize;

use lightbooth::charts::{line_chart, LineSeriesData};
use lightbooth::display::profile::TransferModel;
use lightbooth::display::resolution::{resolve_pair, PairResolution, NEGLIGIBLE_DE00, RESOLVED_FRACTION};
use lightbooth::display::stimulus::GamutPolicy;
use lightbooth::render::scene::MAX_SAMPLES_PER_TARGET;
use lightbooth::render::{load_scene, render, Coding, RenderSettings};

use super::stimulus::{load_profile, transfer_model, ProfileSource};

#[derive(Args, Debug)]
pub struct DisplayResolutionArgs {
    /// The scene (TOML) whose targets are rendered.
    scene: PathBuf,
    #[command(flatten)]
    profile: ProfileSource,
    /// Two or more codings; each is compared with the last (e.g. nstep27,nstep81).
    #[arg(long, value_delimiter = ',', default_value = "nstep27,nstep81", value_parser = parse_coding)]
    codings: Vec<Coding>,
    /// Frame-buffer depths to compare, 1–16 bits each.
    #[arg(long, value_delimiter = ',', default_value = "6,8,10,12,16", value_parser = clap::value_parser!(u32).range(1..=16))]
    bits: Vec<u32>,
    /// Radiometer paths per target (fixed; no adaptive rounds), 1–16777216,
    /// traced in whole batches of 1024: a count between is rounded up, and
    /// the output says so.
    #[arg(long, default_value_t = 4096, value_parser = clap::value_parser!(u64).range(1..=MAX_SAMPLES_PER_TARGET))]
    samples: u64,
    /// Random seed of the render.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Worker threads, 1–1024 (default: one per core).
    #[arg(long, value_parser = super::threads)]
    threads: Option<usize>,
    /// Out-of-gamut targets: scale (one factor common to both codings), clip or fail.
    #[arg(long, default_value = "scale")]
    gamut: GamutPolicy,
    /// The transfer function: gamma or table.
    #[arg(long, default_value = "gamma", value_parser = transfer_model)]
    transfer: TransferModel,
    /// Write the chart (bits against ΔE00, shown and true) as SVG.
    #[arg(long)]
    chart: Option<PathBuf>,
    /// Print the results as JSON.
    #[arg(long)]
    json: bool,
}

fn parse_coding(s: &str) -> Result<Coding, String> {
    s.parse()
}

#[derive(Serialize)]
struct Output {
    scene: String,
    display_profile: String,
    observer: String,
    samples_per_target: u64,
    targets: Vec<String>,
    gamut: GamutPolicy,
    resolved_definition: String,
    pairs: Vec<PairResolution>,
}

pub fn run(args: DisplayResolutionArgs) -> anyhow::Result<()> {
    if args.codings.len() < 2 {
        anyhow::bail!("--codings: give at least two codings to compare (e.g. nstep27,nstep81)");
    }
    let (profile, profile_name) = load_profile(&args.profile)?;
    let scene = load_scene(&args.scene)?;
    if let Some(note) = lightbooth::render::samples_rounding_note("--samples", args.samples) {
        eprintln!("{note}");
    }
    let settings = RenderSettings {
        codings: args.codings.clone(),
        samples: args.samples,
        seed: args.seed,
        threads: args.threads,
        target_relative_se: None,
        observer: profile.observer,
        ..RenderSettings::default()
    };
    let result = render(&scene, &settings, None, None)?;
    let names: Vec<String> = args.codings.iter().map(|c| c.to_string()).collect();
    let xyz_of = |name: &str| -> anyhow::Result<Vec<[f64; 3]>> {
        result
            .targets
            .iter()
            .map(|t| {
                t.coding(name)
                    .map(|c| c.xyz)
                    .with_context(|| format!("target {}: no {name}", t.id))
            })
            .collect()
    };
    let reference = names.last().cloned().unwrap_or_default();
    let b = xyz_of(&reference)?;
    let mut pairs = Vec::new();
    for name in &names[..names.len() - 1] {
        let a = xyz_of(name)?;
        pairs.push(resolve_pair(
            &profile,
            (name, &reference),
            &a,
            &b,
            &args.bits,
            args.gamut,
            args.transfer,
        )?);
    }
    let out = Output {
        scene: format!("{} ({})", result.scene, args.scene.display()),
        display_profile: profile_name,
        observer: profile.observer.to_string(),
        samples_per_target: lightbooth::render::paths_traced(args.samples),
        targets: result.targets.iter().map(|t| t.id.clone()).collect(),
        gamut: args.gamut,
        resolved_definition: format!(
            "a target is resolved at a depth when at least one code differs between the codings and the \
             ΔE00 between what the display shows for each is at least {RESOLVED_FRACTION} × the ΔE00 between \
             them after the gamut policy, unquantised (intended); targets whose intended ΔE00 is below \
             {NEGLIGIBLE_DE00} have nothing to resolve; ΔE00 relative to the display's white"
        ),
        pairs,
    };
    if let Some(path) = &args.chart {
        let svg = chart(&out).map_err(anyhow::Error::msg)?;
        std::fs::write(path, svg).with_context(|| format!("writing {}", path.display()))?;
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        print_table(&out);
    }
    Ok(())
}

fn chart(out: &Output) -> Result<String, String> {
    let mut series = Vec::new();
    for p in &out.pairs {
        series.push(LineSeriesData {
            name: p.a.clone(),
            points: p
                .depths
                .iter()
                .map(|d| (f64::from(d.bits), d.mean_shown_delta_e00))
                .collect(),
            errors: None,
        });
        // The reference is what the display would show with unlimited depth
        // (after the gamut policy); the as-rendered ΔE00 is in the table and JSON.
        series.push(LineSeriesData {
            name: format!("truth {} (on the display, unquantised)", p.a),
            points: p
                .depths
                .iter()
                .map(|d| (f64::from(d.bits), d.mean_intended_delta_e00))
                .collect(),
            errors: None,
        });
    }
    let reference = out.pairs.first().map(|p| p.b.clone()).unwrap_or_default();
    line_chart(
        &format!("{}: ΔE00 to {reference} as the display shows it", out.scene),
        "frame-buffer bits per channel",
        "mean ΔE00 over targets (display white)",
        &series,
        false,
    )
}

fn print_table(out: &Output) {
    println!(
        "{} on {} ({} observer), {} paths per target, gamut {:?}",
        out.scene, out.display_profile, out.observer, out.samples_per_target, out.gamut
    );
    for p in &out.pairs {
        println!("{} vs {}:", p.a, p.b);
        println!(
            "{:>5} {:>13} {:>9} {:>11} {:>15} {:>17} {:>14}",
            "bits", "codes differ", "resolved", "unresolved", "mean shown ΔE", "mean intended ΔE", "mean true ΔE"
        );
        for d in &p.depths {
            println!(
                "{:>5} {:>8}/{:<4} {:>9} {:>11} {:>15.4} {:>17.4} {:>14.4}",
                d.bits,
                d.codes_differ,
                d.colours,
                d.resolved,
                d.unresolved,
                d.mean_shown_delta_e00,
                d.mean_intended_delta_e00,
                d.mean_true_delta_e00
            );
        }
        match p.resolves_at_bits {
            Some(b) => println!("resolves every target from {b} bits"),
            None => println!("does not resolve every target at any depth given"),
        }
    }
    println!("resolved: {}", out.resolved_definition);
}
