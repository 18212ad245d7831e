"""Measures through a simulated CRS ColorCAL MkII with PsychoPy's own client
class (PyPI `psychopy-crs` 0.0.2, `psychopy_crs.colorcal.ColorCAL`), for
tests/instrument/colorcal.rs.

    colorcal_client.py PORT TRUTH.csv CMF.csv

TRUTH.csv is the spectral radiance the simulator is aimed at (`nm,radiance`,
W/(sr·m²·nm), 1 nm); CMF.csv the CIE 1931 2° colour-matching functions
(`nm,xbar,ybar,zbar`). Prints one JSON object: what the client read (its
identification, matrix, X Y Z, x y) beside the truth computed here,
independently of lightbooth: X, Y, Z = 683 lm/W · Σ x̄ȳz̄(λ) L(λ) Δλ. The
Rust test makes the assertions; this script only reports (and exits non-zero
with a message when the client itself fails).

The class is used as published, with one argument chosen: maxAttempts=0.
Under Python 3 its readline never matches its eol (colorcal.py:317 compares
a bytearray with a str), so every read ends on its time-out, and each further
attempt only adds one more time-out of silence (5 s per MES); the bytes on
the wire are the same.
"""

import csv
import json
import sys

from psychopy_crs.colorcal import ColorCAL

KM_LM_PER_W = 683.0


def read_columns(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], [r for r in rows[1:] if r]
    return header, [[float(v) for v in r] for r in body]


def main():
    port, truth_csv, cmf_csv = sys.argv[1:4]
    _, truth_rows = read_columns(truth_csv)
    truth = {int(round(nm)): v for nm, v in truth_rows}
    _, cmf_rows = read_columns(cmf_csv)
    xyz_truth = [
        KM_LM_PER_W * sum(row[i] * truth.get(int(round(row[0])), 0.0) for row in cmf_rows)
        for i in (1, 2, 3)
    ]
    s = sum(xyz_truth)
    out = {
        "truth_XYZ_cd_m2": xyz_truth,
        "truth_xy": [xyz_truth[0] / s, xyz_truth[1] / s],
    }

    cc = ColorCAL(port, maxAttempts=0)
    if not cc.OK or not cc.ok:
        sys.exit(f"PsychoPy's ColorCAL could not connect to {port} (OK={cc.OK}, ok={cc.ok})")
    out["serial"] = cc.serialNum
    out["firmware"] = cc.firm
    out["build"] = cc.firmBuild
    out["needs_zero_calibration"] = cc.getNeedsCalibrateZero()
    out["matrix"] = [[float(v) for v in row] for row in cc.calibMatrix]
    ok, x, y, z = cc.measure()
    if not ok:
        sys.exit(f"PsychoPy's ColorCAL measured, but the unit did not say OK00")
    out["XYZ_cd_m2"] = [float(x), float(y), float(z)]
    out["xy"] = [float(x) / float(x + y + z), float(y) / float(x + y + z)]
    out["second_Y_cd_m2"] = float(cc.getLum())
    print(json.dumps(out))


if __name__ == "__main__":
    main()
