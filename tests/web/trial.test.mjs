// An oddity session's timing and geometry arithmetic (web/trial.js, used by
// web/experiment-run.js) under Node's test runner: whole frames, the
// refresh, one trial's frame clock (the pie's frames, its onset, dropped
// frames, the reaction time), the pie's pieces and the dither's resolution.
import { test } from "node:test";
import assert from "node:assert/strict";
import {
  checkProgress, DROPPED, ditherResolution, frames, medianInterval, pieceAt, pieDiameterPx, TrialClock,
} from "../../web/trial.js";

const HZ60 = 1000 / 60;

test("frames: a duration in whole frames, at least one for any positive time", () => {
  assert.equal(frames(300, HZ60), 18); // the study's 300 ms pie at 60 Hz
  assert.equal(frames(1000, HZ60), 60);
  assert.equal(frames(300, 1000 / 144), 43); // 43.2 frames at 144 Hz
  assert.equal(frames(1, HZ60), 1);
  assert.equal(frames(0, HZ60), 0);
  assert.equal(frames(-5, HZ60), 0);
});

test("medianInterval: the refresh is the median frame interval, one late frame aside", () => {
  const times = [0];
  for (let i = 1; i <= 120; i++) times.push(times[i - 1] + (i === 50 ? 3 * HZ60 : HZ60));
  assert.ok(Math.abs(medianInterval(times) - HZ60) < 1e-9);
  assert.equal(medianInterval([0, 10, 30, 40]), 10); // intervals 10, 20, 10
});

test("pieDiameterPx: 5.7° at 570 mm and 0.25 mm per pixel", () => {
  const d = pieDiameterPx({ pie_diameter_deg: 5.7, viewing_distance_mm: 570, pixel_pitch_mm: 0.25 });
  // 2 · 570 mm · tan(2.85°) / 0.25 mm = 227.01 px
  assert.ok(Math.abs(d - 2 * 570 * Math.tan(2.85 * Math.PI / 180) / 0.25) < 1e-9);
  assert.ok(Math.abs(d - 227.01) < 0.01, String(d));
});

test("pieceAt: left, top and right pieces around 210°, 90° and 330°, background between and outside", () => {
  const at = (deg, radius = 50) => pieceAt(radius * Math.cos(deg * Math.PI / 180), radius * Math.sin(deg * Math.PI / 180), 100, 2);
  assert.equal(at(210), 0);
  assert.equal(at(90), 1);
  assert.equal(at(330), 2);
  // Either side of a boundary, beyond the gap (50 px · sin 5° = 4.4 px > 2).
  assert.equal(at(145), 1);
  assert.equal(at(155), 0);
  assert.equal(at(265), 0);
  assert.equal(at(275), 2);
  assert.equal(at(25), 2);
  assert.equal(at(35), 1);
  // On a boundary (30°, 150°, 270°), within the gap: background.
  assert.equal(at(150), -1);
  assert.equal(at(270), -1);
  assert.equal(at(30), -1);
  // The opposite side of a boundary line through the centre is not a gap.
  assert.equal(at(90 + 180 - 60), 0); // 210°: the ray opposite 30°
  assert.equal(pieceAt(0, 101, 100, 2), -1); // outside the pie
});

test("ditherResolution: a piece of the study's pie over 18 frames resolves about 1/230 of a code", () => {
  const { step, bits } = ditherResolution(227.01, 18);
  // 13 490 pixels per piece × 18 frames; the step 3 · √2 · 0.5 / √n
  const n = Math.PI * (227.01 / 2) ** 2 / 3 * 18;
  assert.ok(Math.abs(step - 3 * Math.SQRT2 * 0.5 / Math.sqrt(n)) < 1e-15);
  assert.ok(Math.abs(step - 0.00430) < 0.00001, String(step));
  assert.ok(Math.abs(bits - 15.86) < 0.01, String(bits));
  // Four times the frames: half the step, one more bit.
  assert.ok(Math.abs(ditherResolution(227.01, 72).bits - bits - 1) < 1e-12);
});

test("checkProgress: the time left only once a patch is measured, at this check's own pace", () => {
  assert.equal(checkProgress(0, 9, 0, 5000), "patch 1 of 9");
  assert.equal(checkProgress(1, 9, 0, 5000), "patch 2 of 9 · about 40 s left at the pace of the 1 measured");
  assert.equal(checkProgress(2, 9, 0, 20000), "patch 3 of 9 · about 70 s left at the pace of the 2 measured");
});

// Runs a clock of `fixation` + `stimulus` frames over callback times `times`.
function run(fixation, stimulus, times) {
  const clock = new TrialClock(fixation, stimulus, HZ60);
  return { clock, frames: times.map((t) => clock.tick(t)) };
}
const steady = (n, from = 1000) => Array.from({ length: n }, (_, i) => from + i * HZ60);

test("TrialClock: the cross for the fixation frames, the pie for the stimulus frames, then the cross", () => {
  const { clock, frames: f } = run(3, 2, steady(8));
  assert.deepEqual(f.map((x) => x.pie), [false, false, false, true, true, false, false, false]);
  assert.deepEqual(f.map((x) => x.changed), [true, false, false, true, false, true, false, false]);
  assert.deepEqual(f.map((x) => x.firstPie), [false, false, false, true, false, false, false, false]);
  // The onset is the callback after the pie's first draw: that frame reached the screen.
  assert.deepEqual(f.map((x) => x.onset), [false, false, false, false, true, false, false, false]);
  assert.equal(clock.onset, 1000 + 4 * HZ60);
  assert.equal(clock.shown, 2);
  assert.equal(clock.dropped, 0);
  assert.equal(clock.intervals.length, 7);
  assert.ok(clock.intervals.every((d) => Math.abs(d - HZ60) < 0.001));
});

test("TrialClock: a key before the pie reached the screen does not answer; the reaction time runs from the onset", () => {
  const clock = new TrialClock(3, 2, HZ60);
  const times = steady(6);
  for (const t of times.slice(0, 4)) clock.tick(t);
  assert.equal(clock.accepts(times[3] + 1), false); // the pie drawn, not yet on the screen
  clock.tick(times[4]);
  assert.equal(clock.accepts(times[4]), false); // at the onset itself: no reaction time of 0
  assert.equal(clock.accepts(times[4] + 250), true);
  assert.equal(clock.over, false); // the pie's frames are not all shown yet
  clock.tick(times[5]);
  assert.equal(clock.over, true);
  const r = clock.result(2, times[4] + 412.5);
  assert.equal(r.response, 2);
  assert.ok(Math.abs(r.reaction_ms - 412.5) < 1e-9);
  assert.equal(r.stimulus_frames, 2);
  assert.equal(r.dropped_frames, 0);
  assert.equal(r.dropped_in_stimulus, false);
  assert.equal(r.frame_intervals_ms.length, 5);
});

test("TrialClock: an interval over 1.5 frames is dropped, and in the stimulus when the frame before showed the pie", () => {
  assert.equal(DROPPED, 1.5);
  // Late during the cross: dropped, not in the stimulus.
  const t1 = steady(8);
  for (let i = 2; i < 8; i++) t1[i] += 1.6 * HZ60; // frame 2 comes 2.6 frames after frame 1
  const a = run(3, 2, t1).clock;
  assert.equal(a.dropped, 1);
  assert.equal(a.droppedInStimulus, false);
  // Exactly 1.5 frames is not dropped.
  const t2 = steady(8);
  for (let i = 2; i < 8; i++) t2[i] += 0.5 * HZ60;
  assert.equal(run(3, 2, t2).clock.dropped, 0);
  // Late after the pie's first frame: dropped in the stimulus.
  const t3 = steady(8);
  for (let i = 4; i < 8; i++) t3[i] += 2 * HZ60;
  const c = run(3, 2, t3).clock;
  assert.equal(c.dropped, 1);
  assert.equal(c.droppedInStimulus, true);
  assert.ok(Math.abs(c.intervals[3] - 3 * HZ60) < 0.001);
});
