// Stimulus sets (/stimulus-sets, /stimulus-sets/ID): the codings of one
// rendered image as the calibrated display will be asked to show them.
// Each coding's linear RGB (GET …/linear/CODING, f32) is drawn with WebGL2
// through the profile's γ and the output method (web/display-gl.js), as
// the experiment's session page draws its stimuli; beside it, its ΔE00 map
// against the reference as the display shows both (drawn by the daemon),
// one scale for the set; then how much of each coding's difference at each
// depth is the quantisation's.
import { $, api, el, fmt, localTime, notice, observerName, startPage } from "./shared.js";
import { fullScreenProgram, METHOD, nearestTexture, OUTPUT_GLSL } from "./display-gl.js";
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
}

startPage().then(() => {
  showNavigation();
  const m = location.pathname.match(/^\/stimulus-sets\/(\d+)$/);
  (m ? showSet(Number(m[1])) : showList()).catch((e) => notice(e.message));
});
