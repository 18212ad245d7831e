//! `lightbooth serve` as a whole: measurements end to end, jobs, crashes, kill -9 and database outages, several booths on PostgreSQL, render workers and the operator's workflow.
//!
//! One test crate (`cargo test --release --test daemon`); each module below
//! was its own crate before, and keeps its file and its tests' names
//! (`cargo test --release --test daemon <module>::`).

#[path = "../common/mod.rs"]
mod common;

mod booths_scale;
mod daemon_crash;
mod daemon_cs2000;
mod daemon_e2e;
mod daemon_jobs;
mod daemon_mock_faults;
mod daemon_models;
mod daemon_pr670;
mod daemon_recovery;
mod daemon_wire_log;
mod db_lock;
mod operator;
mod postgres_daemons;
mod render_workers;
