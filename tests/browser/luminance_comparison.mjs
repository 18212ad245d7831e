// A luminance meter's measurement page (/#/measurements/ID, the newest
// measurement) in Debian's headless Chromium: its comparison with every
// coding is a table of luminances only (coding, rendered Y, the ratio,
// beyond noise: no Δxy or ΔE columns), one row per coding, and the note
// under it says the meter gives no colour. Fails on any console error,
// failed request or HTTP error; saves measurement-luminance.png.
//
// Usage: node luminance_comparison.mjs BASE_URL TOKEN SCREENSHOT_DIR
import { finish, launch, watch } from "./harness.mjs";

const [base, token, shots] = process.argv.slice(2);
if (!base || !token) {
  console.error("usage: node luminance_comparison.mjs BASE_URL TOKEN [SCREENSHOT_DIR]");
  process.exit(2);
}

const browser = await launch();
const failures = [];
try {
  const list = await (await fetch(`${base}/api/measurements`)).json();
  const newest = list.items.reduce((a, b) => (b.id > a.id ? b : a));
  const rows = await (await fetch(`${base}/api/measurements/${newest.id}/luminance-comparisons`)).json();

  const page = await browser.newPage({ viewport: { width: 1300, height: 900 } });
  watch(page, failures);

  await page.goto(`${base}/#/measurements/${newest.id}`);
  await page.waitForSelector("#detail-comparison [data-luminance-only]", { timeout: 15000 });
  const heads = await page.$$eval("#detail-comparison th", (ths) => ths.map((t) => t.textContent));
  const want = ["coding", "rendered Y (cd/m²)", "Y rendered / measured", "Y beyond noise"];
  if (JSON.stringify(heads) !== JSON.stringify(want)) failures.push(`columns ${JSON.stringify(heads)}, not ${JSON.stringify(want)}`);
  const cells = await page.$$eval("#detail-comparison tbody tr", (trs) => trs.map((tr) =>
    [...tr.cells].map((c) => c.textContent)));
  if (cells.length !== rows.length || rows.length < 2) failures.push(`${cells.length} rows shown, ${rows.length} stored`);
  for (const r of rows) {
    const shown = cells.find((c) => c[0] === r.coding);
    if (!shown) failures.push(`coding ${r.coding} not shown`);
    else if (Math.abs(Number(shown[2]) - r.Y_ratio) > 1e-3) failures.push(`${r.coding}: ratio ${shown[2]}, stored ${r.Y_ratio}`);
  }
  const note = await page.$eval("#detail-comparison [data-luminance-only]", (e) => e.textContent);
  if (!note.includes("no colour") || !note.includes(newest.instrument_model)) failures.push(`note: "${note}"`);
  if (shots) await page.screenshot({ path: `${shots}/measurement-luminance.png`, fullPage: true });
  console.log(JSON.stringify({ id: newest.id, heads, rows: cells.length, note }));
} finally {
  await browser.close();
}
finish(failures);
