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
"""

from __future__ import annotations

import argparse
import re
import shutil
import sys
import tempfile
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


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=1000, help="number of cases (default 1000)")
    ap.add_argument("--seed", type=int, default=1, help="seed of the case generator (default 1)")
    ap.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    ap.add_argument("--case", help="run one case, SEED:INDEX, and print all its problems")
    ap.add_argument("--keep", type=Path, help="with --case: write the case's spec and plan files here")
    args = ap.parse_args()
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
