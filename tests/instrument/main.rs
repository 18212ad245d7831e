//! The spectroradiometers: the PR-650 and PR-655/670 drivers against the simulators on real ptys, faults on the wire, PsychoPy's instrument classes as clients, and `lightbooth measure`.
//!
//! One test crate (`cargo test --release --test instrument`); each module below
//! was its own crate before, and keeps its file and its tests' names
//! (`cargo test --release --test instrument <module>::`).

#[path = "../common/mod.rs"]
mod common;

mod cli_measure;
mod discovery;
mod instrument_faults;
mod pr655_driver;
mod pr655_simulator;
mod psychopy_clients;
