// The dashboard of a daemon bound off loopback, where every read needs the
// token: opened with the printed URL (#token=…), it must show the live
// instrument state (event stream), list the scenes (fetch), take a
// measurement (POST) and show its spectrum chart (<img>), with no request
// refused; and the write token must never be in a cookie (Set-Cookie,
// document.cookie, the browser's cookie jar): the event stream and <img>s
// use the read-only cookie the daemon sets. Fails on any HTTP error or
// console error.
//
// Usage: node off_loopback.mjs BASE_URL TOKEN [SCREENSHOT_DIR]
import { finish, launch, watch } from "./harness.mjs";

const [base, token, shots] = process.argv.slice(2);
if (!base || !token) {
  console.error("usage: node off_loopback.mjs BASE_URL TOKEN [SCREENSHOT_DIR]");
  process.exit(2);
}

const browser = await launch();
const failures = [];
try {
  const page = await browser.newPage({ viewport: { width: 1300, height: 1000 } });
  watch(page, failures);
  // Every Set-Cookie the daemon sends, to check none carries the write token.
  const setCookies = [];
  page.on("response", (r) => setCookies.push(r.allHeaders().then((h) => [r.url(), h["set-cookie"] || ""]).catch(() => ["", ""])));

  await page.goto(`${base}/#token=${token}`);
  // The instrument state arrives over the event stream (EventSource: the cookie).
  await page.waitForFunction(() => document.getElementById("instrument").textContent.includes("idle"), null, { timeout: 30000 });
  // The scene list is a fetch (the Authorization header).
  await page.waitForFunction(() => document.querySelectorAll("#scene-select option").length > 1, null, { timeout: 30000 });
  // The token URL opens the home page; measurements are taken on Live.
  await page.goto(`${base}/#/live`);
  await page.selectOption("#scene-select", "white");
  await page.selectOption("#target-select", "patch");
  await page.fill("#samples-input", "2");
  await page.click("#measure-button");
  await page.waitForFunction(() => document.getElementById("live-result").textContent.includes("cd/m²"), null, { timeout: 120000 });
  // The spectrum chart is an <img> (the cookie).
  await page.waitForFunction(() => {
    const img = document.getElementById("live-spectrum");
    return img.complete && img.naturalWidth > 0;
  }, null, { timeout: 30000 });
  if (shots) await page.screenshot({ path: `${shots}/off-loopback.png`, fullPage: true });
  // The write token is never a cookie: not set by the daemon, not visible to
  // script, not in the jar; the read cookie is there (it opened the stream and the chart).
  for (const [url, set] of await Promise.all(setCookies)) {
    if (set.includes(token)) failures.push(`the write token is in a Set-Cookie of ${url}: ${set}`);
  }
  const scriptCookies = await page.evaluate(() => document.cookie);
  if (scriptCookies.includes(token)) failures.push(`the write token is in document.cookie: ${scriptCookies}`);
  const jar = await page.context().cookies();
  for (const c of jar) {
    if (c.value.includes(token)) failures.push(`the write token is in the cookie ${c.name} (path ${c.path})`);
  }
  const port = new URL(base).port;
  const read = jar.find((c) => c.name === `lightbooth_read_${port}`);
  if (!read) failures.push(`no read cookie lightbooth_read_${port}: ${JSON.stringify(jar)}`);
  else if (!read.httpOnly || read.sameSite !== "Strict" || read.path !== "/api") {
    failures.push(`the read cookie is not HttpOnly, SameSite=Strict, path /api: ${JSON.stringify(read)}`);
  }
} catch (e) {
  failures.push(String(e));
} finally {
  await browser.close();
}
finish(failures, "dashboard off loopback ok");
