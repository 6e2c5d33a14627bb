"""In-process planning and rendering speed, and peak memory (issue: plan contract, speed targets).

    python benchmarks/inprocess_bench.py                 # every case, one subprocess each
    python benchmarks/inprocess_bench.py --case 1000ha-2h1z [--runs 5] [--gpkg]

`kml_ms` is the median time of making plan.kml alone (its layers, `report.gpkg.plan_layers`, and
`mission.formats.kml.layers_to_kml`: the KML's share of `render_ms`), `x_kml_ref` its ratio to the
reference workload below.

`--gpkg` renders plan.gpkg too (`aerosurvey plan --gpkg`); `gpkg_ms` is then the median time of
making it alone (the GeoPackage's share of `render_ms`).

Per case, in its own process (so that its peak RSS is its own): the inputs are loaded once
(not timed: file reading is not planning), then `plan_mission` + `render_outputs` (every
output, footprints in the GeoJSON included) run once to warm up and `--runs` more times;
the median is reported, of wall-clock time and of the process's CPU time (on a machine shared
with other work the CPU time moves much less).

The machine is shared and noisy, so every case also times a fixed reference workload between
its runs (interleaved, so that a busy spell hits both) and reports its median as a ratio to
that. The reference is case-independent pure-Python text formatting and `json.dumps` of small
dicts — the same kind of interpreter-bound work as the writers and the planner's per-line
loops, so a slower or busier machine moves both by about the same factor; a numpy or GEOS
call would not (it is dominated by memory bandwidth and barely sees interpreter load).

Targets (issue): 1,000 ha concave area with two holes and an exclusion zone ≤ 100 ms;
100 km² block ≤ 1 s.
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import shapely

sys.path.insert(0, str(Path(__file__).resolve().parent))
import plan_bench  # noqa: E402  (the benchmark next to this one: its cases and file writers)

CASES = ["1000ha-2h1z", "10000ha", "72ha"]
TARGET_MS = {"1000ha-2h1z": 100.0, "10000ha": 1000.0}


def make_case(name: str, tmp: Path) -> Path:
    """Write the case's files into `tmp` and return the spec path.

    "1000ha-2h1z" is plan_bench's 1000ha-holes with two holes and one exclusion zone (the
    issue's case); the others are plan_bench's own."""
    if name != "1000ha-2h1z":
        return plan_bench.make_case(name, tmp)
    import tomli_w

    x0, y0 = plan_bench._origin()
    side = math.sqrt(1000e4)
    outer = shapely.Polygon([(0, 0), (side * 1.1, -80), (side * 1.05, side * 0.95), (side * 0.4, side * 1.02),
                             (-60, side * 0.9)])
    holes = [shapely.Point(side * f, side * g).buffer(side * 0.05, quad_segs=4) for f, g in ((0.3, 0.3), (0.7, 0.6))]
    area = shapely.difference(outer, shapely.union_all(holes))
    scale = math.sqrt(1000e4 / area.area)
    area = shapely.affinity.translate(shapely.affinity.scale(area, scale, scale, origin=(0, 0)), x0, y0)
    zone = shapely.affinity.translate(shapely.box(0, 0, 150, 220), x0 + side * 0.2, y0 + side * 0.6)
    plan_bench._write_area(tmp / "area.geojson", area)
    plan_bench._write_area(tmp / "zone0.geojson", zone)
    spec = {
        "mission": {"name": name, "crs": f"EPSG:{plan_bench.EPSG}"},
        "area": {"file": "area.geojson", "exclusions": ["zone0.geojson"]},
        "camera": {"model": "sony-a6000-16mm"},
        "targets": {"gsd_cm": 2.5, "forward_overlap": 0.75, "side_overlap": 0.6, "images_beyond_boundary": 2},
        "vehicle": {"type": "copter", "cruise_speed_ms": 12.0},
    }
    p = tmp / "spec.toml"
    p.write_text(tomli_w.dumps(spec))
    return p


def reference_work() -> tuple[float, float]:
    """Wall and CPU seconds of a fixed interpreter-bound workload (see the module docstring)."""
    t0, c0 = time.perf_counter(), time.process_time()
    rows = [{"id": f"P1-L{i % 97:03d}-S{i:04d}", "seq": i, "alt": i * 0.01, "xy": [i * 1e-6, -i * 1e-6]}
            for i in range(20000)]
    json.dumps(rows, separators=(",", ":"))
    " ".join(f"{v * 1.0000001:.8f},{v * 0.5:.8f}" for v in range(40000))
    return time.perf_counter() - t0, time.process_time() - c0


def run_case(name: str, runs: int, gpkg: bool = False) -> dict[str, object]:
    from aerosurvey.inputs import load_inputs
    from aerosurvey.outputs import render_outputs
    from aerosurvey.plan.planner import plan_mission
    from aerosurvey.spec import load_spec

    td = tempfile.TemporaryDirectory()  # kept to the end: the manifest hashes the input files
    spec = load_spec(make_case(name, Path(td.name)))
    inputs = load_inputs(spec)
    rss_loaded = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    from aerosurvey.mission.formats.kml import layers_to_kml
    from aerosurvey.report.gpkg import plan_layers

    times, cpu, plan_times, refs, cpu_refs, gpkg_times, kml_times = [], [], [], [], [], [], []
    photos = out_mb = 0.0
    for k in range(runs + 1):
        ref, cpu_ref = reference_work()
        t0, c0 = time.perf_counter(), time.process_time()
        plan = plan_mission(spec, inputs)
        t1 = time.perf_counter()
        rendered = render_outputs(plan, spec, gpkg)
        files = rendered.files
        t2, c2 = time.perf_counter(), time.process_time()
        if gpkg:
            from aerosurvey.report.gpkg import footprints_layer, gpkg_bytes, plan_layers

            t3 = time.perf_counter()
            gpkg_bytes([*plan_layers(plan), footprints_layer(plan)])
            gpkg_times.append(time.perf_counter() - t3)
        t4 = time.perf_counter()
        layers_to_kml(plan_layers(plan), plan.name)
        kml_times.append(time.perf_counter() - t4)
        if k == 0:  # warm-up: imports inside functions, caches
            photos = len(plan.stations.ids)
            out_mb = (sum(len(v.encode()) for v in files.values()) + sum(len(b) for b in rendered.binary.values())) / 1e6
            continue
        times.append(t2 - t0)
        cpu.append(c2 - c0)
        plan_times.append(t1 - t0)
        refs.append(ref)
        cpu_refs.append(cpu_ref)
        del plan, files, rendered
    td.cleanup()
    ms = statistics.median(times) * 1000
    ref_ms = statistics.median(refs) * 1000
    cpu_ms, cpu_ref_ms = statistics.median(cpu) * 1000, statistics.median(cpu_refs) * 1000
    return {"case": name, "photos": photos, "output_mb": round(out_mb, 2),
            "plan_ms": round(statistics.median(plan_times) * 1000, 1),
            "render_ms": round(ms - statistics.median(plan_times) * 1000, 1),
            "total_ms": round(ms, 1), "min_ms": round(min(times) * 1000, 1), "ref_ms": round(ref_ms, 1),
            "x_ref": round(ms / ref_ms, 2), "cpu_ms": round(cpu_ms, 1), "cpu_ref_ms": round(cpu_ref_ms, 1),
            "x_cpu_ref": round(cpu_ms / cpu_ref_ms, 2), "target_ms": TARGET_MS.get(name),
            "rss_loaded_mb": round(rss_loaded, 1),
            "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
            "gpkg_ms": round(statistics.median(gpkg_times[1:] or [math.nan]) * 1000, 1),
            "kml_ms": round(statistics.median(kml_times[1:]) * 1000, 1),
            "x_kml_ref": round(statistics.median(kml_times[1:]) * 1000 / ref_ms, 3)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", choices=CASES)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--gpkg", action="store_true", help="render plan.gpkg too")
    a = ap.parse_args()
    if a.case:
        print(json.dumps(run_case(a.case, a.runs, a.gpkg)))
        return
    cols = ["case", "photos", "plan_ms", "render_ms", "total_ms", "min_ms", "ref_ms", "x_ref", "cpu_ms",
            "cpu_ref_ms", "x_cpu_ref", "target_ms", "rss_loaded_mb", "peak_rss_mb", "output_mb", "gpkg_ms", "kml_ms"]
    print("  ".join(f"{c:>11}" for c in cols))
    for case in CASES:
        out = subprocess.run([sys.executable, __file__, "--case", case, "--runs", str(a.runs)] + (["--gpkg"] if a.gpkg else []),
                             capture_output=True, text=True)
        if out.returncode != 0:
            print(f"{case}: failed\n{out.stderr}", file=sys.stderr)
            continue
        r = json.loads(out.stdout.strip().splitlines()[-1])
        print("  ".join(f"{str(r[c]):>11}" for c in cols), flush=True)


if __name__ == "__main__":
    main()
