"""Shrink a SITL DataFlash log for committing: keep some message types, byte for byte.

    python tests/data/shrink_log.py IN.BIN OUT.bin [--every ATT=5 --every GPS=2]

Keeps every message of the types in KEEP, and every n-th message of the types given with
--every (any type, kept or not), in their original order. Everything
the simulator adds (SIM, SIM2, ESC, IMU, ...) is left out. This is how the logs in this
folder were made from the logs `aerosurvey sitl fly` copied.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from aerosurvey.flight.dataflash import DataFlashLog

KEEP = ("FMT", "FMTU", "MULT", "UNIT", "PARM", "GPS", "CAM", "TRIG", "MODE", "CMD", "BAT", "MSG", "ARM", "EV", "POS")


def shrink(src: Path, dst: Path, every: dict[str, int]) -> dict[str, int]:
    kept: list[int] = []
    counts: dict[str, int] = {}
    with DataFlashLog(src) as log:
        for t, offs in log.offsets.items():
            name = log.formats[t].name if t in log.formats else "FMT"
            step = every.get(name, 1 if name in KEEP else 0)
            if step:
                chosen = offs[::step]
                counts[name] = len(chosen)
                kept.extend(chosen)
        dst.write_bytes(b"".join(log.record(o) for o in sorted(kept)))
    return counts


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("src", type=Path)
    ap.add_argument("dst", type=Path)
    ap.add_argument("--every", action="append", default=[], metavar="TYPE=N")
    args = ap.parse_args()
    every = {k: int(v) for k, v in (e.split("=", 1) for e in args.every)}
    counts = shrink(args.src, args.dst, every)
    print(f"{args.dst}: {args.dst.stat().st_size} bytes, " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))


if __name__ == "__main__":
    main()
