//! Argument definitions and dispatch for every subcommand. The command-line
//! interface is stable: lab scripts and MATLAB users call it.

mod analyze;
mod calibrate;
mod color;
mod display_resolution;
mod experiment;
mod instruments;
mod measure;
mod mock_colorcal;
mod mock_cr250;
mod mock_cs2000;
mod mock_ls100;
mod mock_pr650;
mod mock_pr655;
mod render;
mod serve;
mod stimulus;
mod study;
mod worker;

use clap::{Parser, Subcommand};

#[derive(Parser, Debug)]
#[command(
    name = "lightbooth",
    version,
    about = "Measure a lighting booth with a spectroradiometer (PR-650, PR-655, PR-670, CS-2000, …), render it, and compare"
)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// CIE XYZ, x y, u′ v′ (and CIELAB, ΔE) of every spectrum in a CSV file.
    Color(color::ColorArgs),
    /// Analyses of spectra that do not need the instrument or the renderer.
    #[command(subcommand)]
    Analyze(analyze::AnalyzeCommand),
    /// One averaged measurement from an instrument (real, or simulated by a mock-… command).
    Measure(measure::MeasureArgs),
    /// A simulated PR-650 on a pseudo-terminal; prints the device path first.
    #[command(name = "mock-pr650")]
    MockPr650(mock_pr650::MockPr650Args),
    /// A simulated PR-655 on a pseudo-terminal; prints the device path first.
    #[command(name = "mock-pr655")]
    MockPr655(mock_pr655::MockPr655Args),
    /// A simulated PR-670 on a pseudo-terminal; prints the device path first.
    #[command(name = "mock-pr670")]
    MockPr670(mock_pr655::MockPr655Args),
    /// A simulated Konica Minolta CS-2000 (CS-2000A, CS-3000) on a pseudo-terminal; prints the device path first.
    #[command(name = "mock-cs2000")]
    MockCs2000(mock_cs2000::MockCs2000Args),
    /// A simulated Colorimetry Research CR-250 (or CR-300) on a pseudo-terminal; prints the device path first.
    #[command(name = "mock-cr250")]
    MockCr250(mock_cr250::MockCr250Args),
    /// A simulated CRS ColorCAL MkII on a pseudo-terminal; prints the device path first.
    #[command(name = "mock-colorcal")]
    MockColorCal(mock_colorcal::MockColorCalArgs),
    /// A simulated Konica Minolta LS-100 or CS-100A on a pseudo-terminal; prints the device path first.
    #[command(name = "mock-ls100")]
    MockLs100(mock_ls100::MockLs100Args),
    /// Render a scene in every colour coding at once and measure its targets.
    Render(render::RenderArgs),
    /// The lab daemon: instrument, store, renderer, REST API and dashboards.
    Serve(serve::ServeArgs),
    /// Every coding of every scene against measurements or a converged reference, over seeds.
    Study(study::StudyArgs),
    /// A material's reflectance from a sample and a white-standard measurement, as a scene CSV.
    Reflectance(calibrate::ReflectanceArgs),
    /// The lamp's spectral power distribution from a white-standard measurement, as a scene CSV.
    Illuminant(calibrate::IlluminantArgs),
    /// A rendered OpenEXR image as a measured display's frame-buffer codes (16-bit PNG, raw), with the gamut and ΔE00 report.
    Stimulus(stimulus::StimulusArgs),
    /// At which frame-buffer depth a measured display shows two codings' renderings of a scene apart.
    #[command(name = "display-resolution")]
    DisplayResolution(display_resolution::DisplayResolutionArgs),
    /// The study's oddity experiment: plan its trials, set one up on a display, analyse observers' answers.
    #[command(subcommand)]
    Experiment(experiment::ExperimentCommand),
    /// A render worker: claims the comparisons, renders and studies daemons (`serve --renders workers`) queue in the shared PostgreSQL database.
    Worker(worker::WorkerArgs),
    /// The serial ports, what their USB ids suggest is attached, and (--probe) who answers, never hanging.
    Instruments(instruments::InstrumentsArgs),
}

impl Cli {
    /// True for `serve`, whose logs are the lab's record of a run.
    pub fn is_daemon(&self) -> bool {
        matches!(self.command, Command::Serve(_) | Command::Worker(_))
    }
}

pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Color(args) => color::run(args),
        Command::Analyze(cmd) => analyze::run(cmd),
        Command::Measure(args) => measure::run(args),
        Command::MockPr650(args) => mock_pr650::run(args),
        Command::MockPr655(args) => mock_pr655::run(args, lightbooth::instrument::pr655::Model::Pr655),
        Command::MockPr670(args) => mock_pr655::run(args, lightbooth::instrument::pr655::Model::Pr670),
        Command::MockCs2000(args) => mock_cs2000::run(args),
        Command::MockCr250(args) => mock_cr250::run(args),
        Command::MockColorCal(args) => mock_colorcal::run(args),
        Command::MockLs100(args) => mock_ls100::run(args),
        Command::Render(args) => render::run(args),
        Command::Serve(args) => serve::run(args),
        Command::Worker(args) => worker::run(args),
        Command::Study(args) => study::run(args),
        Command::Reflectance(args) => calibrate::run_reflectance(args),
        Command::Illuminant(args) => calibrate::run_illuminant(args),
        Command::Stimulus(args) => stimulus::run(args),
        Command::DisplayResolution(args) => display_resolution::run(args),
        Command::Experiment(cmd) => experiment::run(cmd),
        Command::Instruments(args) => instruments::run(args),
    }
}

// ---- parsers of numeric flags: out-of-range values are clap errors --------

/// Largest time scale of the simulated PR-650 (`--speed`, `--mock-speed`).
const MAX_TIME_SCALE: f64 = 1000.0;

fn finite_in(s: &str, lo: f64, hi: f64, what: &str) -> Result<f64, String> {
    let v: f64 = s.trim().parse().map_err(|_| format!("`{s}` is not a number"))?;
    if v.is_finite() && (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{v} is outside {lo}–{hi} ({what})"))
    }
}

/// A time scale, 0 (instant) to 1000.
fn time_scale(s: &str) -> Result<f64, String> {
    finite_in(s, 0.0, MAX_TIME_SCALE, "1 = real time, 0 = instant")
}

/// A duration in seconds, 0 to one day.
fn seconds(s: &str) -> Result<f64, String> {
    finite_in(s, 0.0, 86_400.0, "seconds")
}

/// A frequency, above 0 and at most 10 kHz.
fn frequency(s: &str) -> Result<f64, String> {
    let v = finite_in(s, 0.0, 10_000.0, "Hz")?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err("must be above 0 Hz".into())
    }
}

/// A fraction, 0 to below 1.
fn fraction(s: &str) -> Result<f64, String> {
    let v = finite_in(s, 0.0, 1.0, "a fraction")?;
    if v < 1.0 {
        Ok(v)
    } else {
        Err("must be below 1".into())
    }
}

/// Worker threads, 1–1024.
fn threads(s: &str) -> Result<usize, String> {
    match s.trim().parse::<usize>() {
        Ok(n) if (1..=1024).contains(&n) => Ok(n),
        _ => Err(format!("`{s}` is not 1–1024")),
    }
}

/// An illuminant named on the command line: a CIE name (A, D65, F2, F11, E)
/// or `FILE.csv[:COLUMN]` (the column may be left out when the file has one).
fn load_illuminant(spec: &str) -> anyhow::Result<lightbooth::spectrum::Spectrum> {
    use lightbooth::reference_data::{illuminant, Illuminant};
    use lightbooth::spectrum::{table::SpectraTable, SpectralUnit};
    if let Ok(which) = spec.parse::<Illuminant>() {
        return Ok(illuminant(which));
    }
    if !spec.contains(".csv") {
        anyhow::bail!("unknown illuminant `{spec}`: name A, D65, F2, F11 or E, or a FILE.csv[:COLUMN]");
    }
    let (path, column) = split_file_column(spec);
    let table = SpectraTable::read(std::path::Path::new(path))?;
    let column = match column {
        Some(c) => c.to_string(),
        None if table.len() == 1 => table.names().next().unwrap_or_default().to_string(),
        None => anyhow::bail!(
            "{path} has {} columns; say which is the illuminant with {path}:COLUMN ({})",
            table.len(),
            table.names().collect::<Vec<_>>().join(", ")
        ),
    };
    Ok(table.spectrum(&column, SpectralUnit::RelativePower)?)
}

/// `FILE.csv:COLUMN` → (`FILE.csv`, Some(`COLUMN`)); `FILE.csv` → (`FILE.csv`, None).
fn split_file_column(spec: &str) -> (&str, Option<&str>) {
    match spec.rfind(".csv:") {
        Some(i) => (&spec[..i + 4], Some(&spec[i + 5..])),
        None => (spec, None),
    }
}
