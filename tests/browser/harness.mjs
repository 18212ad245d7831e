// The browser tests' one harness (issue 47: each of the 13 scripts copied
// the same launch preamble, page listeners and ending). Every script runs
// Debian's headless Chromium (or $CHROMIUM) through playwright-core, as a
// newcomer's browser:
//
//   import { finish, launch, watch } from "./harness.mjs";
//   const browser = await launch();            // or launch({ webgl: true })
//   const failures = [];
//   try {
//     const page = await browser.newPage();
//     watch(page, failures);                   // console errors, page errors, failed requests, HTTP errors
//     … failures.push("what went wrong") …
//   } finally { await browser.close(); }
//   finish(failures, "what passed");
import { chromium } from "playwright-core";

/** Headless Chromium with the switches every script needs (no sandbox in
 * the test container, no background traffic). `webgl`: WebGL2 through
 * SwiftShader, as the experiment's session page needs (no GPU on the test
 * machine); otherwise the GPU is off. */
export function launch({ webgl = false } = {}) {
  const gpu = webgl ? ["--use-angle=swiftshader", "--enable-unsafe-swiftshader"] : ["--disable-gpu"];
  return chromium.launch({
    executablePath: process.env.CHROMIUM || "/usr/bin/chromium",
    headless: true,
    args: ["--no-sandbox", ...gpu, "--disable-quic", "--no-first-run", "--disable-background-networking",
      "--disable-component-update", "--disable-sync"],
  });
}

/** Fails the run (pushes to `failures`) on anything a page does wrong: a
 * console error (a module that does not load, wrong MIME type or missing
 * file, is one), an uncaught error (an import of a name a module does not
 * export is one), a failed request other than an aborted one (a chart
 * <img> whose source is replaced while loading is aborted on purpose), and
 * any HTTP status of 400 or more. */
export function watch(page, failures) {
  page.on("console", (m) => { if (m.type() === "error") failures.push("console error: " + m.text()); });
  page.on("pageerror", (e) => failures.push("page error: " + e.message));
  page.on("requestfailed", (r) => {
    if (r.failure()?.errorText !== "net::ERR_ABORTED") failures.push(`request failed: ${r.url()} (${r.failure()?.errorText})`);
  });
  page.on("response", (r) => { if (r.status() >= 400) httpFailure(r, failures); });
}

/** An HTTP error as a failure, with the start of the answer's body (the
 * daemon says there what was wrong) appended when it arrives. */
export function httpFailure(r, failures) {
  const i = failures.push(`HTTP ${r.status()} for ${r.url()}`) - 1;
  r.text().then((t) => { failures[i] += `: ${t.slice(0, 500)}`; }).catch(() => {});
}

/** Ends a script: every failure on stderr and exit status 1, or `passed`
 * (if given) on stdout. */
export function finish(failures, passed) {
  if (failures.length) {
    console.error(failures.join("\n"));
    process.exit(1);
  }
  if (passed) console.log(passed);
}
