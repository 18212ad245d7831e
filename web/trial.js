// The arithmetic of an oddity session's timing and geometry (an ES module
// of experiment-run.js): durations in whole frames, the display's refresh,
// dropped frames, one trial's frame clock, the pie's size and pieces, the
// output method's resolution and a display check's progress. Pure: no
// `document`, no WebGL, no clock of its own (times are arguments), so
// tests/web/trial.test.mjs runs it under Node.

/** An interval longer than this many frames is a dropped frame. */
export const DROPPED = 1.5;

/** `ms` as whole frames of `frameMs`: at least one for any positive time. */
export const frames = (ms, frameMs) => (ms <= 0 ? 0 : Math.max(1, Math.round(ms / frameMs)));

/** The median interval between successive `times` (requestAnimationFrame
 * stamps, ms): the display's frame duration. */
export function medianInterval(times) {
  const d = times.slice(1).map((t, i) => t - times[i]).sort((a, b) => a - b);
  return d[Math.floor(d.length / 2)];
}

/** The pie's diameter in pixels: its visual angle at the viewing distance
 * over the pixel pitch (the experiment's presentation). */
export function pieDiameterPx(p) {
  return 2 * p.viewing_distance_mm * Math.tan((p.pie_diameter_deg * Math.PI / 180) / 2) / p.pixel_pitch_mm;
}

/** Which piece of a pie of radius `r` the point (x, y) from its centre (y
 * up) lies in: 0 left, 1 top, 2 right (centred at 210°, 90°, 330°;
 * boundaries at 30°, 150°, 270°), or -1 outside the pie or within `gap`
 * of a boundary (the thin strip of background between pieces). */
export function pieceAt(x, y, r, gap) {
  if (Math.hypot(x, y) > r) return -1;
  const nearBoundary = [30, 150, 270].some((a) => {
    const bx = Math.cos(a * Math.PI / 180), by = Math.sin(a * Math.PI / 180);
    return x * bx + y * by > 0 && Math.abs(x * by - y * bx) < gap;
  });
  if (nearBoundary) return -1;
  const angle = (Math.atan2(y, x) * 180 / Math.PI + 360) % 360;
  return angle >= 30 && angle < 150 ? 1 : angle >= 150 && angle < 270 ? 0 : 2;
}

/** Noisy-bit dithering's resolution for one pie piece (a third of a pie
 * of `diameterPx`) averaged over `stimulusFrames` frames: the step of the
 * mean in 8-bit codes, and the effective bits it amounts to. */
export function ditherResolution(diameterPx, stimulusFrames) {
  const r = diameterPx / 2;
  const n = Math.PI * r * r / 3 * stimulusFrames;
  const step = 3 * Math.SQRT2 * 0.5 / Math.sqrt(n);
  return { step, bits: 8 + Math.log2(1 / step) };
}

/** "patch 3 of 9 · about 40 s left at the pace of the 2 measured": the
 * time left only once a patch has been measured, from this check's own
 * pace (`began` and `now` in ms). */
export function checkProgress(done, total, began, now = Date.now()) {
  if (done === 0) return `patch 1 of ${total}`;
  const perPatch = (now - began) / 1000 / done;
  const left = Math.round(perPatch * (total - done));
  const measured = done === 1 ? "the 1 measured" : `the ${done} measured`;
  return `patch ${done + 1} of ${total} · about ${left} s left at the pace of ${measured}`;
}

/** One trial's frames: the cross for `fixation` frames, the pie for
 * `stimulus` frames, then the cross until a key. `tick(now)` is called in
 * each animation callback (now: its time stamp, ms) and says what to draw;
 * it logs every frame interval, counts an interval over DROPPED frames as
 * dropped (during the pie when the frame before it showed the pie), and
 * takes the pie's onset as the callback after its first draw (when that
 * frame reached the screen). */
export class TrialClock {
  constructor(fixation, stimulus, frameMs) {
    Object.assign(this, { fixation, stimulus, frameMs });
    this.frame = 0;
    this.last = null;
    this.previousPie = false;
    this.pieDrawn = false;
    this.onset = null;
    this.shown = 0;
    this.dropped = 0;
    this.droppedInStimulus = false;
    this.intervals = [];
  }

  /** The frame of the callback at `now`: `pie` (else the cross), whether
   * this callback is the pie's `onset`, whether this is its `firstPie`
   * frame, and whether the phase `changed` (or this is the first frame). */
  tick(now) {
    if (this.last !== null) {
      const dt = now - this.last;
      this.intervals.push(Math.round(dt * 1000) / 1000);
      if (dt > DROPPED * this.frameMs) {
        this.dropped++;
        if (this.previousPie) this.droppedInStimulus = true;
      }
    }
    this.last = now;
    const onset = this.pieDrawn && this.onset === null;
    if (onset) this.onset = now;
    const pie = this.frame >= this.fixation && this.frame < this.fixation + this.stimulus;
    const firstPie = pie && this.shown === 0;
    if (firstPie) this.pieDrawn = true;
    const changed = pie !== this.previousPie || this.frame === 0;
    if (pie) this.shown++;
    this.previousPie = pie;
    this.frame++;
    return { pie, onset, firstPie, changed };
  }

  /** Whether a key at `timeStamp` (ms, the event's own) answers this
   * trial: only after the pie's first frame reached the screen (the daemon
   * refuses a reaction time of 0 or less as no response to the pie). */
  accepts(timeStamp) {
    return this.onset !== null && timeStamp > this.onset;
  }

  /** Whether the pie has been shown whole and its onset is known. */
  get over() {
    return this.frame > this.fixation + this.stimulus && this.onset !== null;
  }

  /** The trial as POST /api/experiment-sessions/{id}/trials takes it, for
   * the answer `key` (0 left, 1 top, 2 right) pressed `at` (ms). */
  result(key, at) {
    return {
      response: key,
      reaction_ms: at - this.onset,
      stimulus_frames: this.shown,
      dropped_frames: this.dropped,
      dropped_in_stimulus: this.droppedInStimulus,
      frame_intervals_ms: this.intervals,
    };
  }
}
