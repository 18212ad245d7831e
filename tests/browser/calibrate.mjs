// Drives the display calibration page in Debian's headless Chromium against
// the daemon with --mock: press start, see the patches shown full-screen
// with progress, then the stored profile with its three charts. Fails on any
// console error, failed request or HTTP error; saves screenshots.
//
// Usage: node calibrate.mjs BASE_URL TOKEN SCREENSHOT_DIR
import { finish, launch, watch } from "./harness.mjs";

const [base, token, shots] = process.argv.slice(2);
if (!base || !token) {
  console.error("usage: node calibrate.mjs BASE_URL TOKEN [SCREENSHOT_DIR]");
  process.exit(2);
}

const browser = await launch();
const failures = [];
try {
  const page = await browser.newPage({ viewport: { width: 1300, height: 1000 } });
  watch(page, failures);

  await page.goto(`${base}/calibrate#token=${token}`);
  await page.fill("#steps", "4");
  await page.fill("#samples", "2");
  await page.click("#start");
  // Mid-calibration: the green ramp on screen, the progress bar moving.
  await page.waitForFunction(() => /green/.test(document.getElementById("status").textContent), null, { timeout: 60000, polling: "raf" });
  const bg = await page.$eval("#patch", (e) => getComputedStyle(e).backgroundColor);
  if (!/^rgb\(0, \d+, 0\)$/.test(bg)) failures.push(`the green patch is shown as ${bg}`);
  if (shots) await page.screenshot({ path: `${shots}/calibrate-running.png` });
  await page.waitForFunction(() => !document.getElementById("profile").hidden, null, { timeout: 120000 });
  await page.waitForFunction(() => [...document.querySelectorAll("#profile img")].every((i) => i.complete && i.naturalWidth > 0), null, { timeout: 30000 });
  const text = await page.textContent("#profile");
  // Whether it passed its stated limits is said first (issue 32: a failed
  // profile was shown like any other).
  for (const want of ["Display profile", "Passed its checks", "Additivity", "judd-vos-1978", "Validation colours"]) {
    if (!text.includes(want)) failures.push(`the profile page lacks "${want}"`);
  }
  if (shots) await page.screenshot({ path: `${shots}/calibrate-profile.png`, fullPage: true });
  // A stored profile opens by its address.
  const url = page.url();
  await page.goto("about:blank");
  await page.goto(url);
  await page.waitForFunction(() => !document.getElementById("profile").hidden, null, { timeout: 10000 });
} catch (e) {
  failures.push("error: " + e.message);
} finally {
  await browser.close();
}
finish(failures, "display calibration page: ok");
