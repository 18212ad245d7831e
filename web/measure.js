// Measuring what a page shows on the screen, shared by the calibration page
// and an experiment's session page: queue a measurement through the
// ordinary API and poll it until it is complete; keep the instrument hold
// the page works under (keepHold).
//
//   const m = await measureAndWait(api, { samples: 3, note: "patch 4 of 21" },
//                                  { onStarted: (id) => …, cancelled: () => false });
//
// Returns the complete measurement, or null when `cancelled()` turns true
// (the caller cancels the measurement itself; what was measured stays
// stored). A measurement that fails, is cancelled by someone else or is
// interrupted throws, naming it and its note.
"use strict";

async function measureAndWait(api, body, { onStarted = () => {}, cancelled = () => false } = {}) {
  const started = await api("/api/measurements", { method: "POST", body: JSON.stringify(body) });
  onStarted(started.id);
  for (;;) {
    const m = await api(`/api/measurements/${started.id}`);
    if (m.state === "complete") return m;
    if (cancelled()) return null;
    if (["failed", "cancelled", "interrupted"].includes(m.state)) {
      throw new Error(`measurement ${started.id} (${body.note || "no note"}) ${m.state}: ${m.error || ""}`);
    }
    await new Promise((r) => setTimeout(r, 200));
  }
}

// Keeps the instrument hold `hold` (what POST /api/instrument/hold answered)
// while the page works under it: renews it every quarter of its
// `renew_within_s`, so it lasts while the page is open and expires soon
// after the page is gone (closed, crashed) instead of blocking the
// instrument until an operator releases it. Stops renewing once the hold
// has ended (the next use of it is refused, saying why). Returns the
// function that stops renewing; call it when releasing the hold.
function keepHold(api, hold) {
  const every = Math.max(5, (hold.renew_within_s || 120) / 4) * 1000;
  const timer = setInterval(() => {
    api(`/api/instrument/hold/${hold.id}/renew`, { method: "POST", body: "{}" }).catch((e) => {
      if (/no hold/.test(e.message)) clearInterval(timer);
    });
  }, every);
  return () => clearInterval(timer);
}
