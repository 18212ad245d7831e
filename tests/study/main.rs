//! The study's workflows: `lightbooth study`, the automatic and failure-map analyses, the speed chart, display calibration and stimuli.
//!
//! One test crate (`cargo test --release --test study`); each module below
//! was its own crate before, and keeps its file and its tests' names
//! (`cargo test --release --test study <module>::`).

mod display_calibration;
mod speed_chart;
mod stimulus;
mod study_auto;
mod study_book_tables;
mod study_failure_map;
mod study_run;
