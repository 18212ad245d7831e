//! The cost of a render setting (a coding alone, a sample count, a bounce
//! cap), measured as wall time in a way that does not favour whichever is
//! timed later.
//!
//! Every coding of a render traces the same rays (the same paths), so rays
//! cannot tell codings apart; they differ in the arithmetic per ray. Wall
//! time does, but timed once each in a fixed order the first one pays the
//! process's warm-up (page faults, the thread pool, caches): on CYLINDER the
//! first-timed `rgb` took 0.97 s against 0.47–0.64 s for the rest. So
//! [`time_renders`] renders the first setting once untimed (the warm-up),
//! then times every setting [`TIMING_REPEATS`] times, each round in a
//! rotated order (round r starts at setting r·n/R), and reports the median
//! with the fastest and slowest: [`TIMING_METHOD`] says so on the charts.

use tokio_util::sync::CancellationToken;

use super::{render, RenderError, RenderResult, RenderSettings, Scene};

/// Timed repeats of every setting.
pub const TIMING_REPEATS: usize = 3;

/// How [`time_renders`] measures, for the charts' axis and the JSON.
pub const TIMING_METHOD: &str =
    "wall time: median of 3 repeats in rotated order after a warm-up render (whiskers: fastest–slowest)";

/// [`TIMING_METHOD`] short enough for a chart's axis title (about 60
/// characters fit under a plot; the long form overflowed the chart on both
/// sides): the rotation and the warm-up are in the JSON and the manual.
pub const TIMING_AXIS: &str = "median of 3 repeats, whiskers fastest–slowest";

/// One setting's timing and its (last) result.
#[derive(Clone, Debug)]
pub struct TimedRender {
    pub result: RenderResult,
    /// The repeats' wall times, s, in the order they ran.
    pub seconds: Vec<f64>,
    /// Its place in each round (0: timed first, right after the warm-up
    /// or the previous round).
    pub places: Vec<usize>,
}

impl TimedRender {
    /// The median wall time, s.
    pub fn median_seconds(&self) -> f64 {
        median(&self.seconds)
    }

    pub fn fastest_seconds(&self) -> f64 {
        self.seconds.iter().copied().fold(f64::INFINITY, f64::min)
    }

    pub fn slowest_seconds(&self) -> f64 {
        self.seconds.iter().copied().fold(0.0, f64::max)
    }

    /// `{"wall_seconds": median, "wall_seconds_min", "wall_seconds_max",
    /// "timing_repeats", "paths", "rays"}`: a setting's cost in the JSON.
    pub fn cost_json(&self) -> serde_json::Value {
        serde_json::json!({
            "wall_seconds": self.median_seconds(),
            "wall_seconds_min": self.fastest_seconds(),
            "wall_seconds_max": self.slowest_seconds(),
            "timing_repeats": self.seconds.len(),
            "paths": self.result.paths,
            "paths_per_target": self.result.paths / self.result.targets.len().max(1) as u64,
            "rays": self.result.rays,
        })
    }
}

/// The median of `v` (the mean of the middle two for an even count); NaN
/// for none.
pub fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    match s.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => s[n / 2],
        n => 0.5 * (s[n / 2 - 1] + s[n / 2]),
    }
}

/// The order of round `round` of `repeats` over `n` settings: rotated so
/// each round starts elsewhere and no setting is always first.
pub fn rotated_order(n: usize, round: usize, repeats: usize) -> impl Iterator<Item = usize> {
    let start = if n == 0 { 0 } else { (round * n / repeats.max(1)) % n };
    (0..n).map(move |i| (start + i) % n)
}

/// Renders each of `settings` `repeats` times in rotated order after one
/// untimed warm-up render of the first, and returns each one's wall times
/// (see the module). Results are deterministic, so the last one is kept.
/// `cancel` stops every render as in [`render`](super::render).
pub fn time_renders(
    scene: &Scene,
    settings: &[RenderSettings],
    repeats: usize,
    cancel: Option<&CancellationToken>,
) -> Result<Vec<TimedRender>, RenderError> {
    time_renders_reporting(scene, settings, repeats, &|_, _| {}, cancel)
}

/// [`time_renders`], calling `progress(done, total)` before the first
/// render and after each (the warm-up counted: `total` is 1 + repeats ×
/// settings).
pub fn time_renders_reporting(
    scene: &Scene,
    settings: &[RenderSettings],
    repeats: usize,
    progress: &(dyn Fn(u64, u64) + Sync),
    cancel: Option<&CancellationToken>,
) -> Result<Vec<TimedRender>, RenderError> {
    let repeats = repeats.max(1);
    let total = if settings.is_empty() {
        0
    } else {
        1 + (repeats * settings.len()) as u64
    };
    let mut done = 0u64;
    progress(done, total);
    if let Some(first) = settings.first() {
        render(scene, first, None, cancel)?;
        done += 1;
        progress(done, total);
    }
    let mut seconds: Vec<Vec<f64>> = vec![Vec::with_capacity(repeats); settings.len()];
    let mut places: Vec<Vec<usize>> = vec![Vec::with_capacity(repeats); settings.len()];
    let mut results: Vec<Option<RenderResult>> = vec![None; settings.len()];
    for round in 0..repeats {
        for (place, i) in rotated_order(settings.len(), round, repeats).enumerate() {
            let r = render(scene, &settings[i], None, cancel)?;
            seconds[i].push(r.wall_seconds);
            places[i].push(place);
            results[i] = Some(r);
            done += 1;
            progress(done, total);
        }
    }
    Ok(results
        .into_iter()
        .zip(seconds)
        .zip(places)
        .map(|((r, seconds), places)| TimedRender {
            result: r.expect("rendered at least once"),
            seconds,
            places,
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(&[]).is_nan());
    }

    /// Every setting is first in some round when there are at least as many
    /// rounds as settings, and each round visits every setting once.
    #[test]
    fn rotated_rounds_visit_every_setting_and_change_the_first() {
        for (n, repeats) in [(7, 3), (3, 3), (1, 3), (32, 3)] {
            let mut firsts = Vec::new();
            for round in 0..repeats {
                let mut order: Vec<usize> = rotated_order(n, round, repeats).collect();
                firsts.push(order[0]);
                order.sort();
                assert_eq!(order, (0..n).collect::<Vec<_>>());
            }
            firsts.dedup();
            assert_eq!(
                firsts.len(),
                repeats.min(n),
                "{n} settings, {repeats} rounds: {firsts:?}"
            );
        }
    }
}
