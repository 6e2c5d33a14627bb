"""The three examples' plans, recorded by meaning: what a change to the code must not alter unnoticed.

`tests/data/golden_examples.json` holds, for each example in `missions/`, what `aerosurvey plan`
planned, read back from its files as their readers would: the mission items of every
`.waypoints` file (command, frame, parameters, position, altitude), the lines (photos, lead-in,
end), the photo count per sortie, the derived values and estimates of the manifest, the rules'
verdicts and the feature counts of plan.geojson. The test compares them within the tolerances
below, item by item, and names what differs; bytes, number formats and key order may change.

A change that alters a plan on purpose re-records the file and says why in its commit:

    .venv/bin/python tests/golden.py --record
"""

from __future__ import annotations

import json
import math
import sys
from collections import Counter
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
RECORDING = ROOT / "tests" / "data" / "golden_examples.json"
EXAMPLES = ("forest-dem", "kubad-abad-fixed-wing", "obratan-72ha")

#: tolerances: degrees of latitude/longitude (~1 cm), metres of altitude, relative for other numbers
DEG = 1e-7
ALT_M = 0.01
REL = 1e-4
ABS = 1e-6


def read_waypoints(path: Path) -> list[list[float]]:
    """A QGC WPL 110 file as ArduPilot's loader reads it: one item per row, its 12 tab-separated
    fields as numbers (index, current, frame, command, p1-p4, lat, lon, alt, autocontinue)."""
    lines = path.read_text(encoding="utf-8").splitlines()
    assert lines[0].startswith("QGC WPL 110"), f"{path.name}: not a QGC WPL 110 file"
    return [[float(v) for v in row.split("\t")] for row in lines[1:] if row.strip()]


def read_plan(folder: Path) -> dict[str, Any]:
    """What the plan in `folder` says, by meaning."""
    m = json.loads((folder / "manifest.json").read_text(encoding="utf-8"))
    geo = json.loads((folder / "plan.geojson").read_text(encoding="utf-8"))
    return {
        "derived": {k: v for k, v in m["derived"].items() if isinstance(v, int | float) and not isinstance(v, bool)},
        "estimates": m["estimates"],
        "lines": [{"id": ln["id"], "photos": ln["photos"], "lead_in": ln["lead_in"], "end": ln["end"]} for ln in m["lines"]],
        "stations": len(m["stations"]),
        "sorties": [{"id": s["id"], "photos": s["photos"], "mission_items": s["mission_items"]} for s in m.get("sorties", [])],
        "rules": sorted(f"{r['profile']}/{r['rule']}: {r['status']}" for r in m.get("rules", [])),
        "features": dict(sorted(Counter(f["properties"].get("role") for f in geo["features"]).items())),
        "waypoints": {p.name: read_waypoints(p) for p in sorted(folder.glob("*.waypoints"))},
    }


def _close(a: float, b: float, tol_abs: float, rel: float = REL) -> bool:
    if a is None or b is None:
        return a is b
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return abs(a - b) <= max(tol_abs, rel * max(abs(a), abs(b)))


def differences(got: dict[str, Any], want: dict[str, Any]) -> list[str]:
    """What differs between two `read_plan` results, each naming the file, item and field."""
    out: list[str] = []
    for key in ("stations", "rules", "features"):
        if got[key] != want[key]:
            out.append(f"{key}: {got[key]} != recorded {want[key]}")
    for key in ("derived", "estimates"):
        for k in sorted(set(got[key]) | set(want[key])):
            a, b = got[key].get(k), want[key].get(k)
            if not (isinstance(a, int | float) and isinstance(b, int | float) and _close(a, b, ABS)) and a != b:
                out.append(f"manifest {key}.{k}: {a} != recorded {b}")
    if [s["id"] for s in got["sorties"]] != [s["id"] for s in want["sorties"]] or got["sorties"] != want["sorties"]:
        out.append(f"sorties: {got['sorties']} != recorded {want['sorties']}")
    if [ln["id"] for ln in got["lines"]] != [ln["id"] for ln in want["lines"]]:
        out.append(f"line ids: {[ln['id'] for ln in got['lines']][:5]}… != recorded {[ln['id'] for ln in want['lines']][:5]}…")
    else:
        for a, b in zip(got["lines"], want["lines"]):
            ends = zip(a["lead_in"] + a["end"], b["lead_in"] + b["end"])
            if a["photos"] != b["photos"] or not all(_close(x, y, DEG, 0) for x, y in ends):
                out.append(f"line {a['id']}: {a} != recorded {b}")
    if sorted(got["waypoints"]) != sorted(want["waypoints"]):
        out.append(f"waypoint files: {sorted(got['waypoints'])} != recorded {sorted(want['waypoints'])}")
    for name in sorted(set(got["waypoints"]) & set(want["waypoints"])):
        a_items, b_items = got["waypoints"][name], want["waypoints"][name]
        if len(a_items) != len(b_items):
            out.append(f"{name}: {len(a_items)} items != recorded {len(b_items)}")
            continue
        for a, b in zip(a_items, b_items):
            same = (a[:4] == b[:4] and a[11] == b[11] and all(_close(x, y, ABS) for x, y in zip(a[4:8], b[4:8]))
                    and _close(a[8], b[8], DEG, 0) and _close(a[9], b[9], DEG, 0) and _close(a[10], b[10], ALT_M, 0))
            if not same:
                out.append(f"{name} item {int(a[0])}: {a} != recorded {b}")
    return out


def plan_example(example: str, out: Path) -> Path:
    from click.testing import CliRunner

    from aerosurvey.cli import main

    res = CliRunner().invoke(main, ["plan", str(ROOT / "missions" / f"{example}.toml"), "-o", str(out)])
    assert res.exit_code == 0, res.output
    return out


def record() -> None:
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        doc = {ex: read_plan(plan_example(ex, Path(tmp) / ex)) for ex in EXAMPLES}
    RECORDING.write_text(json.dumps(doc, separators=(",", ":")) + "\n", encoding="utf-8")
    print(f"recorded {', '.join(EXAMPLES)} into {RECORDING.relative_to(ROOT)} ({RECORDING.stat().st_size} bytes)")


if __name__ == "__main__":
    if sys.argv[1:] != ["--record"]:
        sys.exit("usage: python tests/golden.py --record")
    record()
