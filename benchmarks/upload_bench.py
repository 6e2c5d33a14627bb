"""Upload-and-verify speed of a 704-item mission over MAVLink with `aerosurvey upload`'s defaults.

    python benchmarks/upload_bench.py                  # 704 items, clean and 10 % loss, seed 1
    python benchmarks/upload_bench.py --items 300 --drop 0.2 --seed 4
    python benchmarks/upload_bench.py --sitl           # ArduPilot SITL instead of the fake vehicle
    python benchmarks/upload_bench.py --sitl /path/to/arducopter --sitl-defaults copter.parm
    python benchmarks/upload_bench.py --share          # 200 simulated runs at 10 % and 30 % loss, 2 ms and 100 ms each way
    python benchmarks/upload_bench.py --share --runs 50 --losses 0.3 --latencies 0.1 --jobs 2
    python benchmarks/upload_bench.py --tail --runs 50 --drop 0.3 --jobs 10   # real sockets: median, p90, p95, worst

Every case runs exactly what `aerosurvey upload` runs after its checks, with the command's
defaults: `upload_mission(link, mission, Policy())` (the command's --timeout and --retries
defaults are `Policy()`'s own fields), no policy tuned here. `--items` counts the items on
the wire, home included.

Without --sitl both cases talk to the in-process fake vehicle of the link tests
(tests/link/fake_vehicle.py) on loopback UDP, through aerosurvey's own pymavlink connection
and protocol code: (a) directly, (b) through our UDP relay that drops `--drop` of the
datagrams each way (seeded). The vehicle re-requests a missing item after
`--vehicle-resend` s (ArduPilot: 1 s). Times are wall-clock seconds on this machine in this
run; compare the ratio, not the numbers.

With --sitl the vehicle is ArduPilot's SITL binary (default: arducopter in AEROSURVEY_SITL_BIN),
started in a temporary folder at the mission's home: (a) on its TCP port 5760 + 10·I for the
first instance I ≥ 5 whose ports are free (so that a SITL on the usual 5760, e.g. the
`aerosurvey sitl` harness, is not disturbed), (b) with SERIAL0 sent as UDP to our lossy relay.
A small warm-up upload first absorbs the NO_SPACE that ArduPilot answers right after boot;
the timed run follows. ArduCopter SITL stores at most 650 mission items, home included (it
says "Only 650 items are supported"), so --sitl uses 650 unless --items says otherwise.

With --share: `--runs` uploads and read-backs (default 200) at each loss rate of `--losses`
(default 10 % and 30 %, each way) and each one-way latency of `--latencies` (default 2 ms,
loopback, and 100 ms) on a simulated clock (tests/link/fake_vehicle.py's SimLink, real
MAVLink bytes through aerosurvey's codec) to the fake vehicle with ArduPilot's timers
(re-request after 1 s, cancel after 8 s). Run k uses seed k for both the link and the
mission. It prints a table: the share that ended verified, how the others ended, the
simulated time of an upload and read-back (median, worst), that median against the
protocol's floor (one round trip per item, upload and read-back, and one for MISSION_COUNT
and MISSION_REQUEST_LIST), and the vehicle's error acks (median per run). A run that
returned "verified" while the vehicle's own store differs from the plan is counted
separately and fails the benchmark.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests" / "link"))

from fake_vehicle import FakeVehicle, Faults, LossyRelay, SimLink, VehicleModel, survey_mission  # noqa: E402, I001

from aerosurvey.link import mission_protocol as mp  # noqa: E402
from aerosurvey.link.connection import LinkError, open_link  # noqa: E402
from aerosurvey.link.upload import VerificationFailed, mission_wire_items, upload_mission  # noqa: E402
from aerosurvey.mission.items import Mission  # noqa: E402

#: The SITL binary and its defaults from the same variables as `aerosurvey sitl` (a folder each), if set.
SITL_BIN = str(Path(os.environ.get("AEROSURVEY_SITL_BIN", ".")) / "arducopter")
SITL_DEFAULTS = str(Path(os.environ.get("AEROSURVEY_SITL_DEFAULTS", ".")) / "copter.parm")


def _timed(url: str, mission: Mission, policy: mp.Policy, warm_up: bool) -> tuple[float, object]:
    with open_link(url, 60.0) as link:
        if warm_up:
            upload_mission(link, survey_mission(2), policy)
        t0 = time.perf_counter()
        report = upload_mission(link, mission, policy)
        return time.perf_counter() - t0, report


def _summary(name: str, n_items: int, total: float, report, extra: dict) -> dict:
    up, down = report.mission.stats, report.mission.download_stats
    if not report.mission.verified or down is None:
        raise SystemExit(f"{name}: not verified")
    return {
        "case": name, "items": n_items, "seconds": total, "upload_s": report.mission.seconds,
        "verify_s": report.mission.verify_seconds, "items_per_s": n_items / total,
        "up_resends": up.resends, "up_restarts": up.restarts, "up_repeated_requests": up.duplicate_requests,
        "up_error_acks": len(up.error_acks), "up_ack_lost": up.ack_lost,
        "down_resends": down.resends, "down_restarts": down.restarts, **extra,
    }


def run_fake(name: str, n_items: int, policy: mp.Policy, vehicle_resend: float, drop: float | None, seed: int) -> dict:
    mission = survey_mission(n_items - 6, seed=seed)  # 5 fixed items around the waypoints, and home
    model = VehicleModel(request_resend=vehicle_resend, upload_timeout=8.0)
    with FakeVehicle(model, "udp") as fv, contextlib.ExitStack() as stack:
        relay = stack.enter_context(LossyRelay(fv.port, drop, seed)) if drop is not None else None
        total, report = _timed(relay.url if relay is not None else fv.url, mission, policy, warm_up=False)
    if len(model.stored[0]) != n_items:
        raise SystemExit(f"{name}: the vehicle holds {len(model.stored[0])} items")
    return _summary(name, n_items, total, report, {
        "vehicle_rerequests": model.log.get("request resend", 0),
        "relay": dict(relay.counts) if relay is not None else None})


def _free_instance() -> int:
    """The first SITL instance from 5 on whose TCP ports (5760 + 10·I … +3) nobody listens on."""
    for inst in range(5, 25):
        busy = False
        for port in range(5760 + 10 * inst, 5764 + 10 * inst):
            with socket.socket() as s:
                s.settimeout(0.2)
                busy = busy or s.connect_ex(("127.0.0.1", port)) == 0
        if not busy:
            return inst
    raise SystemExit("no free SITL instance (TCP 5810-6003 all busy)")


@contextlib.contextmanager
def sitl(binary: str, defaults: str | None, home: tuple[float, float, float], serial0: str | None) -> Iterator[int]:
    """Run ArduPilot SITL in a temporary folder; yields its TCP port (unused when serial0 is given)."""
    inst = _free_instance()
    with tempfile.TemporaryDirectory(prefix="aerosurvey-sitl-") as tmp:
        cmd = [binary, "--model", "quad", "--speedup", "1", f"-I{inst}",
               "--home", f"{home[0]:.8f},{home[1]:.8f},{home[2]:.2f},0"]
        if defaults:
            cmd += ["--defaults", defaults]
        if serial0:
            cmd += ["--serial0", serial0]
        with open(Path(tmp) / "sitl.out", "wb") as out:
            proc = subprocess.Popen(cmd, cwd=tmp, stdout=out, stderr=subprocess.STDOUT)
            try:
                port = 5760 + 10 * inst
                if serial0 is None:
                    for _ in range(300):
                        with socket.socket() as s:
                            if s.connect_ex(("127.0.0.1", port)) == 0:
                                break
                        if proc.poll() is not None:
                            raise SystemExit(f"SITL exited at start: {(Path(tmp) / 'sitl.out').read_text()[-500:]}")
                        time.sleep(0.1)
                yield port
            finally:
                proc.terminate()
                try:
                    proc.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait(timeout=10)


def run_sitl(name: str, n_items: int, policy: mp.Policy, drop: float | None, seed: int, binary: str,
             defaults: str | None) -> dict:
    mission = survey_mission(n_items - 6, seed=seed)
    if drop is None:
        with sitl(binary, defaults, mission.home, None) as port:
            total, report = _timed(f"tcp:127.0.0.1:{port}", mission, policy, warm_up=True)
        return _summary(name, n_items, total, report, {"relay": None, "vehicle_rerequests": None})
    with LossyRelay(None, drop, seed) as relay:
        with sitl(binary, defaults, mission.home, f"udpclient:127.0.0.1:{relay.back_port}"):
            total, report = _timed(relay.url, mission, policy, warm_up=True)
        return _summary(name, n_items, total, report, {"relay": dict(relay.counts), "vehicle_rerequests": None})


def _holds_plan(model: VehicleModel, mission: Mission) -> bool:
    """The vehicle's own store against the plan's wire items (command, frame, x, y), home first."""
    wire = mission_wire_items(mission)
    stored = model.stored[0]
    return len(stored) == len(wire) and all(
        (s.command, s.frame, s.x, s.y) == (w.command, w.frame, w.x, w.y) for s, w in zip(stored, wire))


def share_run(args: tuple[int, float, float, int]) -> tuple[str, float, bool, int]:
    """One simulated upload and read-back: (how it ended, simulated seconds, the vehicle holds the plan, error acks)."""
    n_items, drop, latency, seed = args
    mission = survey_mission(n_items - 6, seed=seed)
    model = VehicleModel(request_resend=1.0, upload_timeout=8.0)  # ArduPilot's MissionItemProtocol timers
    link = SimLink(model, Faults(drop=drop, seed=seed), latency=latency)
    try:
        report = upload_mission(link, mission, mp.Policy())  # `aerosurvey upload`'s defaults
        how = "verified" if report.mission.verified else "returned unverified"
    except VerificationFailed:
        how = "verification failed"
    except LinkError as exc:
        text = str(exc)
        how = ("read-back failed" if "not verified" in text or "download" in text else "upload failed")
    acks = sum(k for what, k in model.log.items() if what.startswith("ack ") and "ACCEPTED" not in what)
    return how, link.t, _holds_plan(model, mission), acks


def run_share(n_items: int, drops: list[float], latencies: list[float], runs: int, jobs: int) -> None:
    import concurrent.futures
    import statistics

    print(f"{runs} simulated uploads and read-backs of a {n_items}-item mission (home included) per row, "
          f"`aerosurvey upload`'s defaults ({mp.Policy()}), fake vehicle re-requesting after 1 s and cancelling after 8 s")
    print("| latency each way | loss each way | verified | vehicle holds the plan | median s | worst s | "
          "median / floor | error acks (median) | other ends |")
    print("|---|---|---|---|---|---|---|---|---|")
    bad = 0
    for latency in latencies:
        floor = (2 * n_items + 2) * 2 * latency  # one round trip per item, both ways, and per first step
        for drop in drops:
            tasks = [(n_items, drop, latency, seed) for seed in range(runs)]
            if jobs > 1:
                with concurrent.futures.ProcessPoolExecutor(jobs) as pool:
                    results = list(pool.map(share_run, tasks, chunksize=4))
            else:
                results = [share_run(t) for t in tasks]
            ends: dict[str, int] = {}
            for how, _, holds, _ in results:
                ends[how] = ends.get(how, 0) + 1
                if how == "verified" and not holds:
                    bad += 1
            held = sum(1 for _, _, holds, _ in results if holds)
            verified = ends.pop("verified", 0)
            times = sorted(t for _, t, _, _ in results)
            median = statistics.median(times)
            print(f"| {latency * 1000:g} ms | {drop:.0%} | {verified}/{runs} | {held}/{runs} | {median:.1f} | {times[-1]:.1f} | "
                  f"{median / floor:.2f} | {statistics.median(a for *_, a in results):g} | {dict(sorted(ends.items())) or '-'} |",
                  flush=True)
    if bad:
        raise SystemExit(f"{bad} run(s) reported verified while the vehicle's store differs from the plan")


def tail_run(args: tuple[int, float, float, int]) -> tuple[float, str, int, int, int]:
    """One upload and read-back on real loopback sockets through the lossy relay: (wall seconds, how it
    ended, upload restarts, read-back restarts, whether the final ACK was lost)."""
    n_items, drop, vehicle_resend, seed = args
    try:
        r = run_fake("tail", n_items, mp.Policy(), vehicle_resend, drop, seed)
    except (LinkError, SystemExit) as exc:
        return math.nan, f"failed: {str(exc)[:80]}", 0, 0, 0
    return r["seconds"], "verified", r["up_restarts"], r["down_restarts"], int(r["up_ack_lost"])


def run_tail(n_items: int, drop: float, vehicle_resend: float, runs: int, jobs: int, limit: float) -> None:
    """`runs` uploads and read-backs (seeds 1 … runs) on real sockets through the lossy relay, `jobs` at a
    time: the median, the 90th and 95th percentiles, the worst, and how many took longer than `limit` s."""
    import concurrent.futures
    import statistics

    tasks = [(n_items, drop, vehicle_resend, seed) for seed in range(1, runs + 1)]
    with concurrent.futures.ProcessPoolExecutor(jobs) as pool:
        results = list(pool.map(tail_run, tasks))
    times = sorted(t for t, how, *_ in results if how == "verified")
    failed = [how for _, how, *_ in results if how != "verified"]

    def pct(q: float) -> float:
        return times[min(len(times) - 1, math.ceil(q * len(times)) - 1)] if times else math.nan

    print(f"{runs} uploads and read-backs of {n_items} items on loopback UDP through the relay dropping {drop:.0%} each "
          f"way, `aerosurvey upload`'s defaults, the fake vehicle re-requesting after {vehicle_resend:g} s, {jobs} at a time")
    print(f"verified {len(times)}/{runs}; median {statistics.median(times):.1f} s, p90 {pct(0.9):.1f} s, "
          f"p95 {pct(0.95):.1f} s, worst {times[-1]:.1f} s; over {limit:g} s: {sum(t > limit for t in times)}; "
          f"upload restarts {sum(r[2] for r in results)}, read-back restarts {sum(r[3] for r in results)}, "
          f"final ACK lost {sum(r[4] for r in results)}" + (f"; failed: {failed}" if failed else ""))
    slow = sorted(((t, seed) for (t, how, *_), (*_, seed) in zip(results, tasks) if how == "verified"), reverse=True)[:3]
    print("slowest (s, seed): " + ", ".join(f"{t:.1f} s seed {seed}" for t, seed in slow))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--items", type=int, default=None, help="items on the wire, home included (default 704; 650 with --sitl)")
    ap.add_argument("--drop", type=float, default=0.10, help="share of datagrams the relay drops, each way")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--vehicle-resend", type=float, default=1.0, help="the fake vehicle's re-request interval (s)")
    ap.add_argument("--sitl", nargs="?", const=SITL_BIN, default=None, metavar="ARDUCOPTER",
                    help=f"use ArduPilot SITL (default binary {SITL_BIN})")
    ap.add_argument("--sitl-defaults", default=SITL_DEFAULTS if Path(SITL_DEFAULTS).is_file() else None,
                    help="ArduPilot default parameter file for SITL")
    ap.add_argument("--share", action="store_true", help="the table of --runs simulated runs per loss rate and latency")
    ap.add_argument("--runs", type=int, default=200, help="simulated runs per row for --share")
    ap.add_argument("--losses", default="0.1,0.3", help="loss rates (each way) for --share, comma-separated")
    ap.add_argument("--latencies", default="0.002,0.1", help="one-way latencies (s) for --share, comma-separated")
    ap.add_argument("--jobs", type=int, default=1, help="processes for --share and --tail")
    ap.add_argument("--tail", action="store_true", help="--runs real-socket runs at --drop: the tail of the times")
    ap.add_argument("--limit", type=float, default=60.0, help="--tail counts the runs longer than this (s)")
    args = ap.parse_args()
    if args.tail:
        run_tail(args.items or 704, args.drop, args.vehicle_resend, args.runs, args.jobs, args.limit)
        return
    if args.share:
        run_share(args.items or 704, [float(x) for x in args.losses.split(",")],
                  [float(x) for x in args.latencies.split(",")], args.runs, args.jobs)
        return
    n_items = args.items if args.items is not None else (650 if args.sitl else 704)
    if n_items < 7:
        ap.error("--items must be at least 7")
    if args.sitl and not Path(args.sitl).is_file():
        ap.error(f"--sitl {args.sitl}: no such binary")
    policy = mp.Policy()
    who = (f"ArduPilot SITL {args.sitl} (defaults {args.sitl_defaults})" if args.sitl else
           f"the fake vehicle, re-requesting after {args.vehicle_resend} s")
    print(f"`aerosurvey upload`'s defaults: {policy}; vehicle: {who}")
    try:
        if args.sitl:
            rows = [run_sitl("clean", n_items, policy, None, args.seed, args.sitl, args.sitl_defaults),
                    run_sitl(f"lossy {args.drop:.0%}", n_items, policy, args.drop, args.seed, args.sitl, args.sitl_defaults)]
        else:
            rows = [run_fake("clean", n_items, policy, args.vehicle_resend, None, args.seed),
                    run_fake(f"lossy {args.drop:.0%}", n_items, policy, args.vehicle_resend, args.drop, args.seed)]
    except LinkError as exc:
        raise SystemExit(f"upload failed: {exc}") from None
    for r in rows:
        relay = f", relay forwarded {r['relay']['forwarded']} dropped {r['relay']['dropped']}" if r["relay"] else ""
        rereq = f", vehicle re-requests {r['vehicle_rerequests']}" if r["vehicle_rerequests"] is not None else ""
        print(f"{r['case']:>10}: {r['items']} items uploaded and verified in {r['seconds']:.2f} s "
              f"(upload {r['upload_s']:.2f} s, read back {r['verify_s']:.2f} s) = {r['items_per_s']:.1f} items/s; "
              f"upload resends {r['up_resends']}, restarts {r['up_restarts']}, repeated requests "
              f"{r['up_repeated_requests']}, error acks {r['up_error_acks']}, final ack lost {r['up_ack_lost']}{rereq}; "
              f"download resends {r['down_resends']}, restarts {r['down_restarts']}{relay}")
    print(f"ratio lossy/clean items/s: {rows[1]['items_per_s'] / rows[0]['items_per_s']:.3f}")


if __name__ == "__main__":
    main()
