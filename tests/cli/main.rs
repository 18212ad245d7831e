//! The command line: arguments, `lightbooth color`, and the build (no dependency compiled twice).
//!
//! One test crate (`cargo test --release --test cli`); each module below
//! was its own crate before, and keeps its file and its tests' names
//! (`cargo test --release --test cli <module>::`).

mod cli_arguments;
mod cli_colorimetry;
mod feature_pins;
