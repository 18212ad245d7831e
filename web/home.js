// The home page: where are we? The instrument and the measurement under
// way (samples, time left, Cancel), the queue of every job of this booth
// from any page or client (GET /api/jobs), the booth and the observer, and
// what to do next (targets not yet measured, the display profile's age).
// app.js shows it (showHome) when the hash names it.
import { $, api, duration, fmt, jobButton, laterTime, localTime, notice, observerName, onLabEvent } from "./shared.js";

// A display profile older than this is called stale on the home page (CRT
// phosphors and LCD backlights drift; labs recalibrate weekly).
const PROFILE_STALE_DAYS = 7;

let queue = null; // the newest GET /api/jobs, with the local time it arrived
let instrumentNow = null; // the newest instrument status
let homeTimer = null;

// A job's page and its cancel action.
function jobLink(j) {
  switch (j.kind) {
    case "measurement": return `#/measurements/${j.id}`;
    case "render": return `#/scenes/${j.scene}`;
    case "study": return `#/study/${j.id}`;
    case "image": return `#/viewer/${j.scene}`;
    case "experiment_session": return `/experiment/${j.parent_id}`;
    default: return "#/home";
  }
}
function jobCancelPath(j) {
  return {
    measurement: `/api/measurements/${j.id}/cancel`, render: `/api/renders/${j.id}/cancel`,
    study: `/api/studies/${j.id}/cancel`, image: `/api/images/${j.id}/cancel`,
  }[j.kind];
}
const KIND_NAMES = { measurement: "measurement", render: "render", study: "study", image: "camera image",
  experiment_session: "experiment session" };

// Seconds left of a queue job now, counting down from when the list was made.
function secondsLeftNow(j) {
  if (j.seconds_left === null || j.seconds_left === undefined || !queue) return null;
  return Math.max(0, j.seconds_left - (Date.now() / 1000 - queue.receivedAt));
}

async function loadHome() {
  const [jobs, health, instruments, booths, overview, profiles, lastDone] = await Promise.all([
    api("/api/jobs"), api("/api/health").catch((e) => ({ error: e.message })), api("/api/instruments"),
    api("/api/booths"), api("/api/scene-overview").catch(() => null), api("/api/display-profiles").catch(() => []),
    api("/api/measurements?limit=1&state=complete").catch(() => null),
  ]);
  homeDefaultSamples = health.default_samples || 5;
  showLastMeasurement(lastDone && lastDone.items[0]);
  queue = Object.assign(jobs, { receivedAt: Date.now() / 1000 });
  instrumentNow = instruments.status;
  showQueue();
  showInstrumentCard(instruments);
  showBoothCard(health, booths, instruments);
  showNextSteps(overview, profiles);
}

function showInstrumentCard(instruments) {
  const s = instrumentNow;
  const known = instruments.known.filter((i) => i.booth === undefined || i.booth === instruments.booth);
  const last = known.length ? known[known.length - 1] : null;
  const model = s.model ? `${s.model} ${s.serial || ""}`.trim() : last ? `${last.model} ${last.serial || ""}`.trim() : "instrument";
  const state = { idle: `idle on ${s.port}`, measuring: "measuring", disconnected: `disconnected: ${s.reason}`,
    error: `error: ${s.message}` }[s.state] || s.state;
  $("home-instrument-state").replaceChildren();
  const strong = document.createElement("strong");
  strong.textContent = model;
  const badge = document.createElement("span");
  badge.className = `state-chip ${s.state}`;
  badge.textContent = state;
  $("home-instrument-state").append(strong, " ", badge);
  // What a measurement gives: a spectrum, XYZ (a colorimeter) or luminance only.
  if (s.measures) {
    const measures = document.createElement("span");
    measures.className = "instrument-measures";
    measures.textContent = ` measures ${s.measures}`;
    $("home-instrument-state").append(measures);
  }
  updateCurrentMeasurement();
}

// The measurement under way: what, which sample, the bar, time left.
function updateCurrentMeasurement() {
  const s = instrumentNow;
  const box = $("home-current");
  if (!s || s.state !== "measuring") {
    box.hidden = true;
    return;
  }
  box.hidden = false;
  const what = s.scene ? `${s.scene}/${s.target}` : "a free measurement";
  const underWay = Math.min(s.sample + 1, s.of);
  $("home-current-what").textContent =
    `Measurement #${s.measurement_id}: ${what} — ${s.sample} of ${s.of} samples taken, sample ${underWay} under way`;
  $("home-current-progress").max = s.of;
  $("home-current-progress").value = s.sample;
  const now = Date.now() / 1000;
  const elapsed = now - s.started_at;
  // Only from this measurement's own samples: the previous measurement may
  // have been of a brighter target, whose samples take a fraction of the time.
  $("home-current-time").textContent = s.expected_finish_at && s.sample > 0
    ? `running for ${duration(elapsed)}; about ${duration(s.expected_finish_at - now)} left ` +
      `(extrapolated from this measurement's seconds per sample so far)`
    : `running for ${duration(elapsed)}; no estimate of the time left before its first sample ` +
      `(a sample takes longer the dimmer the target)`;
  $("home-current-cancel").dataset.id = s.measurement_id;
}

$("home-current-cancel").addEventListener("click", async (ev) => {
  notice("");
  try {
    await api(`/api/measurements/${ev.currentTarget.dataset.id}/cancel`, { method: "POST", body: "{}" });
  } catch (e) {
    notice(e.message);
  }
  refreshHomeSoon();
});

// Every serial port, asked its identity (POST /api/instruments/scan: at most
// a few seconds; never a measurement or a settings write).
$("home-scan").addEventListener("click", async (ev) => {
  const button = ev.currentTarget;
  const list = $("home-scan-result");
  button.disabled = true;
  button.textContent = "Looking (at most a few seconds)…";
  notice("");
  try {
    const scan = await api("/api/instruments/scan", { method: "POST", body: "{}" });
    list.replaceChildren();
    if (!scan.ports.length) {
      const li = document.createElement("li");
      li.textContent = "No serial ports on this computer.";
      list.append(li);
    }
    for (const p of scan.ports) {
      const li = document.createElement("li");
      li.className = `scan-${p.status}`;
      const port = document.createElement("code");
      port.textContent = p.port;
      const what = p.status === "identified" ? `${p.model} ${p.serial || ""}`.trim() : p.message;
      li.append(port, `: ${what}` + (p.suggestion ? ` (USB: ${p.suggestion})` : ""));
      list.append(li);
    }
    list.hidden = false;
  } catch (e) {
    notice(e.message);
  } finally {
    button.disabled = false;
    button.textContent = "Look for instruments again";
  }
});

let homeDefaultSamples = 5;

// The newest complete measurement, with what it found.
function showLastMeasurement(m) {
  const p = $("home-last");
  p.replaceChildren();
  if (!m) {
    p.textContent = "No complete measurement yet.";
    return;
  }
  const a = document.createElement("a");
  a.href = `#/measurements/${m.id}`;
  a.textContent = `#${m.id}` + (m.scene ? ` ${m.scene}/${m.target}` : " (free)");
  p.append("Last complete: ", a, `, ${laterTime(Date.now() / 1000, m.finished_at)}: Y = ${fmt(m.Y, 4)} cd/m², ` +
    `x, y = ${fmt(m.x, 4)}, ${fmt(m.y, 4)}`);
}

function showBoothCard(health, booths, instruments) {
  const dl = $("home-booth-facts");
  dl.replaceChildren();
  const others = booths.booths.map((b) => b.booth).filter((b) => b !== booths.this_daemon);
  const facts = [
    ["booth", `${booths.this_daemon} (this daemon)` + (others.length ? `; also in this database: ${others.join(", ")}` : "")],
    ["observer", `${observerName(health.observer || queueObserver())} — every x, y, Y and ΔE on these pages`],
    ["database", health.error ? `unavailable: ${health.error}` : health.database === "ok" ? "answering" : `${health.database}: ${health.database_error || ""}`],
    ["instruments seen", instruments.known.map((i) => `${i.model} ${i.serial || ""}`.trim()).join(", ") || "none yet"],
    ["daemon", `lightbooth ${health.version || ""}`],
  ];
  for (const [k, v] of facts) {
    const dt = document.createElement("dt");
    dt.textContent = k;
    const dd = document.createElement("dd");
    dd.textContent = v;
    dl.append(dt, dd);
  }
}

// The observer of this daemon, as the scene overview names it.
let overviewObserver = null;
function queueObserver() {
  return overviewObserver;
}

// What to do next: the targets never measured here (first the study's five
// booth scenes), a display profile that is missing or stale.
function showNextSteps(overview, profiles) {
  const list = $("home-next-list");
  list.replaceChildren();
  const item = (text, href, label) => {
    const li = document.createElement("li");
    li.append(text + " ");
    if (href) {
      const a = document.createElement("a");
      a.href = href;
      a.textContent = label;
      li.appendChild(a);
    }
    list.appendChild(li);
  };
  if (overview) {
    overviewObserver = overview.observer;
    const pace = queue && queue.seconds_per_sample;
    const unmeasured = overview.scenes.filter((s) => s.measured.length < s.targets.length);
    for (const s of unmeasured.slice(0, 6)) {
      const missing = s.targets.length - s.measured.length;
      // The scene's measurements queued or running (GET /api/jobs) are on
      // their way: never offered as still to measure.
      const waiting = queue ? queue.jobs.filter((j) => j.kind === "measurement" && j.scene === s.scene).length : 0;
      const coming = Math.min(missing, waiting);
      const toGo = missing - coming;
      const time = pace && toGo ? `, about ${duration(toGo * homeDefaultSamples * pace)} at ${homeDefaultSamples} samples each` : "";
      item(`${s.title} (${s.scene}): ${s.measured.length} of ${s.targets.length} target${s.targets.length === 1 ? "" : "s"} measured; ` +
        (coming ? `${coming} on their way; ` : "") + `${toGo} to go${time}.`,
        `#/scenes/${s.scene}`, toGo ? "Measure them →" : "Follow them →");
    }
    if (unmeasured.length > 6) item(`… and ${unmeasured.length - 6} more scenes with targets to measure.`, "#/scenes", "Every scene →");
    if (!unmeasured.length) item("Every target of every scene is measured.", "#/study", "Run the study →");
  }
  if (!profiles.length) {
    item("No display profile yet: experiments need a calibrated display.", "/calibrate", "Calibrate the display →");
  } else {
    const newest = profiles.reduce((a, b) => (a.created_at > b.created_at ? a : b));
    const days = (Date.now() / 1000 - newest.created_at) / 86400;
    if (days > PROFILE_STALE_DAYS) {
      item(`The newest display profile, “${newest.name}”, is ${Math.floor(days)} days old (stale after ${PROFILE_STALE_DAYS}).`,
        "/calibrate", "Recalibrate →");
    } else {
      item(`Display profile “${newest.name}” calibrated ${localTime(newest.created_at)}.`, null);
    }
  }
}

function showQueue() {
  const tbody = document.querySelector("#queue-table tbody");
  tbody.replaceChildren();
  $("queue-empty").hidden = queue.jobs.length > 0;
  $("queue-table").hidden = queue.jobs.length === 0;
  for (const j of queue.jobs) {
    const tr = tbody.insertRow();
    tr.className = "clickable";
    tr.dataset.kind = j.kind;
    tr.dataset.id = j.id;
    const name = tr.insertCell();
    const a = document.createElement("a");
    a.href = jobLink(j);
    a.textContent = `${KIND_NAMES[j.kind] || j.kind} ${j.id}`;
    name.appendChild(a);
    tr.insertCell().textContent = j.what + (j.step ? ` — ${j.step}` : "");
    tr.insertCell().textContent = j.state;
    const progress = tr.insertCell();
    if (j.total) {
      const bar = document.createElement("progress");
      bar.max = j.total;
      bar.value = j.done || 0;
      const label = document.createElement("span");
      label.className = "progress-label";
      label.textContent = j.unit && j.unit.startsWith("%") ? `${fmt(j.done, 3)} ${j.unit}` : `${j.done} of ${j.total} ${j.unit || ""}`;
      progress.append(bar, " ", label);
    } else {
      progress.textContent = j.state === "queued" ? "waiting" : "under way";
    }
    const left = tr.insertCell();
    left.className = "time-left";
    left.title = j.estimate || "no estimate yet: nothing done to extrapolate from";
    tr.insertCell().textContent = j.started_at ? localTime(j.started_at) : j.created_at ? `queued ${localTime(j.created_at)}` : "";
    const actions = tr.insertCell();
    const cancel = jobCancelPath(j);
    if (cancel) {
      const b = jobButton("Cancel", cancel, refreshHomeSoon);
      b.className = "cancel";
      actions.appendChild(b);
    }
    tr.addEventListener("click", () => (location.href = a.href));
  }
  tickTimes();
}

// Counts the times left down between refreshes.
function tickTimes() {
  if (!queue) return;
  const rows = document.querySelectorAll("#queue-table tbody tr");
  queue.jobs.forEach((j, i) => {
    const cell = rows[i]?.querySelector(".time-left");
    if (cell) cell.textContent = j.seconds_left === null ? "–" : `about ${duration(secondsLeftNow(j))}`;
  });
  updateCurrentMeasurement();
}

let refreshPending = null;
function refreshHomeSoon() {
  if (!location.hash.startsWith("#/home") && location.hash !== "" && location.hash !== "#/") return;
  clearTimeout(refreshPending);
  refreshPending = setTimeout(() => loadHome().catch((e) => notice(e.message)), 300);
}

onLabEvent(["measurement_queued", "measurement_started", "measurement_finished", "render_started", "render_finished",
  "study_finished", "image_finished"], refreshHomeSoon);
onLabEvent(["instrument_status"], (d) => {
  instrumentNow = d.status;
  if (!$("view-home").hidden) refreshHomeSoon();
});
onLabEvent(["study_progress", "render_progress", "image_progress"], () => {
  // Progress of jobs other than the instrument's: refresh at most every few seconds.
  if (!$("view-home").hidden && !homeProgressThrottle) {
    homeProgressThrottle = setTimeout(() => { homeProgressThrottle = null; refreshHomeSoon(); }, 3000);
  }
});
let homeProgressThrottle = null;

/** Shows the home view and keeps its times counting; app.js's showView calls it. */
export function showHome() {
  loadHome().catch((e) => notice(e.message));
  clearInterval(homeTimer);
  homeTimer = setInterval(() => {
    if ($("view-home").hidden) clearInterval(homeTimer);
    else tickTimes();
  }, 1000);
}
