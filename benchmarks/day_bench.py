"""A day of flights against the same records ingested one at a time: is one `log ingest` of N
records as quick as N single ingests?

    python benchmarks/day_bench.py                 # 5 records of a ~150 ha plan, best of 3
    python benchmarks/day_bench.py --records 3 --repeat 1 --scale 2

The plan is the tests' 17 ha rectangle (tests/conftest.py's make_spec) grown `--scale` times on
each side, with a battery that splits it into sorties; its stations are dealt in flight order to
`--records` DataFlash logs written by the tests' own writer (tests/flight/dfwriter.py), each with a
photo at every station it holds. Each way is timed as the user runs it, one `aerosurvey` process
per command (its start-up included): the day as one `log ingest R1 … RN --plan PLAN -o DAY`, and
the N single `log ingest Rk --plan PLAN -o OUTk`; then both in this process through the library
(flight/day.py's ingest_day + write_day against flight/ingest.py's ingest + write_ingest per
record), where start-up and the plan's reading are not repeated per command. The figures are the
ratios day / sum of singles (the day also measures the union per sortie and whole); printed,
never asserted.

Measured on the shared 2-core machine (28 Nov 2026, default options: 1173 stations, 18 sorties,
152 ha, 5 records of ~234 photos, best of 3): the day 3.28 s against 13.46 s for the 5 commands
(ratio 0.24); in process 0.49 s against 1.49 s (ratio 0.33: each single reads the plan again).
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(REPO / "tests"), str(REPO / "tests" / "flight")]

from dfwriter import camera_log  # noqa: E402

from conftest import make_spec  # noqa: E402  (the tests' spec writer, found through sys.path above)

AEROSURVEY = [sys.executable, "-m", "aerosurvey.cli"]


def _run(args: list[str]) -> float:
    t = time.perf_counter()
    res = subprocess.run([*AEROSURVEY, *args], capture_output=True, text=True)
    took = time.perf_counter() - t
    if res.returncode != 0:
        raise SystemExit(f"aerosurvey {' '.join(args[:2])} failed ({res.returncode}): {res.stderr[-2000:]}")
    return took


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--records", type=int, default=5)
    ap.add_argument("--scale", type=float, default=3.0, help="the test rectangle grown this many times on each side")
    ap.add_argument("--repeat", type=int, default=3, help="runs of each way; the best is kept")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        w, h = 0.006 * a.scale, 0.0035 * a.scale
        ring = [[15.0, 49.4], [15.0 + w, 49.4], [15.0 + w, 49.4 + h], [15.0, 49.4 + h], [15.0, 49.4]]
        spec = make_spec(tmp, {"flight": {"heading": 0.0}, "battery": {"usable_min": 12.0}}, area=ring)
        plan = tmp / "plan"
        _run(["plan", str(spec), "-o", str(plan)])
        m = json.loads((plan / "manifest.json").read_text())
        rows = m["stations"]
        n = len(rows)
        logs = []
        for k in range(a.records):
            part = rows[k * n // a.records:(k + 1) * n // a.records]
            p = tmp / f"R{k + 1}.bin"
            p.write_bytes(camera_log([(2.0 * t, s["lat"], s["lon"], 400.0, s["alt_rel_m"]) for t, s in enumerate(part)]))
            logs.append(str(p))
        days, singles = [], []
        for r in range(a.repeat):
            days.append(_run(["log", "ingest", *logs, "--plan", str(plan), "-o", str(tmp / f"day{r}")]))
            singles.append(sum(_run(["log", "ingest", p, "--plan", str(plan), "-o", str(tmp / f"one{r}-{k}")])
                               for k, p in enumerate(logs)))
        day, single = min(days), min(singles)
        lib_day, lib_single = _in_process(plan, [Path(p) for p in logs], tmp, a.repeat)
        print(f"plan: {n} stations, {len(m['sorties'])} sorties, {m['derived']['area_ha']:.0f} ha; {a.records} records "
              f"of ~{n // a.records} photos; best of {a.repeat} (median day {statistics.median(days):.2f} s)")
        print(f"day of {a.records} records in one `log ingest`: {day:.2f} s")
        print(f"{a.records} single `log ingest`s, summed:      {single:.2f} s")
        print(f"ratio day / sum of singles: {day / single:.2f}")
        print(f"in process: the day {lib_day:.2f} s, the singles summed {lib_single:.2f} s, "
              f"ratio {lib_day / lib_single:.2f}")


def _in_process(plan: Path, logs: list[Path], tmp: Path, repeat: int) -> tuple[float, float]:
    """(best day, best sum of singles) through the library, the plan read once per way and run."""
    from aerosurvey.flight.day import ingest_day, write_day
    from aerosurvey.flight.ingest import ingest, write_ingest
    from aerosurvey.rules.planview import PlanView

    days, singles = [], []
    for r in range(repeat):
        t = time.perf_counter()
        view = PlanView.from_outdir(plan, "--plan")
        write_day(ingest_day(logs, view), tmp / f"lib-day{r}")
        days.append(time.perf_counter() - t)
        t = time.perf_counter()
        for k, p in enumerate(logs):
            write_ingest(ingest(p, PlanView.from_outdir(plan, "--plan")), tmp / f"lib-one{r}-{k}")
        singles.append(time.perf_counter() - t)
    return min(days), min(singles)


if __name__ == "__main__":
    main()
