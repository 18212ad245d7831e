"""Measures through a simulated Konica Minolta LS-100 or CS-100A with
PsychoPy's own client classes (PyPI `psychopy-minolta` 0.0.2,
`psychopy_minolta.minolta.LS100` and `.CS100A`), for tests/instrument/ls100.rs.

    minolta_client.py LS100|CS100A PORT TRUTH.csv CMF.csv

TRUTH.csv is the spectral radiance the simulator is aimed at (`nm,radiance`,
W/(sr·m²·nm), 1 nm); CMF.csv the CIE 1931 2° colour-matching functions
(`nm,xbar,ybar,zbar`). Prints one JSON object: what the client read
(luminance, and x y from the CS-100A) beside the truth computed here,
independently of lightbooth: X, Y, Z = 683 lm/W · Σ x̄ȳz̄(λ) L(λ) Δλ. The
Rust test makes the assertions; this script only reports (and exits non-zero
with a message when the client itself fails).

The pty: the classes set 7 data bits and even parity (minolta.py:137-141,
394-399), which a Linux pseudo-terminal cannot carry: a plain tcsetattr with
CS7 or PARENB fails with EINVAL, and where pyserial's reconfigure gets through
the line silently stays 8N. This script therefore replaces `serial.Serial`,
before the class is imported, with a subclass that asks for 8 data bits and no
parity, keeping the baud rate (4800) and the 2 stop bits, and says so on
stderr; the simulator checks those two. A real USB-serial port would take 7E2
unchanged.
"""

import csv
import json
import sys

import serial


class _PtySerial(serial.Serial):
    """pyserial's Serial, but 8N (same baud and stop bits) where a pty refuses 7E."""

    def _reconfigure_port(self, *args, **kwargs):
        if self._bytesize != serial.EIGHTBITS or self._parity != serial.PARITY_NONE:
            print(f"minolta_client: {self._port} is a pty; {self._bytesize} data bits, parity "
                  f"{self._parity} fall back to 8N (baud {self._baudrate}, stop bits {self._stopbits} kept)",
                  file=sys.stderr)
            self._bytesize = serial.EIGHTBITS
            self._parity = serial.PARITY_NONE
        return super()._reconfigure_port(*args, **kwargs)


serial.Serial = _PtySerial

from psychopy_minolta.minolta import CS100A, LS100  # noqa: E402

KM_LM_PER_W = 683.0


def read_columns(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], [r for r in rows[1:] if r]
    return header, [[float(v) for v in r] for r in body]


def main():
    kind, port, truth_csv, cmf_csv = sys.argv[1:5]
    _, truth_rows = read_columns(truth_csv)
    truth = {int(round(nm)): v for nm, v in truth_rows}
    _, cmf_rows = read_columns(cmf_csv)
    xyz_truth = [
        KM_LM_PER_W * sum(row[i] * truth.get(int(round(row[0])), 0.0) for row in cmf_rows)
        for i in (1, 2, 3)
    ]
    s = sum(xyz_truth)
    out = {
        "class": kind,
        "truth_Y_cd_m2": xyz_truth[1],
        "truth_xy": [xyz_truth[0] / s, xyz_truth[1] / s],
    }
    cls = {"LS100": LS100, "CS100A": CS100A}[kind]
    meter = cls(port, maxAttempts=1)
    if not meter.OK:
        sys.exit(f"PsychoPy's {kind} could not connect to {port}")
    out["line"] = [meter.com.baudrate, meter.com.bytesize, meter.com.parity, meter.com.stopbits]
    out["Y_cd_m2"] = meter.measure()
    out["second_Y_cd_m2"] = meter.getLum()
    if kind == "CS100A":
        out["xy"] = [meter.lastXColor, meter.lastYColor]
    print(json.dumps(out))


if __name__ == "__main__":
    main()
