//! `lightbooth mock-cr250`: a simulated Colorimetry Research CR-250 or
//! CR-300 on a pseudo-terminal, for `measure --model cr250|cr300` and for
//! any client of the instrument (colour-specio's `CRSpectrometer` is tested
//! against it). What it answers, and the choices where the public sources
//! are silent, are in `docs/src/instruments/cr250.md`. A thin wrapper
//! around [`lightbooth::instrument::sim::spawn_mock`].

use std::io::Write;

use anyhow::Context;
use clap::{Args, ValueEnum};

use lightbooth::instrument::cr250::Model;
use lightbooth::instrument::sim::{spawn_mock, Fault, MockConfig};

use super::mock_pr650::{default_target, load_target, parse_fault, power_switch};

#[derive(Args, Debug)]
pub struct MockCr250Args {
    /// Which of the two: its `RC Model` answer and its grid (4 nm or 1 nm).
    #[arg(long, value_enum, default_value_t = Family::Cr250)]
    model: Family,
    /// What the instrument is aimed at: a spectral radiance W/(sr·m²·nm) in
    /// FILE.csv[:COLUMN] (any grid covering 380–780 nm). Default: D65 at about 100 cd/m².
    #[arg(long, value_name = "FILE.csv[:COLUMN]")]
    spectrum: Option<String>,
    /// Time scale of measurements: 1 = the real instrument's, 0 = instant.
    #[arg(long, default_value_t = 1.0, value_parser = super::time_scale)]
    speed: f64,
    /// Seed of the simulated noise (same seed, same samples).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Serial number `RC ID` reports.
    #[arg(long, default_value = "25010042")]
    serial: String,
    /// Inject a fault: no-answer, truncate, garble, slow or link-dies (into the `RM Spectrum`
    /// reply), error-code (`M` ends with --error-status) or cable-pull (mid-measurement), each
    /// optionally `:RATE` (a probability 0–1, `once` or `Nx`). Repeatable.
    #[arg(long = "fault", value_name = "KIND[@DELAY][:RATE]", value_parser = parse_fault)]
    faults: Vec<Fault>,
    /// Delay before a `slow` reply that names none, ms.
    #[arg(long, default_value_t = 12_000, value_parser = clap::value_parser!(u64).range(0..=600_000))]
    slow_ms: u64,
    /// The code an `error-code` fault ends `M` with: 100 too dark, −303 fluctuating, −304 too
    /// low, −305 not measurable, −306 too high, 101–103 sync.
    #[arg(long, default_value_t = 100, allow_negative_numbers = true,
          value_parser = clap::value_parser!(i32).range(-999..=999))]
    error_status: i32,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum Family {
    Cr250,
    Cr300,
}

pub fn run(args: MockCr250Args) -> anyhow::Result<()> {
    let model = match args.model {
        Family::Cr250 => Model::Cr250,
        Family::Cr300 => Model::Cr300,
    };
    let truth = match &args.spectrum {
        Some(spec) => load_target(spec)?,
        None => default_target(),
    };
    let mut cfg = MockConfig::cr250(truth, model);
    cfg.speed = args.speed;
    cfg.seed = args.seed;
    cfg.serial = args.serial;
    cfg.faults = args.faults;
    cfg.slow_ms = args.slow_ms;
    cfg.error_status = args.error_status;
    let name = model.name();
    let mock = spawn_mock(cfg).with_context(|| format!("cannot open a pseudo-terminal for the simulated {name}"))?;
    let path = mock.device_path().display().to_string();
    let mut stdout = std::io::stdout();
    writeln!(stdout, "{path}")?;
    stdout.flush()?;
    eprintln!(
        "Simulated {name} on {path}: run `lightbooth measure --model {} --port {path}`. Press Enter here to \
         power-cycle it. Ctrl-C stops it.",
        model.flag()
    );
    power_switch(&mock, "settings back to their power-on values")
}
