// Issue 32's small things on the Calibrate and Experiment pages, in
// headless Chromium against the daemon with --mock: both pages show the
// instrument badge (idle, the simulated PR-650) in their header, as every
// page of the index does; the Calibrate page's error notice (a calibration
// started without the write token) is readable: its text against its
// background has a WCAG contrast ratio of at least 4.5 (it was white on
// pink); the pages ask for no icon that is not there. Saves a screenshot
// of the notice (calibrate-error.png). A token the daemon refuses (another
// daemon's, or this one's previous run's) is said on every page, with what
// to do: the read cookie's refusal was shown on the index, swallowed on
// Calibrate and Experiment and never asked on a session page (issue 47);
// saves stale-token.png.
//
// Usage: node page_details.mjs BASE_URL TOKEN SCREENSHOT_DIR
import { launch, finish } from "./harness.mjs";

const [base, token, shots] = process.argv.slice(2);
if (!base || !token) {
  console.error("usage: node page_details.mjs BASE_URL TOKEN [SCREENSHOT_DIR]");
  process.exit(2);
}

const browser = await launch();
const failures = [];

// WCAG 2 contrast ratio of two CSS rgb()/rgba() colours (alpha ignored).
function contrast(a, b) {
  const lum = (c) => {
    const [r, g, bl] = c.match(/[\d.]+/g).slice(0, 3).map((v) => {
      const s = Number(v) / 255;
      return s <= 0.03928 ? s / 12.92 : Math.pow((s + 0.055) / 1.055, 2.4);
    });
    return 0.2126 * r + 0.7152 * g + 0.0722 * bl;
  };
  const [hi, lo] = [lum(a), lum(b)].sort((x, y) => y - x);
  return (hi + 0.05) / (lo + 0.05);
}

try {
  // No token on this browser: a calibration's first write is refused.
  const page = await browser.newPage({ viewport: { width: 1300, height: 900 } });
  const httpErrors = [];
  page.on("pageerror", (e) => failures.push("page error: " + e.message));
  page.on("response", (r) => { if (r.status() >= 400) httpErrors.push(`HTTP ${r.status()} for ${r.url()}`); });

  for (const path of ["/calibrate", "/experiment"]) {
    await page.goto(base + path);
    try {
      await page.waitForFunction(() => /idle/.test(document.querySelector("header #instrument")?.textContent || ""),
        null, { timeout: 15000 });
      const badge = await page.$eval("header #instrument", (b) => ({ text: b.textContent, cls: b.className }));
      if (!/PR-650/.test(badge.text) || !/\bbadge\b/.test(badge.cls)) failures.push(`${path}: badge ${JSON.stringify(badge)}`);
    } catch (e) {
      failures.push(`${path} has no instrument badge in its header`);
    }
  }

  await page.goto(`${base}/calibrate`);
  await page.fill("#steps", "2");
  await page.click("#start");
  await page.waitForFunction(() => !document.getElementById("notice").hidden, null, { timeout: 30000 });
  const notice = await page.$eval("#notice", (n) => {
    const s = getComputedStyle(n);
    return { text: n.textContent, color: s.color, background: s.backgroundColor };
  });
  const ratio = contrast(notice.color, notice.background);
  if (!(ratio >= 4.5)) {
    failures.push(`the Calibrate error notice is ${notice.color} on ${notice.background}: contrast ${ratio.toFixed(2)} (at least 4.5)`);
  }
  if (!/token/.test(notice.text)) failures.push(`the notice does not say what to do: ${notice.text}`);
  if (shots) await page.screenshot({ path: `${shots}/calibrate-error.png` });
  // The only refusal is the write without a token, and every icon is there.
  for (const e of httpErrors) if (!/HTTP 401/.test(e)) failures.push(e);

  // A stale token: each page asks the read cookie with it, is refused, and says so.
  const stale = await browser.newPage({ viewport: { width: 1300, height: 900 } });
  stale.on("pageerror", (e) => failures.push("page error: " + e.message));
  for (const path of ["/", "/calibrate", "/experiment", "/experiment/1/run"]) {
    await stale.goto(`${base}${path}#token=stale-token-of-another-run-0123456789`);
    const shown = await stale.waitForFunction(() => {
      const n = document.getElementById("notice");
      return !n.hidden && /refused this page's token \(HTTP 401\).*open the URL the daemon printed/.test(n.textContent);
    }, null, { timeout: 15000 }).then(() => true, () => false);
    if (!shown) {
      const n = await stale.$eval("#notice", (n) => (n.hidden ? "(hidden)" : n.textContent)).catch((e) => e.message);
      failures.push(`${path} with a refused token does not say so: notice ${JSON.stringify(n)}`);
    }
    if (shots && path === "/calibrate") await stale.screenshot({ path: `${shots}/stale-token.png` });
  }
} catch (e) {
  failures.push("error: " + e.message);
} finally {
  await browser.close();
}
finish(failures, "page details: badges, a readable notice");
