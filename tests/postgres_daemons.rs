//! `serve --db postgres://…`: whole daemons on a real PostgreSQL database
//! (the server `tests/setup.sh` starts). A measurement goes through the API
//! into PostgreSQL with every sample, and a second daemon on the same
//! database starts (no file lock between them) and serves what the first
//! measured.

mod common;

use std::time::Duration;

use common::{get_json, poll_until, post_json, Daemon, TOKEN};

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
