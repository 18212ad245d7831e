// Drives the experiment pages in Debian's headless Chromium against the
// daemon with --mock, with a simulated observer at the keyboard: the setup
// page checks the colours of the newest experiment's measurement, the
// session page verifies the display (every colour drawn, read back and
// measured by the simulated PR-650) and measures test patches at codes
// 127, 128 and 127.30, then (WebGL2, noisy-bit dithering) runs every trial of one
// session, answered with arrow keys by an observer of Gaussian noise σ in
// ΔE00 (true d′ = ΔE00 shown / σ; the differencing rule: the odd piece is
// the one outside the closest pair), then a second session with the CPU
// throttled 4×, and the results page shows the table and the figure.
// Fails on any console error, failed request or HTTP error; saves
// screenshots.
//
// Usage: node experiment.mjs BASE_URL TOKEN SCREENSHOT_DIR
import { launch, finish, httpFailure } from "./harness.mjs";

const [base, token, shots] = process.argv.slice(2);
if (!base || !token) {
  console.error("usage: node experiment.mjs BASE_URL TOKEN [SCREENSHOT_DIR]");
  process.exit(2);
}
const SIGMA = 0.5;

// mulberry32: a small seeded generator, so the observer's answers repeat.
function generator(seed) {
  let a = seed >>> 0;
  return () => {
    a = (a + 0x6D2B79F5) >>> 0;
    let t = a;
    t = Math.imul(t ^ (t >>> 15), t | 1);
    t ^= t + Math.imul(t ^ (t >>> 7), t | 61);
    return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
  };
}
function normal(u) {
  return Math.sqrt(-2 * Math.log(u() + 1e-12)) * Math.cos(2 * Math.PI * u());
}
// The differencing observer: three noisy percepts; the odd one is outside the closest pair.
function answer(configuration, dPrime, u) {
  const seen = [...configuration].map((s) => (s === "N" ? dPrime : 0) + normal(u));
  const gap = (i) => Math.abs(seen[(i + 1) % 3] - seen[(i + 2) % 3]);
  let best = 0;
  for (let i = 1; i < 3; i++) if (gap(i) < gap(best)) best = i;
  return best;
}

const browser = await launch({ webgl: true });
const failures = [];
const auth = { "Authorization": "Bearer " + token };
async function apiGet(path) {
  const r = await fetch(base + path, { headers: auth });
  if (!r.ok) throw new Error(`GET ${path}: HTTP ${r.status}`);
  return r.json();
}

async function runSession(page, experiment, observer, seed, shotName) {
  const u = generator(seed);
  await page.goto(`${base}/experiment/${experiment.id}/run?observer=${observer}#token=${token}`);
  await page.waitForFunction(() => !/loading/.test(document.getElementById("title").textContent), null, { timeout: 10000 });
  await page.click("#start");
  await page.waitForFunction(() => document.body.dataset.state === "trials" || document.body.dataset.state === "complete", null, { timeout: 60000 });
  const colours = new Map(experiment.check.approximations.map((c) => [c.name, c.delta_e00_shown]));
  let shot = false;
  for (;;) {
    const state = await page.evaluate(() => document.body.dataset.state);
    if (state !== "trials") break;
    const position = Number(await page.evaluate(() => document.body.dataset.trial));
    const sessions = await apiGet(`/api/experiments/${experiment.id}/sessions`);
    const session = sessions.filter((s) => s.observer_id === observer).pop();
    const view = await apiGet(`/api/experiment-sessions/${session.id}`);
    if (!view.next || view.next.position !== position) {
      await page.waitForTimeout(20);
      continue;
    }
    // Wait for the pie (keys before it are ignored), then answer.
    // (this trial's pie, which a slow look may have missed on screen: waiting
    // for the pie phase itself hung under load, the page waiting for a key).
    await page.waitForFunction((p) => document.body.dataset.pieShown === String(p), position, { timeout: 20000 });
    // Keys count from the pie's first frame on the screen (the frame after
    // it was drawn): under load that frame came over 200 ms after the draw,
    // and a key pressed before it was ignored while the page waited for one.
    await page.waitForFunction((p) => document.body.dataset.pieOnScreen === String(p), position, { timeout: 20000 });
    if (!shot && shots && shotName) {
      await page.screenshot({ path: `${shots}/${shotName}` });
      shot = true;
    }
    // Regression (issue 46): the verification's (or test patch's) text,
    // "verifying srgb (pie): patch 15 of 15 … Esc cancels", stayed in the
    // corner of the stimulus screen during every trial.
    const hud = await page.textContent("#hud");
    if (hud.trim()) failures.push(`${observer}: trial ${position} shows "${hud}" on the stimulus screen`);
    // A person's reaction takes 200 ms or more; a key before the pie's
    // first frame reached the screen would be an anticipation.
    await page.waitForTimeout(200);
    const key = ["ArrowLeft", "ArrowUp", "ArrowRight"][answer(view.next.configuration, colours.get(view.next.approximation) / SIGMA, u)];
    await page.keyboard.press(key);
    await page.waitForFunction((p) => document.body.dataset.trial !== String(p) || document.body.dataset.state !== "trials",
      position, { timeout: 20000 });
  }
  const status = await page.textContent("#status");
  if (!/session complete/.test(status)) failures.push(`${observer}: the session did not complete: ${status}`);
}

try {
  // A small window: SwiftShader draws every pixel on the CPU, and a frame
  // it cannot draw in time is a dropped frame (the test's experiment uses
  // a coarse pixel pitch, so the pie still fits).
  const page = await browser.newPage({ viewport: { width: 400, height: 300 } });
  page.on("console", (m) => {
    if (m.type() !== "error") return;
    if (/status of 409/.test(m.text()) && /\/api\/measurements\/\d+\/cancel$/.test(m.location().url || "")) return;
    failures.push("console error: " + m.text());
  });
  page.on("pageerror", (e) => failures.push("page error: " + e.message));
  page.on("requestfailed", (r) => {
    if (r.failure()?.errorText !== "net::ERR_ABORTED") failures.push(`request failed: ${r.url()} (${r.failure()?.errorText})`);
  });
  // Esc's cancel may reach a measurement that has just completed: 409, and
  // the verification is cancelled before the next patch all the same.
  page.on("response", (r) => {
    if (r.status() === 409 && /\/api\/measurements\/\d+\/cancel$/.test(new URL(r.url()).pathname)) return;
    if (r.status() >= 400) httpFailure(r, failures);
  });

  const [experiment] = await apiGet("/api/experiments");
  if (!experiment) throw new Error("the test made no experiment");

  // The setup page: the list, and the check of the colours (a desktop window).
  await page.setViewportSize({ width: 1280, height: 900 });
  await page.goto(`${base}/experiment#token=${token}`);
  await page.waitForFunction(() => document.querySelector("#approximations input"), null, { timeout: 20000 });
  await page.click("#check-button");
  await page.waitForSelector("#check-table", { timeout: 20000 });
  const checkText = await page.textContent("#check");
  for (const want of ["noisy-bit dithering", "distinct at 8 bits", "8-bit codes"]) {
    if (!checkText.includes(want)) failures.push(`the setup page's check lacks "${want}"`);
  }
  if (shots) await page.screenshot({ path: `${shots}/experiment-setup.png`, fullPage: true });
  await page.setViewportSize({ width: 400, height: 300 });

  // The display verified before any observer: every colour full-field and
  // in the pie, drawn by the page, read back and measured by the simulated
  // PR-650 looking at the simulated display; then test patches at codes
  // 127, 128 and 127.30 on every gun.
  await page.goto(`${base}/experiment/${experiment.id}/run#token=${token}`);
  await page.waitForFunction(() => /not verified yet/.test(document.getElementById("verification").textContent), null, { timeout: 10000 });
  // Regression (issue 32): a session started on an unverified experiment
  // without a word. The page warns and says what to do; start asks twice.
  const unverified = await page.textContent("#notice");
  if (!/not verified/.test(unverified) || !/verify the display/.test(unverified)) {
    failures.push(`an unverified experiment's run page does not warn: "${unverified}"`);
  }
  await page.fill("#observer", "nobody");
  await page.click("#start");
  if ((await page.textContent("#start")) !== "start anyway" || (await page.evaluate(() => document.body.dataset.state))) {
    failures.push("start on an unverified experiment did not stop at the warning");
  }
  await page.fill("#verify-samples", "8");
  // Regression (issue 32): a verification (70 s) showed no progress, count
  // or Cancel. It holds the instrument, counts its patches, gives the time
  // left at its own pace once a patch is measured, and Esc cancels it: no
  // verification is stored and the hold is released.
  await page.click("#verify");
  await page.waitForFunction(() => /patch 2 of \d+ · about \d+ s left at the pace of the 1 measured · Esc cancels/
    .test(document.getElementById("hud").textContent), null, { timeout: 120000 });
  const held = await apiGet("/api/instrument/hold");
  if (!held || !/verification of experiment/.test(held.purpose)) {
    failures.push(`the verification does not hold the instrument: ${JSON.stringify(held)}`);
  }
  await page.keyboard.press("Escape");
  await page.waitForFunction(() => document.body.dataset.verificationCancelled === "yes" && document.body.dataset.state === "idle",
    null, { timeout: 60000 });
  if (!/verification cancelled/.test(await page.textContent("#notice"))) failures.push("a cancelled verification says nothing");
  if ((await apiGet(`/api/experiments/${experiment.id}/verifications`)).length !== 0) failures.push("a cancelled verification was stored");
  if ((await apiGet("/api/instrument/hold")) !== null) failures.push("a cancelled verification left the instrument held");
  await page.click("#verify");
  await page.waitForFunction(() => document.body.dataset.verification, null, { timeout: 120000 });
  const verification = await page.textContent("#verification");
  if (!/passed/.test(verification)) failures.push(`the verification did not pass: ${verification}`);
  if (shots) await page.screenshot({ path: `${shots}/experiment-verified.png` });
  await page.click(".verify-box summary");
  for (const code of ["127", "128", "127.30"]) {
    await page.fill("#test-code", code);
    const before = await page.evaluate(() => document.body.dataset.testMeasurement || "");
    await page.click("#test-patch");
    await page.waitForFunction((b) => (document.body.dataset.testMeasurement || "") !== b && document.body.dataset.state === "idle",
      before, { timeout: 60000 });
  }

  // One session at full speed, one with the CPU throttled.
  await runSession(page, experiment, "sim1", 1, "experiment-session-pie.png");
  const cdp = await page.context().newCDPSession(page);
  await cdp.send("Emulation.setCPUThrottlingRate", { rate: 4 });
  await runSession(page, experiment, "sim2", 2, null);
  await cdp.send("Emulation.setCPUThrottlingRate", { rate: 1 });

  // The results page (a desktop window).
  await page.setViewportSize({ width: 1280, height: 900 });
  await page.goto(`${base}/experiment/${experiment.id}#token=${token}`);
  await page.waitForFunction(() => document.querySelector("#figure img")?.complete && document.querySelector("#figure img").naturalWidth > 0,
    null, { timeout: 20000 });
  // The psychometric figure (the second image) and the thresholds table.
  await page.waitForFunction(() => {
    const imgs = document.querySelectorAll("#figure img");
    return imgs.length === 2 && [...imgs].every((i) => i.complete && i.naturalWidth > 0);
  }, null, { timeout: 20000 });
  const results = await page.textContent("#analysis");
  for (const want of ["sim1", "sim2", "d′ differencing", "independent observation", "Thresholds",
    "threshold ΔE00 at 2/3", "lapse λ [95 %]", "bounded to [0, 0.06]", "deviance", "thresholds as CSV"]) {
    if (!results.includes(want)) failures.push(`the results page lacks "${want}"`);
  }
  const thresholdRows = await page.$$eval(".threshold-table tbody tr", (trs) => trs.map((tr) => tr.cells[0].textContent));
  for (const who of ["sim1", "sim2", "all"]) {
    if (thresholdRows.filter((o) => o === who).length !== 2) failures.push(`thresholds of ${who}: ${thresholdRows}`);
  }
  const measured = await page.textContent("#detail-verification");
  for (const want of ["passed", "ΔE00 booth → emitted", "full field", "pie"]) {
    if (!measured.includes(want)) failures.push(`the results page's verification lacks "${want}"`);
  }
  if (shots) await page.screenshot({ path: `${shots}/experiment-results.png`, fullPage: true });
} catch (e) {
  failures.push("error: " + e.message);
  // Where the page was when it happened.
  try {
    const [page] = browser.contexts()[0].pages();
    failures.push("page state: " + JSON.stringify(await page.evaluate(() => ({
      dataset: Object.assign({}, document.body.dataset), running: document.body.classList.contains("running"),
      status: document.getElementById("status")?.textContent, notice: document.getElementById("notice")?.textContent,
      focus: document.activeElement?.tagName, url: location.href, title: document.title,
      img: document.querySelector("#figure img") ? [document.querySelector("#figure img").complete, document.querySelector("#figure img").naturalWidth, document.querySelector("#figure img").src] : null,
      analysis: document.getElementById("analysis")?.textContent.slice(0, 200),
    }))));
  } catch (_) { /* the page itself is gone */ }
} finally {
  await browser.close();
}
finish(failures, "experiment pages: ok");
