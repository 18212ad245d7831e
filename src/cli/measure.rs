//! `lightbooth measure`: one averaged measurement from any model lightbooth
//! drives (real or simulated), printed as a summary, JSON or CSV (CSV only
//! from a spectroradiometer).

use std::io::Write;
use std::path::PathBuf;
use std::time::UNIX_EPOCH;

use clap::Args;
use serde::Serialize;

use lightbooth::instrument::{AveragedMeasurement, InstrumentSettings, Reading};
use lightbooth::lab::measure::files::{spectrum_csv, SampleSpectrum};
use tokio_util::sync::CancellationToken;

#[derive(Args, Debug)]
pub struct MeasureArgs {
    /// Serial device (a PR-650: /dev/ttyUSB0; a PR-655/PR-670: /dev/ttyACM0; or the path a `mock-…` command prints).
    #[arg(long)]
    port: Option<String>,
    /// Instrument settings (instruments/pr650.toml, pr655.toml, pr670.toml, colorcal.toml, ls100.toml); the model's defaults apply without it.
    #[arg(long, value_name = "FILE.toml")]
    config: Option<PathBuf>,
    /// The instrument model: pr650, pr655, pr670, cs2000, cs2000a or cs3000 (default: the --config file's, else pr650).
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(lightbooth::instrument::MODEL_FLAGS))]
    model: Option<String>,
    /// Samples to average, 1–99 (the limit of every model lightbooth drives; the driver checks its own).
    #[arg(long, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=99))]
    samples: Option<usize>,
    /// Extra attempts for samples lost to an instrument error or a link fault, 0–99.
    #[arg(long, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(0..=99))]
    retries: Option<usize>,
    /// One JSON object: wavelength_nm, radiance, radiance_sd, samples, Y, x, y, luminance_cv, instrument.
    #[arg(long, conflicts_with = "csv")]
    json: bool,
    /// CSV: nm, mean radiance, its SD, then every good sample.
    #[arg(long)]
    csv: bool,
}

#[derive(Serialize)]
struct InstrumentJson {
    model: String,
    serial: Option<String>,
}

#[derive(Serialize)]
struct SampleJson {
    index: usize,
    /// Seconds since the Unix epoch (UTC) when the sample was taken.
    time: f64,
    code: i32,
    message: String,
    /// W/(sr·m²·nm); null for a bad sample (its buffer is stale or untrustworthy).
    radiance: Option<Vec<f64>>,
    /// cd/m² as the instrument reported it; null for a bad sample.
    luminance: Option<f64>,
    /// X, Y, Z (cd/m²) as the instrument reported them, when it does.
    #[serde(rename = "instrument_XYZ")]
    instrument_xyz: Option<[f64; 3]>,
}

#[derive(Serialize)]
struct MeasurementJson {
    /// What the instrument gave: `spectrum`, `XYZ` or `luminance`.
    reading: &'static str,
    /// Empty when the instrument gives no spectrum.
    wavelength_nm: Vec<f64>,
    radiance: Vec<f64>,
    radiance_sd: Vec<f64>,
    samples: Vec<SampleJson>,
    #[serde(rename = "Y")]
    luminance_cd_m2: f64,
    /// The observer of Y, x, y: CIE 1931 2° from a spectrum (as the PR-650
    /// itself reports), else the observer of the instrument's own reading.
    observer: lightbooth::colorimetry::Observer,
    /// Null from a luminance meter.
    x: Option<f64>,
    y: Option<f64>,
    /// The instrument's own mean XYZ, when it gives one.
    #[serde(rename = "instrument_XYZ")]
    instrument_xyz: Option<[f64; 3]>,
    luminance_cv: f64,
    instrument: InstrumentJson,
}

impl From<&AveragedMeasurement> for MeasurementJson {
    fn from(m: &AveragedMeasurement) -> MeasurementJson {
        MeasurementJson {
            reading: m.reading.name(),
            wavelength_nm: m
                .mean
                .as_ref()
                .map(|s| s.grid().wavelengths().to_vec())
                .unwrap_or_default(),
            radiance: m.mean.as_ref().map(|s| s.values().to_vec()).unwrap_or_default(),
            radiance_sd: m.sd.clone(),
            samples: m
                .samples
                .iter()
                .map(|s| SampleJson {
                    index: s.index,
                    time: s
                        .time
                        .duration_since(UNIX_EPOCH)
                        .map(|d| d.as_secs_f64())
                        .unwrap_or(0.0),
                    code: s.code.code,
                    message: s.code.message.clone(),
                    radiance: s.radiance.as_ref().map(|r| r.values().to_vec()),
                    luminance: s.luminance,
                    instrument_xyz: s.instrument_xyz,
                })
                .collect(),
            luminance_cd_m2: m.luminance_cd_m2,
            observer: reading_observer(m.reading),
            x: m.x,
            y: m.y,
            instrument_xyz: m.instrument_xyz,
            luminance_cv: m.luminance_cv,
            instrument: InstrumentJson {
                model: m.info.model.clone(),
                serial: m.info.serial.clone(),
            },
        }
    }
}

/// The observer of a measurement's Y, x, y as `measure` reports them.
fn reading_observer(reading: Reading) -> lightbooth::colorimetry::Observer {
    match reading {
        Reading::Spectrum => lightbooth::colorimetry::Observer::Cie1931,
        Reading::Tristimulus { observer } | Reading::Luminance { observer } => observer,
    }
}

pub fn run(args: MeasureArgs) -> anyhow::Result<()> {
    let mut settings = match &args.config {
        Some(path) => InstrumentSettings::from_toml_file(path)?,
        None => {
            InstrumentSettings::defaults_for(args.model.as_deref().unwrap_or("pr650")).map_err(anyhow::Error::msg)?
        }
    };
    if let (Some(model), Some(path)) = (&args.model, &args.config) {
        let wanted = InstrumentSettings::defaults_for(model).map_err(anyhow::Error::msg)?;
        anyhow::ensure!(
            wanted.capabilities().model == settings.capabilities().model,
            "--model {model} but {} is a {} settings file: drop --model or use that model's file",
            path.display(),
            settings.capabilities().model
        );
    }
    settings.set_samples(args.samples, args.retries);
    settings.validate().map_err(|e| anyhow::anyhow!("bad settings: {e}"))?;
    let port = args
        .port
        .clone()
        .or_else(|| settings.port().map(str::to_string))
        .ok_or_else(|| {
            anyhow::anyhow!("no port: pass --port PATH (e.g. /dev/ttyUSB0) or set `port` in the --config file")
        })?;
    let mut instrument = settings.open(&port)?;
    let cancel = CancellationToken::new();
    let samples = settings.capabilities().default_samples;
    // Progress on stderr (stdout stays machine-readable): a measurement takes seconds per sample.
    let m = instrument.measure_averaged(
        samples,
        &cancel,
        &mut |s| match s.luminance.or(s.instrument_xyz.map(|v| v[1])) {
            Some(y) if s.code.is_ok() => eprintln!("sample {}: Y = {y:.4} cd/m²", s.index + 1),
            _ => eprintln!("sample {}: {} (not averaged)", s.index + 1, s.code),
        },
    )?;
    let out = std::io::stdout();
    if args.json {
        serde_json::to_writer(out.lock(), &MeasurementJson::from(&m))?;
        println!();
    } else if args.csv {
        let Some(mean) = &m.mean else {
            anyhow::bail!(
                "--csv writes a spectrum, and the {} gives none (it measures {}): use --json",
                m.info.model,
                m.reading.name()
            );
        };
        // The file the API serves as `/api/measurements/{id}/spectrum.csv`.
        let samples: Vec<SampleSpectrum> = m
            .good_samples()
            .filter_map(|s| {
                s.radiance.as_ref().map(|r| SampleSpectrum {
                    index: s.index,
                    radiance: r.values(),
                })
            })
            .collect();
        let csv = spectrum_csv(mean.grid().wavelengths(), Some((mean.values(), &m.sd)), &samples)
            .map_err(|e| anyhow::anyhow!("writing the CSV: {e}"))?;
        out.lock().write_all(&csv)?;
    } else {
        let good = m.good_samples().count();
        println!(
            "{} serial {}: {} of {} samples good",
            m.info.model,
            m.info.serial.as_deref().unwrap_or("unknown"),
            good,
            m.samples.len()
        );
        for s in m.samples.iter().filter(|s| !s.code.is_ok()) {
            println!("  sample {} not averaged: {}", s.index, s.code);
        }
        let observer = reading_observer(m.reading);
        match (m.x, m.y) {
            (Some(x), Some(y)) => println!(
                "Y = {:.4} cd/m²  x = {x:.4}  y = {y:.4}  (observer {observer}, as the instrument reports)",
                m.luminance_cd_m2
            ),
            _ => println!(
                "Y = {:.4} cd/m²  (observer {observer}; the {} measures luminance only)",
                m.luminance_cd_m2, m.info.model
            ),
        }
        println!("luminance CV = {:.3} %", m.luminance_cv * 100.0);
        match &m.mean {
            Some(mean) => println!("spectrum: {} (use --json or --csv for the values)", mean.grid()),
            None => println!("no spectrum: the {} measures {}", m.info.model, m.reading.name()),
        }
    }
    Ok(())
}
