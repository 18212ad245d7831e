//! `lightbooth serve`: the lab daemon. It wires the pieces together:
//!
//! - the [`store`](crate::store) (an SQLite file or a PostgreSQL database, migrated at start-up);
//! - one [instrument task](instrument_task) that owns the PR-650 (real, or
//!   simulated on a pty with `--mock`) and takes queued measurements one at
//!   a time, writing each sample as it is taken;
//! - the lab's render side: the [scene catalogue](crate::lab::scenes), one
//!   [render runner](crate::lab::render_runner) on the rayon pool, the
//!   [comparisons](crate::lab::comparisons) of each measurement with every
//!   coding, the API's renders, studies and images as bounded, cancellable
//!   [jobs](crate::lab::render_jobs), and the
//!   [simulated truth](crate::lab::simulated_truth) with `--mock`;
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
pub mod instrument_task;

use std::future::Future;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use tokio::net::TcpListener;
use tokio::sync::{broadcast, mpsc, watch};

use crate::colorimetry::Observer;
use crate::http::{self, auth, AppState, ServiceConfig};
use crate::instrument::sim::Fault;
use crate::instrument::InstrumentSettings;
use crate::lab::booth_instrument::BoothInstrument;
use crate::lab::comparisons::Comparisons;
use crate::lab::events::EventSink;
use crate::lab::images::ImageJobs;
use crate::lab::instrument_queue::InstrumentStatus;
use crate::lab::render_jobs::RenderJobs;
use crate::lab::render_runner::RenderRunner;
use crate::lab::scenes::SceneCatalog;
use crate::lab::simulated_truth::SimulatedTruth;
use crate::lab::study_jobs::StudyRunner;
use crate::lab::worker_queue::{RenderPlace, WorkerQueue};
use crate::lab::Lab;
use crate::render::integrator::CancellationToken;
use crate::render::Coding;
use crate::store::{Booth, Store};

/// How many measurements may wait for the instrument; more get 409. Enough
/// for every target of every booth scene (1 + 1 + 1 + 1 + 21) at once.
pub const QUEUE_CAPACITY: usize = 64;

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
    /// workers sharing the database (`--renders`, `lab::worker_queue`).
    pub renders: crate::lab::worker_queue::RenderPlace,
}

/// How often a daemon leaving its work to render workers looks for the
/// jobs that ended, to send their events.
pub const WORKER_JOB_POLL: Duration = Duration::from_millis(250);

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
    anyhow::ensure!(
        !options.heartbeat.is_zero() && options.lease > options.heartbeat,
        "the lease ({:?}) must be longer than the heartbeat interval ({:?}), which must not be zero",
        options.lease,
        options.heartbeat
    );
    // Before registering: a daemon that cannot start leaves no lease behind.
    let (token, source) = auth::load_token(options.token_file.as_deref(), &options.default_token_file)?;
    let store = Store::open_recovering(&options.db_url)
        .await
        .with_context(|| format!("opening the database {}", options.db_url))?
        .with_observer(options.observer);
    let (events, _) = broadcast::channel(1024);
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
    // This booth's previous daemon on this host, killed (kill -9, a crash):
    // its work is recovered now, not a lease later (`store::leases`).
    let recovered = store
        .recover_dead_predecessors(&options.booth)
        .await
        .context("recovering the work of this booth's previous daemon")?;
    if recovered.total() > 0 {
        tracing::warn!(
            measurements = recovered.measurements,
            renders = recovered.renders,
            studies = recovered.studies,
            "marked the work of this booth's dead previous daemon as interrupted"
        );
    }
    // Sessions left running with all their trials (issue 32) are complete.
    let completed = crate::lab::experiments::Experiments::new(store.clone())
        .complete_finished_sessions(options.booth.as_str())
        .await
        .context("completing experiment sessions found with all their trials")?;
    if !completed.is_empty() {
        tracing::warn!(sessions = ?completed, "completed experiment sessions found running with all their trials");
    }
    // Image downloads' private folders a killed daemon left behind.
    for left in crate::export::image::remove_stale_export_folders(&std::env::temp_dir()) {
        tracing::info!(folder = %left.display(), "removed an image export folder left by a process that is gone");
    }
    let addr = listener.local_addr()?;
    let loopback_only = addr.ip().is_loopback();
    println!("{}", source.describe());
    println!("lightbooth listening on http://{addr}/");
    println!("dashboard (with the write token): http://{addr}/#token={token}");
    if !loopback_only {
        println!("not bound to loopback: reads need the token too");
    }
    let allowed_hosts = http::hosts::AllowedHosts::new(addr, &options.allowed_hosts).map_err(anyhow::Error::msg)?;
    println!("answering requests for {}", allowed_hosts.describe());

    let (jobs_tx, jobs_rx) = mpsc::channel(QUEUE_CAPACITY);
    let (status_tx, status_rx) = watch::channel(InstrumentStatus::Disconnected {
        reason: "starting".into(),
    });
    // The lab's render side (see `lab`): the scenes, loaded once; one
    // render runner; the comparisons, studies and jobs that use it; and
    // what the simulated instrument measures.
    let catalogue = Arc::new(SceneCatalog::from_folder(&options.scenes_dir, options.observer)?);
    let codings = options
        .codings
        .iter()
        .map(|c| c.parse::<Coding>().map_err(|e| anyhow::anyhow!("coding `{c}`: {e}")))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let truth = Arc::new(SimulatedTruth::new(Arc::clone(&catalogue), options.mock_world.clone())?);
    let workers = match options.renders {
        RenderPlace::Here => None,
        RenderPlace::Workers => {
            anyhow::ensure!(
                store.engine_name() == "postgres",
                "--renders workers needs a database shared with the render workers: a PostgreSQL one \
                 (--db postgres://…); on an SQLite file the daemon renders itself (--renders here)"
            );
            anyhow::ensure!(
                options.mock_world.is_none(),
                "--renders workers cannot be combined with --mock-world: the mock world's scenes are not published to workers"
            );
            let queue = WorkerQueue::publish(
                store.clone(),
                events.clone(),
                &catalogue,
                &codings,
                options.render_samples,
                options.preview_paths,
                options.observer,
            )
            .await?;
            Some(Arc::new(queue))
        }
    };
    let _worker_watch = workers
        .as_ref()
        .map(|queue| AbortOnDrop(tokio::spawn(Arc::clone(queue).watch(WORKER_JOB_POLL))));
    let lab_events = EventSink::bus(events.clone());
    // The daemon's one shutdown token: the renders, studies, jobs, the
    // running measurement and the event streams take children of it or wait on it.
    let shutdown_flag = CancellationToken::new();
    let runner = Arc::new(
        RenderRunner::new(
            store.clone(),
            Arc::clone(&catalogue),
            lab_events.clone(),
            codings.clone(),
            options.render_samples,
            options.observer,
            shutdown_flag.clone(),
        )
        .with_preview_paths(options.preview_paths),
    );
    let comparisons = Arc::new(Comparisons::new(
        store.clone(),
        Arc::clone(&runner),
        lab_events.clone(),
        workers.clone(),
    ));
    // Complete measurements left without a comparison (taken while the
    // daemon stopped, or refused by an older daemon: a colorimeter's in
    // another observer) are compared now, in the background.
    match comparisons.compare_left_over(&options.booth).await {
        Ok(0) => {}
        Ok(n) => tracing::info!(
            measurements = n,
            "queued the comparisons of measurements left uncompared"
        ),
        Err(e) => tracing::error!(error = %e, "cannot look for measurements left uncompared"),
    }
    let studies = Arc::new(StudyRunner::new(
        store.clone(),
        Arc::clone(&catalogue),
        lab_events,
        codings,
        options.observer,
        options.mock_world.clone(),
        shutdown_flag.clone(),
    ));
    let render_jobs = Arc::new(
        RenderJobs::new(
            store.clone(),
            runner,
            studies,
            Arc::clone(&comparisons),
            Arc::new(ImageJobs::new(events.clone(), daemon_id)),
            workers,
        )
        .with_progress(crate::lab::progress::ProgressBoard::follow(&events)),
    );
    let job_worker = render_jobs.run();
    let instrument = instrument_task::spawn(instrument_task::TaskConfig {
        store: store.clone(),
        jobs: jobs_rx,
        status: status_tx,
        events: events.clone(),
        comparisons,
        truth,
        observer: options.observer,
        settings: options.instrument.clone(),
        booth: options.booth.clone(),
        mock: options.mock.then(|| instrument_task::MockSettings {
            personality: options.instrument.simulated_personality(),
            speed: options.mock_speed,
            faults: options.mock_faults.clone(),
            cache_dir: options.cache_dir.clone(),
        }),
        runtime: tokio::runtime::Handle::current(),
        shutdown: shutdown_flag.clone(),
    })?;

    let instrument_handle = BoothInstrument::new(
        store.clone(),
        jobs_tx,
        status_rx,
        events.clone(),
        Some(Arc::new(instrument.canceller())),
        options.instrument.capabilities(),
        options.booth.clone(),
    );
    let state = AppState {
        lab: Lab::new(
            store.clone(),
            options.observer,
            instrument_handle,
            Some(Arc::clone(&render_jobs)),
        ),
        config: Arc::new(ServiceConfig {
            token,
            loopback_only,
            allowed_hosts,
        }),
        events,
        mock: instrument.mock_control(),
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
    render_jobs.shutdown();
    let _ = stop_tx.send(());
    server.await.context("the HTTP server task")??;
    // The server's state (and so the job sender) is gone: the instrument
    // thread finishes its current job and stops.
    instrument.join().await;
    // The job worker marks the cancelled and queued jobs interrupted; a
    // render stops within one batch of paths per thread.
    if tokio::time::timeout(Duration::from_secs(30), job_worker).await.is_err() {
        tracing::warn!("the render job did not stop within 30 s");
    }
    // Only this daemon's own work: a neighbour's on a shared database is
    // its own business.
    for job in [crate::store::Job::Render, crate::store::Job::Study] {
        store
            .interrupt_own_unfinished(
                job.table(),
                &format!(
                    "the daemon shut down during this {}; retry it with POST /api/{}/{{id}}/retry",
                    job.noun(),
                    job.table()
                ),
            )
            .await?;
    }
    let n = store
        .interrupt_own_unfinished("measurements", "the daemon shut down before this measurement ran")
        .await?;
    if n > 0 {
        tracing::info!(count = n, "queued measurements marked interrupted at shutdown");
    }
    lease.release().await.context("marking this daemon stopped")?;
    store.close().await;
    Ok(())
}

/// Aborts a task when dropped: a background task stops with its owner,
/// also when the owner returns early with an error.
pub(crate) struct AbortOnDrop(pub(crate) tokio::task::JoinHandle<()>);

impl Drop for AbortOnDrop {
    fn drop(&mut self) {
        self.0.abort();
    }
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
