"""Measures through a simulated Konica Minolta CS-2000 with colour-specio's
own `CS2000` class (PyPI `colour-specio` 0.4.1, in the Python 3.12 venv
`tests/setup.sh` makes under `target/py312`), for tests/instrument/cs2000.rs.

    specio_client.py PORT TRUTH.csv

TRUTH.csv is the spectral radiance the simulator is aimed at (`nm,radiance`,
W/(sr·m²·nm), 1 nm). Prints one JSON object: what the client read (model,
serial, speed and sync modes, its XYZ and x, y computed by colour-science
from the spectrum it fetched, exposure) beside the truth computed here by
colour-science from the CSV, independently of lightbooth. The Rust test
makes the assertions; this script only reports (and exits non-zero with a
message when the client itself fails).
"""

import csv
import json
import sys

import colour
from specio.device_implementations.konica_minolta import CS2000


def truth_xyz(path):
    with open(path, newline="") as f:
        rows = [r for r in csv.reader(f)][1:]
    data = {int(float(r[0])): float(r[1]) for r in rows if r}
    sd = colour.SpectralDistribution(data)
    return colour.sd_to_XYZ(sd, k=683, method="ASTM E308")


def main():
    port, truth_csv = sys.argv[1:3]
    device = CS2000(port)
    speed = device.speedmode
    sync = device.syncmode
    m = device.measure(repetitions=2)
    xyz = [float(v) for v in m.XYZ]
    truth = [float(v) for v in truth_xyz(truth_csv)]
    spd = m.spd
    report = {
        "model": device.model,
        "serial": device.serial_number,
        "speed_mode": speed.mode.name,
        "nd_mode": speed.nd_mode.name,
        "sync_mode": sync.mode.name,
        "XYZ": xyz,
        "xy": [float(v) for v in m.xy],
        "exposure_s": float(m.exposure),
        "spectrum_points": len(spd.values),
        "spectrum_first_nm": float(spd.wavelengths[0]),
        "spectrum_last_nm": float(spd.wavelengths[-1]),
        "truth_XYZ": truth,
        "truth_xy": [truth[0] / sum(truth), truth[1] / sum(truth)],
    }
    print(json.dumps(report))


if __name__ == "__main__":
    main()
