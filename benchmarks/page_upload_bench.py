"""Upload from the page (`serve --connect`, POST /api/plans/{pid}/vehicle/{name} {"send": true} as a job, waited
for as the page polls it) against `aerosurvey upload` (in process, the same checks and transfers), both to the fake
vehicle as an ArduPilot copter behind a UDP relay that drops a share of the datagrams each way.

Each run pairs one CLI upload and one page upload of the same mission through a relay with the same seed, in
alternating order; each is timed from the request to the verified report (the checks, the connection, the upload
and the read-back). Prints each pair and the medians: the page's target is the CLI's time + 1 s.

    python benchmarks/page_upload_bench.py [--runs 5] [--drop 0.1] [--gsd 1.0]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(REPO / "tests"), str(REPO / "tests" / "link")]

from click.testing import CliRunner  # noqa: E402
from fake_vehicle import FakeVehicle, LossyRelay, VehicleModel  # noqa: E402

from aerosurvey.cli import main  # noqa: E402
from aerosurvey.mission.formats.qgc_plan import loads_plan  # noqa: E402
from conftest import make_spec  # noqa: E402  (the tests' spec writer)

with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    from starlette.testclient import TestClient

AREA = [[15.000, 49.400], [15.012, 49.400], [15.012, 49.4045], [15.000, 49.4045], [15.000, 49.400]]


def cli_upload(plan: Path, url: str) -> float:
    t0 = time.perf_counter()
    res = CliRunner().invoke(main, ["upload", str(plan), "--connect", url])
    took = time.perf_counter() - t0
    assert res.exit_code == 0 and "verified:" in res.output, res.output
    return took


def page_upload(c: TestClient, pid: str) -> float:
    t0 = time.perf_counter()
    r = c.post(f"/api/plans/{pid}/vehicle/mission.plan", json={"send": True})
    job = r.json()["job"]
    while True:
        st = c.get(f"/api/jobs/{job}?wait=0.25").json()  # as the page polls
        if st["state"] not in ("queued", "running"):
            break
    took = time.perf_counter() - t0
    assert st["state"] == "done" and st["result"]["verified"], st
    return took


def main_() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--drop", type=float, default=0.1)
    ap.add_argument("--gsd", type=float, default=1.0)
    args = ap.parse_args()
    from aerosurvey.web.app import create_app

    with tempfile.TemporaryDirectory() as tmp_s:
        tmp = Path(tmp_s)
        spec = make_spec(tmp, {"targets": {"gsd_cm": args.gsd}}, area=AREA)
        res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(tmp / "out")])
        assert res.exit_code == 0, res.output
        plan = tmp / "out" / "mission.plan"
        home = loads_plan(plan.read_text(), str(plan)).home
        cli_s, page_s = [], []
        for run in range(args.runs):
            model = VehicleModel(storage="ardupilot", home=home)
            with FakeVehicle(model, "udp") as fv:
                with LossyRelay(fv.port, drop=args.drop, seed=run) as relay, \
                        TestClient(create_app(spec, vehicle=relay.url)) as c:
                    pid = c.post("/api/plan", json={"spec": c.get("/api/state").json()["spec"]}).json()["job"]
                    while (st := c.get(f"/api/jobs/{pid}?wait=2").json())["state"] in ("queued", "running"):
                        pass
                    pid = st["result"]["plan_id"]
                    if run % 2 == 0:
                        page = page_upload(c, pid)
                    with LossyRelay(fv.port, drop=args.drop, seed=run) as relay2:
                        cli = cli_upload(plan, relay2.url)
                    if run % 2 == 1:
                        page = page_upload(c, pid)
            cli_s.append(cli)
            page_s.append(page)
            print(f"run {run}: {len(model.stored[0])} items held; CLI {cli:.2f} s, page {page:.2f} s, "
                  f"page - CLI {page - cli:+.2f} s", flush=True)
        print(f"median of {args.runs} at {args.drop:.0%} loss: CLI {statistics.median(cli_s):.2f} s, page "
              f"{statistics.median(page_s):.2f} s, page - CLI {statistics.median(p - c for p, c in zip(page_s, cli_s)):+.2f} s; "
              f"worst page - CLI {max(p - c for p, c in zip(page_s, cli_s)):+.2f} s")


if __name__ == "__main__":
    main_()
