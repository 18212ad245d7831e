// A stored display profile's page (/calibrate#profile=ID, the newest
// profile) in Debian's headless Chromium: it says what measured the profile
// (spectra, a colorimeter's XYZ, or a luminance meter's γ only), and its three
// charts load as pictures. Fails on any console error, failed request or HTTP
// error; saves calibrate-profile-<kind>.png.
//
// Usage: node profile_page.mjs BASE_URL TOKEN SCREENSHOT_DIR
import { finish, launch, watch } from "./harness.mjs";

const [base, token, shots] = process.argv.slice(2);
if (!base || !token) {
  console.error("usage: node profile_page.mjs BASE_URL TOKEN [SCREENSHOT_DIR]");
  process.exit(2);
}

const browser = await launch();
const failures = [];
try {
  const profiles = await (await fetch(`${base}/api/display-profiles`)).json();
  const newest = profiles.reduce((a, b) => (b.id > a.id ? b : a));
  const p = newest.profile;
  const kind = p.luminance_additivity ? "luminance" : p.black_xyz ? "xyz" : "spectra";
  const expect = { luminance: "luminance meter: γ per channel only", xyz: "XYZ by a colorimeter", spectra: "spectra" }[kind];

  const page = await browser.newPage({ viewport: { width: 1300, height: 900 } });
  watch(page, failures);

  await page.goto(`${base}/calibrate#profile=${newest.id}`);
  await page.waitForSelector("#measured-as", { timeout: 15000 });
  const said = await page.$eval("#measured-as", (e) => e.textContent);
  if (!said.includes(expect)) failures.push(`profile ${newest.id} (${kind}) says "${said}", without "${expect}"`);
  const state = await page.$eval("#profile-state", (e) => e.textContent);
  if (!state.startsWith("Passed")) failures.push(`profile state: "${state}"`);
  await page.waitForFunction(() => [...document.querySelectorAll("#profile img")].every((i) => i.complete),
    null, { timeout: 15000 });
  const sizes = await page.$$eval("#profile img", (imgs) => imgs.map((i) => [i.alt, i.naturalWidth]));
  if (sizes.length !== 3) failures.push(`${sizes.length} charts, not 3`);
  for (const [alt, w] of sizes) if (!(w > 100)) failures.push(`chart ${alt} did not load (${w} px wide)`);
  if (shots) await page.screenshot({ path: `${shots}/calibrate-profile-${kind}.png`, fullPage: true });
  console.log(JSON.stringify({ id: newest.id, kind, said, sizes }));
} finally {
  await browser.close();
}
finish(failures);
