// The hold–show–measure–release loop (web/measure.js's holdShowMeasure, the
// one loop of the calibration page and an experiment's session page)
// against a stand-in for the daemon's API: what it asks in what order, and
// that the hold is released however the loop ends.
import { test } from "node:test";
import assert from "node:assert/strict";
import { holdShowMeasure, measureAndWait } from "../../web/measure.js";

// A stand-in for shared.js's api(): answers like the daemon, records every
// call as "METHOD path body", and lets a test change an answer (`on`).
function daemon({ on = {} } = {}) {
  const calls = [];
  let nextId = 100;
  const states = new Map();
  const api = async (path, options = {}) => {
    const method = options.method || "GET";
    const body = options.body ? JSON.parse(options.body) : undefined;
    calls.push({ method, path, body });
    const key = `${method} ${path.replace(/\d+/g, "N")}`;
    if (on[key]) return on[key]({ path, body, calls, states });
    if (key === "POST /api/instrument/hold") return { id: 7, renew_within_s: 120 };
    if (key === "POST /api/mock/display") return {};
    if (key === "POST /api/measurements") {
      const id = nextId++;
      states.set(id, body);
      return { id, state: "queued" };
    }
    if (key === "GET /api/measurements/N") return { id: Number(path.split("/").pop()), state: "complete" };
    if (key === "POST /api/instrument/hold/N/release") return null;
    throw new Error(`unexpected ${key}`);
  };
  const said = () => calls.map((c) => `${c.method} ${c.path}`);
  return { api, calls, said };
}

const patches = [{ drive: [0, 0, 0], label: "black" }, { drive: [1, 1, 1], label: "white" }];
const shows = [];
function options(run, extra = {}) {
  shows.length = 0;
  return {
    purpose: "display calibration “test”", patches, samples: 3, run, settleMs: 0, pollMs: 0,
    show: (p, i, simulated) => {
      shows.push({ label: p.label, simulated, stopped: false });
      const shown = shows[shows.length - 1];
      return { display: Promise.resolve({ drive: p.drive }), stop: () => { shown.stopped = true; } };
    },
    note: (p, i) => `patch ${i + 1}: ${p.label}`,
    ...extra,
  };
}

test("holds, then shows, tells the simulated display and measures each patch under the hold, then releases it", async () => {
  const d = daemon();
  const run = { hold: null, measurementId: null, cancelled: false };
  const held = [];
  const out = await holdShowMeasure(d.api, options(run, { onHeld: () => held.push(run.hold) }));
  assert.deepEqual(d.said(), [
    "POST /api/instrument/hold",
    "POST /api/mock/display", "POST /api/measurements", "GET /api/measurements/100",
    "POST /api/mock/display", "POST /api/measurements", "GET /api/measurements/101",
    "POST /api/instrument/hold/7/release",
  ]);
  assert.deepEqual(d.calls[0].body, { purpose: "display calibration “test”" });
  assert.deepEqual(held, [7]); // onHeld once the hold is granted
  assert.deepEqual(d.calls[1].body, { drive: [0, 0, 0], hold: 7 });
  assert.deepEqual(d.calls[2].body, { samples: 3, note: "patch 1: black", hold: 7 });
  assert.deepEqual(d.calls[5].body, { samples: 3, note: "patch 2: white", hold: 7 });
  assert.deepEqual(out.measured.map((x) => [x.patch.label, x.measurement.id]), [["black", 100], ["white", 101]]);
  assert.equal(out.cancelled, false);
  assert.equal(out.simulated, true);
  assert.ok(shows.every((s) => s.stopped), "each patch's drawing is stopped after it");
  assert.equal(run.hold, null);
  assert.equal(run.measurementId, null);
});

test("a daemon with a real instrument (no simulated display) is told once, and the patches are still measured", async () => {
  const d = daemon({ on: { "POST /api/mock/display": () => { throw new Error("no simulated display: this daemon has a real instrument"); } } });
  const out = await holdShowMeasure(d.api, options({}));
  assert.equal(d.said().filter((c) => c === "POST /api/mock/display").length, 1);
  assert.equal(out.simulated, false);
  assert.equal(out.measured.length, 2);
  assert.deepEqual(shows.map((s) => s.simulated), [true, false]); // the second patch needs no read-back
});

test("Cancel during a measurement stops after it: what was measured is returned, the hold released", async () => {
  const run = {};
  let polls = 0;
  const d = daemon({ on: { "GET /api/measurements/N": ({ path }) => {
    const id = Number(path.split("/").pop());
    if (id === 101) {
      polls++;
      assert.equal(run.measurementId, 101); // the page's Cancel knows which measurement to cancel
      run.cancelled = true; // the page's Cancel (or Esc)
      return { id, state: "running" };
    }
    return { id, state: "complete" };
  } } });
  const out = await holdShowMeasure(d.api, options(run));
  assert.equal(out.cancelled, true);
  assert.deepEqual(out.measured.map((x) => x.measurement.id), [100]);
  assert.equal(polls, 1);
  assert.equal(d.said().at(-1), "POST /api/instrument/hold/7/release");
  assert.equal(run.hold, null);
});

test("a failed measurement throws, naming it and its note, and the hold is released", async () => {
  const d = daemon({ on: { "GET /api/measurements/N": ({ path }) =>
    ({ id: Number(path.split("/").pop()), state: "failed", error: "instrument error 19" }) } });
  const run = {};
  await assert.rejects(holdShowMeasure(d.api, options(run)), /measurement 100 \(patch 1: black\) failed: instrument error 19/);
  assert.equal(d.said().at(-1), "POST /api/instrument/hold/7/release");
  assert.ok(shows[0].stopped);
  assert.equal(run.hold, null);
});

test("a refused hold shows nothing, measures nothing and releases nothing", async () => {
  const d = daemon({ on: { "POST /api/instrument/hold": () => { throw new Error("the instrument is held by measurement 3"); } } });
  await assert.rejects(holdShowMeasure(d.api, options({})), /held by measurement 3/);
  assert.deepEqual(d.said(), ["POST /api/instrument/hold"]);
  assert.equal(shows.length, 0);
});

test("measureAndWait polls until complete, and returns null once cancelled", async () => {
  let n = 0;
  const d = daemon({ on: { "GET /api/measurements/N": ({ path }) =>
    ({ id: Number(path.split("/").pop()), state: ++n < 3 ? "running" : "complete" }) } });
  const m = await measureAndWait(d.api, { samples: 1, note: "x" }, { pollMs: 0 });
  assert.equal(m.state, "complete");
  assert.equal(n, 3);
  const cancelled = await measureAndWait(daemon({ on: { "GET /api/measurements/N": () => ({ state: "running" }) } }).api,
    { samples: 1 }, { cancelled: () => true, pollMs: 0 });
  assert.equal(cancelled, null);
});

test("with a real instrument and `aimed`, each patch is measured only after the operator says it is aimed", async () => {
  const d = daemon({ on: { "POST /api/mock/display": () => { throw new Error("no simulated display: this daemon has a real instrument"); } } });
  const aimedAt = [];
  const out = await holdShowMeasure(d.api, options({}, {
    aimed: async (p) => { aimedAt.push([p.label, d.said().filter((c) => c === "POST /api/measurements").length]); },
  }));
  // Each confirmation comes before that patch's measurement is asked for (the first included).
  assert.deepEqual(aimedAt, [["black", 0], ["white", 1]]);
  assert.equal(out.measured.length, 2);
});

test("with the simulated display, `aimed` is not asked: nobody aims a simulated instrument", async () => {
  const d = daemon();
  let asked = 0;
  await holdShowMeasure(d.api, options({}, { aimed: async () => { asked++; } }));
  assert.equal(asked, 0);
});
