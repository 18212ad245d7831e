//! The command line and its manual: arguments, `lightbooth color`, the build (no dependency compiled twice), and the book (it builds, its links resolve, its console examples run).
//!
//! One test crate (`cargo test --release --test cli`); each module below
//! was its own crate before, and keeps its file and its tests' names
//! (`cargo test --release --test cli <module>::`).

mod architecture;
mod book_examples;
mod cli_arguments;
mod cli_colorimetry;
mod feature_pins;
mod newcomer;
