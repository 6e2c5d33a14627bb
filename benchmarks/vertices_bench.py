"""Plan time and peak memory against the number of boundary vertices (issue: detailed boundaries).

    python benchmarks/vertices_bench.py                     # 64, 1,000, 20,000 and 400,000 vertices
    python benchmarks/vertices_bench.py --vertices 64 5000 --repeat 3

The same 380 ha circle (49.43 N, 14.96 E) is drawn with n vertices and planned by `aerosurvey
plan` (a copter, 2.5 cm GSD, 75/60 % overlap, one pass, a 30 min battery), each run a fresh
process whose wall time and peak memory (max RSS, from wait4) are its own: the whole command,
reading the GeoJSON, planning and writing every file. Each case is run --repeat times and its
fastest run kept (the machine is shared); the ratios are against the 64-vertex case of the same
run. Targets: time within 2x, memory within 1.5x of the 64-vertex case. The CPU time (user +
system, from wait4) is printed beside the wall time: on a machine shared with other work it moves
much less. Printed also: the
vertices the manifest reports before and after simplification, and the exit code with the last
line of stderr for a refused plan.

Not covered: boundaries with many holes or many parts, zones with many vertices (the random
areas of benchmarks/safety_bench.py have them), the web page.
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

LAT0, LON0, HECTARES = 49.43, 14.96, 380.0
SPEC = """[mission]
name = "circle-{n}"
crs = "auto"

[area]
file = "circle-{n}.geojson"

[camera]
model = "sony-a6000-16mm"

[targets]
gsd_cm = 2.5
forward_overlap = 0.75
side_overlap = 0.60
images_beyond_boundary = 2

[vehicle]
type = "copter"
cruise_speed_ms = 10.0

[battery]
usable_min = 30.0
"""


def write_case(n: int, folder: Path) -> Path:
    """The circle's GeoJSON (lon/lat from a local equirectangular scale) and its spec; the spec's path."""
    r = math.sqrt(HECTARES * 1e4 / math.pi)
    kx, ky = 111_320.0 * math.cos(math.radians(LAT0)), 110_574.0
    ring = [[round(LON0 + r * math.cos(2 * math.pi * i / n) / kx, 9), round(LAT0 + r * math.sin(2 * math.pi * i / n) / ky, 9)]
            for i in range(n)]
    ring.append(ring[0])
    (folder / f"circle-{n}.geojson").write_text(json.dumps({"type": "Polygon", "coordinates": [ring]}))
    spec = folder / f"circle-{n}.toml"
    spec.write_text(SPEC.format(n=n))
    return spec


def run_plan(spec: Path, out: Path) -> dict[str, object]:
    """`aerosurvey plan` in a fresh process: wall and CPU seconds, peak RSS (MB), exit code, last stderr
    line, the manifest's simplification."""
    cmd = [sys.executable, "-c", "from aerosurvey.cli import main; main()", "-q", "plan", str(spec), "-o", str(out)]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    assert proc.stderr is not None
    err = proc.stderr.read().decode()
    _, status, usage = os.wait4(proc.pid, 0)
    seconds = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    simp = None
    if (out / "manifest.json").exists():
        simp = json.loads((out / "manifest.json").read_text())["derived"].get("simplification")
    return {"seconds": seconds, "cpu_s": usage.ru_utime + usage.ru_stime, "rss_mb": usage.ru_maxrss / 1024.0, "exit": proc.returncode,
            "last": err.strip().splitlines()[-1] if err.strip() else "", "simplification": simp}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--vertices", type=int, nargs="+", default=[64, 1_000, 20_000, 400_000])
    ap.add_argument("--repeat", type=int, default=2, help="runs per case, the fastest kept (default 2)")
    args = ap.parse_args()
    counts = [64] + [n for n in args.vertices if n != 64]
    rows = []
    with tempfile.TemporaryDirectory(prefix="vertices-bench-") as tmp:
        for n in counts:
            spec = write_case(n, Path(tmp))
            runs = [run_plan(spec, Path(tmp) / f"out-{n}-{k}") for k in range(args.repeat)]
            best = min(runs, key=lambda r: float(r["seconds"]))  # type: ignore[arg-type]
            best["rss_mb"] = max(float(r["rss_mb"]) for r in runs)  # type: ignore[arg-type]
            best["cpu_s"] = min(float(r["cpu_s"]) for r in runs)  # type: ignore[arg-type]
            rows.append((n, best))
    base = rows[0][1]
    print(f"{'vertices':>9} {'seconds':>8} {'x time':>7} {'cpu s':>6} {'x cpu':>6} {'peak MB':>8} {'x mem':>6} {'exit':>4}  "
          "vertices planned / note")
    worst_t = worst_m = 0.0
    for n, r in rows:
        rt = float(r["seconds"]) / float(base["seconds"])  # type: ignore[arg-type]
        rm = float(r["rss_mb"]) / float(base["rss_mb"])  # type: ignore[arg-type]
        rc = float(r["cpu_s"]) / float(base["cpu_s"])  # type: ignore[arg-type]
        worst_t, worst_m = max(worst_t, rt), max(worst_m, rm)
        simp = r["simplification"]
        note = (f"{simp['area_vertices'][0]:,} -> {simp['area_vertices'][1]:,} (tolerance {simp['tolerance_m']} m)"
                if isinstance(simp, dict) else str(r["last"]))
        print(f"{n:>9,} {float(r['seconds']):8.2f} {rt:7.2f} {float(r['cpu_s']):6.2f} {rc:6.2f} "  # type: ignore[arg-type]
              f"{float(r['rss_mb']):8.0f} {rm:6.2f} {r['exit']:>4}  {note}")  # type: ignore[arg-type]
    ok = worst_t <= 2.0 and worst_m <= 1.5
    print(f"worst ratios: time {worst_t:.2f}x (target 2), memory {worst_m:.2f}x (target 1.5) -> {'PASS' if ok else 'FAIL'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
