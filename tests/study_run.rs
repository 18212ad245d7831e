//! The study runner on real scenes: against the converged reference and
//! against measurements taken with the simulated PR-650, with its report.

use std::path::PathBuf;

use lightbooth::render::Coding;
use lightbooth::store::Store;
use lightbooth::study::measure::measure_with_simulator;
use lightbooth::study::report::write_report;
use lightbooth::study::run::{run_study, Against, StudyOptions};

fn scene(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(format!("{name}.toml"))
}

fn quick(against: Against) -> StudyOptions {
    StudyOptions {
        codings: vec![Coding::Rgb, Coding::NStep(3), Coding::NStep(81), Coding::Spectral],
        seeds: 3,
        samples: 1024,
        target_relative_se: Some(0.01),
        against,
        ..StudyOptions::default()
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn against_the_reference_spectral_agrees_and_three_steps_do_not() {
    let result = run_study(&[scene("red")], &quick(Against::Reference), None, &|_| {})
        .await
        .unwrap();
    let s = &result.scenes[0];
    assert_eq!(s.white_source, "reference render (white/patch)");
    let get = |c: &str| s.codings.iter().find(|x| x.coding == c).unwrap();
    let (spectral, nstep3, nstep81) = (get("spectral"), get("nstep3"), get("nstep81"));
    assert_eq!(spectral.per_seed.len(), 3);
    // Spectral differs from the converged reference only by noise: its
    // luminance error is within 4 of its own reported relative SEs, and it
    // differs significantly at no target.
    let rel_se = spectral.profile[0].Y_se / spectral.profile[0].Y.mean;
    assert!(
        spectral.rms_rel.mean < 4.0 * rel_se + 4.0 * spectral.rms_rel.sd,
        "{:?} vs SE {rel_se}",
        spectral.rms_rel
    );
    assert_eq!(
        spectral.significant_targets, 0,
        "{:?} vs truth {:?}",
        spectral.profile, s.truth
    );
    // The study's finding on the saturated red patch: three bands are far
    // off (ΔE*ab beyond the discrimination threshold of 2), 81 bands are not.
    assert!(
        nstep3.mean_dE76.mean > 2.0 + 3.0 * nstep3.mean_dE76.sd,
        "{:?}",
        nstep3.mean_dE76
    );
    assert!(
        nstep81.mean_dE76.mean < nstep3.mean_dE76.mean / 5.0,
        "{:?}",
        nstep81.mean_dE76
    );
    // Every seed is a different render.
    assert!(nstep3.per_seed[0].rms_rel != nstep3.per_seed[1].rms_rel);

    let dir = tempfile::tempdir().unwrap();
    write_report(&result, dir.path()).unwrap();
    let html = std::fs::read_to_string(dir.path().join("index.html")).unwrap();
    assert!(html.contains("<svg") && html.contains("nstep3"));
    let figures = std::fs::read_to_string(dir.path().join("figures.csv")).unwrap();
    assert_eq!(figures.lines().count(), 1 + 4 * 3, "one row per coding and seed");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn against_simulated_measurements_the_truth_is_the_stored_measurement() {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::open(&format!("sqlite://{}", dir.path().join("s.sqlite").display()))
        .await
        .unwrap();
    let cache = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("converged-cache");
    let ids = measure_with_simulator(&[scene("white")], &store, &cache, 1, &|_| {})
        .await
        .unwrap();
    assert_eq!(ids.len(), 1);
    let m = store.get_measurement(ids[0]).await.unwrap().unwrap();
    assert_eq!(m.samples.len(), 5);
    let result = run_study(&[scene("white")], &quick(Against::Measurements), Some(&store), &|_| {})
        .await
        .unwrap();
    let s = &result.scenes[0];
    assert_eq!(s.truth[0].source, format!("measurement {}", ids[0]));
    assert_eq!(s.white_source, format!("measurement {} (white/patch)", ids[0]));
    // The measurement's SE comes from its five samples.
    assert!(s.truth[0].Y_se > 0.0);
    // The simulated instrument (8 nm slit, noise) sees the converged spectral
    // radiance: spectral rendering and measurement agree within a few percent.
    let spectral = s.codings.iter().find(|c| c.coding == "spectral").unwrap();
    assert!(spectral.rms_rel.mean < 0.03, "{:?}", spectral.rms_rel);

    // Without measurements the study says what to do.
    let err = run_study(&[scene("red")], &quick(Against::Measurements), Some(&store), &|_| {})
        .await
        .unwrap_err();
    assert!(
        err.to_string().contains("no complete measurement of red/patch"),
        "{err}"
    );
}
