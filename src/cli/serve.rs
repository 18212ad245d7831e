//! `lightbooth serve`: the lab daemon (see `lightbooth::daemon`).

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::Context;
use clap::Args;
use serde::Deserialize;

use lightbooth::colorimetry::Observer;
use lightbooth::daemon::{self, DaemonOptions};
use lightbooth::instrument::sim::Fault;
use lightbooth::instrument::InstrumentSettings;
use lightbooth::lab::render::worker_queue::RenderPlace;
use lightbooth::store::Booth;

#[derive(Args, Debug)]
pub struct ServeArgs {
    /// Daemon settings (TOML); every key optional. Command-line flags override it.
    #[arg(long, default_value = "lightbooth.toml")]
    config: PathBuf,
    /// Run a simulated instrument on a pseudo-terminal instead of opening the real port: the
    /// model the instrument settings name (a PR-650 without them), or MODEL: a spectroradiometer
    /// (pr650, pr655, pr670, cs2000, cs2000a, cs3000, cr250, cr300), a colorimeter (colorcal,
    /// cs100a) or a luminance meter (ls100), e.g. `--mock cs2000`.
    #[arg(long, value_name = "MODEL", num_args = 0..=1, default_missing_value = "settings",
          value_parser = mock_model)]
    mock: Option<String>,
    /// The database: sqlite://lightbooth.sqlite (one booth; created if
    /// missing) or postgres://USER@HOST/DATABASE (a lab's shared server; the
    /// database must exist).
    #[arg(long)]
    db: Option<String>,
    /// Address to listen on. Loopback by default; elsewhere, reads need the token too.
    #[arg(long)]
    bind: Option<SocketAddr>,
    /// A host name the daemon answers requests for besides `localhost` and
    /// its own addresses (repeatable), e.g. the booth PC's name when the
    /// dashboard is opened by it. Others get 421: the defence against DNS
    /// rebinding.
    #[arg(long = "allowed-host", value_name = "NAME")]
    allowed_hosts: Vec<String>,
    /// File holding the write token (else LIGHTBOOTH_TOKEN, else one is generated).
    #[arg(long)]
    token_file: Option<PathBuf>,
    /// Instrument settings (port, timeouts, retries, samples), or `auto`: probe the serial ports
    /// (as `lightbooth instruments --probe`) and drive the one instrument that identifies itself,
    /// with its model's defaults.
    #[arg(long, value_name = "FILE.toml|auto")]
    instrument: Option<PathBuf>,
    /// With --instrument auto: also probe this port (one sysfs does not list, e.g. a simulator's
    /// pseudo-terminal). Repeatable.
    #[arg(long = "probe-port", value_name = "PATH", requires = "instrument")]
    probe_ports: Vec<String>,
    /// Time scale of the simulated instrument (--mock): 1 = the real model's timing, 0 = instant.
    #[arg(long, value_parser = super::time_scale)]
    mock_speed: Option<f64>,
    /// Fault injected into the simulated instrument's link (--mock), KIND[@DELAY][:RATE]
    /// (repeatable): KIND one of
    /// no-answer, truncate, garble, stale, error-code, cable-pull, slow, double-crlf, link-dies;
    /// RATE a probability 0–1, `once` or `Nx`; `slow` takes its delay, e.g. slow@2500ms:once
    /// (default 12 s). Also settable while running: POST /api/mock/faults.
    #[arg(long = "mock-fault", value_name = "KIND[@DELAY][:RATE]")]
    mock_faults: Vec<Fault>,
    /// The observer of every x,y, XYZ, CIELAB and ΔE the daemon computes and
    /// charts: judd-vos-1978 (the study's; default), cie-1931, cie-1964-10, cie-2015-2 or cie-2015-10.
    #[arg(long)]
    observer: Option<Observer>,
    /// The folder of scene files the daemon measures, renders and compares
    /// (default: the config file's `scenes_dir`, else `scenes` in this
    /// folder, else the `scenes` folder of the repository this binary was
    /// built in or from).
    #[arg(long, value_name = "DIR")]
    scenes: Option<PathBuf>,
    /// With --mock: a folder of scene files with the same ids as the scenes
    /// that the simulated instrument measures instead of the model (the booth as
    /// it is, e.g. scenes/truth).
    #[arg(long, requires = "mock")]
    mock_world: Option<PathBuf>,
    /// The booth this daemon and its instrument measure in, recorded with
    /// every measurement (letters, digits, `-`, `_`, `.`). Several booths
    /// sharing one PostgreSQL database each give their own; one booth needs
    /// none (`default`).
    #[arg(long)]
    booth: Option<Booth>,
    /// Where comparisons, renders and studies run: `here` (the default) or
    /// `workers` (`lightbooth worker` processes sharing the PostgreSQL
    /// database; the daemon publishes its scenes for them).
    #[arg(long, value_parser = clap::builder::ValueParser::new(|s: &str| s.parse::<RenderPlace>()))]
    renders: Option<RenderPlace>,
}

/// `lightbooth.toml`: the daemon's settings file.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct ConfigFile {
    db: Option<String>,
    bind: Option<SocketAddr>,
    /// Host names besides `localhost` and the daemon's addresses (see `--allowed-host`).
    allowed_hosts: Option<Vec<String>>,
    token_file: Option<PathBuf>,
    instrument: Option<PathBuf>,
    scenes_dir: Option<PathBuf>,
    cache_dir: Option<PathBuf>,
    codings: Option<Vec<String>>,
    render_samples: Option<u64>,
    /// Camera paths in all of a render's dashboard preview.
    preview_paths: Option<u64>,
    mock_speed: Option<f64>,
    observer: Option<String>,
    mock_world: Option<PathBuf>,
    booth: Option<String>,
    /// Seconds between the daemon's lease renewals (default 2).
    heartbeat_seconds: Option<f64>,
    /// Seconds without a heartbeat after which other daemons on the same
    /// database count this one gone and mark its unfinished work
    /// interrupted (default 10; longer than `heartbeat_seconds`).
    lease_seconds: Option<f64>,
    /// `here` or `workers` (see `--renders`).
    renders: Option<String>,
}

/// A positive number of seconds from key `key` of the config file.
fn seconds_key(config: &Path, key: &str, value: Option<f64>, default: Duration) -> anyhow::Result<Duration> {
    match value {
        None => Ok(default),
        Some(s) if s.is_finite() && s > 0.0 && s < 86_400.0 => Ok(Duration::from_secs_f64(s)),
        Some(s) => anyhow::bail!(
            "{}: key `{key}`: {s} is not a number of seconds between 0 and 86400",
            config.display()
        ),
    }
}

/// The scenes folder: `--scenes`, else the config file's `scenes_dir`
/// (relative to the folder it is run from, as every path of the file), else
/// the first of `scenes` in the current folder, the `scenes` folder of the
/// repository the running binary sits in (`REPO/target/release/lightbooth`)
/// and that of the repository it was built from. A folder named but not
/// there is an error naming it and saying what to do; none found, the same.
fn scenes_folder(flag: Option<PathBuf>, file: Option<PathBuf>, config: &Path) -> anyhow::Result<PathBuf> {
    let named = |dir: PathBuf, how: String| -> anyhow::Result<PathBuf> {
        anyhow::ensure!(
            dir.is_dir(),
            "cannot read the scenes folder {} ({how}): not a folder; give the folder of the scene files              (the repository's `scenes`) with --scenes DIR",
            dir.display()
        );
        Ok(dir)
    };
    if let Some(dir) = flag {
        return named(dir, "--scenes".into());
    }
    if let Some(dir) = file {
        return named(dir, format!("key `scenes_dir` of {}", config.display()));
    }
    let here = PathBuf::from("scenes");
    let beside_binary = std::env::current_exe().ok().and_then(|exe| {
        exe.ancestors()
            .skip(1)
            .map(|dir| dir.join("scenes"))
            .find(|dir| dir.join("white.toml").is_file())
    });
    let built_from = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let candidates: Vec<PathBuf> = std::iter::once(here)
        .chain(beside_binary)
        .chain(std::iter::once(built_from))
        .collect();
    match candidates.iter().find(|dir| dir.is_dir()) {
        Some(dir) => Ok(dir.clone()),
        None => anyhow::bail!(
            "no scenes folder: looked in {}; run from the repository's root or give the folder of the scene              files with --scenes DIR",
            candidates
                .iter()
                .map(|d| std::path::absolute(d).unwrap_or_else(|_| d.clone()).display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

fn read_config(path: &Path, explicit: bool) -> anyhow::Result<ConfigFile> {
    match std::fs::read_to_string(path) {
        Ok(text) => toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display())),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound && !explicit => Ok(ConfigFile::default()),
        Err(e) => Err(anyhow::anyhow!("cannot read {}: {e}", path.display())),
    }
}

pub fn run(args: ServeArgs) -> anyhow::Result<()> {
    let explicit = args.config != Path::new("lightbooth.toml");
    let file = read_config(&args.config, explicit)?;
    let explicit_instrument_file = args.instrument.is_some() || file.instrument.is_some();
    let instrument_path = args
        .instrument
        .or(file.instrument)
        .unwrap_or_else(|| "instruments/pr650.toml".into());
    let named_model = args.mock.as_deref().filter(|m| *m != "settings");
    let instrument = if instrument_path == Path::new("auto") {
        anyhow::ensure!(
            args.mock.is_none(),
            "--instrument auto looks for a real instrument; with --mock, name the model: --mock MODEL"
        );
        let (port, flag) = lightbooth::instrument::discovery::find_one_instrument(
            Path::new("/sys"),
            &args.probe_ports,
            std::time::Duration::from_secs(2),
        )
        .map_err(|e| anyhow::anyhow!("--instrument auto: {e}"))?;
        eprintln!("--instrument auto: found a {flag} on {port}; driving it with the model's default settings");
        let mut settings = InstrumentSettings::defaults_for(flag).map_err(anyhow::Error::msg)?;
        settings.set_port(port);
        settings
    } else {
        match (instrument_path.exists(), named_model) {
            (true, None) => InstrumentSettings::from_toml_file(&instrument_path)?,
            (true, Some(model)) => {
                let file = InstrumentSettings::from_toml_file(&instrument_path)?;
                let wanted = InstrumentSettings::defaults_for(model).map_err(anyhow::Error::msg)?;
                let explicit_file = explicit_instrument_file;
                if wanted.capabilities().model == file.capabilities().model {
                    file
                } else {
                    anyhow::ensure!(
                        !explicit_file,
                        "--mock {model} but {} is a {} settings file: drop one of them",
                        instrument_path.display(),
                        file.capabilities().model
                    );
                    wanted
                }
            }
            (false, Some(model)) => InstrumentSettings::defaults_for(model).map_err(anyhow::Error::msg)?,
            (false, None) => {
                anyhow::ensure!(
                    args.mock.is_some(),
                    "instrument settings {} not found",
                    instrument_path.display()
                );
                InstrumentSettings::default()
            }
        }
    };
    let booth = match (args.booth, file.booth) {
        (Some(b), _) => b,
        (None, Some(name)) => name
            .parse()
            .map_err(|e| anyhow::anyhow!("{}: key `booth`: {e}", args.config.display()))?,
        (None, None) => Booth::default(),
    };
    let heartbeat = seconds_key(
        &args.config,
        "heartbeat_seconds",
        file.heartbeat_seconds,
        daemon::DEFAULT_HEARTBEAT,
    )?;
    let lease = seconds_key(&args.config, "lease_seconds", file.lease_seconds, daemon::DEFAULT_LEASE)?;
    anyhow::ensure!(
        lease > heartbeat,
        "{}: key `lease_seconds` ({} s) must be longer than `heartbeat_seconds` ({} s)",
        args.config.display(),
        lease.as_secs_f64(),
        heartbeat.as_secs_f64()
    );
    let renders = match (args.renders, file.renders) {
        (Some(r), _) => r,
        (None, Some(name)) => name
            .parse()
            .map_err(|e| anyhow::anyhow!("{}: key `renders`: {e}", args.config.display()))?,
        (None, None) => RenderPlace::Here,
    };
    // The flags add to the file's list.
    let mut allowed_hosts = file.allowed_hosts.unwrap_or_default();
    for name in &allowed_hosts {
        lightbooth::http::hosts::parse_allowed_host(name)
            .map_err(|e| anyhow::anyhow!("{}: key `allowed_hosts`: {e}", args.config.display()))?;
    }
    for name in &args.allowed_hosts {
        lightbooth::http::hosts::parse_allowed_host(name).map_err(|e| anyhow::anyhow!("--allowed-host: {e}"))?;
    }
    allowed_hosts.extend(args.allowed_hosts);
    let options = DaemonOptions {
        allowed_hosts,
        renders,
        heartbeat,
        lease,
        booth,
        bind: args
            .bind
            .or(file.bind)
            .unwrap_or_else(|| "127.0.0.1:8650".parse().expect("valid address")),
        db_url: args
            .db
            .or(file.db)
            .unwrap_or_else(|| "sqlite://lightbooth.sqlite".into()),
        mock: args.mock.is_some(),
        mock_speed: args.mock_speed.or(file.mock_speed).unwrap_or(1.0),
        mock_faults: args.mock_faults,
        instrument,
        scenes_dir: scenes_folder(args.scenes, file.scenes_dir, &args.config)?,
        cache_dir: file.cache_dir.unwrap_or_else(|| ".lightbooth-cache".into()),
        token_file: args.token_file.or(file.token_file),
        default_token_file: "lightbooth.token".into(),
        codings: file.codings.unwrap_or_else(|| {
            ["rgb", "srgb", "nstep3", "nstep9", "nstep27", "nstep81", "spectral"]
                .map(String::from)
                .to_vec()
        }),
        render_samples: file.render_samples.unwrap_or(16_384),
        preview_paths: match file.preview_paths {
            Some(0) => anyhow::bail!(
                "{}: key `preview_paths`: 0; give 1 or more paths",
                args.config.display()
            ),
            Some(n) => n,
            None => lightbooth::render::sensor::PREVIEW_PATH_BUDGET,
        },
        observer: match (args.observer, file.observer) {
            (Some(o), _) => o,
            (None, Some(name)) => name
                .parse()
                .map_err(|e| anyhow::anyhow!("{}: key `observer`: {e}", args.config.display()))?,
            (None, None) => Observer::JuddVos,
        },
        mock_world: args.mock_world.or(file.mock_world),
    };
    if let Some(world) = &options.mock_world {
        anyhow::ensure!(
            options.mock,
            "--mock-world needs --mock (a real booth is its own world)"
        );
        anyhow::ensure!(world.is_dir(), "--mock-world {}: not a folder", world.display());
    }
    // Before the daemon prints its URL: a dashboard that dies a moment after
    // its address was printed sends the user to a page that never answers.
    lightbooth::lab::scenes::SceneCatalog::from_folder(&options.scenes_dir, options.observer)?;
    anyhow::ensure!(
        options.mock_speed.is_finite() && (0.0..=super::MAX_TIME_SCALE).contains(&options.mock_speed),
        "mock_speed {} must be 0–{}",
        options.mock_speed,
        super::MAX_TIME_SCALE
    );
    let runtime = tokio::runtime::Runtime::new().context("starting the async runtime")?;
    runtime.block_on(async move {
        let listener = tokio::net::TcpListener::bind(options.bind)
            .await
            .with_context(|| format!("cannot listen on {}: is another daemon running?", options.bind))?;
        daemon::run(listener, options, daemon::shutdown_signal()).await
    })
}

/// `--mock`'s model: one lightbooth drives, or `settings` (the flag alone).
fn mock_model(s: &str) -> Result<String, String> {
    let flag = s.to_ascii_lowercase().replace('-', "");
    if flag == "settings" || lightbooth::instrument::MODEL_FLAGS.contains(&flag.as_str()) {
        Ok(flag)
    } else {
        Err(format!(
            "`{s}` is not a model lightbooth simulates; use one of {}",
            lightbooth::instrument::MODEL_FLAGS.join(", ")
        ))
    }
}
