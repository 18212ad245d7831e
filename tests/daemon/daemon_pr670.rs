//! The daemon driving a (simulated) PR-670 exactly as it drives a PR-650:
//! the API, the store and the dashboard's data say which instrument took a
//! measurement, its spectrum stays on the PR-670's 2 nm grid, and requests
//! are checked against the PR-670's own limits.

use crate::common;

use std::time::Duration;

use common::{get_json, poll_until, post_json, Daemon, TOKEN};
use lightbooth::instrument::pr655::{Model, Pr655Settings};
use lightbooth::instrument::InstrumentSettings;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_pr670_booth_measures_from_the_api_and_every_measurement_names_it() {
    let settings = Pr655Settings {
        command_timeout_ms: 2_000,
        measure_timeout_ms: Some(5_000),
        gap_timeout_ms: 500,
        remote_entry_delay_ms: 40,
        ..Pr655Settings::for_model(Model::Pr670)
    };
    let d = Daemon::start_instrument(0.0, InstrumentSettings::Pr655(settings)).await;
    let (_, health) = get_json(d.addr, "/api/health").await;
    assert_eq!(health["instrument"]["model"], "PR-670", "{health}");
    assert_eq!(health["instrument"]["serial"], "67065106", "{health}");

    let (status, e) = post_json(d.addr, "/api/measurements", TOKEN, r#"{"samples": 100}"#).await;
    assert_eq!(status, 400, "{e}");
    assert!(e.to_string().contains("PR-670"), "the limit is the model's: {e}");

    let (status, m) = post_json(
        d.addr,
        "/api/measurements",
        TOKEN,
        r#"{"scene": "white", "target": "patch", "samples": 3}"#,
    )
    .await;
    assert_eq!(status, 202, "{m}");
    let id = m["id"].as_i64().unwrap();
    let done = poll_until(
        d.addr,
        &format!("/api/measurements/{id}"),
        Duration::from_secs(120),
        |v| v["state"] != "queued" && v["state"] != "running",
    )
    .await;
    assert_eq!(done["state"], "complete", "{done}");
    assert_eq!(done["instrument_model"], "PR-670");
    assert_eq!(done["instrument_serial"], "67065106");
    let nm = done["wavelength_nm"].as_array().unwrap();
    assert_eq!(nm.len(), 201, "the PR-670's native grid, not resampled");
    assert_eq!((nm[0].as_f64(), nm[1].as_f64()), (Some(380.0), Some(382.0)));
    assert_eq!(done["samples"].as_array().unwrap().len(), 3);
    let (_, listing) = get_json(d.addr, "/api/measurements").await;
    assert_eq!(listing["items"][0]["instrument_model"], "PR-670", "{listing}");
    d.stop().await;
}
