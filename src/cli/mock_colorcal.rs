//! `lightbooth mock-colorcal`: a simulated CRS ColorCAL MkII on a
//! pseudo-terminal, for trying `measure --model colorcal` (and PsychoPy's
//! `ColorCAL` class) without the instrument. A thin wrapper around
//! [`lightbooth::instrument::sim::spawn_mock`]; what the simulator does and
//! chooses is in `crates/instrument/src/sim/colorcal.rs`.

use std::io::Write;

use anyhow::Context;
use clap::Args;

use lightbooth::instrument::sim::{spawn_mock, BusyInput, Fault, FaultKind, MockConfig};

use super::mock_pr650::{default_target, load_target, parse_fault, power_switch};

#[derive(Args, Debug)]
pub struct MockColorCalArgs {
    /// What the instrument is aimed at: a spectral radiance W/(sr·m²·nm) in
    /// FILE.csv[:COLUMN] (any grid covering 380–780 nm). Default: D65 at about 100 cd/m².
    #[arg(long, value_name = "FILE.csv[:COLUMN]")]
    spectrum: Option<String>,
    /// Time scale: 1 = the real instrument's measurement time (0.5 s per MES), 0 = instant.
    #[arg(long, default_value_t = 1.0, value_parser = super::time_scale)]
    speed: f64,
    /// Seed of the simulated noise (same seed, same samples).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// The eight-digit serial number `IDR` reports.
    #[arg(long, default_value = "10003154")]
    serial: String,
    /// Inject a fault into the `MES` reply: no-answer, truncate, garble, stale, cable-pull, slow,
    /// double-crlf or link-dies, each optionally `:RATE` (a probability 0–1, `once` or `Nx`);
    /// `slow` may name its delay, e.g. slow@2500ms:once. Repeatable. (`error-code` does not apply:
    /// no public source documents a status for a failed MES.)
    #[arg(long = "fault", value_name = "KIND[@DELAY][:RATE]", value_parser = colorcal_fault)]
    faults: Vec<Fault>,
    /// Delay before a `slow` reply that names none, ms.
    #[arg(long, default_value_t = 12_000, value_parser = clap::value_parser!(u64).range(0..=600_000))]
    slow_ms: u64,
    /// Discard bytes that arrive during a measurement instead of queueing them.
    #[arg(long)]
    drop_busy_input: bool,
}

fn colorcal_fault(s: &str) -> Result<Fault, String> {
    let fault = parse_fault(s)?;
    if fault.kind == FaultKind::ErrorCode {
        return Err("the ColorCAL has no documented error status for MES; use another fault".into());
    }
    Ok(fault)
}

pub fn run(args: MockColorCalArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.serial.len() == 8 && args.serial.bytes().all(|b| b.is_ascii_digit()),
        "--serial {}: the ColorCAL's serial number has eight digits",
        args.serial
    );
    let truth = match &args.spectrum {
        Some(spec) => load_target(spec)?,
        None => default_target(),
    };
    let mut cfg = MockConfig::colorcal(truth);
    cfg.speed = args.speed;
    cfg.seed = args.seed;
    cfg.faults = args.faults;
    cfg.slow_ms = args.slow_ms;
    cfg.serial = args.serial;
    cfg.busy_input = if args.drop_busy_input {
        BusyInput::Drop
    } else {
        BusyInput::Queue
    };
    let mock = spawn_mock(cfg).context("cannot open a pseudo-terminal for the simulated ColorCAL MkII")?;
    let path = mock.device_path().display().to_string();
    // First stdout line: the device path, for scripts.
    let mut stdout = std::io::stdout();
    writeln!(stdout, "{path}")?;
    stdout.flush()?;
    eprintln!(
        "Simulated ColorCAL MkII on {path}: run `lightbooth measure --model colorcal --port {path}`. Press Enter \
         here to re-plug it. Ctrl-C stops it."
    );
    power_switch(&mock, "re-plugged")
}
