// The session page of an oddity experiment (/experiment/ID/run), shown
// full-screen on the calibrated stimulus display.
//
// Before the first trial it measures the display's refresh (the median
// requestAnimationFrame interval with nothing else drawn) and turns every
// duration into whole frames. Each frame is drawn with WebGL2: the pie, in
// linear RGB, is a 32-bit float texture; the fragment shader applies the
// display profile's inverse and the output method (web/display-gl.js:
// 8 bits, noisy-bit dithering, or 10 bits into a float16 drawing buffer). Stimuli change only
// inside the animation callback; every frame interval is logged, an
// interval over 1.5 frames is a dropped frame, and keys are timed with the
// event's own timeStamp. Every trial is posted as it ends; the daemon says
// which trial comes next, so a reload resumes where the session stopped.
import { $, api, notice, startPage } from "./shared.js";
import { fullScreenProgram, METHOD, nearestTexture, OUTPUT_GLSL } from "./display-gl.js";
import { holdShowMeasure } from "./measure.js";
import { checkProgress, ditherResolution, frames as wholeFrames, medianInterval, pieceAt, pieDiameterPx as pieDiameterPxOf,
  TrialClock } from "./trial.js";

const experimentId = Number(location.pathname.split("/")[2]);
const KEYS = { ArrowLeft: 0, ArrowUp: 1, ArrowRight: 2 };

let experiment = null;
let view = null;
let frameMs = null;
let stopRequested = false;
// Start pressed once on an experiment whose display has no passing verification.
let warnedUnverified = false;
const UNVERIFIED = "This experiment's display is not verified: the colours observers see may not be the ones intended. " +
  "Press “verify the display” below (with the spectroradiometer aimed at the screen) before the first observer; " +
  "press start again to run without it.";

function fact(name, value) {
  const dt = document.createElement("dt");
  dt.textContent = name;
  const dd = document.createElement("dd");
  dd.textContent = value;
  $("facts").append(dt, dd);
}

// A duration in whole frames of the display's measured refresh (web/trial.js).
const frames = (ms) => wholeFrames(ms, frameMs);

// ---- WebGL2 ------------------------------------------------------------

const FRAGMENT = `#version 300 es
precision highp float;
precision highp int;
precision highp sampler2D;
uniform sampler2D pie;        // linear RGB of the pie's square, RGBA32F
uniform ivec2 pieOrigin;      // its lower-left pixel on the canvas
uniform ivec2 pieSize;
uniform bool showPie;
uniform bool showCross;
uniform ivec2 centre;
uniform int crossArm;
uniform int crossHalfWidth;
uniform vec3 background;      // linear RGB
${OUTPUT_GLSL}
out vec4 colour;

void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec3 linear = background;
  if (showPie) {
    ivec2 q = p - pieOrigin;
    if (all(greaterThanEqual(q, ivec2(0))) && all(lessThan(q, pieSize))) linear = texelFetch(pie, q, 0).rgb;
  } else if (showCross) {
    ivec2 d = abs(p - centre);
    if ((d.x <= crossArm && d.y <= crossHalfWidth) || (d.y <= crossArm && d.x <= crossHalfWidth)) linear = vec3(0.0);
  }
  colour = vec4(shown(linear, p), 1.0);
}`;

const screen = { canvas: null, gl: null, program: null, texture: null, u: {}, outputPath: "" };

function setUpScreen() {
  const canvas = $("screen");
  const dpr = window.devicePixelRatio || 1;
  canvas.width = Math.round(innerWidth * dpr);
  canvas.height = Math.round(innerHeight * dpr);
  const gl = canvas.getContext("webgl2", { antialias: false, alpha: false, depth: false, desynchronized: false, preserveDrawingBuffer: true });
  if (!gl) throw new Error("this browser has no WebGL2: the session needs it to draw the stimuli with more than 8 bits");
  let path = "WebGL2, 8-bit canvas";
  if (view.output === "10bit") {
    if (typeof gl.drawingBufferStorage !== "function") {
      throw new Error("10-bit output: this browser offers no float drawing buffer (drawingBufferStorage); use noisy_bit");
    }
    gl.drawingBufferStorage(gl.RGBA16F, canvas.width, canvas.height);
    path = "WebGL2, float16 drawing buffer (10-bit codes; whether the display shows 10 bits is not visible to the page: verify with the spectroradiometer)";
  }
  const program = fullScreenProgram(gl, FRAGMENT);
  const texture = nearestTexture(gl);
  for (const name of ["pie", "pieOrigin", "pieSize", "showPie", "showCross", "centre", "crossArm", "crossHalfWidth",
    "background", "inverseGamma", "method", "frameSeed"]) screen.u[name] = gl.getUniformLocation(program, name);
  gl.viewport(0, 0, canvas.width, canvas.height);
  gl.uniform1i(screen.u.pie, 0);
  gl.uniform3fv(screen.u.background, view.background.linear);
  gl.uniform3fv(screen.u.inverseGamma, view.gammas.map((g) => 1 / g));
  gl.uniform1i(screen.u.method, METHOD[view.output]);
  const cx = Math.floor(canvas.width / 2), cy = Math.floor(canvas.height / 2);
  gl.uniform2i(screen.u.centre, cx, cy);
  // The cross: arms of 0.3° of the pie's 5.7° scale, two pixels wide at least.
  const diameter = pieDiameterPx();
  gl.uniform1i(screen.u.crossArm, Math.max(4, Math.round(diameter * 0.3 / view.presentation.pie_diameter_deg)));
  gl.uniform1i(screen.u.crossHalfWidth, Math.max(1, Math.round(diameter / 200)));
  Object.assign(screen, { canvas, gl, program, texture, outputPath: path, cx, cy });
}

const pieDiameterPx = () => pieDiameterPxOf(view.presentation);

// The pie of one trial as a float texture: three 120° pieces (left, top,
// right) with a thin gap of background between them.
function uploadPie(configuration, approximationIndex) {
  const colours = { O: view.original.linear, N: view.approximations[approximationIndex].linear };
  uploadPieColours([...configuration].map((letter) => colours[letter]));
}

// The pie's pieces in linear RGB: left, top, right.
function uploadPieColours(pieces) {
  const { gl } = screen;
  const d = pieDiameterPx();
  const size = Math.ceil(d) + 2;
  const r = d / 2, c = size / 2, gap = Math.max(2, d * 0.02) / 2;
  const bg = view.background.linear;
  const data = new Float32Array(size * size * 4);
  for (let j = 0; j < size; j++) {
    for (let i = 0; i < size; i++) {
      // y up: texture row 0 is the bottom. Pieces left, top, right (web/trial.js).
      const piece = pieceAt(i + 0.5 - c, j + 0.5 - c, r, gap);
      const rgb = piece < 0 ? bg : pieces[piece];
      data.set([rgb[0], rgb[1], rgb[2], 1], (j * size + i) * 4);
    }
  }
  gl.bindTexture(gl.TEXTURE_2D, screen.texture);
  gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, size, size, 0, gl.RGBA, gl.FLOAT, data);
  gl.uniform2i(screen.u.pieOrigin, screen.cx - Math.floor(size / 2), screen.cy - Math.floor(size / 2));
  gl.uniform2i(screen.u.pieSize, size, size);
}

let frameCounter = 0;
function draw(showPie, showCross) {
  const { gl } = screen;
  gl.uniform1i(screen.u.showPie, showPie ? 1 : 0);
  gl.uniform1i(screen.u.showCross, showCross ? 1 : 0);
  gl.uniform1ui(screen.u.frameSeed, (frameCounter++ * 2654435761) >>> 0);
  gl.drawArrays(gl.TRIANGLES, 0, 3);
}

// ---- timing ------------------------------------------------------------

// The median of 120 frame intervals with nothing else drawn.
function measureRefresh() {
  return new Promise((resolve) => {
    const times = [];
    const tick = (t) => {
      times.push(t);
      if (times.length < 121) requestAnimationFrame(tick);
      else resolve(medianInterval(times));
    };
    requestAnimationFrame(tick);
  });
}

// The background alone for the adaptation time, with the cross.
function adapt(seconds) {
  return new Promise((resolve) => {
    const n = frames(seconds * 1000);
    let i = 0;
    const tick = () => {
      draw(false, true);
      if (++i >= n) resolve();
      else requestAnimationFrame(tick);
    };
    requestAnimationFrame(tick);
  });
}

// One trial: the cross for the fixation frames, the pie for the stimulus
// frames, then the cross until a key (the frames counted by web/trial.js's
// TrialClock). Resolves with what happened.
function runTrial(next) {
  uploadPie(next.configuration, next.approximation_index);
  const clock = new TrialClock(frames(view.presentation.fixation_ms), frames(view.presentation.stimulus_ms), frameMs);
  return new Promise((resolve) => {
    let response = null;
    const onKey = (e) => {
      if (!(e.key in KEYS)) return;
      e.preventDefault();
      // Before the pie's first frame reached the screen: ignored.
      if (!clock.accepts(e.timeStamp)) return;
      if (response === null) response = { key: KEYS[e.key], at: e.timeStamp };
    };
    addEventListener("keydown", onKey);
    const tick = (now) => {
      const frame = clock.tick(now);
      // From now on a key answers this trial (an observer script waits for it).
      if (frame.onset) document.body.dataset.pieOnScreen = String(next.position);
      // Which trial's pie has been drawn: an observer script (the browser
      // test) answers once it is, however late it looks.
      if (frame.firstPie) document.body.dataset.pieShown = String(next.position);
      if (frame.changed) document.body.dataset.phase = frame.pie ? "pie" : "cross";
      draw(frame.pie, !frame.pie);
      if (response !== null && clock.over) {
        removeEventListener("keydown", onKey);
        resolve(clock.result(response.key, response.at));
      } else {
        requestAnimationFrame(tick);
      }
    };
    requestAnimationFrame(tick);
  });
}

// ---- verification --------------------------------------------------------
//
// Before observers sit down, every colour is shown through the same path as
// a trial (this shader, the profile's γ, the output method) full-field and
// in the pie, and measured with the booth's spectroradiometer as a
// calibration patch is. With `serve --mock` the simulated PR-650 looks at a
// simulated display, which is told the codes this page drew in the
// instrument's spot: the frame buffer is read back over several frames
// (every dithered pixel and frame counted), so the simulated display emits
// what this shader really produced.

// Frames read back per patch for the simulated display.
const READBACK_FRAMES = 16;

// The view of an experiment without a session (the verification's).
async function verificationView() {
  const profile = await api(`/api/display-profiles/${experiment.display_profile_id}`);
  return {
    presentation: experiment.request.presentation,
    output: experiment.output_method,
    gammas: profile.profile.transfer.map((t) => t.gamma),
    original: experiment.check.original,
    approximations: experiment.check.approximations,
    background: experiment.check.background,
  };
}

// The instrument's spot: a square of `side` pixels at the screen's centre
// (full field) or at the middle of the left piece (pie), lower-left corner.
function spot(geometry) {
  const r = pieDiameterPx() / 2;
  const side = Math.max(8, Math.min(64, Math.round(r / 3)));
  let x = screen.cx, y = screen.cy;
  if (geometry === "pie") {
    x += (r / 2) * Math.cos(210 * Math.PI / 180);
    y += (r / 2) * Math.sin(210 * Math.PI / 180);
  }
  return { x: Math.round(x - side / 2), y: Math.round(y - side / 2), side };
}

// Adds the codes of the spot in the frame just drawn to `counts`.
function countSpot(area, counts, maxCode) {
  const { gl } = screen;
  const n = area.side * area.side * 4;
  let values;
  if (maxCode === 255) {
    values = new Uint8Array(n);
    gl.readPixels(area.x, area.y, area.side, area.side, gl.RGBA, gl.UNSIGNED_BYTE, values);
  } else {
    const f = new Float32Array(n);
    gl.readPixels(area.x, area.y, area.side, area.side, gl.RGBA, gl.FLOAT, f);
    values = f.map((v) => Math.round(v * maxCode));
  }
  for (let i = 0; i < n; i += 4) {
    for (let c = 0; c < 3; c++) counts[c][Math.min(maxCode, Math.max(0, values[i + c]))]++;
  }
}

// Shows `linear` (the whole screen, or all three pieces of the pie) every
// frame until the returned stop() is called; with `readback`, resolves
// `counted` once READBACK_FRAMES frames of the spot are counted.
function showPatch(linear, geometry, readback) {
  const { gl } = screen;
  const maxCode = view.output === "10bit" ? 1023 : 255;
  const counts = [0, 1, 2].map(() => new Array(maxCode + 1).fill(0));
  const area = spot(geometry);
  if (geometry === "pie") {
    gl.uniform3fv(screen.u.background, view.background.linear);
    uploadPieColours([linear, linear, linear]);
  } else {
    gl.uniform3fv(screen.u.background, linear);
  }
  let running = true, frames = 0, done;
  const counted = new Promise((resolve) => { done = resolve; });
  const tick = () => {
    if (!running) return;
    draw(geometry === "pie", false);
    if (readback && frames < READBACK_FRAMES) {
      countSpot(area, counts, maxCode);
      if (++frames === READBACK_FRAMES) done({ code_counts: counts, max_code: maxCode });
    }
    requestAnimationFrame(tick);
  };
  requestAnimationFrame(tick);
  if (!readback) done(null);
  return { counted, stop: () => { running = false; gl.uniform3fv(screen.u.background, view.background.linear); } };
}

// The display check under way (verification or test patch): its hold on
// the instrument (while held, no other measurement is taken and nobody else
// changes the display), the measurement under way, and whether Esc asked
// it to stop (web/measure.js's holdShowMeasure keeps it).
const check = { hold: null, measurementId: null, cancelled: false };

// Holds the instrument for `purpose` and shows and measures each of
// `patches` ({ linear, geometry, note }) through the trials' drawing path;
// with the simulated display, tells it the codes this page drew in the
// instrument's spot first. `onHeld` begins the screen; `progress(i, total,
// began)` writes the corner text. Returns web/measure.js's { measured,
// cancelled, simulated }.
function measureOnScreen(purpose, patches, samples, { onHeld, progress = () => {} }) {
  return holdShowMeasure(api, {
    purpose, patches, samples, run: check, onHeld, progress,
    show: (p, i, simulated) => {
      const shown = showPatch(p.linear, p.geometry, simulated);
      return { display: shown.counted, stop: shown.stop };
    },
    note: (p) => p.note,
  });
}

// Esc during a display check: the measurement under way is cancelled, no
// verification is stored, and what was measured stays stored.
async function cancelCheck() {
  if (check.hold === null || check.cancelled) return;
  check.cancelled = true;
  $("hud").textContent = "cancelling…";
  if (check.measurementId !== null) {
    await api(`/api/measurements/${check.measurementId}/cancel`, { method: "POST", body: "{}" }).catch(() => {});
  }
}

// The corner text (#hud) belongs to the check that writes it: every screen
// starts and ends without it, so no trial shows a verification's "patch 15
// of 15 … Esc cancels".
function beginScreen() {
  $("hud").textContent = "";
  document.body.classList.add("running");
  try { document.documentElement.requestFullscreen().catch(() => {}); } catch (_) { /* windowed */ }
  setUpScreen();
}

function endScreen() {
  $("hud").textContent = "";
  document.body.classList.remove("running");
  if (document.fullscreenElement) document.exitFullscreen().catch(() => {});
}

async function verify() {
  notice("");
  $("verify").disabled = $("start").disabled = true;
  const samples = Number($("verify-samples").value);
  try {
    view = await verificationView();
    const colours = [view.original, ...view.approximations, view.background];
    // Every colour full-field, then in the pie (the pie's surround is the
    // background itself, so the background is not shown as a pie).
    const plan = [];
    for (const geometry of ["full_field", "pie"]) {
      for (const c of colours) {
        if (geometry === "pie" && c.name === "background") continue;
        const where = geometry.replace("_", " ");
        plan.push({ c, geometry, where, linear: c.linear, note: `experiment ${experimentId} verification: ${c.name}, ${where}` });
      }
    }
    // The daemon verifies only patches measured under a hold of exactly
    // this purpose (lab::experiments::verification::hold_purpose).
    const { measured, cancelled, simulated } = await measureOnScreen(`verification of experiment ${experimentId}`, plan, samples, {
      onHeld: () => {
        beginScreen();
        document.body.dataset.state = "verifying";
      },
      progress: (i, total, began) => {
        const { c, where } = plan[i];
        $("hud").textContent = `verifying ${c.name} (${where}): ${checkProgress(i, total, began)} · Esc cancels`;
      },
    });
    endScreen();
    if (cancelled) {
      notice(`verification cancelled: nothing was stored as a verification; the patches measured before Esc stay ` +
        `stored as measurements. Press “verify the display” to start again.`);
      document.body.dataset.verificationCancelled = "yes";
      return;
    }
    const patches = measured.map(({ patch, measurement }) =>
      ({ colour: patch.c.name, geometry: patch.geometry, measurement_id: measurement.id }));
    const v = await api(`/api/experiments/${experimentId}/verifications`, {
      method: "POST",
      body: JSON.stringify({ patches, client: `${navigator.userAgent}; ${screen.outputPath}` + (simulated ? "; simulated display" : "") }),
    });
    showVerification(v);
  } catch (e) {
    endScreen();
    notice("verification stopped: " + e.message);
  } finally {
    document.body.dataset.state = "idle";
    $("verify").disabled = $("start").disabled = false;
  }
}

// A full-field test patch at fractional codes (e.g. 127.30 on every gun),
// shown with the experiment's output method without the profile's γ, and
// measured: with noisy-bit dithering its mean lies between the two 8-bit
// levels around it.
async function testPatch() {
  notice("");
  const code = Number($("test-code").value);
  if (!(code >= 0 && code <= 255)) {
    notice("test patch: give a code from 0 to 255, e.g. 127.3");
    return;
  }
  $("test-patch").disabled = true;
  try {
    view = await verificationView();
    const patch = { linear: [code / 255, code / 255, code / 255], geometry: "full_field",
      note: `test patch: code ${code.toFixed(2)} on every gun, ${view.output}` };
    const { measured, cancelled } = await measureOnScreen(`test patch of experiment ${experimentId}`, [patch],
      Number($("verify-samples").value), {
        onHeld: () => {
          beginScreen();
          document.body.dataset.state = "verifying";
          $("hud").textContent = `test patch: code ${code.toFixed(2)} · Esc cancels`;
          // γ = 1: the drive is the linear value, so the code drawn is exactly `code`.
          screen.gl.uniform3fv(screen.u.inverseGamma, [1, 1, 1]);
        },
      });
    endScreen();
    if (cancelled || !measured.length) {
      notice("test patch cancelled");
      return;
    }
    const m = measured[0].measurement;
    $("test-result").textContent = `code ${code.toFixed(2)} (${view.output}): measurement ${m.id}, ` +
      `${m.luminance_cd_m2 === undefined ? "" : Number(m.luminance_cd_m2).toFixed(4) + " cd/m²"}`;
    document.body.dataset.testMeasurement = String(m.id);
  } catch (e) {
    endScreen();
    notice("test patch stopped: " + e.message);
  } finally {
    document.body.dataset.state = "idle";
    $("test-patch").disabled = false;
  }
}

function showVerification(v) {
  const box = $("verification");
  box.replaceChildren();
  if (!v) {
    box.textContent = "not verified yet: verify the display before the first observer";
    notice(UNVERIFIED);
    return;
  }
  const head = document.createElement("div");
  head.className = v.passed ? "passed" : "failed";
  head.textContent = `verification ${v.id} ${v.passed ? "passed" : "FAILED"} (ΔE00 tolerance ${v.tolerance_delta_e00}, ` +
    `${v.observer} observer, the display's white): ` + v.summary.join("; ");
  box.append(head);
  document.body.dataset.verification = v.passed ? "passed" : "failed";
  if (!v.passed) notice(`the display's newest verification failed: ${v.summary[0]}. Run observers only once it passes.`);
}

// ---- the session -------------------------------------------------------

function describe() {
  $("facts").replaceChildren();
  const p = view.presentation;
  const hz = frameMs ? 1000 / frameMs : null;
  fact("observer", view.session.observer_id);
  fact("trials", `${view.trials_recorded} of ${view.trials_total} recorded` + (view.repeats ? ` (${view.repeats} repeated after a dropped frame)` : "") +
    (view.excluded ? `; ${view.excluded} not counted (a frame dropped during the pie)` : ""));
  fact("pie", `${p.pie_diameter_deg}° = ${pieDiameterPx().toFixed(0)} px at ${p.viewing_distance_mm} mm and ${p.pixel_pitch_mm} mm per pixel (as stated in the experiment)`);
  if (hz) {
    fact("display", `${hz.toFixed(2)} Hz (median frame ${frameMs.toFixed(3)} ms, measured)`);
    fact("timeline", `cross ${frames(p.fixation_ms)} frames (${(frames(p.fixation_ms) * frameMs).toFixed(0)} ms), ` +
      `pie ${frames(p.stimulus_ms)} frames (${(frames(p.stimulus_ms) * frameMs).toFixed(0)} ms), then the cross until a key`);
  } else {
    fact("timeline", `cross ${p.fixation_ms} ms, pie ${p.stimulus_ms} ms, then the cross until a key; adaptation ${p.adaptation_s} s`);
  }
  fact("output", outputWords(hz));
}

// The method and its effective resolution for one pie piece over the pie's frames.
function outputWords(hz) {
  if (view.output === "8bit") return "8 bits per gun, each colour rounded to its nearest code";
  if (view.output === "10bit") return "10 bits per gun (float16 drawing buffer)";
  const { step, bits } = ditherResolution(pieDiameterPx(), hz ? frames(view.presentation.stimulus_ms) : 18);
  return `noisy-bit dithering of 8-bit codes (Allard & Faubert 2008): the mean of a piece over the pie's frames ` +
    `resolves ${step.toFixed(4)} of a code, about ${bits.toFixed(1)} bits`;
}

async function load() {
  try {
    experiment = await api(`/api/experiments/${experimentId}`);
    $("title").textContent = `${experiment.name} (${experiment.scene}/${experiment.target}), ${experiment.output_method}`;
    const observer = new URLSearchParams(location.search).get("observer");
    if (observer) $("observer").value = observer;
    $("status").textContent = (experiment.check.summary || []).join("; ");
    const verifications = await api(`/api/experiments/${experimentId}/verifications`);
    showVerification(verifications[0]);
  } catch (e) {
    notice(e.message);
  }
}

async function start() {
  await loaded; // the verification's state, before deciding to warn
  if (document.body.dataset.verification !== "passed" && !warnedUnverified) {
    warnedUnverified = true;
    notice(document.body.dataset.verification === "failed"
      ? "The display's newest verification failed: run observers only once it passes. Press start again to run anyway."
      : UNVERIFIED);
    $("start").textContent = "start anyway";
    return;
  }
  notice("");
  try {
    view = await api(`/api/experiments/${experimentId}/sessions`, {
      method: "POST", body: JSON.stringify({ observer: $("observer").value.trim() }),
    });
    if (!view.next) {
      describe();
      $("status").textContent = "this observer's session is complete";
      return;
    }
    beginScreen();
    frameMs = await measureRefresh();
    view = await api(`/api/experiment-sessions/${view.session.id}/display`, {
      method: "POST", body: JSON.stringify({ frame_ms: frameMs, client: `${navigator.userAgent}; ${screen.outputPath}` }),
    });
    describe();
    document.body.dataset.state = "adapting";
    await adapt(view.presentation.adaptation_s);
    document.body.dataset.state = "trials";
    while (view.next && !stopRequested) {
      document.body.dataset.trial = String(view.next.position);
      const result = await runTrial(view.next);
      view = await api(`/api/experiment-sessions/${view.session.id}/trials`, {
        method: "POST", body: JSON.stringify(Object.assign({ position: view.next.position }, result)),
      });
    }
  } catch (e) {
    notice(e.message + " — the trials recorded are kept; press start to resume");
  }
  endScreen();
  if (view) {
    describe();
    document.body.dataset.state = view.next ? "paused" : "complete";
    $("status").textContent = view.next
      ? `paused after trial ${view.trials_recorded}; press start to resume`
      : `session complete: ${view.trials_recorded} trials. Thank you!`;
    // For the operator: too many trials not counted (the daemon's words).
    if (view.warning) notice(view.warning);
  }
  stopRequested = false;
}

addEventListener("keydown", (e) => {
  if (e.key !== "Escape") return;
  if (check.hold !== null) cancelCheck();
  else stopRequested = true;
});
$("start").addEventListener("click", start);
$("verify").addEventListener("click", verify);
$("test-patch").addEventListener("click", testPatch);
// The read cookie is asked (and a refused token said) before the experiment is read.
const loaded = startPage().then(load);
