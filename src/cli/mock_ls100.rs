//! `lightbooth mock-ls100`: a simulated Konica Minolta LS-100 (or, with
//! `--model cs100a`, a CS-100A) in communication mode on a pseudo-terminal,
//! for trying `measure --model ls100|cs100a` (and PsychoPy's `LS100` and
//! `CS100A` classes) without the meter. A thin wrapper around
//! [`lightbooth::instrument::sim::spawn_mock`]; what the simulator does and
//! chooses is in `crates/instrument/src/sim/ls100.rs`. The meters report no serial
//! number, so there is no `--serial`.

use std::io::Write;

use anyhow::Context;
use clap::{Args, ValueEnum};

use lightbooth::instrument::ls100::Model;
use lightbooth::instrument::sim::{spawn_mock, BusyInput, Fault, MockConfig};

use super::mock_pr650::{default_target, load_target, parse_fault, power_switch};

#[derive(Clone, Copy, Debug, ValueEnum)]
enum Meter {
    Ls100,
    Cs100a,
}

#[derive(Args, Debug)]
pub struct MockLs100Args {
    /// Which meter: ls100 (luminance) or cs100a (luminance and x, y).
    #[arg(long, value_enum, default_value_t = Meter::Ls100)]
    model: Meter,
    /// What the meter is aimed at: a spectral radiance W/(sr·m²·nm) in
    /// FILE.csv[:COLUMN] (any grid covering 380–780 nm). Default: D65 at about 100 cd/m².
    #[arg(long, value_name = "FILE.csv[:COLUMN]")]
    spectrum: Option<String>,
    /// Time scale: 1 = the real meter's measurement (0.8 s) and 4800-baud wire times, 0 = instant.
    #[arg(long, default_value_t = 1.0, value_parser = super::time_scale)]
    speed: f64,
    /// Seed of the simulated noise (same seed, same samples).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Inject a fault into the `MES` reply: no-answer, truncate, garble, stale, error-code,
    /// cable-pull, slow, double-crlf or link-dies, each optionally `:RATE` (a probability 0–1,
    /// `once` or `Nx`); `slow` may name its delay, e.g. slow@2500ms:once. Repeatable.
    #[arg(long = "fault", value_name = "KIND[@DELAY][:RATE]", value_parser = parse_fault)]
    faults: Vec<Fault>,
    /// Delay before a `slow` reply that names none, ms.
    #[arg(long, default_value_t = 12_000, value_parser = clap::value_parser!(u64).range(0..=600_000))]
    slow_ms: u64,
    /// The status of an `error-code` fault: ER00, ER01, ER10 (measuring range over), ER11, ER19,
    /// ER20 or ER30 (battery exhausted).
    #[arg(long, default_value = "ER10", value_parser = error_status)]
    error_status: u8,
    /// Discard bytes that arrive during a measurement instead of queueing them.
    #[arg(long)]
    drop_busy_input: bool,
}

/// `ERnn` → nn, for the codes the public sources list.
fn error_status(s: &str) -> Result<u8, String> {
    const LISTED: [u8; 7] = [0, 1, 10, 11, 19, 20, 30];
    match lightbooth::instrument::status_word::StatusWord::parse(s.as_bytes()) {
        Some(lightbooth::instrument::status_word::StatusWord::Er(n)) if LISTED.contains(&n) => Ok(n),
        _ => Err(format!("`{s}`: use one of ER00, ER01, ER10, ER11, ER19, ER20, ER30")),
    }
}

pub fn run(args: MockLs100Args) -> anyhow::Result<()> {
    let model = match args.model {
        Meter::Ls100 => Model::Ls100,
        Meter::Cs100a => Model::Cs100a,
    };
    let truth = match &args.spectrum {
        Some(spec) => load_target(spec)?,
        None => default_target(),
    };
    let mut cfg = MockConfig::ls100(truth, model);
    cfg.speed = args.speed;
    cfg.seed = args.seed;
    cfg.faults = args.faults;
    cfg.slow_ms = args.slow_ms;
    cfg.error_code = args.error_status;
    cfg.busy_input = if args.drop_busy_input {
        BusyInput::Drop
    } else {
        BusyInput::Queue
    };
    let name = model.name();
    let mock = spawn_mock(cfg).with_context(|| format!("cannot open a pseudo-terminal for the simulated {name}"))?;
    let path = mock.device_path().display().to_string();
    // First stdout line: the device path, for scripts.
    let mut stdout = std::io::stdout();
    writeln!(stdout, "{path}")?;
    stdout.flush()?;
    let flag = name.to_ascii_lowercase().replace('-', "");
    eprintln!(
        "Simulated {name} in communication mode on {path} (4800 baud; a pty carries no parity, so clients \
         fall back to 8N2): run `lightbooth measure --model {flag} --port {path}`. Press Enter here to \
         power-cycle it. Ctrl-C stops it."
    );
    power_switch(&mock, "back on in communication mode")
}
