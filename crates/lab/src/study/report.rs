//! The study's charts and a self-contained report (`--report DIR`): an HTML
//! page with every chart as inline SVG, the SVG files themselves, and CSV
//! files of every number, for a scientist to attach to a paper.

use std::fmt::Write as _;
use std::path::Path;

use super::run::{SceneStudy, StudyResult, SweepPoint};
use crate::charts::{self, Bar, LineSeriesData, ScatterSeries};

/// What a chart title says about the renders' bounce cap: nothing without
/// one, " — truncated at N bounces" with one (a bias beside the SE).
fn truncation_suffix(s: &SceneStudy) -> String {
    s.truncated_at_bounces
        .map(|b| format!(" — truncated at {b} bounces"))
        .unwrap_or_default()
}

/// The bounces of the study's renders in words, for the report.
fn bounces_text(cap: Option<u32>) -> String {
    match cap {
        None => format!(
            "no bounce cap (Russian roulette from bounce {}, unbiased)",
            lightbooth_render::DEFAULT_ROULETTE_FROM
        ),
        Some(b) => format!("<strong>{}</strong>", lightbooth_render::truncation_note(b)),
    }
}

/// Luminance along the targets per coding (mean over seeds ± 1 SD over
/// seeds) and the truth (± its SE).
pub fn profile_chart(s: &SceneStudy) -> Result<String, String> {
    let mut series = vec![LineSeriesData {
        name: format!("truth ({})", s.truth.first().map(|t| t.source.as_str()).unwrap_or("")),
        points: s
            .truth
            .iter()
            .enumerate()
            .map(|(i, t)| (i as f64 + 1.0, t.XYZ[1]))
            .collect(),
        errors: Some(s.truth.iter().map(|t| t.Y_se).collect()),
    }];
    for c in &s.codings {
        series.push(LineSeriesData {
            name: c.coding.clone(),
            points: c
                .profile
                .iter()
                .enumerate()
                .map(|(i, p)| (i as f64 + 1.0, p.Y.mean))
                .collect(),
            errors: Some(c.profile.iter().map(|p| p.Y.sd).collect()),
        });
    }
    charts::profile_chart(
        &format!(
            "{}: luminance along the targets (±1 SD over seeds){}",
            s.title,
            truncation_suffix(s)
        ),
        &s.targets,
        if s.scene == "cylinder" {
            "target (scene order; hNN: NN cm above the card)"
        } else {
            "target (scene order)"
        },
        "luminance Y (cd/m²)",
        &series,
    )
}

/// Chromaticities of the truth and of every coding (profiles as lines), in
/// the study's observer (the one its options name).
pub fn chromaticity_chart(s: &SceneStudy) -> Result<String, String> {
    let line = s.targets.len() > 1;
    let mut series = vec![ScatterSeries {
        name: "truth".into(),
        points: s.truth.iter().map(|t| (t.x, t.y)).collect(),
        connect: line,
    }];
    for c in &s.codings {
        series.push(ScatterSeries {
            name: c.coding.clone(),
            points: c.profile.iter().map(|p| (p.x.mean, p.y.mean)).collect(),
            connect: line,
        });
    }
    charts::chromaticity_chart(&format!("{}: chromaticity", s.title), s.observer, &series)
}

/// rms_rel per coding, ±1 SD over seeds.
pub fn rms_chart(s: &SceneStudy) -> Result<String, String> {
    let bars: Vec<Bar> = s
        .codings
        .iter()
        .map(|c| Bar {
            label: c.coding.clone(),
            value: c.rms_rel.mean,
            sd: Some(c.rms_rel.sd),
        })
        .collect();
    charts::bar_chart(
        &format!("{}: rms_rel (±1 SD over seeds){}", s.title, truncation_suffix(s)),
        "rms_rel (relative, 0.01 = 1 %)",
        &bars,
    )
}

/// Mean ΔE*ab per coding, ±1 SD over targets (the study's error bars).
pub fn delta_e_chart(s: &SceneStudy) -> Result<String, String> {
    let bars: Vec<Bar> = s
        .codings
        .iter()
        .map(|c| Bar {
            label: c.coding.clone(),
            value: c.mean_dE76.mean,
            sd: Some(c.sd_dE76_over_targets),
        })
        .collect();
    charts::bar_chart(
        &format!("{}: mean ΔE*ab (±1 SD over targets){}", s.title, truncation_suffix(s)),
        "mean ΔE*ab (CIELAB units)",
        &bars,
    )
}

/// Wall time against mean ΔE00 for every sweep point, one series per
/// coding (its colour and marker), each point labelled with what its sweep
/// varied, and the Pareto front as its own series. Every point renders a
/// fixed number of paths per target (no adaptive stop), timed as
/// [`lightbooth_render::cost`] says (the median, whiskers fastest–slowest, the
/// method in the axis title). Rays traced are in
/// `sweeps.csv` beside the time but are not the axis: the codings trace the
/// same rays for the same paths and differ only in the arithmetic per ray.
pub fn speed_chart(s: &SceneStudy) -> Result<String, String> {
    let mut series = Vec::new();
    let mut labels = Vec::new();
    let mut spreads = Vec::new();
    let mut codings: Vec<&str> = Vec::new();
    for p in &s.sweeps {
        if !codings.contains(&p.coding.as_str()) {
            codings.push(&p.coding);
        }
    }
    for coding in codings {
        let points: Vec<&SweepPoint> = s.sweeps.iter().filter(|p| p.coding == coding).collect();
        series.push(ScatterSeries {
            name: coding.to_string(),
            points: points.iter().map(|p| (p.wall_seconds, p.mean_dE00)).collect(),
            connect: false,
        });
        labels.push(points.iter().map(|p| sweep_label(p)).collect());
        spreads.push(
            points
                .iter()
                .map(|p| (p.wall_seconds_min, p.wall_seconds_max))
                .collect(),
        );
    }
    let front = pareto_front(&s.sweeps);
    series.push(ScatterSeries {
        name: "Pareto front".into(),
        points: front
            .iter()
            .map(|&i| (s.sweeps[i].wall_seconds, s.sweeps[i].mean_dE00))
            .collect(),
        connect: true,
    });
    charts::scatter_chart_with_spread(
        &format!(
            "{}: speed against accuracy (p = paths per target, b = bounces){}",
            s.title,
            truncation_suffix(s)
        ),
        &format!("render time (s, log scale): {}", lightbooth_render::cost::TIMING_AXIS),
        "mean ΔE00 (CIEDE2000 units, log scale)",
        &series,
        &labels,
        &spreads,
        (true, true),
    )
}

/// A sweep point's label: what its sweep varied — paths per target ("4096 p"),
/// bounces ("3 b"), or the coding itself for the coding and N sweeps.
fn sweep_label(p: &SweepPoint) -> String {
    match p.sweep.as_str() {
        "samples" => format!("{} p", p.samples),
        "bounces" => match p.bounces {
            Some(b) => format!("{b} b"),
            None => "∞ b".into(),
        },
        _ => p.coding.clone(),
    }
}

/// Indices of the sweep points no other point beats in both time and error,
/// fastest first.
pub fn pareto_front(points: &[SweepPoint]) -> Vec<usize> {
    super::auto::pareto_front(&points.iter().map(|p| (p.wall_seconds, p.mean_dE00)).collect::<Vec<_>>())
}

/// Writes the report's files (see [`report_files`]) into `dir`.
pub fn write_report(result: &StudyResult, dir: &Path) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    for (name, bytes) in report_files(result)? {
        std::fs::write(dir.join(name), bytes)?;
    }
    Ok(())
}

/// The report as (file name, contents): `index.html` with every chart
/// inline, one SVG per chart (`SCENE_CHART.svg`, `failure_map_*.svg`), CSVs
/// of every number and `study.json`.
pub fn report_files(result: &StudyResult) -> std::io::Result<Vec<(String, Vec<u8>)>> {
    let mut files: Vec<(String, Vec<u8>)> = Vec::new();
    let mut html = String::from(
        "<!doctype html><html lang=\"en\"><head><meta charset=\"utf-8\"><link rel=\"icon\" href=\"data:,\"><title>lightbooth study</title>\
         <style>body{font-family:system-ui,sans-serif;margin:2em;max-width:1200px}table{border-collapse:collapse}\
         td,th{border-bottom:1px solid #ddd;padding:.2em .6em;text-align:right}td:first-child,th:first-child{text-align:left}\
         .charts{display:grid;grid-template-columns:repeat(auto-fit,minmax(560px,1fr));gap:1em}figure{margin:0}\
         figure.wide{grid-column:1/-1}svg{max-width:100%;height:auto}section.scene{border-top:2px solid #1d3557;margin-top:2em}",
    );
    // The codings' colours, the same table the charts use.
    html.push_str(&charts::coding_css());
    html.push_str("</style></head><body><h1>lightbooth study</h1>");
    let o = &result.options;
    let _ = write!(
        html,
        "<p>Against {:?}; {} seeds; codings {}; first round {} paths per target, adaptive to a relative SE of Y of {}; \
         {}. Wall time {:.1} s. Figures: rms_rel = sqrt(mean (1 − S/M)²) over a scene's targets; ΔE with the \
         CIELAB white the scene file declares, stated per scene; observer {}; a target differs beyond noise when \
         |Ȳ_render − Y_truth| &gt; {}·√(SE_render² + SE_truth²); ± values are SD over seeds unless marked.</p>",
        o.against,
        o.seeds,
        o.codings.iter().map(|c| c.to_string()).collect::<Vec<_>>().join(", "),
        o.samples,
        o.target_relative_se.map(|v| format!("{:.2} %", v * 100.0)).unwrap_or_else(|| "none".into()),
        bounces_text(o.max_bounces),
        result.wall_seconds,
        result.observer,
        result.beyond_noise_k
    );
    // The three tables' rows (written by the `csv` crate at the end).
    let (mut figures_rows, mut profile_rows, mut sweeps_rows) = (Vec::new(), Vec::new(), Vec::new());
    for s in &result.scenes {
        let _ = write!(
            html,
            "<section class=\"scene\"><h2>{} ({})</h2><p>CIELAB white: {}. Renders of all seeds: {:.2} s.</p><table><tr><th>coding</th>\
             <th>rms_rel</th><th>mean ΔE*ab</th><th>SD over targets</th><th>mean ΔE00</th><th>targets beyond noise (|ΔY| &gt; 3·SE)</th><th>distinguishable within the instrument's stated accuracy</th></tr>",
            html_text(&s.title),
            html_text(&s.scene),
            html_text(&s.white_source),
            s.render_seconds
        );
        for c in &s.codings {
            let _ = write!(
                html,
                "<tr><td class=\"coding-{}\">{}</td><td>{:.4} ± {:.4}</td><td>{:.3} ± {:.3}</td><td>{:.3}</td><td>{:.3} ± {:.3}</td><td>{} of {}</td><td>{}</td></tr>",
                c.coding,
                c.coding,
                c.rms_rel.mean,
                c.rms_rel.sd,
                c.mean_dE76.mean,
                c.mean_dE76.sd,
                c.sd_dE76_over_targets,
                c.mean_dE00.mean,
                c.mean_dE00.sd,
                c.significant_targets,
                s.targets.len(),
                html_text(&distinguishable_cell(c))
            );
            for (seed, f) in c.per_seed.iter().enumerate() {
                figures_rows.push(
                    [
                        s.scene.to_string(),
                        s.observer.to_string(),
                        c.coding.to_string(),
                        (seed + 1).to_string(),
                        f.rms_rel.to_string(),
                        f.mean_dE76.to_string(),
                        f.sd_dE76.to_string(),
                        f.mean_dE00.to_string(),
                        f.sd_dE00.to_string(),
                    ]
                    .to_vec(),
                );
            }
            for (p, t) in c.profile.iter().zip(&s.truth) {
                profile_rows.push(
                    [
                        s.scene.to_string(),
                        s.observer.to_string(),
                        p.target.to_string(),
                        c.coding.to_string(),
                        p.Y.mean.to_string(),
                        p.Y.sd.to_string(),
                        p.Y_se.to_string(),
                        p.x.mean.to_string(),
                        p.y.mean.to_string(),
                        t.XYZ[1].to_string(),
                        t.x.to_string(),
                        t.y.to_string(),
                        t.source.to_string(),
                        p.Y_differs_significantly.to_string(),
                    ]
                    .to_vec(),
                );
            }
        }
        html.push_str("</table><div class=\"charts\">");
        let mut charts: Vec<(&str, Result<String, String>)> = vec![
            ("chromaticity", chromaticity_chart(s)),
            ("profile", profile_chart(s)),
            ("rms", rms_chart(s)),
            ("de", delta_e_chart(s)),
        ];
        if let Some(auto) = &s.auto {
            let c = &auto.choice;
            let v = &auto.verification;
            let _ = write!(
                html,
                "<h3>Automatic settings</h3><p>{} with {} bounces and {} paths per target; verified against the \
                 converged spectral answer: rms_rel {:.4}, mean ΔE00 {:.3} (max {:.3}), {:.2} s — {}. On the Pareto \
                 front of the alternatives (within timing noise): {}.</p><ul>{}</ul>",
                c.coding,
                c.bounces,
                c.samples,
                v.rms_rel,
                v.mean_de00,
                v.max_de00,
                v.wall_seconds,
                if v.meets {
                    "meets the tolerance"
                } else {
                    "does NOT meet the tolerance"
                },
                auto.candidates.auto_on_front_within_noise,
                c.reasons
                    .iter()
                    .map(|r| format!("<li>{}</li>", html_text(r)))
                    .collect::<String>()
            );
            charts.push(("auto", Ok(auto.svg.clone())));
        }
        if !s.sweeps.is_empty() {
            charts.push(("speed", speed_chart(s)));
            let front = pareto_front(&s.sweeps);
            for (i, p) in s.sweeps.iter().enumerate() {
                sweeps_rows.push(
                    [
                        s.scene.to_string(),
                        s.observer.to_string(),
                        p.sweep.to_string(),
                        p.coding.to_string(),
                        p.samples.to_string(),
                        p.bounces.map_or_else(|| "unbounded".to_string(), |b| b.to_string()),
                        p.wall_seconds.to_string(),
                        p.wall_seconds_min.to_string(),
                        p.wall_seconds_max.to_string(),
                        p.rays.to_string(),
                        p.rms_rel.to_string(),
                        p.mean_dE00.to_string(),
                        p.study_choice.to_string(),
                        front.contains(&i).to_string(),
                    ]
                    .to_vec(),
                );
            }
        }
        for (name, svg) in charts {
            match svg {
                Ok(svg) => {
                    let class = if name == "chromaticity" { " class=\"wide\"" } else { "" };
                    let _ = write!(html, "<figure{class}>{svg}</figure>");
                    files.push((format!("{}_{name}.svg", s.scene), svg.into_bytes()));
                }
                Err(e) => {
                    let _ = write!(html, "<p>chart {name} failed: {e}</p>");
                }
            }
        }
        html.push_str("</div></section>");
    }
    if let Some(map) = &result.failure_map {
        html.push_str(
            "<h2>Where codings fail</h2><p>Illuminant × ColorChecker patch (direct light, exact) and the CYLINDER's \
             card reflectance scaled 0.25–1 (mean ± SD over seeds); thresholds ΔE*ab = 2 and rms_rel = 5 %. Every \
             number: <a href=\"failure_map.csv\">failure_map.csv</a>.</p><div class=\"charts\">",
        );
        let svgs = map.svgs().map_err(std::io::Error::other)?;
        for (name, svg) in svgs {
            let _ = write!(html, "<figure>{svg}</figure>");
            files.push((name, svg.into_bytes()));
        }
        html.push_str("</div>");
        files.push(("failure_map.csv".into(), map.to_csv().into_bytes()));
    }
    html.push_str("<p>Numbers: <a href=\"figures.csv\">figures.csv</a> (per scene, coding and seed), <a href=\"profiles.csv\">profiles.csv</a> (per target), <a href=\"sweeps.csv\">sweeps.csv</a>, <a href=\"study.json\">study.json</a> (everything).</p></body></html>");
    files.push(("index.html".into(), html.into_bytes()));
    let csv = |header: &[&str], rows: Vec<Vec<String>>| {
        crate::export::csv_table::csv_table(header, rows)
            .map(String::into_bytes)
            .map_err(std::io::Error::other)
    };
    files.push((
        "figures.csv".into(),
        csv(
            &[
                "scene",
                "observer",
                "coding",
                "seed",
                "rms_rel",
                "mean_dE76",
                "sd_dE76",
                "mean_dE00",
                "sd_dE00",
            ],
            figures_rows,
        )?,
    ));
    files.push((
        "profiles.csv".into(),
        csv(
            &[
                "scene",
                "observer",
                "target",
                "coding",
                "Y_mean",
                "Y_sd_seeds",
                "Y_se",
                "x_mean",
                "y_mean",
                "truth_Y",
                "truth_x",
                "truth_y",
                "truth_source",
                "Y_differs_significantly",
            ],
            profile_rows,
        )?,
    ));
    files.push((
        "sweeps.csv".into(),
        csv(
            &[
                "scene",
                "observer",
                "sweep",
                "coding",
                "samples",
                "bounces",
                "wall_seconds",
                "wall_seconds_min",
                "wall_seconds_max",
                "rays",
                "rms_rel",
                "mean_dE00",
                "study_choice",
                "pareto",
            ],
            sweeps_rows,
        )?,
    ));
    files.push((
        "study.json".into(),
        serde_json::to_vec_pretty(result).map_err(std::io::Error::other)?,
    ));
    Ok(files)
}

/// The report's last column: whether the coding is told apart from the
/// measurements within the instrument's stated accuracy, with rms_rel's
/// 95th percentile of what measurement error alone gives.
pub fn distinguishable_cell(c: &super::run::CodingStudy) -> String {
    match (&c.uncertainty, &c.uncertainty_not_propagated) {
        (Some(u), _) => format!(
            "{}{}",
            u.distinguishable(),
            accuracy_detail(
                u.rms_rel.null_95th_stated_accuracy,
                u.dE00_targets_beyond_stated_accuracy,
                c.profile.len()
            )
        ),
        (None, Some(why)) => format!("not propagated: {why}"),
        (None, None) => "against the reference: no instrument".into(),
    }
}

/// The figures behind [`distinguishable_cell`]'s words, in parentheses,
/// naming only what is on record: rms_rel's 95th percentile from
/// measurement error alone, and at how many of the scene's `targets` ΔE00
/// is beyond the stated accuracy. Empty when neither is (the words already
/// say "no accuracy on record"); the report once ended "ΔE00 beyond at —
/// targets".
pub fn accuracy_detail(null_95th: Option<f64>, beyond: Option<usize>, targets: usize) -> String {
    let mut parts = Vec::new();
    if let Some(v) = null_95th {
        parts.push(format!("rms_rel from measurement error alone ≤ {v:.4}"));
    }
    if let Some(n) = beyond {
        parts.push(format!("ΔE00 beyond the stated accuracy at {n} of {targets} targets"));
    }
    if parts.is_empty() {
        String::new()
    } else {
        format!(" ({})", parts.join("; "))
    }
}

/// `text` as HTML text: a scene's name and white come from its file, and
/// stored text is never markup (a scene named `<img onerror=…>` is shown as
/// those characters, not run).
fn html_text(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::accuracy_detail;

    /// The CLI study report ended "ΔE00 beyond at — targets" when the
    /// instrument stated no colour accuracy: only what is on record is
    /// named, each as a phrase that reads.
    #[test]
    fn the_study_report_ended_de00_beyond_at_dash_targets() {
        assert_eq!(
            accuracy_detail(Some(0.01234), Some(3), 21),
            " (rms_rel from measurement error alone ≤ 0.0123; ΔE00 beyond the stated accuracy at 3 of 21 targets)"
        );
        assert_eq!(
            accuracy_detail(Some(0.01234), None, 21),
            " (rms_rel from measurement error alone ≤ 0.0123)"
        );
        assert_eq!(accuracy_detail(None, None, 21), "");
        for text in [accuracy_detail(Some(0.1), None, 1), accuracy_detail(None, Some(0), 1)] {
            assert!(!text.contains('—') && !text.contains("beyond at"), "{text}");
        }
    }
}
