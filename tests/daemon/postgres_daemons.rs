//! `serve --db postgres://…`: whole daemons on a real PostgreSQL database
//! (the server `tests/setup.sh` starts). A measurement goes through the API
//! into PostgreSQL with every sample, and a second daemon on the same
//! database starts (no file lock between them) and serves what the first
//! measured. Leases: a daemon starting or stopping beside a running one
//! leaves its work alone, and a daemon killed with SIGKILL has its running
//! measurement interrupted (samples kept) by a neighbour once its lease
//! runs out, with nothing else touched.

use crate::common;

use std::io::{BufRead, BufReader};
use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use common::{get_json, poll_until, post_json, Daemon, TOKEN};
use serde_json::Value;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn two_daemons_share_one_postgres_database_and_see_each_others_measurements() {
    let db = common::fresh_postgres_database().await;
    let a = Daemon::start_on(0.0, &db).await;
    let (status, m) = post_json(a.addr, "/api/measurements", TOKEN, r#"{"samples":3,"note":"booth A"}"#).await;
    assert_eq!(status, 202, "{m}");
    let url = m["url"].as_str().unwrap().to_string();
    let done = poll_until(a.addr, &url, Duration::from_secs(60), |v| {
        v["state"] != "queued" && v["state"] != "running"
    })
    .await;
    assert_eq!(done["state"], "complete", "{done}");
    assert_eq!(done["samples"].as_array().unwrap().len(), 3);

    let b = Daemon::start_on(0.0, &db).await;
    let (status, page) = get_json(b.addr, "/api/measurements").await;
    assert_eq!(status, 200);
    assert_eq!(page["total"], 1, "{page}");
    assert_eq!(page["items"][0]["note"], "booth A");
    assert_eq!(page["items"][0]["state"], "complete");
    let (_, health) = get_json(b.addr, "/api/health").await;
    assert_eq!(health["status"], "ok", "{health}");
    b.stop().await;
    a.stop().await;
}

/// Two booths' daemons on one PostgreSQL database (`serve --booth`): every
/// measurement names its booth, `?booth=` gives one booth's measurements
/// (as a MATLAB script asks for them), `/api/booths` lists both, and a bad
/// booth name is a 400 saying what a name may hold.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn each_booths_daemon_records_its_booth_and_the_api_filters_by_booth() {
    let db = common::fresh_postgres_database().await;
    let north = Daemon::start_booth(0.0, &db, "north").await;
    let south = Daemon::start_booth(0.0, &db, "south").await;
    for (d, samples) in [(&north, 2), (&south, 3), (&south, 2)] {
        let (status, m) = post_json(
            d.addr,
            "/api/measurements",
            TOKEN,
            &format!(r#"{{"samples":{samples}}}"#),
        )
        .await;
        assert_eq!(status, 202, "{m}");
        let url = m["url"].as_str().unwrap().to_string();
        let done = poll_until(d.addr, &url, Duration::from_secs(60), |v| {
            v["state"] != "queued" && v["state"] != "running"
        })
        .await;
        assert_eq!(done["state"], "complete", "{done}");
    }
    // Either daemon answers for the whole lab.
    let (_, all) = get_json(north.addr, "/api/measurements").await;
    assert_eq!(all["total"], 3, "{all}");
    let (_, page) = get_json(north.addr, "/api/measurements?booth=south").await;
    assert_eq!(page["total"], 2, "{page}");
    for m in page["items"].as_array().unwrap() {
        assert_eq!(m["booth"], "south", "{m}");
        assert_eq!(m["instrument_model"], "PR-650", "{m}");
    }
    let (_, page) = get_json(south.addr, "/api/measurements?booth=north&instrument_model=PR-650").await;
    assert_eq!(page["total"], 1, "{page}");
    assert_eq!(page["items"][0]["booth"], "north");
    let (_, page) = get_json(south.addr, "/api/measurements?instrument_model=PR-670").await;
    assert_eq!(page["total"], 0, "{page}");

    let (status, booths) = get_json(south.addr, "/api/booths").await;
    assert_eq!(status, 200);
    assert_eq!(booths["this_daemon"], "south");
    let names: Vec<(&str, i64)> = booths["booths"]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| (b["booth"].as_str().unwrap(), b["measurements"].as_i64().unwrap()))
        .collect();
    assert_eq!(names, [("north", 1), ("south", 2)]);
    let (_, health) = get_json(north.addr, "/api/health").await;
    assert_eq!(health["booth"], "north");

    let (status, v) = get_json(north.addr, "/api/measurements?booth=north%20wing").await;
    assert_eq!(status, 400, "{v}");
    let message = v["error"]["message"].as_str().unwrap();
    assert!(message.contains("booth") && message.contains("a space"), "{message}");
    south.stop().await;
    north.stop().await;
}

/// Starts a measurement of `samples` samples on `daemon`; its URL.
async fn start_measurement(daemon: SocketAddr, samples: u32) -> String {
    let (status, m) = post_json(
        daemon,
        "/api/measurements",
        TOKEN,
        &format!(r#"{{"samples":{samples}}}"#),
    )
    .await;
    assert_eq!(status, 202, "{m}");
    m["url"].as_str().unwrap().to_string()
}

/// Waits (bounded) until the measurement at `url` is running with at least
/// `samples` samples stored.
async fn wait_for_samples(reader: SocketAddr, url: &str, samples: usize) -> Value {
    poll_until(reader, url, Duration::from_secs(60), |v| {
        v["state"] == "running" && v["samples"].as_array().is_some_and(|s| s.len() >= samples)
    })
    .await
}

/// The regression of issue 14's bug: a daemon starting (and later shutting
/// down) on a PostgreSQL database marked *every* unfinished measurement
/// interrupted, the running one of another booth's daemon included. With
/// leases both leave it alone, and it completes with all its samples.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_second_booths_daemon_starting_left_the_first_ones_running_measurement_alone() {
    let db = common::fresh_postgres_database().await;
    let north = Daemon::start_booth(0.2, &db, "north").await;
    let url = start_measurement(north.addr, 8).await;
    wait_for_samples(north.addr, &url, 1).await;

    let south = Daemon::start_booth(0.0, &db, "south").await;
    let (_, m) = get_json(north.addr, &url).await;
    assert_eq!(m["state"], "running", "south's start touched north's measurement: {m}");
    south.stop().await;
    let (_, m) = get_json(north.addr, &url).await;
    assert_eq!(
        m["state"], "running",
        "south's shutdown touched north's measurement: {m}"
    );

    let done = poll_until(north.addr, &url, Duration::from_secs(120), |v| {
        v["state"] != "queued" && v["state"] != "running"
    })
    .await;
    assert_eq!(done["state"], "complete", "{done}");
    assert_eq!(done["samples"].as_array().unwrap().len(), 8);
    north.stop().await;
}

/// `lightbooth serve` as a child process, killed (SIGKILL) when dropped.
struct ServeProcess {
    child: Child,
    addr: SocketAddr,
    _dir: tempfile::TempDir,
}

impl Drop for ServeProcess {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Runs the built binary: `serve --mock --db DB --booth BOOTH` with a short
/// lease (`heartbeat_seconds`, `lease_seconds` in its config file); returns
/// once its instrument is idle.
async fn spawn_serve(db: &str, booth: &str, heartbeat_seconds: f64, lease_seconds: f64) -> ServeProcess {
    let dir = tempfile::tempdir().unwrap();
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let cache = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("converged-cache");
    let config = dir.path().join("lightbooth.toml");
    std::fs::write(
        &config,
        format!(
            "scenes_dir = {:?}\ncache_dir = {:?}\nheartbeat_seconds = {heartbeat_seconds}\nlease_seconds = {lease_seconds}\n",
            root.join("scenes").display().to_string(),
            cache.display().to_string(),
        ),
    )
    .unwrap();
    let token_file = dir.path().join("token");
    std::fs::write(&token_file, TOKEN).unwrap();
    let log = std::fs::File::create(dir.path().join("serve.log")).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .current_dir(&root)
        .args([
            "serve",
            "--mock",
            "--mock-speed",
            "0.2",
            "--bind",
            "127.0.0.1:0",
            "--db",
            db,
            "--booth",
            booth,
        ])
        .arg("--config")
        .arg(&config)
        .arg("--token-file")
        .arg(&token_file)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::from(log))
        .spawn()
        .expect("run lightbooth serve");
    let stdout = child.stdout.take().unwrap();
    // The daemon prints `lightbooth listening on http://ADDR/`; read its
    // lines on a thread (and keep draining them) so it never blocks on a pipe.
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if let Some(rest) = line.strip_prefix("lightbooth listening on http://") {
                let _ = tx.send(rest.trim_end_matches('/').to_string());
            }
        }
    });
    let addr: SocketAddr = tokio::task::spawn_blocking(move || rx.recv_timeout(Duration::from_secs(60)))
        .await
        .unwrap()
        .expect("the daemon printed its address")
        .parse()
        .unwrap();
    poll_until(addr, "/api/health", Duration::from_secs(60), |v| {
        v["instrument"]["state"] == "idle"
    })
    .await;
    ServeProcess { child, addr, _dir: dir }
}

/// kill -9 of a booth's daemon mid-measurement: once its lease runs out a
/// neighbour marks that measurement interrupted, keeping the samples it
/// took and naming the dead daemon (booth, pid); a third booth's running
/// measurement is untouched and still completes.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_daemon_killed_mid_measurement_has_it_interrupted_by_a_neighbour_and_nothing_else_touched() {
    let db = common::fresh_postgres_database().await;
    let south = Daemon::start_booth(0.0, &db, "south").await;
    let east = Daemon::start_booth(0.2, &db, "east").await;
    let mut north = spawn_serve(&db, "north", 0.3, 1.5).await;
    let north_pid = north.child.id();

    let north_url = start_measurement(north.addr, 60).await;
    let east_url = start_measurement(east.addr, 12).await;
    wait_for_samples(south.addr, &north_url, 2).await;
    wait_for_samples(south.addr, &east_url, 1).await;
    north.child.kill().unwrap(); // SIGKILL: no shutdown marking, no stopped_at
    north.child.wait().unwrap();
    let (_, at_kill) = get_json(south.addr, &north_url).await;
    let kept = at_kill["samples"].as_array().unwrap().len();
    assert_eq!(at_kill["state"], "running", "{at_kill}");

    // Lease 1.5 s + a neighbour's heartbeat (2 s by default), bounded generously.
    let m = poll_until(south.addr, &north_url, Duration::from_secs(30), |v| {
        v["state"] != "running"
    })
    .await;
    assert_eq!(m["state"], "interrupted", "{m}");
    assert_eq!(m["samples"].as_array().unwrap().len(), kept, "{m}");
    assert!(kept >= 2);
    let error = m["error"].as_str().unwrap();
    assert!(
        error.contains("booth `north`")
            && error.contains(&format!("pid {north_pid}"))
            && error.contains("stopped heartbeating"),
        "{error}"
    );
    let (_, e) = get_json(south.addr, &east_url).await;
    assert_eq!(
        e["state"], "running",
        "the kill's recovery touched east's measurement: {e}"
    );
    let done = poll_until(east.addr, &east_url, Duration::from_secs(120), |v| {
        v["state"] != "queued" && v["state"] != "running"
    })
    .await;
    assert_eq!(done["state"], "complete", "{done}");
    assert_eq!(done["samples"].as_array().unwrap().len(), 12);
    drop(north);
    east.stop().await;
    south.stop().await;
}

/// Measures `scene/target` with `samples` samples on `daemon` and waits
/// (bounded) until it is complete and its comparisons are stored; its id.
async fn measure_and_compare(daemon: SocketAddr, scene: &str, target: &str, samples: u32) -> i64 {
    let (status, m) = post_json(
        daemon,
        "/api/measurements",
        TOKEN,
        &format!(r#"{{"scene":"{scene}","target":"{target}","samples":{samples}}}"#),
    )
    .await;
    assert_eq!(status, 202, "{m}");
    let id = m["id"].as_i64().unwrap();
    let done = poll_until(
        daemon,
        &format!("/api/measurements/{id}"),
        Duration::from_secs(120),
        |v| v["state"] != "queued" && v["state"] != "running",
    )
    .await;
    assert_eq!(done["state"], "complete", "{done}");
    poll_until(
        daemon,
        &format!("/api/measurements/{id}/comparisons"),
        Duration::from_secs(300),
        |v| v.as_array().is_some_and(|rows| !rows.is_empty()),
    )
    .await;
    id
}

/// A comparison's CIELAB white ignored the booth: the white was the newest
/// complete measurement of the white target in *any* booth, so booth
/// north measuring its Spectralon rewrote every comparison of booth south
/// with north's white. Each booth's comparisons now use, and keep, the
/// white measured in their own booth.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_white_measured_in_one_booth_rewrote_another_booths_comparisons() {
    let db = common::fresh_postgres_database().await;
    let north = Daemon::start_booth(0.0, &db, "north").await;
    let south = Daemon::start_booth(0.0, &db, "south").await;
    let south_white = measure_and_compare(south.addr, "white", "patch", 2).await;
    let north_white = measure_and_compare(north.addr, "white", "patch", 2).await;

    let (_, south_rows) = get_json(south.addr, &format!("/api/measurements/{south_white}/comparisons")).await;
    let (_, north_rows) = get_json(north.addr, &format!("/api/measurements/{north_white}/comparisons")).await;
    let sources = |rows: &Value| -> Vec<String> {
        rows.as_array()
            .unwrap()
            .iter()
            .map(|r| r["white_source"].as_str().unwrap().to_string())
            .collect()
    };
    let south_sources = sources(&south_rows);
    assert!(
        south_sources
            .iter()
            .all(|s| s == &format!("measurement {south_white} (white/patch)")),
        "north's white (measurement {north_white}) reached south's comparisons: {south_sources:?}"
    );
    let north_sources = sources(&north_rows);
    assert!(
        north_sources
            .iter()
            .all(|s| s == &format!("measurement {north_white} (white/patch)")),
        "{north_sources:?}"
    );
    // The ΔE of south's rows is still computed with south's own white: it
    // measured the white itself, so the row's white is its measured XYZ.
    for row in south_rows.as_array().unwrap() {
        let (white_y, measured_y) = (row["white_Y"].as_f64().unwrap(), row["measured_Y"].as_f64().unwrap());
        assert!(
            (white_y - measured_y).abs() <= 1e-6 * measured_y,
            "white Y {white_y} vs south's own measured Y {measured_y}: {row}"
        );
    }
    south.stop().await;
    north.stop().await;
}

/// A neighbour's interruption sent no event: a daemon whose heartbeat
/// marked a killed daemon's measurement interrupted told no one, so its
/// dashboards saw it only on their next read. Its `/api/events` clients now
/// get `measurement_finished` (interrupted, with the error naming the dead
/// daemon) as it happens.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_neighbours_measurement_interrupted_by_recovery_sent_no_event() {
    let db = common::fresh_postgres_database().await;
    let south = Daemon::start_booth(0.0, &db, "south").await;
    let mut north = spawn_serve(&db, "north", 0.3, 1.5).await;
    let mut events = common::events(south.addr).await;

    let north_url = start_measurement(north.addr, 60).await;
    let north_id: i64 = north_url.rsplit('/').next().unwrap().parse().unwrap();
    wait_for_samples(south.addr, &north_url, 2).await;
    north.child.kill().unwrap(); // SIGKILL: only a neighbour can end its measurement
    north.child.wait().unwrap();

    // Lease 1.5 s + south's heartbeat (2 s), bounded generously.
    let event = common::wait_for(
        &mut events,
        "the interrupted event of north's measurement",
        Duration::from_secs(30),
        |name, v| name == "measurement_finished" && v["measurement_id"] == north_id,
    )
    .await;
    assert_eq!(event["state"], "interrupted", "{event}");
    let error = event["error"].as_str().unwrap();
    assert!(
        error.contains("booth `north`") && error.contains("stopped heartbeating"),
        "{error}"
    );
    let (_, m) = get_json(south.addr, &north_url).await;
    assert_eq!(m["state"], "interrupted", "the event matches the row: {m}");
    assert_eq!(m["error"].as_str(), Some(error));
    drop(north);
    south.stop().await;
}

/// A one-shot tool held no lease: `lightbooth study --db postgres://…` wrote
/// its study with no daemon, and a daemon starting meanwhile recovered it as
/// abandoned (interrupted), so the study could not be stored. The tool now
/// registers in `daemons` and heartbeats while it runs: the study completes.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_tools_study_was_interrupted_by_a_daemon_starting_on_the_same_database() {
    let db = common::fresh_postgres_database().await;
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let cache = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("converged-cache");
    // Enough paths that the study is still rendering when the daemon starts.
    let tool = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .current_dir(&root)
        .args([
            "study",
            "scenes/white.toml",
            "--measure-simulated",
            "--seeds",
            "4",
            "--samples",
            "2000000",
        ])
        .args(["--booth", "south", "--db", &db])
        .arg("--cache-dir")
        .arg(&cache)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run lightbooth study");
    let reader = lightbooth::store::Store::open_to_read(&db).await.unwrap();
    let deadline = tokio::time::Instant::now() + Duration::from_secs(120);
    loop {
        if let Some(s) = reader.get_study(1).await.unwrap() {
            assert_eq!(s.state, "running", "{:?}", s.error);
            break;
        }
        assert!(
            tokio::time::Instant::now() < deadline,
            "the tool never started its study"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }

    let north = Daemon::start_booth(0.0, &db, "north").await;
    let study = reader.get_study(1).await.unwrap().unwrap();
    assert_eq!(
        study.state, "running",
        "the daemon's start interrupted the tool's study: {:?}",
        study.error
    );
    let out = tokio::task::spawn_blocking(move || tool.wait_with_output())
        .await
        .unwrap()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let study = reader.get_study(1).await.unwrap().unwrap();
    assert_eq!(study.state, "complete", "{:?}", study.error);
    // The tool's lease: its booth, and stopped once it finished.
    let (_, booths) = get_json(north.addr, "/api/booths").await;
    assert_eq!(booths["this_daemon"], "north", "{booths}");
    let lease = reader.daemon(1).await.unwrap().expect("the tool registered first");
    assert_eq!(lease.booth, "south");
    assert!(lease.stopped_at.is_some(), "{lease:?}");
    north.stop().await;
}

/// The bug (issue 32): the study's truth and CIELAB white were the newest
/// complete measurement of *any* booth (`store.latest_complete`), while the
/// daemon's comparisons take them from the compared measurement's booth; on
/// one PostgreSQL database with two booths the same measurement got another
/// ΔE from the study than from the dashboard. A study of booth north uses
/// north's measurements, even when south measured the target later.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_study_of_one_booth_took_the_newer_measurement_of_another_booth() {
    use lightbooth::colorimetry::Observer;
    use lightbooth::lab::study::measure::{measure_with_simulator, SimulatedPr650};
    use lightbooth::lab::study::run::{run_study, Against, StudyOptions};
    use lightbooth::render::Coding;
    use lightbooth::store::{Booth, Store};

    let db = common::fresh_postgres_database().await;
    let store = Store::open(&db).await.unwrap();
    let white = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/white.toml");
    let cache = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("converged-cache");
    let (north, south): (Booth, Booth) = ("north".parse().unwrap(), "south".parse().unwrap());
    let mut measured = Vec::new();
    for (booth, seed) in [(&north, 1), (&south, 2)] {
        let ids = measure_with_simulator(
            std::slice::from_ref(&white),
            &store,
            booth,
            &cache,
            SimulatedPr650 { seed, speed: 0.0 },
            Observer::JuddVos,
            None,
            &|_| {},
        )
        .await
        .unwrap();
        assert_eq!(ids.len(), 1, "WHITE has one target");
        measured.push(ids[0]);
    }
    assert!(measured[1] > measured[0], "south measured last: {measured:?}");
    for (booth, id) in [(&north, measured[0]), (&south, measured[1])] {
        let options = StudyOptions {
            codings: vec![Coding::Rgb, Coding::Spectral],
            seeds: 1,
            samples: 256,
            target_relative_se: None,
            against: Against::Measurements,
            booth: booth.clone(),
            ..StudyOptions::default()
        };
        let result = run_study(std::slice::from_ref(&white), &options, Some(&store), &|_| {}, None)
            .await
            .unwrap();
        let s = &result.scenes[0];
        assert_eq!(s.truth[0].source, format!("measurement {id}"), "booth {booth}'s truth");
        assert_eq!(
            s.white_source,
            format!("measurement {id} (white/patch)"),
            "booth {booth}'s CIELAB white"
        );
    }
    // A booth that measured nothing has no truth: never a neighbour's.
    let options = StudyOptions {
        against: Against::Measurements,
        booth: "east".parse().unwrap(),
        ..StudyOptions::default()
    };
    let err = run_study(std::slice::from_ref(&white), &options, Some(&store), &|_| {}, None)
        .await
        .unwrap_err();
    assert!(
        err.to_string()
            .contains("no complete measurement of white/patch in booth east"),
        "{err}"
    );
}
