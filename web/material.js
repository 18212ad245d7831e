// The "measure a material" view: measure the white standard, then the sample
// in the same geometry, then save the reflectance (POST /api/reflectances).
// The chart is the daemon's SVG. app.js shows it (showMaterialView) when the
// hash names it.
import { $, api, fmt, notice } from "./shared.js";

let materialScenes = [];

function fillMaterialTargets(sceneSel, targetSel, preferred) {
  const s = materialScenes.find((x) => x.id === $(sceneSel).value);
  const sel = $(targetSel);
  sel.replaceChildren();
  for (const t of s ? s.targets : []) sel.add(new Option(t, t));
  if (s && s.targets.includes(preferred)) sel.value = preferred;
}

/** The Material view: its scene and target choices once, and the stored reflectances. */
export async function showMaterialView() {
  if (!materialScenes.length) {
    try {
      materialScenes = await api("/api/scenes");
    } catch (e) {
      materialScenes = [];
    }
    for (const [sceneSel, targetSel, preferred] of [
      ["mat-standard-scene", "mat-standard-target", "standard"],
      ["mat-sample-scene", "mat-sample-target", "sample"],
    ]) {
      const sel = $(sceneSel);
      for (const s of materialScenes) sel.add(new Option(s.id, s.id));
      if (materialScenes.some((s) => s.id === "material_bench")) sel.value = "material_bench";
      sel.addEventListener("change", () => fillMaterialTargets(sceneSel, targetSel, preferred));
      fillMaterialTargets(sceneSel, targetSel, preferred);
    }
  }
  loadReflectances();
}

// Measures a scene target and waits for the end; shows the state in `stateId`.
async function measureStep(sceneSel, targetSel, idInput, stateId) {
  notice("");
  const body = { scene: $(sceneSel).value, target: $(targetSel).value, samples: Number($("mat-samples").value) };
  const state = $(stateId);
  try {
    const r = await api("/api/measurements", { method: "POST", body: JSON.stringify(body) });
    $(idInput).value = r.id;
    state.textContent = `measurement ${r.id}: queued`;
    for (;;) {
      await new Promise((ok) => setTimeout(ok, 400));
      const m = await api(`/api/measurements/${r.id}`);
      if (m.state === "queued" || m.state === "running") {
        state.textContent = `measurement ${r.id}: ${m.state}, sample ${m.samples_taken} of ${m.samples_requested}`;
        continue;
      }
      state.textContent = m.state === "complete"
        ? `measurement ${r.id}: complete, Y = ${fmt(m.Y, 5)} cd/m² (${m.good_samples} good samples)`
        : `measurement ${r.id}: ${m.state} ${m.error || ""}`;
      state.className = "step-state " + (m.state === "complete" ? "ok" : "flag");
      return;
    }
  } catch (e) {
    notice(e.message);
  }
}

$("mat-measure-standard").addEventListener("click", () =>
  measureStep("mat-standard-scene", "mat-standard-target", "mat-standard-id", "mat-standard-state"));
$("mat-measure-sample").addEventListener("click", () =>
  measureStep("mat-sample-scene", "mat-sample-target", "mat-sample-id", "mat-sample-state"));
$("mat-standard-cal").addEventListener("change", () => {
  $("mat-standard-file").hidden = $("mat-standard-cal").value !== "file";
});

// The calibration fields of a request: a shipped standard, or the chosen file's text.
async function standardFields() {
  if ($("mat-standard-cal").value !== "file") return { standard: $("mat-standard-cal").value };
  const f = $("mat-standard-file").files[0];
  if (!f) throw new Error("choose the standard's certificate CSV file");
  return { standard_csv: await f.text(), standard_file: f.name };
}

function showReflectance(r) {
  $("mat-result").hidden = false;
  $("mat-title").textContent = `Reflectance ${r.id} “${r.name}”: measurement ${r.sample_measurement_id} against the standard in measurement ${r.standard_measurement_id}`;
  const f = r.flags;
  const flags = $("mat-flags");
  const parts = [];
  if (f.above_one_nm.length) parts.push(`ρ > 1 at ${f.above_one_nm.length} wavelength(s) (${f.above_one_nm.slice(0, 8).join(", ")}${f.above_one_nm.length > 8 ? ", …" : ""} nm; max ${fmt(f.max, 4)})`);
  if (f.below_zero_nm.length) parts.push(`ρ < 0 at ${f.below_zero_nm.length} wavelength(s) (min ${fmt(f.min, 4)})`);
  flags.className = parts.length ? "flag" : "ok";
  flags.textContent = parts.length
    ? "Flagged, kept as measured: " + parts.join("; ") + "."
    : `Every value in [0, 1] (ρ from ${fmt(f.min, 3)} to ${fmt(f.max, 3)}).`;
  const uMax = Math.max(...r.uncertainty);
  $("mat-provenance").textContent =
    `Standard's calibration ${r.standard.file} (sha256 ${r.standard.sha256.slice(0, 16)}…)` +
    (r.standard.uncertainty_stated ? "" : ", no uncertainty stated (taken as 0)") +
    `; largest standard uncertainty u = ${fmt(uMax, 2)}.`;
  const csv = $("mat-csv");
  csv.href = `/api/reflectances/${r.id}/csv` + (parts.length ? "?clip=true" : "");
  csv.textContent = `${r.name}.csv (scene spectrum)`;
  $("mat-csv-note").textContent = parts.length
    ? "clipped to [0, 1] for the scene, as its header says"
    : `use as reflectance = "spectra/${r.name}.csv:${r.name}"`;
  $("mat-chart").src = `/api/reflectances/${r.id}/chart.svg`;
}

$("material-form").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  notice("");
  try {
    const body = Object.assign(
      {
        sample_measurement_id: Number($("mat-sample-id").value),
        standard_measurement_id: Number($("mat-standard-id").value),
      },
      await standardFields(),
    );
    if ($("mat-name").value.trim()) body.name = $("mat-name").value.trim();
    const r = await api("/api/reflectances", { method: "POST", body: JSON.stringify(body) });
    showReflectance(r);
    loadReflectances();
  } catch (e) {
    notice(e.message);
  }
});

$("mat-save-lamp").addEventListener("click", async () => {
  notice("");
  try {
    const body = Object.assign({ measurement_id: Number($("mat-standard-id").value) }, await standardFields());
    const s = await api("/api/illuminants", { method: "POST", body: JSON.stringify(body) });
    const a = document.createElement("a");
    a.href = `/api/illuminants/${s.id}/csv`;
    a.textContent = `${s.name}.csv`;
    $("mat-lamp").textContent = `Lamp spectrum ${s.id} from measurement ${s.measurement_id} (relative, 100 at 560 nm; Y = ${fmt(s.Y, 4)} cd/m² on the standard): `;
    $("mat-lamp").appendChild(a);
  } catch (e) {
    notice(e.message);
  }
});

async function loadReflectances() {
  let rows = [];
  try {
    rows = await api("/api/reflectances");
  } catch (e) {
    notice(e.message);
  }
  const body = document.querySelector("#reflectance-table tbody");
  body.replaceChildren();
  for (const r of rows) {
    const tr = document.createElement("tr");
    const flagged = r.flags.above_one_nm.length + r.flags.below_zero_nm.length;
    for (const v of [r.id, r.name, r.sample_measurement_id, r.standard_measurement_id, r.standard.file, fmt(r.flags.max, 4),
      flagged ? `${flagged} outside [0, 1]` : "none"]) {
      const td = document.createElement("td");
      td.textContent = v;
      tr.appendChild(td);
    }
    tr.className = "clickable";
    tr.title = "show this reflectance";
    tr.addEventListener("click", () => showReflectance(r));
    body.appendChild(tr);
  }
}
