//! Speed against accuracy: the candidate settings timed and compared,
//! their Pareto front, and its chart.

use super::*;

/// The indices of the non-dominated points of (seconds, error), fastest
/// first: a point is dominated when another is no slower and no worse and
/// better in one. Points with a NaN are never on the front.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let ok = |p: &(f64, f64)| !p.0.is_nan() && !p.1.is_nan();
    let mut front: Vec<usize> = (0..points.len())
        .filter(|&i| {
            let p = points[i];
            ok(&p)
                && !points
                    .iter()
                    .any(|q| ok(q) && q.0 <= p.0 && q.1 <= p.1 && (q.0 < p.0 || q.1 < p.1))
        })
        .collect();
    front.sort_by(|&a, &b| {
        points[a]
            .0
            .total_cmp(&points[b].0)
            .then(points[a].1.total_cmp(&points[b].1))
    });
    front
}

/// One point of the speed/accuracy chart.
#[derive(Clone, Debug, Serialize)]
pub struct Candidate {
    pub label: String,
    #[serde(serialize_with = "coding_name")]
    pub coding: Coding,
    pub bounces: u32,
    pub samples: u64,
    /// The fastest of the timed repeats, s.
    pub wall_seconds: f64,
    pub rms_rel: f64,
    pub max_de00: f64,
    /// The fraction of the tolerance used: max(rms_rel / tol, max ΔE00 / tol);
    /// ≤ 1 meets it.
    pub error: f64,
    /// The part of `error` that is noise: 2 × the noise rms_rel / tol.
    pub error_noise: f64,
    pub is_auto: bool,
    pub on_front: bool,
}

/// The relative difference in wall time below which two candidates count
/// as equally fast, whatever the spread of their repeats.
pub const TIMING_RESOLUTION: f64 = 0.05;

/// The candidate set of the speed/accuracy chart, its front and the chart.
#[derive(Clone, Debug, Serialize)]
pub struct CandidateSet {
    pub scene: String,
    pub candidates: Vec<Candidate>,
    /// Indices into `candidates`, fastest first.
    pub front: Vec<usize>,
    pub auto_index: usize,
    /// The largest spread of wall time between repeats of one candidate, or
    /// `TIMING_RESOLUTION` of its wall time if larger, s: the timing noise.
    pub timing_noise_seconds: f64,
    /// No candidate is faster by more than the timing noise *and* more
    /// accurate by more than the error noise than the automatic choice.
    pub auto_on_front_within_noise: bool,
    #[serde(skip)]
    pub svg: String,
}

/// Renders the chart's alternatives — `nstep3`, `nstep9`, `nstep27`,
/// `nstep81`, `spectral`, `rgb`, `srgb` at each of `bounces`, plus the
/// automatic choice — each alone, with the choice's sample count and seed,
/// timed as the fastest of `repeats` rounds over all of them, and compares each with
/// `reference`. Returns the points, the Pareto front of (seconds, error) and
/// an SVG chart with the front and the automatic point.
pub fn candidate_set(
    scene: &Scene,
    choice: &AutoChoice,
    reference: &RenderResult,
    bounces: &[u32],
    repeats: usize,
    cancel: Option<&CancellationToken>,
) -> Result<CandidateSet, AutoError> {
    let codings = [
        Coding::NStep(3),
        Coding::NStep(9),
        Coding::NStep(27),
        Coding::NStep(81),
        Coding::Spectral,
        Coding::Rgb,
        Coding::Srgb,
    ];
    let mut runs: Vec<(Coding, u32, bool)> = Vec::new();
    for &b in bounces {
        for &c in &codings {
            runs.push((c, b, c == choice.coding && b == choice.bounces));
        }
    }
    if !runs.iter().any(|r| r.2) {
        runs.push((choice.coding, choice.bounces, true));
    }
    let tol = choice.tolerance;
    let settings_of = |coding: Coding, b: u32| RenderSettings {
        codings: vec![coding],
        max_bounces: Some(b),
        ..choice.settings()
    };
    // The repeats go round-robin over the candidates (every candidate once,
    // then again), so a change in the machine's load between rounds shows as
    // spread between one candidate's repeats, the timing noise, instead of as
    // a difference between candidates timed back to back.
    let mut times: Vec<Vec<f64>> = vec![Vec::new(); runs.len()];
    let mut results: Vec<Option<RenderResult>> = vec![None; runs.len()];
    for _ in 0..repeats.max(1) {
        for (i, &(coding, b, _)) in runs.iter().enumerate() {
            let r = render(scene, &settings_of(coding, b), None, cancel)?;
            times[i].push(r.wall_seconds);
            results[i] = Some(r);
        }
    }
    let mut candidates = Vec::new();
    let mut timing_noise = 0.0f64;
    for (i, (coding, b, is_auto)) in runs.into_iter().enumerate() {
        let r = results[i].take().expect("at least one run");
        let fastest = times[i].iter().copied().fold(f64::INFINITY, f64::min);
        let slowest = times[i].iter().copied().fold(0.0, f64::max);
        // Approximation: wall times within TIMING_RESOLUTION of each other are
        // the same speed, even when the repeats happened to agree more
        // closely (on a shared machine they rarely mean more).
        timing_noise = timing_noise.max(slowest - fastest).max(TIMING_RESOLUTION * fastest);
        let (_, points, noise) = compare_with_reference(&r, reference)?;
        let s = summarize(&points);
        let max_de00 = points.iter().map(|p| p.de00).fold(0.0, f64::max);
        candidates.push(Candidate {
            label: format!("{coding} ab{b}{}", if is_auto { " (auto)" } else { "" }),
            coding,
            bounces: b,
            samples: settings_of(coding, b).samples,
            wall_seconds: fastest,
            rms_rel: s.rms_rel,
            max_de00,
            error: (s.rms_rel / tol.rms_rel).max(max_de00 / tol.de00),
            error_noise: 2.0 * noise / tol.rms_rel,
            is_auto,
            on_front: false,
        });
    }
    let pts: Vec<(f64, f64)> = candidates.iter().map(|c| (c.wall_seconds, c.error)).collect();
    let front = pareto_front(&pts);
    for &i in &front {
        candidates[i].on_front = true;
    }
    let auto_index = candidates.iter().position(|c| c.is_auto).expect("the auto run");
    let a = &candidates[auto_index];
    let auto_on_front_within_noise = !candidates.iter().any(|c| {
        c.wall_seconds < a.wall_seconds - timing_noise && c.error < a.error - a.error_noise.max(c.error_noise)
    });
    let svg = speed_accuracy_svg(&scene.name, &candidates, &front, auto_index)?;
    Ok(CandidateSet {
        scene: scene.name.clone(),
        candidates,
        front,
        auto_index,
        timing_noise_seconds: timing_noise,
        auto_on_front_within_noise,
        svg,
    })
}

/// The speed/accuracy chart: every candidate, the front as a line, the
/// automatic choice, and the tolerance (error = 1).
pub fn speed_accuracy_svg(
    scene: &str,
    candidates: &[Candidate],
    front: &[usize],
    auto_index: usize,
) -> Result<String, AutoError> {
    let pick = |f: &dyn Fn(&Candidate) -> bool| -> Vec<(f64, f64)> {
        candidates
            .iter()
            .filter(|c| f(c))
            .map(|c| (c.wall_seconds, c.error))
            .collect()
    };
    let mut series = vec![
        ScatterSeries {
            name: "candidates".into(),
            points: pick(&|c| !c.on_front),
            connect: false,
        },
        ScatterSeries {
            name: "Pareto front".into(),
            points: front
                .iter()
                .map(|&i| (candidates[i].wall_seconds, candidates[i].error))
                .collect(),
            connect: true,
        },
        ScatterSeries {
            name: format!("auto: {}", candidates[auto_index].label.replace(" (auto)", "")),
            points: vec![(candidates[auto_index].wall_seconds, candidates[auto_index].error)],
            connect: false,
        },
    ];
    let xs: Vec<f64> = candidates.iter().map(|c| c.wall_seconds).collect();
    let (lo, hi) = (
        xs.iter().copied().fold(f64::INFINITY, f64::min),
        xs.iter().copied().fold(0.0, f64::max),
    );
    series.push(ScatterSeries {
        name: "tolerance".into(),
        points: vec![(lo, 1.0), (hi, 1.0)],
        connect: true,
    });
    scatter_chart(
        &format!("{scene}: speed and accuracy"),
        "wall time (s, log scale)",
        "error / tolerance (log scale)",
        &series,
        (true, true),
    )
    .map_err(AutoError::Chart)
}
