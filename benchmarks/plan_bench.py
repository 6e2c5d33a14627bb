"""Planning speed, memory and plan quality on synthetic areas (issue: planner core).

    python benchmarks/plan_bench.py            # all cases, one subprocess each, then start-up
    python benchmarks/plan_bench.py --case 1000ha-holes
    python benchmarks/plan_bench.py --startup  # only the command start-up section
    python benchmarks/plan_bench.py --startup --before ../other/src  # and the same commands from other sources
    python benchmarks/plan_bench.py --command --rounds 3  # the whole `aerosurvey plan` on 100 km2, every output

Each case runs in its own process so that its peak memory (max RSS) is its own. Times are
wall-clock seconds on this machine in this run, and the process's CPU seconds (steadier on a
busy machine); the 72 ha block is planned in the same run as a baseline, and every case
reports its times as ratios to it. Quality: the length
flown with the camera on against the lower bound area / spacing + the required
extensions at both ends of every run, and the photo count against area / (spacing · base)
plus the extension photos.

Start-up: wall (and CPU) time of fresh `aerosurvey` processes (`python -m aerosurvey.cli`, the sources
this interpreter imports), median of 5 rounds, each round running every command once, as
ratios to baselines timed in the same rounds: `python -c "import click"` for help pages,
`python -c "import numpy, shapely, pyproj"` for planning the 72 ha example. Byte code is
compiled into a temporary PYTHONPYCACHEPREFIX by a warm-up run first, as an installed
package has it (PYTHONDONTWRITEBYTECODE is dropped for these processes).
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pyproj
import shapely

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "missions" / "tools"))

LAT0, LON0, EPSG = 49.40, 15.00, 32633


def _lonlat_rings(geom: shapely.Geometry) -> list:
    t = pyproj.Transformer.from_crs(EPSG, 4326, always_xy=True)
    out = []
    for poly in shapely.get_parts(geom):
        rings = []
        for r in [poly.exterior, *poly.interiors]:
            x, y = t.transform(*np.asarray(r.coords).T)
            rings.append([[round(a, 8), round(b, 8)] for a, b in zip(x, y)])
        out.append(rings)
    return out


def _write_area(path: Path, geom: shapely.Geometry) -> None:
    polys = _lonlat_rings(geom)
    gj = {"type": "MultiPolygon", "coordinates": polys} if len(polys) > 1 else {"type": "Polygon", "coordinates": polys[0]}
    path.write_text(json.dumps({"type": "FeatureCollection", "features": [{"type": "Feature", "properties": {}, "geometry": gj}]}))


def _origin() -> tuple[float, float]:
    t = pyproj.Transformer.from_crs(4326, EPSG, always_xy=True)
    return t.transform(LON0, LAT0)


def make_case(name: str, tmp: Path) -> Path:
    """Write the case's area, zones, DEM and spec into `tmp`; return the spec path."""
    import tomli_w

    if name == "72ha":
        return REPO / "missions" / "obratan-72ha.toml"
    x0, y0 = _origin()
    spec = {
        "mission": {"name": name, "crs": f"EPSG:{EPSG}"},
        "area": {"file": "area.geojson"},
        "camera": {"model": "sony-a6000-16mm"},
        "targets": {"gsd_cm": 2.5, "forward_overlap": 0.75, "side_overlap": 0.6, "images_beyond_boundary": 2},
        "vehicle": {"type": "copter", "cruise_speed_ms": 12.0},
    }
    if name.startswith("1000ha"):
        side = math.sqrt(1000e4)
        outer = shapely.Polygon([(0, 0), (side * 1.1, -80), (side * 1.05, side * 0.95), (side * 0.4, side * 1.02), (-60, side * 0.9)])
        holes = [shapely.Point(side * f, side * g).buffer(side * 0.05, quad_segs=4) for f, g in ((0.3, 0.3), (0.7, 0.6), (0.5, 0.8))]
        area = shapely.difference(outer, shapely.union_all(holes))
        scale = math.sqrt(1000e4 / area.area)
        area = shapely.affinity.scale(area, scale, scale, origin=(0, 0))
        area = shapely.affinity.translate(area, x0, y0)
        zones = [shapely.affinity.translate(shapely.box(0, 0, 150, 220), x0 + side * 0.2, y0 + side * 0.6),
                 shapely.affinity.translate(shapely.Point(0, 0).buffer(90, quad_segs=4), x0 + side * 0.8, y0 + side * 0.25)]
        _write_area(tmp / "area.geojson", area)
        names = []
        for i, z in enumerate(zones):
            _write_area(tmp / f"zone{i}.geojson", z)
            names.append(f"zone{i}.geojson")
        spec["area"]["exclusions"] = names
        if name.endswith("dem"):
            from synthetic_dem import write_dem

            b = area.bounds
            w, h = int(b[2] - b[0]) + 200, int(b[3] - b[1]) + 200
            write_dem(str(tmp / "dem.tif"), EPSG, b[0] - 100, b[3] + 100, w, h, 1.0, 400.0, 40.0)
            spec["terrain"] = {"dem": "dem.tif", "mode": name.split("-")[-2]}
    elif name == "10000ha":
        side = math.sqrt(10000e4)
        area = shapely.affinity.translate(shapely.Polygon([(0, 0), (side, 0), (side * 1.1, side), (-side * 0.1, side * 0.95)]), x0, y0)
        scale = math.sqrt(10000e4 / area.area)
        area = shapely.affinity.scale(area, scale, scale)
        _write_area(tmp / "area.geojson", area)
        spec["targets"]["gsd_cm"] = 2.9
    elif name == "convex-square":
        _write_area(tmp / "area.geojson", shapely.affinity.translate(shapely.box(0, 0, 1000, 1000), x0, y0))
        spec["flight"] = {"heading": 0.0}
    else:
        raise SystemExit(f"unknown case {name!r}")
    p = tmp / "spec.toml"
    p.write_text(tomli_w.dumps(spec))
    return p


def quality(plan, spec) -> dict[str, float]:
    s, b, L = plan.sensor.spacing_m, plan.sensor.base_m, plan.sensor.along_m
    k = plan.sensor.forward_images_per_point
    beyond = spec.targets.images_beyond_boundary
    ext = max(beyond * b, (k - 1) * b - L / 2, 0.0)
    runs = len(plan.route.runs)
    passes = len(plan.layout.passes)
    area = plan.site.area.area
    if plan.site.zones is not None:
        area -= shapely.intersection(plan.site.area, shapely.buffer(plan.site.zones, plan.site.margin_m)).area
    bound_len = passes * area / s + runs * 2 * ext
    flown = sum((len(r.station_xy) - 1) * b for r in plan.route.runs)
    bound_photos = passes * area / (s * b) + runs * 2 * ext / b
    # the fewest whole lines that put every point of the area's width in k_side strips
    # (the outer-edge rule), at each pass's heading: the structural minimum
    from aerosurvey.plan.frame import LineFrame

    k_side = plan.sensor.side_images_per_point
    min_lines = 0
    for p in plan.layout.passes:
        _, v0, _, v1 = LineFrame(p.frame.heading_deg).geom_to_frame(plan.site.area).bounds
        min_lines += max(k_side, math.ceil((v1 - v0 - plan.sensor.across_m + 2 * (k_side - 1) * s) / s - 1e-9) + 1)
    lines = len({(r.pass_index, r.line) for r in plan.route.runs})
    return {"lines": lines, "min_lines": min_lines,"line_length_m": round(flown, 1), "line_length_bound_m": round(bound_len, 1),
            "line_length_ratio": round(flown / bound_len, 4), "photos": len(plan.stations.ids),
            "photos_bound": round(bound_photos, 1), "photos_ratio": round(len(plan.stations.ids) / bound_photos, 4)}


def run_case(name: str) -> dict:
    from aerosurvey.inputs import plan_from_files
    from aerosurvey.outputs import write_outputs
    from aerosurvey.spec import load_spec

    with tempfile.TemporaryDirectory() as td:
        tmp = Path(td)
        # the case's files (a DEM of millions of cells) are made by a process of their own: this one's peak
        # memory is then the planning's and writing's alone
        made = subprocess.run([sys.executable, __file__, "--make-case", name, str(tmp)], capture_output=True, text=True)
        if made.returncode != 0:
            raise SystemExit(f"{name}: making the case failed\n{made.stderr}")
        spec_path = Path(made.stdout.strip().splitlines()[-1])
        # the modules are imported above, before timing: module import is not planning work
        t0, c0 = time.perf_counter(), time.process_time()
        spec = load_spec(spec_path)
        plan = plan_from_files(spec)
        t1, c1 = time.perf_counter(), time.process_time()
        files = write_outputs(plan, spec, tmp / "out").files
        t2, c2 = time.perf_counter(), time.process_time()
        size = sum(len(v.encode()) for v in files.values())
    rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return {"case": name, "area_ha": round(plan.site.area.area / 1e4, 1), "plan_s": round(t1 - t0, 3),
            "write_s": round(t2 - t1, 3), "total_s": round(t2 - t0, 3), "plan_cpu_s": round(c1 - c0, 3),
            "write_cpu_s": round(c2 - c1, 3), "total_cpu_s": round(c2 - c0, 3), "peak_rss_mb": round(rss_mb, 1),
            "output_mb": round(size / 1e6, 2), **quality(plan, spec)}


STARTUP_ROUNDS = 5
_EXAMPLE = str(REPO / "missions" / "obratan-72ha.toml")
#: (name, argv after the interpreter, [(baseline name, largest allowed ratio to it or None)])
STARTUP = [
    ("import click", ["-c", "import click"], []),
    ("import numpy, shapely, pyproj", ["-c", "import numpy, shapely, pyproj"], []),
    ("aerosurvey --help", ["-m", "aerosurvey.cli", "--help"], [("import click", 4.0)]),
    # a group's help page lists its subcommands from a registry, importing none of them (scipy for qa)
    ("aerosurvey plan --help", ["-m", "aerosurvey.cli", "plan", "--help"], [("import click", 4.0)]),
    ("aerosurvey qa --help", ["-m", "aerosurvey.cli", "qa", "--help"], [("import click", 4.0)]),
    # the plan's work through the library, no CLI: the ratio of the command to it is what start-up adds
    ("library plan 72ha", ["-c", "from pathlib import Path; from aerosurvey.spec import load_spec; "
                           "from aerosurvey.inputs import plan_from_files; from aerosurvey.outputs import write_outputs; "
                           f"spec = load_spec(Path({_EXAMPLE!r})); write_outputs(plan_from_files(spec), spec, Path('{{tmp}}/lib'))"],
     [("import numpy, shapely, pyproj", None)]),
    ("aerosurvey plan 72ha", ["-m", "aerosurvey.cli", "plan", _EXAMPLE, "-o", "{tmp}/out"],
     [("import numpy, shapely, pyproj", 2.5), ("library plan 72ha", None)]),
]


def _startup_rows(before: str | None, table: list) -> list[tuple[str, list[str], list, dict[str, str]]]:
    """`table` (STARTUP's form) with an environment each; with `before` (a source folder), each aerosurvey command twice:
    as this interpreter imports it and, as "NAME (before)", from `before` (e.g. the main checkout's src)."""
    rows = [(name, argv, comparisons, {}) for name, argv, comparisons in table]
    if before:
        rows += [(f"{name} (before)", argv, comparisons, {"PYTHONPATH": before})
                 for name, argv, comparisons in table if name.startswith(("aerosurvey", "library"))]
    return rows


def startup(before: str | None = None, rounds: int = STARTUP_ROUNDS, table: list | None = None) -> list[dict]:
    """Fresh-process wall times of the STARTUP commands (or `table`'s) and their ratios to their baselines."""
    import os
    import statistics

    commands = _startup_rows(before, STARTUP if table is None else table)
    with tempfile.TemporaryDirectory() as td:
        base_env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
        base_env["PYTHONPYCACHEPREFIX"] = str(Path(td) / "pycache")
        times: dict[str, list[float]] = {name: [] for name, *_ in commands}
        cpu: dict[str, list[float]] = {name: [] for name, *_ in commands}
        for rnd in range(rounds + 1):  # round 0 compiles the byte code and is not counted
            # every other round in reverse order: a drift in the machine's load then biases no command
            for name, argv, _, extra_env in (commands if rnd % 2 else commands[::-1]):
                cmd = [sys.executable, *(a.replace("{tmp}", td) for a in argv)]
                r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
                t0 = time.perf_counter()
                out = subprocess.run(cmd, capture_output=True, text=True, env={**base_env, **extra_env})
                dt = time.perf_counter() - t0
                r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
                if out.returncode != 0:
                    raise SystemExit(f"{name} failed:\n{out.stderr}")
                if rnd:
                    times[name].append(dt)
                    cpu[name].append(r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime)
    med = {name: statistics.median(v) for name, v in times.items()}
    med_cpu = {name: statistics.median(v) for name, v in cpu.items()}
    rows = []
    for name, _, comparisons, _ in commands:
        for base, limit in comparisons or [(None, None)]:
            if name.endswith(" (before)") and base in med and f"{base} (before)" in med:
                base = f"{base} (before)"  # the library baseline of the same sources
            ratio = med[name] / med[base] if base else None
            rows.append({"command": name, "median_s": round(med[name], 3), "cpu_s": round(med_cpu[name], 3),
                         "baseline": base or "", "ratio": round(ratio, 2) if ratio is not None else "",
                         "cpu_ratio": round(med_cpu[name] / med_cpu[base], 2) if base else "",
                         "target": f"<= {limit}x" if limit else "",
                         "met": ("yes" if ratio <= limit else "NO") if (limit and ratio is not None) else ""})
    return rows


def command(before: str | None, rounds: int) -> list[dict]:
    """The whole `aerosurvey plan` command on the 100 km2 case (issue 38: "one 100 km2 plan with every output: <= 1 s
    for the whole command"), fresh processes as the start-up section runs them: its default outputs, and with --gpkg
    too; the baseline is importing numpy, shapely and pyproj. Each row says whether its median wall and CPU time are
    within 1 s."""
    with tempfile.TemporaryDirectory() as td:
        spec = str(make_case("10000ha", Path(td)))
        plan = ["-m", "aerosurvey.cli", "-q", "plan", spec, "-o"]
        base = "import numpy, shapely, pyproj"
        table = [(base, ["-c", base], []),
                 ("aerosurvey plan 100 km2", [*plan, "{tmp}/out"], [(base, None)]),
                 ("aerosurvey plan 100 km2 --gpkg", [*plan, "{tmp}/out-gpkg", "--gpkg"], [(base, None)])]
        rows = startup(before, rounds, table)
    for r in rows:
        if r["baseline"]:
            r.update(target="<= 1 s", met=f"wall {'yes' if r['median_s'] <= 1 else 'NO'}, cpu {'yes' if r['cpu_s'] <= 1 else 'NO'}")
    return rows


def print_startup(rows: list[dict], rounds: int = STARTUP_ROUNDS) -> None:
    print(f"start-up: fresh processes, median of {rounds} rounds; ratio of wall times (the target), "
          "cpu_ratio of user+system CPU times (steadier on a busy machine)")
    cols = ["command", "median_s", "cpu_s", "baseline", "ratio", "cpu_ratio", "target", "met"]
    widths = {c: max(len(c), *(len(str(r[c])) for r in rows)) for c in cols}
    print("  ".join(c.ljust(widths[c]) for c in cols))
    for r in rows:
        print("  ".join(str(r[c]).ljust(widths[c]) for c in cols).rstrip())


CASES = ["72ha", "convex-square", "1000ha-holes", "1000ha-holes-fixed-dem", "1000ha-holes-follow-dem", "10000ha"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", choices=CASES)
    ap.add_argument("--startup", action="store_true", help="Only the start-up section.")
    ap.add_argument("--command", action="store_true", help="Only the whole `aerosurvey plan` command on 100 km2 (with "
                    "and without --gpkg), as the start-up section times commands.")
    ap.add_argument("--before", metavar="SRC", help="Start-up: also time the aerosurvey commands from this source folder "
                    "(e.g. ../other/src) in the same rounds, as rows 'NAME (before)'.")
    ap.add_argument("--rounds", type=int, default=STARTUP_ROUNDS, help="Start-up rounds (median of them).")
    ap.add_argument("--make-case", nargs=2, metavar=("CASE", "FOLDER"), help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.make_case:
        print(make_case(a.make_case[0], Path(a.make_case[1])))
        return
    if a.case:
        print(json.dumps(run_case(a.case)))
        return
    if a.startup:
        print_startup(startup(a.before, a.rounds), a.rounds)
        return
    if a.command:
        print_startup(command(a.before, a.rounds), a.rounds)
        return
    rows = []
    for case in CASES:
        out = subprocess.run([sys.executable, __file__, "--case", case], capture_output=True, text=True)
        if out.returncode != 0:
            print(f"{case}: failed\n{out.stderr}", file=sys.stderr)
            continue
        rows.append(json.loads(out.stdout.strip().splitlines()[-1]))
    base = next((r for r in rows if r["case"] == "72ha"), None)
    cols = ["case", "area_ha", "plan_s", "write_s", "total_s", "x72ha", "total_cpu_s", "cpu_x72ha", "peak_rss_mb",
            "output_mb", "line_length_ratio", "lines", "min_lines", "photos", "photos_ratio"]
    print("  ".join(f"{c:>11}" for c in cols))
    for r in rows:  # CPU times are steadier than wall times on a machine others load
        r["x72ha"] = round(r["total_s"] / base["total_s"], 1) if base else float("nan")
        r["cpu_x72ha"] = round(r["total_cpu_s"] / base["total_cpu_s"], 1) if base else float("nan")
        print("  ".join(f"{str(r[c]):>11}" for c in cols))
    print()
    print_startup(startup(a.before, a.rounds), a.rounds)


if __name__ == "__main__":
    main()
