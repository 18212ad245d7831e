// Issue 25's "done means": after the dashboard test has measured, compared
// and studied, calibrate the display from its page, then open every page
// from the one navigation bar, as a newcomer would, and save a screenshot of
// each (page-<name>.png). The caller's harness.mjs watch(page, failures)
// fails the run on any console error, page error, failed request or HTTP
// error on any of them: a page module that does not load (a missing file,
// a type other than JavaScript, an import of a name not exported) is one.
//
// Used by dashboard.mjs (one daemon, one history): visitEveryPage(page, base, shots, failures).

// The navigation bar's links, in order (web/nav.js), and what each page
// shows once it has loaded.
const PAGES = [
  ["Home", "home", () => document.querySelectorAll("#home-next-list li").length > 0
    && /idle/.test(document.getElementById("home-instrument-state").textContent)],
  ["Live", "live", () => document.querySelectorAll("#scene-select option").length > 1],
  ["Measurements", "measurements", () => document.querySelectorAll("#measurement-table tbody tr").length > 0],
  ["Scenes", "scenes", () => document.querySelectorAll("#scene-table > tbody > tr").length > 0],
  ["Viewer", "viewer", () => document.querySelector("#view-viewer") && !document.querySelector("#view-viewer").hidden],
  ["Study", "study", () => document.querySelectorAll("#study-table tbody tr").length > 0],
  ["Material", "material", () => document.querySelector("#view-material") && !document.querySelector("#view-material").hidden],
  // The profile calibrated just before is listed, a link to its page.
  ["Calibrate", "calibrate", () => document.getElementById("status").textContent === "ready"
    && /stimulus monitor/.test(document.getElementById("stored-profiles").textContent)],
  // The stimulus sets: the list (made from the viewer; empty here is fine).
  ["Stimuli", "stimulus-sets", () => document.getElementById("list-view") && !document.getElementById("list-view").hidden],
  // The profile just calibrated is offered for a new experiment.
  ["Experiment", "experiment", () => document.getElementById("experiment-table")
    && [...document.querySelectorAll("#profile option")].some((o) => /^\d+: /.test(o.textContent))],
];

const NAV = ["Home", "Live", "Measurements", "Scenes", "Viewer", "Study", "Material", "Calibrate", "Stimuli", "Experiment"];

async function imagesLoaded(page) {
  await page.waitForFunction(() => [...document.images].filter((i) => !i.hidden && i.src)
    .every((i) => i.complete && i.naturalWidth > 0), null, { timeout: 60000 });
}

export async function visitEveryPage(page, base, shots, failures) {
  // Calibrate the (simulated) display from its page: a small plan.
  await page.goto(`${base}/calibrate`);
  await page.fill("#steps", "4");
  await page.fill("#samples", "2");
  await page.click("#start");
  await page.waitForFunction(() => !document.getElementById("profile").hidden, null, { timeout: 180000 });
  await imagesLoaded(page);

  // Every page, reached from the navigation bar of the page before.
  await page.goto(`${base}/#/home`);
  for (const [label, name, loaded] of PAGES) {
    await page.waitForSelector("header nav a");
    const links = await page.$$eval("header nav a", (as) => as.map((a) => a.textContent));
    if (links.join(",") !== NAV.join(",")) failures.push(`${page.url()}: navigation ${links}`);
    await page.click(`header nav a:text-is("${label}")`);
    await page.waitForLoadState("load");
    try {
      await page.waitForFunction(loaded, null, { timeout: 60000 });
    } catch (e) {
      failures.push(`${label} (${page.url()}) did not show its content: ${e.message.split("\n")[0]}`);
    }
    await page.waitForLoadState("networkidle");
    await imagesLoaded(page);
    // The page's own link is marked as the one open.
    const active = await page.$$eval("header nav a.active", (as) => as.map((a) => a.textContent));
    if (active.join() !== label) failures.push(`${label}: the navigation marks ${JSON.stringify(active)} as open`);
    if (shots) await page.screenshot({ path: `${shots}/page-${name}.png`, fullPage: true });
  }

  // Home after it all: a display profile calibrated just now (not "no
  // profile"), and the next thing to measure named.
  await page.goto(`${base}/#/home`);
  await page.waitForFunction(() => document.querySelectorAll("#home-next-list li").length > 0);
  const next = await page.textContent("#home-next-list");
  if (/No display profile yet/.test(next) || !/calibrated/.test(next)) failures.push(`home, next steps after calibrating: ${next}`);
  if (!/not (yet )?measured|Measure/.test(next)) failures.push(`home does not name the next thing to measure: ${next}`);
}
