"""Measures through a simulated Colorimetry Research CR-250 or CR-300 with
colour-specio's own `CRSpectrometer` class (PyPI `colour-specio` 0.4.1, in
the Python 3.12 venv `tests/setup.sh` makes under `target/py312`), for
tests/instrument/cr250.rs.

    specio_cr_client.py PORT TRUTH.csv

TRUTH.csv is the spectral radiance the simulator is aimed at (`nm,radiance`,
W/(sr·m²·nm), 1 nm). Prints one JSON object: what the client read (model,
serial, instrument type, speed, its XYZ and x, y computed by colour-science
from the spectrum it fetched, the spectrum's grid, the exposure) beside the
truth computed here by colour-science from the CSV, independently of
lightbooth. The Rust test makes the assertions.
"""

import csv
import json
import sys

import colour
from specio.device_implementations.colorimetry_research import CRSpectrometer


def truth_xyz(path):
    with open(path, newline="") as f:
        rows = [r for r in csv.reader(f)][1:]
    data = {int(float(r[0])): float(r[1]) for r in rows if r}
    return colour.sd_to_XYZ(colour.SpectralDistribution(data), k=683, method="ASTM E308")


def main():
    port, truth_csv = sys.argv[1:3]
    device = CRSpectrometer(port)
    kind = device.instrument_type
    m = device.measure(repetitions=2)
    xyz = [float(v) for v in m.XYZ]
    truth = [float(v) for v in truth_xyz(truth_csv)]
    spd = m.spd
    print(json.dumps({
        "model": device.model,
        "serial": device.serial_number,
        "firmware": device.firmware,
        "instrument_type": kind.name,
        "speed": device.measurement_speed.name,
        "XYZ": xyz,
        "xy": [float(v) for v in m.xy],
        "exposure_s": float(m.exposure),
        "spectrum_points": len(spd.values),
        "spectrum_first_nm": float(spd.wavelengths[0]),
        "spectrum_last_nm": float(spd.wavelengths[-1]),
        "spectrum_step_nm": float(spd.shape.interval),
        "truth_XYZ": truth,
        "truth_xy": [truth[0] / sum(truth), truth[1] / sum(truth)],
    }))


if __name__ == "__main__":
    main()
