// Issue 32: Live and a measurement's page showed only Y, x, y, although
// the README promises "the average and its comparison with every colour
// coding"; and the camera view's cd/m² scale stopped near 2 for a patch of
// over 30 cd/m². In headless Chromium against the daemon with --mock:
// a free measurement on Live says it has no comparison and why; WHITE's
// patch measured on Live shows, once its comparisons are stored, a row per
// coding of the daemon (the same as the API's), and so does its page under
// Measurements; the Scenes page's camera view of WHITE has a cd/m² scale
// whose ticks reach the patch's measured luminance. Fails on any console
// error, failed request or HTTP error; saves screenshots.
//
// Usage: node measurement_views.mjs BASE_URL TOKEN SCREENSHOT_DIR
import { finish, launch, watch } from "./harness.mjs";

const [base, token, shots] = process.argv.slice(2);
if (!base || !token) {
  console.error("usage: node measurement_views.mjs BASE_URL TOKEN [SCREENSHOT_DIR]");
  process.exit(2);
}
const auth = { "Authorization": "Bearer " + token };
async function apiGet(path) {
  const r = await fetch(base + path, { headers: auth });
  if (!r.ok) throw new Error(`GET ${path}: HTTP ${r.status}`);
  return r.json();
}

const browser = await launch();
const failures = [];
// The rows of a comparison table: [coding, …cells].
const tableRows = (page, selector) => page.$$eval(`${selector} table tbody tr`,
  (trs) => trs.map((tr) => [...tr.cells].map((c) => c.textContent)));
try {
  const page = await browser.newPage({ viewport: { width: 1300, height: 1000 } });
  watch(page, failures);

  await page.goto(`${base}/#token=${token}`);
  await page.goto(`${base}/#/live`);
  await page.waitForFunction(() => document.querySelectorAll("#scene-select option").length > 1);

  // A free measurement: no comparison, and the page says why.
  await page.fill("#samples-input", "2");
  await page.click("#measure-button");
  await page.waitForFunction(() => /Y = /.test(document.getElementById("live-result").textContent), null, { timeout: 60000 });
  const free = Number((await page.textContent("#progress-text")).match(/#(\d+)/)[1]);
  try {
    await page.waitForFunction(() => /free measurement/.test(document.getElementById("live-comparison")?.textContent),
      null, { timeout: 10000 });
  } catch (e) {
    failures.push(`Live, a free measurement: no word on its comparison ("${await page.textContent("#live-result")}" only)`);
  }

  // WHITE's patch: its comparison with every coding, as the API has it.
  await page.selectOption("#scene-select", "white");
  await page.selectOption("#target-select", "patch");
  await page.fill("#samples-input", "3");
  await page.click("#measure-button");
  // This measurement's result, not the free one's still on the page.
  await page.waitForFunction((before) => {
    const m = document.getElementById("progress-text").textContent.match(/#(\d+)/);
    return m && Number(m[1]) !== before && /Y = /.test(document.getElementById("live-result").textContent);
  }, free, { timeout: 60000 });
  const id = Number((await page.textContent("#progress-text")).match(/#(\d+)/)[1]);
  let shown = [];
  try {
    // Until its render and comparisons are stored, the box says where they are.
    await page.waitForFunction(() => document.querySelector("#live-comparison [data-comparison-state]")
      || document.querySelector("#live-comparison table"), null, { timeout: 10000 });
    const waiting = await page.textContent("#live-comparison");
    if (!/comparison/i.test(waiting)) failures.push(`Live while the comparison is computed: "${waiting}"`);
    await page.waitForFunction(() => document.querySelectorAll("#live-comparison table tbody tr").length > 0, null,
      { timeout: 300000 });
    shown = await tableRows(page, "#live-comparison");
  } catch (e) {
    failures.push(`Live, WHITE's patch: no comparison shown (${e.message.split("\n")[0]})`);
  }
  if (shots) await page.screenshot({ path: `${shots}/live-comparison.png`, fullPage: true });
  const rows = await apiGet(`/api/measurements/${id}/comparisons`);
  const check = (where, got) => {
    const want = rows.map((r) => r.coding).sort();
    const have = got.map((r) => r[0]).sort();
    if (have.join() !== want.join()) failures.push(`${where}: codings ${have} (the API's: ${want})`);
    for (const r of rows) {
      const row = got.find((g) => g[0] === r.coding);
      if (row && !row.includes(r.dE00.toPrecision(3))) failures.push(`${where}: ${r.coding}'s ΔE00 ${r.dE00} not in ${row}`);
    }
  };
  if (!rows.length) failures.push(`the API has no comparison rows for measurement ${id}`);
  if (shown.length) check("Live", shown);

  // The measurement's own page.
  await page.goto(`${base}/#/measurements/${id}`);
  try {
    await page.waitForFunction(() => document.querySelectorAll("#detail-comparison table tbody tr").length > 0, null,
      { timeout: 30000 });
    check(`measurement ${id}'s page`, await tableRows(page, "#detail-comparison"));
  } catch (e) {
    failures.push(`measurement ${id}'s page shows no comparison: "${await page.textContent("#detail-summary")}"`);
  }
  if (shots) await page.screenshot({ path: `${shots}/measurement-comparison.png`, fullPage: true });

  // The camera view's cd/m² scale reaches the patch's luminance.
  const patchY = (await apiGet(`/api/measurements/${id}`)).Y;
  await page.goto(`${base}/#/scenes/white`);
  try {
    await page.waitForFunction(() => document.querySelectorAll("#preview-scale .lum-ticks span").length > 0, null,
      { timeout: 120000 });
    const ticks = await page.$$eval("#preview-scale .lum-ticks span", (s) => s.map((t) => Number(t.textContent)));
    const top = Math.max(...ticks);
    if (!(top >= patchY)) failures.push(`the camera view's cd/m² scale stops at ${top} (ticks ${ticks}); WHITE's patch measures ${patchY} cd/m²`);
  } catch (e) {
    failures.push(`WHITE's camera view has no cd/m² scale: ${e.message.split("\n")[0]}`);
  }
  if (shots) await page.screenshot({ path: `${shots}/scene-white-scale.png`, fullPage: true });
} catch (e) {
  failures.push("error: " + e.message);
} finally {
  await browser.close();
}
finish(failures, "measurement views: comparison on Live and the measurement's page, the scale reaches the patch");
