//! lightbooth: checks, in the lab, that a rendered stimulus matches the real
//! scene.
//!
//! It drives the lab's instrument in a lighting booth (the spectroradiometers
//! PR-650/655/670, CS-2000/2000A/3000 and CR-250/300, the ColorCAL MkII and
//! CS-100A colorimeters, the LS-100 luminance meter), keeps every sample,
//! renders the same scene in every
//! colour coding (RGB, sRGB, N-step spectral, full spectral) and reports how
//! far each rendering is from the measurement, and at what cost in time. The
//! study it automates is Ruppertsberg & Bloj (2006), "Rendering complex
//! scenes for psychophysics using RADIANCE: How accurate can you get?",
//! JOSA A 23(4), 759–768.
//!
//! # Where things live
//!
//! Science, pure and without I/O, is a crate of its own,
//! `lightbooth-science` (`crates/science`), whose modules this crate
//! re-exports under their names; it depends on no other part of
//! lightbooth, and Cargo refuses a build where it would:
//!
//! - [`spectrum`]: spectra with their grid and unit; CSV in and out.
//! - [`reference_data`]: CIE matching functions, illuminants and reflectance
//!   sets compiled into the binary.
//! - [`colorimetry`]: XYZ, chromaticity, CIELAB, ΔE*ab, CIEDE2000, RGB spaces.
//! - [`nstep`]: the N-step spectral approximation and its error analysis.
//! - [`comparison`]: the figures of merit of a rendering against a
//!   measurement (ΔE, luminance ratio, rms_rel, significance).
//! - [`calibration`]: reflectances and lamp spectra from measurements
//!   against a white standard.
//! - [`display`]: a display profile, and rendered colours turned into
//!   frame-buffer codes.
//! - [`random`]: seeded random numbers specified to the bit (SplitMix64),
//!   for seeds that are stored.
//! - [`psychophysics`]: whether an observer can tell: percent correct with
//!   its exact interval, and d′ of the study's oddity task under the
//!   differencing and independent-observation models.
//!
//! The two instruments of the lab, a real one and a simulated one, are a
//! crate each above the science (`crates/instrument`, `crates/render`),
//! re-exported here under their names:
//!
//! - [`instrument`]: the `Spectroradiometer` trait; one serial link session
//!   (`instrument::link`: exchange, resync, timeouts) and one reply error
//!   (`instrument::reply`) under the drivers of every model; their
//!   simulators on ptys (`instrument::sim`); discovery under a deadline.
//! - [`render`]: the built-in spectral renderer, every coding in one pass.
//!   **It samples a light in [`render::integrator`]** (`estimate_direct`:
//!   one light of the scene's one collection, chosen by the light sampler
//!   of [`render::lights`]`::sampler`, by luminous flux by default).
//!
//! Keeping and showing results:
//!
//! - [`store`]: the database (SQLite or PostgreSQL), every raw sample; a
//!   crate of its own above those two (`crates/store`, with the top-level
//!   `migrations/` embedded).
//! - [`charts`]: the charts as SVG; [`export`]: MAT, EXR and ENVI files;
//!   pure functions of the data a workflow chooses, a crate of their own
//!   beside the store (`crates/report`).
//!
//! The workflows, a crate of their own above the store and the report
//! (`crates/lab`):
//!
//! - [`lab`]: measurements, the instrument queue, events, renders,
//!   comparisons, jobs, camera images, calibrations, leases, the hand-off
//!   to render workers. **A measurement is asked for in
//!   [`lab::measure::booth_instrument`]** (`BoothInstrument::request`: checked,
//!   recorded, queued; the HTTP handlers' one way to the instrument) **and
//!   taken in [`lab::measure::recorder`]** (`Recorder::take`: each sample stored
//!   before the next, completed or ended with its reason; the daemon's
//!   instrument task and the simulated study both call it). **A measurement's comparison with every
//!   coding is computed in [`lab::compare`]** (`Comparisons::compare`:
//!   it takes the render of the scene from the store, or has
//!   [`lab::render::runner`] render it once, resolves the booth's CIELAB
//!   white, applies [`comparison`]'s figures of merit), and stored by
//!   [`store`]; [`lab::compare::summary`] summarises a scene's per coding;
//!   [`lab::compare::white`] resolves a scene's CIELAB white, for the
//!   study too.
//! - [`lab::study`]: the study (every coding against measurements or a
//!   reference, sweeps, failure maps, the automatic choice of settings).
//! - [`lab::experiments`]: the oddity experiment. **An experiment's trial
//!   is stored by `Experiments::record_trial`** ([`lab::experiments::session`]:
//!   it checks the trial against the session's next position and its
//!   frames, then [`store`]'s `insert_trial` writes it, the session's last
//!   one ending the session in the same transaction).
//!
//! Serving them:
//!
//! - [`http`]: the REST API, server-sent events and dashboards (axum).
//!   **Its handlers reach the lab only through [`lab::LabHandle`]** (the app
//!   state's handle on the instrument, the renders, the experiments and
//!   every record); the architecture test fails on a handler that names
//!   the store.
//! - [`worker`]: `lightbooth worker`, a render worker on PostgreSQL.
//! - [`daemon`]: `lightbooth serve`, wiring it all: [`daemon::run`] starts
//!   the instrument task, the lab's workflows and the HTTP server.
//!
//! The command line (`src/cli/`, in the binary) calls these.
//!
//! # The layer rule
//!
//! Levels 0 to 3 are crates (science; instrument and render; store, and
//! report with the charts and exports; lab): the compiler keeps the science below
//! everything else, the instruments and the renderer out of each other,
//! and all of them below this crate. Above them, inside this crate, a module may use
//! modules on its own level or below, never above; the
//! architecture test (`tests/cli/architecture.rs`) reads this table and
//! every `crate::…` path under `src/`, and fails naming the file, the line
//! and the forbidden edge. No two files import each other, directly or
//! round a circle (the same test resolves every path to its file; a
//! module's `mod.rs` using its own submodules does not count). So physics
//! and colour science know nothing of storage or HTTP, and the workflows
//! know nothing of axum. Only levels 4
//! and 5 may name the HTTP layer; today only the daemon, which wires it
//! together, does (the worker, on level 4 beside it, does not).
//!
//! | level | modules |
//! |---|---|
//! | 5 | daemon |
//! | 4 | http, worker |
//! | 3 | lab |
//! | 2 | store, charts, export |
//! | 1 | instrument, render |
//! | 0 | spectrum, reference_data, colorimetry, nstep, comparison, calibration, display, psychophysics, random |

pub mod daemon;
pub mod http;
pub mod worker;

// The layers below this crate, each a crate of its own, under the names
// their modules had here: the lab (`crates/lab`), the store and the charts
// and exports under it (`crates/store`, `crates/report`), the instruments and
// the renderer under it (`crates/instrument`, `crates/render`), and the
// science under them all (`crates/science`).
pub use lightbooth_instrument as instrument;
pub use lightbooth_lab as lab;
pub use lightbooth_render as render;
pub use lightbooth_report::{charts, export};
pub use lightbooth_science::{
    calibration, colorimetry, comparison, display, nstep, psychophysics, random, reference_data, spectrum, uncertainty,
};
pub use lightbooth_store as store;
