//! The home page's instrument card in a real headless Chromium
//! (`tests/browser/instrument_card.mjs`) against a daemon driving a
//! simulated CS-2000: model, serial, what it measures, port, and "Look for
//! instruments again" listing every serial port with what it answered.

use crate::common;

use common::Daemon;
use lightbooth::instrument::cs2000::{Cs2000Settings, Model};
use lightbooth::instrument::InstrumentSettings;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_instrument_card_names_what_it_measures_and_looks_for_instruments_again() {
    let settings = Cs2000Settings {
        command_timeout_ms: 2_000,
        end_margin_ms: 500,
        ..Cs2000Settings::for_model(Model::Cs2000)
    };
    let d = Daemon::start_instrument(0.0, InstrumentSettings::Cs2000(settings)).await;
    let shots = common::screenshot_dir();
    eprintln!("instrument card screenshots: {}", shots.display());
    let result = common::run_browser_script("instrument_card.mjs", d.addr, shots).await;
    d.stop().await;
    if let Err(e) = result {
        panic!("{e}");
    }
}
