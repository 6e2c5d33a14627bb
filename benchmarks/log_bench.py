"""DataFlash reading speed: pymavlink's DFReader against aerosurvey's reader, same log, same run.

    python benchmarks/log_bench.py                  # the committed SITL log, concatenated to >= 100 MB
    python benchmarks/log_bench.py --log FLIGHT.BIN --min-mb 150

A log of N flights back to back is itself a valid DataFlash log (each repeats its FMT
messages). Each reader runs in its own process so that its peak memory is its own.
pymavlink reads every message (recv_msg); ours scans every message and decodes the CAM,
GPS and ATT columns.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def run_pymavlink(path: str) -> int:
    from pymavlink import DFReader

    r = DFReader.DFReader_binary(path)
    n = 0
    while r.recv_msg() is not None:
        n += 1
    return n


def run_ours(path: str) -> int:
    from aerosurvey.flight.dataflash import DataFlashLog

    with DataFlashLog(path) as log:
        n = sum(log.counts().values())
        for name in ("CAM", "GPS", "ATT"):
            log.messages(name)
    return n


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--log", default=str(REPO / "tests" / "data" / "sitl_copter_survey.bin"))
    ap.add_argument("--min-mb", type=float, default=100.0)
    ap.add_argument("--child", choices=["pymavlink", "ours"])
    a = ap.parse_args()
    if a.child:
        t = time.perf_counter()
        n = (run_pymavlink if a.child == "pymavlink" else run_ours)(a.log)
        print(json.dumps({"messages": n, "seconds": time.perf_counter() - t,
                          "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
        return
    src = Path(a.log).read_bytes()
    copies = max(1, int(a.min_mb * 1e6 // len(src)) + 1)
    with tempfile.TemporaryDirectory() as td:
        big = Path(td) / "big.bin"
        with open(big, "wb") as fh:
            for _ in range(copies):
                fh.write(src)
        mb = big.stat().st_size / 1e6
        print(f"log: {copies} x {Path(a.log).name} = {mb:.1f} MB")
        res = {}
        for kind in ("pymavlink", "ours"):
            p = subprocess.run([sys.executable, __file__, "--child", kind, "--log", str(big)], capture_output=True,
                               text=True, check=True)
            res[kind] = json.loads(p.stdout.strip().splitlines()[-1])
        for kind, r in res.items():
            print(f"{kind:>9}: {r['messages']} messages in {r['seconds']:.2f} s = {r['messages'] / r['seconds']:,.0f} msg/s, "
                  f"{mb / r['seconds']:.1f} MB/s, peak RSS {r['peak_rss_mb']:.0f} MB")
        print(f"throughput ratio ours / pymavlink: {res['pymavlink']['seconds'] / res['ours']['seconds']:.1f}x")


if __name__ == "__main__":
    main()
