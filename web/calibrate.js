// Display calibration: shows each colour of the plan full-screen, measures it
// through the ordinary measurement API (with --mock, first tells the
// simulated display what is shown), then has the daemon fit and store the
// profile, and shows it with its charts. `#profile=ID` shows a stored one.
import { $, api, duration, el, notice, startPage, token } from "./shared.js";
import { holdShowMeasure } from "./measure.js";
import { showNavigation } from "./nav.js";

const css = (d) => `rgb(${d.map((v) => Math.round(v * 255)).join(",")})`;

// The calibration under way: its hold on the instrument (no one else
// measures or changes the display until it ends), its measurement, whether
// Cancel was pressed (web/measure.js's holdShowMeasure keeps it).
const run = { hold: null, measurementId: null, cancelled: false };

async function calibrate() {
  notice("");
  $("start").disabled = true;
  try {
    const steps = Number($("steps").value), samples = Number($("samples").value);
    const plan = await api(`/api/display-profiles/plan?steps=${steps}`);
    const name = $("name").value;
    // Each patch full-screen, told to the simulated display with --mock (a
    // daemon with a real instrument answers 404 there), and measured.
    const { measured, cancelled } = await holdShowMeasure(api, {
      purpose: `display calibration “${name}”`,
      patches: plan.patches,
      samples,
      run,
      onHeld: () => {
        document.body.classList.add("calibrating");
        if (document.documentElement.requestFullscreen) document.documentElement.requestFullscreen().catch(() => {});
        $("progress").max = plan.patches.length;
        $("cancel").hidden = false;
      },
      // Time left: the patches still to measure at the pace of those measured.
      progress: (i, total, began) => {
        const p = plan.patches[i];
        const left = i ? ` · about ${duration(((Date.now() - began) / 1000 / i) * (total - i))} left` : "";
        $("status").textContent = `${i + 1}/${total}: ${p.label} (${p.purpose})${left}`;
        $("progress").value = i;
      },
      show: (p) => {
        $("patch").style.background = css(p.drive);
        return { display: { drive: p.drive } };
      },
      note: (p, i) => `display calibration “${name}”: patch ${i + 1} of ${plan.patches.length}, ${p.label}`,
    });
    $("progress").value = measured.length;
    $("cancel").hidden = true;
    const shown = measured.map(({ patch, measurement }) => ({ drive: patch.drive, measurement_id: measurement.id }));
    if (cancelled) {
      document.body.classList.remove("calibrating");
      if (document.fullscreenElement) document.exitFullscreen().catch(() => {});
      const ids = shown.map((x) => x.measurement_id);
      $("status").textContent = `cancelled after ${shown.length} of ${plan.patches.length} patches: no profile was fitted. ` +
        (ids.length ? `The ${ids.length} complete measurements are kept (ids ${ids[0]}–${ids[ids.length - 1]}, ` +
          "notes “display calibration …”); the one under way keeps its samples, marked partial." : "Nothing was measured.");
      return;
    }
    $("status").textContent = "fitting the profile…";
    const row = await api("/api/display-profiles", {
      method: "POST",
      body: JSON.stringify({ name, patches: shown }),
    });
    document.body.classList.remove("calibrating");
    if (document.fullscreenElement) document.exitFullscreen().catch(() => {});
    $("status").textContent = row.state === "failed"
      ? `profile ${row.id} stored as FAILED, and cannot be chosen for an experiment: ${row.failures.join("; ")}. Calibrate again.`
      : `profile ${row.id} stored`;
    showStoredProfiles();
    history.replaceState(null, "", `#profile=${row.id}`);
    showProfile(row);
  } catch (e) {
    document.body.classList.remove("calibrating");
    notice(e.message + (token() ? "" : " (open the URL the daemon printed, with #token=…, to allow measurements)"));
    $("status").textContent = "stopped";
  } finally {
    $("start").disabled = false;
    $("cancel").hidden = true;
  }
}

const f = (v, d = 4) => Number(v).toFixed(d);

// A table of a header row and rows of cells, every cell text.
function table(headers, rows) {
  const t = el("table");
  const head = t.createTHead().insertRow();
  for (const h of headers) head.appendChild(el("th", h));
  const body = t.createTBody();
  for (const cells of rows) {
    const tr = body.insertRow();
    cells.forEach((c, i) => tr.appendChild(el(i === 0 && cells.header ? "th" : "td", c)));
  }
  return t;
}

function showProfile(row) {
  const p = row.profile;
  const xyz = (v) => { const s = v[0] + v[1] + v[2]; return [v[0] / s, v[1] / s]; };
  const sec = $("profile");
  sec.hidden = false;
  $("controls").hidden = true;
  const primaryRows = ["red", "green", "blue"].map((n, c) => {
    const t = p.transfer[c];
    return Object.assign([n, f(t.gamma, 3), f(t.rms_residual, 4)], { header: true });
  });
  const ids = p.measurement_ids;
  const facts = el("p");
  let validationHead;
  let validation;
  if (p.luminance_additivity) {
    // A luminance meter's profile: γ per channel and luminances, no colour.
    const a = p.luminance_additivity;
    facts.append(el("strong", "Measured with a luminance meter: γ per channel only.", { id: "measured-as" }),
      " The primaries' colours are unknown, so this profile cannot turn a colour into codes and cannot be chosen " +
      `for an experiment (calibrate with a colorimeter or a spectroradiometer for that). White: Y ${f(a.white_cd_m2, 2)} cd/m². ` +
      "Additivity (white's luminance against black + R + G + B): ",
    el("strong", `${f(a.relative_difference * 100, 2)} %`, { id: "additivity" }),
    `. Fitted to ${ids.length} measurements (ids ${ids[0]}–${ids[ids.length - 1]}). Transfer model: t = v`,
    el("sup", "γ"), " over the black level, from luminance.");
    validationHead = ["drive (r, g, b)", "luminance predicted vs measured (%)", "measurement"];
    validation = (p.luminance_validation || []).map((v) =>
      [v.drive.map((d) => f(d, 3)).join(", "), f(v.relative_difference * 100, 2), v.measurement_id ?? "–"]);
  } else {
    const w = p.additivity.white_xyz;
    const measuredAs = p.black_xyz
      ? `Measured as XYZ by a colorimeter, in its ${p.observer} observer; γ from luminance.`
      : "Measured as spectra by a spectroradiometer.";
    facts.append(el("strong", measuredAs, { id: "measured-as" }), " Observer: ", el("strong", p.observer),
      ` (every XYZ and ΔE00 here). White: Y ${f(w[1], 2)} cd/m², ` +
      `x ${f(xyz(w)[0])}, y ${f(xyz(w)[1])}. Additivity (white against black + R + G + B): `,
    el("strong", `ΔE00 ${f(p.additivity.delta_e00, 3)}`, { id: "additivity" }),
    `. Fitted to ${ids.length} measurements (ids ${ids[0]}–${ids[ids.length - 1]}). Transfer model: t = v`,
    el("sup", "γ"), " over the black level.");
    validationHead = ["drive (r, g, b)", "ΔE00 predicted vs measured", "measurement"];
    validation = (p.validation || []).map((v) =>
      [v.drive.map((d) => f(d, 3)).join(", "), f(v.delta_e00, 3), v.measurement_id ?? "–"]);
  }
  // The charts at the size the scene pages give theirs: a grid of figures,
  // a colorimeter's primaries (an x,y diagram of two panels) a whole row.
  const charts = el("div", undefined, { className: "charts", id: "profile-charts" });
  for (const chart of ["primaries", "transfer", "additivity"]) {
    const fig = el("figure");
    if (chart === "primaries" && p.black_xyz && !p.luminance_additivity) fig.className = "wide";
    fig.appendChild(el("img", undefined, { alt: chart, src: `/api/display-profiles/${row.id}/${chart}.svg` }));
    charts.appendChild(fig);
  }
  const links = el("p");
  links.append(el("a", "calibrate again", { href: "/calibrate" }), " · ", el("a", "dashboard", { href: "/" }));
  // A profile over its stated limits is shown as failed, above everything
  // else, with what failed (the daemon's words).
  const verdict = row.state === "failed"
    ? el("p", `FAILED, and cannot be chosen for an experiment: ${row.failures.join("; ")}. Calibrate again.`,
      { className: "notice", id: "profile-state" })
    : el("p", `Passed its checks (fit residual and validation ${p.luminance_additivity ? "luminance" : "ΔE00"} ` +
      "within their stated limits).", { id: "profile-state" });
  sec.replaceChildren(el("h1", `Display profile ${row.id}: ${row.name}`), verdict, facts,
    table(["channel", "γ", "RMS residual"], primaryRows), charts, el("h2", "Validation colours"),
    table(validationHead, validation), links);
}

// The newest stored profiles, each a link to its page (#profile=ID), so
// that this page is not only a white screen to someone who opens it to look.
async function showStoredProfiles() {
  const profiles = await api("/api/display-profiles").catch(() => []);
  const box = $("stored-profiles");
  box.textContent = "";
  if (!profiles.length) return;
  box.append("stored profiles: ");
  const newest = [...profiles].sort((a, b) => b.created_at - a.created_at).slice(0, 5);
  newest.forEach((p, i) => {
    if (i) box.append(" · ");
    const a = document.createElement("a");
    a.href = `#profile=${p.id}`;
    a.textContent = `${p.id}: ${p.name} (${new Date(p.created_at * 1000).toLocaleString()})` +
      (p.state === "failed" ? " FAILED" : "");
    a.addEventListener("click", async (ev) => {
      ev.preventDefault();
      history.replaceState(null, "", `#profile=${p.id}`);
      showProfile(await api(`/api/display-profiles/${p.id}`));
    });
    box.appendChild(a);
  });
  if (profiles.length > newest.length) box.append(` · and ${profiles.length - newest.length} older`);
  box.hidden = false;
}

(async function init() {
  const credential = startPage();
  showNavigation();
  await credential;
  $("start").addEventListener("click", calibrate);
  // Cancel: stops the measurement under way and fits nothing; what was measured stays stored.
  $("cancel").addEventListener("click", async () => {
    run.cancelled = true;
    $("cancel").disabled = true;
    if (run.measurementId) {
      await api(`/api/measurements/${run.measurementId}/cancel`, { method: "POST", body: "{}" }).catch(() => {});
    }
    $("cancel").disabled = false;
  });
  showStoredProfiles();
  // The words name this booth's instrument, whichever model it is.
  api("/api/health").then((h) => { if (h.instrument_model) $("instrument-model").textContent = h.instrument_model; })
    .catch(() => {});
  const m = location.hash.match(/profile=(\d+)/);
  if (m) {
    try {
      showProfile(await api(`/api/display-profiles/${m[1]}`));
    } catch (e) {
      notice(e.message);
    }
  }
})();
