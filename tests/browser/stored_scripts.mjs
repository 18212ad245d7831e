// Issue 32: a display profile's name was a stored script that read the
// write token (calibrate.js wrote it with innerHTML). This stores text
// carrying a script in every named record the API takes — a display
// profile's name, an experiment's name, an observer id, measurement notes,
// a reflectance's standard file and note, an illuminant's standard file —
// and the daemon's caller has put a scene file whose name carries one in
// its scenes folder (SCENE_ID). Then it opens every page in headless
// Chromium, each after a visit with #token=…, and fails if any script runs
// (the payloads call window.__pwned, a function this test exposes), if a
// page lacks a Content-Security-Policy that forbids inline script, if text
// written as HTML on purpose (as a missed innerHTML would) runs its
// event-handler attribute, or if a stored text is not shown, as text, on
// the page that shows its record.
//
// Self-contained (it makes its records over the REST API), so it runs
// against any daemon with --mock whose scenes folder holds the hostile scene:
//
// Usage: node stored_scripts.mjs BASE_URL TOKEN SCREENSHOT_DIR [SCENE_ID]
import { launch, finish } from "./harness.mjs";

const [base, token, shots, sceneId = "hostile"] = process.argv.slice(2);
if (!base || !token) {
  console.error("usage: node stored_scripts.mjs BASE_URL TOKEN [SCREENSHOT_DIR] [SCENE_ID]");
  process.exit(2);
}

// The payload: markup that runs code when written as HTML (an image that
// fails to load and a handler attribute), with no `/` so that file-name
// fields take it too, and none in the handler (an unquoted attribute ends
// at a space). `what` says which record carried it.
const script = (what) => `<img src=x onerror=__pwned('${what.replaceAll(" ", "-")}')>`;

const failures = [];
const auth = { "Authorization": "Bearer " + token };
async function call(method, path, body) {
  const r = await fetch(base + path, {
    method,
    headers: Object.assign({ "Accept": "application/json" }, auth, body ? { "Content-Type": "application/json" } : {}),
    body: body ? JSON.stringify(body) : undefined,
  });
  const text = await r.text();
  let json = null;
  try {
    json = JSON.parse(text);
  } catch (e) {
    // Not JSON: kept as text for the message.
  }
  return { status: r.status, body: json, text };
}
async function must(method, path, body, want) {
  const r = await call(method, path, body);
  if (!want.includes(r.status)) throw new Error(`${method} ${path}: HTTP ${r.status}: ${r.text.slice(0, 300)}`);
  return r.body;
}
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
async function measured(body) {
  const { id } = await must("POST", "/api/measurements", body, [202]);
  for (let i = 0; i < 1200; i++) {
    const m = await must("GET", `/api/measurements/${id}`, undefined, [200]);
    if (m.state === "complete") return id;
    if (!["queued", "running"].includes(m.state)) throw new Error(`measurement ${id}: ${m.state} ${m.error || ""}`);
    await sleep(100);
  }
  throw new Error(`measurement ${id} did not complete in 120 s`);
}

// ---- the records, each with a script in its text ---------------------------

// What each page must show as text: [page, the text].
const shownAs = [];
const ids = {};

async function makeRecords() {
  const scenes = await must("GET", "/api/scenes", undefined, [200]);
  const scene = scenes.find((s) => s.id === sceneId);
  if (!scene) throw new Error(`no scene ${sceneId} in the daemon's scenes folder: the caller puts one there`);
  if (!scene.title.includes("onerror")) throw new Error(`scene ${sceneId}'s name carries no script: ${scene.title}`);
  shownAs.push(["scenes", scene.title], ["scene", scene.title]);

  // A measurement with notes, taken under an instrument hold whose purpose
  // (stored with the measurement, shown on its page) carries a script too.
  const purpose = "calibration " + script("hold purpose");
  const hold = await must("POST", "/api/instrument/hold", { purpose }, [201]);
  ids.free = await measured({ samples: 2, notes: "notes " + script("measurement notes"), hold: hold.id });
  await must("POST", `/api/instrument/hold/${hold.id}/release`, {}, [200]);
  shownAs.push(["measurement", "notes " + script("measurement notes")], ["measurement", purpose]);

  // A display profile (the simulated display, the 4-level plan).
  const plan = await must("GET", "/api/display-profiles/plan?steps=4", undefined, [200]);
  const patches = [];
  for (const p of plan.patches) {
    await must("POST", "/api/mock/display", { drive: p.drive }, [204]);
    patches.push({ drive: p.drive, measurement_id: await measured({ samples: 2 }) });
  }
  const profileName = "monitor " + script("display profile");
  const profile = await must("POST", "/api/display-profiles", { name: profileName, patches }, [201]);
  ids.profile = profile.id;
  shownAs.push(["profile", profileName], ["calibrate", profileName], ["experiments", profileName]);

  // A measurement of WHITE's patch, compared with every coding, with notes.
  ids.compared = await measured({ scene: "white", target: "patch", samples: 3, notes: script("target notes") });
  for (let i = 0; ; i++) {
    const rows = await must("GET", `/api/measurements/${ids.compared}/comparisons`, undefined, [200]);
    if (rows.length >= 3) break;
    if (i > 3000) throw new Error("the comparisons of WHITE's patch were not stored in 300 s");
    await sleep(100);
  }
  // Its experiment, named with a script.
  const experimentName = "oddity " + script("experiment");
  const e = await must("POST", "/api/experiments", {
    name: experimentName, measurement_id: ids.compared, display_profile_id: ids.profile,
    approximations: ["nstep3", "nstep9", "nstep81", "rgb"], output: "noisy_bit",
    presentation: { repeats: 1, adaptation_s: 0, fixation_ms: 250, pixel_pitch_mm: 0.5 },
  }, [201]);
  ids.experiment = e.id;
  shownAs.push(["experiments", experimentName], ["experiment", experimentName], ["run", experimentName]);

  // An observer id with a script is refused, naming the field; an ordinary one runs.
  const hostile = await call("POST", `/api/experiments/${ids.experiment}/sessions`, { observer: script("observer") });
  if (hostile.status !== 400 || !/observer/.test(hostile.text)) {
    failures.push(`an observer id carrying a script: HTTP ${hostile.status} ${hostile.text.slice(0, 200)} (want 400 naming \`observer\`)`);
  }
  await must("POST", `/api/experiments/${ids.experiment}/sessions`, { observer: "obs01" }, [200]);

  // A reflectance and an illuminant with a script in their standard's file name and note.
  const csv = "nm,reflectance\n380,0.98\n780,0.99\n";
  const file = script("standard file") + ".csv";
  const reflectance = await call("POST", "/api/reflectances", {
    sample_measurement_id: ids.compared, standard_measurement_id: ids.free, standard_csv: csv, standard_file: file,
    note: script("reflectance note"),
  });
  if (reflectance.status === 201) shownAs.push(["material", file]);
  else failures.push(`POST /api/reflectances with a script in standard_file: HTTP ${reflectance.status} ${reflectance.text.slice(0, 200)}`);
  const illuminant = await call("POST", "/api/illuminants", {
    measurement_id: ids.free, standard_csv: csv, standard_file: script("illuminant file") + ".csv",
  });
  if (illuminant.status !== 201 && illuminant.status !== 400) {
    failures.push(`POST /api/illuminants with a script in standard_file: HTTP ${illuminant.status} ${illuminant.text.slice(0, 200)}`);
  }
}

// ---- every page -----------------------------------------------------------------

// [key, address, what shows it has loaded].
function pages() {
  return [
    ["home", "/#/home", () => document.querySelectorAll("#home-next-list li").length > 0],
    ["live", "/#/live", () => document.querySelectorAll("#scene-select option").length > 1],
    ["measurements", "/#/measurements", () => document.querySelectorAll("#measurement-table tbody tr").length > 0],
    ["measurement", `/#/measurements/${ids.free}`, () => !document.getElementById("measurement-detail").hidden],
    ["measurement-compared", `/#/measurements/${ids.compared}`,
      () => !document.getElementById("measurement-detail").hidden],
    ["scenes", "/#/scenes", () => document.querySelectorAll("#scene-table > tbody > tr").length > 0],
    ["scene", `/#/scenes/${sceneId}`, () => /\S/.test(document.getElementById("scene-title").textContent)],
    ["viewer", `/#/viewer/${sceneId}`, () => !document.getElementById("view-viewer").hidden],
    ["study", "/#/study", () => !document.getElementById("view-study").hidden],
    ["material", "/#/material", () => document.querySelectorAll("#reflectance-table tbody tr").length > 0],
    ["calibrate", "/calibrate", () => /\d/.test(document.getElementById("stored-profiles").textContent)],
    ["profile", `/calibrate#profile=${ids.profile}`, () => !document.getElementById("profile").hidden],
    ["experiments", "/experiment", () => document.querySelectorAll("#experiment-table tbody tr").length > 0
      && document.querySelectorAll("#profile option").length > 0],
    ["experiment", `/experiment/${ids.experiment}`, () => /\S/.test(document.getElementById("detail-title").textContent)],
    ["run", `/experiment/${ids.experiment}/run`, () => !/loading/.test(document.getElementById("title").textContent)],
    ["matlab", "/matlab/", () => document.querySelectorAll("li").length > 0],
  ];
}

const browser = await launch();
try {
  await makeRecords();
  const page = await browser.newPage({ viewport: { width: 1300, height: 1000 } });
  const ran = [];
  await page.exposeFunction("__pwned", (what) => ran.push(`${what} on ${page.url()}`));
  page.on("pageerror", (e) => failures.push(`page error on ${page.url()}: ${e.message}`));
  // One visit with the write token, as the reproduction.
  await page.goto(`${base}/#token=${token}`);
  await page.waitForFunction(() => localStorage.getItem("lightbooth-token"), null, { timeout: 10000 });
  for (const [key, path, loaded] of pages()) {
    // A whole load each time, not a change of hash within one page.
    await page.goto("about:blank");
    const response = await page.goto(base + path);
    const csp = response.headers()["content-security-policy"] || "";
    const scriptSrc = (csp.match(/script-src ([^;]*)/) || [])[1];
    if (!scriptSrc || /unsafe-inline|unsafe-eval|\*/.test(scriptSrc)) {
      failures.push(`${path}: no Content-Security-Policy forbidding inline script (got "${csp}")`);
    }
    try {
      await page.waitForFunction(loaded, null, { timeout: 60000 });
    } catch (e) {
      failures.push(`${key} (${path}) did not show its content: ${e.message.split("\n")[0]}`);
    }
    await page.waitForLoadState("networkidle");
    // The stored texts this page shows, shown as text.
    const text = await page.evaluate(() => document.body.textContent);
    for (const [where, want] of shownAs) {
      if (where === key && !text.includes(want)) failures.push(`${path} does not show "${want}" as text`);
    }
    // What one missed innerHTML would do: the policy must stop its handler.
    const written = await page.evaluate(() => {
      const box = document.createElement("div");
      try {
        box.innerHTML = "<img src=x onerror=__pwned('missed-innerHTML')>";
      } catch (e) {
        return "refused: " + e.message;
      }
      document.body.appendChild(box);
      return "written";
    });
    await page.waitForTimeout(300);
    if (shots) await page.screenshot({ path: `${shots}/stored-scripts-${key}.png`, fullPage: true });
    if (written !== "written" && !/TrustedHTML|Trusted Type/i.test(written)) failures.push(`${path}: innerHTML threw ${written}`);
  }
  // Whatever ran, on any page.
  for (const r of ran) failures.push(`a script ran: ${r}`);
} catch (e) {
  failures.push("error: " + e.message);
} finally {
  await browser.close();
}
finish(failures, "stored scripts: none ran on any page; every page carries the policy");
