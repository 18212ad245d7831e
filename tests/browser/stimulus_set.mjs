// Drives the stimulus set of a rendered image in Debian's headless Chromium
// (issue 48, part 2): in the image viewer of CYLINDER (its render complete,
// the display calibrated), make a stimulus set of rgb, nstep9 and spectral
// at 8 bits, follow the link to its page, and check what it draws: each
// coding's canvas holds, pixel for pixel, the 8-bit codes of its linear RGB
// through the profile's γ (computed here from the same GET the page read,
// not by the page's shader), each ΔE00 map is loaded at the image's size,
// the scale has its five ticks and the share table a row per coding. Then
// the 12-bit drawing is asked for and the page says how it draws it. Then
// the set is verified on the (simulated) display at the scene's targets:
// every target within ΔE00 1 of its intention, the booth's measurements
// where the booth was measured, the luminance profile chart. Fails on any
// console error, failed request or HTTP error; saves screenshots
// (stimulus-set.png, stimulus-set-12bit.png, stimulus-set-verification.png).
//
// Usage: node stimulus_set.mjs BASE_URL TOKEN SCREENSHOT_DIR
import { finish, launch, watch } from "./harness.mjs";

const [base, token, shots] = process.argv.slice(2);
if (!base || !token) {
  console.error("usage: node stimulus_set.mjs BASE_URL TOKEN [SCREENSHOT_DIR]");
  process.exit(2);
}

const browser = await launch({ webgl: true });
const failures = [];
try {
  const page = await browser.newPage({ viewport: { width: 1400, height: 1100 } });
  watch(page, failures);
  await page.goto(`${base}/#token=${token}`);
  await page.waitForFunction(() => document.getElementById("instrument").textContent.includes("idle"), null, { timeout: 30000 });
  await page.goto(`${base}/#/viewer/cylinder`);
  await page.waitForFunction(() => !document.getElementById("image-viewer").hidden
    && document.querySelectorAll("#stimulus-profile option").length > 0, null, { timeout: 30000 });
  await page.fill("#stimulus-codings", "rgb,nstep9,spectral");
  await page.selectOption("#stimulus-output", "8bit");
  await page.click("#stimulus-make");
  await page.waitForSelector("#stimulus-link", { timeout: 180000 });
  await page.click("#stimulus-link");
  await page.waitForFunction(() => document.querySelectorAll("#codings canvas.as-displayed").length === 3
    && [...document.images].filter((i) => i.classList.contains("delta-e-map")).every((i) => i.complete && i.naturalWidth > 0)
    && document.getElementById("draw-path").textContent.length > 0, null, { timeout: 60000 });

  // What each canvas draws, against the codes computed here.
  const drawn = await page.evaluate(async () => {
    const id = Number(location.pathname.split("/")[2]);
    const set = await (await fetch(`/api/stimulus-sets/${id}`)).json();
    const profile = await (await fetch(`/api/display-profiles/${set.profile_id}`)).json();
    const gammas = profile.profile.transfer.map((t) => t.gamma);
    const out = { codings: set.codings, width: set.width, height: set.height, mismatches: [], compared: 0, maps: [] };
    for (const figure of document.querySelectorAll("#codings figure")) {
      const coding = figure.dataset.coding;
      const linear = new Float32Array(await (await fetch(`/api/stimulus-sets/${id}/linear/${coding}`)).arrayBuffer());
      const canvas = figure.querySelector("canvas");
      const gl = canvas.getContext("webgl2");
      const px = new Uint8Array(set.width * set.height * 4);
      gl.readPixels(0, 0, set.width, set.height, gl.RGBA, gl.UNSIGNED_BYTE, px);
      for (let y = 0; y < set.height; y++) {
        for (let x = 0; x < set.width; x++) {
          const row = set.height - 1 - y; // readPixels' row 0 is the bottom
          for (let k = 0; k < 3; k++) {
            const l = Math.min(Math.max(linear[3 * (y * set.width + x) + k], 0), 1);
            const want = Math.round(Math.pow(l, 1 / gammas[k]) * 255);
            const got = px[4 * (row * set.width + x) + k];
            out.compared++;
            // The shader's pow in float32 may land a code off at a half.
            if (Math.abs(got - want) > 1 && out.mismatches.length < 5) out.mismatches.push({ coding, x, y, k, got, want });
          }
        }
      }
      const map = figure.querySelector("img.delta-e-map");
      out.maps.push([coding, map.naturalWidth, map.naturalHeight]);
    }
    out.ticks = [...document.querySelectorAll("#scale-ticks span")].map((s) => s.textContent);
    out.rows = document.querySelectorAll("#shares tbody tr").length;
    out.facts = document.getElementById("facts").textContent;
    return out;
  });
  if (drawn.mismatches.length) failures.push("canvas codes differ from linear^(1/γ) · 255: " + JSON.stringify(drawn.mismatches));
  if (drawn.compared !== 3 * 3 * drawn.width * drawn.height) failures.push(`compared ${drawn.compared} codes`);
  for (const [coding, w, h] of drawn.maps) {
    if (w !== drawn.width || h !== drawn.height) failures.push(`${coding}'s ΔE00 map is ${w} × ${h}`);
  }
  if (drawn.ticks.length !== 5 || Number(drawn.ticks[0]) !== 0 || !(Number(drawn.ticks[4]) > 0)) failures.push("scale ticks " + drawn.ticks);
  if (drawn.rows !== 3) failures.push(`${drawn.rows} rows in the share table`);
  for (const want of ["render", "cylinder", "display white", "8bit"]) {
    if (!drawn.facts.includes(want)) failures.push(`the facts lack "${want}": ${drawn.facts}`);
  }
  if (shots) await page.screenshot({ path: `${shots}/stimulus-set.png`, fullPage: true });

  await page.selectOption("#output", "12bit");
  const hint = await page.textContent("#draw-hint");
  if (!/12 bits per gun/.test(hint) || !/nearest/.test(hint)) failures.push("12-bit drawing, hint: " + hint);
  if (shots) await page.screenshot({ path: `${shots}/stimulus-set-12bit.png`, fullPage: true });

  // The verification at the scene's targets: full-screen, measured under
  // the set's hold by the simulated PR-650 looking at the simulated
  // display, which is told the codes this page drew under the field.
  await page.selectOption("#output", "8bit");
  // Magnified ×2: the page draws each image pixel as 2 × 2 screen pixels and
  // reads back the screen pixels under the field; the daemon weighs each
  // image pixel by its screen pixels the field sees. A disagreement between
  // the two would show as ΔE00 intended → emitted.
  await page.fill("#verify-magnification", "2");
  await page.click("#verify");
  await page.waitForFunction(() => !document.getElementById("verification").hidden
    && document.getElementById("verify-chart").complete && document.getElementById("verify-chart").naturalWidth > 0,
  null, { timeout: 240000 });
  const rows = await page.$$eval("#verify-table tbody tr", (trs) => trs.map((tr) => [...tr.cells].map((c) => c.textContent)));
  if (rows.length < 15) failures.push(`${rows.length} targets verified`);
  for (const r of rows) {
    if (!(Number(r[5]) < 1)) failures.push(`target ${r[0]}: ΔE00 intended → emitted ${r[5]}`);
  }
  const booth = rows.filter((r) => r[4] !== "not measured").map((r) => r[0]);
  if (booth.join() !== "h01,h11,h21") failures.push(`booth measurements shown at ${booth}`);
  // A 72-px image ×2 at 0.25 mm seen from 570 mm is 3.6° high, not CYLINDER's 35°: the page says so.
  const caption = await page.textContent("#verify-caption");
  if (!/Note: the image is 3\.6° high/.test(caption) || !/shown ×2/.test(caption)) failures.push("caption: " + caption);
  const chart = await page.evaluate(async () => (await fetch(document.getElementById("verify-chart").src)).text());
  for (const want of ["booth", "emitted", "intended", "luminance Y"]) {
    if (!chart.includes(want)) failures.push(`the verification's chart lacks "${want}"`);
  }
  if (shots) {
    await page.$eval("#verification", (v) => v.scrollIntoView());
    await page.screenshot({ path: `${shots}/stimulus-set-verification.png`, fullPage: true });
  }

  // The list page links the set.
  await page.goto(`${base}/stimulus-sets`);
  await page.waitForSelector("#set-table tbody tr a", { timeout: 30000 });
} catch (e) {
  failures.push("exception: " + (e.stack || e));
} finally {
  await browser.close();
}
finish(failures, "stimulus set: ok");
