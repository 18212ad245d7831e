// Measuring what a page shows on the screen (an ES module), shared by the
// calibration page and an experiment's session page: hold the instrument,
// show each patch, tell the simulated display what is shown (with --mock),
// measure it through the ordinary API, and release the hold however that
// ends (holdShowMeasure); or one measurement polled until it is complete
// (measureAndWait); and keeping a hold alive while the page works under it
// (keepHold). Every function takes the page's `api` (shared.js's, or a
// stand-in in tests/web/measure.test.mjs); importing this module does
// nothing.

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

/** Queues a measurement (`body`: samples, note, hold) and polls it until it
 * is complete:
 *
 *     const m = await measureAndWait(api, { samples: 3, note: "patch 4 of 21" },
 *                                    { onStarted: (id) => …, cancelled: () => false });
 *
 * Returns the complete measurement, or null when `cancelled()` turns true
 * (the caller cancels the measurement itself; what was measured stays
 * stored). A measurement that fails, is cancelled by someone else or is
 * interrupted throws, naming it and its note. */
export async function measureAndWait(api, body, { onStarted = () => {}, cancelled = () => false, pollMs = 200 } = {}) {
  const started = await api("/api/measurements", { method: "POST", body: JSON.stringify(body) });
  onStarted(started.id);
  for (;;) {
    const m = await api(`/api/measurements/${started.id}`);
    if (m.state === "complete") return m;
    if (cancelled()) return null;
    if (["failed", "cancelled", "interrupted"].includes(m.state)) {
      throw new Error(`measurement ${started.id} (${body.note || "no note"}) ${m.state}: ${m.error || ""}`);
    }
    await sleep(pollMs);
  }
}

/** Keeps the instrument hold `hold` (what POST /api/instrument/hold
 * answered) while the page works under it: renews it every quarter of its
 * `renew_within_s`, so it lasts while the page is open and expires soon
 * after the page is gone (closed, crashed) instead of blocking the
 * instrument until an operator releases it. Stops renewing once the hold
 * has ended (the next use of it is refused, saying why). Returns the
 * function that stops renewing; call it when releasing the hold. */
export function keepHold(api, hold) {
  const every = Math.max(5, (hold.renew_within_s || 120) / 4) * 1000;
  const timer = setInterval(() => {
    api(`/api/instrument/hold/${hold.id}/renew`, { method: "POST", body: "{}" }).catch((e) => {
      if (/no hold/.test(e.message)) clearInterval(timer);
    });
  }, every);
  return () => clearInterval(timer);
}

/** The hold–show–measure–release loop of a display check (a calibration's
 * patches, an experiment's verification, a test patch):
 *
 * 1. holds the instrument for `purpose` (refused, naming who or what, while
 *    anything else is measuring or queued; while held nothing else is
 *    measured and nobody else changes the display), renewed while the page
 *    is open (keepHold), and calls `onHeld()`;
 * 2. for each of `patches`, unless `run.cancelled`: `progress(i, total,
 *    began)` (began: Date.now() at the first patch), `show(patch, i,
 *    simulated)`, which draws the patch and returns `{ display, stop }`:
 *    `display` (or a promise of it) is what the simulated display is told
 *    is shown (null: nothing), `stop()` ends the drawing after the patch;
 *    with --mock it POSTs `display` with the hold to /api/mock/display (a
 *    daemon with a real instrument answers "no simulated display", and is
 *    not asked again); waits `settleMs` for the monitor to settle; with a
 *    real instrument and `aimed`, waits for `aimed(patch, i)` (the
 *    operator aims at the patch and confirms); and measures `samples`
 *    samples with the note `note(patch, i)`;
 * 3. releases the hold however this ends (done, cancelled, or an error,
 *    which is thrown on).
 *
 * `run` is the page's view of the check under way: `run.hold` (the hold's
 * id while held, else null), `run.measurementId` (the measurement under
 * way, for the page's Cancel or Esc to cancel) and `run.cancelled` (set by
 * the page to stop after the measurement under way). Returns `{ measured:
 * [{ patch, measurement }], cancelled, simulated }`: the complete
 * measurements in order (what was measured stays stored when cancelled). */
export async function holdShowMeasure(api, { purpose, patches, samples, note, show, run,
  onHeld = () => {}, progress = () => {}, settleMs = 100, pollMs = 200, aimed = null }) {
  const held = await api("/api/instrument/hold", { method: "POST", body: JSON.stringify({ purpose }) });
  Object.assign(run, { hold: held.id, measurementId: null, cancelled: false });
  const stopRenewing = keepHold(api, held);
  const measured = [];
  let simulated = true;
  try {
    onHeld();
    const began = Date.now();
    for (const [i, patch] of patches.entries()) {
      if (run.cancelled) break;
      progress(i, patches.length, began);
      const shown = show(patch, i, simulated) || {};
      try {
        const display = await shown.display;
        if (simulated && display) {
          try {
            await api("/api/mock/display", { method: "POST", body: JSON.stringify({ ...display, hold: run.hold }) });
          } catch (e) {
            if (!/no simulated display/.test(e.message)) throw e;
            simulated = false; // a real instrument looks at the real screen
          }
        }
        await sleep(settleMs); // let the monitor settle on the new colour
        // A real instrument the operator aims (an image's targets): wait for
        // the operator to say it is aimed.
        if (!simulated && aimed) await aimed(patch, i);
        if (run.cancelled) break;
        const m = await measureAndWait(api, { samples, note: note(patch, i), hold: run.hold },
          { onStarted: (id) => (run.measurementId = id), cancelled: () => run.cancelled, pollMs });
        if (m === null) break;
        measured.push({ patch, measurement: m });
      } finally {
        run.measurementId = null;
        if (shown.stop) shown.stop();
      }
    }
    return { measured, cancelled: run.cancelled, simulated };
  } finally {
    stopRenewing();
    await api(`/api/instrument/hold/${held.id}/release`, { method: "POST", body: "{}" }).catch(() => {});
    run.hold = null;
  }
}
