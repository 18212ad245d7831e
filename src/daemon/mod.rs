//! `lightbooth serve`: the lab daemon. It keeps what is the process's and
//! leaves the lab to the lab:
//!
//! - the [`store`](crate::store) (an SQLite file or a PostgreSQL database,
//!   migrated at start-up), opened and recovered;
//! - the lab, built in one place, [`DaemonLab::start`] (`lab::assemble`):
//!   the scene catalogue, the render side, the API's jobs, the
//!   [instrument task](crate::lab::measure::task) that owns the
//!   instrument (real, or simulated on a pty with `--mock`), the handle the
//!   HTTP layer calls; and stopped in order ([`DaemonLab::stop`]);
//! - a [lock](db_lock) on an SQLite database file, so one daemon owns it;
//! - a [lease](crate::lab::lease) in the database, renewed by a heartbeat
//!   task, so that daemons sharing a PostgreSQL database recover only the
//!   work of daemons that are gone (see `store/leases.rs`);
//! - the [HTTP layer](crate::http) (REST API, events, dashboards): the
//!   daemon is the one module that names it (the layer rule in `lib.rs`).
//!
//! [`run`] takes a shutdown future, as mini-redis's server does, so tests
//! start and stop a whole daemon in-process.

pub mod db_lock;

use std::future::Future;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use tokio::net::TcpListener;

use crate::colorimetry::Observer;
use crate::http::{self, auth, AppState, ServiceConfig};
use crate::instrument::sim::Fault;
use crate::instrument::InstrumentSettings;
use crate::lab::assemble::{DaemonLab, LabSettings};
use crate::lab::measure::task::MockSettings;
use crate::store::{Booth, Store};
use tokio_util::sync::CancellationToken;

/// Everything `serve` needs, from the command line and the config file.
#[derive(Clone, Debug)]
pub struct DaemonOptions {
    pub bind: SocketAddr,
    /// Host names requests may name besides `localhost` and the daemon's
    /// addresses (`--allowed-host`; see `http::hosts`).
    pub allowed_hosts: Vec<String>,
    /// The booth this daemon and its instrument measure in (`--booth`).
    pub booth: Booth,
    /// `sqlite://path` (created if missing).
    pub db_url: String,
    /// Run a simulated PR-650 on a pty instead of opening a real port.
    pub mock: bool,
    /// Time scale of the simulated PR-650 (1 = the real instrument's timing).
    pub mock_speed: f64,
    /// Faults injected into the simulated PR-650 from the start.
    pub mock_faults: Vec<Fault>,
    /// The booth's instrument: its model and settings file.
    pub instrument: InstrumentSettings,
    pub scenes_dir: PathBuf,
    /// Converged scene spectra (for the simulated PR-650) are cached here.
    pub cache_dir: PathBuf,
    pub token_file: Option<PathBuf>,
    /// Where a generated token is written when neither a token file nor
    /// `LIGHTBOOTH_TOKEN` is given.
    pub default_token_file: PathBuf,
    /// Codings rendered for each comparison.
    pub codings: Vec<String>,
    /// Radiometer samples per target of a comparison render.
    pub render_samples: u64,
    /// Camera paths in all of a render's dashboard preview
    /// (`render::sensor::PREVIEW_PATH_BUDGET` unless configured).
    pub preview_paths: u64,
    /// The one colorimetric observer of every x,y, XYZ, CIELAB and ΔE this
    /// daemon computes (comparisons, charts); the study's Judd–Vos by default.
    pub observer: Observer,
    /// With `mock`: a folder of scene files (same ids as `scenes_dir`) that
    /// the simulated PR-650 measures instead of the model scenes — the booth
    /// as it is, when it differs from the model (`serve --mock-world DIR`).
    pub mock_world: Option<PathBuf>,
    /// How often the daemon renews its lease and looks for gone daemons'
    /// work to recover ([`DEFAULT_HEARTBEAT`]).
    pub heartbeat: Duration,
    /// How long after its last heartbeat the daemon counts as gone and its
    /// unfinished work may be marked interrupted by another daemon
    /// ([`DEFAULT_LEASE`]; longer than `heartbeat`).
    pub lease: Duration,
    /// Where comparisons, renders and studies run: here, or on render
    /// workers sharing the database (`--renders`, `lab::render::worker_queue`).
    pub renders: crate::lab::render::worker_queue::RenderPlace,
}

/// The heartbeat interval of a daemon's lease unless configured.
pub const DEFAULT_HEARTBEAT: Duration = Duration::from_secs(2);

/// A daemon's lease unless configured: five heartbeats, so a slow database
/// round trip or two never costs a live daemon its work.
pub const DEFAULT_LEASE: Duration = Duration::from_secs(10);

/// Runs the daemon on an already-bound listener until `shutdown` resolves.
/// The running measurement, render and study are cancelled and marked
/// interrupted; queued ones are marked interrupted; nothing half-written is
/// left. Refuses to start on a database another daemon holds.
pub async fn run(
    listener: TcpListener,
    options: DaemonOptions,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> anyhow::Result<()> {
    // Before the store opens: opening marks unfinished work interrupted.
    let _lock = db_lock::acquire(&options.db_url)?;
    options.check_lease()?;
    // Before registering: a daemon that cannot start leaves no lease behind.
    let (token, source) = auth::load_token(options.token_file.as_deref(), &options.default_token_file)?;
    let store = Store::open_recovering(&options.db_url)
        .await
        .with_context(|| format!("opening the database {}", options.db_url))?
        .with_observer(options.observer);
    let events = crate::lab::events::EventSink::bus(1024);
    // From here on every measurement, render and study this daemon creates
    // or runs names it, and its lease says it is alive; its heartbeat tells
    // the event clients of the gone daemons' work it interrupts.
    let lease = crate::lab::lease::Lease::take(
        &store,
        &options.booth,
        options.lease,
        options.heartbeat,
        Some(events.clone()),
    )
    .await
    .context("registering this daemon's lease")?;
    let daemon_id = lease.id();
    let store = lease.store().clone();
    tracing::info!(daemon = daemon_id, booth = %options.booth, "registered; heartbeat every {:?}, lease {:?}", options.heartbeat, options.lease);
    crate::lab::assemble::recover_at_start(&store, &options.booth).await?;
    let addr = listener.local_addr()?;
    let loopback_only = addr.ip().is_loopback();
    let allowed_hosts = http::hosts::AllowedHosts::new(addr, &options.allowed_hosts).map_err(anyhow::Error::msg)?;
    announce(addr, &source.describe(), &token, &allowed_hosts);
    // The daemon's one shutdown token: the renders, studies, jobs, the
    // running measurement and the event streams take children of it or wait on it.
    let shutdown_flag = CancellationToken::new();
    let (lab, running) = DaemonLab::start(
        store.clone(),
        events.clone(),
        daemon_id,
        options.lab_settings(),
        shutdown_flag.clone(),
    )
    .await?;
    let state = AppState {
        lab,
        config: Arc::new(ServiceConfig {
            token,
            loopback_only,
            allowed_hosts,
        }),
        events,
        mock: running.mock_control(),
        shutting_down: shutdown_flag.clone(),
    };
    let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
    let server = tokio::spawn(http::serve(listener, state, async move {
        let _ = stop_rx.await;
    }));
    shutdown.await;
    tracing::info!("shutting down: cancelling the running measurement, render and study; closing the HTTP server");
    // Stops the running measurement, render and study, and ends the event streams.
    shutdown_flag.cancel();
    running.stop_jobs();
    let _ = stop_tx.send(());
    server.await.context("the HTTP server task")??;
    // The server's state (and so the instrument queue's sender) is gone:
    // the lab's instrument task, job worker and unfinished rows end now.
    running.stop().await?;
    lease.release().await.context("marking this daemon stopped")?;
    store.close().await;
    Ok(())
}

impl DaemonOptions {
    /// The lease must outlast the heartbeat, which must tick.
    fn check_lease(&self) -> anyhow::Result<()> {
        anyhow::ensure!(
            !self.heartbeat.is_zero() && self.lease > self.heartbeat,
            "the lease ({:?}) must be longer than the heartbeat interval ({:?}), which must not be zero",
            self.lease,
            self.heartbeat
        );
        Ok(())
    }

    /// The options that are the lab's.
    fn lab_settings(&self) -> LabSettings {
        LabSettings {
            booth: self.booth.clone(),
            observer: self.observer,
            scenes_dir: self.scenes_dir.clone(),
            codings: self.codings.clone(),
            render_samples: self.render_samples,
            preview_paths: self.preview_paths,
            mock_world: self.mock_world.clone(),
            renders: self.renders,
            instrument: self.instrument.clone(),
            mock: self.mock.then(|| MockSettings {
                personality: self.instrument.simulated_personality(),
                speed: self.mock_speed,
                faults: self.mock_faults.clone(),
                cache_dir: self.cache_dir.clone(),
            }),
        }
    }
}

/// What the operator reads as the daemon starts (stdout): where the token
/// came from, the address, the dashboard's link with the write token, and
/// the host names it answers for.
fn announce(addr: SocketAddr, token_source: &str, token: &str, hosts: &http::hosts::AllowedHosts) {
    println!("{token_source}");
    println!("lightbooth listening on http://{addr}/");
    println!("dashboard (with the write token): http://{addr}/#token={token}");
    if !addr.ip().is_loopback() {
        println!("not bound to loopback: reads need the token too");
    }
    println!("answering requests for {}", hosts.describe());
}

/// Resolves on SIGINT (Ctrl-C) or SIGTERM.
pub async fn shutdown_signal() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(e) => {
                tracing::warn!(error = %e, "cannot listen for SIGTERM");
                std::future::pending::<()>().await
            }
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => tracing::info!("SIGINT received"),
        _ = term => tracing::info!("SIGTERM received"),
    }
}
