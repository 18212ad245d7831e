//! Render requests beyond the documented limits (`render::scene`) are
//! refused with 400 naming the field, before any work is queued: one
//! request with `samples` and `bounces` of 4e9 used to tie up the renderer.
//! A whole daemon on loopback, as a script would reach it.

mod common;

use common::{get_json, post_json, Daemon, TOKEN};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn render_request_with_4e9_samples_or_bounces_is_refused_and_starts_nothing() {
    let daemon = Daemon::start(0.0).await;
    for (body, field) in [
        (r#"{"samples": 4000000000}"#, "samples"),
        (r#"{"samples": 0}"#, "samples"),
        (r#"{"bounces": 4000000000}"#, "bounces"),
        (r#"{"bounces": 65}"#, "bounces"),
    ] {
        let (status, v) = post_json(daemon.addr, "/api/scenes/white/renders", TOKEN, body).await;
        assert_eq!(status, 400, "{body}: {v}");
        let message = v["error"]["message"].as_str().unwrap();
        assert!(message.contains(&format!("field `{field}`")), "{body}: {message}");
    }
    let (status, renders) = get_json(daemon.addr, "/api/scenes/white/renders").await;
    assert_eq!(status, 200);
    assert_eq!(
        renders.as_array().unwrap().len(),
        0,
        "a refused request left a render: {renders}"
    );
    daemon.stop().await;
}
