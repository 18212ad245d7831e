// lightbooth dashboard: plain JavaScript, no build step. Charts are SVG drawn
// by the daemon (plotters), so this file only fetches JSON, follows the
// server-sent events and swaps <img> sources.
import {
  $, api, count, duration, el, fmt, followLabEvents, instrumentBadgeText, jobButton, laterTime, localTime,
  luminanceScale, notice, observerName, onLabEvent, startPage, token,
} from "./shared.js";
import { showHome } from "./home.js";
import { showMaterialView } from "./material.js";
import { showNavigation } from "./nav.js";
import { showViewerView } from "./viewer.js";

// --- views -----------------------------------------------------------------

function showView() {
  const [, hashView, arg] = (location.hash || "#/home").split("/");
  const view = hashView || "home";
  for (const s of document.querySelectorAll(".view")) s.hidden = s.id !== "view-" + view;
  for (const a of document.querySelectorAll("nav a")) a.classList.toggle("active", a.dataset.view === view);
  if (view === "home") showHome(); // web/home.js
  if (view === "measurements") loadMeasurements(arg);
  if (view === "scenes") loadScenes(arg);
  if (view === "viewer") showViewerView(arg, sceneInfo); // web/viewer.js
  if (view === "study") loadStudies(arg);
  if (view === "material") showMaterialView(); // web/material.js
}
// The views of other modules (home.js, viewer.js, material.js) are
// imported above: defined before this module runs, whatever the load order.
window.addEventListener("hashchange", showView);

// --- instrument status and events ------------------------------------------

let current = null; // the measurement this page started and is following

let badgeStatus = null;
function setStatus(s) {
  badgeStatus = s;
  const b = $("instrument");
  b.className = "badge " + s.state;
  b.textContent = instrumentBadgeText(s);
}
// The badge's time left counts down between samples.
setInterval(() => { if (badgeStatus && badgeStatus.state === "measuring") setStatus(badgeStatus); }, 1000);

// Shows the end of the measurement this page started (`current`): from its
// `measurement_finished` event, or, when it ended before the page knew its id
// (a fast instrument answers before the POST does), from the POST's own check.
async function showFinished(id) {
  const m = await api(`/api/measurements/${id}`);
  if (id !== current || ["queued", "running"].includes(m.state)) return;
  $("cancel-current").hidden = true;
  // Its samples' events may have come before its id did, too.
  $("progress").max = m.samples_requested;
  $("progress").value = m.samples_taken;
  $("progress-text").textContent = `measurement #${id}: ${m.state}` + (m.error ? ` (${m.error})` : "");
  refreshLiveSpectrum(hasSpectrum(m));
  $("live-result").textContent = m.state === "complete"
    ? `Y = ${fmt(m.Y, 5)} cd/m², x = ${fmt(m.x, 4)}, y = ${fmt(m.y, 4)} (${observerName(m.observer)}), luminance CV = ${fmt(m.luminance_cv, 2)}`
    : `${m.state}: ${m.error || ""}` + (m.partial ? ` (partial average of ${m.good_samples}: Y = ${fmt(m.Y, 5)} cd/m²)` : "");
  showComparison($("live-comparison"), m).catch((e) => notice(e.message));
}

// The page's one event stream (shared.js), for this module's views and
// home.js's and viewer.js's.
function follow() {
  onLabEvent(["instrument_status"], (d) => setStatus(d.status));
  onLabEvent(["measurement_queued"], () => {
    if (location.hash.startsWith("#/measurements")) loadMeasurements();
  });
  onLabEvent(["measurement_started"], (d) => {
    if (location.hash.startsWith("#/measurements")) loadMeasurements();
    if (d.measurement_id !== current) return;
    $("progress").max = d.samples;
    $("progress").value = 0;
    $("progress-text").textContent = `measurement #${d.measurement_id}: starting`;
  });
  onLabEvent(["sample"], (d) => {
    if (location.hash.startsWith("#/measurements")) loadMeasurements();
    if (d.measurement_id !== current) return;
    const done = Math.min(d.index + 1, d.of);
    $("progress").max = d.of;
    $("progress").value = done;
    $("progress-text").textContent =
      `measurement #${d.measurement_id}: sample ${done} of ${d.of} (code ${d.code}: ${d.message})`;
    if (d.radiance != null) refreshLiveSpectrum(true); // a bad sample, or a colorimeter's, has none
  });
  onLabEvent(["measurement_finished"], async (d) => {
    if (d.measurement_id === current) await showFinished(d.measurement_id);
    // The measurement table follows every state change (queued, cancelled, finished).
    if (location.hash.startsWith("#/measurements")) loadMeasurements();
    updateSceneProgress();
  });
  for (const name of ["render_started", "render_finished"]) {
    onLabEvent([name], (d) => {
      if (openScene === d.scene) loadSceneDetail(d.scene);
      if (name === "render_finished" && location.hash === "#/scenes") loadScenes();
      refreshComparisons(null, d.scene);
    });
  }
  onLabEvent(["comparison_ready"], (d) => {
    if (openScene === d.scene) loadSceneDetail(d.scene);
    refreshComparisons(d.measurement_id);
  });
  onLabEvent(["study_progress"], (d) => {
    studyRunning = d;
    $("study-progress").textContent = `study ${d.study_id}: ${d.message}` + studyTimeLeft(d.study_id);
    if (location.hash.startsWith("#/study")) refreshStudyEstimate(d.study_id);
  });
  onLabEvent(["study_finished"], (d) => {
    studyRunning = null;
    $("study-progress").textContent = `study ${d.study_id}: ${d.ok ? "complete" : "did not complete: " + d.error}`;
    if (location.hash.startsWith("#/study")) loadStudies(String(d.study_id));
  });
  followLabEvents(() => setStatus({ state: "disconnected", reason: "lost the event stream; retrying" }));
}

// A study's time left, as GET /api/jobs last extrapolated it, shown again
// every 2 s between its progress events (a step can take half the run).
const studyEstimates = new Map();
let studyRunning = null; // the newest study_progress of a study not finished
setInterval(() => {
  if (!studyRunning || !location.hash.startsWith("#/study")) return;
  const d = studyRunning;
  refreshStudyEstimate(d.study_id);
  $("study-progress").textContent = `study ${d.study_id}: ${d.message}` + studyTimeLeft(d.study_id);
}, 2000);
// No estimate ("about 0 s" at 14 s of a 31 s run was none): "estimating…"
// until the daemon has one, and again once the one it gave has run out.
function studyTimeLeft(id) {
  const e = studyEstimates.get(id);
  if (!e) return "";
  const begun = e.done === null || e.done === undefined ? "" : ` — ${fmt(e.done, 3)} % of its work begun`;
  const left = e.seconds_left === null ? 0 : e.seconds_left - (Date.now() / 1000 - e.at);
  if (left < 1) return `${begun || " —"}; time left: estimating… (this step is slower than the ones before it, or none is done yet)`;
  return `${begun}; about ${duration(left)} left (each scene's steps weighed by its targets)`;
}
let studyEstimateBusy = false;
async function refreshStudyEstimate(id) {
  if (studyEstimateBusy) return;
  studyEstimateBusy = true;
  try {
    const q = await api("/api/jobs");
    const j = q.jobs.find((x) => x.kind === "study" && x.id === id);
    if (j) studyEstimates.set(id, { seconds_left: j.seconds_left, done: j.done, at: Date.now() / 1000 });
  } catch (e) {
    // The estimate is a nicety; the progress message stands without it.
  } finally {
    setTimeout(() => (studyEstimateBusy = false), 2000);
  }
}

// Live's spectrum chart of the running measurement, redrawn after each
// sample; an instrument that gives no spectrum (a colorimeter's XYZ, a
// luminance meter's Y) has none to draw, and Live says so instead.
function refreshLiveSpectrum(hasSpectrum) {
  const img = $("live-spectrum");
  img.hidden = !hasSpectrum;
  $("live-no-spectrum").hidden = hasSpectrum;
  if (hasSpectrum) img.src = `/api/measurements/${current}/spectrum.svg?t=${Date.now()}`;
  else $("live-no-spectrum").textContent = NO_SPECTRUM;
}

// What shows where a spectrum chart would be, for an instrument without spectra.
const NO_SPECTRUM = "No spectrum to chart: this instrument measures XYZ or luminance only. " +
  "Each sample's values are in the measurement's table.";

// Whether measurement m (as GET /api/measurements/{id} gives it) has a spectrum to chart.
function hasSpectrum(m) {
  return m.wavelength_nm != null || (m.samples || []).some((s) => s.radiance != null);
}

// --- live: start a measurement ---------------------------------------------

let sceneInfo = [];

async function loadSceneChoices() {
  try {
    sceneInfo = await api("/api/scenes");
  } catch (e) {
    sceneInfo = [];
  }
  const sel = $("scene-select");
  for (const s of sceneInfo) sel.add(new Option(`${s.id}: ${s.title}`, s.id));
  sel.addEventListener("change", fillTargets);
  fillTargets();
}

function fillTargets() {
  const sel = $("target-select");
  sel.replaceChildren();
  const s = sceneInfo.find((x) => x.id === $("scene-select").value);
  for (const t of s ? s.targets : []) sel.add(new Option(t, t));
  sel.disabled = !s;
}

async function startMeasurement(body) {
  return api("/api/measurements", { method: "POST", body: JSON.stringify(body) });
}

$("measure-form").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  notice("");
  const body = { samples: Number($("samples-input").value) };
  if ($("notes-input").value.trim()) body.notes = $("notes-input").value.trim();
  if ($("scene-select").value) {
    body.scene = $("scene-select").value;
    body.target = $("target-select").value;
  }
  try {
    const r = await startMeasurement(body);
    current = r.id;
    $("progress-box").hidden = false;
    $("progress").value = 0;
    $("progress").max = body.samples;
    $("progress-text").textContent = `measurement #${r.id}: queued`;
    $("cancel-current").hidden = false;
    $("live-result").textContent = "";
    $("live-comparison").hidden = true;
    // Its `measurement_finished` may have come before its id did.
    await showFinished(r.id);
  } catch (e) {
    notice(e.message + (token() ? "" : " (open the URL the daemon printed, with #token=…, to allow measurements)"));
  }
});

// --- measurements ----------------------------------------------------------

const PAGE = 100;
let measurementOffset = 0;

// "partial (3 of 5)" for an unfinished measurement averaged over its good samples.
function stateText(m) {
  return m.partial ? `${m.state}, partial (${m.good_samples} of ${m.samples_requested})` : m.state;
}

async function cancelMeasurement(id) {
  notice("");
  try {
    // The answer (and the measurement_finished event) updates the table and the live progress.
    await api(`/api/measurements/${id}/cancel`, { method: "POST", body: "{}" });
  } catch (e) {
    notice(e.message);
  }
  if (location.hash.startsWith("#/measurements")) loadMeasurements();
}

function measurementQuery() {
  const q = new URLSearchParams({ limit: PAGE, offset: measurementOffset });
  if ($("filter-booth").value) q.set("booth", $("filter-booth").value);
  if ($("filter-model").value) q.set("instrument_model", $("filter-model").value);
  if ($("filter-scene").value) q.set("scene", $("filter-scene").value);
  if ($("filter-state").value) q.set("state", $("filter-state").value);
  return q.toString();
}

// The models that measure a spectrum (lab::measure::recorder::SPECTRORADIOMETERS).
const SPECTRORADIOMETERS = ["PR-650", "PR-655", "PR-670", "CS-2000", "CS-2000A", "CS-3000", "CR-250", "CR-300"];

// What the listed x, y and Y are in: each observer named, and whose numbers
// they are — lightbooth's from a spectroradiometer's spectrum (the daemon's
// --observer), a colorimeter's or a luminance meter's own.
function observerNote(items) {
  const observers = [...new Set(items.filter((m) => m.observer).map((m) => m.observer))];
  if (!observers.length) return "";
  const spectral = items.some((m) => m.observer && SPECTRORADIOMETERS.includes(m.instrument_model));
  const own = items.some((m) => m.observer && !SPECTRORADIOMETERS.includes(m.instrument_model));
  const parts = [`Y, x, y in the ${observers.map(observerName).join(" and the ")} observer` +
    (observers.length > 1 ? " (each measurement's page names its own)" : "")];
  if (spectral) parts.push("a spectroradiometer's computed by lightbooth from its spectrum in the daemon's --observer " +
    "(the instrument's own CIE 1931 x, y are on each measurement's page)");
  if (own) parts.push("a colorimeter's XYZ or a luminance meter's Y as the instrument gave it, in its own observer, " +
    "which its comparisons use too");
  return parts.join("; ") + ".";
}

async function loadMeasurements(openId) {
  const page = await api(`/api/measurements?${measurementQuery()}`);
  $("observer-note").textContent = observerNote(page.items);
  const tbody = document.querySelector("#measurement-table tbody");
  tbody.replaceChildren();
  for (const m of page.items) {
    const tr = tbody.insertRow();
    tr.dataset.id = m.id;
    const instrument = m.instrument_model ? `${m.instrument_model} ${m.instrument_serial || ""}`.trim() : "";
    const taken = m.started_at ?? m.created_at;
    const took = m.started_at && m.finished_at ? duration(m.finished_at - m.started_at) : m.started_at ? "running" : "";
    // Today's times without the date (the date is in the cell's tooltip).
    for (const v of [m.id, (m.started_at ? "" : "queued ") + laterTime(Date.now() / 1000, taken), laterTime(taken, m.finished_at),
      took, m.booth, instrument, m.scene || "", m.target || "", stateText(m),
      `${m.samples_taken}/${m.samples_requested}`, fmt(m.Y, 5), fmt(m.x, 4), fmt(m.y, 4), fmt(m.luminance_cv, 2),
      m.note]) tr.insertCell().textContent = v;
    tr.cells[1].title = localTime(taken);
    const action = tr.insertCell();
    if (m.state === "queued" || m.state === "running") {
      const b = document.createElement("button");
      b.textContent = "Cancel";
      b.className = "cancel";
      b.addEventListener("click", (ev) => {
        ev.stopPropagation();
        cancelMeasurement(m.id);
      });
      action.appendChild(b);
    }
    tr.className = "clickable";
    tr.title = "open this measurement";
    tr.addEventListener("click", () => (location.hash = `#/measurements/${m.id}`));
  }
  const first = page.total ? page.offset + 1 : 0;
  $("page-info").textContent = `${first}–${page.offset + page.items.length} of ${page.total}`;
  $("page-prev").disabled = page.offset === 0;
  $("page-next").disabled = page.offset + page.items.length >= page.total;
  if (openId) showMeasurement(openId);
}

async function fillMeasurementFilter() {
  const sel = $("filter-scene");
  for (const s of sceneInfo) sel.add(new Option(s.id, s.id));
  // Every booth sharing the database; this daemon's own is marked.
  const booths = await api("/api/booths");
  const names = booths.booths.map((b) => b.booth);
  if (!names.includes(booths.this_daemon)) names.push(booths.this_daemon);
  for (const name of names.sort())
    $("filter-booth").add(new Option(name === booths.this_daemon ? `${name} (this daemon)` : name, name));
  // Every instrument model the database has seen, this daemon's included.
  const instruments = await api("/api/instruments");
  const models = new Set(instruments.known.map((i) => i.model));
  if (instruments.status && instruments.status.model) models.add(instruments.status.model);
  for (const model of [...models].sort()) $("filter-model").add(new Option(model, model));
}

for (const id of ["filter-booth", "filter-model", "filter-scene", "filter-state"]) {
  $(id).addEventListener("change", () => {
    measurementOffset = 0;
    loadMeasurements();
  });
}
$("page-prev").addEventListener("click", () => {
  measurementOffset = Math.max(0, measurementOffset - PAGE);
  loadMeasurements();
});
$("page-next").addEventListener("click", () => {
  measurementOffset += PAGE;
  loadMeasurements();
});

async function showMeasurement(id) {
  const m = await api(`/api/measurements/${id}`);
  $("measurement-detail").hidden = false;
  $("detail-title").textContent = `Measurement ${m.id}` + (m.scene ? `: ${m.scene} / ${m.target}` : "");
  const average = `Y = ${fmt(m.Y, 5)} cd/m², x = ${fmt(m.x, 4)}, y = ${fmt(m.y, 4)} (${observerName(m.observer)}), CV = ${fmt(m.luminance_cv, 2)}` +
    (m.instrument_x != null ? `; the ${m.instrument_model || "instrument"}'s own CIE 1931 values: Y = ${fmt(m.instrument_Y, 5)} cd/m², x = ${fmt(m.instrument_x, 4)}, y = ${fmt(m.instrument_y, 4)}` : "");
  $("detail-summary").textContent = (m.state === "complete" ? average
    : `${m.state}${m.error ? ": " + m.error : ""}` +
      (m.partial ? `. Partial average of ${m.good_samples} good samples: ${average}` : "")) +
    ` · queued ${localTime(m.created_at)}` +
    (m.started_at ? `, taken ${localTime(m.started_at)}` + (m.finished_at ? ` to ${localTime(m.finished_at)} (${duration(m.finished_at - m.started_at)})` : "") : "") +
    (m.hold ? ` · taken for the ${m.hold.purpose} (instrument hold ${m.hold.id})` : "") +
    (m.note ? ` · notes: ${m.note}` : "");
  showComparison($("detail-comparison"), m).catch((e) => notice(e.message));
  const spectral = hasSpectrum(m);
  $("detail-downloads").hidden = !spectral;
  $("detail-figure").hidden = !spectral;
  $("detail-no-spectrum").hidden = spectral;
  $("detail-no-spectrum").textContent = spectral ? "" : `No spectrum to chart: the ${m.instrument_model || "instrument"} ` +
    `measures ${m.XYZ != null ? "XYZ" : "luminance"} only; each sample's values are in the table below ` +
    "(CSV, MAT and the chart need a spectroradiometer).";
  for (const [el, ext] of [["detail-csv", "csv"], ["detail-mat", "mat"], ["detail-svg", "svg"]])
    $(el).href = `/api/measurements/${id}/spectrum.${ext}`;
  if (spectral) $("detail-spectrum").src = `/api/measurements/${id}/spectrum.svg?t=${Date.now()}`;
  const tbody = document.querySelector("#sample-table tbody");
  tbody.replaceChildren();
  for (const s of m.samples) {
    const tr = tbody.insertRow();
    // Numbered from 1, as the live progress counts them (the API's `index` is 0-based).
    for (const v of [s.index + 1, new Date(s.time * 1000).toLocaleTimeString(), s.code, s.message, s.usable ? "yes" : "no",
      fmt(s.Y, 5), fmt(s.instrument_Y, 4)]) tr.insertCell().textContent = v;
  }
}

$("cancel-current").addEventListener("click", () => current && cancelMeasurement(current));

// --- a measurement's comparison with every colour coding --------------------

// The boxes showing a comparison (Live, a measurement's page): box → measurement.
const comparisonBoxes = new Map();

// Shows in `box` measurement m's comparison with every colour coding of its
// scene's render (GET /api/measurements/{id}/comparisons), or, until it is
// stored, where it is and its state: none for a free measurement or one
// that did not complete; otherwise computed from the scene's render, which
// may be queued, running or failed (GET /api/scenes/{scene}/renders).
async function showComparison(box, m) {
  comparisonBoxes.set(box, m);
  box.hidden = false;
  const heading = el("h4", "Comparison with every colour coding");
  const state = (text) => {
    const p = el("p", text, "hint");
    p.dataset.comparisonState = "";
    return p;
  };
  if (!m.scene) {
    box.replaceChildren(heading, state("None: a free measurement (no scene target) has nothing to be compared with. " +
      "Choose a scene and target on Live to compare a measurement with every coding's rendering."));
    return;
  }
  if (m.state !== "complete") {
    box.replaceChildren(heading, state(`None: only a complete measurement is compared; this one is ${m.state}.`));
    return;
  }
  // A luminance meter's measurement has Y and no colour: it is compared in
  // luminance alone (GET /api/measurements/{id}/luminance-comparisons).
  const luminanceOnly = m.XYZ == null && m.x == null && m.Y != null;
  const [rows, renders] = await Promise.all([
    api(`/api/measurements/${m.id}/${luminanceOnly ? "luminance-comparisons" : "comparisons"}`),
    // A daemon without the renderer (503) lists no renders: its workers render.
    api(`/api/scenes/${encodeURIComponent(m.scene)}/renders`).catch(() => [])]);
  if (comparisonBoxes.get(box) !== m) return; // another measurement was opened meanwhile
  const sceneLink = el("a", `the scene ${m.scene}: its charts and every target`);
  sceneLink.href = `#/scenes/${encodeURIComponent(m.scene)}`;
  const model = m.instrument_model || "instrument";
  if (!rows.length) {
    const busy = renders.find((r) => r.state === "running") || renders.find((r) => r.state === "queued");
    const newest = renders[0];
    let text;
    if (busy) {
      text = `Being computed: it waits for render ${busy.id} of ${m.scene} (${busy.codings.join(", ")}), ${busy.state}; ` +
        "the comparison follows when the render completes.";
    } else if (newest && newest.state === "failed") {
      text = `Not computed: the newest render of ${m.scene} (render ${newest.id}) failed` +
        (newest.error ? `: ${newest.error}` : "") + ". Render the scene again from its page.";
    } else {
      text = `Being computed from the stored render of ${m.scene}; it appears here when it is stored.`;
    }
    const p = state(text + " ");
    p.append("See ", sceneLink, ".");
    box.replaceChildren(heading, p);
    return;
  }
  if (luminanceOnly) {
    box.replaceChildren(heading, luminanceTable(rows), luminanceNote(rows, model, sceneLink));
    return;
  }
  const t = document.createElement("table");
  t.className = "comparison-table";
  const head = t.createTHead().insertRow();
  for (const h of ["coding", "rendered Y (cd/m²)", "Y rendered / measured", "Δxy", "ΔE*ab", "ΔE00", "Y beyond noise"]) {
    head.appendChild(el("th", h));
  }
  const body = t.createTBody();
  for (const r of rows) {
    const tr = body.insertRow();
    for (const v of [r.coding, fmt(r.rendered_Y, 5), fmt(r.Y_ratio, 4), fmt(r.xy_distance, 3), fmt(r.dE76, 3),
      fmt(r.dE00, 3), r.Y_beyond_noise === null || r.Y_beyond_noise === undefined ? "–" : r.Y_beyond_noise ? "yes" : "no"]) {
      tr.insertCell().textContent = v;
    }
  }
  const r0 = rows[0];
  const note = el("p", `${rows.length} codings of render ${r0.render_id}; CIELAB white: ${r0.white_source} ` +
    `(observer: ${observerName(r0.observer)}). `, "hint");
  note.append("See ", sceneLink, ".");
  box.replaceChildren(heading, t, note);
}

// A luminance meter's comparison rows: luminances and their ratio only.
function luminanceTable(rows) {
  const t = document.createElement("table");
  t.className = "comparison-table";
  const head = t.createTHead().insertRow();
  for (const h of ["coding", "rendered Y (cd/m²)", "Y rendered / measured", "Y beyond noise"]) {
    head.appendChild(el("th", h));
  }
  const body = t.createTBody();
  for (const r of rows) {
    const tr = body.insertRow();
    for (const v of [r.coding, fmt(r.rendered_Y, 5), fmt(r.Y_ratio, 4), r.Y_beyond_noise ? "yes" : "no"]) {
      tr.insertCell().textContent = v;
    }
  }
  return t;
}

// What a luminance-only comparison is, under its table.
function luminanceNote(rows, model, sceneLink) {
  const r0 = rows[0];
  const note = el("p", `${rows.length} codings of render ${r0.render_id}, in luminance only: the ${model} ` +
    `measures luminance (${observerName(r0.observer)} ȳ), no colour, so there is no x, y or ΔE; a colorimeter ` +
    "or a spectroradiometer gives them. ", "hint");
  note.dataset.luminanceOnly = "";
  note.append("See ", sceneLink, ".");
  return note;
}

// A comparison was stored (measurement id) or a render of `scene` moved on:
// the boxes showing that measurement's comparison follow it.
function refreshComparisons(measurementId, scene) {
  for (const [box, m] of comparisonBoxes) {
    if (box.hidden || box.offsetParent === null) continue;
    if (m.id === measurementId || (scene && m.scene === scene)) showComparison(box, m).catch((e) => notice(e.message));
  }
}

// --- scenes ----------------------------------------------------------------

let openScene = null;
// The measurements "Measure every target" queued, per scene: its run's total.
const sceneRuns = new Map();

// The Scenes page: every scene at a glance (GET /api/scene-overview), or
// one scene's page when the hash names it.
async function loadScenes(openId) {
  $("scene-overview").hidden = !!openId;
  $("scene-detail").hidden = !openId;
  if (openId) return loadSceneDetail(openId);
  openScene = null;
  const [o, health] = await Promise.all([api("/api/scene-overview"), api("/api/health").catch(() => ({}))]);
  $("scene-overview-note").textContent =
    `Each scene of the booth: its camera view, how many of its targets are measured in booth ${o.booth}, and how far each ` +
    `coding's rendering is from the measurements (mean CIEDE2000 ΔE00 and rms_rel of Y over the measured targets; ` +
    `observer ${observerName(o.observer)}). Click a scene to open it.`;
  const tbody = document.querySelector("#scene-table tbody");
  tbody.replaceChildren();
  for (const s of o.scenes) {
    const tr = tbody.insertRow();
    tr.className = "clickable";
    tr.dataset.scene = s.scene;
    const name = tr.insertCell();
    const a = document.createElement("a");
    a.href = `#/scenes/${s.scene}`;
    a.textContent = s.title;
    const id = document.createElement("div");
    id.className = "hint";
    id.textContent = s.scene;
    name.append(a, id);
    const thumb = tr.insertCell();
    if (s.preview_render_id) {
      const img = document.createElement("img");
      img.className = "thumb";
      img.alt = `${s.title}: camera view of render ${s.preview_render_id} (sRGB coding)`;
      img.src = `/api/renders/${s.preview_render_id}/preview.png`;
      thumb.appendChild(img);
    } else {
      // A render makes the thumbnail (and the comparisons, once a target is measured).
      const b = jobButton("Render it", `/api/scenes/${s.scene}/renders`, () => loadScenes());
      b.title = "render the scene in every coding (it joins the queue on the home page)";
      const queued = document.createElement("div");
      queued.className = "hint";
      queued.textContent = "not rendered yet";
      thumb.append(queued, b);
    }
    const measured = tr.insertCell();
    const bar = document.createElement("progress");
    bar.max = s.targets.length;
    bar.value = s.measured.length;
    bar.className = "small";
    measured.append(`${s.measured.length} / ${s.targets.length} `, bar);
    tr.insertCell().textContent = s.last_measured_at ? localTime(s.last_measured_at) : "never";
    const figures = tr.insertCell();
    figures.className = "coding-figures";
    if (s.codings.length) figures.appendChild(codingFiguresTable(s.codings));
    else {
      const none = document.createElement("span");
      none.className = "hint";
      // Words that fit the attached instrument (issue 46: an LS-100 booth said
      // "measure a target" beside "1 / 1 measured").
      none.textContent = health.instrument_measures === "luminance" && s.measured.length
        ? `luminance only (${health.instrument_model}): the Y ratios are on each measurement's page`
        : s.measured.length ? "comparison being computed" : "no comparison yet: measure a target";
      figures.appendChild(none);
    }
    tr.addEventListener("click", (ev) => {
      if (ev.target.closest("a")) return;
      location.hash = `#/scenes/${s.scene}`;
    });
  }
}

// The three claims of a coding's figures, one cell each: whether its
// rms_rel is beyond the render's noise, the measurement's repeatability
// and the instrument's stated accuracy, and of how many targets the ΔE00
// is. "not stated" where the instrument has no accuracy on record.
function claimCells(u) {
  if (!u) return ["—", "—", "—"];
  const stated = (v) => v !== null && v !== undefined;
  return ["beyond_noise", "beyond_repeatability", "beyond_stated_accuracy"].map((claim) => {
    const rms = u.rms_rel.claims[claim];
    const made = u.targets.filter((t) => stated(t.dE00.claims[claim]));
    const beyond = made.filter((t) => t.dE00.claims[claim]).length;
    // The 95th percentile of what measurement error alone gives, beside the claim.
    const bound = { beyond_repeatability: u.rms_rel.null_95th_repeatability,
      beyond_stated_accuracy: u.rms_rel.null_95th_stated_accuracy }[claim];
    const rmsText = stated(rms) ? `rms_rel ${rms ? "yes" : "no"}` +
      (bound != null ? ` (${fmt(u.rms_rel.observed, 4)} vs ≤ ${fmt(bound, 4)})` : "") : "rms_rel: not stated";
    const deText = made.length ? `ΔE00 ${beyond} of ${u.targets.length}` : "ΔE00: not stated";
    return `${rmsText}; ${deText}`;
  });
}

// Under the coding table: how the claims were made and from what.
function uncertaintyNote(codings) {
  const u = codings.map((c) => c.uncertainty).find((x) => x);
  const why = codings.map((c) => c.uncertainty_not_propagated).find((x) => x);
  if (!u) return why ? `No intervals: ${why}.` : "";
  const a = u.stated_accuracy;
  const stated = [
    a.luminance_bound_percent != null ? `luminance ±${a.luminance_bound_percent} %` : null,
    a.chromaticity_bound_x != null ? `x ±${a.chromaticity_bound_x}` : null,
    a.chromaticity_bound_y != null ? `y ±${a.chromaticity_bound_y}` : null,
    a.wavelength_bound_nm != null ? `wavelength ±${a.wavelength_bound_nm} nm` : null,
  ].filter((x) => x);
  const rms = u.rms_rel;
  return `Beyond: the observed figure against what the measurement's error alone gives (95 %), from ${u.draws} ` +
    `seeded Monte Carlo draws (GUM Supplement 1) of each measured spectrum within its repeatability and of the ` +
    `${u.instrument_model}'s stated accuracy: ${stated.length ? stated.join(", ") : "no figure on record, so no " +
    "claim about it"}; the rest unset (source: ${a.source}). Measurement error alone gives ` +
    `rms_rel up to ${fmt(rms.null_95th_repeatability, 3)} (repeatability) and ${fmt(rms.null_95th_stated_accuracy, 3)} ` +
    "(with the stated accuracy)." +
    (u.simulated_truth_relative_se != null ? ` The simulated instrument's truth is itself a render, of relative ` +
      `standard error up to ${fmt(100 * u.simulated_truth_relative_se, 2)} % in Y: counted with the repeatability ` +
      "in every claim." : "") +
    (why ? ` Some codings have no intervals: ${why}.` : "");
}

// A compact table: one column per coding (its colour), mean ΔE00 and rms_rel rows.
function codingFiguresTable(codings) {
  const t = document.createElement("table");
  t.className = "compact";
  const head = t.createTHead().insertRow();
  head.insertCell().textContent = "";
  for (const c of codings) {
    const th = document.createElement("th");
    const swatch = document.createElement("span");
    swatch.className = "swatch";
    swatch.style.background = c.colour;
    th.append(swatch, c.coding);
    head.appendChild(th);
  }
  const body = t.createTBody();
  for (const [label, key, digits] of [["mean ΔE00", "mean_dE00", 3], ["rms_rel", "rms_rel", 2]]) {
    const tr = body.insertRow();
    tr.insertCell().textContent = label;
    for (const c of codings) tr.insertCell().textContent = fmt(c[key], digits);
  }
  const n = body.insertRow();
  n.insertCell().textContent = "targets";
  for (const c of codings) n.insertCell().textContent = c.points;
  return t;
}

// The sentence beside a scene's empty table and charts: a luminance meter
// gives no colour to compare in x, y and ΔE (its measurements' pages compare
// their luminance); otherwise nothing is compared yet, in the observer named.
// What every number of a scene's table and charts is in: the observer its
// comparisons were made in, and, where that is not the daemon's --observer,
// why (a colorimeter's XYZ or a luminance meter's Y is the instrument's own).
function comparisonObserverNote(health, observer) {
  const own = health.observer && observer !== health.observer;
  return `Every ΔE, x, y and Y below is in the ${observerName(observer)} observer` +
    (own ? `: the ${health.instrument_model}'s own, in which it gives its ${health.instrument_measures}; the daemon's ` +
      `--observer (${observerName(health.observer)}) applies to what it computes from spectra.` : ".");
}

function noComparisonReason(health, observer) {
  if (health.instrument_measures === "luminance")
    return `No colour comparison: the ${health.instrument_model} measures luminance only (${observerName(observer)} ` +
      "V(λ)), so there is no x, y or ΔE to tabulate or chart here. Each of its measurements' pages compares its " +
      "luminance with every coding (the Y ratio); a colorimeter or a spectroradiometer gives the colour comparison.";
  return `No comparison yet: measure a target of this scene; its comparison with every coding, in the ` +
    `${observerName(observer)} observer, appears here once stored.`;
}

async function loadSceneDetail(id) {
  openScene = id;
  const s = sceneInfo.find((x) => x.id === id);
  $("scene-detail").hidden = false;
  $("scene-title").textContent = s ? `${s.id}: ${s.title}` : id;
  // The previous scene's camera view and caption go with its title, at
  // once: not only after this scene's answers arrive (a test that read the
  // caption right after the title changed saw the old one on a busy machine).
  $("scene-preview").hidden = true;
  $("scene-preview").onload = null;
  $("preview-caption").textContent = "";
  $("preview-scale").replaceChildren();
  $("scene-csv").href = `/api/scenes/${id}/comparisons.csv`;
  $("scene-mat").href = `/api/scenes/${id}/comparisons.mat`;
  const c = await api(`/api/scenes/${id}/comparisons`);
  if (openScene !== id) return; // another scene was opened meanwhile
  const tbody = document.querySelector("#coding-table tbody");
  tbody.replaceChildren();
  for (const r of c.codings) {
    const tr = tbody.insertRow();
    for (const v of [r.coding, r.points, fmt(r.rms_rel), `${fmt(r.mean_dE76)} ± ${fmt(r.sd_dE76, 2)}`,
      `${fmt(r.mean_dE00)} ± ${fmt(r.sd_dE00, 2)}`, fmt(r.mean_Y_ratio, 4),
      ...claimCells(r.uncertainty)]) tr.insertCell().textContent = v;
  }
  $("coding-uncertainty-note").textContent = uncertaintyNote(c.codings);
  const health = await api("/api/health").catch(() => ({}));
  if (openScene !== id) return;
  $("coding-observer").textContent = c.rows.length ? comparisonObserverNote(health, c.observer) : "";
  // Why the table and charts are empty, when they are.
  const why = c.rows.length ? "" : noComparisonReason(health, c.observer);
  $("scene-no-comparison").hidden = !why;
  $("scene-no-comparison").textContent = why;
  const renders = await api(`/api/scenes/${id}/renders`);
  if (openScene !== id) return;
  showRenderJobs(renders);
  const done = renders.find((r) => r.state === "complete");
  $("scene-viewer-link").href = `#/viewer/${id}`;
  updateSceneProgress();
  showMissingTargets(id).catch((e) => notice(e.message));
  const preview = $("scene-preview");
  preview.hidden = !done;
  // Never leave the previous scene's caption under this one, nor let its
  // image, loading late, write one.
  preview.onload = null;
  $("preview-caption").textContent = done ? "" : "No complete render of this scene yet: no camera view.";
  if (done) {
    // Paths per pixel as the daemon chooses them (lightbooth_render::sensor::preview_spp):
    // a 20 million path budget over the pixels, 16 to 1024.
    preview.onload = () => {
      if (openScene !== id) return;
      const key = done.result && done.result.preview && done.result.preview.log_average_cd_m2;
      $("preview-scale").replaceChildren(...(key ? [luminanceScale(key, "sRGB coding")] : []));
      const spp = Math.min(1024, Math.max(16, Math.floor(20e6 / (preview.naturalWidth * preview.naturalHeight))));
      $("preview-caption").textContent =
        `Camera view of render ${done.id} (sRGB coding, ${spp} paths per pixel, not denoised). ` +
        `Render: ${done.codings.join(", ")}; ${fmt(done.wall_seconds, 3)} s`;
    };
    preview.src = `/api/renders/${done.id}/preview.png`;
  }
  const t = Date.now();
  for (const chart of ["chromaticity", "profile", "rms", "de", "speed"]) {
    const img = $("chart-" + chart);
    img.hidden = c.rows.length === 0;
    if (c.rows.length) img.src = `/api/scenes/${id}/charts/${chart}.svg?t=${t}`;
  }
}

// The scene's renders still queued or running, each with a Cancel button.
function showRenderJobs(renders) {
  const list = $("scene-jobs");
  list.replaceChildren();
  for (const r of renders.filter((r) => r.state === "queued" || r.state === "running")) {
    const li = document.createElement("li");
    li.textContent = `render ${r.id} (${r.codings.join(", ")}): ${r.state} `;
    li.appendChild(jobButton("Cancel", `/api/renders/${r.id}/cancel`, () => loadSceneDetail(r.scene)));
    list.appendChild(li);
  }
}

// The open scene's targets with no complete measurement in this booth and
// none queued or running: a target on its way is not offered again (the
// page once offered "the 17 targets not yet measured" beside 17 of them
// waiting, and one click queued each twice).
let openSceneMissing = [];
async function showMissingTargets(id) {
  const s = sceneInfo.find((x) => x.id === id);
  const booths = await api("/api/booths");
  const inState = (state) => api(`/api/measurements?scene=${encodeURIComponent(id)}&state=${state}&limit=1000&booth=${encodeURIComponent(booths.this_daemon)}`);
  const [done, queued, running] = await Promise.all([inState("complete"), inState("queued"), inState("running")]);
  if (openScene !== id || !s) return;
  const onTheirWay = new Set([...queued.items, ...running.items].map((m) => m.target));
  const unmeasured = s.targets.filter((t) => !done.items.some((m) => m.target === t));
  openSceneMissing = unmeasured.filter((t) => !onTheirWay.has(t));
  const coming = unmeasured.length - openSceneMissing.length;
  const b = $("measure-missing");
  b.hidden = !openSceneMissing.length || openSceneMissing.length === s.targets.length;
  b.textContent = `Measure the ${count(openSceneMissing.length, "target")} not yet measured` + (coming ? ` and not on their way` : "");
  $("scene-on-their-way").textContent = coming
    ? `${coming} not yet measured ${coming === 1 ? "is" : "are"} on their way (queued or being measured).`
    : "";
  $("measure-scene").textContent = unmeasured.length < s.targets.length ? "Measure every target again" : "Measure every target";
}

$("measure-scene").addEventListener("click", () => {
  const s = sceneInfo.find((x) => x.id === openScene);
  if (s) measureTargets(s, s.targets);
});
$("measure-missing").addEventListener("click", () => {
  const s = sceneInfo.find((x) => x.id === openScene);
  if (s) measureTargets(s, openSceneMissing);
});

async function measureTargets(s, targets) {
  notice("");
  const run = { ids: [] };
  sceneRuns.set(s.id, run);
  let already = 0;
  try {
    for (const target of targets) {
      // The daemon queues nothing for a target already on its way
      // (`duplicate`): the run follows that measurement instead.
      const r = await startMeasurement({ scene: s.id, target, samples: 5 });
      if (r.duplicate) already += 1;
      run.ids.push(r.id);
      current = r.id;
    }
    if (already) notice(`${count(already, "target")} already on ${already === 1 ? "its" : "their"} way: not queued again.`);
  } catch (e) {
    notice(e.message);
  }
  updateSceneProgress();
  showMissingTargets(s.id).catch(() => {});
}

// The scene's measurements waiting or under way (from any page or client,
// GET /api/jobs), with the time left; the run this page started as a bar.
let sceneProgressBusy = false;
async function updateSceneProgress() {
  const scene = openScene;
  if (!scene || sceneProgressBusy) return;
  sceneProgressBusy = true;
  try {
    const q = await api("/api/jobs");
    if (scene !== openScene) return;
    const mine = q.jobs.filter((j) => j.kind === "measurement" && j.scene === scene);
    const run = sceneRuns.get(scene);
    const bar = $("scene-run-progress");
    $("cancel-scene-run").hidden = mine.length === 0;
    if (!mine.length) {
      bar.hidden = true;
      if (run && run.ids.length && !run.reported) {
        run.reported = true;
        showMissingTargets(scene).catch(() => {});
        $("scene-progress").textContent = run.cancelled
          ? `cancelled ${count(run.cancelled, "measurement")} (one under way keeps the samples it took, marked partial); ` +
            `the ${run.ids.length - run.cancelled} taken before are kept.`
          : `all ${run.ids.length} targets measured.`;
      } else if (!run) $("scene-progress").textContent = "";
      return;
    }
    const last = mine[mine.length - 1];
    const left = last.seconds_left === null ? "" : `; about ${duration(last.seconds_left)} left (${last.estimate})`;
    const running = mine.find((j) => j.state === "running");
    if (run && run.ids.length) {
      const waiting = run.ids.filter((id) => mine.some((j) => j.id === id)).length;
      bar.hidden = false;
      bar.max = run.ids.length;
      bar.value = run.ids.length - waiting;
      $("scene-progress").textContent = `${run.ids.length - waiting} of ${run.ids.length} targets measured` +
        (running ? `, now ${running.what.split(",")[0]} (sample ${running.done + 1} of ${running.total})` : "") + left;
    } else {
      bar.hidden = true;
      $("scene-progress").textContent = `${count(mine.length, "measurement")} of this scene waiting or under way` + left;
    }
  } catch (e) {
    notice(e.message);
  } finally {
    sceneProgressBusy = false;
  }
}

// Cancels every measurement of the open scene still waiting or under way;
// the ones taken are kept (and a running one keeps its samples, marked partial).
$("cancel-scene-run").addEventListener("click", async () => {
  notice("");
  const scene = openScene;
  const q = await api("/api/jobs");
  const mine = q.jobs.filter((j) => j.kind === "measurement" && j.scene === scene);
  // The queued ones first, so the instrument does not take the next up meanwhile.
  mine.sort((a, b) => (a.state === "queued" ? 0 : 1) - (b.state === "queued" ? 0 : 1));
  let cancelled = 0;
  for (const j of mine) {
    try {
      await api(`/api/measurements/${j.id}/cancel`, { method: "POST", body: "{}" });
      cancelled += 1;
    } catch (e) {
      // It finished meanwhile: kept.
    }
  }
  const run = sceneRuns.get(scene) || { ids: mine.map((j) => j.id) };
  run.cancelled = cancelled;
  run.reported = false;
  sceneRuns.set(scene, run);
  updateSceneProgress();
});
setInterval(() => { if (openScene && !$("cancel-scene-run").hidden) updateSceneProgress(); }, 2000);

// --- study -----------------------------------------------------------------

// The study's five booth scenes (Ruppertsberg & Bloj 2006): the form's default.
const STUDY_SCENES = ["white", "red", "green", "blue", "cylinder"];
const STUDY_FORM_KEY = "lightbooth-study-request";

function fillStudyScenes() {
  const box = $("study-scenes");
  for (const s of sceneInfo) {
    const label = document.createElement("label");
    const input = document.createElement("input");
    input.type = "checkbox";
    input.value = s.id;
    input.checked = STUDY_SCENES.includes(s.id);
    label.append(input, ` ${s.id}`);
    box.appendChild(label);
  }
  // The last request started from this browser, if any.
  const last = JSON.parse(localStorage.getItem(STUDY_FORM_KEY) || "null");
  if (last) {
    const scenes = (last.scenes || "").split(",");
    for (const i of box.querySelectorAll("input")) i.checked = scenes.includes(i.value);
    $("study-against").value = last.against || "measurements";
    $("study-seeds").value = last.seeds || 2;
    $("study-sweeps").checked = !!last.sweeps;
    $("study-failure").checked = !!last.failure_map;
    $("study-auto").value = last.auto || "";
    $("study-measure-missing").checked = last.measure_missing !== false;
  }
  for (const el of $("study-form").querySelectorAll("input, select")) el.addEventListener("change", planStudy);
}

function studyRequest() {
  const scenes = [...document.querySelectorAll("#study-scenes input:checked")].map((i) => i.value);
  const body = {
    scenes: scenes.join(","),
    against: $("study-against").value,
    seeds: Number($("study-seeds").value),
    sweeps: $("study-sweeps").checked,
    failure_map: $("study-failure").checked,
  };
  if ($("study-auto").value.trim()) body.auto = $("study-auto").value.trim();
  if (body.against === "measurements" && $("study-measure-missing").checked) body.measure_missing = true;
  return body;
}

// Before it starts: what the study will measure first and roughly how long
// that takes (the instrument's pace, GET /api/jobs), and how long the
// rendering took last time per scene and seed.
async function planStudy() {
  const body = studyRequest();
  const scenes = body.scenes ? body.scenes.split(",") : [];
  if (!scenes.length) {
    $("study-plan").textContent = "Choose at least one scene.";
    return;
  }
  // Never an empty box while the plan is fetched (the scene overview can take seconds).
  if (!$("study-plan").textContent) $("study-plan").textContent = "Planning the study…";
  try {
    const [overview, jobs, health, studies] = await Promise.all([api("/api/scene-overview"), api("/api/jobs"),
      api("/api/health"), api("/api/studies")]);
    const parts = [];
    if (body.against === "measurements") {
      const missing = overview.scenes.filter((s) => scenes.includes(s.scene))
        .reduce((n, s) => n + s.targets.length - s.measured.length, 0);
      if (missing && body.measure_missing) {
        const pace = jobs.seconds_per_sample;
        parts.push(`First it measures the ${count(missing, "target")} with no complete measurement, ${count(health.default_samples, "sample")} each` +
          (pace ? `: about ${duration(missing * health.default_samples * pace)} at ${fmt(pace, 2)} s per sample (${jobs.pace_source}).`
            : " (no measurement yet to time the instrument by)."));
      } else if (missing) {
        parts.push(`${count(missing, "target")} ${missing === 1 ? "has" : "have"} no complete measurement: the study will refuse to start; tick “measure missing targets first”.`);
      } else parts.push("Every target of these scenes is measured: it renders at once.");
    } else parts.push("Against the converged spectral reference: no measurement needed.");
    // Rendering: the last complete study's seconds per scene and seed.
    const done = studies.find((st) => st.state === "complete" && st.wall_seconds && st.request && st.request.seeds);
    const units = scenes.length * body.seeds;
    if (done) {
      const doneUnits = (done.request.scenes || "").split(",").filter(Boolean).length * done.request.seeds || 1;
      const extra = (body.sweeps && !done.request.sweeps) || (body.failure_map && !done.request.failure_map) ? " (more with sweeps or failure maps than that study had)" : "";
      parts.push(`Then it renders ${count(scenes.length, "scene")} × ${count(body.seeds, "seed")}: about ${duration(done.wall_seconds / doneUnits * units)}, ` +
        `from study ${done.id} (${fmt(done.wall_seconds, 3)} s for ${doneUnits} scene-seeds)${extra}.`);
    } else {
      parts.push(`Then it renders ${count(scenes.length, "scene")} × ${count(body.seeds, "seed")}; no earlier study to time that by.`);
    }
    $("study-plan").textContent = parts.join(" ");
  } catch (e) {
    $("study-plan").textContent = `No plan: ${e.message}. The study can still be started; the daemon checks it.`;
  }
}

$("study-form").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  notice("");
  const body = studyRequest();
  try {
    const r = await api("/api/studies", { method: "POST", body: JSON.stringify(body) });
    localStorage.setItem(STUDY_FORM_KEY, JSON.stringify(Object.assign({}, body, { measure_missing: $("study-measure-missing").checked })));
    $("study-progress").textContent = `study ${r.id}: queued`;
    loadStudies();
  } catch (e) {
    notice(e.message);
  }
});

async function loadStudies(openId) {
  const list = await api("/api/studies");
  const tbody = document.querySelector("#study-table tbody");
  tbody.replaceChildren();
  for (const st of list) {
    const tr = tbody.insertRow();
    for (const v of [st.id, st.state + (st.error ? ": " + st.error : "")]) tr.insertCell().textContent = v;
    // Cancel a study still queued or running; retry one that did not complete.
    const actions = tr.insertCell();
    if (st.state === "queued" || st.state === "running") {
      actions.appendChild(jobButton("Cancel", `/api/studies/${st.id}/cancel`, () => loadStudies()));
    } else if (st.state !== "complete") {
      actions.appendChild(jobButton("Retry", `/api/studies/${st.id}/retry`, () => loadStudies()));
    }
    for (const v of [new Date(st.created_at * 1000).toLocaleString(), fmt(st.wall_seconds, 3)])
      tr.insertCell().textContent = v;
    // The request folded away: a summary line, the JSON on demand.
    const details = document.createElement("details");
    const summary = document.createElement("summary");
    const r = st.request || {};
    summary.textContent = [r.scenes, r.against, r.seeds ? `${r.seeds} seeds` : ""].filter(Boolean).join(" · ") || "request";
    const pre = document.createElement("pre");
    pre.textContent = JSON.stringify(st.request, null, 2);
    details.append(summary, pre);
    details.addEventListener("click", (e) => e.stopPropagation());
    tr.insertCell().appendChild(details);
    tr.className = "clickable";
    tr.title = "open this study's figures";
    tr.addEventListener("click", () => (location.hash = `#/study/${st.id}`));
  }
  // A study already running when the page opened: its step and time left
  // now, not at its next progress event (a step can take half the run).
  const running = list.find((st) => st.state === "running");
  if (running && (!studyRunning || studyRunning.study_id !== running.id)) {
    api("/api/jobs").then((q) => {
      const j = q.jobs.find((x) => x.kind === "study" && x.id === running.id);
      if (!j || (studyRunning && studyRunning.study_id === running.id)) return;
      studyRunning = { study_id: running.id, message: j.step || j.what || "running" };
      studyEstimates.set(running.id, { seconds_left: j.seconds_left, done: j.done, at: Date.now() / 1000 });
      $("study-progress").textContent = `study ${running.id}: ${studyRunning.message}` + studyTimeLeft(running.id);
    }).catch(() => {});
  }
  if (openId) showStudy(openId);
  planStudy();
}

function chartFigure(src, alt) {
  const fig = document.createElement("figure");
  // The x,y diagram has two panels: give it the whole row.
  if (/chromaticity/.test(src)) fig.className = "wide";
  const img = document.createElement("img");
  img.alt = alt;
  img.src = src;
  fig.appendChild(img);
  return fig;
}

async function showStudy(id) {
  const st = await api(`/api/studies/${id}`);
  $("study-detail").hidden = false;
  $("study-title").textContent = `Study ${st.id}: ${st.state}` + (st.error ? ` (${st.error})` : "");
  // Only a finished study has a report: no links that lead nowhere.
  const files = st.files || [];
  const links = $("study-links");
  links.hidden = !files.includes("index.html");
  $("study-report").href = `/api/studies/${id}/files/index.html`;
  $("study-figures").href = `/api/studies/${id}/files/figures.csv`;
  const summary = $("study-summary");
  summary.replaceChildren();
  const charts = $("study-charts");
  charts.replaceChildren();
  const svgs = files.filter((f) => f.endsWith(".svg"));
  const shown = new Set();
  for (const s of st.result ? st.result.scenes : []) {
    // One section per scene: heading, table, its charts.
    const section = document.createElement("section");
    section.className = "study-scene";
    const h = document.createElement("h4");
    h.textContent = `${s.title} (${s.scene})`;
    const white = document.createElement("p");
    white.textContent = `CIELAB white: ${s.white_source}.`;
    section.append(h, white);
    const t = document.createElement("table");
    const headRow = t.createTHead().insertRow();
    for (const label of ["coding", "rms_rel ± SD (seeds)", "mean ΔE*ab ± SD (seeds)", "SD over targets", "mean ΔE00",
      "beyond noise"]) {
      const th = document.createElement("th");
      th.textContent = label;
      headRow.appendChild(th);
    }
    const body = t.createTBody();
    for (const c of s.codings) {
      const tr = body.insertRow();
      for (const v of [c.coding, `${fmt(c.rms_rel.mean)} ± ${fmt(c.rms_rel.sd, 2)}`,
        `${fmt(c.mean_dE76.mean)} ± ${fmt(c.mean_dE76.sd, 2)}`, fmt(c.sd_dE76_over_targets),
        fmt(c.mean_dE00.mean), `${c.significant_targets} of ${s.targets.length}`]) tr.insertCell().textContent = v;
    }
    section.appendChild(t);
    if (s.auto) {
      const p = document.createElement("p");
      const c = s.auto.choice, v = s.auto.verification;
      p.textContent = `Automatic: ${c.coding}, ${c.bounces} bounces, ${c.samples} paths per target — rms_rel ${fmt(v.rms_rel)}, ` +
        `mean ΔE00 ${fmt(v.mean_de00)} (${v.meets ? "meets" : "misses"} the tolerance). ` + c.reasons.join(" ");
      section.appendChild(p);
    }
    const grid = document.createElement("div");
    grid.className = "charts";
    for (const f of svgs.filter((f) => f.startsWith(s.scene + "_"))) {
      grid.appendChild(chartFigure(`/api/studies/${id}/files/${f}`, `${s.title}: ${f}`));
      shown.add(f);
    }
    section.appendChild(grid);
    summary.appendChild(section);
  }
  const rest = svgs.filter((f) => !shown.has(f));
  if (rest.length) {
    const h = document.createElement("h4");
    h.textContent = "Where codings fail";
    charts.appendChild(h);
    const grid = document.createElement("div");
    grid.className = "charts";
    for (const f of rest) grid.appendChild(chartFigure(`/api/studies/${id}/files/${f}`, f));
    charts.appendChild(grid);
  }
}

// --- start -----------------------------------------------------------------

// The token from the printed URL (#token=…) opens the home page; the
// navigation bar; then, after the read cookie (off loopback, <img>s and the
// event stream need it), the event stream and the view the hash names.
const readCredential = startPage({ hashAfter: "#/home" });
showNavigation();
readCredential.then(() => {
  follow();
  loadSceneChoices().then(() => {
    fillStudyScenes();
    fillMeasurementFilter().catch((e) => notice(e.message));
    showView();
  });
});
