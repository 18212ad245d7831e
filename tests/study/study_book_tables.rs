//! The study chapter's tables and timings (`docs/src/study-tables.md` and
//! `docs/src/study-timing.md`, included by `docs/src/study.md`), written by
//! running the commands the chapter shows, as a user runs them: the built
//! binary's `lightbooth study … --measure-simulated --against measurements
//! --json` on the five booth scenes, once against the model and once with
//! `--truth-scene scenes/truth`. The bug (issue 46): the chapter's table was
//! typed in by hand and disagreed with the binary (targets beyond noise:
//! srgb 15 against the book's 12, nstep81 5 against 2, spectral 3 against 1;
//! CYLINDER rms_rel rgb 1.78 % against 1.74 %), and the README's "about 22 s"
//! and the chapter's 47.5 s against 33 s measured.
//!
//! Every number of the tables is seeded (the simulated PR-650's noise, every
//! render's seed stream, the converged truth's own seed), so an unchanged
//! program computes the same tables: a run that computes others fails,
//! saying how to update the book. The timings vary with the machine: they
//! are written to `target/` on every run, and into the book only with
//! `LIGHTBOOTH_UPDATE_BOOK=1`.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use serde_json::Value;

const SCENES: [&str; 5] = ["white", "red", "green", "blue", "cylinder"];
const CODINGS: [&str; 7] = ["rgb", "srgb", "nstep3", "nstep9", "nstep27", "nstep81", "spectral"];

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// `lightbooth study` on the five scenes with `extra` arguments, in a fresh
/// folder (its own database and converged-truth cache, as on a first run):
/// the parsed `--json` result and the command's wall time in seconds.
fn study(extra: &[&str]) -> (Value, f64) {
    let dir = tempfile::tempdir().unwrap();
    let scenes: Vec<PathBuf> = SCENES
        .iter()
        .map(|s| root().join("scenes").join(format!("{s}.toml")))
        .collect();
    let started = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .arg("study")
        .args(&scenes)
        .args(["--measure-simulated", "--against", "measurements", "--json"])
        .arg("--db")
        .arg(format!("sqlite://{}", dir.path().join("study.sqlite").display()))
        .arg("--cache-dir")
        .arg(dir.path().join("cache"))
        .args(extra)
        .current_dir(dir.path())
        .output()
        .unwrap();
    let wall = started.elapsed().as_secs_f64();
    assert!(
        out.status.success(),
        "lightbooth study {extra:?}: {}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    (
        serde_json::from_slice(&out.stdout).expect("--json prints the study"),
        wall,
    )
}

fn coding<'a>(result: &'a Value, scene: &str, coding: &str) -> &'a Value {
    let s = result["scenes"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["scene"] == scene)
        .unwrap_or_else(|| panic!("no scene {scene}"));
    s["codings"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["coding"] == coding)
        .unwrap_or_else(|| panic!("no coding {coding} in {scene}"))
}

fn num(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

/// ΔE*ab as the chapter writes it: three significant figures below 10,
/// one decimal above.
fn de(v: f64) -> String {
    if v >= 10.0 {
        format!("{v:.1}")
    } else {
        format!("{v:.2}")
    }
}

fn percent(v: f64) -> String {
    format!("{:.2} %", 100.0 * v)
}

fn row(label: &str, cells: impl Iterator<Item = String>) -> String {
    format!("| {label} | {} |\n", cells.collect::<Vec<_>>().join(" | "))
}

fn header(first: &str) -> String {
    format!(
        "| {first} | {} |\n|---|{}\n",
        CODINGS.join(" | "),
        "---|".repeat(CODINGS.len())
    )
}

/// The tables of the chapter from the two studies' results.
fn tables(model: &Value, perturbed: &Value) -> String {
    let mut out = String::new();
    out += "<!-- Written by tests/study/study_book_tables.rs: do not edit by hand. -->\n\n";
    out += &format!(
        "Mean ΔE*ab over {} seeds against the simulated PR-650's measurements ({} observer), the \
         CYLINDER's relative RMS luminance error, and how many of the 25 targets differ from the \
         measurement beyond noise (k = {}):\n\n",
        model["options"]["seeds"],
        model["observer"].as_str().unwrap(),
        model["beyond_noise_k"]
    );
    out += &header("scene");
    for scene in SCENES {
        out += &row(
            &format!("{} ΔE*ab", scene.to_uppercase()),
            CODINGS
                .iter()
                .map(|c| de(num(&coding(model, scene, c)["mean_dE76"]["mean"]))),
        );
    }
    out += &row(
        "CYLINDER rms_rel",
        CODINGS
            .iter()
            .map(|c| percent(num(&coding(model, "cylinder", c)["rms_rel"]["mean"]))),
    );
    out += &row(
        "targets beyond noise (of 25)",
        CODINGS.iter().map(|c| {
            SCENES
                .iter()
                .map(|s| coding(model, s, c)["significant_targets"].as_u64().unwrap())
                .sum::<u64>()
                .to_string()
        }),
    );
    let sd_max = SCENES
        .iter()
        .flat_map(|s| {
            CODINGS
                .iter()
                .map(move |c| num(&coding(model, s, c)["mean_dE76"]["sd"]))
        })
        .fold(0.0, f64::max);
    out += &format!("\nThe largest SD of a mean ΔE*ab over seeds is {sd_max:.3}.\n\n");

    // rms_rel against what the instrument's stated accuracy alone gives.
    let claims = coding(model, "white", "rgb")["uncertainty"].clone();
    if claims.is_object() {
        let null = claims["rms_rel"]["null_95th_stated_accuracy"].as_f64();
        out += &format!(
            "Relative RMS luminance error per scene; **bold** where it is distinguishable from the \
             measurement beyond the {} stated accuracy ({} in luminance; measurement error alone gives \
             rms_rel up to {} at the 95th percentile):\n\n",
            claims["instrument_model"].as_str().unwrap(),
            claims["accuracy"]["luminance_bound_percent"]
                .as_f64()
                .map_or("not stated".into(), |p| format!("±{p} %")),
            null.map_or("—".into(), percent),
        );
        out += &header("rms_rel");
        for scene in SCENES {
            out += &row(
                scene.to_uppercase().as_str(),
                CODINGS.iter().map(|c| {
                    let k = coding(model, scene, c);
                    let v = percent(num(&k["rms_rel"]["mean"]));
                    match k["uncertainty"]["rms_rel"]["claims"]["beyond_stated_accuracy"].as_bool() {
                        Some(true) => format!("**{v}**"),
                        _ => v,
                    }
                }),
            );
        }
        out += "\n";
    }

    out += "The same with `--truth-scene scenes/truth` (the CYLINDER as a lab might really have it) against the \
            model's renderings, CYLINDER only:\n\n";
    out += &header("CYLINDER vs");
    out += &row(
        "perfect model: ΔE*ab",
        CODINGS
            .iter()
            .map(|c| de(num(&coding(model, "cylinder", c)["mean_dE76"]["mean"]))),
    );
    out += &row(
        "perturbed truth: ΔE*ab",
        CODINGS
            .iter()
            .map(|c| de(num(&coding(perturbed, "cylinder", c)["mean_dE76"]["mean"]))),
    );
    out += &row(
        "perfect model: rms_rel",
        CODINGS
            .iter()
            .map(|c| percent(num(&coding(model, "cylinder", c)["rms_rel"]["mean"]))),
    );
    out += &row(
        "perturbed truth: rms_rel",
        CODINGS
            .iter()
            .map(|c| percent(num(&coding(perturbed, "cylinder", c)["rms_rel"]["mean"]))),
    );
    out += &row(
        "perfect model: beyond noise (of 21)",
        CODINGS
            .iter()
            .map(|c| coding(model, "cylinder", c)["significant_targets"].to_string()),
    );
    out += &row(
        "perturbed truth: beyond noise (of 21)",
        CODINGS
            .iter()
            .map(|c| coding(perturbed, "cylinder", c)["significant_targets"].to_string()),
    );
    out
}

fn timing(model: (&Value, f64), perturbed: (&Value, f64)) -> String {
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    // What else the machine was doing: the 1-minute load average at the end.
    let load = std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|l| l.split_whitespace().next().map(str::to_string))
        .unwrap_or_else(|| "unknown".into());
    format!(
        "<!-- Written by tests/study/study_book_tables.rs with LIGHTBOOTH_UPDATE_BOOK=1. -->\n\
         Measured by `tests/study/study_book_tables.rs` on a {cores}-core machine with a load average of {load} (the release build, a fresh \
         database and converged-truth cache, so each target's truth is converged first): the study against \
         the model {:.1} s wall in all ({:.1} s for the study itself, after measuring); with \
         `--truth-scene scenes/truth` {:.1} s ({:.1} s for the study).\n",
        model.1,
        num(&model.0["wall_seconds"]),
        perturbed.1,
        num(&perturbed.0["wall_seconds"]),
    )
}

/// The chapter's file `name` is `text`, or with `LIGHTBOOTH_UPDATE_BOOK=1`
/// becomes it. The run's text is always in `target/`.
fn the_books_file_is(name: &str, text: &str, compare: bool) {
    std::fs::write(root().join("target").join(name), text).unwrap();
    let book = root().join("docs/src").join(name);
    if std::env::var_os("LIGHTBOOTH_UPDATE_BOOK").is_some() {
        std::fs::write(&book, text).unwrap();
        return;
    }
    if compare {
        let shown = std::fs::read_to_string(&book).unwrap_or_default();
        assert!(
            shown == text,
            "the book's {} is not what this run computed (target/{name}): if the change is meant, run \
             `LIGHTBOOTH_UPDATE_BOOK=1 cargo test --release --test study study_book_tables` and commit the file",
            book.display()
        );
    }
}

#[test]
fn the_study_chapters_tables_were_typed_by_hand() {
    let model = study(&[]);
    let truth = root().join("scenes/truth");
    let perturbed = study(&["--truth-scene", truth.to_str().unwrap()]);
    the_books_file_is("study-tables.md", &tables(&model.0, &perturbed.0), true);
    the_books_file_is(
        "study-timing.md",
        &timing((&model.0, model.1), (&perturbed.0, perturbed.1)),
        false,
    );
}
