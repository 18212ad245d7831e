//! The default render is unbiased (issue 22): it used to stop every path at
//! 5 bounces, which left the Cornell box 1–1.6 % too dark at four of its
//! nine targets while each result reported an SE of about 0.3 %. Now the
//! default has no bounce cap (Russian roulette ends the paths), and a cap,
//! still available to emulate RADIANCE's `-ab 5`, is stated in the output.
//!
//! The independent answer here is an unbiased estimator of another kind: a
//! render with a fixed 64-bounce depth limit (the booth's reflectances leave
//! < 1e-6 of the light after 64 bounces) and Russian roulette from bounce 5,
//! with its own seed, so its noise is independent of the default's.

use std::path::Path;
use std::process::Command;

use lightbooth::render::{load_scene, render, Coding, RenderResult, RenderSettings};

fn scene_path(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name)
}

/// The default render, `spectral` and `rgb` only (the transport is the
/// same for every coding; fewer codings keep the test short).
fn default_render(name: &str) -> RenderResult {
    let scene = load_scene(&scene_path(name)).unwrap();
    let settings = RenderSettings {
        codings: vec![Coding::Rgb, Coding::Spectral],
        ..RenderSettings::default()
    };
    render(&scene, &settings, None, None).unwrap()
}

/// 64 bounces, Russian roulette from 5, another seed, the same SE goal.
fn deep_render(name: &str) -> RenderResult {
    let scene = load_scene(&scene_path(name)).unwrap();
    let settings = RenderSettings {
        codings: vec![Coding::Rgb, Coding::Spectral],
        max_bounces: Some(64),
        russian_roulette_from: Some(5),
        seed: 0x5eed_0022,
        ..RenderSettings::default()
    };
    render(&scene, &settings, None, None).unwrap()
}

/// Every target and coding of `a` within 3 combined SE of `b` (plus 1e-6 of
/// Y for the targets that see only an emitter: zero SE in both).
fn assert_agree(a: &RenderResult, b: &RenderResult) {
    let mut failures = Vec::new();
    for (ta, tb) in a.targets.iter().zip(&b.targets) {
        assert_eq!(ta.id, tb.id);
        for (name, ca) in &ta.codings {
            let cb = tb.coding(name).unwrap();
            let se = ca.luminance_se_cd_m2.hypot(cb.luminance_se_cd_m2);
            let diff = ca.luminance_cd_m2 - cb.luminance_cd_m2;
            if diff.abs() > 3.0 * se + 1e-6 * cb.luminance_cd_m2.abs() {
                failures.push(format!(
                    "{} {name}: default {:.5} vs 64-bounce {:.5} cd/m² ({:+.3} %, {:.1} combined SE)",
                    ta.id,
                    ca.luminance_cd_m2,
                    cb.luminance_cd_m2,
                    100.0 * diff / cb.luminance_cd_m2,
                    diff / se
                ));
            }
        }
    }
    assert!(
        failures.is_empty(),
        "the default render is biased:\n{}",
        failures.join("\n")
    );
}

#[test]
fn default_render_of_the_cornell_box_is_not_darkened_by_a_bounce_cap() {
    let default = default_render("cornell_box.toml");
    assert_eq!(default.truncated_at_bounces, None);
    assert_eq!(default.targets.len(), 9);
    assert_agree(&default, &deep_render("cornell_box.toml"));
}

#[test]
fn default_render_of_the_cylinder_booth_is_not_darkened_by_a_bounce_cap() {
    let default = default_render("cylinder.toml");
    assert_eq!(default.truncated_at_bounces, None);
    assert_agree(&default, &deep_render("cylinder.toml"));
}

/// The JSON of the default render says it is not truncated, in a way a
/// client reads: `max_bounces` and `truncated_at_bounces` are `null`, never
/// u32::MAX's 4294967295; a capped render says "truncated at 5 bounces".
#[test]
fn capped_render_json_says_it_is_truncated_at_n_bounces() {
    let scene = load_scene(&scene_path("cornell_box.toml")).unwrap();
    let quick = RenderSettings {
        codings: vec![Coding::Spectral],
        samples: 256,
        target_relative_se: None,
        ..RenderSettings::default()
    };
    let open = serde_json::to_value(render(&scene, &quick, None, None).unwrap()).unwrap();
    assert!(open["settings"]["max_bounces"].is_null(), "{}", open["settings"]);
    assert!(open["truncated_at_bounces"].is_null());
    assert!(open.get("truncation_note").is_none());
    let back: RenderSettings = serde_json::from_value(open["settings"].clone()).unwrap();
    assert_eq!(back.max_bounces, None);

    let capped = RenderSettings {
        max_bounces: Some(5),
        ..quick
    };
    let v = serde_json::to_value(render(&scene, &capped, None, None).unwrap()).unwrap();
    assert_eq!(v["truncated_at_bounces"], 5);
    assert_eq!(v["settings"]["max_bounces"], 5);
    assert!(
        v["truncation_note"]
            .as_str()
            .unwrap()
            .contains("truncated at 5 bounces"),
        "{}",
        v["truncation_note"]
    );

    // The command line: the JSON and the table say it too.
    let cli = |extra: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
            .arg("render")
            .arg(scene_path("cornell_box.toml"))
            .args(["--codings", "spectral", "--samples", "256", "--target-se", "0"])
            .args(extra)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8(out.stdout).unwrap()
    };
    let json: serde_json::Value = serde_json::from_str(&cli(&["--bounces", "5", "--json"])).unwrap();
    assert_eq!(json["truncated_at_bounces"], 5);
    assert!(cli(&["--bounces", "5"]).contains("truncated at 5 bounces"));
    let json: serde_json::Value = serde_json::from_str(&cli(&["--json"])).unwrap();
    assert!(json["truncated_at_bounces"].is_null());
    assert_eq!(json["settings"]["russian_roulette_from"], 3);
    assert!(!cli(&[]).contains("truncated"));
}

/// Without a cap, roulette is what ends a path: "never" needs a cap.
#[test]
fn unbounded_render_without_russian_roulette_is_refused() {
    let scene = load_scene(&scene_path("cornell_box.toml")).unwrap();
    let settings = RenderSettings {
        russian_roulette_from: None,
        samples: 256,
        ..RenderSettings::default()
    };
    let e = render(&scene, &settings, None, None).unwrap_err().to_string();
    assert!(e.contains("Russian roulette") && e.contains("cap"), "{e}");
}

/// Issue 22: every coding of a render traces the same rays, so "rays
/// traced" cannot rank codings, and timed once each in a fixed order the
/// first-timed coding (`rgb`) was the slowest in every render — warm-up,
/// not cost. Now each is timed 3 times in rotated order after a warm-up
/// render, the median reported with its spread, and the method stated.
#[test]
fn first_timed_coding_does_not_pay_the_warm_up_timings_are_rotated_medians() {
    use lightbooth::render::cost::{time_renders, TIMING_METHOD, TIMING_REPEATS};
    let scene = load_scene(&scene_path("white.toml")).unwrap();
    let alone: Vec<RenderSettings> = [Coding::Rgb, Coding::Srgb, Coding::NStep(9), Coding::Spectral]
        .iter()
        .map(|c| RenderSettings {
            codings: vec![*c],
            samples: 1024,
            target_relative_se: None,
            ..RenderSettings::default()
        })
        .collect();
    let timed = time_renders(&scene, &alone, TIMING_REPEATS, None).unwrap();
    assert_eq!(timed.len(), 4);
    for t in &timed {
        assert_eq!(t.seconds.len(), TIMING_REPEATS);
        assert!(t.fastest_seconds() <= t.median_seconds() && t.median_seconds() <= t.slowest_seconds());
    }
    // No coding is timed first in every round; rgb (first in the list) is
    // timed first at most once.
    assert!(timed.iter().all(|t| t.places.iter().filter(|&&p| p == 0).count() <= 1));
    assert!(timed[0].places.iter().any(|&p| p > 0));
    // The same rays for every coding: rays cannot be the cost axis.
    assert!(timed.iter().all(|t| t.result.rays == timed[0].result.rays));
    assert!(TIMING_METHOD.contains("median") && TIMING_METHOD.contains("rotated") && TIMING_METHOD.contains("warm-up"));

    // The command line's --time-each-coding states it and gives the spread.
    let out = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .arg("render")
        .arg(scene_path("white.toml"))
        .args([
            "--codings",
            "rgb,spectral",
            "--samples",
            "256",
            "--target-se",
            "0",
            "--time-each-coding",
            "--json",
        ])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rgb = &v["coding_cost"]["rgb"];
    assert_eq!(rgb["timing_repeats"], 3);
    assert!(rgb["wall_seconds_min"].as_f64().unwrap() <= rgb["wall_seconds"].as_f64().unwrap());
    assert!(rgb["wall_seconds"].as_f64().unwrap() <= rgb["wall_seconds_max"].as_f64().unwrap());
    let def = v["cost_definition"].as_str().unwrap();
    assert!(
        def.contains("median of 3 repeats in rotated order after a warm-up"),
        "{def}"
    );
}

/// The check above has teeth: the old default (a 5-bounce cap, no
/// roulette) fails it on the Cornell box — the bug this file pins.
#[test]
fn old_five_bounce_default_fails_the_same_check_on_the_cornell_box() {
    let scene = load_scene(&scene_path("cornell_box.toml")).unwrap();
    let old = RenderSettings {
        codings: vec![Coding::Rgb, Coding::Spectral],
        max_bounces: Some(5),
        russian_roulette_from: None,
        ..RenderSettings::default()
    };
    let old = render(&scene, &old, None, None).unwrap();
    let deep = deep_render("cornell_box.toml");
    let caught = std::panic::catch_unwind(|| assert_agree(&old, &deep));
    let message = *caught
        .expect_err("a 5-bounce render passed as unbiased")
        .downcast::<String>()
        .unwrap();
    assert!(message.contains("short_front"), "{message}");
    eprintln!("{message}");
}
