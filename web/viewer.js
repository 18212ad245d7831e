// The image viewer (#/viewer/SCENE): camera images of the scene's newest
// complete render in any coding (lab::images), a pixel probe with
// the pixel's channels ± SE charted by the daemon, and the per-pixel ΔE00
// map between two codings with its scale bar. app.js shows it
// (showViewerView) when the hash names it.
import { $, api, duration, fmt, luminanceScale, notice, observerName, onLabEvent } from "./shared.js";

let viewerRender = null; // the render whose images are shown
let viewerShown = null; // ImageInfo of the image on screen
let viewerWaiting = null;
const viewerWake = [];
// Progress of the image being waited for, from the page's event stream.
onLabEvent(["image_progress"], (p) => {
  if (!viewerWaiting || p.image_id !== viewerWaiting) return;
  const bar = $("viewer-progress");
  bar.hidden = false;
  bar.value = p.pixels ? p.pixels_done / p.pixels : 0;
  // The daemon's upper bound (its path cap, its time budget and a pass),
  // or why there is none (lab::progress::image_time_left).
  const left = p.seconds_left === null || p.seconds_left === undefined ? null : p.seconds_left;
  $("viewer-state").textContent =
    `image ${p.image_id}: pass ${p.pass}, ${p.pixels_done} of ${p.pixels} pixels done, ` +
    `${p.paths.toLocaleString()} paths, ${fmt(p.elapsed_seconds, 2)} s` +
    (left === null ? (p.estimate ? `; ${p.estimate}` : "") : `; about ${duration(left)} left at most (${p.estimate})`);
});
onLabEvent(["image_finished"], () => viewerWake.splice(0).forEach((f) => f()));

/** The Viewer view: pick a scene of `sceneInfo` (GET /api/scenes); its
 * newest complete render's images. */
export async function showViewerView(sceneId, sceneInfo) {
  const select = $("viewer-scene");
  if (!select.options.length) {
    for (const s of sceneInfo) select.add(new Option(`${s.title} (${s.id})`, s.id));
    select.addEventListener("change", () => (location.hash = `#/viewer/${select.value}`));
  }
  const scene = sceneId || select.value || (sceneInfo[0] && sceneInfo[0].id);
  if (!scene) return;
  select.value = scene;
  const renders = await api(`/api/scenes/${scene}/renders`);
  const done = renders.find((r) => r.state === "complete") || null;
  $("viewer-scene-state").textContent = done ? ""
    : "No complete render of this scene yet: measure one of its targets (the daemon renders it to compare), then come back.";
  if (viewerRender?.id !== done?.id) openImageViewer(done);
}

function openImageViewer(render) {
  viewerRender = render;
  viewerShown = null;
  $("image-viewer").hidden = !render;
  for (const id of ["viewer-figure", "probe-figure", "de-figure"]) $(id).hidden = true;
  $("viewer-state").textContent = "";
  $("viewer-progress").hidden = true;
  if (!render) return;
  $("viewer-title").textContent = `Image viewer: render ${render.id}`;
  for (const [select, preferred] of [["viewer-coding", "spectral"], ["viewer-against", "rgb"]]) {
    const s = $(select);
    s.replaceChildren();
    for (const c of render.codings) s.add(new Option(c, c, false, c === preferred));
  }
  // The stimulus set: the render's codings, the reference last (spectral when it has it).
  const codings = render.codings.filter((c) => c !== "spectral").concat(render.codings.includes("spectral") ? ["spectral"] : []);
  $("stimulus-codings").value = codings.join(",");
  $("stimulus-state").replaceChildren();
  api("/api/display-profiles").then((profiles) => {
    const select = $("stimulus-profile");
    select.replaceChildren();
    for (const p of profiles.filter((p) => p.state === "passed")) select.add(new Option(`${p.id}: ${p.name}`, p.id));
    if (!select.options.length) $("stimulus-state").textContent = "No passing display profile yet: calibrate the display first (Calibrate).";
  }, (e) => notice(e.message));
}

// Makes a stimulus set of the listed codings (rendered together) and links to its page.
$("stimulus-form").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  notice("");
  const state = $("stimulus-state");
  try {
    const codings = $("stimulus-codings").value.split(",").map((c) => c.trim()).filter(Boolean);
    const infos = await viewerSet(codings);
    state.textContent = "converting…";
    const set = await api("/api/stimulus-sets", { method: "POST", body: JSON.stringify({
      image_id: infos[0].id, display_profile_id: Number($("stimulus-profile").value),
      gamut: $("stimulus-gamut").value, output: $("stimulus-output").value }) });
    const link = document.createElement("a");
    link.href = `/stimulus-sets/${set.id}`;
    link.id = "stimulus-link";
    link.textContent = `stimulus set ${set.id}: ${set.codings.join(", ")} against ${set.reference}`;
    state.replaceChildren(link);
  } catch (e) {
    state.textContent = "";
    notice(e.message);
  }
});

// Waits (bounded by the daemon's time budget) until an image of the
// render in `coding` is complete; queues it if there is none.
async function viewerImage(coding) {
  return (await viewerSet([coding]))[0];
}

// The same for images in several codings rendered from the same paths
// (one request, `codings`; the last is their reference), so that their
// difference is the codings', not two draws of noise.
async function viewerSet(codings) {
  const body = codings.length === 1 ? { coding: codings[0] } : { codings };
  const r = await api(`/api/renders/${viewerRender.id}/images`, { method: "POST", body: JSON.stringify(body) });
  const ids = r.images.map((i) => i.image_id);
  const named = `image${ids.length > 1 ? "s" : ""} ${ids.join(", ")} (${codings.join(", ")})`;
  viewerWaiting = r.image_id;
  $("viewer-cancel").hidden = false;
  $("viewer-cancel").dataset.id = r.image_id;
  try {
    for (;;) {
      const infos = await Promise.all(ids.map((id) => api(`/api/images/${id}`)));
      if (infos.every((i) => i.state === "complete")) return infos;
      const ended = infos.find((i) => i.state === "failed" || i.state === "cancelled");
      if (ended) throw new Error(`${named} ${ended.state}: ${ended.error || ""}`);
      $("viewer-state").textContent = `${named}: ${infos[0].state}`;
      await new Promise((wake) => { viewerWake.push(wake); setTimeout(wake, 1000); });
    }
  } finally {
    viewerWaiting = null;
    $("viewer-cancel").hidden = true;
    $("viewer-progress").hidden = true;
    $("viewer-state").textContent = "";
  }
}

// The coding's swatch and name, as nodes (text, never markup).
function codingLabel(info) {
  const swatch = document.createElement("span");
  swatch.className = "swatch";
  swatch.style.background = info.colour;
  const label = document.createElement("span");
  label.append(swatch, info.settings.coding);
  return label;
}

$("viewer-form").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  notice("");
  const render = viewerRender;
  try {
    const info = await viewerImage($("viewer-coding").value);
    if (render !== viewerRender) return;
    viewerShown = info;
    const img = $("viewer-image");
    img.onload = () => {
      const s = info.settings;
      $("viewer-scale").replaceChildren(...(info.display_log_average_cd_m2
        ? [luminanceScale(info.display_log_average_cd_m2, `${s.coding} coding`)] : []));
      const spp = info.paths / (s.width * s.height);
      $("viewer-caption").replaceChildren(`Image ${info.id} of render ${info.render_id}: `, codingLabel(info),
        ` coding, ${s.width} × ${s.height} px, ` +
        `${fmt(spp, 3)} paths per pixel on average (${s.min_spp}–${s.max_spp}; ${info.passes} passes, stop: ` +
        `${info.stop.replace("_", " ")}), ${fmt(info.elapsed_seconds, 3)} s. Shown as XYZ (observer: ` +
        `${observerName(info.observer)}) → linear sRGB → Reinhard global tone map (each pixel × 0.18 / the ` +
        `log-average luminance, then v / (1 + v)) → sRGB encoding: for looking at, not for measuring. ` +
        `Click a pixel to probe it.`);
      $("viewer-state").textContent = "";
    };
    img.src = `/api/images/${info.id}/display.png`;
    $("viewer-exr").href = `/api/images/${info.id}/image.exr`;
    $("viewer-mat").href = `/api/images/${info.id}/image.mat`;
    $("viewer-figure").hidden = false;
    $("viewer-marker").hidden = true;
  } catch (e) {
    notice(e.message);
  }
});

$("viewer-image").addEventListener("click", async (ev) => {
  const info = viewerShown;
  if (!info) return;
  const img = ev.currentTarget;
  const scale = img.naturalWidth / img.clientWidth;
  const x = Math.min(img.naturalWidth - 1, Math.floor(ev.offsetX * scale));
  const y = Math.min(img.naturalHeight - 1, Math.floor(ev.offsetY * scale));
  const marker = $("viewer-marker");
  Object.assign(marker.style, {
    left: `${x / scale}px`, top: `${y / scale}px`, width: `${Math.max(6, 1 / scale)}px`, height: `${Math.max(6, 1 / scale)}px`,
  });
  marker.hidden = false;
  try {
    const p = await api(`/api/images/${info.id}/pixel?x=${x}&y=${y}`);
    const chart = $("probe-chart");
    chart.src = `/api/images/${info.id}/pixel.svg?x=${x}&y=${y}`;
    const pm = (q, d = 4) => `${fmt(q.mean, d)} ± ${fmt(q.se, 2)}`;
    $("probe-caption").replaceChildren(`Pixel (${x}, ${y}) of image ${info.id}, `, codingLabel(info),
      `, ${fmt(p.paths_per_pixel, 3)} paths: ` +
      `${p.wavelengths_nm ? "spectral radiance (W/(sr·m²·nm)) against wavelength (nm)" : "linear R, G, B"}, ` +
      `mean ± 1 SE. X = ${pm(p.X)}, Y = ${pm(p.Y)} cd/m², Z = ${pm(p.Z)}; x, y = ${fmt(p.chromaticity_x, 4)}, ` +
      `${fmt(p.chromaticity_y, 4)} (observer: ${observerName(p.observer)}); L, M, S = ${fmt(p.L.mean, 4)}, ` +
      `${fmt(p.M.mean, 4)}, ${fmt(p.S.mean, 4)} (Stockman & Sharpe 2°, L + M in cd/m²).`);
    $("probe-figure").hidden = false;
  } catch (e) {
    notice(e.message);
  }
});

$("viewer-de").addEventListener("click", async () => {
  notice("");
  const render = viewerRender;
  try {
    const [coding, against] = [$("viewer-coding").value, $("viewer-against").value];
    if (coding === against) throw new Error(`pick two different codings for a ΔE00 map (both are ${coding})`);
    const [a, b] = await viewerSet([coding, against]);
    if (render !== viewerRender) return;
    const m = await api(`/api/images/${a.id}/delta-e?against=${b.id}`);
    const stops = m.stops.map((c, i) => `rgb(${c.join(",")}) ${(100 * i) / (m.stops.length - 1)}%`);
    $("de-bar").style.background = `linear-gradient(to right, ${stops.join(", ")})`;
    const ticks = $("de-ticks");
    ticks.replaceChildren();
    for (const f of [0, 0.25, 0.5, 0.75, 1]) {
      const t = document.createElement("span");
      t.style.left = `${100 * f}%`;
      // The end ticks sit inside the bar's ends, not half outside (the "0.000" was cut).
      t.style.transform = f === 0 ? "none" : f === 1 ? "translateX(-100%)" : "translateX(-50%)";
      t.textContent = fmt(f * m.scale_max, 3);
      ticks.appendChild(t);
    }
    $("de-map").src = `/api/images/${a.id}/delta-e.png?against=${b.id}`;
    $("de-caption").replaceChildren("CIEDE2000 ΔE00 per pixel between ", codingLabel(a), ` (image ${a.id}) and `,
      codingLabel(b), ` (image ${b.id}), ` +
      `through CIELAB with the scene's white: ${m.white_source}, XYZ = ${m.white.map((v) => fmt(v, 4)).join(", ")} ` +
      `(observer: ${observerName(m.observer)}). Mean ${fmt(m.mean, 3)}, 95th percentile ${fmt(m.p95, 3)}, ` +
      `max ${fmt(m.max, 3)}; viridis from 0 to ${fmt(m.scale_max, 3)}. The two images were ${m.noise}.`);
    $("de-figure").hidden = false;
  } catch (e) {
    notice(e.message);
  }
});

// Cancels the image being waited for; the daemon keeps nothing of it.
$("viewer-cancel").addEventListener("click", async (ev) => {
  try {
    await api(`/api/images/${ev.currentTarget.dataset.id}/cancel`, { method: "POST", body: "{}" });
  } catch (e) {
    notice(e.message);
  }
});
