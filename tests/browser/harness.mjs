// The browser tests' one harness (issue 47: each of the 13 scripts copied
// the same launch preamble and ending). Every script runs Debian's headless
// Chromium (or $CHROMIUM) through playwright-core, as a newcomer's browser:
//
//   import { launch, finish } from "./harness.mjs";
//   const browser = await launch();            // or launch({ webgl: true })
//   const failures = [];
//   try { … failures.push("what went wrong") … } finally { await browser.close(); }
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

/** Ends a script: every failure on stderr and exit status 1, or `passed`
 * (if given) on stdout. */
export function finish(failures, passed) {
  if (failures.length) {
    console.error(failures.join("\n"));
    process.exit(1);
  }
  if (passed) console.log(passed);
}
