"""Terrain: the memory a DEM adds to `aerosurvey plan`, and the time of the clearance check along every leg
(issue 36: "1,000 ha with a DEM within 1.5x the memory of the same plan without one; clearance along legs for
100 km2 within 1 s").

    python benchmarks/terrain_bench.py                 # both sections
    python benchmarks/terrain_bench.py --memory        # peak RSS of `aerosurvey plan`, with and without a DEM
    python benchmarks/terrain_bench.py --clearance     # the clearance check on 100 km2
    python benchmarks/terrain_bench.py --clearance --cell 2

Memory: plan_bench's 1,000 ha area (holes, two zones) planned by `aerosurvey plan` in a fresh process each (its own
peak RSS from wait4), in terrain mode `follow` over plan_bench's 1 m DEM written round the area, and over a DEM
three times as wide and high (nine times the cells) round the same area, as ratios to the plan without a DEM. The
DEMs are written by another process before the plans run (their memory is not counted). The plan with a DEM
spaces its lines for the height over the ground less twice the terrain tolerance: it has more photos than the flat
plan, so a flat plan of the same spacing is measured too.

Clearance: plan_bench's 10,000 ha (100 km2) area over a synthetic DEM of `--cell` metres, planned in this process,
then `terrain_clearance` on its flight (the whole mission: one launch point cannot split 100 km2 into sorties) timed from a
fresh Dem (no tile unpacked yet, as the plan's last step meets it) and again with the tiles the first run
left in its cache: wall and CPU seconds, the legs' length and the DEM cells under it.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import plan_bench  # noqa: E402


def write_dem(path: Path, west: float, north: float, width: int, height: int, cell: float, rows_at_once: int = 512) -> None:
    """A smooth hilly DEM (a few broad hills and a slope, as missions/tools/synthetic_dem.py), written a band of rows at a
    time so that a large one does not fill this process."""
    import rasterio
    from rasterio.transform import from_origin
    from rasterio.windows import Window

    rng = np.random.default_rng(7)
    w, h = width * cell, height * cell
    hills = [(rng.uniform(0, w), rng.uniform(0, h), rng.uniform(0.15, 0.4) * max(w, h), rng.uniform(0.3, 0.7))
             for _ in range(6)]
    profile = dict(driver="GTiff", width=width, height=height, count=1, dtype="float32", crs=f"EPSG:{plan_bench.EPSG}",
                   transform=from_origin(west, north, cell, cell), nodata=-9999.0, compress="deflate", tiled=True,
                   blockxsize=256, blockysize=256)
    xs = (np.arange(width) + 0.5) * cell
    with rasterio.open(path, "w", **profile) as ds:
        for r0 in range(0, height, rows_at_once):
            n = min(rows_at_once, height - r0)
            ys = (np.arange(r0, r0 + n) + 0.5) * cell
            gx, gy = np.meshgrid(xs, ys)
            z = 400.0 + 40.0 * 0.3 * gx / xs[-1]
            for cx, cy, r, a in hills:
                z += 40.0 * a * np.exp(-((gx - cx) ** 2 + (gy - cy) ** 2) / (2 * r * r))
            ds.write(z.astype(np.float32), 1, window=Window(0, r0, width, n))


def _peak_rss_mb(argv: list[str]) -> tuple[float, float, int]:
    """Peak RSS (MB) and CPU seconds of one fresh process, and its exit code."""
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    assert proc.stderr is not None
    err = proc.stderr.read().decode()
    if proc.returncode not in (0, 1):  # 1: a rule fails (the uncovered ground next to the zones), the plan is written
        raise SystemExit(f"{' '.join(argv)} failed:\n{err}")
    return usage.ru_maxrss / 1024, usage.ru_utime + usage.ru_stime, proc.returncode


def make_memory_cases(tmp: Path) -> None:
    """The three specs of the memory section and their DEMs, written into `tmp` (run in a process of its own)."""
    import tomllib

    import pyproj
    import shapely
    import tomli_w

    spec_path = plan_bench.make_case("1000ha-holes-follow-dem", tmp)  # its DEM: the area's bounds + 100 m, 1 m cells
    spec = tomllib.loads(spec_path.read_text())
    flat = dict(spec)
    flat.pop("terrain")
    (tmp / "flat.toml").write_text(tomli_w.dumps(flat))
    # the same area over a DEM three times as wide and high, the area in its middle
    area = shapely.from_geojson((tmp / "area.geojson").read_text())
    t = pyproj.Transformer.from_crs(4326, plan_bench.EPSG, always_xy=True)
    b = shapely.transform(area, lambda xy: np.column_stack(t.transform(xy[:, 0], xy[:, 1]))).bounds
    w, h = int(b[2] - b[0]) + 200, int(b[3] - b[1]) + 200
    write_dem(tmp / "big.tif", b[0] - 100 - w, b[3] + 100 + h, 3 * w, 3 * h, 1.0)
    (tmp / "big.toml").write_text(tomli_w.dumps(dict(spec, terrain=dict(spec["terrain"], dem="big.tif"))))


def _same_spacing(tmp: Path) -> None:
    """flat.toml with the GSD that gives the DEM plan's line spacing: the same plan's photos, without a DEM."""
    import tomllib

    import tomli_w

    want = json.loads((tmp / "out-spec" / "manifest.json").read_text())["derived"]["line_spacing_m"]
    got = json.loads((tmp / "out-flat" / "manifest.json").read_text())["derived"]["line_spacing_m"]
    spec = tomllib.loads((tmp / "flat.toml").read_text())
    spec["targets"]["gsd_cm"] *= want / got
    (tmp / "flat-same.toml").write_text(tomli_w.dumps(spec))


def memory() -> list[dict]:
    """Each plan in a fresh process started from this one, which has not grown: the DEMs are written by another."""
    import rasterio

    rows = []
    with tempfile.TemporaryDirectory() as td:
        tmp = Path(td)
        subprocess.run([sys.executable, __file__, "--make-memory-cases", td], check=True)
        cmd = [sys.executable, "-m", "aerosurvey.cli", "plan"]
        cases = [("no DEM", tmp / "flat.toml", None), ("DEM round the area", tmp / "spec.toml", tmp / "dem.tif"),
                 ("DEM 9x the cells", tmp / "big.toml", tmp / "big.tif"),
                 ("no DEM, the DEM plan's spacing", tmp / "flat-same.toml", None),
                 ("the same, rasterio loaded first", tmp / "flat-same.toml", None)]
        # the last row: the library a DEM is read with (GDAL inside rasterio's wheel) loaded, no DEM read
        loaded = [sys.executable, "-c", "import runpy, sys, rasterio; sys.argv[0] = 'aerosurvey';"
                  " runpy.run_module('aerosurvey.cli', run_name='__main__')", "plan"]
        base = None
        for name, path, dem in cases:
            if name == "no DEM, the DEM plan's spacing":  # follow flies H − tolerance, spaces lines for H − 2·tolerance
                _same_spacing(tmp)
            argv = loaded if name.endswith("loaded first") else cmd
            rss, cpu, code = _peak_rss_mb([*argv, str(path), "-o", str(tmp / f"out-{path.stem}")])
            base = base or rss
            cells = None
            if dem is not None:
                with rasterio.open(dem) as ds:
                    cells = ds.width * ds.height
            m = json.loads((tmp / f"out-{path.stem}" / "manifest.json").read_text())
            rows.append({"case": name, "photos": len(m["stations"]), "dem_cells_M": round(cells / 1e6, 1) if cells else "",
                         "dem_file_mb": round(dem.stat().st_size / 1e6, 1) if dem else "", "peak_rss_mb": round(rss, 1),
                         "x_no_dem": round(rss / base, 2), "x_same_plan": "", "cpu_s": round(cpu, 2), "exit": code,
                         "target": "", "met": ""})
    # the ratio the target is about: to the flat plan of the same lines and photos
    same = rows[3]["peak_rss_mb"]
    for r in rows[1:3]:
        r.update(x_same_plan=round(r["peak_rss_mb"] / same, 2), target="<= 1.5x",
                 met="yes" if r["peak_rss_mb"] / same <= 1.5 else "NO")
    return rows


def clearance(cell: float) -> dict:
    import tomllib

    import pyproj
    import shapely
    import tomli_w

    from aerosurvey.inputs import plan_from_files
    from aerosurvey.mission.clearance import terrain_clearance
    from aerosurvey.outputs import mission_programs
    from aerosurvey.plan.landing import PLANE_RTL_LOITER_M
    from aerosurvey.plan.terrain import Dem
    from aerosurvey.spec import load_spec

    with tempfile.TemporaryDirectory() as td:
        tmp = Path(td)
        spec_path = plan_bench.make_case("10000ha", tmp)
        area = shapely.from_geojson((tmp / "area.geojson").read_text())
        t = pyproj.Transformer.from_crs(4326, plan_bench.EPSG, always_xy=True)
        b = shapely.transform(area, lambda xy: np.column_stack(t.transform(xy[:, 0], xy[:, 1]))).bounds
        pad = 600.0
        width, height = math.ceil((b[2] - b[0] + 2 * pad) / cell), math.ceil((b[3] - b[1] + 2 * pad) / cell)
        write_dem(tmp / "dem.tif", b[0] - pad, b[3] + pad, width, height, cell)
        spec = tomllib.loads(spec_path.read_text())
        spec["terrain"] = {"dem": "dem.tif", "mode": "follow"}
        spec_path.write_text(tomli_w.dumps(spec))
        plan = plan_from_files(load_spec(spec_path))
        programs = mission_programs(plan)
        s = plan.site
        assert s.dem is not None

        def run(dem: Dem) -> tuple[float, float, object]:
            w0, c0 = time.perf_counter(), time.process_time()
            report = terrain_clearance(programs, dem, s.planar, s.grid_scale, s.min_clearance_m,
                                       PLANE_RTL_LOITER_M * s.grid_scale, plan.sensor.turn_radius_m * s.grid_scale)
            return time.perf_counter() - w0, time.process_time() - c0, report

        fresh = Dem(s.dem.grid, s.planar)
        wall_cold, cpu_cold, report = run(fresh)
        wall_warm, cpu_warm, _ = run(fresh)
        from aerosurvey.airspace.legs import flight_legs

        length = sum(math.dist(leg.leg.start, leg.leg.end) for stem, p in programs.items()
                     for leg in flight_legs(p, stem, s.planar, 0.0, s.grid_scale)) / s.grid_scale
        lowest = min(report.lowest, key=lambda w: w.clearance_m)  # type: ignore[attr-defined]
    return {"area_km2": round(s.area.area / s.grid_scale ** 2 / 1e6, 1), "dem_cell_m": cell,
            "dem_cells_M": round(width * height / 1e6, 1), "flights": len(programs), "legs_km": round(length / 1000, 1),
            "cells_crossed_M": round(length / cell / 1e6, 2), "wall_s_cold": round(wall_cold, 3),
            "cpu_s_cold": round(cpu_cold, 3), "wall_s_warm": round(wall_warm, 3), "cpu_s_warm": round(cpu_warm, 3),
            "lowest": lowest.text(), "target": "<= 1 s", "met": "yes" if cpu_cold <= 1.0 else "NO"}


def _print(rows: list[dict]) -> None:
    cols = list(rows[0])
    widths = {c: max(len(c), *(len(str(r[c])) for r in rows)) for c in cols}
    print("  ".join(c.ljust(widths[c]) for c in cols))
    for r in rows:
        print("  ".join(str(r[c]).ljust(widths[c]) for c in cols).rstrip())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--memory", action="store_true", help="Only the memory section.")
    ap.add_argument("--clearance", action="store_true", help="Only the clearance section.")
    ap.add_argument("--cell", type=float, default=5.0, help="Clearance: the DEM's cell size in metres (default 5).")
    ap.add_argument("--make-memory-cases", metavar="DIR", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.make_memory_cases:
        make_memory_cases(Path(a.make_memory_cases))
        return
    both = not (a.memory or a.clearance)
    if a.memory or both:
        print("peak RSS of `aerosurvey plan` on 1,000 ha (terrain mode follow), fresh process each")
        _print(memory())
    if a.clearance or both:
        print("\nclearance along every leg of every flight on 100 km2 (cold: no tile unpacked yet; warm: the cache the first run left)")
        _print([clearance(a.cell)])


if __name__ == "__main__":
    main()
