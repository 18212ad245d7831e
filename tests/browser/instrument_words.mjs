// The words of the pages that depend on the booth's instrument, in Debian's
// headless Chromium, for whichever model the daemon drives (GET /api/health:
// instrument_model, instrument_measures):
// - Calibrate asks to aim that model (not a PR-650 on every booth);
// - the Measurements page's instrument filter offers that model;
// - the WHITE scene's page: with a luminance meter, a sentence beside the
//   empty table saying it measures luminance only and where its luminance
//   comparison is; otherwise its comparison table has a row per coding,
//   the summary's observer is the one the comparisons are made in, and the
//   sentence above the table names it (the instrument's own, and why, on a
//   colorimeter's booth).
// Fails on any console error or page error; saves
// calibrate-MODEL.png and scene-white-MODEL.png.
//
// Usage: node instrument_words.mjs BASE_URL TOKEN SCREENSHOT_DIR
import { launch, finish } from "./harness.mjs";

const [base, token, shots] = process.argv.slice(2);
if (!base || !token) {
  console.error("usage: node instrument_words.mjs BASE_URL TOKEN [SCREENSHOT_DIR]");
  process.exit(2);
}

const browser = await launch();
const failures = [];
try {
  const health = await (await fetch(`${base}/api/health`)).json();
  const model = health.instrument_model;
  const file = model.replace(/[^A-Za-z0-9-]+/g, "_");
  const page = await browser.newPage({ viewport: { width: 1300, height: 900 } });
  page.on("console", (m) => { if (m.type() === "error") failures.push("console error: " + m.text()); });
  page.on("pageerror", (e) => failures.push("page error: " + e.message));

  // Calibrate: aim the booth's model.
  await page.goto(`${base}/calibrate`);
  await page.waitForFunction((m) => document.getElementById("instrument-model").textContent === m, model,
    { timeout: 15000 }).catch(() => {});
  const controls = await page.$eval("#controls", (e) => e.innerText);
  if (!controls.includes(`aim the ${model} at the centre`)) failures.push(`Calibrate says: "${controls.split("\n")[0]}"`);
  if (model !== "PR-650" && controls.includes("PR-650")) failures.push(`Calibrate names a PR-650 on a ${model} booth`);
  if (shots) await page.screenshot({ path: `${shots}/calibrate-${file}.png` });

  // Measurements: the filter offers the model.
  await page.goto(`${base}/#/measurements`);
  await page.waitForFunction((m) => [...document.querySelectorAll("#filter-model option")].some((o) => o.value === m),
    model, { timeout: 15000 }).catch(() => failures.push(`the Measurements filter does not offer ${model}`));
  const note = await page.$eval("#observer-note", (e) => e.textContent);

  // The WHITE scene's page.
  await page.goto(`${base}/#/scenes/white`);
  await page.waitForFunction(() => document.getElementById("scene-title").textContent.startsWith("white"),
    null, { timeout: 15000 });
  const c = await (await fetch(`${base}/api/scenes/white/comparisons`)).json();
  let sentence = "";
  if (health.instrument_measures === "luminance") {
    await page.waitForSelector("#scene-no-comparison:not([hidden])", { timeout: 15000 })
      .catch(() => failures.push("no sentence beside the LS-100's empty scene table"));
    sentence = await page.$eval("#scene-no-comparison", (e) => e.textContent);
    if (!sentence.includes(`the ${model} measures luminance only`) || !sentence.includes("Y ratio"))
      failures.push(`scene sentence: "${sentence}"`);
  } else {
    await page.waitForFunction((n) => document.querySelectorAll("#coding-table tbody tr").length === n,
      c.codings.length, { timeout: 15000 }).catch(() => failures.push(`the scene table has not ${c.codings.length} rows`));
    if (c.observer !== health.comparison_observer)
      failures.push(`the scene is summarised in ${c.observer}, its comparisons are in ${health.comparison_observer}`);
    const shown = await page.$eval("#scene-no-comparison", (e) => e.hidden);
    if (!shown && c.rows.length) failures.push("a 'no comparison' sentence beside a scene with comparisons");
    // The observer named beside the table's numbers, and why where it is
    // the instrument's own (issue 46).
    if (c.rows.length) {
      await page.waitForFunction(() => document.getElementById("coding-observer").textContent !== "", null,
        { timeout: 15000 }).catch(() => {});
      const said = await page.$eval("#coding-observer", (e) => e.textContent);
      const own = c.observer !== health.observer;
      if (!said.startsWith("Every ΔE, x, y and Y below is in the ") ||
          (own && !said.includes(`the ${model}'s own`)) || (!own && said.includes("'s own")))
        failures.push(`the scene table's observer: "${said}" (comparisons in ${c.observer}, daemon ${health.observer})`);
    }
  }
  if (shots) await page.screenshot({ path: `${shots}/scene-white-${file}.png`, fullPage: true });

  // The Scenes overview: a luminance meter's measured scene is not told to
  // "measure a target" (issue 46).
  if (health.instrument_measures === "luminance") {
    await page.goto(`${base}/#/scenes`);
    await page.waitForSelector("#scene-table tbody tr[data-scene='white']", { timeout: 15000 });
    const cell = await page.$eval("#scene-table tbody tr[data-scene='white'] .coding-figures", (e) => e.textContent);
    if (!cell.includes("luminance only")) failures.push(`Scenes overview for WHITE on the ${model}: "${cell}"`);
    if (shots) await page.screenshot({ path: `${shots}/scenes-${file}.png`, fullPage: true });
  }
  console.log(JSON.stringify({ model, measures: health.instrument_measures, observer: c.observer,
    codings: c.codings.length, sentence, note }));
} finally {
  await browser.close();
}
finish(failures);
