// The one navigation bar of every dashboard page (index, calibrate,
// experiment): written into <header><nav> as the page loads, so the pages
// cannot drift apart. On the index page the links are its views (#/home …)
// and app.js marks the active one; on the others the page's own link is.
// Every page's header also shows the instrument badge: on the index page
// app.js feeds it from the event stream; on the others it is written here
// and follows GET /api/health.
"use strict";

// The instrument's state in a few words, for the badge (InstrumentStatus).
function instrumentBadgeText(s) {
  const left = (at) => {
    const t = Math.max(0, Math.round(at - Date.now() / 1000));
    if (t < 60) return `${t} s`;
    if (t < 3600) return `${Math.floor(t / 60)} min ${String(t % 60).padStart(2, "0")} s`;
    return `${Math.floor(t / 3600)} h ${String(Math.floor((t % 3600) / 60)).padStart(2, "0")} min`;
  };
  if (s.state === "idle") {
    return `${s.model} ${s.serial || ""}`.trim() + (s.measures ? ` (${s.measures})` : "") + ` idle on ${s.port}`;
  }
  if (s.state === "measuring") {
    // The sample under way, not the count taken: "sample 0 of 5" read as stuck.
    const what = s.scene ? ` ${s.scene}/${s.target}` : "";
    // From this measurement's own pace only (after its first sample): another
    // target's samples may take a fraction of this one's.
    const remaining = s.expected_finish_at && s.sample > 0
      ? ` · about ${left(s.expected_finish_at)} left at its pace so far` : "";
    return `measuring #${s.measurement_id}${what}: sample ${Math.min(s.sample + 1, s.of)} of ${s.of}${remaining}`;
  }
  if (s.state === "disconnected") return "disconnected: " + s.reason;
  return "error: " + s.message;
}
(function writeNavigation() {
  const nav = document.querySelector("header nav");
  if (!nav) return;
  const onIndex = location.pathname === "/";
  const links = [
    ["Home", "home"], ["Live", "live"], ["Measurements", "measurements"], ["Scenes", "scenes"],
    ["Viewer", "viewer"], ["Study", "study"], ["Material", "material"],
    ["Calibrate", null, "/calibrate"], ["Experiment", null, "/experiment"],
  ];
  nav.replaceChildren();
  for (const [label, view, path] of links) {
    const a = document.createElement("a");
    a.textContent = label;
    if (view) {
      a.href = onIndex ? `#/${view}` : `/#/${view}`;
      a.dataset.view = view;
    } else {
      a.href = path;
      if (location.pathname === path) a.classList.add("active");
    }
    nav.appendChild(a);
  }
})();

(function followInstrument() {
  const header = document.querySelector("header");
  if (!header || location.pathname === "/") return; // the index page's badge is app.js's
  const badge = document.createElement("a");
  badge.id = "instrument";
  badge.className = "badge";
  badge.href = "/#/home";
  badge.title = "the instrument: open the home page for the queue";
  badge.textContent = "connecting…";
  header.appendChild(badge);
  async function poll() {
    try {
      const token = localStorage.getItem("lightbooth-token");
      const r = await fetch("/api/health", { headers: token ? { "Authorization": "Bearer " + token } : {} });
      const health = await r.json();
      if (!health.instrument) throw new Error(health.error ? health.error.message : `HTTP ${r.status}`);
      badge.className = "badge " + health.instrument.state;
      badge.textContent = instrumentBadgeText(health.instrument);
    } catch (e) {
      badge.className = "badge disconnected";
      badge.textContent = `instrument unknown: ${e.message}`;
    }
    setTimeout(poll, 2000);
  }
  // After the page's own script has taken the token from its #token=…
  // (bound off loopback, reads need it).
  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", poll);
  else poll();
})();
