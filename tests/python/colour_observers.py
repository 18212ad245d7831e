"""Prints colour-science's tables of the CIE observers and the Stockman &
Sharpe cone fundamentals as JSON, for lightbooth's test that its embedded
copies agree with this independent copy (tests/cli/cli_colorimetry.rs).

Run with the colour-specio venv's Python (target/py312), which has colour-science.
"""
import json
import warnings

warnings.filterwarnings("ignore")
import colour  # noqa: E402

NAMES = {
    "cie-1931": "CIE 1931 2 Degree Standard Observer",
    "cie-1964-10": "CIE 1964 10 Degree Standard Observer",
    "cie-2015-2": "CIE 2015 2 Degree Standard Observer",
    "cie-2015-10": "CIE 2015 10 Degree Standard Observer",
    "stockman-sharpe-2": "Stockman & Sharpe 2 Degree Cone Fundamentals",
    "stockman-sharpe-10": "Stockman & Sharpe 10 Degree Cone Fundamentals",
}
out = {"colour_version": colour.__version__}
for key, name in NAMES.items():
    table = colour.MSDS_CMFS[name]
    out[key] = {
        "wavelength_nm": [float(w) for w in table.wavelengths],
        # CVRL leaves the 10° s̄ blank above 615 nm; colour-science reads NaN: null here.
        "values": [[None if v != v else float(v) for v in row] for row in table.values],
    }
print(json.dumps(out))
