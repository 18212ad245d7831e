//! The REST API and the dashboards: every route through `app(state)` or a real loopback server, hardening against hostile clients, the OpenAPI document checked by Schemathesis, and the pages in headless Chromium.
//!
//! One test crate (`cargo test --release --test api`); each module below
//! was its own crate before, and keeps its file and its tests' names
//! (`cargo test --release --test api <module>::`).

#[path = "../common/mod.rs"]
mod common;

mod api_schemathesis;
mod dashboard_browser;
mod dashboard_instrument_card;
mod dashboard_material;
mod dashboard_off_loopback;
mod dashboard_page_details;
mod dashboard_stored_scripts;
mod dashboard_viewer;
mod display_calibration_browser;
mod display_profile_api;
mod experiment;
mod experiment_races;
mod experiment_study;
mod http_hardening;
mod http_parts;
mod octave_examples;
mod render_requests;
mod service_api;
mod stimulus_sets;
