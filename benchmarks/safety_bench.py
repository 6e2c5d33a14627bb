"""No-fly zones and unphotographed ground on a thousand random areas (issue: zone safety).

    python benchmarks/safety_bench.py                 # 1000 cases, seed 1, 2 workers
    python benchmarks/safety_bench.py --n 200 --seed 7 --workers 1
    python benchmarks/safety_bench.py --case 7:123 --keep /tmp/case   # one case (seed:index), files kept

Cases come from tests/zone_cases.py (convex, concave, holed and corridor areas of 0.5-300 ha
at latitudes 0, ±35, ±50, ±65, copters and planes, one to three zones crossing the boundary,
inside or just outside, with and without battery sorties, launch point given or default,
RTL or land). Each is planned through the public entry points (load_spec, plan_mission,
write_outputs) and judged by tests/independent_legs.py, which shares no code with the
planner. Printed: crashes (any exception but the planner's InputError), refusals grouped by
message, plans with a leg inside a zone (legs, files, metres), launch points in a zone,
plans whose .plan fence lacks a zone, plans with unreported ground seen by fewer than two
photos, and reported areas grossly above the measured one. Crashes, zone violations and
unreported gaps must all be 0.

    python benchmarks/safety_bench.py --stress 40     # 40 hard geometries through `aerosurvey plan`

Stress cases (issue: detailed boundaries and limits), four kinds in turn, random sizes: slivers
(1-5 m wide, 5-3,000 km long), multi-part areas with parts 1-6,000 km apart, detailed
boundaries (a 50-500 ha circle of 10,000-400,000 vertices with up to 0.3 m of digitising noise, and a
zone of 20,000 vertices) and
many zones (50-300 small zones over 20-80 ha). Each runs `aerosurvey -q plan` in a fresh
process (timeout 300 s) and is judged from outside: the exit code (0 planned, 1 a failing
error rule, 2 refused), a traceback on stderr, a refusal in more than one line, peak memory
(max RSS from wait4) over 2 GB. Crashes, tracebacks, multi-line refusals and runs over 2 GB
must all be 0.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import traceback
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(REPO / "tests"), str(REPO / "src")]

import zone_cases as zc  # noqa: E402  (the tests' generator and checker, found through sys.path above)


def _params(seed: int, index: int) -> zc.CaseParams:
    return zc.random_params(np.random.default_rng([seed, index]))


def run_one(seed: int, index: int, keep: Path | None = None) -> dict[str, Any]:
    """Plan and check case `index` of `seed`; a plain summary (picklable)."""
    params = _params(seed, index)
    case = zc.make_case(params)
    folder = keep if keep is not None else Path(tempfile.mkdtemp(prefix="safety-"))
    t0 = time.perf_counter()
    res: dict[str, Any] = {"id": f"{seed}:{index}", "vehicle": params.vehicle, "kind": params.kind, "zones": len(case.zones),
                           "describe": case.describe()}
    try:
        o = zc.plan_case(case, folder)
    except Exception as exc:  # noqa: BLE001  (a crash is what is counted here)
        res["crash"] = f"{type(exc).__name__}: {exc}"
        res["trace"] = traceback.format_exc(limit=-3)
        return res
    finally:
        res["seconds"] = time.perf_counter() - t0
        if keep is None:
            shutil.rmtree(folder, ignore_errors=True)
    if o.refused is not None:
        res["refused"] = o.refused
        return res
    legs = o.violating_legs
    res["legs"] = [(leg.file, leg.kind, leg.worst_m) for leg in legs]
    res["margin_legs"] = [(leg.file, leg.kind, leg.in_margin_m) for f in o.files for leg in f.legs
                          if leg.in_margin_m > 0.0 and leg.worst_m == 0.0]
    res["homes_in_zone"] = o.homes_in_zone
    res["files"] = len(o.files)
    res["fence_missing"] = o.fence_missing
    c = o.coverage
    assert c is not None  # a planned case is always measured
    res["gap_samples"] = len(c.gap_samples)
    res["gap_near_zone"] = c.near_zone
    res["unreported"] = c.unreported_count
    res["measured_gap_m2"] = c.measured_gap_m2
    res["reported_m2"] = c.reported_m2
    res["overstated"] = c.grossly_overstated
    res["problems"] = o.problems()
    if o.overstated():
        res["problems"].append(o.overstated())
    return res


def _shape(msg: str) -> str:
    """A refusal's message with its numbers and quoted values masked, to group alike ones."""
    return re.sub(r"-?\d+(\.\d+)?", "#", re.sub(r"\[[^\]]*\]", "[…]", msg))[:160]


def report(results: list[dict[str, Any]], seconds: float, workers: int) -> list[str]:
    planned = [r for r in results if "crash" not in r and "refused" not in r]
    crashes = [r for r in results if "crash" in r]
    refused = [r for r in results if "refused" in r]
    viol = [r for r in planned if r["legs"]]
    home = [r for r in planned if r["homes_in_zone"]]
    fence = [r for r in planned if r["fence_missing"]]
    gaps = [r for r in planned if r["gap_samples"]]
    unrep = [r for r in planned if r["unreported"]]
    over = [r for r in planned if r["overstated"]]
    legs = [leg for r in viol for leg in r["legs"]]
    out = [f"cases {len(results)} (with zones {sum(1 for r in results if r['zones'])}), planned {len(planned)}, "
           f"{seconds:.0f} s wall on {workers} worker(s), {np.mean([r['seconds'] for r in results]):.2f} s per case"]
    out.append(f"CRASHES                       {len(crashes)}")
    for msg, n in Counter(_shape(r["crash"]) for r in crashes).most_common(10):
        out.append(f"    {n:4d}  {msg}")
    out.append(f"refusals (InputError)         {len(refused)}")
    for msg, n in Counter(_shape(r["refused"]) for r in refused).most_common(10):
        out.append(f"    {n:4d}  {msg}")
    out.append(f"ZONE VIOLATIONS (plans)       {len(viol)}   (copter {sum(r['vehicle'] == 'copter' for r in viol)}, "
               f"plane {sum(r['vehicle'] == 'plane' for r in viol)})")
    if legs:
        metres = np.array([m for _, _, m in legs])
        files = {(r["id"], f) for r in viol for f, _, _ in r["legs"]}
        out.append(f"    legs {len(legs)} in {len(files)} files; metres inside: median {np.median(metres):.0f}, max {metres.max():.0f}")
        for kind, n in Counter(k for _, k, _ in legs).most_common():
            plans = sum(1 for r in viol if any(k == kind for _, k, _ in r["legs"]))
            out.append(f"    {kind:12s} {n:5d} legs in {plans} plans, max {max(m for _, k, m in legs if k == kind):.0f} m")
        sortie = {(r["id"], f) for r in viol for f, _, _ in r["legs"] if f.startswith("sortie")}
        out.append(f"    sortie files with a violation: {len(sortie)} in {len({i for i, _ in sortie})} plans")
    margin = [r for r in planned if r.get("margin_legs")]
    kinds = Counter(k for r in margin for _, k, _ in r["margin_legs"]).most_common()
    out.append(f"plans with a leg inside a zone's margin only (information) {len(margin)}   "
               + ", ".join(f"{k} {n} legs" for k, n in kinds))
    out.append(f"HOME IN A ZONE (plans)        {len(home)}   (files {sum(len(r['homes_in_zone']) for r in home)})")
    out.append(f"fence lacks a zone (plans)    {len(fence)}")
    out.append(f"plans with ground seen by < 2 photos   {len(gaps)}   (copter {sum(r['vehicle'] == 'copter' for r in gaps)}, "
               f"plane {sum(r['vehicle'] == 'plane' for r in gaps)}; with gap samples within margin + 50 m of a zone "
               f"{sum(1 for r in gaps if r['gap_near_zone'])}, "
               f"farther away {sum(1 for r in gaps if r['gap_samples'] > r['gap_near_zone'])})")
    out.append(f"UNREPORTED GAPS (plans)       {len(unrep)}" + (
        f"   max {max(r['measured_gap_m2'] for r in unrep):.0f} m², median {np.median([r['measured_gap_m2'] for r in unrep]):.0f} m²"
        if unrep else ""))
    out.append(f"reported > 2x measured + 100 m² (plans)  {len(over)}")
    for title, rows, word in (("crash", crashes, ""), ("violation", viol, "inside zone"), ("home in zone", home, "launch point"),
                              ("unreported gap", unrep, "not reported"), ("overstated", over, "reported as")):
        for r in rows[:3]:
            detail = r.get("crash") or next((p for p in r.get("problems", []) if word in p), "")
            out.append(f"  e.g. {title}: --case {r['id']}  {r['describe']}\n        {detail[:220]}")
    out.append(f"verdict: crashes {len(crashes)}, zone violations {len({r['id'] for r in viol + home})} plans, "
               f"unreported gaps {len(unrep)} plans"
               f" -> {'PASS' if not (crashes or viol or home or unrep) else 'FAIL'}")
    return out


STRESS_KINDS = ("sliver", "far-parts", "detailed", "many-zones")
STRESS_TIMEOUT_S = 300
STRESS_SPEC = """[mission]
name = "stress"
[area]
file = "area.geojson"
exclusions = {zones}
[camera]
model = "sony-a6000-16mm"
[targets]
gsd_cm = {gsd}
forward_overlap = 0.75
side_overlap = 0.6
[vehicle]
type = "{vehicle}"
cruise_speed_ms = {speed}
"""


def _stress_geometry(kind: str, rng: np.random.Generator) -> tuple[list[list[list[list[float]]]], list[list[list[float]]], str]:
    """(area polygons, zone rings, description) in lon/lat for one stress case."""
    lat0 = float(rng.uniform(-60.0, 60.0))
    lon0 = float(rng.uniform(-170.0, 150.0))
    kx, ky = 111_320.0 * max(0.05, np.cos(np.radians(lat0))), 110_574.0

    def ring(x: np.ndarray, y: np.ndarray, lon: float = lon0, lat: float = lat0) -> list[list[float]]:
        pts = np.c_[lon + x / kx, np.clip(lat + y / ky, -89.0, 89.0)].round(9).tolist()
        return pts + [pts[0]]

    def circle(r: float, n: int, wobble: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        a = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
        rr = r + wobble * rng.uniform(-1.0, 1.0, n)
        return rr * np.cos(a), rr * np.sin(a)

    if kind == "sliver":
        w, length = float(rng.uniform(1.0, 5.0)), float(10 ** rng.uniform(np.log10(5e3), np.log10(3e6)))
        ang = rng.uniform(0, np.pi)
        c, s_ = np.cos(ang), np.sin(ang)
        length = min(length, 0.9 * 110_574.0 * (89.0 - abs(lat0)) / max(abs(s_), 1e-3))  # stay off the poles
        x, y = np.array([0.0, length, length, 0.0]), np.array([0.0, 0.0, w, w])
        return [[ring(x * c - y * s_, x * s_ + y * c)]], [], f"sliver {w:.1f} m x {length / 1000:,.0f} km"
    if kind == "far-parts":
        parts = int(rng.integers(2, 5))
        apart = float(10 ** rng.uniform(3.0, np.log10(6e6)))
        polys = []
        for i in range(parts):
            x, y = circle(float(rng.uniform(80.0, 300.0)), 32)
            dlon = i * apart / kx
            polys.append([ring(x, y, ((lon0 + dlon + 180.0) % 360.0) - 180.0, lat0)])
        return polys, [], f"{parts} parts {apart / 1000:,.0f} km apart"
    if kind == "detailed":
        n = int(10 ** rng.uniform(4.0, np.log10(4e5)))
        r = float(np.sqrt(rng.uniform(50e4, 500e4) / np.pi))
        x, y = circle(r, n, wobble=float(rng.uniform(0.0, 0.3)))  # digitising noise of centimetres
        zx, zy = circle(r * 0.1, 20_000)
        return [[ring(x, y)]], [ring(zx + r * 0.3, zy)], f"circle of {n:,} vertices, {np.pi * r * r / 1e4:.0f} ha, a zone of 20,000"
    side = float(np.sqrt(rng.uniform(20e4, 80e4)))
    zones = []
    for _ in range(int(rng.integers(50, 301))):
        zx, zy = circle(float(rng.uniform(1.0, 8.0)), 16)
        zones.append(ring(zx + rng.uniform(10.0, side - 10.0), zy + rng.uniform(10.0, side - 10.0)))
    sq = np.array([0.0, side, side, 0.0]), np.array([0.0, 0.0, side, side])
    return [[ring(*sq)]], zones, f"{len(zones)} zones over {side * side / 1e4:.0f} ha"


def run_stress(seed: int, index: int) -> dict[str, Any]:
    """One stress case through `aerosurvey -q plan` in its own process: exit code, stderr, seconds, peak MB."""
    import json

    rng = np.random.default_rng([seed, index, 22])
    kind = STRESS_KINDS[index % len(STRESS_KINDS)]
    polys, zones, describe = _stress_geometry(kind, rng)
    folder = Path(tempfile.mkdtemp(prefix="stress-"))
    try:
        area = {"type": "MultiPolygon", "coordinates": polys} if len(polys) > 1 else {"type": "Polygon", "coordinates": polys[0]}
        (folder / "area.geojson").write_text(json.dumps(area))
        names = []
        for i, z in enumerate(zones):
            (folder / f"zone{i}.geojson").write_text(json.dumps({"type": "Polygon", "coordinates": [z]}))
            names.append(f"zone{i}.geojson")
        vehicle = str(rng.choice(["copter", "plane"]))
        (folder / "spec.toml").write_text(STRESS_SPEC.format(
            zones=json.dumps(names), gsd=round(float(rng.uniform(1.5, 2.8)), 2), vehicle=vehicle,
            speed=12.0 if vehicle == "copter" else 20.0))
        cmd = [sys.executable, "-c", "from aerosurvey.cli import main; main()", "-q", "plan", str(folder / "spec.toml"),
               "-o", str(folder / "out")]
        t0 = time.perf_counter()
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        timer = threading.Timer(STRESS_TIMEOUT_S, proc.kill)
        timer.start()
        assert proc.stderr is not None
        err = proc.stderr.read()  # until the process ends (or is killed at the timeout)
        _, status, usage = os.wait4(proc.pid, 0)
        timer.cancel()
        seconds = time.perf_counter() - t0
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    code = os.waitstatus_to_exitcode(status)
    return {"id": f"{seed}:{index}", "kind": kind, "describe": describe, "exit": code,
            "timed_out": seconds >= STRESS_TIMEOUT_S and code < 0, "stderr": err.decode(errors="replace").strip(),
            "seconds": seconds, "rss_mb": usage.ru_maxrss / 1024.0}


def stress_report(results: list[dict[str, Any]], seconds: float, workers: int) -> list[str]:
    out = [f"stress cases {len(results)}, {seconds:.0f} s wall on {workers} worker(s)"]
    bad: dict[str, list[dict[str, Any]]] = {"CRASHES (exit not 0/1/2)": [], "TRACEBACKS": [], "MULTI-LINE REFUSALS": [],
                                            "OVER 2 GB": [], "TIMED OUT": []}
    for r in results:
        lines = r["stderr"].splitlines()
        if r["exit"] not in (0, 1, 2) and not r["timed_out"]:
            bad["CRASHES (exit not 0/1/2)"].append(r)
        if "Traceback" in r["stderr"]:
            bad["TRACEBACKS"].append(r)
        if r["exit"] == 2 and len(lines) != 1:
            bad["MULTI-LINE REFUSALS"].append(r)
        if r["rss_mb"] > 2048:
            bad["OVER 2 GB"].append(r)
        if r["timed_out"]:
            bad["TIMED OUT"].append(r)
    for kind in STRESS_KINDS:
        rows = [r for r in results if r["kind"] == kind]
        if rows:
            out.append(f"  {kind:11s} {len(rows):3d} cases: planned {sum(r['exit'] == 0 for r in rows)}, rule failing (exit 1) "
                       f"{sum(r['exit'] == 1 for r in rows)}, refused {sum(r['exit'] == 2 for r in rows)}; "
                       f"seconds max {max(r['seconds'] for r in rows):.1f}, peak MB max {max(r['rss_mb'] for r in rows):.0f}")
    refusals = Counter(_shape(r["stderr"]) for r in results if r["exit"] == 2)
    out.append("refusals by message:")
    out += [f"    {n:4d}  {msg}" for msg, n in refusals.most_common(12)]
    for title, rows in bad.items():
        out.append(f"{title:28s} {len(rows)}")
        for r in rows[:3]:
            out.append(f"  e.g. --stress case {r['id']} ({r['describe']}): exit {r['exit']}, {r['seconds']:.0f} s, "
                       f"{r['rss_mb']:.0f} MB, {r['stderr'][-300:]!r}")
    out.append("verdict: " + ("PASS" if not any(bad.values()) else "FAIL"))
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=1000, help="number of cases (default 1000)")
    ap.add_argument("--seed", type=int, default=1, help="seed of the case generator (default 1)")
    ap.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    ap.add_argument("--case", help="run one case, SEED:INDEX, and print all its problems")
    ap.add_argument("--keep", type=Path, help="with --case: write the case's spec and plan files here")
    ap.add_argument("--stress", type=int, metavar="N", help="run N stress cases (slivers, far parts, detailed boundaries, "
                    "many zones) through `aerosurvey plan` instead")
    args = ap.parse_args()
    if args.stress:
        t0 = time.perf_counter()
        if args.workers > 1:
            with ProcessPoolExecutor(args.workers) as pool:
                stress = list(pool.map(run_stress, [args.seed] * args.stress, range(args.stress)))
        else:
            stress = [run_stress(args.seed, i) for i in range(args.stress)]
        print("\n".join(stress_report(stress, time.perf_counter() - t0, args.workers)))
        return 0
    if args.case:
        seed, index = (int(v) for v in args.case.split(":"))
        r = run_one(seed, index, args.keep)
        print(r["describe"])
        for key in ("crash", "trace", "refused"):
            if key in r:
                print(f"{key}: {r[key]}")
        for p in r.get("problems", []):
            print("  " + p)
        return 0
    t0 = time.perf_counter()
    results: list[dict[str, Any]] = []
    if args.workers > 1:
        with ProcessPoolExecutor(args.workers) as pool:
            futures = [pool.submit(run_one, args.seed, i) for i in range(args.n)]
            for k, f in enumerate(futures, start=1):
                results.append(f.result())
                if k % 50 == 0:
                    print(f"  {k}/{args.n} cases, {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    else:
        for i in range(args.n):
            results.append(run_one(args.seed, i))
    print("\n".join(report(results, time.perf_counter() - t0, args.workers)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
