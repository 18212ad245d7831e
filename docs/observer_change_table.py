"""Writes the book's observer-change table (docs/src/observer-change-table.md)
from five studies of the booth scenes, one per observer.

Each study measures all 25 targets with the simulated PR-650 and compares
every coding with those measurements (8 seeds), as the book's "Reproducing
the study's table" does, in one observer:

    for o in judd-vos-1978 cie-1931 cie-1964-10 cie-2015-2 cie-2015-10; do
      lightbooth study scenes/{white,red,green,blue,cylinder}.toml --measure-simulated \\
          --against measurements --db sqlite:///tmp/obs-$o.sqlite --observer $o --json > /tmp/obs/$o.json
    done
    python3 docs/observer_change_table.py /tmp/obs > docs/src/observer-change-table.md
"""
import json
import sys
from pathlib import Path

OBSERVERS = [
    ("judd-vos-1978", "Judd–Vos 1978 2°"),
    ("cie-1931", "CIE 1931 2°"),
    ("cie-1964-10", "CIE 1964 10°"),
    ("cie-2015-2", "CIE 2015 2°"),
    ("cie-2015-10", "CIE 2015 10°"),
]

folder = Path(sys.argv[1])
studies = {o: json.loads((folder / f"{o}.json").read_text()) for o, _ in OBSERVERS}
for o, s in studies.items():
    assert s["observer"] == o, f"{o}.json is a study in {s['observer']}"
first = studies[OBSERVERS[0][0]]
scenes = [s["scene"] for s in first["scenes"]]
codings = [c["coding"] for c in first["scenes"][0]["codings"]]


def figure(o, scene, coding, key):
    s = next(s for s in studies[o]["scenes"] if s["scene"] == scene)
    c = next(c for c in s["codings"] if c["coding"] == coding)
    return c[key]["mean"]


def table(key, label, digits):
    head = "| scene | coding | " + " | ".join(name for _, name in OBSERVERS) + " | largest change |"
    rows = [head, "|" + "---|" * (len(OBSERVERS) + 3)]
    for scene in scenes:
        for coding in codings:
            values = [figure(o, scene, coding, key) for o, _ in OBSERVERS]
            change = max(values) - min(values)
            cells = " | ".join(f"{v:.{digits}f}" for v in values)
            rows.append(f"| {scene.upper()} | {coding} | {cells} | {change:.{digits}f} |")
    return f"**{label}** (mean over the scene's targets, mean over 8 seeds)\n\n" + "\n".join(rows) + "\n"


print(table("mean_dE00", "Mean ΔE00", 3))
print(table("rms_rel", "rms_rel of luminance", 4))
print(
    f"Each column is one study of the five booth scenes in that observer (renders, simulated PR-650 "
    f"measurements and every ΔE in it), {first['options'].get('seeds', 8)} seeds each. Written by "
    "`docs/observer_change_table.py`."
)
