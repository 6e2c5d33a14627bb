"""A PX4 upload and read-back through MAVSDK's mission_raw plugin against aerosurvey's own protocol.

    python benchmarks/px4_bench.py                       # 400 items, clean and 5 % loss, seeds 1-5
    python benchmarks/px4_bench.py --items 1000 --drop 0.1 --seeds 3
    python benchmarks/px4_bench.py --timeout 0.25        # MAVSDK's (and our ceiling's) answer timeout

Both transports upload the same survey mission (with its fence) to the same in-process fake
vehicle set up as PX4 (tests/link/fake_vehicle.py: re-requests every 250 ms, gives up after 5 s,
PX4's stored form), on loopback UDP, then read it back and compare it: (a) `upload_plan` through
`link.px4.MavsdkTransfers` (what `aerosurvey upload` does for a PX4 plan), (b) `upload_mission`
through aerosurvey's own protocol on a pymavlink link (what it does for ArduPilot), both with the
command's --timeout (default 1 s: MAVSDK waits that long for each answer; ours is the ceiling of
its adaptive resend timer). With `--drop` the fake drops that share of the packets each
way and duplicates as many (seeded per run; the timing of the resends still varies from run to
run, so the same seed does not replay exactly). It prints per transport the runs verified, how
the others ended, and the wall-clock seconds (median, worst) of the verified ones, and the ratio
of the medians MAVSDK / ours: compare that ratio, not the seconds. What it does not cover: a
real PX4 (SITL or hardware), radio latency (loopback answers in well under a millisecond), and
MAVSDK's behaviour against ArduPilot.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests" / "link"))

from fake_vehicle import FakeVehicle, Faults, VehicleModel, survey_mission  # noqa: E402, I001

from aerosurvey.link import mission_protocol as mp  # noqa: E402
from aerosurvey.link.connection import LinkError, open_link  # noqa: E402
from aerosurvey.link.px4 import MavsdkTransfers  # noqa: E402
from aerosurvey.link.upload import VerificationFailed, upload_mission, upload_plan  # noqa: E402


def one(transport: str, items: int, drop: float, seed: int, timeout: float) -> tuple[str, float]:
    m = survey_mission(items - 5, firmware="px4", fence=True, seed=seed)
    model = VehicleModel(px4=True, home=m.home)
    policy = mp.Policy(timeout=timeout)
    with FakeVehicle(model, "udp", Faults(drop=drop, dup=drop, seed=seed)) as fv:
        t0 = time.monotonic()
        try:
            if transport == "mavsdk":
                with open_link(fv.url, policy.silence) as link:
                    vehicle = link.vehicle
                assert vehicle is not None
                t0 = time.monotonic()
                with MavsdkTransfers(fv.url, vehicle, policy.timeout, policy.silence) as transfers:
                    upload_plan(transfers, m)
            else:
                with open_link(fv.url, policy.silence) as link:
                    t0 = time.monotonic()
                    upload_mission(link, m, policy)
        except VerificationFailed as exc:
            return f"verification failed: {str(exc)[:60]}", time.monotonic() - t0
        except LinkError as exc:
            return f"link error: {str(exc)[:60]}", time.monotonic() - t0
        seconds = time.monotonic() - t0
    stored = [(s.x, s.y) for s in model.stored[0]]
    if stored != [(round(it.x * 1e7), round(it.y * 1e7)) for it in m.items]:
        raise SystemExit(f"{transport} seed {seed}: reported verified but the vehicle stores something else")
    return "verified", seconds


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--items", type=int, default=400, help="mission items (PX4 has no home item)")
    ap.add_argument("--drop", type=float, default=0.05, help="share of packets dropped (and duplicated) each way")
    ap.add_argument("--seeds", type=int, default=5, help="runs per case (seeds 1..N)")
    ap.add_argument("--timeout", type=float, default=mp.Policy().timeout, help="the command's --timeout (both transports)")
    args = ap.parse_args()
    for drop in (0.0, args.drop):
        medians = {}
        for transport in ("ours", "mavsdk"):
            runs = [one(transport, args.items, drop, seed, args.timeout) for seed in range(1, args.seeds + 1)]
            ok = [s for how, s in runs if how == "verified"]
            others = [how for how, _ in runs if how != "verified"]
            medians[transport] = statistics.median(ok) if ok else float("nan")
            worst = max(ok) if ok else float("nan")
            print(f"drop {drop:.0%} {transport:6s}: {len(ok)}/{len(runs)} verified, median {medians[transport]:.2f} s, "
                  f"worst {worst:.2f} s" + (f"; others: {others}" if others else ""))
        print(f"drop {drop:.0%} ratio MAVSDK / ours (median): {medians['mavsdk'] / medians['ours']:.2f}")


if __name__ == "__main__":
    main()
