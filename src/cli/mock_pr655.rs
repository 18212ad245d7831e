//! `lightbooth mock-pr655` and `lightbooth mock-pr670`: a simulated PR-655 or
//! PR-670 on a pseudo-terminal, for trying `measure --model pr655|pr670` (and
//! any PR-655/670 client) without the instrument. Every behaviour the
//! protocol sheet leaves uncertain (`docs/src/instruments/pr655-670-protocol.md` §13)
//! is a flag. A thin wrapper around [`lightbooth::instrument::sim::spawn_mock`].

use std::io::Write;

use anyhow::Context;
use clap::{Args, ValueEnum};

use lightbooth::instrument::pr655::protocol::{LineStyle, StatusStyle};
use lightbooth::instrument::pr655::Model;
use lightbooth::instrument::sim::{
    spawn_mock, AfterFailure, BusyInput, Fault, MockConfig, Pr655Switches, StrayTerminator, SyncFailure,
};

use super::mock_pr650::{default_target, load_target, parse_fault, power_switch};

#[derive(Args, Debug)]
pub struct MockPr655Args {
    /// What the instrument is aimed at: a spectral radiance W/(sr·m²·nm) in
    /// FILE.csv[:COLUMN] (any grid covering 380–780 nm). Default: D65 at about 100 cd/m².
    #[arg(long, value_name = "FILE.csv[:COLUMN]")]
    spectrum: Option<String>,
    /// Time scale of measurements: 1 = the real instrument's, 0 = instant (replies go at USB speed).
    #[arg(long, default_value_t = 1.0, value_parser = super::time_scale)]
    speed: f64,
    /// Seed of the simulated noise (same seed, same samples).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Inject a fault into the `M5` reply: no-answer, truncate, garble, stale, error-code,
    /// cable-pull, slow, double-crlf or link-dies, each optionally `:RATE` (a probability 0–1,
    /// `once` or `Nx`); `slow` may name its delay, e.g. slow@2500ms:once. Repeatable.
    #[arg(long = "fault", value_name = "KIND[@DELAY][:RATE]", value_parser = parse_fault)]
    faults: Vec<Fault>,
    /// Delay before a `slow` reply that names none, ms.
    #[arg(long, default_value_t = 12_000, value_parser = clap::value_parser!(u64).range(0..=600_000))]
    slow_ms: u64,
    /// Status of an `error-code` fault (−8 weak light, −2 overload, −1/−10 sync, −12 adaptive time-out).
    #[arg(long, default_value_t = -8, allow_negative_numbers = true,
          value_parser = clap::value_parser!(i32).range(-9999..=-1))]
    error_status: i32,
    /// Serial number reported by `D110`.
    #[arg(long, default_value = "67065106")]
    serial: String,
    /// The source flickers at this frequency (what `F` reports); default: steady (`F` fails with −3).
    #[arg(long, value_parser = super::frequency)]
    flicker_hz: Option<f64>,
    /// With auto sync on (`SS1`), measurements fail (with the `--sync-failure` status), even
    /// though `F` finds the flicker. A steady source, or one outside 20–400 Hz, is unsyncable anyway.
    #[arg(long)]
    unsyncable: bool,
    /// §13.9: the status of an `SS1` measurement of an unsyncable source: cannot-auto-sync (−10)
    /// or not-constant (−1).
    #[arg(long, value_enum, default_value_t = SyncFail::CannotAutoSync)]
    sync_failure: SyncFail,
    /// §13.7: time auto sync (`SS1`) spends finding the source's frequency before each
    /// measurement, ms at --speed 1 (no source documents it).
    #[arg(long, default_value_t = 1000, value_parser = clap::value_parser!(u64).range(0..=60_000))]
    sync_detection_ms: u64,
    /// Discard bytes that arrive during a measurement instead of queueing them.
    #[arg(long)]
    drop_busy_input: bool,
    /// §13.2: take the letters of `PHOTO` only when each arrives in its own read (a burst is
    /// ignored). Default: any pacing, as real units answer clients that write with no pause (§1).
    #[arg(long)]
    strict_photo: bool,
    /// §13.2: the banner's latency, ms (a late banner past 10 s is a link fault to try).
    #[arg(long, default_value_t = 300, value_parser = clap::value_parser!(u64).range(0..=60_000))]
    banner_latency_ms: u64,
    /// §13.10: never answer `PHOTO`.
    #[arg(long)]
    no_banner: bool,
    /// §13.2: what a stray CR/LF right after `PHOTO` produces.
    #[arg(long, value_enum, default_value_t = Stray::Ignore)]
    stray_terminator: Stray,
    /// §13.2: a second `PHOTO` in remote mode gets no banner (default: only on the PR-670).
    #[arg(long, value_enum)]
    photo_only_once: Option<OnOff>,
    /// §13.4: only CR ends a command (an LF is ignored). Default: CR or LF, as real units answer
    /// LF-terminated commands (§1).
    #[arg(long)]
    cr_only: bool,
    /// §13.4: accept lower-case commands.
    #[arg(long)]
    any_case: bool,
    /// §13.5: status width (`00000`, `-0008`) or (`0000`, `-8`).
    #[arg(long, value_enum, default_value_t = Status::FiveDigits)]
    status: Status,
    /// §13.8: the 16th byte of a spectral line.
    #[arg(long, value_enum, default_value_t = Lines::TrailingSpace)]
    lines: Lines,
    /// §13.9: what `D` answers after a failed measurement.
    #[arg(long, value_enum, default_value_t = After::Error)]
    after_failure: After,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum Stray {
    Ignore,
    EmptyLine,
    IllegalCommand,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum OnOff {
    On,
    Off,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum Status {
    FiveDigits,
    FourDigits,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum Lines {
    TrailingSpace,
    LeadingSpace,
    ThreeDigitExponent,
    Plain,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum SyncFail {
    CannotAutoSync,
    NotConstant,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum After {
    Error,
    Stale,
    NoData,
}

pub fn run(args: MockPr655Args, model: Model) -> anyhow::Result<()> {
    let truth = match &args.spectrum {
        Some(spec) => load_target(spec)?,
        None => default_target(),
    };
    let defaults = Pr655Switches::for_model(model);
    let switches = Pr655Switches {
        strict_photo: args.strict_photo,
        banner_latency_ms: args.banner_latency_ms,
        no_banner: args.no_banner,
        stray_terminator: match args.stray_terminator {
            Stray::Ignore => StrayTerminator::Ignore,
            Stray::EmptyLine => StrayTerminator::EmptyLine,
            Stray::IllegalCommand => StrayTerminator::IllegalCommand,
        },
        photo_only_once: args
            .photo_only_once
            .map_or(defaults.photo_only_once, |o| matches!(o, OnOff::On)),
        accept_lf: !args.cr_only,
        case_insensitive: args.any_case,
        status_style: match args.status {
            Status::FiveDigits => StatusStyle::FiveDigits,
            Status::FourDigits => StatusStyle::FourDigits,
        },
        line_style: match args.lines {
            Lines::TrailingSpace => LineStyle::TrailingSpace,
            Lines::LeadingSpace => LineStyle::LeadingSpace,
            Lines::ThreeDigitExponent => LineStyle::ThreeDigitExponent,
            Lines::Plain => LineStyle::Plain,
        },
        after_failure: match args.after_failure {
            After::Error => AfterFailure::Error,
            After::Stale => AfterFailure::Stale,
            After::NoData => AfterFailure::NoData,
        },
        error_status: args.error_status,
        sync_failure: match args.sync_failure {
            SyncFail::CannotAutoSync => SyncFailure::CannotAutoSync,
            SyncFail::NotConstant => SyncFailure::NotConstant,
        },
        sync_detection_ms: args.sync_detection_ms,
        ..defaults
    };
    let mut cfg = MockConfig::pr655(truth, switches);
    cfg.speed = args.speed;
    cfg.seed = args.seed;
    cfg.faults = args.faults;
    cfg.slow_ms = args.slow_ms;
    cfg.serial = args.serial;
    cfg.flicker_hz = args.flicker_hz;
    cfg.unsyncable = args.unsyncable;
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
        "Simulated {name} on {path}: run `lightbooth measure --model {flag} --port {path}`. Press Enter here to \
         power-cycle it. Ctrl-C stops it."
    );
    power_switch(&mock, "back in local mode, waiting for PHOTO")
}
