//! Issue 32: a display profile's name was a stored script that read the
//! write token (`web/calibrate.js` wrote it with `innerHTML`). Text carrying
//! a script is stored in every named record (display profile, experiment,
//! observer id, measurement notes, a reflectance's and an illuminant's
//! standard file, and a scene file's name in the daemon's scenes folder),
//! and every page is opened in headless Chromium
//! (`tests/browser/stored_scripts.mjs`): no script may run, each shows the
//! stored text as text, and every page carries a Content-Security-Policy
//! under which even text written as HTML cannot run its handler.
//! Screenshots go to `target/screenshots/`.

use crate::common;

use std::path::Path;

use common::Daemon;

/// Copies the folder `from` into `to`, recursively.
fn copy_folder(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_folder(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), target).unwrap();
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_script_stored_in_any_name_runs_on_no_page_and_the_policy_forbids_inline_script() {
    // The repository's scenes, and WHITE again as `hostile`, its name a script.
    let scenes = tempfile::tempdir().unwrap();
    copy_folder(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes"), scenes.path());
    let white = std::fs::read_to_string(scenes.path().join("white.toml")).unwrap();
    assert!(
        white.contains("name = \"WHITE\""),
        "scenes/white.toml names itself WHITE"
    );
    let hostile = white.replacen(
        "name = \"WHITE\"",
        "name = \"WHITE <img src=x onerror=__pwned('scene-name')>\"",
        1,
    );
    std::fs::write(scenes.path().join("hostile.toml"), hostile).unwrap();

    let d = Daemon::start_with_scenes(0.0, scenes.path()).await;
    let shots = common::screenshot_dir();
    eprintln!("stored-script screenshots: {}", shots.display());
    let result = common::run_browser_script("stored_scripts.mjs", d.addr, shots).await;
    d.stop().await;
    if let Err(e) = result {
        panic!("{e}");
    }
}
