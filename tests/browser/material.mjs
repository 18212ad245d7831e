// Drives the dashboard's "measure a material" flow in Debian's headless
// Chromium: measure the white standard and the ColorChecker tile of the
// MATERIAL_BENCH scene, save the reflectance, see ρ(λ) with its uncertainty
// band and its flags, download the scene CSV, save the lamp spectrum. Fails
// on any console error, failed request or HTTP error; saves a screenshot.
//
// Usage: node material.mjs BASE_URL TOKEN SCREENSHOT_DIR
import { finish, launch, watch } from "./harness.mjs";

const [base, token, shots] = process.argv.slice(2);
if (!base || !token) {
  console.error("usage: node material.mjs BASE_URL TOKEN [SCREENSHOT_DIR]");
  process.exit(2);
}

const browser = await launch();
const failures = [];
try {
  const page = await browser.newPage({ viewport: { width: 1300, height: 1000 } });
  watch(page, failures);

  await page.goto(`${base}/#token=${token}`);
  await page.waitForFunction(() => document.getElementById("instrument").textContent.includes("idle"), null, { timeout: 30000 });
  await page.goto(`${base}/#/material`);
  await page.waitForFunction(() => document.getElementById("mat-sample-target").value === "sample", null, { timeout: 10000 });
  if ((await page.inputValue("#mat-standard-target")) !== "standard") failures.push("the standard's target is not preselected");

  // 1. the white standard, 2. the sample: each waits for its measurement to complete.
  await page.fill("#mat-samples", "5");
  await page.click("#mat-measure-standard");
  await page.waitForFunction(() => /complete, Y =/.test(document.getElementById("mat-standard-state").textContent), null, { timeout: 120000 });
  await page.click("#mat-measure-sample");
  await page.waitForFunction(() => /complete, Y =/.test(document.getElementById("mat-sample-state").textContent), null, { timeout: 120000 });
  const ids = await page.$eval("#view-material", () => [document.getElementById("mat-standard-id").value, document.getElementById("mat-sample-id").value]);
  if (!ids[0] || !ids[1] || ids[0] === ids[1]) failures.push("measurement ids not filled in: " + ids);

  // 3. save: the chart, the flags, the provenance, the CSV link.
  await page.fill("#mat-name", "red_tile");
  await page.click("#mat-save");
  await page.waitForFunction(() => {
    const img = document.getElementById("mat-chart");
    return !document.getElementById("mat-result").hidden && img.complete && img.naturalWidth > 0;
  }, null, { timeout: 30000 });
  const flags = await page.textContent("#mat-flags");
  if (!/Every value in \[0, 1\]/.test(flags)) failures.push("flags: " + flags);
  const provenance = await page.textContent("#mat-provenance");
  if (!/spectralon_99\.csv \(sha256 [0-9a-f]{16}…\)/.test(provenance)) failures.push("provenance: " + provenance);
  const href = await page.getAttribute("#mat-csv", "href");
  const csv = await page.evaluate(async (h) => (await fetch(h)).text(), href);
  if (!csv.startsWith("# lightbooth reflectance") || !csv.includes("\nnm,red_tile,red_tile_u\n"))
    failures.push("the scene CSV: " + csv.slice(0, 300));
  const svg = await page.evaluate(async () => (await fetch(document.getElementById("mat-chart").src)).text());
  if (!svg.includes("±1 u") || !svg.includes("ρ(λ) measured")) failures.push("the chart lacks its band or line");
  await page.waitForFunction(() => document.querySelectorAll("#reflectance-table tbody tr").length === 1);

  // The lamp's spectrum from the standard's measurement.
  await page.click("#mat-save-lamp");
  await page.waitForFunction(() => /Lamp spectrum \d+ from measurement/.test(document.getElementById("mat-lamp").textContent));
  const lamp = await page.getAttribute("#mat-lamp a", "href");
  const lampCsv = await page.evaluate(async (h) => (await fetch(h)).text(), lamp);
  if (!lampCsv.includes("100 at 560 nm")) failures.push("the lamp CSV: " + lampCsv.slice(0, 300));
  if (shots) await page.screenshot({ path: `${shots}/material.png`, fullPage: true });
} catch (e) {
  failures.push("exception: " + (e.stack || e));
} finally {
  await browser.close();
}
finish(failures, "material flow: ok");
