//! `lightbooth study`: the study's question for any scenes — how far each
//! coding is from the truth, at what cost, with the spread over seeds.

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, ValueEnum};

use lightbooth::colorimetry::Observer;
use lightbooth::daemon::{DEFAULT_HEARTBEAT, DEFAULT_LEASE};
use lightbooth::lab::lease::Lease;
use lightbooth::lab::study::measure::{measure_with_simulator, SimulatedPr650};
use lightbooth::lab::study::report::write_report;
use lightbooth::lab::study::run::{run_study, Against, StudyOptions};
use lightbooth::render::Coding;
use lightbooth::store::{Job, Store};

#[derive(Args, Debug)]
pub struct StudyArgs {
    /// Scene files (the scene id is the file name without .toml).
    #[arg(required = true)]
    scenes: Vec<PathBuf>,
    /// The truth: stored measurements, or a converged spectral rendering.
    #[arg(long, value_enum, default_value_t = AgainstArg::Measurements)]
    against: AgainstArg,
    /// Codings to compare (comma-separated).
    #[arg(
        long,
        default_value = "rgb,srgb,nstep3,nstep9,nstep27,nstep81,spectral",
        value_delimiter = ','
    )]
    codings: Vec<Coding>,
    /// Seeds: each renders every coding once; figures are given as mean ± SD over seeds.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=64))]
    seeds: u32,
    /// First-round paths per target (rendering continues to a 0.3 % SE of
    /// Y), rounded up to whole batches of 1024, and the output says so.
    #[arg(long, default_value_t = 4096,
          value_parser = clap::value_parser!(u64).range(1..=lightbooth::render::scene::MAX_SAMPLES_PER_TARGET))]
    samples: u64,
    /// Cap the renders at this many bounces, 0–64 (5 emulates the original
    /// study's RADIANCE -ab 5; the report then says "truncated at N bounces").
    /// Default: no cap, Russian roulette ends the paths (unbiased).
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=i64::from(lightbooth::render::scene::MAX_BOUNCES)))]
    bounces: Option<u32>,
    /// Also sweep samples, bounces and N for the speed-against-accuracy chart.
    #[arg(long)]
    sweeps: bool,
    /// Also choose per scene the cheapest settings meeting this tolerance, e.g. `de00=1,rms=0.02`.
    #[arg(long)]
    auto: Option<lightbooth::lab::study::auto::Tolerance>,
    /// Also compute the failure maps (illuminant × patch; CYLINDER interreflection).
    #[arg(long)]
    failure_map: bool,
    /// The database with the measurements (and where the study is stored):
    /// sqlite://FILE or postgres://USER@HOST/DATABASE.
    #[arg(long, default_value = "sqlite://lightbooth.sqlite")]
    db: String,
    /// The booth this study runs for, recorded with its lease in the
    /// database's `daemons` table (as a daemon's `--booth`): while the study
    /// runs it heartbeats, so a daemon starting on the same database leaves
    /// its study alone.
    #[arg(long, default_value = lightbooth::store::DEFAULT_BOOTH)]
    booth: lightbooth::store::Booth,
    /// First measure every target with the simulated PR-650 (reproducible, no booth needed).
    #[arg(long)]
    measure_simulated: bool,
    /// Time scale of the simulated PR-650 of --measure-simulated: 0 = instant, 1 = the real
    /// instrument's measurement and 9600-baud wire times.
    #[arg(long, default_value_t = 0.0, value_parser = super::time_scale)]
    simulated_speed: f64,
    /// Where converged spectra of scene targets are cached.
    #[arg(long, default_value = ".lightbooth-cache")]
    cache_dir: PathBuf,
    /// Write a self-contained report (HTML with SVG charts, CSV of every number) here.
    #[arg(long)]
    report: Option<PathBuf>,
    /// The observer of every XYZ, x,y, CIELAB and ΔE: judd-vos-1978 (the
    /// study's), cie-1931, cie-1964-10, cie-2015-2 or cie-2015-10.
    #[arg(long, default_value = "judd-vos-1978")]
    observer: Observer,
    /// The booth as it is, when it differs from the model: a scene file (for
    /// the scene with the same file name) or a folder of them. The reference
    /// truth and the simulated measurements come from it; the codings render
    /// the model scenes.
    #[arg(long)]
    truth_scene: Option<PathBuf>,
    /// Print the whole result as JSON.
    #[arg(long)]
    json: bool,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum AgainstArg {
    Measurements,
    Reference,
}

pub fn run(args: StudyArgs) -> anyhow::Result<()> {
    if let Some(note) = lightbooth::render::samples_rounding_note("--samples", args.samples) {
        eprintln!("{note}");
    }
    let options = StudyOptions {
        codings: args.codings.clone(),
        seeds: args.seeds,
        samples: args.samples,
        max_bounces: args.bounces,
        against: match args.against {
            AgainstArg::Measurements => Against::Measurements,
            AgainstArg::Reference => Against::Reference,
        },
        sweeps: args.sweeps,
        failure_map: args.failure_map,
        auto: args.auto,
        observer: args.observer,
        truth_scene: args.truth_scene.clone(),
        booth: args.booth.clone(),
        ..StudyOptions::default()
    };
    if let Some(t) = &options.truth_scene {
        anyhow::ensure!(t.exists(), "--truth-scene {}: no such file or folder", t.display());
        let used = args.scenes.iter().any(|s| options.truth_path(s) != *s);
        anyhow::ensure!(
            used,
            "--truth-scene {}: matches none of the scenes (a truth scene is used for the scene with its file name)",
            t.display()
        );
    }
    anyhow::ensure!(options.seeds >= 1, "--seeds must be at least 1");
    let runtime = tokio::runtime::Runtime::new().context("starting the async runtime")?;
    runtime.block_on(async move {
        let needs_store = matches!(options.against, Against::Measurements) || args.measure_simulated;
        // The study's rows name its lease, renewed while it runs and
        // released at the end (also on error): no daemon counts them abandoned.
        let lease = if needs_store {
            let store = Store::open_as_tool(&args.db)
                .await
                .with_context(|| format!("opening {}", args.db))?;
            let lease = Lease::take(&store, &args.booth, DEFAULT_LEASE, DEFAULT_HEARTBEAT, None)
                .await
                .with_context(|| format!("registering this study's lease in {}", args.db))?;
            Some(lease)
        } else {
            None
        };
        let store = lease.as_ref().map(|l| l.store().clone());
        let outcome = study(&args, &options, store).await;
        if let Some(lease) = lease {
            lease.release().await.context("marking this study's lease stopped")?;
        }
        outcome
    })
}

/// The study itself, on `store` when it needs one.
async fn study(args: &StudyArgs, options: &StudyOptions, store: Option<Store>) -> anyhow::Result<()> {
    {
        let progress = |msg: &str| eprintln!("{msg}");
        if args.measure_simulated {
            let store = store.as_ref().expect("opened above");
            let ids = measure_with_simulator(
                &args.scenes,
                store,
                &args.booth,
                &args.cache_dir,
                SimulatedPr650 {
                    seed: 1,
                    speed: args.simulated_speed,
                },
                options.observer,
                options.truth_scene.as_deref(),
                &progress,
            )
            .await?;
            eprintln!("stored {} simulated measurements", ids.len());
        }
        let request = serde_json::json!({ "scenes": &args.scenes, "options": options, "command_line": true });
        // Created and started at once: the study runs here, now (a
        // study left `queued` could not be completed).
        let study_id = match &store {
            Some(store) => {
                let id = store.create_study(&request).await?;
                anyhow::ensure!(
                    store.start_job(Job::Study, id).await?,
                    "study {id} was ended before it started"
                );
                Some(id)
            }
            None => None,
        };
        let result = match run_study(&args.scenes, options, store.as_ref(), &progress, None).await {
            Ok(r) => r,
            Err(e) => {
                if let (Some(store), Some(id)) = (&store, study_id) {
                    store.fail_study(id, &e.to_string()).await?;
                }
                return Err(e.into());
            }
        };
        if let (Some(store), Some(id)) = (&store, study_id) {
            let files = lightbooth::lab::study::report::report_files(&result)?;
            store
                .complete_study(id, &serde_json::to_value(&result)?, result.wall_seconds, &files)
                .await?;
            eprintln!("study stored as {id}");
        }
        if let Some(dir) = &args.report {
            write_report(&result, dir).with_context(|| format!("writing the report to {}", dir.display()))?;
            eprintln!("report: {}", dir.join("index.html").display());
        }
        if args.json {
            println!("{}", serde_json::to_string_pretty(&result)?);
        } else {
            println!(
                "{:<10} {:<9} {:>16} {:>16} {:>16} {:>12}  distinguishable within the instrument's stated accuracy",
                "scene", "coding", "rms_rel", "mean dE*ab", "mean dE00", "sig. targets"
            );
            for s in &result.scenes {
                for c in &s.codings {
                    println!(
                        "{:<10} {:<9} {:>8.4} ±{:>6.4} {:>8.3} ±{:>6.3} {:>8.3} ±{:>6.3} {:>6} of {:<3}  {}",
                        s.scene,
                        c.coding,
                        c.rms_rel.mean,
                        c.rms_rel.sd,
                        c.mean_dE76.mean,
                        c.mean_dE76.sd,
                        c.mean_dE00.mean,
                        c.mean_dE00.sd,
                        c.significant_targets,
                        s.targets.len(),
                        lightbooth::lab::study::report::distinguishable_cell(c)
                    );
                }
            }
            println!(
                "wall time {:.2} s (± are SD over {} seeds); observer {}; sig. targets: |ΔY| > {} × combined SE",
                result.wall_seconds, options.seeds, result.observer, result.beyond_noise_k
            );
        }
        Ok(())
    }
}
