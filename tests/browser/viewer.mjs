// Drives the dashboard's image viewer in Debian's headless Chromium: on
// CYLINDER's page (its render already complete), show the spectral image,
// wait for it, click a pixel, see the probe chart with a spectrum ± SE
// against wavelength, then the ΔE00 map against rgb with its scale bar.
// Fails on any console error, failed request or HTTP error; saves
// screenshots (viewer-image.png, viewer-probe.png, viewer-delta-e.png).
//
// Usage: node viewer.mjs BASE_URL TOKEN SCREENSHOT_DIR
import { finish, launch, watch } from "./harness.mjs";

const [base, token, shots] = process.argv.slice(2);
if (!base || !token) {
  console.error("usage: node viewer.mjs BASE_URL TOKEN [SCREENSHOT_DIR]");
  process.exit(2);
}

const browser = await launch();
const failures = [];
try {
  const page = await browser.newPage({ viewport: { width: 1300, height: 1000 } });
  watch(page, failures);

  await page.goto(`${base}/#token=${token}`);
  await page.waitForFunction(() => document.getElementById("instrument").textContent.includes("idle"), null, { timeout: 30000 });
  await page.goto(`${base}/#/viewer/cylinder`);
  await page.waitForFunction(() => !document.getElementById("image-viewer").hidden, null, { timeout: 30000 });
  const codings = await page.$$eval("#viewer-coding option", (o) => o.map((x) => x.value));
  if (!codings.includes("spectral") || !codings.includes("rgb")) failures.push("codings offered: " + codings);

  // The spectral image, tone-mapped, with a caption naming the observer and the tone map.
  await page.selectOption("#viewer-coding", "spectral");
  await page.click("#viewer-show");
  await page.waitForFunction(() => {
    const img = document.getElementById("viewer-image");
    return img.complete && img.naturalWidth > 0 && /Reinhard/.test(document.getElementById("viewer-caption").textContent);
  }, null, { timeout: 180000 });
  // Beside it, its cd/m² scale (the tone map's grey levels as luminances).
  await page.waitForFunction(() => document.querySelectorAll("#viewer-scale .lum-ticks span").length >= 2
    && /cd\/m²/.test(document.getElementById("viewer-scale").textContent), null, { timeout: 10000 });
  const caption = await page.textContent("#viewer-caption");
  for (const want of ["spectral coding", "observer: Judd–Vos 1978 2°", "Reinhard global tone map", "sRGB"]) {
    if (!caption.includes(want)) failures.push(`the image caption lacks "${want}": ${caption}`);
  }
  if (shots) await page.screenshot({ path: `${shots}/viewer-image.png`, fullPage: true });

  // Probe the middle of the image: its spectrum ± SE as a chart, and XYZ, x,y.
  const box = await page.$eval("#viewer-image", (i) => [i.clientWidth, i.clientHeight]);
  // shown_at_its_96_px_not_the_screens: the image fills the width (up to 900 px), square pixels.
  if (box[0] < 800 || Math.abs(box[0] / box[1] - 96 / 72) > 0.02) failures.push(`the image is shown ${box[0]} × ${box[1]} px`);
  await page.click("#viewer-image", { position: { x: box[0] * 0.5, y: box[1] * 0.55 } });
  await page.waitForFunction(() => {
    const img = document.getElementById("probe-chart");
    return !document.getElementById("probe-figure").hidden && img.complete && img.naturalWidth > 0;
  }, null, { timeout: 30000 });
  const svg = await page.evaluate(async () => (await fetch(document.getElementById("probe-chart").src)).text());
  for (const want of ["wavelength (nm)", "W/(sr·m²·nm)", "spectral"]) {
    if (!svg.includes(want)) failures.push(`the probe chart lacks "${want}"`);
  }
  const probe = await page.textContent("#probe-caption");
  if (!/Y = [0-9.e+-]+ ± [0-9.e+-]+ cd\/m²/.test(probe) || !/x, y = 0\.\d+, 0\.\d+/.test(probe)) failures.push("probe caption: " + probe);
  if (shots) await page.screenshot({ path: `${shots}/viewer-probe.png`, fullPage: true });

  // The ΔE00 map against rgb, with its scale bar.
  await page.selectOption("#viewer-against", "rgb");
  await page.click("#viewer-de");
  await page.waitForFunction(() => {
    const img = document.getElementById("de-map");
    return !document.getElementById("de-figure").hidden && img.complete && img.naturalWidth > 0;
  }, null, { timeout: 180000 });
  const de = await page.textContent("#de-caption");
  if (!/CIEDE2000/.test(de) || !/h21/.test(de) || !/max [0-9.]+/.test(de)) failures.push("ΔE caption: " + de);
  // The two codings are rendered from the same paths: the caption gives the paired noise.
  if (!/rendered from the same paths: the paths' noise alone puts an RMS ΔE00 of [0-9.]+/.test(de) ||
      !/standard error is [0-9.]+/.test(de)) failures.push("ΔE caption without the paired noise: " + de);
  const ticks = await page.$$eval("#de-ticks span", (s) => s.map((x) => x.textContent));
  if (ticks.length !== 5 || Number(ticks[0]) !== 0 || !(Number(ticks[4]) > 0)) failures.push("scale ticks: " + ticks);
  if (shots) {
    await page.$eval("#de-figure", (f) => f.scrollIntoView());
    await page.screenshot({ path: `${shots}/viewer-delta-e.png`, fullPage: true });
  }
} catch (e) {
  failures.push("exception: " + (e.stack || e));
} finally {
  await browser.close();
}
finish(failures, "image viewer: ok");
