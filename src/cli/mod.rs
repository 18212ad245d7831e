//! Argument definitions and dispatch for every subcommand. The command-line
//! interface is stable: lab scripts and MATLAB users call it.

mod analyze;
mod color;
mod measure;
mod mock_pr650;
mod render;
mod serve;
mod study;

use clap::{Parser, Subcommand};

#[derive(Parser, Debug)]
#[command(
    name = "lightbooth",
    version,
    about = "Measure a lighting booth with a PR-650, render it, and compare"
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
    /// One averaged measurement from a PR-650 (real, or simulated by mock-pr650).
    Measure(measure::MeasureArgs),
    /// A simulated PR-650 on a pseudo-terminal; prints the device path first.
    #[command(name = "mock-pr650")]
    MockPr650(mock_pr650::MockPr650Args),
    /// Render a scene in every colour coding at once and measure its targets.
    Render(render::RenderArgs),
    /// The lab daemon: instrument, store, renderer, REST API and dashboards.
    Serve(serve::ServeArgs),
    /// Every coding of every scene against measurements or a converged reference, over seeds.
    Study(study::StudyArgs),
}

impl Cli {
    /// True for `serve`, whose logs are the lab's record of a run.
    pub fn is_daemon(&self) -> bool {
        matches!(self.command, Command::Serve(_))
    }
}

pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Color(args) => color::run(args),
        Command::Analyze(cmd) => analyze::run(cmd),
        Command::Measure(args) => measure::run(args),
        Command::MockPr650(args) => mock_pr650::run(args),
        Command::Render(args) => render::run(args),
        Command::Serve(args) => serve::run(args),
        Command::Study(args) => study::run(args),
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
