//! The instruments: the PR-650, PR-655/670, CS-2000, CR-250, ColorCAL MkII and LS-100/CS-100A drivers against the simulators on real ptys, faults on the wire, the public clients (PsychoPy's instrument classes, colour-specio) against the simulators, and `lightbooth measure`.
//!
//! One test crate (`cargo test --release --test instrument`); each module below
//! was its own crate before, and keeps its file and its tests' names
//! (`cargo test --release --test instrument <module>::`).

#[path = "../common/mod.rs"]
mod common;

mod cli_measure;
mod colorcal;
mod colorimeter_support;
mod cr250;
mod cs2000;
mod discovery;
mod instrument_faults;
mod ls100;
mod pr655_driver;
mod pr655_simulator;
mod psychopy_clients;
