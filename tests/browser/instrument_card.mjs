// The home page's instrument card in Debian's headless Chromium, against a
// daemon driving a (simulated) CS-2000: the card names the model, its serial,
// what it measures and its port; "Look for instruments again" lists every
// serial port of this machine with what it answered, and the button comes
// back. Fails on any console error, failed request or HTTP error; saves
// screenshots.
//
// Usage: node instrument_card.mjs BASE_URL TOKEN SCREENSHOT_DIR
import { finish, launch, watch } from "./harness.mjs";

const [base, token, shots] = process.argv.slice(2);
if (!base || !token) {
  console.error("usage: node instrument_card.mjs BASE_URL TOKEN [SCREENSHOT_DIR]");
  process.exit(2);
}

const browser = await launch();
const failures = [];
try {
  const page = await browser.newPage({ viewport: { width: 1300, height: 900 } });
  watch(page, failures);

  await page.goto(`${base}/#token=${token}`);
  await page.waitForFunction(() => /measures spectrum/.test(document.getElementById("home-instrument-state").textContent),
    null, { timeout: 30000 });
  const card = await page.$eval("#home-instrument-state", (e) => e.textContent);
  for (const want of ["CS-2000", "20101234", "measures spectrum", "idle on /dev/pts/"]) {
    if (!card.includes(want)) failures.push(`the card says "${card}", without "${want}"`);
  }
  await page.click("#home-scan");
  await page.waitForFunction(() => !document.getElementById("home-scan-result").hidden, null, { timeout: 15000 });
  await page.waitForFunction(() => !document.getElementById("home-scan").disabled, null, { timeout: 15000 });
  const items = await page.$$eval("#home-scan-result li", (lis) => lis.map((li) => li.textContent));
  if (!items.length) failures.push("the scan listed nothing, not even 'No serial ports'");
  for (const item of items) {
    if (!/^(\/dev\/\S+: .+|No serial ports on this computer\.)$/.test(item)) failures.push(`scan line "${item}"`);
  }
  const label = await page.$eval("#home-scan", (b) => b.textContent);
  if (label !== "Look for instruments again") failures.push(`the button says "${label}" after the scan`);
  if (shots) await page.$eval("#home-instrument", (e) => e.scrollIntoView());
  if (shots) await page.screenshot({ path: `${shots}/home-instrument-card.png` });
  console.log(JSON.stringify({ card, items }));
} finally {
  await browser.close();
}
finish(failures);
