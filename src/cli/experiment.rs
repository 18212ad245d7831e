//! `lightbooth experiment`: the study's oddity experiment from the command
//! line — plan how many trials it needs, set one up on a database (checked
//! on its display), list them, and analyse the trials observers gave.

use anyhow::Context;
use clap::{Args, Subcommand, ValueEnum};

use lightbooth::display::output::OutputMethod;
use lightbooth::display::stimulus::GamutPolicy;
use lightbooth::lab::experiments::analysis::{analysis_csv, analysis_text};
use lightbooth::lab::experiments::{ExperimentRequest, Experiments};
use lightbooth::psychophysics::design::CONFIGURATIONS;
use lightbooth::psychophysics::observer::SimulatedObserver;
use lightbooth::psychophysics::oddity::OddityModel;
use lightbooth::psychophysics::plan::trials_for_power;
use lightbooth::psychophysics::presentation::Presentation;
use lightbooth::random::SplitMix64;
use lightbooth::store::Store;

#[derive(Subcommand, Debug)]
pub enum ExperimentCommand {
    /// How many oddity trials tell d′₀ from d′₁ with a given power (exact binomial test).
    Plan(PlanArgs),
    /// Set up an experiment from a measurement and a display profile, and check its colours.
    Create(CreateArgs),
    /// The experiments stored in a database.
    List(DbArgs),
    /// Percent correct and d′ per observer and approximation.
    Analyze(AnalyzeArgs),
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum ModelArg {
    Differencing,
    IndependentObservation,
    Both,
}

#[derive(Args, Debug)]
pub struct PlanArgs {
    /// The d′ the test must reject (the null hypothesis).
    #[arg(long, default_value_t = 1.0, value_parser = d_prime)]
    d0: f64,
    /// The d′ the test must detect.
    #[arg(long, default_value_t = 2.0, value_parser = d_prime)]
    d1: f64,
    /// The test's size (one-sided).
    #[arg(long, default_value_t = 0.05, value_parser = probability)]
    alpha: f64,
    /// The power wanted.
    #[arg(long, default_value_t = 0.8, value_parser = probability)]
    power: f64,
    /// The decision model of the observer.
    #[arg(long, value_enum, default_value_t = ModelArg::Both)]
    model: ModelArg,
    /// Check each plan with this many simulated observers of true d′ = d′₁
    /// (their share of rejections is the simulated power); 0 skips it.
    #[arg(long, default_value_t = 4000, value_parser = clap::value_parser!(u32).range(0..=100_000))]
    simulate: u32,
    /// JSON instead of text.
    #[arg(long)]
    json: bool,
}

/// The share of `sessions` simulated observers of true d′ `d1` (seed 1)
/// whose count reaches `critical` of `trials`, with its standard error.
fn simulated_power(model: OddityModel, trials: u32, critical: u32, d1: f64, sessions: u32) -> (f64, f64) {
    let observer = SimulatedObserver::new(1.0, model).expect("unit noise is valid");
    let block: Vec<_> = (0..trials as usize).map(|i| CONFIGURATIONS[i % 6]).collect();
    let mut rng = SplitMix64(1);
    let rejected = (0..sessions)
        .filter(|_| observer.run_block(&block, d1, &mut rng) >= critical)
        .count();
    let p = rejected as f64 / f64::from(sessions.max(1));
    (p, (p * (1.0 - p) / f64::from(sessions.max(1))).sqrt())
}

#[derive(Args, Debug)]
pub struct DbArgs {
    /// The database: sqlite://FILE or postgres://USER@HOST/DATABASE.
    #[arg(long, default_value = "sqlite://lightbooth.sqlite")]
    db: String,
}

#[derive(Args, Debug)]
pub struct CreateArgs {
    #[command(flatten)]
    db: DbArgs,
    /// A complete measurement with comparisons: its scene target is the experiment's.
    #[arg(long)]
    measurement: i64,
    /// The stored display profile the stimuli are shown through.
    #[arg(long)]
    profile: i64,
    /// Codings to test against the original (comma-separated).
    #[arg(long, value_delimiter = ',', required = true)]
    approximations: Vec<String>,
    /// `measured` (the study's) or a coding whose rendering is the original.
    #[arg(long, default_value = "measured")]
    original: String,
    /// 8bit, noisy_bit or 10bit.
    #[arg(long, default_value = "noisy_bit")]
    output: OutputMethod,
    /// scale, clip or fail.
    #[arg(long, default_value = "scale")]
    gamut: GamutPolicy,
    /// Repeats of each of the six configurations per approximation (the study: 6).
    #[arg(long, default_value_t = 6)]
    repeats: u32,
    /// Eye to screen, mm.
    #[arg(long, default_value_t = 570.0)]
    viewing_distance_mm: f64,
    /// Width of one screen pixel, mm.
    #[arg(long, default_value_t = 0.25)]
    pixel_pitch_mm: f64,
    /// The trial orders' seed (drawn and stored when absent).
    #[arg(long)]
    seed: Option<u64>,
    #[arg(long, default_value = "")]
    name: String,
}

#[derive(Args, Debug)]
pub struct AnalyzeArgs {
    #[command(flatten)]
    db: DbArgs,
    /// The experiment's id.
    experiment: i64,
    /// CSV instead of text.
    #[arg(long)]
    csv: bool,
}

fn d_prime(s: &str) -> Result<f64, String> {
    super::finite_in(s, 0.0, 10.0, "d′")
}

fn probability(s: &str) -> Result<f64, String> {
    let v = super::finite_in(s, 0.0, 1.0, "a probability")?;
    if v > 0.0 && v < 1.0 {
        Ok(v)
    } else {
        Err(format!("{v}: give a probability strictly between 0 and 1"))
    }
}

pub fn run(cmd: ExperimentCommand) -> anyhow::Result<()> {
    match cmd {
        ExperimentCommand::Plan(a) => plan(a),
        ExperimentCommand::Create(a) => runtime()?.block_on(create(a)),
        ExperimentCommand::List(a) => runtime()?.block_on(list(a)),
        ExperimentCommand::Analyze(a) => runtime()?.block_on(analyze(a)),
    }
}

fn runtime() -> anyhow::Result<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .context("cannot start the async runtime")
}

fn plan(a: PlanArgs) -> anyhow::Result<()> {
    if a.d1 <= a.d0 {
        anyhow::bail!(
            "--d1 {} must be larger than --d0 {}: the test detects a larger d′",
            a.d1,
            a.d0
        );
    }
    let models: Vec<OddityModel> = match a.model {
        ModelArg::Differencing => vec![OddityModel::Differencing],
        ModelArg::IndependentObservation => vec![OddityModel::IndependentObservation],
        ModelArg::Both => OddityModel::ALL.to_vec(),
    };
    let mut rows = Vec::new();
    for m in models {
        let p = trials_for_power(a.d0, a.d1, m, a.alpha, a.power).map_err(anyhow::Error::msg)?;
        let sim = (a.simulate > 0).then(|| simulated_power(m, p.trials, p.critical_correct, a.d1, a.simulate));
        rows.push((m, p, sim));
    }
    if a.json {
        let v: Vec<serde_json::Value> = rows
            .iter()
            .map(|(m, p, sim)| {
                serde_json::json!({
                    "model": m.name(), "d0": a.d0, "d1": a.d1, "alpha": a.alpha, "power_wanted": a.power,
                    "trials": p.trials, "critical_correct": p.critical_correct, "size": p.size, "power": p.power,
                    "simulated_observers": a.simulate, "simulated_power": sim.map(|s| s.0),
                    "simulated_power_se": sim.map(|s| s.1),
                })
            })
            .collect();
        println!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(());
    }
    println!(
        "oddity trials to tell d′ = {} from d′ = {} (one-sided exact binomial test, α = {}, power ≥ {}):",
        a.d0, a.d1, a.alpha, a.power
    );
    for (m, p, sim) in rows {
        println!(
            "  {:<24} {:>4} trials; reject d′ = {} at {} or more correct (size {:.4}, power {:.4})",
            m.name(),
            p.trials,
            a.d0,
            p.critical_correct,
            p.size,
            p.power
        );
        if let Some((power, se)) = sim {
            println!(
                "  {:<24} simulated: {} observers of d′ = {} rejected d′ = {} in {:.1} % ± {:.1} % (1 SE)",
                "",
                a.simulate,
                a.d1,
                a.d0,
                100.0 * power,
                100.0 * se
            );
        }
    }
    println!("the study ran 36 trials per observer and condition (6 configurations × 6 repeats)");
    Ok(())
}

async fn create(a: CreateArgs) -> anyhow::Result<()> {
    let store = Store::open(&a.db.db).await?;
    let request = ExperimentRequest {
        name: a.name,
        measurement_id: a.measurement,
        original: a.original,
        approximations: a.approximations,
        display_profile_id: a.profile,
        output: a.output,
        gamut: a.gamut,
        presentation: Presentation {
            repeats: a.repeats,
            viewing_distance_mm: a.viewing_distance_mm,
            pixel_pitch_mm: a.pixel_pitch_mm,
            ..Presentation::default()
        },
        seed: a.seed,
    };
    let e = Experiments::new(store).create(request).await?;
    println!(
        "experiment {} ({}), {} on {}/{}",
        e.id, e.name, e.output_method, e.scene, e.target
    );
    if let Some(lines) = e.check["summary"].as_array() {
        for l in lines {
            println!("  {}", l.as_str().unwrap_or_default());
        }
    }
    if let Some(cs) = e.check["approximations"].as_array() {
        for c in cs {
            println!(
                "  {}: {}",
                c["name"].as_str().unwrap_or_default(),
                c["verdict"].as_str().unwrap_or_default()
            );
        }
    }
    println!("run it: open /experiment/{}/run on the stimulus display", e.id);
    Ok(())
}

async fn list(a: DbArgs) -> anyhow::Result<()> {
    let store = Store::open(&a.db).await?;
    for e in store.list_experiments().await? {
        println!(
            "{:>4}  {:<24} {}/{}  {}  measurement {}  profile {}",
            e.id, e.name, e.scene, e.target, e.output_method, e.measurement_id, e.display_profile_id
        );
    }
    Ok(())
}

async fn analyze(a: AnalyzeArgs) -> anyhow::Result<()> {
    let store = Store::open(&a.db.db).await?;
    let r = Experiments::new(store).analyze(a.experiment).await?;
    if a.csv {
        print!("{}", analysis_csv(&r));
        return Ok(());
    }
    print!("{}", analysis_text(&r));
    Ok(())
}
