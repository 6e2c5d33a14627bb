"""Upload-and-verify speed of a 700-item mission over MAVLink, clean and through a lossy link.

    python benchmarks/upload_bench.py                  # 700 items, 10 % loss, seed 1
    python benchmarks/upload_bench.py --items 300 --drop 0.2 --seed 4

Both cases talk to the in-process fake vehicle of the link tests (tests/link/fake_vehicle.py)
on loopback UDP, through aerosurvey's own pymavlink connection and protocol code:
(a) directly, (b) through our UDP relay that drops `--drop` of the datagrams each way (seeded).
The vehicle re-requests a missing item after `--vehicle-resend` s (ArduPilot: 1 s), so a lost
request costs that long. Each case must upload, read back and match; the run fails otherwise.
Times are wall-clock seconds on this machine in this run; compare the ratio, not the numbers.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests" / "link"))

from aerosurvey.link import mission_protocol as mp  # noqa: E402
from aerosurvey.link.connection import open_link  # noqa: E402
from aerosurvey.link.upload import upload_mission  # noqa: E402
from fake_vehicle import FakeVehicle, LossyRelay, VehicleModel, survey_mission  # noqa: E402


def run_case(name: str, n_items: int, policy: mp.Policy, vehicle_resend: float, drop: float | None, seed: int) -> dict:
    mission = survey_mission(n_items - 5, seed=seed)  # 5 fixed items around the waypoints
    assert len(mission.items) == n_items
    model = VehicleModel(request_resend=vehicle_resend, upload_timeout=8.0)
    with FakeVehicle(model, "udp") as fv:
        relay = LossyRelay(fv.port, drop, seed) if drop is not None else None
        url = relay.url if relay is not None else fv.url
        if relay is not None:
            relay.__enter__()
        try:
            with open_link(url, 10.0) as link:
                t0 = time.perf_counter()
                report = upload_mission(link, mission, policy)
                total = time.perf_counter() - t0
        finally:
            if relay is not None:
                relay.__exit__(None, None, None)
    if not report.mission.verified or len(model.stored[0]) != n_items + 1:
        raise SystemExit(f"{name}: not verified")
    up, down = report.mission.stats, report.mission.download_stats
    assert down is not None
    return {
        "case": name, "items": n_items, "seconds": total, "upload_s": report.mission.seconds,
        "verify_s": report.mission.verify_seconds, "items_per_s": n_items / total,
        "up_resends": up.resends, "up_restarts": up.restarts, "up_repeated_requests": up.duplicate_requests,
        "up_error_acks": len(up.error_acks), "up_ack_lost": up.ack_lost,
        "vehicle_rerequests": model.log.get("request resend", 0),
        "down_resends": down.resends, "down_restarts": down.restarts,
        "relay": dict(relay.counts) if relay is not None else None,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--items", type=int, default=700, help="mission items (home is sent as one more)")
    ap.add_argument("--drop", type=float, default=0.10, help="share of datagrams the relay drops, each way")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--timeout", type=float, default=0.2, help="our resend interval (s)")
    ap.add_argument("--retries", type=int, default=10,
                    help="unanswered resends in a row before giving up; at 10 %% loss each way an exchange fails "
                         "19 %% of the time, so 700 x 0.19^(retries+1) is the chance a transfer gives up")
    ap.add_argument("--vehicle-resend", type=float, default=1.0, help="the vehicle's re-request interval (s)")
    args = ap.parse_args()
    if args.items < 6:
        ap.error("--items must be at least 6")
    policy = mp.Policy(timeout=args.timeout, retries=args.retries, restarts=5, busy_wait=1.0)
    print(f"policy: resend after {policy.timeout} s, {policy.retries} retries, {policy.restarts} restarts; "
          f"vehicle re-requests after {args.vehicle_resend} s")
    rows = [run_case("clean", args.items, policy, args.vehicle_resend, None, args.seed),
            run_case(f"lossy {args.drop:.0%}", args.items, policy, args.vehicle_resend, args.drop, args.seed)]
    for r in rows:
        relay = f", relay forwarded {r['relay']['forwarded']} dropped {r['relay']['dropped']}" if r["relay"] else ""
        print(f"{r['case']:>10}: {r['items']} items uploaded and verified in {r['seconds']:.2f} s "
              f"(upload {r['upload_s']:.2f} s, read back {r['verify_s']:.2f} s) = {r['items_per_s']:.0f} items/s; "
              f"upload resends {r['up_resends']}, restarts {r['up_restarts']}, repeated requests "
              f"{r['up_repeated_requests']}, error acks {r['up_error_acks']}, final ack lost {r['up_ack_lost']}, vehicle re-requests "
              f"{r['vehicle_rerequests']}; download resends {r['down_resends']}, restarts {r['down_restarts']}{relay}")
    print(f"ratio lossy/clean items/s: {rows[1]['items_per_s'] / rows[0]['items_per_s']:.3f}")


if __name__ == "__main__":
    main()
