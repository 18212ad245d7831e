//! The study's oddity experiment through the real daemon with `--mock`: the
//! simulated display calibrated through the API, WHITE's patch measured and
//! compared, an experiment set up on them; then the pages in headless
//! Chromium: the display verified through the session page's own shader
//! and the simulated PR-650, a dithered test patch measured between two
//! 8-bit levels, and a simulated observer at the keyboard
//! (`tests/browser/experiment.mjs`), whose every trial the daemon stored
//! with its frames, and the API alone driven by simulated observers of known
//! d′ for the statistics.

use crate::common;

use std::time::Duration;

use common::{get_json, post_json, Daemon, TOKEN};
use lightbooth::psychophysics::design::{Configuration, Stimulus};
use lightbooth::psychophysics::observer::SimulatedObserver;
use lightbooth::psychophysics::oddity::OddityModel;
use lightbooth::random::SplitMix64;
use serde_json::{json, Value};

pub(crate) use common::calibrated::{calibrated_booth, compared_measurement, measure};

pub(crate) async fn create(d: &Daemon, body: Value) -> Value {
    let (s, e) = post_json(d.addr, "/api/experiments", TOKEN, &body.to_string()).await;
    assert_eq!(s, 201, "{e}");
    e
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn observers_run_the_oddity_experiment_in_the_browser_and_every_trial_is_stored_with_its_frames() {
    let d = Daemon::start(0.0).await;
    let (profile, measurement) = calibrated_booth(&d).await;
    let e = create(
        &d,
        json!({
            "measurement_id": measurement, "display_profile_id": profile,
            "approximations": ["nstep3", "nstep9", "nstep81", "rgb"], "output": "noisy_bit",
            "presentation": { "repeats": 1, "adaptation_s": 0, "fixation_ms": 250, "pixel_pitch_mm": 0.5 },
            "seed": 5,
        }),
    )
    .await;
    let id = e["id"].as_i64().unwrap();
    let shots = common::screenshot_dir();
    eprintln!("experiment screenshots: {}", shots.display());
    let result = common::run_browser_script("experiment.mjs", d.addr, shots).await;
    if let Err(err) = result {
        d.stop().await;
        panic!("{err}");
    }
    verified_on_the_simulated_display(&d, id, profile).await;
    let (_, sessions) = get_json(d.addr, &format!("/api/experiments/{id}/sessions")).await;
    let sessions = sessions.as_array().unwrap().clone();
    assert_eq!(sessions.len(), 2, "{sessions:?}");
    for s in &sessions {
        assert_eq!(s["state"], "complete", "{s}");
        let frame_ms = s["frame_ms"].as_f64().expect("the page measured the refresh");
        assert!((4.0..=50.0).contains(&frame_ms), "frame {frame_ms} ms");
        assert!(s["client"].as_str().unwrap().contains("WebGL2"), "{s}");
    }
    // Every trial, as the database has it: 4 approximations × 6 configurations,
    // plus one repeat for each trial with a dropped frame during its pie (at
    // most 24); the
    // page's counts agree with the frame intervals it logged.
    let db = d.stop_keeping_files().await;
    let store = lightbooth::store::Store::open(&format!("sqlite://{}", db.path().join("lab.sqlite").display()))
        .await
        .unwrap();
    for s in &sessions {
        let sid = s["id"].as_i64().unwrap();
        let frame_ms = s["frame_ms"].as_f64().unwrap();
        let trials = store.trials_of_session(sid).await.unwrap();
        let repeats = trials.iter().filter(|t| t.dropped_in_stimulus).count().min(24);
        assert_eq!(
            trials.len(),
            24 + repeats,
            "session {sid}: the planned trials and the (capped) repeats"
        );
        let mut dropped_total = 0;
        for t in &trials {
            let long = t.frame_intervals_ms.iter().filter(|&&v| v > 1.5 * frame_ms).count() as i64;
            assert_eq!(
                t.dropped_frames, long,
                "session {sid} trial {}: dropped frames against its intervals",
                t.position
            );
            dropped_total += t.dropped_frames;
            let planned = (300.0 / frame_ms).round() as i64;
            assert_eq!(
                t.stimulus_frames,
                planned.max(1),
                "session {sid} trial {}: the pie's frames",
                t.position
            );
            assert!(t.reaction_ms > 0.0 && t.reaction_ms < 20_000.0, "{}", t.reaction_ms);
            if t.dropped_in_stimulus {
                assert!(t.dropped_frames > 0);
            }
        }
        eprintln!(
            "session {sid} ({}): {} trials, {repeats} repeated, {dropped_total} dropped frames, {:.2} Hz",
            s["observer_id"],
            trials.len(),
            1000.0 / frame_ms
        );
    }
}

/// A measurement's mean luminance and its standard error from its samples'
/// spread, cd/m², and the measurement.
async fn luminance_and_se(d: &Daemon, measurement: i64) -> (f64, f64, Value) {
    let (s, m) = get_json(d.addr, &format!("/api/measurements/{measurement}")).await;
    assert_eq!(s, 200, "{m}");
    let y = common::luminance_of_samples(&m);
    (y.mean, y.se, m)
}

/// What the page verified: every colour, drawn by the page's shader with
/// noisy-bit dithering, read back, emitted by the simulated display and
/// measured by the simulated PR-650, is within ΔE00 1 of what the
/// experiment intended; the approximations that share the original's
/// 8-bit codes are distinct *means* with dithering, their measured
/// differences from the original as the profile predicts; and the test
/// patch at code 127.30 on every gun lies between the 127 and 128 levels
/// where the profile predicts (Allard & Faubert 2008).
async fn verified_on_the_simulated_display(d: &Daemon, id: i64, profile_id: i64) {
    let (s, vs) = get_json(d.addr, &format!("/api/experiments/{id}/verifications")).await;
    assert_eq!(s, 200, "{vs}");
    let v = &vs[0];
    assert_eq!(v["passed"], true, "{v}");
    let colours = v["colours"].as_array().unwrap();
    // Original, 4 approximations and the background full-field; all but the background in the pie.
    assert_eq!(colours.len(), 11, "{v}");
    for c in colours {
        let de = c["delta_e00_emitted"].as_f64().unwrap();
        assert!(de <= 1.0, "{c}");
        assert_eq!(c["booth_xyz"].is_null(), c["colour"] == "background", "{c}");
    }
    let (_, e) = get_json(d.addr, &format!("/api/experiments/{id}")).await;
    let full = |name: &str| {
        colours
            .iter()
            .find(|c| c["colour"] == name && c["geometry"] == "full_field")
            .unwrap_or_else(|| panic!("{name} full field in {v}"))
            .clone()
    };
    let original = full("original");
    let (y_o, se_o, _) = luminance_and_se(d, original["measurement_id"].as_i64().unwrap()).await;
    let mut shared = 0;
    for a in e["check"]["approximations"].as_array().unwrap() {
        let name = a["name"].as_str().unwrap();
        let c = full(name);
        let (y_a, se_a, _) = luminance_and_se(d, c["measurement_id"].as_i64().unwrap()).await;
        let predicted = c["predicted_xyz"][1].as_f64().unwrap() - original["predicted_xyz"][1].as_f64().unwrap();
        let measured = y_a - y_o;
        let se = (se_a * se_a + se_o * se_o).sqrt();
        eprintln!(
            "{name}: 8-bit codes {} (original {}), ΔY predicted {predicted:+.4}, measured {measured:+.4} ± {se:.4} cd/m²",
            a["codes_8bit"], e["check"]["original"]["codes_8bit"]
        );
        assert!(
            (measured - predicted).abs() <= 4.0 * se + 1e-3 * y_o,
            "{name}: the measured difference from the original, {measured} cd/m², is not the predicted {predicted} (SE {se})"
        );
        if a["distinct_at_8bit"] == false && a["distinct"] == true {
            shared += 1;
        }
    }
    eprintln!("{shared} approximation(s) share the original's 8-bit codes and are distinct with dithering");

    // The test patches, measured after the verification: codes 127, 128
    // and 127.30 on every gun. Dithered, 127.30 shows code 128 on 30 % of
    // pixels and frames, so its mean is 30 % of the way from the 127 level
    // to the 128 level (the display is additive; the profile's prediction
    // of a dithered mean, `mean_dithered_output`, is this interpolation).
    let last = colours
        .iter()
        .map(|c| c["measurement_id"].as_i64().unwrap())
        .max()
        .unwrap();
    let mut levels = Vec::new();
    for (k, code) in ["127.00", "128.00", "127.30"].iter().enumerate() {
        let (y, se, m) = luminance_and_se(d, last + 1 + k as i64).await;
        assert!(
            m["note"]
                .as_str()
                .unwrap()
                .starts_with(&format!("test patch: code {code}")),
            "{m}"
        );
        levels.push((y, se));
    }
    let [(y127, se127), (y128, se128), (y, se)] = [levels[0], levels[1], levels[2]];
    let gap = y128 - y127;
    let fraction = (y - y127) / gap;
    // First-order propagation of the three SEs.
    let se_fraction =
        ((se * se + (1.0 - fraction).powi(2) * se127 * se127 + fraction.powi(2) * se128 * se128).sqrt()) / gap;
    let (_, p) = get_json(d.addr, &format!("/api/display-profiles/{profile_id}")).await;
    let profile: lightbooth::display::DisplayProfile = serde_json::from_value(p["profile"].clone()).unwrap();
    let predicted = {
        let t = |v: f64| lightbooth::display::output::mean_dithered_output(&profile, 1, v / 255.0);
        (t(127.3) - t(127.0)) / (t(128.0) - t(127.0))
    };
    eprintln!(
        "test patches: 127 → {y127:.4} ± {se127:.4}, 128 → {y128:.4} ± {se128:.4}, 127.30 → {y:.4} ± {se:.4} cd/m²: \
         {fraction:.3} ± {se_fraction:.3} of the way (the profile predicts {predicted:.3})"
    );
    assert!(
        gap > 6.0 * (se127 * se127 + se128 * se128).sqrt(),
        "the two levels are told apart"
    );
    assert!((predicted - 0.3).abs() < 1e-9, "{predicted}");
    assert!(
        (fraction - predicted).abs() <= 4.0 * se_fraction && se_fraction < 0.1,
        "127.30 dithered lies {fraction} ± {se_fraction} of the way from 127 to 128, not {predicted}"
    );
}

/// `observer_id`'s whole session of experiment `id` through the API, each
/// trial answered by `observer` seeing the ΔE00 shown of each approximation
/// (`shown`: name, ΔE00); the last session view.
pub(crate) async fn run_simulated_session(
    d: &Daemon,
    id: i64,
    observer_id: &str,
    shown: &[(String, f64)],
    observer: &SimulatedObserver,
    rng: &mut SplitMix64,
) -> Value {
    let (s, mut view) = post_json(
        d.addr,
        &format!("/api/experiments/{id}/sessions"),
        TOKEN,
        &json!({ "observer": observer_id }).to_string(),
    )
    .await;
    assert_eq!(s, 200, "{view}");
    let sid = view["session"]["id"].as_i64().unwrap();
    report_display(d, sid).await;
    while let Some(next) = view["next"].as_object().cloned() {
        let name = next["approximation"].as_str().unwrap();
        let de = shown.iter().find(|(n, _)| n == name).unwrap().1;
        let response = observer.respond(
            configuration(next["configuration"].as_str().unwrap()),
            de / observer.sigma(),
            rng,
        );
        let body = trial(next["position"].as_u64().unwrap(), response as u8);
        let path = format!("/api/experiment-sessions/{sid}/trials");
        let (mut s, mut v) = post_json(d.addr, &path, TOKEN, &body.to_string()).await;
        // A busy daemon (other tests' renders on two cores) may ask to come back later.
        for _ in 0..20 {
            if s != 429 && s != 503 {
                break;
            }
            tokio::time::sleep(Duration::from_millis(250)).await;
            (s, v) = post_json(d.addr, &path, TOKEN, &body.to_string()).await;
        }
        assert_eq!(s, 200, "trial {}: {v}", next["position"]);
        view = v;
    }
    view
}

/// The refresh [`report_display`] reports, ms a frame.
pub(crate) const FRAME_MS: f64 = 16.7;

/// Reports the session page's measured refresh ([`FRAME_MS`]), as the page
/// does before its first trial.
pub(crate) async fn report_display(d: &Daemon, session: i64) {
    let (s, v) = post_json(
        d.addr,
        &format!("/api/experiment-sessions/{session}/display"),
        TOKEN,
        &json!({ "frame_ms": FRAME_MS, "client": "test" }).to_string(),
    )
    .await;
    assert_eq!(s, 200, "{v}");
}

/// A trial as the page reports it at [`FRAME_MS`] with the study's
/// presentation (the cross's 60 frames, the pie's 18, then the key), no
/// frame dropped.
pub(crate) fn trial(position: u64, response: u8) -> Value {
    json!({
        "position": position, "response": response, "reaction_ms": 600.0, "stimulus_frames": 18,
        "dropped_frames": 0, "dropped_in_stimulus": false, "frame_intervals_ms": vec![FRAME_MS; 100],
    })
}

/// Each approximation's name and the ΔE00 the display shows it at.
pub(crate) fn shown_delta_e00(experiment: &Value) -> Vec<(String, f64)> {
    experiment["check"]["approximations"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            (
                c["name"].as_str().unwrap().to_string(),
                c["delta_e00_shown"].as_f64().unwrap(),
            )
        })
        .collect()
}

fn configuration(letters: &str) -> Configuration {
    let mut c = [Stimulus::Original; 3];
    for (i, l) in letters.chars().enumerate() {
        if l == 'N' {
            c[i] = Stimulus::Approximation;
        }
    }
    Configuration(c)
}

/// Four simulated observers of σ = 0.25 ΔE00 answer every trial of the
/// study's design (36 per approximation) through the API alone: the pooled
/// d′ of each approximation recovers its true d′ = ΔE00 shown / σ within
/// the interval, and N = 3 is found every time while an approximation the
/// display cannot show apart stays near chance.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn simulated_observers_through_the_api_recover_their_true_d_prime() {
    let d = Daemon::start(0.0).await;
    let (profile, measurement) = calibrated_booth(&d).await;
    let e = create(
        &d,
        json!({
            "measurement_id": measurement, "display_profile_id": profile,
            "approximations": ["nstep3", "nstep9", "nstep27", "nstep81"], "output": "noisy_bit", "seed": 9,
        }),
    )
    .await;
    let id = e["id"].as_i64().unwrap();
    let shown = shown_delta_e00(&e);
    let sigma = 0.25;
    let observer = SimulatedObserver::new(sigma, OddityModel::Differencing).unwrap();
    let mut rng = SplitMix64(77);
    for o in 0..4 {
        let view = run_simulated_session(&d, id, &format!("sim{o}"), &shown, &observer, &mut rng).await;
        assert_eq!(view["trials_recorded"], 144);
    }
    let (s, a) = get_json(d.addr, &format!("/api/experiments/{id}/analysis")).await;
    assert_eq!(s, 200, "{a}");
    let (s, csv) = common::request(
        d.addr,
        "GET",
        &format!("/api/experiments/{id}/analysis.csv"),
        None,
        None,
    )
    .await;
    assert_eq!(s, 200);
    let csv = String::from_utf8(csv).unwrap();
    assert_eq!(csv.lines().count(), 1 + 4 * 5, "{csv}");
    // The MAT-file, read by the `matfile` crate: the CSV's rows, the JSON's numbers.
    let (s, mat) = common::request(
        d.addr,
        "GET",
        &format!("/api/experiments/{id}/analysis.mat"),
        None,
        None,
    )
    .await;
    assert_eq!(s, 200);
    let parsed = matfile::MatFile::parse(mat.as_slice()).expect("a MAT-file MATLAB can load");
    let pc = parsed.find_by_name("proportion_correct").expect("proportion_correct");
    assert_eq!(pc.size(), &vec![4 * 5, 1]);
    let matfile::NumericData::Double { real, .. } = pc.data() else {
        panic!("proportion_correct is not double")
    };
    for (r, v) in a["rows"].as_array().unwrap().iter().zip(real) {
        assert_eq!(r["differencing"]["proportion_correct"].as_f64().unwrap(), *v);
    }
    let (s, svg) = common::request(
        d.addr,
        "GET",
        &format!("/api/experiments/figure.svg?ids={id}"),
        None,
        None,
    )
    .await;
    assert_eq!(s, 200);
    let svg = String::from_utf8(svg).unwrap();
    assert!(
        svg.contains("chance 33 %") && svg.contains("nstep81"),
        "the figure marks chance and names each bar"
    );
    d.stop().await;
    for row in a["rows"].as_array().unwrap().iter().filter(|r| r["observer"] == "all") {
        let name = row["approximation"].as_str().unwrap();
        let de = shown.iter().find(|(n, _)| n == name).unwrap().1;
        let truth = (de / sigma).min(lightbooth::psychophysics::oddity::MAX_D_PRIME);
        let dp = &row["differencing"];
        let (lo, hi) = (
            dp["d_prime_interval"][0].as_f64().unwrap(),
            dp["d_prime_interval"][1].as_f64().unwrap(),
        );
        eprintln!(
            "{name}: ΔE00 {de:.3}, true d′ {truth:.2}, {}/{} correct, d′ {:.2} [{lo:.2}, {hi:.2}]",
            row["correct"], row["trials"], dp["d_prime"]
        );
        assert_eq!(row["trials"], 144);
        // 144 trials: the 95 % interval covers the truth (a 1-in-20 miss per
        // approximation would be seen; the seed is fixed, so this is pinned).
        assert!(
            lo <= truth && truth <= hi,
            "{name}: true d′ {truth} outside [{lo}, {hi}]"
        );
    }
}
