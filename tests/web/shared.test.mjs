// The pages' pure helpers (web/shared.js) under Node's own test runner:
// `node --test tests/web/`. Importing web/shared.js must not touch
// `document` or `window` (Node has neither): the import below is that test.
import { test } from "node:test";
import assert from "node:assert/strict";
import {
  count, duration, fmt, instrumentBadgeText, laterTime, localTime, luminanceScaleTicks, observerName,
  readCookieRefusal,
} from "../../web/shared.js";

test("duration: seconds, then minutes and zero-padded seconds, then hours and zero-padded minutes", () => {
  assert.equal(duration(0), "0 s");
  assert.equal(duration(12.4), "12 s");
  assert.equal(duration(59.6), "1 min 00 s"); // rounded first, then split
  assert.equal(duration(185), "3 min 05 s");
  assert.equal(duration(3599), "59 min 59 s");
  assert.equal(duration(3600), "1 h 00 min");
  assert.equal(duration(7380), "2 h 03 min");
});

test("duration: none, not a number or negative reads as a dash or 0 s, never NaN", () => {
  assert.equal(duration(null), "–");
  assert.equal(duration(undefined), "–");
  assert.equal(duration(NaN), "–");
  assert.equal(duration(Infinity), "–");
  assert.equal(duration(-5), "0 s"); // a countdown past its estimate
});

test("count: the noun in the singular for one only", () => {
  assert.equal(count(1, "target"), "1 target");
  assert.equal(count(0, "target"), "0 targets");
  assert.equal(count(2, "seed"), "2 seeds");
  assert.equal(count("1", "scene"), "1 scene");
});

test("fmt: significant digits, a dash for none, 0 kept", () => {
  assert.equal(fmt(34.5678), "34.6");
  assert.equal(fmt(34.5678, 5), "34.568");
  assert.equal(fmt(0.000123456, 2), "0.00012");
  assert.equal(fmt(0), "0.00");
  assert.equal(fmt(null), "–");
  assert.equal(fmt(undefined), "–");
});

test("localTime and laterTime: nothing for no time; the time of day alone on the same day", () => {
  assert.equal(localTime(null), "");
  assert.equal(laterTime(0, undefined), "");
  const noon = new Date(2026, 11, 7, 12, 0, 0).getTime() / 1000;
  assert.equal(laterTime(noon, noon + 60), new Date((noon + 60) * 1000).toLocaleTimeString());
  assert.equal(laterTime(noon, noon + 2 * 86400), new Date((noon + 2 * 86400) * 1000).toLocaleString());
  assert.equal(localTime(noon), new Date(noon * 1000).toLocaleString());
});

test("observerName: each observer the daemon names, and an unrecorded one said so", () => {
  assert.equal(observerName("judd-vos-1978"), "Judd–Vos 1978 2°");
  assert.equal(observerName("cie-1931"), "CIE 1931 2°");
  assert.equal(observerName("cie-1964-10"), "CIE 1964 10°");
  assert.equal(observerName("cie-2015-2"), "CIE 2015 2°");
  assert.equal(observerName("cie-2015-10"), "CIE 2015 10°");
  assert.equal(observerName(undefined), "observer not recorded");
});

test("the instrument badge: idle names the model, what it measures and the port", () => {
  assert.equal(instrumentBadgeText({ state: "idle", model: "PR-650", serial: "60954303", measures: "spectrum", port: "/dev/pts/0" }),
    "PR-650 60954303 (spectrum) idle on /dev/pts/0");
  assert.equal(instrumentBadgeText({ state: "idle", model: "LS-100", port: "/dev/ttyUSB0" }), "LS-100 idle on /dev/ttyUSB0");
});

test("the instrument badge: measuring names the sample under way, and the time left only after a sample", () => {
  const s = { state: "measuring", measurement_id: 7, scene: "white", target: "patch", sample: 0, of: 5, expected_finish_at: 1100 };
  // "sample 0 of 5" read as stuck: the sample under way is 1.
  assert.equal(instrumentBadgeText(s, 1000), "measuring #7 white/patch: sample 1 of 5");
  assert.equal(instrumentBadgeText({ ...s, sample: 2 }, 1000),
    "measuring #7 white/patch: sample 3 of 5 · about 1 min 40 s left at its pace so far");
  // The last sample taken: never "sample 6 of 5"; past the estimate: 0 s, not negative.
  assert.equal(instrumentBadgeText({ ...s, sample: 5, scene: null }, 1200),
    "measuring #7: sample 5 of 5 · about 0 s left at its pace so far");
});

test("the instrument badge: disconnected and error say why", () => {
  assert.equal(instrumentBadgeText({ state: "disconnected", reason: "no port" }), "disconnected: no port");
  assert.equal(instrumentBadgeText({ state: "error", message: "timeout" }), "error: timeout");
});

test("a refused read cookie says what was refused and what to do", () => {
  const text = readCookieRefusal(401);
  assert.match(text, /refused this page's token \(HTTP 401\)/);
  assert.match(text, /open the URL the daemon printed/);
  // What it means on loopback too, where reads need no token: changes are refused.
  assert.match(text, /every other change will be refused/);
});

test("the luminance scale's ticks are decades inside the bar, placed along log Y", () => {
  // Log average 1 cd/m²: k = 0.18; the bar runs from 10^-1.25 to 10^4.74.
  const { low, high, ticks } = luminanceScaleTicks(1);
  assert.ok(Math.abs(low - Math.log10(0.01 / 0.99 / 0.18)) < 1e-12);
  assert.ok(Math.abs(high - Math.log10(0.9999 / 0.0001 / 0.18)) < 1e-12);
  assert.deepEqual(ticks.map((t) => t.label), ["0.1", "1", "10", "100", "1000", "10000"]);
  for (const t of ticks) assert.ok(t.at > 0 && t.at < 1, `${t.label} at ${t.at}`);
  // 1 cd/m² sits where log10(1) = 0 is between the ends.
  assert.ok(Math.abs(ticks[1].at - (0 - low) / (high - low)) < 1e-12);
  // A bright scene (log average 30 cd/m², a 34.5 cd/m² patch) reaches past the patch.
  const bright = luminanceScaleTicks(30).ticks.map((t) => Number(t.label));
  assert.ok(Math.max(...bright) >= 100000, String(bright));
});
