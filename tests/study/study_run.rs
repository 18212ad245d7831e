//! The study runner on real scenes: against the converged reference and
//! against measurements taken with the simulated PR-650, with its report.

use std::path::PathBuf;

use lightbooth::colorimetry::Observer;
use lightbooth::lab::study::measure::{measure_with_simulator, SimulatedPr650};
use lightbooth::lab::study::report::write_report;
use lightbooth::lab::study::run::{progress_fractions, progress_steps, run_study, Against, StudyOptions};
use lightbooth::render::Coding;
use lightbooth::store::Store;

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

/// Regression (issue 46): a study's steps counted as equal, so a study of
/// four one-target scenes then CYLINDER (21 targets) was 5/6 done when
/// CYLINDER began and said "about 0 s" left at 14 s of a 31 s run. Each
/// scene's steps weigh its targets: CYLINDER begins at 12/80 of the work;
/// the failure maps weigh the mean step; the fractions only grow, one per
/// progress call.
#[test]
fn a_studys_fraction_done_weighs_each_scene_by_its_targets() {
    let options = StudyOptions {
        seeds: 2,
        failure_map: true,
        ..quick(Against::Measurements)
    };
    let targets = [1, 1, 1, 1, 21];
    let f = progress_fractions(&targets, &options);
    assert_eq!(f.len(), progress_steps(targets.len(), &options));
    let per_scene = 1 + 2;
    let cylinder_begins = f[4 * per_scene];
    // Four scenes of three steps weighing 1, of 12 + 3 × 21 + 5 = 80.
    assert!((cylinder_begins - 12.0 / 80.0).abs() < 1e-12, "{f:?}");
    assert!(f.windows(2).all(|w| w[0] < w[1]), "{f:?}");
    assert_eq!(f[0], 0.0);
    // The failure maps, last, weigh (3 × 4 + 3 × 21) / 15 = 5 of 80.
    assert!((f.last().unwrap() - 75.0 / 80.0).abs() < 1e-12, "{f:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn against_the_reference_spectral_agrees_and_three_steps_do_not() {
    // Counts its progress reports: the dashboard's fraction done is the
    // k-th report over `progress_steps`, so the two must agree.
    let reports = std::sync::Mutex::new(Vec::new());
    let options = quick(Against::Reference);
    let result = run_study(
        &[scene("red")],
        &options,
        None,
        &|m| reports.lock().unwrap().push(m.to_string()),
        None,
    )
    .await
    .unwrap();
    let reports = reports.into_inner().unwrap();
    assert_eq!(reports.len(), progress_steps(1, &options), "{reports:?}");
    assert_eq!(reports.len(), 1 + 3, "the truth and three seeds: {reports:?}");
    let s = &result.scenes[0];
    assert_eq!(s.white_source, "reference render (white/patch)");
    assert_eq!(result.observer, Observer::JuddVos);
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
    // Its own (empty) icon: a browser opening the report asks for no
    // /favicon.ico, whose 404 was the report's only console error.
    assert!(html.contains(r#"<link rel="icon" href="data:,">"#));
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
    let ids = measure_with_simulator(
        &[scene("white")],
        &store,
        &Default::default(),
        &cache,
        SimulatedPr650 { seed: 1, speed: 0.0 },
        Observer::JuddVos,
        None,
        &|_| {},
    )
    .await
    .unwrap();
    assert_eq!(ids.len(), 1);
    let m = store.get_measurement(ids[0]).await.unwrap().unwrap();
    assert_eq!(m.samples.len(), 5);
    let result = run_study(
        &[scene("white")],
        &quick(Against::Measurements),
        Some(&store),
        &|_| {},
        None,
    )
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
    let err = run_study(
        &[scene("red")],
        &quick(Against::Measurements),
        Some(&store),
        &|_| {},
        None,
    )
    .await
    .unwrap_err();
    assert!(
        err.to_string().contains("no complete measurement of red/patch"),
        "{err}"
    );
}

/// Every figure of a study names its observer, and the observer is really
/// used: the same scene under CIE 1931 gives other XYZ than under Judd–Vos
/// (renderings and truth alike), and the JSON says `cie-1931`.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn study_json_names_the_observer_it_computed_with() {
    let jv = run_study(&[scene("blue")], &quick(Against::Reference), None, &|_| {}, None)
        .await
        .unwrap();
    let options = StudyOptions {
        observer: Observer::Cie1931,
        ..quick(Against::Reference)
    };
    let c31 = run_study(&[scene("blue")], &options, None, &|_| {}, None)
        .await
        .unwrap();
    let json = serde_json::to_value(&c31).unwrap();
    assert_eq!(json["observer"], "cie-1931");
    assert_eq!(json["options"]["observer"], "cie-1931");
    assert_eq!(json["scenes"][0]["observer"], "cie-1931");
    assert_eq!(serde_json::to_value(&jv).unwrap()["observer"], "judd-vos-1978");
    let (a, b) = (&jv.scenes[0].truth[0], &c31.scenes[0].truth[0]);
    // Judd–Vos raised the 1931 ȳ below 460 nm: a blue patch moves most.
    let d = (a.x - b.x).hypot(a.y - b.y);
    assert!(d > 1e-3, "Judd–Vos ({}, {}) vs CIE 1931 ({}, {})", a.x, a.y, b.x, b.y);
    // Within one observer, spectral still agrees with the truth.
    let spectral = c31.scenes[0].codings.iter().find(|c| c.coding == "spectral").unwrap();
    assert_eq!(spectral.significant_targets, 0, "{:?}", spectral.profile);
}

/// The truth was the first paths of the comparison render (same seed, same
/// bounce cap), so `spectral` agreed by construction and a modelling error
/// could not show. With a truth scene the booth differs from the model (here
/// the WHITE scene's lamp 3150 K instead of 3200 K): `spectral` now differs
/// from the truth beyond noise and by about the ΔE the lamp change makes,
/// while against the model's own truth it does not.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn simulated_truth_is_independent_of_the_compared_render() {
    let model = scene("white");
    let scenes_dir = model.parent().unwrap().display().to_string();
    let text = std::fs::read_to_string(&model)
        .unwrap()
        .replace("blackbody_k = 3200", "blackbody_k = 3150")
        .replace("\"luminaires/", &format!("\"{scenes_dir}/luminaires/"))
        .replace("\"spectra/", &format!("\"{scenes_dir}/spectra/"));
    let truth_dir = tempfile::tempdir().unwrap();
    std::fs::write(truth_dir.path().join("white.toml"), text).unwrap();
    let perfect = run_study(
        std::slice::from_ref(&model),
        &quick(Against::Reference),
        None,
        &|_| {},
        None,
    )
    .await
    .unwrap();
    let options = StudyOptions {
        truth_scene: Some(truth_dir.path().to_path_buf()),
        ..quick(Against::Reference)
    };
    let perturbed = run_study(&[model], &options, None, &|_| {}, None).await.unwrap();
    assert_eq!(
        perturbed.scenes[0].truth[0].scene_file,
        truth_dir.path().join("white.toml").display().to_string()
    );
    let spectral = |r: &lightbooth::lab::study::run::StudyResult| {
        r.scenes[0]
            .codings
            .iter()
            .find(|c| c.coding == "spectral")
            .unwrap()
            .clone()
    };
    let (p, q) = (spectral(&perfect), spectral(&perturbed));
    assert_eq!(p.significant_targets, 0, "{:?}", p.profile);
    // 50 K cooler at ~3200 K moves the white patch's chromaticity: ΔE*ab of
    // order 1, far above the perfect model's ~0.1 noise floor.
    assert!(q.mean_dE76.mean > 0.5, "{:?}", q.mean_dE76);
    assert!(
        q.mean_dE76.mean > 5.0 * p.mean_dE76.mean,
        "{:?} vs {:?}",
        q.mean_dE76,
        p.mean_dE76
    );
}

/// The Cornell box goes through the study like a booth scene: every target
/// is compared with the converged reference in every coding, its CIELAB
/// white is the back wall its file declares, and the light target — pure
/// emission, no transport — agrees exactly in the codings that reproduce a
/// light (spectral, rgb).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_cornell_box_runs_through_the_study() {
    let options = StudyOptions {
        seeds: 2,
        ..quick(Against::Reference)
    };
    let result = run_study(&[scene("cornell_box")], &options, None, &|_| {}, None)
        .await
        .unwrap();
    let s = &result.scenes[0];
    assert_eq!(s.targets.len(), 9);
    assert_eq!(s.white_source, "reference render (cornell_box/back_wall)");
    let light = s.targets.iter().position(|t| t == "light").unwrap();
    let truth_y = s.truth[light].XYZ[1];
    for c in &s.codings {
        assert_eq!(c.profile.len(), 9, "{}", c.coding);
        let y = c.profile[light].Y.mean;
        if c.coding == "spectral" || c.coding == "rgb" {
            assert!((y / truth_y - 1.0).abs() < 1e-5, "{}: {y} vs {truth_y}", c.coding);
        }
    }
}

/// Issue 32: the study report wrote a scene's name from its file into
/// `index.html` as markup. A scene named with a script is shown as text, in
/// the page and in its charts.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_scene_name_with_markup_is_text_in_the_study_report() {
    let scenes = tempfile::tempdir().unwrap();
    let source = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes");
    for folder in ["spectra", "luminaires"] {
        std::os::unix::fs::symlink(source.join(folder), scenes.path().join(folder)).unwrap();
    }
    let payload = r#"<img src=x onerror="alert(1)"> & 'white'"#;
    let toml = std::fs::read_to_string(source.join("white.toml"))
        .unwrap()
        .replace(r#"name = "WHITE""#, &format!("name = {payload:?}"));
    assert!(toml.contains("onerror"), "the scene's name line moved");
    let file = scenes.path().join("white.toml");
    std::fs::write(&file, toml).unwrap();
    let options = StudyOptions {
        codings: vec![Coding::Rgb, Coding::Spectral],
        seeds: 1,
        samples: 256,
        target_relative_se: None,
        against: Against::Reference,
        ..StudyOptions::default()
    };
    let result = run_study(&[file], &options, None, &|_| {}, None).await.unwrap();
    let dir = tempfile::tempdir().unwrap();
    write_report(&result, dir.path()).unwrap();
    let html = std::fs::read_to_string(dir.path().join("index.html")).unwrap();
    assert!(!html.contains("<img"), "the scene's name is markup in the report");
    assert!(
        html.contains("&lt;img src=x onerror=&quot;alert(1)&quot;&gt; &amp; &#39;white&#39;"),
        "the scene's name is not shown as text"
    );
}

/// The bug (issue 46): the study filed its simulated PR-650 under the
/// default booth (`Booth::default()` in `measure_with_simulator`) while its
/// measurements went to `--booth`, and the instruments table's `ON
/// CONFLICT` then moved an instrument already seen in another booth. The
/// instrument is recorded in the booth it measures in.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_study_filed_its_simulated_instrument_under_the_default_booth() {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::open(&format!("sqlite://{}", dir.path().join("s.sqlite").display()))
        .await
        .unwrap();
    let cache = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("converged-cache");
    let north: lightbooth::store::Booth = "north".parse().unwrap();
    let ids = measure_with_simulator(
        &[scene("white")],
        &store,
        &north,
        &cache,
        SimulatedPr650 { seed: 1, speed: 0.0 },
        Observer::JuddVos,
        None,
        &|_| {},
    )
    .await
    .unwrap();
    let m = store.get_measurement(ids[0]).await.unwrap().unwrap();
    let instruments = store.list_instruments().await.unwrap();
    assert_eq!(instruments.len(), 1, "{instruments:?}");
    assert_eq!(instruments[0].booth, "north", "{instruments:?}");
    assert_eq!(m.summary.booth, "north");
}

/// The study job's token reaches the study's own renders (it was a
/// thread-local the study never saw as an argument): cancelled when the
/// first seed begins, after the truth was rendered, the study ends with the
/// render's cancelled error instead of rendering every seed.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_study_whose_token_is_cancelled_stops_at_its_next_render() {
    use lightbooth::lab::study::run::StudyError;
    use lightbooth::render::RenderError;
    let token = tokio_util::sync::CancellationToken::new();
    let seeds_begun = std::sync::atomic::AtomicUsize::new(0);
    let progress = |message: &str| {
        if message.contains("seed") {
            seeds_begun.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            token.cancel();
        }
    };
    let err = run_study(
        &[scene("blue")],
        &quick(Against::Reference),
        None,
        &progress,
        Some(&token),
    )
    .await
    .unwrap_err();
    assert!(matches!(err, StudyError::Render(RenderError::Cancelled)), "{err}");
    assert_eq!(
        seeds_begun.load(std::sync::atomic::Ordering::Relaxed),
        1,
        "no seed after the cancel"
    );
}
