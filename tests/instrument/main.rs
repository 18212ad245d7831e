//! The instruments: the PR-650, PR-655/670, CS-2000, CR-250, ColorCAL MkII and LS-100/CS-100A drivers against the simulators on real ptys, faults on the wire, the public clients (PsychoPy's instrument classes, colour-specio) against the simulators, and `lightbooth measure`.
//!
//! One test crate (`cargo test --release --test instrument`); each module below
//! was its own crate before, and keeps its file and its tests' names
//! (`cargo test --release --test instrument <module>::`).

#[path = "../common/mod.rs"]
mod common;

/// These tests wait on the simulators' real-time replies and timeouts far
/// more than they compute: 82 tests took 8 CPU-seconds in 128 s of wall time
/// at libtest's default of one test per core, and 38 s eight at a time, on a
/// 2-core machine. So this binary runs eight at once unless told otherwise
/// (`--test-threads N` or `RUST_TEST_THREADS` still win). The other suites
/// compute, or race a simulator's pace against the test's own, and keep the
/// default: the daemon suite, eight at a time, lost two such races.
///
/// Set before `main` (an ELF `.init_array` entry, as the `ctor` crate makes,
/// run while the process is still single-threaded), because libtest reads
/// the variable as it starts.
#[used]
#[link_section = ".init_array"]
static WAITING_TESTS_RUN_EIGHT_AT_ONCE: extern "C" fn() = eight_test_threads;

extern "C" fn eight_test_threads() {
    if std::env::var_os("RUST_TEST_THREADS").is_none() {
        std::env::set_var("RUST_TEST_THREADS", "8");
    }
}

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
