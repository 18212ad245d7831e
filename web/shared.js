// What every page of the dashboards shares (an ES module, imported by
// app.js, home.js, material.js, viewer.js, nav.js, calibrate.js,
// experiment.js, experiment-run.js and measure.js; no globals between
// files): the element lookup, the write token, the API call, the notice,
// the read cookie, the instrument's event stream, and the pure formatting
// (durations, numbers, counts, times, observers, the instrument badge).
//
// Importing it does nothing: nothing here touches `document`, `window`,
// `location` or `localStorage` until a function is called, so the pure
// helpers run under Node's test runner too (tests/web/*.test.mjs).

// --- pure formatting ----------------------------------------------------

/** "12 s", "3 min 05 s", "2 h 03 min": a duration for people; "–" for none. */
export function duration(seconds) {
  if (seconds === null || seconds === undefined || !isFinite(seconds)) return "–";
  const s = Math.max(0, Math.round(seconds));
  if (s < 60) return `${s} s`;
  if (s < 3600) return `${Math.floor(s / 60)} min ${String(s % 60).padStart(2, "0")} s`;
  return `${Math.floor(s / 3600)} h ${String(Math.floor((s % 3600) / 60)).padStart(2, "0")} min`;
}

/** "1 target", "2 targets": a count with its noun in the right number. */
export const count = (n, noun) => `${n} ${noun}${Number(n) === 1 ? "" : "s"}`;

/** A number to `digits` significant digits; "–" for none. */
export const fmt = (v, digits = 3) => (v === null || v === undefined ? "–" : Number(v).toPrecision(digits));

/** Local date and time of a POSIX-seconds timestamp (the API keeps seconds, UTC); "" for none. */
export const localTime = (t) => (t === null || t === undefined ? "" : new Date(t * 1000).toLocaleString());

/** A time after `since`: the time of day only when it is the same day. */
export function laterTime(since, t) {
  if (t === null || t === undefined) return "";
  const a = new Date(since * 1000), b = new Date(t * 1000);
  return a.toDateString() === b.toDateString() ? b.toLocaleTimeString() : b.toLocaleString();
}

/** The observer of lightbooth's x, y as a person reads it. */
export function observerName(o) {
  return {
    "judd-vos-1978": "Judd–Vos 1978 2°", "cie-1931": "CIE 1931 2°", "cie-1964-10": "CIE 1964 10°",
    "cie-2015-2": "CIE 2015 2°", "cie-2015-10": "CIE 2015 10°",
  }[o] || "observer not recorded";
}

/** The instrument's state in a few words, for the badge every page's
 * header shows (an InstrumentStatus); `now` in POSIX seconds. */
export function instrumentBadgeText(s, now = Date.now() / 1000) {
  if (s.state === "idle") {
    return `${s.model} ${s.serial || ""}`.trim() + (s.measures ? ` (${s.measures})` : "") + ` idle on ${s.port}`;
  }
  if (s.state === "measuring") {
    // The sample under way, not the count taken: "sample 0 of 5" read as stuck.
    const what = s.scene ? ` ${s.scene}/${s.target}` : "";
    // From this measurement's own pace only (after its first sample): another
    // target's samples may take a fraction of this one's.
    const remaining = s.expected_finish_at && s.sample > 0
      ? ` · about ${duration(s.expected_finish_at - now)} left at its pace so far` : "";
    return `measuring #${s.measurement_id}${what}: sample ${Math.min(s.sample + 1, s.of)} of ${s.of}${remaining}`;
  }
  if (s.state === "disconnected") return "disconnected: " + s.reason;
  return "error: " + s.message;
}

/** What the page says when the daemon refuses the read cookie (HTTP
 * `status`): the token the page holds is not this daemon's. */
export function readCookieRefusal(status) {
  return `The daemon refused this page's token (HTTP ${status}): it is not this daemon's, so measuring, ` +
    "calibrating and every other change will be refused (and, off loopback, charts, images and live updates " +
    "will not load); open the URL the daemon printed (with #token=…) again.";
}

// --- the page: elements, token, API, notice -------------------------------

/** The element with this id. */
export const $ = (id) => document.getElementById(id);

/** The write token this browser keeps (from the daemon's printed URL); "" without one. */
export const token = () => localStorage.getItem("lightbooth-token") || "";

// A refused read cookie (startPage): said first in every notice until the
// page is opened again with the right token, so no later message hides it.
let tokenProblem = "";

/** Shows `text` in the page's #notice (after a refused token, if any), or
 * hides it for "". */
export function notice(text) {
  const n = $("notice");
  n.textContent = [tokenProblem, text].filter(Boolean).join(" ");
  n.hidden = !n.textContent;
}

/** A JSON call to the daemon with the write token; throws the daemon's
 * error message on a refusal. A 204 answers null. */
export async function api(path, options = {}) {
  const headers = Object.assign({ "Accept": "application/json" }, options.headers || {});
  if (options.body !== undefined) headers["Content-Type"] = "application/json";
  if (token()) headers["Authorization"] = "Bearer " + token();
  const r = await fetch(path, Object.assign({}, options, { headers }));
  const body = r.status === 204 ? null : await r.json().catch(() => null);
  if (!r.ok) throw new Error(body && body.error ? body.error.message : r.statusText);
  return body;
}

/** An element with text (never markup: names and notes are stored text)
 * and a class name, or properties to set (`{ id, href, className }`). */
export function el(tag, text, attrs) {
  const e = document.createElement(tag);
  if (text !== undefined && text !== null) e.textContent = String(text);
  if (typeof attrs === "string") e.className = attrs;
  else if (attrs) Object.assign(e, attrs);
  return e;
}

/** Every page's start: takes the write token from the URL's `#token=…`
 * (the daemon prints that URL) into localStorage, leaving `hashAfter` in
 * its place, then asks the read cookie. Bound off loopback, reads need a
 * token too: fetch() sends the write token in the Authorization header,
 * but chart <img>s, download links and the event stream (EventSource)
 * cannot set headers, so the page asks the daemon (with the header) for a
 * read-only cookie: HttpOnly, SameSite=Strict, for /api, named after the
 * daemon's port, holding a read token the daemon derives for this run. The
 * write token never goes in a cookie (cookies are not bound to a port: any
 * other local service under /api would receive it); see src/http/auth.rs.
 * A cookie of older versions is deleted.
 *
 * A refused read cookie (a token of another daemon, or of this one's
 * previous run) is shown in the page's notice, saying what to do, and
 * stays at the head of every later notice; a failed request is shown too.
 * Resolves once the cookie is set or refused. */
export function startPage({ hashAfter = "" } = {}) {
  const m = location.hash.match(/token=([0-9A-Za-z_-]+)/);
  if (m) {
    localStorage.setItem("lightbooth-token", m[1]);
    history.replaceState(null, "", location.pathname + location.search + hashAfter);
  }
  document.cookie = "lightbooth_token=; path=/api; max-age=0; SameSite=Strict";
  if (!token()) return Promise.resolve();
  return fetch("/api/read-cookie", { method: "POST", headers: { "Authorization": "Bearer " + token() } }).then(
    (r) => {
      if (r.ok) return;
      tokenProblem = readCookieRefusal(r.status);
      notice("");
    },
    (e) => notice(`No read cookie (${e.message}): charts, images and live updates may not load; reload the page.`));
}

/** A button that POSTs to a job's action (cancel, retry) and then calls `then`. */
export function jobButton(label, path, then) {
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

// --- the lab's event stream (the index page) ------------------------------

// The views of the index page (home.js, viewer.js, app.js) follow the same
// event stream: one connection per page, not one per module.
const labEventHandlers = new Map();

/** Calls `handler(data)` for every event of the names in `names`. */
export function onLabEvent(names, handler) {
  for (const name of names) {
    if (!labEventHandlers.has(name)) labEventHandlers.set(name, []);
    labEventHandlers.get(name).push(handler);
  }
}

/** Opens the one event stream (GET /api/events) and hands each event to
 * the handlers given to onLabEvent; `onError` when the stream is lost. */
export function followLabEvents(onError) {
  const es = new EventSource("/api/events");
  for (const [name, handlers] of labEventHandlers) {
    es.addEventListener(name, (e) => {
      const d = JSON.parse(e.data);
      for (const h of handlers) h(d);
    });
  }
  es.onerror = onError;
  return es;
}

// --- a luminance scale under a tone-mapped picture ------------------------

/** The place (0–1 along the bar) and label of each decade tick of the
 * luminance scale for log average `logAverage` cd/m² (see luminanceScale). */
export function luminanceScaleTicks(logAverage) {
  const k = 0.18 / logAverage;
  const low = Math.log10(0.01 / 0.99 / k), high = Math.log10(0.9999 / 0.0001 / k);
  const ticks = [];
  for (let e = Math.ceil(low); e <= Math.floor(high); e++) {
    ticks.push({ at: (e - low) / (high - low), label: e >= 0 ? String(Math.pow(10, e)) : Math.pow(10, e).toFixed(-e) });
  }
  return { k, low, high, ticks };
}

/** A cd/m² scale for an image shown through the daemon's global Reinhard
 * tone map: a grey of Y cd/m² is shown at the linear display value
 * d = Yk/(1 + Yk), k = 0.18 / the image's log-average luminance. The bar
 * runs over log Y, from the luminance shown at d = 0.01 (near black) to the
 * one shown at d = 0.9999 (white), each place in the grey the image shows
 * that luminance in; its ticks are decades of cd/m². (It ran over d, and
 * the tone map crowds everything above a few times the log average into
 * its last percent: the ticks stopped near 2 cd/m² beside a 34.5 cd/m²
 * patch.) */
export function luminanceScale(logAverage, what) {
  const { k, low, high, ticks: decades } = luminanceScaleTicks(logAverage);
  const at = (f) => Math.pow(10, low + f * (high - low)); // the luminance at f (0–1) along the bar
  const wrap = el("div", undefined, "lum-scale");
  const bar = el("div", undefined, "lum-bar");
  const encode = (v) => (v <= 0.0031308 ? 12.92 * v : 1.055 * Math.pow(v, 1 / 2.4) - 0.055);
  const stops = [];
  for (let i = 0; i <= 40; i++) {
    const y = at(i / 40);
    const g = Math.round(255 * encode((y * k) / (1 + y * k)));
    stops.push(`rgb(${g},${g},${g}) ${i * 2.5}%`);
  }
  bar.style.background = `linear-gradient(to right, ${stops.join(", ")})`;
  const ticks = el("div", undefined, "lum-ticks");
  for (const { at: f, label } of decades) {
    const t = el("span", label);
    t.style.left = `${f * 100}%`;
    // The end ticks sit inside the bar's ends, not half outside.
    if (f < 0.03) t.style.transform = "none";
    if (f > 0.97) t.style.transform = "translateX(-100%)";
    ticks.appendChild(t);
  }
  const unit = el("div", `luminance (cd/m², a tick per factor of 10) shown at that grey — ${what}; tone-mapped ` +
    `(log average ${fmt(logAverage, 3)} cd/m²), for looking at, not for measuring`, "lum-unit");
  wrap.append(bar, ticks, unit);
  return wrap;
}
