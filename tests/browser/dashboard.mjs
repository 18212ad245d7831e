// Drives the lightbooth dashboard in Debian's headless Chromium, as a
// scientist would: open the printed URL (with the token), start a
// measurement of the WHITE scene, watch its progress, see the spectrum, the
// comparison table and the charts, every scene's page, a finished study
// (one section per scene, the request folded away, a report link that
// answers) and a failed one (no report link); then calibrates the display
// and opens every page from the navigation bar (every_page.mjs). Fails on any console error,
// failed request or HTTP error; saves a screenshot of every page into
// SCREENSHOT_DIR for a reviewer.
//
// Usage: node dashboard.mjs BASE_URL TOKEN SCREENSHOT_DIR
import { finish, launch, watch } from "./harness.mjs";
import { visitEveryPage } from "./every_page.mjs";

const [base, token, shots] = process.argv.slice(2);
if (!base || !token) {
  console.error("usage: node dashboard.mjs BASE_URL TOKEN [SCREENSHOT_DIR]");
  process.exit(2);
}

const browser = await launch();
const failures = [];
try {
  const page = await browser.newPage({ viewport: { width: 1300, height: 1000 } });
  watch(page, failures);

  await page.goto(`${base}/#token=${token}`);
  await page.waitForFunction(() => document.getElementById("instrument").textContent.includes("idle"), null, { timeout: 30000 });
  // The home page first: the instrument, the queue (empty), what to measure next.
  await page.waitForFunction(() => /idle/.test(document.getElementById("home-instrument-state").textContent)
    && document.querySelectorAll("#home-next-list li").length > 0 && !document.getElementById("queue-empty").hidden,
    null, { timeout: 30000 });
  if (shots) await page.screenshot({ path: `${shots}/home.png`, fullPage: true });
  await page.goto(`${base}/#/live`);

  // Start a measurement of the WHITE scene's patch.
  await page.waitForFunction(() => document.querySelectorAll("#scene-select option").length > 1);
  await page.selectOption("#scene-select", "white");
  await page.selectOption("#target-select", "patch");
  await page.fill("#samples-input", "5");
  await page.click("#measure-button");

  // Progress: sample k of 5, a progress bar, then the result.
  await page.waitForFunction(() => /sample \d of 5/.test(document.getElementById("progress-text").textContent), null, { timeout: 60000 });
  await page.waitForFunction(() => document.getElementById("live-result").textContent.includes("cd/m²"), null, { timeout: 60000 });
  const progress = await page.$eval("#progress", (p) => [p.value, p.max]);
  if (progress[0] !== 5 || progress[1] !== 5) failures.push(`progress bar at ${progress}`);
  // live_y_was_the_instruments_cie_1931_luminance: the Y shown beside the
  // observer's x, y is that observer's XYZ[1], not the instrument's own Y.
  {
    const text = await page.$eval("#live-result", (e) => e.textContent);
    const id = Number((await page.$eval("#progress-text", (e) => e.textContent)).match(/#(\d+)/)[1]);
    const m = await (await fetch(`${base}/api/measurements/${id}`, { headers: { Authorization: `Bearer ${token}` } })).json();
    const shown = Number(text.match(/Y = ([0-9.e+-]+) cd/)[1]);
    if (Math.abs(shown - Number(m.XYZ[1].toPrecision(5))) > 1e-9 || !text.includes("Judd"))
      failures.push(`Live shows Y = ${shown} but XYZ[1] (${m.observer}) is ${m.XYZ[1]}: ${text}`);
  }
  await page.waitForFunction(() => {
    const img = document.getElementById("live-spectrum");
    return img.complete && img.naturalWidth > 0;
  });
  if (shots) await page.screenshot({ path: `${shots}/live.png`, fullPage: true });

  // The measurement list and its detail.
  await page.goto(`${base}/#/measurements`);
  await page.waitForSelector("#measurement-table tbody tr");
  if (shots) await page.screenshot({ path: `${shots}/measurements.png`, fullPage: true });
  await page.click("#measurement-table tbody tr");
  await page.waitForFunction(() => document.querySelectorAll("#sample-table tbody tr").length === 5);
  {
    // Issue 46: samples were numbered from 0 where the progress counts from 1.
    const numbers = await page.$$eval("#sample-table tbody tr", (rows) => rows.map((r) => r.cells[0].textContent));
    if (numbers.join(",") !== "1,2,3,4,5") failures.push(`samples numbered ${numbers.join(",")}, not 1–5`);
  }
  {
    const summary = await page.$eval("#detail-summary", (e) => e.textContent);
    if (!/own CIE 1931 values: Y = [0-9.]+ cd\/m²/.test(summary)) failures.push(`detail without the instrument's own Y: ${summary}`);
  }
  await page.waitForFunction(() => {
    const img = document.getElementById("detail-spectrum");
    return img.complete && img.naturalWidth > 0;
  });
  if (shots) await page.screenshot({ path: `${shots}/measurement-detail.png`, fullPage: true });

  // Cancel a long measurement from the live page: it keeps its samples, says
  // so, and the table lists it with its notes, its date and its partial average.
  await page.goto(`${base}/#/live`);
  await page.selectOption("#scene-select", "");
  await page.fill("#samples-input", "99");
  await page.fill("#notes-input", "cancelled from the dashboard");
  await page.click("#measure-button");
  await page.waitForFunction(() => {
    const m = document.getElementById("progress-text").textContent.match(/sample (\d+) of 99/);
    return m && Number(m[1]) >= 2;
  }, null, { timeout: 60000 });
  // The home page shows it under way, with its samples and a time left, in the queue.
  await page.goto(`${base}/#/home`);
  await page.waitForFunction(() => !document.getElementById("home-current").hidden
    && /samples taken/.test(document.getElementById("home-current-what").textContent)
    && [...document.querySelectorAll("#queue-table tbody tr")].some((tr) => /running/.test(tr.textContent)
      && /about/.test(tr.querySelector(".time-left").textContent)), null, { timeout: 30000 });
  if (shots) await page.screenshot({ path: `${shots}/home-measuring.png`, fullPage: true });
  await page.goto(`${base}/#/live`);
  await page.waitForFunction(() => !document.getElementById("cancel-current").hidden);
  await page.click("#cancel-current");
  await page.waitForFunction(() => /: cancelled \(cancelled by the operator after \d+ samples/.test(
    document.getElementById("progress-text").textContent), null, { timeout: 30000 });
  await page.goto(`${base}/#/measurements`);
  await page.waitForFunction(() => [...document.querySelectorAll("#measurement-table tbody tr")].some((tr) =>
    /cancelled, partial \(\d+ of 99\)/.test(tr.textContent) && tr.textContent.includes("cancelled from the dashboard")
    && /\d{1,2}:\d{2}/.test(tr.cells[1].textContent) && /\d{1,2}:\d{2}/.test(tr.cells[2].textContent)
    && tr.cells[4].textContent === "default"
    && /^PR-650 \d+$/.test(tr.cells[5].textContent)), null,
    { timeout: 30000 });
  const pageInfo = await page.textContent("#page-info");
  if (!/^1–2 of 2$/.test(pageInfo)) failures.push("page info: " + pageInfo);
  // The booth and instrument filters: this daemon's booth (marked) and its
  // PR-650 keep both measurements.
  const boothOption = await page.textContent("#filter-booth option[value='default']");
  if (boothOption !== "default (this daemon)") failures.push("booth option: " + boothOption);
  await page.selectOption("#filter-booth", "default");
  await page.waitForFunction(() => document.getElementById("page-info").textContent === "1–2 of 2");
  if (shots) await page.screenshot({ path: `${shots}/measurements.png`, fullPage: true });
  // The instrument filter offers the models the database has seen (this
  // daemon's PR-650), not a fixed list of Photo Research models (issue 46).
  await page.waitForFunction(() => [...document.querySelectorAll("#filter-model option")].some((o) => o.value === "PR-650"));
  const offered = await page.$$eval("#filter-model option", (os) => os.map((o) => o.value).join(","));
  if (offered !== ",PR-650") failures.push(`instrument filter offers "${offered}"`);
  await page.selectOption("#filter-model", "PR-650");
  await page.waitForFunction(() => document.getElementById("page-info").textContent === "1–2 of 2"
    && document.querySelectorAll("#measurement-table tbody tr").length === 2);
  await page.selectOption("#filter-model", "");
  await page.selectOption("#filter-booth", "");

  // The scene comparison: every coding, every chart.
  await page.goto(`${base}/#/scenes/white`);
  await page.waitForFunction(() => document.querySelectorAll("#coding-table tbody tr").length === 7, null, { timeout: 120000 });
  for (const chart of ["chromaticity", "profile", "rms", "de", "speed"]) {
    await page.waitForFunction((id) => {
      const img = document.getElementById("chart-" + id);
      return img.complete && img.naturalWidth > 0;
    }, chart, { timeout: 30000 });
  }
  await page.waitForFunction(() => {
    const img = document.getElementById("scene-preview");
    return !img.hidden && img.complete && img.naturalWidth > 0;
  }, null, { timeout: 30000 });
  const codings = await page.$$eval("#coding-table tbody tr td:first-child", (tds) => tds.map((t) => t.textContent));
  if (codings.join(",") !== "rgb,srgb,nstep3,nstep9,nstep27,nstep81,spectral") failures.push("codings: " + codings);
  // Each coding's three claims, and under the table what they rest on.
  const claims = await page.$$eval("#coding-table tbody tr", (trs) => trs.map((tr) => [...tr.cells].slice(6).map((c) => c.textContent)));
  for (const [i, row] of claims.entries()) {
    if (row.length !== 3 || !row.every((c) => /^rms_rel/.test(c))) failures.push(`coding ${codings[i]}'s claims: ${row}`);
    if (!/ΔE00: not stated/.test(row[2])) failures.push(`the PR-650 states no colour accuracy, yet ${codings[i]}: ${row[2]}`);
  }
  const claimNote = await page.textContent("#coding-uncertainty-note");
  if (!/PR-650's stated accuracy: luminance ±4 %/.test(claimNote)) failures.push("the claims' note: " + claimNote);
  const caption = await page.textContent("#preview-caption");
  if (!/paths per pixel/.test(caption)) failures.push("preview caption does not say its paths per pixel: " + caption);
  if (shots) await page.screenshot({ path: `${shots}/scene-white.png`, fullPage: true });

  // Every other scene's page (no measurements yet: the page still loads cleanly).
  // The Scenes overview: a row per scene, WHITE measured (1 of 1) with its
  // thumbnail and a ΔE00 per coding.
  await page.goto(`${base}/#/scenes`);
  await page.waitForSelector("#scene-table tbody tr");
  await page.waitForFunction(() => {
    const row = document.querySelector("#scene-table tbody tr[data-scene=white]");
    const img = row && row.querySelector("img.thumb");
    return row && /1 \/ 1/.test(row.cells[2].textContent) && row.querySelectorAll("table.compact th").length === 7
      && img && img.complete && img.naturalWidth > 0;
  }, null, { timeout: 30000 });
  if (shots) await page.screenshot({ path: `${shots}/scenes.png`, fullPage: true });
  const sceneIds = await page.$$eval("#scene-table > tbody > tr", (trs) => trs.map((tr) => tr.dataset.scene));
  for (const id of sceneIds.filter((id) => id !== "white")) {
    await page.goto(`${base}/#/scenes/${id}`);
    await page.waitForFunction((id) => document.getElementById("scene-title").textContent.startsWith(id), id);
    await page.waitForLoadState("networkidle");
    // Regression: the WHITE scene's preview caption stayed under scenes never rendered.
    const staleCaption = await page.textContent("#preview-caption");
    if (/Camera view of render/.test(staleCaption) && !(await page.isVisible("#scene-preview")))
      failures.push(`scene ${id} shows another scene's preview caption: ${staleCaption}`);
    if (shots) await page.screenshot({ path: `${shots}/scene-${id}.png`, fullPage: true });
  }

  // Regression (issue 46): the scene page offered to "measure the 17
  // targets not yet measured" beside 17 of them waiting, and one click
  // queued each twice. With the instrument slowed, three targets queued
  // from outside are "on their way", the button offers only the rest, and
  // its click leaves one measurement per target.
  {
    const auth = { Authorization: `Bearer ${token}`, "Content-Type": "application/json" };
    const call = async (method, path, body) => {
      const r = await fetch(base + path, { method, headers: auth, body: body === undefined ? undefined : JSON.stringify(body) });
      return r.status === 204 ? null : r.json();
    };
    await call("POST", "/api/mock/faults", { faults: "slow@3000ms" });
    const cylinder = await call("GET", "/api/scenes/cylinder");
    const complete = await call("GET", "/api/measurements?scene=cylinder&state=complete&limit=1000");
    const unmeasured = cylinder.targets.filter((t) => !complete.items.some((m) => m.target === t));
    const newestBefore = (await call("GET", "/api/measurements?limit=1")).items[0]?.id ?? 0;
    for (const target of unmeasured.slice(0, 3)) await call("POST", "/api/measurements", { scene: "cylinder", target, samples: 5 });
    await page.goto(`${base}/#/scenes/cylinder`);
    await page.waitForFunction(() => /on their way/.test(document.getElementById("scene-on-their-way")?.textContent || ""), null, { timeout: 20000 });
    const way = await page.textContent("#scene-on-their-way");
    if (!way.startsWith("3 not yet measured are on their way")) failures.push(`scene page, 3 targets queued: "${way}"`);
    const offer = await page.textContent("#measure-missing");
    const rest = unmeasured.length - 3;
    if (!offer.startsWith(`Measure the ${rest} target${rest === 1 ? "" : "s"} not yet measured`))
      failures.push(`scene page, 3 of ${unmeasured.length} unmeasured targets queued, offers: "${offer}"`);
    if (shots) await page.screenshot({ path: `${shots}/scene-cylinder-queued.png`, fullPage: true });
    await page.click("#measure-missing");
    await page.waitForFunction(() => document.getElementById("measure-missing").hidden &&
      /on their way/.test(document.getElementById("scene-on-their-way").textContent), null, { timeout: 60000 });
    const all = await call("GET", "/api/measurements?scene=cylinder&limit=1000");
    const mine = all.items.filter((m) => m.id > newestBefore);
    const targets = mine.map((m) => m.target);
    if (targets.length !== new Set(targets).size || targets.length !== unmeasured.length)
      failures.push(`after "measure the rest": ${targets.length} measurements for ${unmeasured.length} unmeasured targets (${targets.join(", ")})`);
    if (shots) await page.screenshot({ path: `${shots}/scene-cylinder-all-on-their-way.png`, fullPage: true });
    await call("POST", "/api/mock/faults", { faults: "" });
    for (const m of mine) if (m.state === "queued" || m.state === "running") await call("POST", `/api/measurements/${m.id}/cancel`, {});
    // A cancel answers 202 while the running one is still stopping: wait
    // until the instrument is free, or the calibration below finds it busy
    // (its hold refused with 409, seen in a clean-clone CI run).
    for (let waited = 0; ; waited += 200) {
      const busy = (await call("GET", "/api/measurements?state=running&limit=1")).total +
        (await call("GET", "/api/measurements?state=queued&limit=1")).total;
      if (busy === 0) break;
      if (waited > 60000) { failures.push(`${busy} measurements still queued or running 60 s after their cancel`); break; }
      await new Promise((r) => setTimeout(r, 200));
    }
  }

  // A study of the WHITE scene against the measurement just taken, with sweeps.
  // Regression (issue 46): the plan box was an empty bar before and after a
  // run, and the time left said "about 0 s" mid-run. A sampler records both
  // (this page keeps its document: the study page is a hash route).
  await page.evaluate(() => {
    window.__studySeen = { emptyPlan: 0, aboutZero: [] };
    setInterval(() => {
      if (!location.hash.startsWith("#/study")) return;
      const plan = document.getElementById("study-plan");
      if (plan && plan.offsetHeight > 0 && !plan.textContent.trim()) window.__studySeen.emptyPlan += 1;
      const progress = document.getElementById("study-progress").textContent;
      if (/about 0 s/.test(progress)) window.__studySeen.aboutZero.push(progress);
    }, 25);
  });
  await page.goto(`${base}/#/study`);
  await page.waitForSelector("#study-scenes input[value=white]");
  for (const box of await page.$$("#study-scenes input")) {
    if ((await box.getAttribute("value")) !== "white") await box.uncheck();
  }
  await page.fill("#study-seeds", "2");
  await page.click("#study-button");
  // A page opened on the running study shows its step and time left at
  // once, not at the study's next progress event (issue 46: a study page
  // opened mid-step showed "running" and nothing else).
  {
    await page.waitForFunction(() => /^study \d+: /.test(document.getElementById("study-progress").textContent),
      null, { timeout: 60000 });
    const late = await browser.newPage({ viewport: { width: 1300, height: 1000 } });
    await late.goto(`${base}/#/study`);
    const running = async () => (await (await fetch(`${base}/api/studies`)).json()).some((st) => st.state === "running");
    if (await running()) {
      const shown = await late.waitForFunction(
        () => /^study \d+: .*(left|estimating)/.test(document.getElementById("study-progress").textContent),
        null, { timeout: 2000 }).then(() => true, () => false);
      if (shown && shots) await late.screenshot({ path: `${shots}/study-running.png`, fullPage: true });
      if (!shown && await running()) failures.push("a page opened on a running study showed no progress line within 2 s");
    }
    await late.close();
  }
  await page.waitForFunction(() => /complete|failed/.test(document.getElementById("study-progress").textContent), null, { timeout: 180000 });
  const progressText = await page.textContent("#study-progress");
  if (!progressText.includes("complete")) failures.push("study: " + progressText);
  await page.waitForFunction(() => document.getElementById("study-plan").textContent.trim() !== "Planning the study…", null, { timeout: 30000 });
  await page.waitForTimeout(200);
  const seen = await page.evaluate(() => window.__studySeen);
  if (seen.emptyPlan) failures.push(`the study's plan box was an empty bar (${seen.emptyPlan} samples of 25 ms)`);
  if (seen.aboutZero.length) failures.push(`the study's time left said "about 0 s": ${seen.aboutZero[0]}`);
  await page.waitForSelector("#study-table tbody tr");
  await page.click("#study-table tbody tr td");
  const images = "#study-detail img";
  await page.waitForFunction((sel) => document.querySelectorAll(sel).length >= 5, images, { timeout: 30000 });
  await page.waitForFunction((sel) => [...document.querySelectorAll(sel)].every((i) => i.complete && i.naturalWidth > 0), images, { timeout: 30000 });
  // One section per scene, with its heading and its own charts.
  const sections = await page.$$eval("#study-summary section.study-scene", (ss) =>
    ss.map((s) => [s.querySelector("h4")?.textContent || "", s.querySelectorAll("img").length]));
  if (!sections.length || sections.some(([h, n]) => !h || n < 4)) failures.push("study sections: " + JSON.stringify(sections));
  // The request is folded away, not printed raw in the table.
  if (!(await page.$("#study-table tbody tr details"))) failures.push("the study request is not folded in <details>");
  // The report link is shown for a finished study and answers.
  if (!(await page.isVisible("#study-report"))) failures.push("no report link for a finished study");
  const report = await page.request.get(await page.getAttribute("#study-report", "href").then((h) => new URL(h, base).href));
  if (report.status() !== 200) failures.push(`report link answers ${report.status()}`);
  if (shots) await page.screenshot({ path: `${shots}/study.png`, fullPage: true });

  // A study that ends without a report (one cancelled while it runs; a
  // study missing measurements is refused up front): no dead report links.
  const started = await page.request.post(`${base}/api/studies`, {
    headers: { Authorization: `Bearer ${token}` },
    data: { scenes: "blue", against: "reference", seeds: 64, sweeps: true },
  });
  if (started.status() !== 202) failures.push(`starting the study to cancel answered ${started.status()}`);
  const failedId = (await started.json()).id;
  await page.request.post(`${base}/api/studies/${failedId}/cancel`, { headers: { Authorization: `Bearer ${token}` } });
  await page.waitForFunction(async (id) => {
    const r = await fetch(`/api/studies/${id}`);
    return (await r.json()).state === "cancelled";
  }, failedId, { timeout: 30000 });
  await page.goto(`${base}/#/study/${failedId}`);
  await page.waitForFunction((id) => document.getElementById("study-title").textContent.includes(`Study ${id}: cancelled`), failedId);
  if (await page.isVisible("#study-report")) failures.push("a study that did not complete shows a report link");
  if (shots) await page.screenshot({ path: `${shots}/study-failed.png`, fullPage: true });

  // Measured, compared, studied: now calibrate, and open every page.
  await visitEveryPage(page, base, shots, failures);
} catch (e) {
  failures.push(String(e));
} finally {
  await browser.close();
}
finish(failures, "dashboard ok");
