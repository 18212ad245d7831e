//! `lightbooth mock-cs2000`: a simulated Konica Minolta CS-2000, CS-2000A or
//! CS-3000 on a pseudo-terminal, for `measure --model cs2000` and for any
//! client of the instrument (colour-specio's `CS2000` class is tested
//! against it). What it answers, and the choices where the public sources
//! are silent, are in `docs/src/instruments/cs2000.md`. A thin wrapper
//! around [`lightbooth::instrument::sim::spawn_mock`].

use std::io::Write;

use anyhow::Context;
use clap::{Args, ValueEnum};

use lightbooth::instrument::cs2000::Model;
use lightbooth::instrument::sim::{spawn_mock, Fault, MockConfig};

use super::mock_pr650::{default_target, load_target, parse_fault, power_switch};

#[derive(Args, Debug)]
pub struct MockCs2000Args {
    /// Which of the family: its `IDDR` answer.
    #[arg(long, value_enum, default_value_t = Family::Cs2000)]
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
    /// Serial number `IDDR` reports.
    #[arg(long, default_value = "20101234")]
    serial: String,
    /// Inject a fault: no-answer, truncate, garble, slow or link-dies (into a spectral block's
    /// reply), error-code (the measurement ends with --error-code) or cable-pull (mid-measurement),
    /// each optionally `:RATE` (a probability 0–1, `once` or `Nx`). Repeatable.
    #[arg(long = "fault", value_name = "KIND[@DELAY][:RATE]", value_parser = parse_fault)]
    faults: Vec<Fault>,
    /// Delay before a `slow` reply that names none, ms.
    #[arg(long, default_value_t = 12_000, value_parser = clap::value_parser!(u64).range(0..=600_000))]
    slow_ms: u64,
    /// The `ERnn` an `error-code` fault ends a measurement with: 10 over range, 51/52
    /// temperature, 71 sync, 83 measurement area.
    #[arg(long, default_value_t = 71, value_parser = clap::value_parser!(u8).range(0..=99))]
    error_code: u8,
    /// Announce 0 s for `MEAS,1` and send no end line: a client must poll `MEDR,0,0,1`
    /// through its `ER02` (not ready) answers until the measurement ends.
    #[arg(long)]
    short_estimate: bool,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum Family {
    Cs2000,
    Cs2000a,
    Cs3000,
}

pub fn run(args: MockCs2000Args) -> anyhow::Result<()> {
    let model = match args.model {
        Family::Cs2000 => Model::Cs2000,
        Family::Cs2000a => Model::Cs2000A,
        Family::Cs3000 => Model::Cs3000,
    };
    let truth = match &args.spectrum {
        Some(spec) => load_target(spec)?,
        None => default_target(),
    };
    let mut cfg = MockConfig::cs2000(truth, model);
    cfg.speed = args.speed;
    cfg.seed = args.seed;
    cfg.serial = args.serial;
    cfg.faults = args.faults;
    cfg.slow_ms = args.slow_ms;
    cfg.error_code = args.error_code;
    cfg.short_estimate = args.short_estimate;
    let name = model.name();
    let mock = spawn_mock(cfg).with_context(|| format!("cannot open a pseudo-terminal for the simulated {name}"))?;
    let path = mock.device_path().display().to_string();
    // First stdout line: the device path, for scripts.
    let mut stdout = std::io::stdout();
    writeln!(stdout, "{path}")?;
    stdout.flush()?;
    eprintln!(
        "Simulated {name} on {path}: run `lightbooth measure --model {} --port {path}`. Press Enter here to \
         power-cycle it. Ctrl-C stops it.",
        model.flag()
    );
    power_switch(&mock, "remote mode off until RMTS,1")
}
