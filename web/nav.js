// The one navigation bar of every dashboard page (index, calibrate,
// experiment; an ES module): each page's script calls showNavigation() as
// it starts, so the pages cannot drift apart. On the index page the links
// are its views (#/home …) and app.js marks the active one; on the others
// the page's own link is. Every page's header also shows the instrument
// badge: on the index page app.js feeds it from the event stream; on the
// others it is written here and follows GET /api/health.
import { instrumentBadgeText, token } from "./shared.js";

/** Writes the navigation bar into <header><nav>, and, except on the index
 * page, the instrument badge after it. Call after startPage() (bound off
 * loopback, the badge's reads need the token it takes from the URL). */
export function showNavigation() {
  writeNavigation();
  followInstrument();
}

function writeNavigation() {
  const nav = document.querySelector("header nav");
  if (!nav) return;
  const onIndex = location.pathname === "/";
  const links = [
    ["Home", "home"], ["Live", "live"], ["Measurements", "measurements"], ["Scenes", "scenes"],
    ["Viewer", "viewer"], ["Study", "study"], ["Material", "material"],
    ["Calibrate", null, "/calibrate"], ["Stimuli", null, "/stimulus-sets"], ["Experiment", null, "/experiment"],
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
}

function followInstrument() {
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
      const r = await fetch("/api/health", { headers: token() ? { "Authorization": "Bearer " + token() } : {} });
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
  poll();
}
