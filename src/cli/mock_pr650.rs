//! `lightbooth mock-pr650`: a simulated PR-650 on a pseudo-terminal, for trying
//! `measure` (and any PR-650 client) without the instrument. A thin wrapper
//! around [`lightbooth::instrument::sim::spawn_mock`].

use std::io::{BufRead, Write};
use std::path::Path;
use std::time::Duration;

use anyhow::Context;
use clap::{Args, ValueEnum};

use lightbooth::instrument::sim::{spawn_mock, BeforeFirstMeasurement, BusyInput, Fault, MockConfig};
use lightbooth::reference_data::{illuminant, Illuminant};
use lightbooth::spectrum::{table::SpectraTable, SpectralUnit, Spectrum};

#[derive(Args, Debug)]
pub struct MockPr650Args {
    /// What the instrument is aimed at: a spectral radiance W/(sr·m²·nm) in
    /// FILE.csv[:COLUMN] (any grid covering 380–780 nm). Default: D65 at about 100 cd/m².
    #[arg(long, value_name = "FILE.csv[:COLUMN]")]
    spectrum: Option<String>,
    /// Time scale: 1 = the real instrument's measurement and 9600-baud wire times, 0 = instant.
    #[arg(long, default_value_t = 1.0, value_parser = super::time_scale)]
    speed: f64,
    /// Seed of the simulated noise (same seed, same samples).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Inject a fault: no-answer, truncate, garble, stale, error-code, cable-pull, slow, double-crlf
    /// or link-dies, each optionally `:RATE` (a probability 0–1, `once` or `Nx`); `slow` may name
    /// its delay, e.g. slow@2500ms:once or slow@2.5s. Repeatable.
    #[arg(long = "fault", value_name = "KIND[@DELAY][:RATE]", value_parser = parse_fault)]
    faults: Vec<Fault>,
    /// Delay before a `slow` reply that names none, ms (the driver's default command timeout is 3000 ms).
    #[arg(long, default_value_t = 12_000, value_parser = clap::value_parser!(u64).range(0..=600_000))]
    slow_ms: u64,
    /// Quality code of an `error-code` fault (18 leaves the spectral buffer stale).
    #[arg(long, default_value_t = 18, value_parser = clap::value_parser!(u8).range(0..=99))]
    error_code: u8,
    /// The power-on window for entering remote mode, seconds; 0 = never closes.
    /// Press Enter in this terminal to power-cycle the simulated unit.
    #[arg(long, default_value_t = 5.0, value_parser = super::seconds)]
    remote_window_s: f64,
    /// Serial number reported by `D110`.
    #[arg(long, default_value = "60954303")]
    serial: String,
    /// End the spectral report's first header line in a bare CR.
    #[arg(long)]
    header_cr: bool,
    /// Send replies at once instead of at 9600 baud.
    #[arg(long)]
    no_pace: bool,
    /// The source flickers at this frequency (what `F` reports); default: steady.
    #[arg(long, value_parser = super::frequency)]
    flicker_hz: Option<f64>,
    /// With sync on, measurements fail with code 07.
    #[arg(long)]
    unsyncable: bool,
    /// What `D5` answers before the first measurement.
    #[arg(long, value_enum, default_value_t = BeforeFirst::Zeros)]
    before_first: BeforeFirst,
    /// Discard bytes that arrive during a measurement instead of queueing them.
    #[arg(long)]
    drop_busy_input: bool,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum BeforeFirst {
    Zeros,
    Silent,
}

pub(super) fn parse_fault(s: &str) -> Result<Fault, String> {
    s.parse()
}

/// D65 scaled to about 100 cd/m², the default target.
pub(super) fn default_target() -> Spectrum {
    let d65 = illuminant(Illuminant::D65);
    let values = d65.values().iter().map(|v| v * 1.4e-5).collect();
    Spectrum::new(d65.grid().clone(), SpectralUnit::SpectralRadiance, values).expect("D65 is a valid spectrum")
}

pub(super) fn load_target(spec: &str) -> anyhow::Result<Spectrum> {
    let (path, column) = super::split_file_column(spec);
    let table = SpectraTable::read(Path::new(path))?;
    let column = match column {
        Some(c) => c.to_string(),
        None if table.len() == 1 => table.names().next().unwrap_or_default().to_string(),
        None => anyhow::bail!(
            "{path} has {} columns; say which is the radiance with {path}:COLUMN ({})",
            table.len(),
            table.names().collect::<Vec<_>>().join(", ")
        ),
    };
    Ok(table.spectrum(&column, SpectralUnit::SpectralRadiance)?)
}

pub fn run(args: MockPr650Args) -> anyhow::Result<()> {
    if !(args.speed >= 0.0 && args.speed.is_finite()) {
        anyhow::bail!("--speed {} must be 0 or more", args.speed);
    }
    let truth = match &args.spectrum {
        Some(spec) => load_target(spec)?,
        None => default_target(),
    };
    let mut cfg = MockConfig::new(truth);
    cfg.speed = args.speed;
    cfg.seed = args.seed;
    cfg.faults = args.faults;
    cfg.slow_ms = args.slow_ms;
    cfg.error_code = args.error_code;
    cfg.remote_window_ms = (args.remote_window_s > 0.0).then_some((args.remote_window_s * 1000.0) as u64);
    cfg.serial = args.serial;
    cfg.header_bare_cr = args.header_cr;
    cfg.pace_output = !args.no_pace;
    cfg.flicker_hz = args.flicker_hz;
    cfg.unsyncable = args.unsyncable;
    cfg.before_first = match args.before_first {
        BeforeFirst::Zeros => BeforeFirstMeasurement::StaleZeros,
        BeforeFirst::Silent => BeforeFirstMeasurement::NoReply,
    };
    cfg.busy_input = if args.drop_busy_input {
        BusyInput::Drop
    } else {
        BusyInput::Queue
    };
    let window = cfg.remote_window_ms;
    let mock = spawn_mock(cfg).context("cannot open a pseudo-terminal for the simulated PR-650")?;
    let path = mock.device_path().display().to_string();
    // First stdout line: the device path, for scripts.
    let mut stdout = std::io::stdout();
    writeln!(stdout, "{path}")?;
    stdout.flush()?;
    match window {
        Some(ms) => eprintln!(
            "Simulated PR-650 on {path}, just powered on: run `lightbooth measure --port {path}` within {:.1} s \
             (the real unit's remote-mode window). Press Enter here to power-cycle it. Ctrl-C stops it.",
            ms as f64 / 1000.0
        ),
        None => eprintln!(
            "Simulated PR-650 on {path}: run `lightbooth measure --port {path}`. Press Enter here to power-cycle \
             it. Ctrl-C stops it."
        ),
    }
    power_switch(&mock, "the remote-mode window is open again")
}

/// Runs until Ctrl-C: Enter on stdin power-cycles the simulated unit
/// (`message` says what that did); a pulled simulated cable ends it.
pub(super) fn power_switch(mock: &lightbooth::instrument::sim::MockHandle, message: &str) -> anyhow::Result<()> {
    // Enter on stdin = power switch. At EOF (`</dev/null`, `nohup`, CI) the
    // reader thread ends and the unit simply stays on: stop listening then,
    // rather than polling a closed channel, which returns at once (a busy loop).
    let (tx, rx) = std::sync::mpsc::channel::<()>();
    std::thread::spawn(move || {
        for line in std::io::stdin().lock().lines() {
            if line.is_err() || tx.send(()).is_err() {
                break;
            }
        }
    });
    let mut stdin_open = true;
    loop {
        if stdin_open {
            match rx.recv_timeout(Duration::from_millis(200)) {
                Ok(()) => {
                    mock.power_cycle();
                    eprintln!("power-cycled: {message}");
                }
                Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
                Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => stdin_open = false,
            }
        } else {
            std::thread::sleep(Duration::from_millis(200));
        }
        if mock.is_unplugged() {
            anyhow::bail!("the simulated cable was pulled (fault cable-pull); the simulator has stopped");
        }
    }
}
