// Stimulus sets (/stimulus-sets, /stimulus-sets/ID): the codings of one
// rendered image as the calibrated display will be asked to show them.
// Each coding's linear RGB (GET …/linear/CODING, f32) is drawn with WebGL2
// through the profile's γ and the output method (web/display-gl.js), as
// the experiment's session page draws its stimuli; beside it, its ΔE00 map
// against the reference as the display shows both (drawn by the daemon),
// one scale for the set; then how much of each coding's difference at each
// depth is the quantisation's; and the verification of a coding on the
// display at the scene's targets (full-screen, one image pixel per screen
// pixel, measured under the set's instrument hold; with --mock the
// simulated display is told the codes this page drew under the field).
import { $, api, el, fmt, localTime, notice, observerName, startPage } from "./shared.js";
import { fullScreenProgram, METHOD, nearestTexture, OUTPUT_GLSL } from "./display-gl.js";
import { holdShowMeasure } from "./measure.js";
import { showNavigation } from "./nav.js";

const OUTPUT_NAMES = {
  "8bit": "8 bits per gun", "noisy_bit": "noisy-bit dithering of 8-bit codes (one frame of it)",
  "10bit": "10 bits per gun", "12bit": "12 bits per gun",
};

const FRAGMENT = `#version 300 es
precision highp float;
precision highp int;
precision highp sampler2D;
uniform sampler2D image;      // linear RGB, RGBA32F, row 0 at the bottom
${OUTPUT_GLSL}
out vec4 colour;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  colour = vec4(shown(texelFetch(image, p, 0).rgb, p), 1.0);
}`;

/** Draws `linear` (Float32Array, R G B per pixel, rows top to bottom) on
 * `canvas` through the γs and the output; the drawing path in words. */
function draw(canvas, linear, width, height, gammas, output) {
  canvas.width = width;
  canvas.height = height;
  const gl = canvas.getContext("webgl2", { antialias: false, alpha: false, preserveDrawingBuffer: true });
  if (!gl) throw new Error("this browser has no WebGL2: the page needs it to draw the stimuli as the display gets them");
  let path = "WebGL2, 8-bit canvas";
  if ((output === "10bit" || output === "12bit") && typeof gl.drawingBufferStorage === "function") {
    gl.drawingBufferStorage(gl.RGBA16F, width, height);
    path = "WebGL2, float16 drawing buffer (10 bits of each code kept)";
  }
  const program = fullScreenProgram(gl, FRAGMENT);
  nearestTexture(gl);
  // Texture row 0 is the bottom: flip the image's rows.
  const rgba = new Float32Array(width * height * 4);
  for (let y = 0; y < height; y++) {
    for (let x = 0; x < width; x++) {
      const from = 3 * ((height - 1 - y) * width + x);
      const to = 4 * (y * width + x);
      rgba.set(linear.subarray(from, from + 3), to);
      rgba[to + 3] = 1;
    }
  }
  gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, width, height, 0, gl.RGBA, gl.FLOAT, rgba);
  gl.uniform1i(gl.getUniformLocation(program, "image"), 0);
  gl.uniform3fv(gl.getUniformLocation(program, "inverseGamma"), gammas.map((g) => 1 / g));
  gl.uniform1i(gl.getUniformLocation(program, "method"), METHOD[output]);
  gl.uniform1ui(gl.getUniformLocation(program, "frameSeed"), 1);
  gl.viewport(0, 0, width, height);
  gl.drawArrays(gl.TRIANGLES, 0, 3);
  return path;
}

function fact(name, value) {
  $("facts").append(el("dt", name), el("dd", value));
}

const summary = (s) => `mean ${fmt(s.mean, 3)}, p95 ${fmt(s.p95, 3)}, max ${fmt(s.max, 3)}`;

async function showList() {
  $("list-view").hidden = false;
  const body = $("set-table").tBodies[0];
  for (const s of await api("/api/stimulus-sets")) {
    const tr = el("tr");
    const link = el("a", String(s.id), { href: `/stimulus-sets/${s.id}` });
    const cell = el("td");
    cell.append(link);
    tr.append(cell);
    for (const v of [s.source === "render" ? `render ${s.render_id} (${s.scene})` : "upload", s.codings.join(", "),
      s.reference, `${s.width} × ${s.height}`, String(s.profile_id), s.policy, s.output, localTime(s.created_at)]) {
      tr.append(el("td", v));
    }
    body.append(tr);
  }
}

async function showSet(id) {
  $("set-view").hidden = false;
  const set = await api(`/api/stimulus-sets/${id}`);
  const profile = await api(`/api/display-profiles/${set.profile_id}`);
  const report = set.report;
  const gammas = profile.profile.transfer.map((t) => t.gamma);
  $("set-title").textContent = `Stimulus set ${set.id}: ${set.codings.length} codings against ${set.reference}`;
  fact("source", set.source === "render"
    ? `render ${set.render_id} of ${set.scene}, camera images ${set.provenance.image_ids.join(", ")} (one set of paths)`
    : `an uploaded OpenEXR: “${set.provenance.stated}” (SHA-256 ${set.provenance.file_sha256}, ${set.provenance.file_bytes} bytes)`);
  fact("image", `${set.width} × ${set.height} px`);
  fact("display profile", `${profile.name} (profile ${profile.id}), γ ${gammas.map((g) => fmt(g, 3)).join(", ")}`);
  fact("observer", observerName(set.observer));
  fact("display white", `XYZ ${report.white.map((v) => fmt(v, 4)).join(", ")} (Y in cd/m²): the white of every ΔE00 here`);
  fact("gamut policy", `${set.policy}: ${report.gamut.out_of_gamut} of ${report.gamut.colours} colours out of gamut` +
    (set.policy === "scale" ? `, every colour × ${fmt(report.gamut.scale_factor, 4)}` : ""));
  fact("output", `${set.output} (${OUTPUT_NAMES[set.output]}): the display will be asked to show this`);
  fact("created", localTime(set.created_at));

  const linear = {};
  for (const c of set.codings) {
    const r = await fetch(`/api/stimulus-sets/${id}/linear/${encodeURIComponent(c)}`);
    if (!r.ok) throw new Error(`the linear RGB of ${c}: ${r.status}`);
    linear[c] = new Float32Array(await r.arrayBuffer());
  }
  const select = $("output");
  for (const o of Object.keys(METHOD)) select.add(new Option(OUTPUT_NAMES[o], o, false, o === set.output));
  const figures = $("codings");
  const canvases = {};
  for (const c of report.codings) {
    const figure = el("figure");
    figure.dataset.coding = c.coding;
    const pair = el("div", null, "pair");
    const canvas = el("canvas");
    canvas.className = "as-displayed";
    canvases[c.coding] = canvas;
    const map = el("img", null, { alt: `ΔE00 map of ${c.coding} against ${set.reference}`, className: "delta-e-map" });
    map.src = `/api/stimulus-sets/${id}/delta-e/${encodeURIComponent(c.coding)}`;
    pair.append(canvas, map);
    const caption = el("figcaption");
    const a = c.against_reference;
    const atOutput = a && a.shown.find((s) => s.output === set.output);
    caption.append(el("strong", c.coding), el("span", a
      ? ` — left: as the display is asked to show it; right: ΔE00 against ${set.reference} as the display shows ` +
        `both at ${set.output} (${summary(atOutput.delta_e00)}). As rendered: ${summary(a.rendered)}; after the gamut ` +
        `policy, unquantised: ${summary(a.intended)}. Out of gamut before the policy: ${c.out_of_gamut_pixels} pixels.`
      : ` — the reference: as the display is asked to show it (its map against itself is 0 everywhere). Out of ` +
        `gamut before the policy: ${c.out_of_gamut_pixels} pixels.`));
    figure.append(pair, caption);
    figures.append(figure);
  }
  const redraw = () => {
    let path = "";
    for (const c of set.codings) path = draw(canvases[c], linear[c], set.width, set.height, gammas, select.value);
    $("draw-path").textContent = `drawn with ${path}`;
    $("draw-hint").textContent = `Each image is drawn as the display gets it: linear RGB → drive = linear^(1/γ) per ` +
      `gun → ${OUTPUT_NAMES[select.value]}. This screen is not the calibrated display: the codes are right, the ` +
      `colours you see here are this screen's.` +
      (select.value === "12bit" || select.value === "10bit" ? " Codes beyond this canvas's depth are shown at its nearest." : "");
  };
  select.addEventListener("change", redraw);
  redraw();

  // The maps' one scale.
  const top = report.delta_e_map_scale_max;
  const stops = ["#440154", "#482878", "#3e4989", "#31688e", "#26828e", "#1f9e89", "#35b779", "#6ece58", "#b5de2b", "#fde725"];
  $("scale-bar").style.background = `linear-gradient(to right, ${stops.join(", ")})`;
  for (const f of [0, 0.25, 0.5, 0.75, 1]) {
    const t = el("span", fmt(f * top, 3));
    t.style.left = `${100 * f}%`;
    t.style.transform = f === 0 ? "none" : f === 1 ? "translateX(-100%)" : "translateX(-50%)";
    $("scale-ticks").append(t);
  }
  $("scale-caption").textContent = `CIEDE2000 ΔE00 per pixel against ${set.reference}, both as the display shows them ` +
    `at ${set.output}, with the display's white; viridis from 0 to ${fmt(top, 3)} (the set's largest, rounded up), ` +
    `the same for every coding.`;

  // The quantisation's share: shown against the reference at each depth,
  // beside the unquantised (intended) difference and the quantisation alone.
  const outputs = Object.keys(METHOD);
  const head = el("tr");
  head.append(el("th", "coding"), el("th", "intended"));
  for (const o of outputs) head.append(el("th", `shown ${o}`), el("th", `quantisation ${o}`));
  $("shares").tHead.append(head);
  for (const c of report.codings) {
    const tr = el("tr");
    const a = c.against_reference;
    tr.append(el("td", c.coding), el("td", a ? fmt(a.intended.mean, 3) : "—"));
    for (const o of outputs) {
      const shown = a && a.shown.find((s) => s.output === o);
      const q = c.quantisation.find((s) => s.output === o);
      tr.append(el("td", shown ? fmt(shown.delta_e00.mean, 3) : "—"), el("td", fmt(q.delta_e00.mean, 3)));
    }
    $("shares").tBodies[0].append(tr);
  }
  const bound = report.quantisation_bound.map(([b, v]) => `${b} bits ${fmt(v, 3)}`).join(", ");
  $("shares-caption").textContent = `Mean ΔE00 over the image's pixels. “intended”: against ${set.reference} after the ` +
    `gamut policy, unquantised (a display of unlimited depth); “shown”: against ${set.reference} as the display shows ` +
    `both at that output; “quantisation”: the coding's own intended → shown (the output's share). noisy_bit is the ` +
    `mean over frames. The worst ΔE00 half a code can cause (sampled): ${bound}.`;

  // The verification: a coding, the screen's geometry; the newest result.
  for (const c of set.codings) $("verify-coding").add(new Option(c, c));
  $("verify-coding").value = set.codings.find((c) => c !== set.reference) || set.reference;
  if (set.source !== "render") {
    $("verify").disabled = true;
    $("verify-state").textContent = "an uploaded set names no scene: its targets cannot be projected into it";
  }
  const done = await api(`/api/stimulus-sets/${id}/verifications`);
  if (done.length) showVerification(set, done[done.length - 1]);
  $("verify-form").addEventListener("submit", async (ev) => {
    ev.preventDefault();
    $("verify").disabled = true;
    try {
      await verify(set, gammas, linear);
    } catch (e) {
      document.body.classList.remove("running");
      notice("verification stopped: " + e.message);
    } finally {
      $("verify").disabled = false;
    }
  });
  addEventListener("keydown", async (ev) => {
    if (ev.key !== "Escape" || check.hold === null) return;
    check.cancelled = true;
    if (check.measurementId !== null) {
      await api(`/api/measurements/${check.measurementId}/cancel`, { method: "POST", body: "{}" }).catch(() => {});
    }
  });
}

// ---- verification on the display -------------------------------------------

// The full-screen image: the coding's linear RGB at one screen pixel per
// image pixel, centred, black around it; a ring marks the target to aim at
// (outside the field, and gone before the instrument measures).
const SCREEN_FRAGMENT = `#version 300 es
precision highp float;
precision highp int;
precision highp sampler2D;
uniform sampler2D image;
uniform ivec2 origin;         // the image's lower-left screen pixel
uniform ivec2 size;           // the image's size, image pixels
uniform int magnification;    // screen pixels per image pixel, each way
uniform vec2 ring;            // the marker's centre (screen pixels), or (-1e9, -1e9)
uniform vec2 ringRadii;       // inner and outer radius
${OUTPUT_GLSL}
out vec4 colour;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  ivec2 q = p - origin;
  vec3 linear = vec3(0.0);
  if (all(greaterThanEqual(q, ivec2(0))) && all(lessThan(q, size * magnification))) {
    linear = texelFetch(image, q / magnification, 0).rgb;
  }
  float d = distance(gl_FragCoord.xy, ring);
  if (d >= ringRadii.x && d <= ringRadii.y) linear = vec3(1.0, 0.0, 1.0);
  colour = vec4(shown(linear, p), 1.0);
}`;

// Frames of the field read back per target for the simulated display (every
// dithered pixel and frame counted).
const READBACK_FRAMES = 16;

const check = { hold: null, measurementId: null, cancelled: false };

function screenFor(set, gammas, coding, linear, m) {
  if (set.output === "12bit") {
    throw new Error("a 12-bit set cannot be verified from a browser: its drawing buffer keeps 10 bits (make the set at 10 bits)");
  }
  const canvas = $("screen");
  const dpr = window.devicePixelRatio || 1;
  canvas.width = Math.round(innerWidth * dpr);
  canvas.height = Math.round(innerHeight * dpr);
  const gl = canvas.getContext("webgl2", { antialias: false, alpha: false, preserveDrawingBuffer: true });
  if (!gl) throw new Error("this browser has no WebGL2: the verification needs it to draw the image as the display gets it");
  if (set.output === "10bit") {
    if (typeof gl.drawingBufferStorage !== "function") throw new Error("10-bit output: this browser offers no float drawing buffer");
    gl.drawingBufferStorage(gl.RGBA16F, canvas.width, canvas.height);
  }
  if (canvas.width < set.width * m || canvas.height < set.height * m) {
    throw new Error(`the screen (${canvas.width} × ${canvas.height} px) is smaller than the image magnified ×${m} ` +
      `(${set.width * m} × ${set.height * m}): use a smaller magnification`);
  }
  const program = fullScreenProgram(gl, SCREEN_FRAGMENT);
  nearestTexture(gl);
  const rgba = new Float32Array(set.width * set.height * 4);
  for (let y = 0; y < set.height; y++) {
    for (let x = 0; x < set.width; x++) {
      const from = 3 * ((set.height - 1 - y) * set.width + x);
      rgba.set(linear.subarray(from, from + 3), 4 * (y * set.width + x));
      rgba[4 * (y * set.width + x) + 3] = 1;
    }
  }
  gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, set.width, set.height, 0, gl.RGBA, gl.FLOAT, rgba);
  const u = (n) => gl.getUniformLocation(program, n);
  const origin = [Math.floor((canvas.width - set.width * m) / 2), Math.floor((canvas.height - set.height * m) / 2)];
  gl.uniform1i(u("image"), 0);
  gl.uniform2i(u("origin"), origin[0], origin[1]);
  gl.uniform2i(u("size"), set.width, set.height);
  gl.uniform1i(u("magnification"), m);
  gl.uniform3fv(u("inverseGamma"), gammas.map((g) => 1 / g));
  gl.uniform1i(u("method"), METHOD[set.output]);
  gl.viewport(0, 0, canvas.width, canvas.height);
  let frame = 0;
  const maxCode = set.output === "10bit" ? 1023 : 255;
  return {
    // A target's centre on the screen (GL coordinates, y up).
    centre: (t) => [origin[0] + m * t.x, origin[1] + m * (set.height - t.y)],
    draw(ring, radii) {
      gl.uniform2f(u("ring"), ring ? ring[0] : -1e9, ring ? ring[1] : -1e9);
      gl.uniform2f(u("ringRadii"), radii ? radii[0] : 0, radii ? radii[1] : 0);
      gl.uniform1ui(u("frameSeed"), (frame++ * 2654435761) >>> 0);
      gl.drawArrays(gl.TRIANGLES, 0, 3);
    },
    // Adds the codes of the screen pixels whose centres lie within `r` of `c`.
    count(c, r, counts) {
      const x0 = Math.max(0, Math.floor(c[0] - r)), y0 = Math.max(0, Math.floor(c[1] - r));
      const w = Math.min(canvas.width, Math.ceil(c[0] + r) + 1) - x0, h = Math.min(canvas.height, Math.ceil(c[1] + r) + 1) - y0;
      let values;
      if (maxCode === 255) {
        values = new Uint8Array(w * h * 4);
        gl.readPixels(x0, y0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, values);
      } else {
        const f = new Float32Array(w * h * 4);
        gl.readPixels(x0, y0, w, h, gl.RGBA, gl.FLOAT, f);
        values = f.map((v) => Math.round(v * maxCode));
      }
      for (let j = 0; j < h; j++) {
        for (let i = 0; i < w; i++) {
          const dx = x0 + i + 0.5 - c[0], dy = y0 + j + 0.5 - c[1];
          if (dx * dx + dy * dy > r * r) continue;
          const k = 4 * (j * w + i);
          for (let ch = 0; ch < 3; ch++) counts[ch][Math.min(maxCode, Math.max(0, values[k + ch]))]++;
        }
      }
    },
    maxCode,
  };
}

// Waits for Space (aimed) or Esc (cancel).
function waitForAim() {
  return new Promise((resolve) => {
    const key = (ev) => {
      if (ev.key === " " || ev.key === "Escape") {
        removeEventListener("keydown", key);
        if (ev.key === "Escape") check.cancelled = true;
        resolve();
      }
    };
    addEventListener("keydown", key);
  });
}

async function verify(set, gammas, linear) {
  notice("");
  const coding = $("verify-coding").value;
  const screen = { viewing_distance_mm: Number($("verify-distance").value), pixel_pitch_mm: Number($("verify-pitch").value),
    magnification: Number($("verify-magnification").value) };
  const query = `viewing_distance_mm=${screen.viewing_distance_mm}&pixel_pitch_mm=${screen.pixel_pitch_mm}` +
    `&magnification=${screen.magnification}`;
  const plan = await api(`/api/stimulus-sets/${set.id}/targets?${query}`);
  const targets = plan.targets.filter((t) => t.verifiable);
  if (!targets.length) throw new Error("no target of the scene is inside the image and unhidden");
  const view = screenFor(set, gammas, coding, linear[coding], plan.magnification);
  const r = plan.field_radius_px;
  let marker = null;
  const { measured, cancelled, simulated } = await holdShowMeasure(api, {
    purpose: plan.hold_purpose, patches: targets, samples: Number($("verify-samples").value), run: check,
    note: (t) => `stimulus set ${set.id} verification: ${coding} at target ${t.id}`,
    onHeld: () => document.body.classList.add("running"),
    progress: (i, total) => { $("hud").textContent = `target ${targets[i].id}: ${i + 1} of ${total} · Esc cancels`; },
    show: (t, i, isSimulated) => {
      const c = view.centre(t);
      let running = true;
      marker = isSimulated ? null : c;
      const counts = [0, 1, 2].map(() => new Array(view.maxCode + 1).fill(0));
      let frames = 0, done;
      const counted = new Promise((resolve) => { done = resolve; });
      const tick = () => {
        if (!running) return;
        view.draw(marker, [r + 3, r + 6]);
        if (isSimulated && frames < READBACK_FRAMES) {
          view.count(c, r, counts);
          if (++frames === READBACK_FRAMES) done({ code_counts: counts, max_code: view.maxCode });
        }
        requestAnimationFrame(tick);
      };
      requestAnimationFrame(tick);
      if (!isSimulated) done(null);
      return { display: counted, stop: () => { running = false; } };
    },
    aimed: async (t) => {
      $("hud").textContent = `aim the instrument at the ring (target ${t.id}) and press Space · Esc cancels`;
      await waitForAim();
      marker = null; // nothing but the image while the instrument measures
    },
  });
  document.body.classList.remove("running");
  if (cancelled) {
    notice("verification cancelled: nothing was stored as a verification; what was measured stays stored.");
    return;
  }
  const v = await api(`/api/stimulus-sets/${set.id}/verifications`, { method: "POST", body: JSON.stringify({
    coding, screen, client: `${navigator.userAgent}; WebGL2` + (simulated ? "; simulated display" : ""),
    targets: measured.map(({ patch, measurement }) => ({ target: patch.id, measurement_id: measurement.id })) }) });
  showVerification(set, v);
}

function showVerification(set, v) {
  const body = $("verify-table").tBodies[0];
  body.replaceChildren();
  for (const t of v.result.targets) {
    const tr = el("tr");
    for (const cell of [t.id, String(t.pixels), fmt(t.intended[1], 4), fmt(t.emitted[1], 4),
      t.booth_xyz ? fmt(t.booth_xyz[1], 4) : "not measured", fmt(t.delta_e00_intended_emitted, 3),
      fmt(t.delta_e00_quantisation, 3), fmt(t.delta_e00_profile, 3),
      t.delta_e00_booth_emitted === null ? "—" : fmt(t.delta_e00_booth_emitted, 3)]) tr.append(el("td", cell));
    body.append(tr);
  }
  const r = v.result;
  $("verify-caption").textContent = `Verification ${v.id} of ${v.coding} (${localTime(v.created_at)}): the instrument's ` +
    `field covered a disc of ${fmt(r.field_radius_px, 3)} screen pixels around each target, the image shown ` +
    `×${r.magnification}. ΔE00 with the display's white; ` +
    `Y in cd/m². “quantisation”: intended → what the profile predicts of the ${r.output} codes; “display vs profile”: ` +
    `predicted → emitted. The booth's measurement is shown through the set's gamut policy (${r.policy}, × ` +
    `${fmt(r.scale_factor, 4)}), as the image was. Largest ΔE00 intended → emitted ${fmt(r.max_delta_e00_intended_emitted, 3)}` +
    (r.max_delta_e00_booth_emitted === null ? "." : `; booth → emitted ${fmt(r.max_delta_e00_booth_emitted, 3)}.`) +
    (r.angular_size_note ? ` Note: ${r.angular_size_note}` : "");
  $("verify-chart").src = `/api/stimulus-sets/${set.id}/verifications/${v.id}/profile.svg`;
  $("verification").hidden = false;
}

startPage().then(() => {
  showNavigation();
  const m = location.pathname.match(/^\/stimulus-sets\/(\d+)$/);
  (m ? showSet(Number(m[1])) : showList()).catch((e) => notice(e.message));
});
