"""Measures through a simulated Photo Research instrument with PsychoPy's own
client classes (PyPI `psychopy-photoresearch`), for tests/instrument/psychopy_clients.rs.

    psychopy_client.py PR655|PR650 PORT TRUTH.csv CMF.csv

TRUTH.csv is the spectral radiance the simulator is aimed at (`nm,radiance`,
W/(sr·m²·nm), 1 nm); CMF.csv the CIE 1931 2° colour-matching functions
(`nm,xbar,ybar,zbar`). Prints one JSON object: what the client read
(model, serial, luminance, tristimulus, spectrum summary) beside the truth
computed here, independently of lightbooth: Y = 683 lm/W · Σ ȳ(λ) L(λ) Δλ.
The Rust test makes the assertions; this script only reports (and exits
non-zero with a message when the client itself fails).
"""

import csv
import json
import sys
import time

# PsychoPy's PR650.measure() still calls time.clock(), removed in Python 3.8;
# the stand-in is the clock Python documents as its replacement. It is only
# used to time the call (its value is never read).
if not hasattr(time, "clock"):
    time.clock = time.perf_counter

from psychopy_photoresearch import PR650, PR655  # noqa: E402

KM_LM_PER_W = 683.0
# 1 fL = 1/π cd/ft² = 3.426259 cd/m² (the PR-655/670 reports Y in fL after
# SU0, its power-on setting, and PsychoPy's PR655 class never sends SU1).
CD_M2_PER_FL = 3.426259


def read_columns(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], [r for r in rows[1:] if r]
    return header, [[float(v) for v in r] for r in body]


def truth_at(truth, nm):
    """Linear interpolation of the 1 nm truth at `nm`."""
    lo = int(nm)
    if lo + 1 not in truth:
        return truth[lo]
    t = nm - lo
    return truth[lo] * (1 - t) + truth[lo + 1] * t


def pearson(a, b):
    n = len(a)
    ma, mb = sum(a) / n, sum(b) / n
    cov = sum((x - ma) * (y - mb) for x, y in zip(a, b))
    va = sum((x - ma) ** 2 for x in a)
    vb = sum((y - mb) ** 2 for y in b)
    return cov / (va * vb) ** 0.5


def main():
    kind, port, truth_csv, cmf_csv = sys.argv[1:5]
    _, truth_rows = read_columns(truth_csv)
    truth = {int(round(nm)): v for nm, v in truth_rows}
    _, cmf_rows = read_columns(cmf_csv)
    y_truth = KM_LM_PER_W * sum(ybar * truth.get(int(round(nm)), 0.0) for nm, _, ybar, _ in cmf_rows)

    out = {"class": kind, "truth_Y_cd_m2": y_truth}
    if kind == "PR655":
        phot = PR655(port)
        if not phot.OK or not phot.type:
            sys.exit(f"PsychoPy's PR655 could not connect to {port} (OK={phot.OK}, type={phot.type!r})")
        out["model"] = phot.type
        out["serial"] = phot.getDeviceSN()
        phot.measure()
        units = phot.getLastUV()[1].strip()
        scale = CD_M2_PER_FL if units == "0" else 1.0
        out["units_code"] = units
        out["Y_cd_m2"] = phot.getLastLum() * scale
        out["XYZ_cd_m2"] = [v * scale for v in phot.lastTristim]
        out["xy"] = phot.lastXY
        out["cct_K"] = phot.lastColorTemp
        nm, power = phot.getLastSpectrum(parse=True)
        # getLum() measures again and returns that measurement's luminance.
        out["second_Y_cd_m2"] = phot.getLum() * scale
        phot.endRemoteMode()
    elif kind == "PR650":
        phot = PR650(port)
        if not phot.OK:
            sys.exit(f"PsychoPy's PR650 could not connect to {port}")
        out["model"] = phot.type
        out["serial"] = phot.sendMessage("d110").strip().split(",")[-1]
        phot.measure()
        # PR650's setup command ('s01,,,,,,01,1') ends in units 1, metric:
        # Y in cd/m² (D2's second field is luminance/illuminance, not units).
        scale = 1.0
        out["Y_cd_m2"] = phot.getLastLum()
        nm, power = phot.getLastSpectrum(parse=True)
        nm = [float(v) for v in nm]
        power = [float(v) for v in power]
        out["second_Y_cd_m2"] = phot.getLum() * scale
    else:
        sys.exit(f"unknown client class {kind!r}: PR655 or PR650")

    nm, power = [float(v) for v in nm], [float(v) for v in power]
    expected = [truth_at(truth, w) for w in nm]
    out["spectrum_points"] = len(nm)
    out["spectrum_first_nm"] = nm[0] if nm else None
    out["spectrum_last_nm"] = nm[-1] if nm else None
    out["spectrum_step_nm"] = (nm[1] - nm[0]) if len(nm) > 1 else None
    out["spectrum_correlation"] = pearson(power, expected) if len(nm) > 2 else None
    # Per-nm radiance: the ratio of the reported to the true radiance is 1.
    out["spectrum_scale"] = sum(power) / sum(expected) if nm else None
    print(json.dumps(out))


if __name__ == "__main__":
    main()
