"""Plan time and peak memory of long corridors (issue: "a 220 km corridor plans in seconds").

    python benchmarks/corridor_bench.py                       # 22 and 220 km, with and without sorties
    python benchmarks/corridor_bench.py --km 220 --repeat 3

A synthetic pipeline centreline winds from 49.0 N, 15.0 E north-eastwards: a bend every 2 km,
turning by up to ±35° (seeded), so a 220 km line has 110 segments. It is planned by `aerosurvey
plan` in a fresh process (a copter, the a6000 at 2.8 cm GSD, 75/60 % overlap, a 300 m wide
corridor: 3 strips), once without a battery and once with 30 min batteries and a launch point
every 5 km along the line; and once more with the corridor given as its outline (the line buffered
by 150 m, a polygon, no width: its centreline and widths derived, plan/centreline.py), without a
battery. The whole command is timed (reading, planning, every output file)
and its peak memory (max RSS, wait4) read; the fastest of --repeat runs is kept. Printed with
each: photos, strips, sorties and the exit code.

The reference for "in seconds" is the 72 ha area example planned in the same run (`missions/
obratan-72ha.toml`): the corridor's time is also given as a ratio against it.

Not covered: corridors over a DEM (terrain following), with exclusion zones, or planes; the web page.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import random
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SPEC = """[mission]
name = "pipeline-{km}km"

[area]
file = "line.geojson"

[pattern]
kind = "corridor"
width_m = 300

[camera]
model = "sony-a6000-16mm"
trigger = "distance"

[targets]
gsd_cm = 2.8
forward_overlap = 0.75
side_overlap = 0.6
images_beyond_boundary = 2

[vehicle]
type = "copter"
cruise_speed_ms = 12.0

[limits]
max_photos = 1000000
max_flight_hours = 1000
"""
BATTERY = """
[battery]
usable_min = 30
reserve = 0.25
launch_points = {points}
"""


def centreline(km: float, seed: int = 1) -> list[tuple[float, float]]:
    rng = random.Random(seed)
    lon, lat, bearing = 15.0, 49.0, 45.0
    pts = [(lon, lat)]
    for _ in range(int(km / 2.0)):
        bearing += rng.uniform(-35.0, 35.0)
        bearing = min(max(bearing, 0.0), 90.0)  # keep heading north-east
        d = 2000.0
        lat += d * math.cos(math.radians(bearing)) / 111_320.0
        lon += d * math.sin(math.radians(bearing)) / (111_320.0 * math.cos(math.radians(lat)))
        pts.append((lon, lat))
    return pts


def outline(pts: list[tuple[float, float]], half_m: float) -> dict:
    """The corridor's outline: the centreline buffered by `half_m` in a local equirectangular frame
    (metres about its first point), as a GeoJSON Polygon in longitude/latitude."""
    import shapely

    lon0, lat0 = pts[0]
    kx, ky = 111_320.0 * math.cos(math.radians(lat0)), 110_574.0
    line = shapely.LineString([((lo - lon0) * kx, (la - lat0) * ky) for lo, la in pts])
    ring = shapely.get_coordinates(shapely.buffer(line, half_m).exterior)
    return {"type": "Polygon", "coordinates": [[[lon0 + x / kx, lat0 + y / ky] for x, y in ring]]}


def run(cmd: list[str], cwd: Path) -> tuple[float, float, int, str]:
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    _, status, usage = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t0
    err = p.stderr.read() if p.stderr else ""
    return wall, usage.ru_maxrss / 1024.0, os.waitstatus_to_exitcode(status), err.strip().splitlines()[-1] if err.strip() else ""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--km", type=float, nargs="+", default=[22.0, 220.0])
    ap.add_argument("--repeat", type=int, default=1)
    args = ap.parse_args()
    exe = [str(Path(sys.executable).with_name("aerosurvey"))]
    repo = Path(__file__).resolve().parent.parent
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp)
        ref = min(run([*exe, "-q", "plan", str(repo / "missions/obratan-72ha.toml"), "-o", str(base / f"ref{i}")], base)[0]
                  for i in range(args.repeat))
        print(f"reference: missions/obratan-72ha.toml {ref:.2f} s")
        print(f"{'case':<26} {'time s':>7} {'x ref':>6} {'MB':>6} {'photos':>8} {'strips':>6} {'sorties':>7} exit")
        for km in args.km:
            pts = centreline(km)
            (base / "line.geojson").write_text(json.dumps({"type": "LineString", "coordinates": pts}))
            every = max(1, int(5.0 / 2.0))
            launch = json.dumps([list(p) for p in pts[::every]])
            (base / "outline.geojson").write_text(json.dumps(outline(pts, 150.0)))
            for case in ("one flight", "sorties", "polygon"):
                sorties = case == "sorties"
                text = SPEC.format(km=km) + (BATTERY.format(points=launch) if sorties else "")
                if case == "polygon":
                    text = text.replace('file = "line.geojson"', 'file = "outline.geojson"').replace("width_m = 300\n", "")
                spec = base / f"c{km:g}{case[0]}.toml"
                spec.write_text(text)
                best = None
                for i in range(args.repeat):
                    out = base / f"out-{spec.stem}-{i}"
                    r = run([*exe, "-q", "plan", str(spec), "-o", str(out)], base)
                    if best is None or r[0] < best[0][0]:
                        best = (r, out)
                assert best is not None
                (wall, mb, code, last), out = best
                photos = strips = n_sorties = 0
                if (out / "manifest.json").exists():
                    m = json.loads((out / "manifest.json").read_text())
                    photos, strips, n_sorties = len(m["stations"]), len({ln["line"] for ln in m["lines"]}), len(m["sorties"])
                name = f"{km:g} km {case}"
                print(f"{name:<26} {wall:7.2f} {wall / ref:6.2f} {mb:6.0f} {photos:8d} {strips:6d} {n_sorties:7d} {code}"
                      + (f"  {last}" if code else ""))


if __name__ == "__main__":
    main()
