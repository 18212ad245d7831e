//! `lightbooth reflectance` and `lightbooth illuminant`: the calibrations of
//! [`lightbooth::calibration`] from measurements stored in a database, written
//! as scene spectrum CSVs with their provenance (and stored in the database,
//! as `POST /api/reflectances` and `POST /api/illuminants` do).

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;

use lightbooth::calibration::reflectance::OutOfRange;
use lightbooth::calibration::standard::{WhiteStandard, SHIPPED};
use lightbooth::lab::records::calibration::{self as measured, MeasuredError};
use lightbooth::store::Store;

#[derive(Args, Debug)]
pub struct ReflectanceArgs {
    /// The database with the measurements: sqlite://FILE (the daemon must not
    /// be running on it) or postgres://USER@HOST/DATABASE.
    #[arg(long, default_value = "sqlite://lightbooth.sqlite")]
    db: String,
    /// The sample's measurement id.
    #[arg(long)]
    sample: i64,
    /// The white standard's measurement id (same geometry, in the sample's place).
    #[arg(long)]
    standard: i64,
    /// The standard's calibrated reflectance: a CSV file (`nm,reflectance[,uncertainty]`)
    /// or a shipped standard's name (spectralon_99).
    #[arg(long)]
    standard_reflectance: String,
    /// The scene CSV to write (e.g. scenes/spectra/red_tile.csv).
    #[arg(long)]
    out: PathBuf,
    /// Its column name (default: the file name without .csv).
    #[arg(long)]
    name: Option<String>,
    /// Clip values outside [0, 1] in the CSV (said in its header); else such a reflectance is refused.
    #[arg(long)]
    clip: bool,
    #[arg(long, default_value = "")]
    note: String,
}

#[derive(Args, Debug)]
pub struct IlluminantArgs {
    /// The database with the measurement: sqlite://FILE (the daemon must not
    /// be running on it) or postgres://USER@HOST/DATABASE.
    #[arg(long, default_value = "sqlite://lightbooth.sqlite")]
    db: String,
    /// The white standard's measurement id.
    #[arg(long)]
    measurement: i64,
    /// The standard's calibrated reflectance: a CSV file or a shipped standard's name.
    #[arg(long)]
    standard_reflectance: String,
    /// The scene CSV to write (e.g. scenes/spectra/lamp.csv).
    #[arg(long)]
    out: PathBuf,
    /// Its column name (default: the file name without .csv).
    #[arg(long)]
    name: Option<String>,
    #[arg(long, default_value = "")]
    note: String,
}

fn load_standard(spec: &str) -> anyhow::Result<WhiteStandard> {
    if let Some(s) = WhiteStandard::shipped(spec) {
        return Ok(s);
    }
    let path = Path::new(spec);
    if !path.exists() {
        let names: Vec<&str> = SHIPPED.iter().map(|s| s.0).collect();
        anyhow::bail!(
            "--standard-reflectance {spec}: no such file, and not a shipped standard ({})",
            names.join(", ")
        );
    }
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {spec}"))?;
    let file = path
        .file_name()
        .map(|f| f.to_string_lossy().to_string())
        .unwrap_or_default();
    // The error names the file as given (with its line and column).
    WhiteStandard::parse(&text, spec)
        .map(|mut s| {
            s.file_name = file;
            s
        })
        .map_err(|e| anyhow::anyhow!("--standard-reflectance: {e}"))
}

fn column_name(name: Option<String>, out: &Path) -> String {
    name.unwrap_or_else(|| {
        out.file_stem()
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_default()
    })
}

/// Opens an existing database, holding the daemon's lock (never under a running daemon).
async fn open(db: &str) -> anyhow::Result<(Store, Option<lightbooth::daemon::db_lock::DbLock>)> {
    if let Some(path) = lightbooth::daemon::db_lock::database_path(db) {
        anyhow::ensure!(path.exists(), "--db {db}: no such database file");
    }
    let lock = lightbooth::daemon::db_lock::acquire(db)
        .map_err(|e| anyhow::anyhow!("{e} (while the daemon runs, use POST /api/reflectances or /api/illuminants)"))?;
    let store = Store::open_as_tool(db).await.with_context(|| format!("opening {db}"))?;
    Ok((store, lock))
}

fn cli_error(e: MeasuredError) -> anyhow::Error {
    anyhow::anyhow!(
        "{}",
        e.to_string()
            .replace("field `sample_measurement_id`", "--sample")
            .replace("field `standard_measurement_id`", "--standard")
            .replace("field `measurement_id`", "--measurement")
            .replace("field `name`", "--name")
    )
}

fn write_out(out: &Path, text: &str) -> anyhow::Result<()> {
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    // Written whole next to it, then renamed: never a torn CSV.
    let tmp = out.with_extension("csv.tmp");
    std::fs::write(&tmp, text).with_context(|| format!("writing {}", tmp.display()))?;
    std::fs::rename(&tmp, out).with_context(|| format!("renaming {} to {}", tmp.display(), out.display()))
}

pub fn run_reflectance(args: ReflectanceArgs) -> anyhow::Result<()> {
    let standard = load_standard(&args.standard_reflectance)?;
    let name = column_name(args.name, &args.out);
    measured::check_name(&name).map_err(cli_error)?;
    let runtime = tokio::runtime::Runtime::new().context("starting the async runtime")?;
    runtime.block_on(async move {
        let (store, _lock) = open(&args.db).await?;
        let rule = if args.clip {
            OutOfRange::ClipAndSay
        } else {
            OutOfRange::Refuse
        };
        let row = measured::create_reflectance(&store, args.sample, args.standard, &standard, &name, &args.note)
            .await
            .map_err(cli_error)?;
        let text = measured::reflectance_csv(&store, &row, rule)
            .await
            .map_err(|e| anyhow::anyhow!("reflectance {} is stored, but not written: {e} (or use --clip)", row.id))?;
        write_out(&args.out, &text)?;
        eprintln!(
            "reflectance {} `{}` stored and written to {}{}",
            row.id,
            row.name,
            args.out.display(),
            if row.flags.is_clean() {
                String::new()
            } else {
                format!(
                    "; FLAGGED: {}",
                    lightbooth::calibration::reflectance::describe_flags(&row.flags)
                )
            }
        );
        Ok(())
    })
}

pub fn run_illuminant(args: IlluminantArgs) -> anyhow::Result<()> {
    let standard = load_standard(&args.standard_reflectance)?;
    let name = column_name(args.name, &args.out);
    measured::check_name(&name).map_err(cli_error)?;
    let runtime = tokio::runtime::Runtime::new().context("starting the async runtime")?;
    runtime.block_on(async move {
        let (store, _lock) = open(&args.db).await?;
        let row = measured::create_illuminant(&store, args.measurement, &standard, &name, &args.note)
            .await
            .map_err(cli_error)?;
        let text = measured::illuminant_csv(&store, &row).await.map_err(cli_error)?;
        write_out(&args.out, &text)?;
        eprintln!(
            "illuminant {} `{}` stored and written to {}",
            row.id,
            row.name,
            args.out.display()
        );
        Ok(())
    })
}
