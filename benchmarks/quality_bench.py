"""Plan quality at equal guarantee against a peer planner, opencoverage 0.2.0 (PyPI), and
against the plan's own lower bounds (issue 27).

    python benchmarks/quality_bench.py                 # every area, both scenarios
    python benchmarks/quality_bench.py --area block-72ha --scenario gsd4.5
    python benchmarks/quality_bench.py --bound-sweep   # no peer: convex blocks of 12 to 4,000 ha against the photo bound
    PYTHONPATH=OTHER/src python benchmarks/quality_bench.py   # another version's planner (e.g. main's sources)

The peer is installed by this script into its own virtual environment under the user's cache
folder ($XDG_CACHE_HOME or ~/.cache, aerosurvey-bench/peer-opencoverage-0.2.0; created on the
first run with `python -m venv` and `pip install opencoverage==0.2.0`), outside the repository,
and run in a subprocess of that environment (the repository imports nothing of it).

Areas (local metres about 49.4 N 15 E, written as lon/lat GeoJSON for aerosurvey):
- block-12ha: a 400 x 300 m rectangle turned 20 degrees (convex);
- block-72ha: a convex quadrilateral of 72 ha;
- small-2ha: a regular pentagon of 2 ha (convex, narrower than a footprint at 120 m and above);
- concave-L-35ha: 900 x 600 m less a 550 x 350 m corner;
- concave-U-220ha: 2,000 x 1,500 m less an 800 x 1,000 m notch (large);
- holes-17ha: 500 x 400 m with a round and a square hole;
- corridor-25ha: a 120 m wide strip along a 2.1 km polyline with one bend.
Scenarios: `gsd4.5` (GSD 4.5 cm, the height cap raised to 200 m: 184 m above ground) and
`cap120` (120 m above ground, the usual cap). Both: Sony a6000 16 mm landscape, 75 % forward and
60 % side overlap, a copter at 10 m/s, automatic heading, no cross-hatch, no photos beyond the
boundary, no coverage margin.

Method (equal guarantee): the guarantee is aerosurvey's, every point of the area on at least
k_side x k_fwd = 2 x 4 = 8 photos. aerosurvey plans the area; its mission.waypoints is replayed
by tests/independent_coverage.py (ArduPilot's distance trigger at 50 Hz at the set speed) and the
photos' footprints are counted on a grid of samples (120 along the longer side of the area's
box) inside the area. The peer (pattern optimal_sweep, 3,600 angle steps, the same camera,
overlaps, height and speed) is handed the area buffered outward (round joins) by d, its path
written as the rows of a QGC WPL file (DO_CHANGE_SPEED, the first waypoint,
DO_SET_CAM_TRIGG_DIST(its forward distance, 0, 1), every waypoint of its path, the trigger off)
and replayed by the same code (the distance commanded as aerosurvey commands its own: the whole
50 Hz check steps within the peer's forward distance in ArduPilot's metres along its lines (the
replay measures in them), less half a step, else the autopilot's pictures fall farther apart
than asked and some ground stays on 7 photos at any buffer); d is
the smallest (bisection, 9 steps from 0 to a footprint's width, doubled while short) at which
its photos see >= 99.9 % of the samples on >= 8 photos.
Photos: the replayed pictures (the peer's trigger stays on along its connectors, as one
DO_SET_CAM_TRIGG_DIST mission flies). Path: aerosurvey's from its first lead-in to its last line
end (lead-ins and turns included, not the legs from and back home); the peer's whole path
(lines and connectors, no lead-in). Bounds: the manifest's derived.bounds (strips: the minimum
width by rotating calipers with the 2-strip side rule at the edges; photos: area / (base x
spacing)).

Not covered: the time model (turns, accelerations) of either planner, wind, terrain, zones,
other overlaps or cameras, images beyond the boundary (none asked here: aerosurvey's bands and
pieces of concave areas are laid only then), cross-hatch, planes; the peer's bisection finds a d at which the rule holds, not always
the smallest when coverage is not monotone in d (this can only favour aerosurvey by a few
metres of buffer).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import shapely
import shapely.affinity

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))

import independent_coverage as ic  # noqa: E402  (the tests' independent replay, by path)
from ardupilot_location import metres_per_ground_metre  # noqa: E402

LAT0, LON0, EPSG = 49.40, 15.00, 32633
PEER = "opencoverage==0.2.0"
CAMERA = ("sony-a6000-16mm", 23.5, 15.6, 6000, 4000, 16.0)
FORWARD, SIDE, SPEED = 0.75, 0.60, 10.0
NEED = 8  # photos on every point: 2 strips x 4 photos
SCENARIOS = {"gsd4.5": {"gsd_cm": 4.5, "cap": 200.0}, "cap120": {"height_m": 120.0, "cap": 120.0}}

PEER_RUNNER = """
import json, sys
import opencoverage as oc
from shapely.geometry import shape
q = json.load(sys.stdin)
cam = oc.PinholeCamera(pixel_size_mm=q["pixel_mm"], focal_length_mm=q["focal_mm"], sensor_width_mm=q["sw_mm"],
                       sensor_height_mm=q["sh_mm"], capture_rate_s=1.0)
uav = oc.UAV(min_height=1.0, max_height=1000.0, survey_velocity=q["speed"])
m = oc.plan(polygon=shape(q["polygon"]), uav=uav, camera=cam, pattern="optimal_sweep", lateral_overlap=q["side"],
            forward_overlap=q["forward"], target=q["target"], target_value=q["value"], n_angle_steps=3600)
print(json.dumps({"path": [list(p) for p in m.path], "height": m.flight_height, "forward": m.forward_distance}))
"""


def areas() -> dict[str, shapely.Polygon]:
    def scaled(g: shapely.Polygon, ha: float) -> shapely.Polygon:
        f = math.sqrt(ha * 1e4 / g.area)
        return shapely.affinity.scale(g, f, f, origin="centroid")

    block = shapely.Polygon([(0, 0), (1000, 60), (980, 760), (-40, 700)])
    t = np.linspace(0, 2 * np.pi, 6)[:-1]
    pent = shapely.Polygon(np.column_stack([np.cos(t), np.sin(t)]))
    holes = shapely.difference(shapely.box(0, 0, 500, 400), shapely.union_all(
        [shapely.Point(150, 200).buffer(50, quad_segs=8), shapely.box(320, 120, 400, 240)]))
    out = {
        "block-12ha": shapely.affinity.rotate(shapely.box(0, 0, 400, 300), 20.0),
        "block-72ha": scaled(block, 72.0),
        "small-2ha": scaled(pent, 2.0),
        "concave-L-35ha": shapely.difference(shapely.box(0, 0, 900, 600), shapely.box(350, 250, 900, 600)),
        "concave-U-220ha": shapely.difference(shapely.box(0, 0, 2000, 1500), shapely.box(600, 500, 1400, 1500)),
        "holes-17ha": holes,
        "corridor-25ha": shapely.LineString([(0, 0), (1200, 0), (2000, 400)]).buffer(60, cap_style="flat"),
    }
    return {k: shapely.affinity.translate(g, -g.centroid.x, -g.centroid.y) for k, g in out.items()}


def cache_dir() -> Path:
    root = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return root / "aerosurvey-bench" / ("peer-" + PEER.replace("==", "-"))


def peer_python() -> Path:
    """The peer's interpreter, its environment made on first use."""
    env = cache_dir()
    py = env / "bin" / "python"
    if not py.exists():
        env.parent.mkdir(parents=True, exist_ok=True)
        subprocess.run([sys.executable, "-m", "venv", str(env)], check=True)
    if subprocess.run([str(py), "-c", "import opencoverage"], capture_output=True).returncode:
        subprocess.run([str(py), "-m", "pip", "install", "-q", PEER], check=True)
    return py


def peer_plan(py: Path, polygon: shapely.Polygon, scenario: dict) -> dict:
    _, sw, sh, nw, _, f = CAMERA
    target, value = ("resolution", scenario["gsd_cm"] * 10.0) if "gsd_cm" in scenario else ("altitude", scenario["height_m"])
    q = {"polygon": shapely.geometry.mapping(polygon), "pixel_mm": sw / nw, "focal_mm": f, "sw_mm": sw, "sh_mm": sh,
         "speed": SPEED, "side": SIDE, "forward": FORWARD, "target": target, "value": value}
    res = subprocess.run([str(py), "-c", PEER_RUNNER], input=json.dumps(q), capture_output=True, text=True, check=True)
    return json.loads(res.stdout)


def peer_rows(peer: dict, to_ll) -> list[list[float]]:
    """The peer's path as the rows of a QGC WPL file (index, current, frame, command, p1-p4, lat, lon, alt, 1)."""
    xy = np.asarray(peer["path"], float)
    lon, lat = to_ll.transform(xy[:, 0], xy[:, 1])
    h = peer["height"]
    # commanded as aerosurvey commands its own: whole 50 Hz check steps within the peer's forward
    # distance, less half a step, so the autopilot's pictures lie no farther apart than it asked;
    # in ArduPilot's metres (its flat earth, as the replay measures), along the peer's lines (its
    # legs of a base or more: the fewest autopilot metres per ground metre of any of them)
    d = np.hypot(*np.diff(xy, axis=0).T)
    long = np.flatnonzero(d >= peer["forward"])
    scale = min((metres_per_ground_metre(lat[i], lon[i], lat[i + 1], lon[i + 1], d[i]) for i in long.tolist()), default=1.0)
    step = SPEED / 50.0
    command = math.floor(peer["forward"] * scale / step + 1e-9) * step - step / 2.0
    rows = [[0, 0, 3, ic.DO_CHANGE_SPEED, 1, SPEED, -1, 0, 0, 0, 0, 1],
            [0, 0, 3, ic.NAV_WAYPOINT, 0, 0, 0, 0, lat[0], lon[0], h, 1],
            [0, 0, 3, ic.DO_SET_CAM_TRIGG_DIST, command, 0, 1, 0, 0, 0, 0, 1]]
    rows += [[0, 0, 3, ic.NAV_WAYPOINT, 0, 0, 0, 0, a, o, h, 1] for a, o in zip(lat[1:].tolist(), lon[1:].tolist())]
    rows.append([0, 0, 3, ic.DO_SET_CAM_TRIGG_DIST, 0, 0, 0, 0, 0, 0, 0, 1])
    return [[float(v) for v in r] for r in rows]


def seen(rows: list[list[float]], to_xy, gx: np.ndarray, gy: np.ndarray) -> tuple[int, float]:
    """(photos, share of the samples on NEED photos or more) of a mission's rows, replayed."""
    photos = ic.replay_triggers(rows, to_xy, None, 0.0)
    counts = ic.footprint_counts(photos, gx, gy, CAMERA[1:], "landscape")
    return len(photos.x), float(np.mean(counts >= NEED))


def write_area(path: Path, area: shapely.Polygon, to_ll) -> None:
    rings = [[list(p) for p in zip(*to_ll.transform(*np.asarray(r.coords).T))] for r in [area.exterior, *area.interiors]]
    path.write_text(json.dumps({"type": "Polygon", "coordinates": rings}))


def ours(area: shapely.Polygon, scenario: dict, to_ll, to_xy, gx, gy, tmp: Path) -> dict:
    import tomli_w

    from aerosurvey.inputs import plan_from_files
    from aerosurvey.outputs import write_outputs
    from aerosurvey.spec import load_spec

    write_area(tmp / "area.geojson", area, to_ll)
    targets = {k: v for k, v in scenario.items() if k in ("gsd_cm", "height_m")}
    spec = {"mission": {"name": "quality", "crs": f"EPSG:{EPSG}"}, "area": {"file": "area.geojson"},
            "camera": {"model": CAMERA[0], "mount": "landscape", "trigger": "distance"},
            "targets": {**targets, "forward_overlap": FORWARD, "side_overlap": SIDE, "images_beyond_boundary": 0},
            "vehicle": {"type": "copter", "cruise_speed_ms": SPEED, "max_height_agl_m": scenario["cap"]},
            "flight": {"heading": "auto", "cross_hatch": False}}
    (tmp / "spec.toml").write_text(tomli_w.dumps(spec))
    loaded = load_spec(tmp / "spec.toml")
    plan = plan_from_files(loaded)
    write_outputs(plan, loaded, tmp / "out")
    manifest = json.loads((tmp / "out" / "manifest.json").read_text())
    _, rows = ic.read_wpl(tmp / "out" / "mission.waypoints")
    photos, share = seen(rows, to_xy, gx, gy)
    kinds = [w.kind for w in plan.waypoints]
    first = kinds.index("lead_in")
    last = len(kinds) - 1 - kinds[::-1].index("line_end")
    xy = np.array([(w.x, w.y) for w in plan.waypoints[first:last + 1]])
    path = float(np.hypot(*np.diff(xy, axis=0).T).sum()) / plan.site.grid_scale
    b = manifest["derived"].get("bounds") or {"strips": math.nan, "photos": math.nan}  # none before issue 27's
    return {"photos": photos, "share": share, "path_m": path, "strips": len({r["line"] for r in manifest["lines"]}),
            "strip_bound": b["strips"], "photo_bound": b["photos"], "planned": int(manifest["estimates"]["photos"])}


def peer(py: Path, area: shapely.Polygon, scenario: dict, to_ll, to_xy, gx, gy, across: float) -> dict:
    def attempt(d: float) -> tuple[dict, int, float]:
        poly = shapely.buffer(area, d, quad_segs=4) if d > 0 else area
        p = peer_plan(py, poly, scenario)
        n, share = seen(peer_rows(p, to_ll), to_xy, gx, gy)
        return p, n, share

    lo, hi = 0.0, across
    best = attempt(0.0)
    if best[2] < 0.999:
        best = attempt(hi)
        while best[2] < 0.999:
            if hi > 16 * across:
                raise SystemExit(f"the peer's photos see {best[2]:.2%} of the area on {NEED} photos at a buffer of {hi:.0f} m")
            lo, hi = hi, 2 * hi
            best = attempt(hi)
        for _ in range(9):
            mid = (lo + hi) / 2.0
            got = attempt(mid)
            if got[2] >= 0.999:
                hi, best = mid, got
            else:
                lo = mid
    else:
        hi = 0.0
    p, n, share = best
    xy = np.asarray(p["path"], float)
    return {"photos": n, "share": share, "path_m": float(np.hypot(*np.diff(xy, axis=0).T).sum()), "buffer_m": hi}


def bound_sweep(scenarios: list[str], to_ll, to_xy) -> None:
    """How the photos' excess over the photo bound falls as a convex block grows: the edge
    strips and the line ends the guarantee needs grow with the perimeter, the bound with the area."""
    block = areas()["block-12ha"]
    for scen in scenarios:
        for ha in (12, 72, 300, 1000, 4000):
            f = math.sqrt(ha * 1e4 / block.area)
            area = shapely.affinity.scale(block, f, f, origin="centroid")
            gx, gy = ic.grid_inside(area, 120)
            with tempfile.TemporaryDirectory() as td:
                a = ours(area, SCENARIOS[scen], to_ll, to_xy, gx, gy, Path(td))
            print(json.dumps({"scenario": scen, "ha": ha, "photos": a["planned"], "photo_bound": a["photo_bound"],
                              "photos_over_bound": round(a["planned"] / a["photo_bound"], 3), "strips": a["strips"],
                              "strip_bound": a["strip_bound"], "ours_on_8": round(a["share"], 5)}), flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--area", action="append", help="only these areas (repeatable)")
    ap.add_argument("--scenario", action="append", choices=sorted(SCENARIOS))
    ap.add_argument("--bound-sweep", action="store_true",
                    help="no peer: block-12ha's rectangle scaled to 12 ... 4,000 ha, photos against the photo bound")
    args = ap.parse_args()
    import pyproj

    to_xy = ic.local_projection(LON0, LAT0)
    to_ll = pyproj.Transformer.from_crs(to_xy.target_crs, "EPSG:4326", always_xy=True)
    if args.bound_sweep:
        bound_sweep(args.scenario or list(SCENARIOS), to_ll, to_xy)
        return
    py = peer_python()
    rows = []
    for scen in args.scenario or list(SCENARIOS):
        for name, area in areas().items():
            if args.area and name not in args.area:
                continue
            gx, gy = ic.grid_inside(area, 120)
            with tempfile.TemporaryDirectory() as td:
                a = ours(area, SCENARIOS[scen], to_ll, to_xy, gx, gy, Path(td))
            h = SCENARIOS[scen].get("height_m") or SCENARIOS[scen]["gsd_cm"] / 100.0 * CAMERA[5] / (CAMERA[1] / CAMERA[3])
            across = h / CAMERA[5] * CAMERA[1]
            b = peer(py, area, SCENARIOS[scen], to_ll, to_xy, gx, gy, across)
            row = {"scenario": scen, "area": name, "ha": round(area.area / 1e4, 1),
                   "ours_photos": a["photos"], "peer_photos": b["photos"], "photos_ratio": round(a["photos"] / b["photos"], 3),
                   "ours_path_m": round(a["path_m"]), "peer_path_m": round(b["path_m"]),
                   "path_ratio": round(a["path_m"] / b["path_m"], 3), "ours_on_8": round(a["share"], 5),
                   "peer_on_8": round(b["share"], 5), "peer_buffer_m": round(b["buffer_m"], 1),
                   "strips": a["strips"], "strip_bound": a["strip_bound"], "photo_bound": a["photo_bound"],
                   "photos_over_bound": round(a["planned"] / a["photo_bound"], 3)}
            rows.append(row)
            print(json.dumps(row), flush=True)
    if len(rows) > 1:
        pr, ph = [r["path_ratio"] for r in rows], [r["photos_ratio"] for r in rows]
        print(json.dumps({"rows": len(rows), "path_ratio_median": round(statistics.median(pr), 3), "path_ratio_max": max(pr),
                          "path_worse_rows": sum(r > 1.0 for r in pr), "photos_ratio_median": round(statistics.median(ph), 3),
                          "photos_ratio_max": max(ph), "photos_worse_rows": sum(r > 1.0 for r in ph)}))


if __name__ == "__main__":
    main()
