"""The page's re-plan latency: a spec change through the JSON API against the same plan
made by the library directly, in the same process and run.

    python benchmarks/web_bench.py [--repeat 5]

For each example mission: the median wall time of `plan_mission` + `render_outputs` (what
the CLI does before writing files) and of POST /api/plan → job done (what the page waits
for after a change: planning, rendering, control points, map layers, JSON), and their
ratio; then two plans submitted at once against the same two one after the other.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
MISSIONS = ["obratan-72ha", "kubad-abad-fixed-wing", "forest-dem", "road-corridor"]


def _direct(spec_path: Path) -> float:
    from aerosurvey.inputs import plan_from_files
    from aerosurvey.outputs import render_outputs
    from aerosurvey.spec import load_spec

    t = time.perf_counter()
    loaded = load_spec(spec_path)
    render_outputs(plan_from_files(loaded), loaded)
    return time.perf_counter() - t


def _via_api(c, spec: dict) -> tuple[float, dict]:
    t = time.perf_counter()
    job = c.post("/api/plan", json={"spec": spec}).json()["job"]
    while True:
        st = c.get(f"/api/jobs/{job}?wait=5").json()
        if st["state"] not in ("queued", "running"):
            break
    if st["state"] != "done":
        raise SystemExit(f"plan failed: {st['error']}")
    return time.perf_counter() - t, st


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        from starlette.testclient import TestClient
    from aerosurvey.web.app import create_app

    print(f"{'mission':24s} {'photos':>6s} {'library s':>9s} {'page s':>7s} {'ratio':>6s} {'result MB':>9s}")
    for name in MISSIONS:
        spec_path = REPO / "missions" / f"{name}.toml"
        direct = [_direct(spec_path) for _ in range(args.repeat)]
        with TestClient(create_app(spec_path)) as c:
            spec = c.get("/api/state").json()["spec"]
            runs = [_via_api(c, spec) for _ in range(args.repeat)]
        web = [t for t, _ in runs]
        st = runs[-1][1]
        size = len(json.dumps(st["result"])) / 1e6
        print(f"{name:24s} {st['result']['summary']['photos']:6d} {statistics.median(direct):9.3f} "
              f"{statistics.median(web):7.3f} {statistics.median(web) / statistics.median(direct):6.2f} {size:9.2f}")
    spec_path = REPO / "missions" / "obratan-72ha.toml"
    with TestClient(create_app(spec_path, workers=2)) as c:
        a = c.get("/api/state").json()["spec"]
        b = json.loads(json.dumps(a))
        b["targets"]["side_overlap"] = 0.7
        t = time.perf_counter()
        for s in (a, b):
            _via_api(c, s)
        one_by_one = time.perf_counter() - t
        t = time.perf_counter()
        jobs = [c.post("/api/plan", json={"spec": s}).json()["job"] for s in (a, b)]
        for j in jobs:
            while c.get(f"/api/jobs/{j}?wait=5").json()["state"] in ("queued", "running"):
                pass
        together = time.perf_counter() - t
    print(f"two Obrataň plans: one after the other {one_by_one:.2f} s, at once {together:.2f} s "
          f"(ratio {together / one_by_one:.2f}; threads share the GIL)")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
