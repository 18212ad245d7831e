//! Render requests beyond the documented limits (`render::scene`) are
//! refused with 400 naming the field, before any work is queued: one
//! request with `samples` and `bounces` of 4e9 used to tie up the renderer.
//! A whole daemon on loopback, as a script would reach it.

use crate::common;

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

/// A render the daemon records leaves its scene's bundle in the store (for
/// render workers without `scenes/`): the render row's key leads to the
/// bundle, and the bundle unpacked far from `scenes/` loads with that key.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_recorded_render_stores_its_scene_bundle_under_the_renders_key() {
    let daemon = Daemon::start(0.0).await;
    let (status, r) = post_json(daemon.addr, "/api/scenes/white/renders", TOKEN, r#"{"samples": 64}"#).await;
    assert!(status == 200 || status == 202, "{status}: {r}");
    let id = r["render_id"].as_i64().unwrap();
    let url = format!("sqlite://{}", daemon.dir.path().join("lab.sqlite").display());
    let store = lightbooth::store::Store::open_to_read(&url).await.unwrap();
    let render = store.get_render(id).await.unwrap().unwrap();
    let hash = store
        .scene_bundle_for_render_key(&render.scene_hash)
        .await
        .unwrap()
        .expect("no bundle stored for the render's scene");
    let stored = store.scene_bundle(&hash).await.unwrap().unwrap();
    assert_eq!(stored.scene_id, "white");
    assert_eq!(stored.bundle.scene_file(), "white.toml");
    let cache = tempfile::tempdir().unwrap();
    let toml = stored.bundle.unpack(cache.path()).unwrap();
    let unpacked = lightbooth::render::load_scene(&toml).unwrap();
    assert_eq!(lightbooth::render::scene_hash(&unpacked).unwrap(), render.scene_hash);
    daemon.stop().await;
}
