// lightbooth dashboard: plain JavaScript, no build step. Charts are SVG drawn
// by the daemon (plotters), so this file only fetches JSON, follows the
// server-sent events and swaps <img> sources.
"use strict";

const $ = (id) => document.getElementById(id);

// The write token: the daemon prints a URL with `#token=…`; keep it in
// localStorage so reloading the page keeps working.
(function takeTokenFromUrl() {
  const m = location.hash.match(/token=([0-9A-Za-z_-]+)/);
  if (m) {
    localStorage.setItem("lightbooth-token", m[1]);
    history.replaceState(null, "", location.pathname + "#/live");
  }
})();

function token() {
  return localStorage.getItem("lightbooth-token") || "";
}

// Bound off loopback, reads need a token too. fetch() sends the write token
// in the Authorization header (below); chart <img>s, download links and the
// event stream (EventSource) cannot set headers, so the page asks the daemon
// (with the header) for a read-only cookie: HttpOnly, SameSite=Strict, for
// /api, named after the daemon's port, holding a read token the daemon
// derives for this run. The write token never goes in a cookie (cookies are
// not bound to a port: any other local service under /api would receive
// it); see src/service/auth.rs. A cookie of older versions is deleted.
document.cookie = "lightbooth_token=; path=/api; max-age=0; SameSite=Strict";
const readCredential = token()
  ? fetch("/api/read-cookie", { method: "POST", headers: { "Authorization": "Bearer " + token() } })
    .then((r) => { if (!r.ok) throw new Error(`the daemon refused the token (HTTP ${r.status}): open the URL it printed`); })
    .catch((e) => notice(e.message))
  : Promise.resolve();

function notice(text) {
  const n = $("notice");
  n.textContent = text;
  n.hidden = !text;
}

async function api(path, options = {}) {
  const headers = Object.assign({ "Accept": "application/json" }, options.headers || {});
  if (options.body !== undefined) headers["Content-Type"] = "application/json";
  if (token()) headers["Authorization"] = "Bearer " + token();
  const r = await fetch(path, Object.assign({}, options, { headers }));
  const body = await r.json().catch(() => null);
  if (!r.ok) {
    const msg = body && body.error ? body.error.message : r.statusText;
    throw new Error(msg);
  }
  return body;
}

const fmt = (v, digits = 3) => (v === null || v === undefined ? "–" : Number(v).toPrecision(digits));

// --- views -----------------------------------------------------------------

function showView() {
  const [, view, arg] = (location.hash || "#/live").split("/");
  for (const s of document.querySelectorAll(".view")) s.hidden = s.id !== "view-" + (view || "live");
  for (const a of document.querySelectorAll("nav a")) a.classList.toggle("active", a.dataset.view === view);
  if (view === "measurements") loadMeasurements(arg);
  if (view === "scenes") loadScenes(arg);
  if (view === "study") loadStudies(arg);
}
window.addEventListener("hashchange", showView);

// --- instrument status and events ------------------------------------------

let current = null; // the measurement this page started and is following

function setStatus(s) {
  const b = $("instrument");
  b.className = "badge " + s.state;
  if (s.state === "idle") b.textContent = `${s.model} ${s.serial || ""} idle on ${s.port}`;
  else if (s.state === "measuring") b.textContent = `measuring #${s.measurement_id}: sample ${s.sample} of ${s.of}`;
  else if (s.state === "disconnected") b.textContent = "disconnected: " + s.reason;
  else b.textContent = "error: " + s.message;
}

function follow() {
  const es = new EventSource("/api/events");
  es.addEventListener("instrument_status", (e) => setStatus(JSON.parse(e.data).status));
  es.addEventListener("measurement_queued", () => {
    if (location.hash.startsWith("#/measurements")) loadMeasurements();
  });
  es.addEventListener("measurement_started", (e) => {
    const d = JSON.parse(e.data);
    if (location.hash.startsWith("#/measurements")) loadMeasurements();
    if (d.measurement_id !== current) return;
    $("progress").max = d.samples;
    $("progress").value = 0;
    $("progress-text").textContent = `measurement #${d.measurement_id}: starting`;
  });
  es.addEventListener("sample", (e) => {
    const d = JSON.parse(e.data);
    if (location.hash.startsWith("#/measurements")) loadMeasurements();
    if (d.measurement_id !== current) return;
    const done = Math.min(d.index + 1, d.of);
    $("progress").max = d.of;
    $("progress").value = done;
    $("progress-text").textContent =
      `measurement #${d.measurement_id}: sample ${done} of ${d.of} (code ${d.code}: ${d.message})`;
    refreshLiveSpectrum();
  });
  es.addEventListener("measurement_finished", async (e) => {
    const d = JSON.parse(e.data);
    if (d.measurement_id === current) {
      $("cancel-current").hidden = true;
      $("progress-text").textContent = `measurement #${d.measurement_id}: ${d.state}` + (d.error ? ` (${d.error})` : "");
      refreshLiveSpectrum();
      const m = await api(`/api/measurements/${d.measurement_id}`);
      $("live-result").textContent = m.state === "complete"
        ? `Y = ${fmt(m.Y, 5)} cd/m², x = ${fmt(m.x, 4)}, y = ${fmt(m.y, 4)} (${observerName(m.observer)}), luminance CV = ${fmt(m.luminance_cv, 2)}`
        : `${m.state}: ${m.error || ""}` + (m.partial ? ` (partial average of ${m.good_samples}: Y = ${fmt(m.Y, 5)} cd/m²)` : "");
    }
    // The measurement table follows every state change (queued, cancelled, finished).
    if (location.hash.startsWith("#/measurements")) loadMeasurements();
    if (scenesQueue.length && d.measurement_id === scenesQueue[0]) scenesQueue.shift();
    updateSceneProgress();
  });
  for (const name of ["render_started", "render_finished"]) {
    es.addEventListener(name, (e) => {
      const d = JSON.parse(e.data);
      if (openScene === d.scene) loadSceneDetail(d.scene);
    });
  }
  es.addEventListener("comparison_ready", (e) => {
    const d = JSON.parse(e.data);
    if (openScene === d.scene) loadSceneDetail(d.scene);
  });
  es.addEventListener("study_progress", (e) => {
    const d = JSON.parse(e.data);
    $("study-progress").textContent = `study ${d.study_id}: ${d.message}`;
  });
  es.addEventListener("study_finished", (e) => {
    const d = JSON.parse(e.data);
    $("study-progress").textContent = `study ${d.study_id}: ${d.ok ? "complete" : "did not complete: " + d.error}`;
    if (location.hash.startsWith("#/study")) loadStudies(String(d.study_id));
  });
  es.onerror = () => setStatus({ state: "disconnected", reason: "lost the event stream; retrying" });
}

function refreshLiveSpectrum() {
  const img = $("live-spectrum");
  img.hidden = false;
  img.src = `/api/measurements/${current}/spectrum.svg?t=${Date.now()}`;
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
  sel.innerHTML = "";
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

// Local date and time of a POSIX-seconds timestamp (the API keeps seconds, UTC).
const localTime = (t) => (t === null || t === undefined ? "" : new Date(t * 1000).toLocaleString());

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

// The observer of lightbooth's x, y as a person reads it.
function observerName(o) {
  return { "judd-vos-1978": "Judd–Vos 1978 2°", "cie-1931": "CIE 1931 2°" }[o] || "observer not recorded";
}

async function loadMeasurements(openId) {
  const page = await api(`/api/measurements?${measurementQuery()}`);
  const named = page.items.find((m) => m.observer);
  $("observer-note").textContent = named
    ? `x, y: computed by lightbooth from each spectrum with the ${observerName(named.observer)} observer ` +
      "(the daemon's --observer); the instrument's own CIE 1931 x, y are on each measurement's page."
    : "";
  const tbody = document.querySelector("#measurement-table tbody");
  tbody.innerHTML = "";
  for (const m of page.items) {
    const tr = tbody.insertRow();
    tr.dataset.id = m.id;
    const instrument = m.instrument_model ? `${m.instrument_model} ${m.instrument_serial || ""}`.trim() : "";
    for (const v of [m.id, localTime(m.created_at), m.booth, instrument, m.scene || "", m.target || "", stateText(m),
      `${m.samples_taken}/${m.samples_requested}`, fmt(m.Y, 5), fmt(m.x, 4), fmt(m.y, 4), fmt(m.luminance_cv, 2),
      m.note]) tr.insertCell().textContent = v;
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
    ` · ${localTime(m.created_at)}` + (m.note ? ` · notes: ${m.note}` : "");
  for (const [el, ext] of [["detail-csv", "csv"], ["detail-mat", "mat"], ["detail-svg", "svg"]])
    $(el).href = `/api/measurements/${id}/spectrum.${ext}`;
  $("detail-spectrum").src = `/api/measurements/${id}/spectrum.svg?t=${Date.now()}`;
  const tbody = document.querySelector("#sample-table tbody");
  tbody.innerHTML = "";
  for (const s of m.samples) {
    const tr = tbody.insertRow();
    for (const v of [s.index, new Date(s.time * 1000).toLocaleTimeString(), s.code, s.message, s.usable ? "yes" : "no",
      fmt(s.Y, 5), fmt(s.instrument_Y, 4)]) tr.insertCell().textContent = v;
  }
}

$("cancel-current").addEventListener("click", () => current && cancelMeasurement(current));

// --- scenes ----------------------------------------------------------------

let openScene = null;
let scenesQueue = [];

async function loadScenes(openId) {
  const list = $("scene-list");
  list.innerHTML = "";
  for (const s of sceneInfo) {
    const li = document.createElement("li");
    const a = document.createElement("a");
    a.href = `#/scenes/${s.id}`;
    a.textContent = `${s.id}: ${s.title} (${s.targets.length} target${s.targets.length > 1 ? "s" : ""})`;
    li.appendChild(a);
    list.appendChild(li);
  }
  if (openId) loadSceneDetail(openId);
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
  $("scene-csv").href = `/api/scenes/${id}/comparisons.csv`;
  $("scene-mat").href = `/api/scenes/${id}/comparisons.mat`;
  const c = await api(`/api/scenes/${id}/comparisons`);
  if (openScene !== id) return; // another scene was opened meanwhile
  const tbody = document.querySelector("#coding-table tbody");
  tbody.innerHTML = "";
  for (const r of c.codings) {
    const tr = tbody.insertRow();
    for (const v of [r.coding, r.points, fmt(r.rms_rel), `${fmt(r.mean_dE76)} ± ${fmt(r.sd_dE76, 2)}`,
      `${fmt(r.mean_dE00)} ± ${fmt(r.sd_dE00, 2)}`, fmt(r.mean_Y_ratio, 4)]) tr.insertCell().textContent = v;
  }
  const renders = await api(`/api/scenes/${id}/renders`);
  if (openScene !== id) return;
  showRenderJobs(renders);
  const done = renders.find((r) => r.state === "complete");
  if (viewerRender?.id !== done?.id) openImageViewer(done || null); // web/viewer.js
  const preview = $("scene-preview");
  preview.hidden = !done;
  // Never leave the previous scene's caption under this one, nor let its
  // image, loading late, write one.
  preview.onload = null;
  $("preview-caption").textContent = done ? "" : "No complete render of this scene yet: no camera view.";
  if (done) {
    // Paths per pixel as the daemon chooses them (src/render/sensor.rs,
    // preview_spp): a 20 million path budget over the pixels, 16 to 1024.
    preview.onload = () => {
      if (openScene !== id) return;
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

// A button that POSTs to a job's action (cancel, retry) and then refreshes.
function jobButton(label, path, then) {
  const b = document.createElement("button");
  b.textContent = label;
  b.addEventListener("click", async (ev) => {
    ev.stopPropagation();
    notice("");
    try {
      await api(path, { method: "POST", body: "{}" });
    } catch (e) {
      notice(e.message);
    }
    then();
  });
  return b;
}

// The scene's renders still queued or running, each with a Cancel button.
function showRenderJobs(renders) {
  const list = $("scene-jobs");
  list.innerHTML = "";
  for (const r of renders.filter((r) => r.state === "queued" || r.state === "running")) {
    const li = document.createElement("li");
    li.textContent = `render ${r.id} (${r.codings.join(", ")}): ${r.state} `;
    li.appendChild(jobButton("Cancel", `/api/renders/${r.id}/cancel`, () => loadSceneDetail(r.scene)));
    list.appendChild(li);
  }
}

$("measure-scene").addEventListener("click", async () => {
  notice("");
  const s = sceneInfo.find((x) => x.id === openScene);
  if (!s) return;
  try {
    for (const target of s.targets) {
      const r = await startMeasurement({ scene: s.id, target, samples: 5 });
      scenesQueue.push(r.id);
      current = r.id;
    }
  } catch (e) {
    notice(e.message);
  }
  updateSceneProgress();
});

function updateSceneProgress() {
  $("scene-progress").textContent = scenesQueue.length ? `${scenesQueue.length} measurement(s) to go` : "";
}

// --- study -----------------------------------------------------------------

function fillStudyScenes() {
  const box = $("study-scenes");
  for (const s of sceneInfo) {
    const label = document.createElement("label");
    label.innerHTML = `<input type="checkbox" value="${s.id}" checked> ${s.id}`;
    box.appendChild(label);
  }
}

$("study-form").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  notice("");
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
  try {
    const r = await api("/api/studies", { method: "POST", body: JSON.stringify(body) });
    $("study-progress").textContent = `study ${r.id}: queued`;
    loadStudies();
  } catch (e) {
    notice(e.message);
  }
});

async function loadStudies(openId) {
  const list = await api("/api/studies");
  const tbody = document.querySelector("#study-table tbody");
  tbody.innerHTML = "";
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
    tr.addEventListener("click", () => (location.hash = `#/study/${st.id}`));
  }
  if (openId) showStudy(openId);
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
  summary.innerHTML = "";
  const charts = $("study-charts");
  charts.innerHTML = "";
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
    t.innerHTML = "<thead><tr><th>coding</th><th>rms_rel ± SD (seeds)</th><th>mean ΔE*ab ± SD (seeds)</th><th>SD over targets</th><th>mean ΔE00</th><th>beyond noise</th></tr></thead>";
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

// After the read cookie (off loopback, <img>s and the event stream need it).
readCredential.then(() => {
  follow();
  loadSceneChoices().then(() => {
    fillStudyScenes();
    fillMeasurementFilter().catch((e) => notice(e.message));
    showView();
  });
});
