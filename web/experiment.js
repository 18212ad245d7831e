// Experiments (/experiment, /experiment/ID): set one up from a complete
// measurement and its comparisons, see every colour on the display (codes
// at 8 bits and with the output method, out of gamut, not distinct) before
// anyone is run, follow its sessions, and read the results (percent
// correct, d′ under both models, the study's Fig. 5 right).
import { $, api, el, localTime, notice, startPage } from "./shared.js";
import { showNavigation } from "./nav.js";

function row(cells) {
  const tr = el("tr");
  for (const c of cells) {
    if (c instanceof Node) {
      const td = el("td");
      td.append(c);
      tr.append(td);
    } else if (c && typeof c === "object") {
      tr.append(el("td", c.text, c.cls));
    } else {
      tr.append(el("td", c === undefined || c === null ? "" : String(c)));
    }
  }
  return tr;
}

const when = localTime;
const codes = (c) => `(${c.join(", ")})`;
const yesNo = (v) => ({ text: v ? "yes" : "no", cls: v ? "yes" : "no" });

// ---- the check: every colour on the display ------------------------------

// A table with its header row and an empty body (returned).
function tableWithHead(id, headers) {
  const table = el("table");
  table.id = id;
  const head = el("tr");
  for (const h of headers) head.append(el("th", h));
  table.append(el("thead"));
  table.tHead.append(head);
  const body = el("tbody");
  table.append(body);
  return { table, body };
}

// A paragraph, then the lines as a list.
function summaryList(box, text, cls, lines) {
  box.append(el("p", text, cls));
  const ul = el("ul", undefined, "summary");
  for (const line of lines) ul.append(el("li", line));
  box.append(ul);
}

function checkView(check) {
  const box = el("div");
  const r = check.resolution;
  summaryList(box, `Output: ${r.how} (${r.effective_bits.toFixed(1)} effective bits per gun).`, "hint", check.summary);
  const { table, body } = tableWithHead("check-table", ["colour", "8-bit codes", "fractional codes", "ΔE00 intended",
    "ΔE00 shown", "distinct at 8 bits", `distinct (${r.method})`, "what the display does"]);
  const o = check.original;
  body.append(row([o.name, codes(o.codes_8bit), o.fractional_code.map((v) => v.toFixed(3)).join(", "), "", "", "", "", o.verdict]));
  for (const c of check.approximations) {
    body.append(row([c.name, codes(c.codes_8bit), c.fractional_code.map((v) => v.toFixed(3)).join(", "),
      c.delta_e00_intended.toFixed(3), c.delta_e00_shown.toFixed(3), yesNo(c.distinct_at_8bit), yesNo(c.distinct), c.verdict]));
  }
  const b = check.background;
  body.append(row([b.name, codes(b.codes_8bit), b.fractional_code.map((v) => v.toFixed(3)).join(", "), "", "", "", "", b.verdict]));
  box.append(table);
  box.append(el("p", "ΔE00 relative to the display's white, in the display profile's observer.", "hint"));
  return box;
}

// ---- setting one up -------------------------------------------------------

let comparisonsByMeasurement = new Map();
// The listed measurements by id (what loadCodings says of one without comparisons).
let measurementById = new Map();

async function loadSetup() {
  const [list, profiles, measurements] = await Promise.all([
    api("/api/experiments"),
    api("/api/display-profiles"),
    api("/api/measurements?state=complete&limit=200"),
  ]);
  const tbody = $("experiment-table").tBodies[0];
  tbody.replaceChildren();
  for (const e of list) {
    const tr = row([e.id, e.name, `${e.scene}/${e.target}`, e.output_method, e.request.approximations.join(", "),
      (e.check.testable || []).join(", ") || "none", when(e.created_at)]);
    tr.className = "clickable";
    tr.title = "open this experiment";
    tr.addEventListener("click", () => { location.href = `/experiment/${e.id}`; });
    tbody.append(tr);
  }
  if (!list.length) tbody.append(row(["", "no experiments yet", "", "", "", "", ""]));
  $("profile").replaceChildren(...profiles.map((p) => {
    // A failed profile (fit residual or validation ΔE00 over its limit) is
    // listed, marked, and cannot be chosen.
    // A luminance meter's profile (γ only, no primaries' colour) cannot
    // show an experiment's colours: listed, saying so, and not offered.
    const failed = p.state === "failed";
    const luminanceOnly = p.profile.black_cd_m2 != null;
    const o = el("option", `${p.id}: ${p.name} (${p.profile.observer}, ${when(p.created_at)})` +
      (failed ? ` — FAILED: ${p.failures.join("; ")}` : "") +
      (luminanceOnly ? " — a luminance meter's (γ only, no primaries' colour): cannot show colours; calibrate with a " +
        "colorimeter or a spectroradiometer" : ""));
    o.value = p.id;
    o.disabled = failed || luminanceOnly;
    return o;
  }));
  if (!profiles.length) $("profile").append(el("option", "no display profile: calibrate the display first (/calibrate)"));
  const items = (measurements.items || measurements).filter((m) => m.scene && m.target);
  measurementById = new Map(items.map((m) => [m.id, m]));
  $("measurement").replaceChildren(...items.map((m) => {
    const o = el("option", `${m.id}: ${m.scene}/${m.target}, ${m.booth}, ${when(m.created_at)}`);
    o.value = m.id;
    return o;
  }));
  if (!items.length) $("measurement").append(el("option", "no complete measurement of a scene target yet"));
  await loadCodings();
}

async function loadCodings() {
  const id = Number($("measurement").value);
  const box = $("approximations");
  if (!id) return;
  let rows = comparisonsByMeasurement.get(id);
  if (!rows) {
    rows = await api(`/api/measurements/${id}/comparisons`);
    comparisonsByMeasurement.set(id, rows);
  }
  const codings = [...new Set(rows.map((r) => r.coding))];
  box.replaceChildren();
  if (!codings.length) {
    // The real reason: a luminance meter's measurement has no colour to
    // compare or show; otherwise its comparison is still being computed.
    const m = measurementById.get(id);
    box.textContent = m && m.XYZ == null && m.x == null && m.Y != null
      ? `measurement ${id} is the ${m.instrument_model || "luminance meter"}'s: luminance only, no colour, so it has ` +
        "no colour comparison to take approximations from; choose a colorimeter's or a spectroradiometer's measurement"
      : `measurement ${id} has no comparisons yet: they are computed after it completes; reload in a moment`;
    return;
  }
  box.append(el("span", "approximations: "));
  for (const c of codings) {
    const label = el("label");
    const input = el("input");
    input.type = "checkbox";
    input.value = c;
    input.checked = /^nstep(3|9|27|81)$|^s?rgb$/.test(c);
    label.append(input, " " + c);
    box.append(label);
  }
  const original = $("original");
  original.replaceChildren(original.options[0]);
  for (const c of codings) {
    const o = el("option", `the ${c} rendering`);
    o.value = c;
    original.append(o);
  }
}

function request() {
  const number = (id) => Number($(id).value);
  return {
    name: $("name").value.trim(),
    measurement_id: number("measurement"),
    original: $("original").value,
    approximations: [...$("approximations").querySelectorAll("input:checked")].map((i) => i.value)
      .filter((c) => c !== $("original").value),
    display_profile_id: number("profile"),
    output: $("output").value,
    gamut: $("gamut").value,
    presentation: {
      pie_diameter_deg: number("pie_diameter_deg"), viewing_distance_mm: number("viewing_distance_mm"),
      pixel_pitch_mm: number("pixel_pitch_mm"), fixation_ms: number("fixation_ms"), stimulus_ms: number("stimulus_ms"),
      adaptation_s: number("adaptation_s"), repeats: number("repeats"),
    },
  };
}

async function check() {
  notice("");
  try {
    const c = await api("/api/experiments/check", { method: "POST", body: JSON.stringify(request()) });
    $("check").replaceChildren(el("h3", "The colours on the display"), checkView(c));
  } catch (e) {
    notice(e.message);
  }
}

async function create(ev) {
  ev.preventDefault();
  notice("");
  try {
    const e = await api("/api/experiments", { method: "POST", body: JSON.stringify(request()) });
    location.href = `/experiment/${e.id}`;
  } catch (e) {
    notice(e.message);
  }
}

// The newest verification: each colour as the display emitted it, measured.
function verificationView(v) {
  const box = el("div");
  if (!v) {
    box.append(el("p", "Not verified yet: open the session page on the stimulus display and press “verify the display” " +
      "before the first observer.", "notice"));
    return box;
  }
  summaryList(box, `Verification ${v.id} (${when(v.created_at)}): ${v.passed ? "passed" : "FAILED"} — ` +
    `ΔE00 tolerance ${v.tolerance_delta_e00}, ${v.observer} observer, relative to the display's white.`,
  v.passed ? "hint" : "notice", v.summary);
  const { table, body } = tableWithHead("verification-table", ["colour", "shown", "measurement", "Y emitted cd/m²",
    "ΔE00 intended → emitted", "of which quantisation", "of which drift", "ΔE00 booth → emitted", "verdict"]);
  for (const c of v.colours) {
    const tr = row([c.colour, c.geometry.replace("_", " "), c.measurement_id, c.emitted_xyz[1].toFixed(3),
      c.delta_e00_emitted.toFixed(3), c.delta_e00_quantisation.toFixed(3), c.delta_e00_drift.toFixed(3),
      c.delta_e00_booth === null ? "" : c.delta_e00_booth.toFixed(2), c.passed ? "within tolerance" : c.likely_cause]);
    tr.lastChild.className = c.passed ? "yes" : "no";
    body.append(tr);
  }
  box.append(table);
  box.append(el("p", "Intended: the colour asked of the display (gamut policy applied, unquantised); quantisation: " +
    "ΔE00 from intended to what the profile predicts the output method emits; drift: from that prediction to the " +
    "measurement; booth: the real booth measurement the stimulus stands for, shown through the same gamut policy.", "hint"));
  return box;
}

// ---- one experiment ----------------------------------------------------------

async function loadDetail(id) {
  $("list-view").hidden = true;
  $("detail-view").hidden = false;
  const [e, sessions, analysis, verifications] = await Promise.all([
    api(`/api/experiments/${id}`),
    api(`/api/experiments/${id}/sessions`),
    api(`/api/experiments/${id}/analysis`),
    api(`/api/experiments/${id}/verifications`),
  ]);
  $("detail-title").textContent = `Experiment ${e.id}: ${e.name}`;
  const p = e.request.presentation;
  $("detail-facts").textContent = `${e.scene}/${e.target} in booth ${e.booth}; original: ${e.request.original} ` +
    `(measurement ${e.measurement_id}); display profile ${e.display_profile_id}; ${e.output_method}; ` +
    `pie ${p.pie_diameter_deg}° for ${p.stimulus_ms} ms after a ${p.fixation_ms} ms cross, ${p.repeats} ${p.repeats === 1 ? "repeat" : "repeats"} of ` +
    `6 configurations per approximation, ${p.adaptation_s} s adaptation; seed ${e.seed_text}.`;
  $("run-link").href = `/experiment/${e.id}/run`;
  $("detail-check").replaceChildren(checkView(e.check));
  $("detail-verification").replaceChildren(verificationView(verifications[0]));
  const tbody = $("session-table").tBodies[0];
  tbody.replaceChildren();
  for (const s of sessions) {
    tbody.append(row([s.id, s.observer_id, s.superseded_by ? `superseded by ${s.superseded_by}` : s.state, s.trials_recorded,
      s.frame_ms ? `${(1000 / s.frame_ms).toFixed(2)} Hz` : "not measured yet", when(s.created_at)]));
  }
  if (!sessions.length) tbody.append(row(["", "no sessions yet", "", "", "", ""]));
  const box = $("analysis");
  box.replaceChildren();
  if (!analysis.rows.length) {
    // Trials may be stored and none counted: every one dropped a frame during its pie.
    box.append(el("p", analysis.sessions ? analysis.notes[0] + ": none is counted yet." : "No trials yet.", "hint"));
    $("figure").replaceChildren();
    return;
  }
  const table = el("table");
  const head = el("tr");
  for (const h of ["observer", "approximation", "correct", "% correct [95 %]", "d′ differencing [95 %]",
    "d′ independent observation [95 %]", "ΔE00 shown", "not counted"]) head.append(el("th", h));
  table.append(el("thead"));
  table.tHead.append(head);
  const body = el("tbody");
  const dp = (x) => `${x.d_prime.toFixed(2)} [${x.d_prime_interval[0].toFixed(2)}, ${x.upper_bounded ? x.d_prime_interval[1].toFixed(2) : "no bound"}]` + (x.rule ? " *" : "");
  for (const r of analysis.rows) {
    const d = r.differencing;
    if (!d) {
      // Every trial of this condition was excluded: the row says so.
      body.append(row([r.observer, r.approximation, `0/0`, "none counted", "—", "—", r.delta_e00_shown.toFixed(3), r.excluded]));
      continue;
    }
    body.append(row([r.observer, r.approximation, `${r.correct}/${r.trials}`,
      `${(100 * d.proportion_correct).toFixed(1)} [${(100 * d.proportion_interval[0]).toFixed(1)}, ${(100 * d.proportion_interval[1]).toFixed(1)}]`,
      dp(d), dp(r.independent_observation), r.delta_e00_shown.toFixed(3), r.excluded]));
  }
  table.append(body);
  box.append(table);
  for (const n of analysis.notes) box.append(el("p", n, "hint"));
  for (const w of analysis.warnings) box.append(el("p", "warning: " + w, "notice"));
  const ruled = analysis.rows.find((r) => r.differencing && r.differencing.rule);
  if (ruled) box.append(el("p", "* " + ruled.differencing.rule, "hint"));
  box.append(thresholdTable(analysis));
  const csv = el("a", "analysis as CSV");
  csv.href = `/api/experiments/${id}/analysis.csv`;
  const thresholds = el("a", "thresholds as CSV");
  thresholds.href = `/api/experiments/${id}/thresholds.csv`;
  const mat = el("a", "both as a MAT-file");
  mat.href = `/api/experiments/${id}/analysis.mat`;
  box.append(csv, " · ", thresholds, " · ", mat);
  await readCredential;
  const img = el("img");
  img.alt = "d′ and percent correct per approximation";
  img.src = `/api/experiments/figure.svg?ids=${id}`;
  const curve = el("img");
  curve.alt = "percent correct against ΔE00 with each observer's fitted psychometric function";
  curve.src = `/api/experiments/${id}/psychometric.svg`;
  $("figure").replaceChildren(img, el("figcaption", "d′ under the differencing model (bars, 95 % intervals), percent correct (◆) on the right axis; chance is 33 %.", "hint"),
    curve, el("figcaption", `Percent correct against ΔE00 (${analysis.delta_e00_basis}) with the fitted d′ = ΔE00/σ ` +
      "(differencing model), each observer's percent with its exact 95 % interval; chance is the dashed line at 33 %; " +
      "hollow diamonds: the percent the fit predicts for approximations the display could not show apart at 8 bits.", "hint"));
}

// Each observer's threshold: σ and the ΔE00 at 2/3 correct with their
// profile-likelihood intervals, the lapse rate λ fitted with σ (its
// interval and bound), what the likelihood leaves at a bound (in words,
// under the table), and how well one σ explains every approximation
// (deviance, p), under both oddity models.
function thresholdTable(analysis) {
  const wrap = el("div");
  wrap.append(el("h3", "Thresholds"));
  const table = el("table");
  table.className = "threshold-table";
  const head = el("tr");
  for (const h of ["observer", "model", "σ (ΔE00) [95 %]", "threshold ΔE00 at 2/3 [95 %]", "lapse λ [95 %]", "deviance (df)", "p"]) {
    head.append(el("th", h));
  }
  table.append(el("thead"));
  table.tHead.append(head);
  const body = el("tbody");
  const end = (v) => (v === null || v === undefined ? "∞" : v.toFixed(3));
  const atBounds = [];
  let lapseMax = null;
  for (const t of analysis.thresholds) {
    const f = t.fit;
    if (!f) {
      // A sentence for a person; the fitter's own reason is `not_fitted` in the JSON and CSV.
      body.append(row([t.observer, t.model, t.no_fit || "no fit", "", "", "", ""]));
      continue;
    }
    const g = f.goodness_of_fit;
    lapseMax = f.lapse_max;
    const marks = f.at_bounds.length ? " †" : "";
    for (const b of f.at_bounds) atBounds.push(`† ${t.observer}, ${t.model}: ${b}.`);
    body.append(row([t.observer, t.model, `${end(f.sigma)} [${end(f.sigma_interval[0])}, ${end(f.sigma_interval[1])}]${marks}`,
      `${end(f.threshold)} [${end(f.threshold_interval[0])}, ${end(f.threshold_interval[1])}]${marks}`,
      `${f.lapse.toFixed(3)} [${f.lapse_interval[0].toFixed(3)}, ${f.lapse_interval[1].toFixed(3)}]`,
      `${g.deviance.toFixed(2)} (${g.degrees_of_freedom})`, g.p_value === null ? "no df left" : g.p_value.toFixed(3)]));
  }
  table.append(body);
  wrap.append(table, el("p", `One σ per observer over all approximations, d′ = ΔE00/σ, ΔE00 ${analysis.delta_e00_basis === "verified" ?
    "as the display was measured to show it (the newest passing verification)" :
    "as the display profile predicts it is shown (no passing verification yet)"}; a small p says one σ does not ` +
    "explain every approximation." + (lapseMax === null ? "" : ` λ is the lapse rate fitted with σ, the share of trials ` +
    `missed far above threshold (the fitted curve's ceiling is 1 − λ), bounded to [0, ${lapseMax}] (Wichmann & Hill 2001); ` +
    "the threshold is the lapse-free observer's."), "hint"));
  for (const b of atBounds) wrap.append(el("p", b, "notice"));
  return wrap;
}

// Chart <img>s off loopback read with the daemon's read-only cookie (startPage).
const readCredential = startPage();
showNavigation();
const parts = location.pathname.split("/").filter(Boolean);
const detailId = parts.length >= 2 ? Number(parts[1]) : null;
(detailId ? loadDetail(detailId) : loadSetup()).catch((e) => notice(e.message));
$("measurement").addEventListener("change", () => loadCodings().catch((e) => notice(e.message)));
$("check-button").addEventListener("click", check);
$("setup").addEventListener("submit", create);
