"""Photos per run: the manifest against the exported mission replayed with an independent model of
ArduPilot's trigger (tests/independent_trigger.py), on random plans (seeded), copters and planes.

    python benchmarks/trigger_bench.py                    # 60 plans, ArduPilot's 50 Hz check
    python benchmarks/trigger_bench.py --check-hz 1000    # a check 20 times as often (nearly continuous)
    python benchmarks/trigger_bench.py --long             # 5.8 km runs east-west and north-south at 49 N, 70 N, 60 S
    python benchmarks/trigger_bench.py --anywhere         # the random plans moved to random places (70 S to 70 N)

Prints each plan whose count differs (seed, vehicle, stations, photos flown, the first runs that
differ) and how many plans differ. ArduPilot checks the distance at 50 Hz; a replay that checks
far more often takes a picture nearly every commanded distance, which is half a check step
under the spacing the stations are laid at. Not covered: anything the model leaves out (the
vehicle's speed changes, its lag behind the waypoints, wind).
"""

from __future__ import annotations

import argparse
import json
import math
import random
import sys
import tempfile
from pathlib import Path

from click.testing import CliRunner

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))

import independent_trigger as it  # noqa: E402
from aerosurvey.cli import main as cli  # noqa: E402
from conftest import make_spec, random_polygon, write_geojson  # noqa: E402


def _moved(rings: list, lat0: float, lon0: float) -> list:
    """Rings drawn near 49.4 N 15 E, the same shape (metres east and north) around lat0, lon0."""
    kx0, kx = 111_320.0 * math.cos(math.radians(49.4)), 111_320.0 * math.cos(math.radians(lat0))
    return [[[lon0 + (x - 15.0) * kx0 / kx, lat0 + y - 49.4] for x, y in ring] for ring in rings]


def _spec(seed: int, tmp: Path, anywhere: bool = False) -> Path:
    r = random.Random(seed)
    place = (r.uniform(-70, 70), r.uniform(-179, 179)) if anywhere else (49.4, 15.0)
    vehicle = r.choice(["copter", "plane"])
    size = r.uniform(150, 1000)
    over: dict = {"vehicle": {"type": vehicle, "cruise_speed_ms": r.uniform(6, 14) if vehicle == "copter" else r.uniform(14, 22)},
                  "targets": {"gsd_cm": r.uniform(1.5, 2.9), "forward_overlap": r.uniform(0.6, 0.85),
                              "side_overlap": r.uniform(0.5, 0.8), "images_beyond_boundary": r.choice([0, 0, 1, 2, 8])},
                  "flight": {"cross_hatch": r.random() < 0.3}}
    if r.random() < 0.5:
        over["flight"]["heading"] = r.uniform(0, 180)
    if r.random() < 0.4:  # square exclusion zones
        k_lat, k_lon = 1 / 111_320.0, 1 / (111_320.0 * math.cos(math.radians(49.4)))
        zones = []
        for z in range(r.randint(1, 3)):
            cx, cy, h = r.uniform(-size, size) * 0.6, r.uniform(-size, size) * 0.6, r.uniform(10, size / 5)
            ring = [[15.0 + (cx + dx) * k_lon, 49.4 + (cy + dy) * k_lat] for dx, dy in ((-h, -h), (h, -h), (h, h), (-h, h), (-h, -h))]
            write_geojson(tmp / f"z{z}.geojson", _moved([ring], *place))
            zones.append(f"z{z}.geojson")
        over["area"] = {"exclusions": zones}
    return make_spec(tmp, over, rings=_moved(random_polygon(r.choice(["convex", "concave", "holed"]), seed, size), *place))


LONG_CASES = [(h, v, lat) for lat in (49.4, 70.0, -60.0) for v in ("copter", "plane") for h in (0.0, 90.0)]


def _long_spec(case: int, tmp: Path) -> Path:
    heading, vehicle, lat = LONG_CASES[case]
    # 5.8 km x 1.1 km, near the edge of UTM zone 34
    ring = _moved([[[15.0, 49.4], [15.08, 49.4], [15.08, 49.41], [15.0, 49.41], [15.0, 49.4]]], lat, 23.0)[0]
    return make_spec(tmp, {"vehicle": {"type": vehicle, "cruise_speed_ms": 12.0 if vehicle == "copter" else 18.0},
                           "targets": {"gsd_cm": 2.0, "forward_overlap": 0.8, "side_overlap": 0.6},
                           "flight": {"heading": heading}, "limits": {"max_photos": 500_000}}, area=ring)


def compare(spec: Path, out: Path) -> tuple[int, int, list[tuple[str, int, int]]] | None:
    """(stations, photos flown, runs that differ as (id, planned, flown)); None when no plan is written
    (a plan whose error-severity rule fails exits 1 but is written, and its mission is compared)."""
    res = CliRunner().invoke(cli, ["plan", str(spec), "-o", str(out)])
    if res.exit_code not in (0, 1) or not (out / "manifest.json").exists():
        return None
    m = json.loads((out / "manifest.json").read_text())
    photos = it.replay(out / "mission.waypoints")
    flown = [0] * max(len(m["lines"]), 1 + max((p.block for p in photos), default=-1))
    for p in photos:
        flown[p.block] += 1
    planned = [line["photos"] for line in m["lines"]] + [0] * (len(flown) - len(m["lines"]))
    ids = [line["id"] for line in m["lines"]] + ["(no run)"] * (len(flown) - len(m["lines"]))
    diff = [(i, p, f) for i, p, f in zip(ids, planned, flown) if p != f]
    return len(m["stations"]), len(photos), diff


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plans", type=int, default=60)
    ap.add_argument("--seed", type=int, default=200, help="the first plan's seed (each plan has its own)")
    ap.add_argument("--check-hz", type=float, default=it.UPDATE_HZ, help="the camera's distance checks per second")
    ap.add_argument("--long", action="store_true", help="twelve plans with 5.8 km runs instead of random ones")
    ap.add_argument("--anywhere", action="store_true", help="random plans at random places, not near 49.4 N 15 E")
    a = ap.parse_args()
    it.UPDATE_HZ = a.check_hz
    cases = range(len(LONG_CASES)) if a.long else range(a.seed, a.seed + a.plans)
    differ = planned = 0
    for case in cases:
        with tempfile.TemporaryDirectory() as td:
            spec = _long_spec(case, Path(td)) if a.long else _spec(case, Path(td), a.anywhere)
            got = compare(spec, Path(td) / "out")
        if got is None:
            continue
        planned += 1
        stations, flown, diff = got
        if diff:
            differ += 1
            print(f"plan {case}: {stations} stations, {flown} photos flown; runs that differ (id, planned, flown): {diff[:4]}"
                  + (f" and {len(diff) - 4} more" if len(diff) > 4 else ""))
    print(f"{differ} of {planned} plans differ (checks at {a.check_hz:g} Hz; {len(cases) - planned} of {len(cases)} not written)")


if __name__ == "__main__":
    main()
