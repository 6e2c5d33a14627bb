"""DataFlash reading, like for like: pymavlink's DFReader and aerosurvey's reader on the same tasks.

    python benchmarks/log_bench.py                      # the committed SITL plane log, repeated to >= 110 MB
    python benchmarks/log_bench.py --log FLIGHT.BIN     # a log of your own (repeated if under --min-mb)
    python benchmarks/log_bench.py --damaged 0          # speed and memory only
    python benchmarks/log_bench.py --no-speed --readers ours   # the damaged copies only, our reader only

Two tasks, each reader in its own process per task (so the peak memory is the task's own):

  all       every message of every type decoded: pymavlink's recv_msg() loop; ours scans and
            decodes each type to columns (one type at a time, like pymavlink's one message at a time)
  cam-gps-att  the camera, GPS and attitude messages only: pymavlink's indexed
            recv_match(type=["CAM", "GPS", "ATT"]) (it indexes the log when it opens it); ours
            scans and decodes those three types

The big log is the chosen log written N times back to back; N flights in one file are a valid
DataFlash log (each copy repeats its FMT records with the same layouts).

Then damaged copies of the committed SITL logs (junk FMT records inserted; a chunk copied
again after itself, before itself or inside itself; the log cut off; bits flipped; seeded),
per kind of damage: for each reader the camera events it returns against those
of the intact log, over the events the damage did not touch: recovered, returned twice,
and returned but not in the intact log (altered or invented). Then every field of every
returned event against the intact event nearest in time (within 5 s; touched by the damage
or not): position, altitude, relative altitude, roll, pitch, yaw, each within the
tolerance of FIELD_TOLERANCE; an event beyond it in any field is "altered", and "impossible"
when the field is out of physical bounds (PHYSICAL); an empty (NaN) field where the intact
event has one is "emptied"; and how many events the reader dropped as implausible
(`read.implausible_events`). pymavlink reads CAM with recv_match; ours is `read_events`, the
reader plus its checks, as `log ingest` uses it.
"""

from __future__ import annotations

import argparse
import bisect
import contextlib
import io
import json
import math
import os
import random
import resource
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DATA = REPO / "tests" / "data"
TASKS = ("all", "cam-gps-att")
THREE = ["CAM", "GPS", "ATT"]


def _rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def child(reader: str, task: str, path: str) -> dict[str, float]:
    """One reader, one task, in this process: messages decoded, seconds, peak RSS."""
    if reader == "pymavlink":
        from pymavlink import DFReader
    else:
        from aerosurvey.flight.dataflash import DataFlashLog
    base = _rss_mb()
    t = time.perf_counter()
    n = 0
    if reader == "pymavlink":
        r = DFReader.DFReader_binary(path)
        if task == "all":
            while r.recv_msg() is not None:
                n += 1
        else:
            while r.recv_match(type=THREE) is not None:
                n += 1
    else:
        with DataFlashLog(path) as log:
            names = [f.name for f in log.formats.values() if f.dtype is not None] if task == "all" else THREE
            for name in names:
                cols = log.messages(name)
                n += len(next(iter(cols.values()))) if cols else 0
                del cols
    return {"messages": n, "seconds": time.perf_counter() - t, "peak_rss_mb": _rss_mb(), "base_rss_mb": base}


# --- damaged copies -----------------------------------------------------------------------------

HEAD = b"\xa3\x95"


#: a CAM event's fields as compared: (lat, lon, alt AMSL m, rel alt m, roll, pitch, yaw degrees)
Fields = tuple[float, float, float, float, float, float, float]
#: a returned field farther than this from the intact event's is altered: metres of position
#: (lat and lon), metres of altitude and relative altitude, degrees of attitude
FIELD_TOLERANCE = {"position_m": 2.5, "alt_m": 4.0, "angle_deg": 6.0}
#: what no vehicle logs: altitudes beyond 10 km of sea level or home, roll beyond ±180°, pitch
#: beyond ±90°, yaw outside -180..360°
PHYSICAL = {"alt_m": 10_000.0, "roll": 180.0, "pitch": 90.0, "yaw": (-180.0, 360.0)}


def _cam_fields(m: object) -> Fields:
    """A pymavlink CAM message's fields (ArduCopter 4.6 names the attitude R, P, Y)."""
    def get(*names: str) -> float:
        return float(next(getattr(m, k) for k in names if hasattr(m, k)))
    return (get("Lat"), get("Lng"), get("Alt"), get("RelAlt"), get("R", "Roll"), get("P", "Pitch"), get("Y", "Yaw"))


def _intact_fields(path: Path) -> dict[int, Fields]:
    """Every CAM event's fields by its TimeUS, as pymavlink reads the intact log."""
    from pymavlink import DFReader

    r = DFReader.DFReader_binary(str(path))
    out = {}
    while (m := r.recv_match(type="CAM")) is not None:
        out[int(m.TimeUS)] = _cam_fields(m)
    return out


def _altered(got: Fields, true: Fields) -> tuple[list[str], list[str], bool]:
    """(the fields beyond FIELD_TOLERANCE of the intact event's, the fields emptied, whether a
    returned field is out of physical bounds)."""
    names = ("position", "alt", "rel_alt", "roll", "pitch", "yaw")
    lat, lon, *rest = got
    k = math.pi / 180 * 6_371_000
    moved = math.hypot((lat - true[0]) * k, (lon - true[1]) * k * math.cos(math.radians(true[0])))
    diffs = [moved, abs(rest[0] - true[2]), abs(rest[1] - true[3]), abs(rest[2] - true[4]), abs(rest[3] - true[5]),
             abs((rest[4] - true[6] + 180.0) % 360.0 - 180.0)]
    limits = [FIELD_TOLERANCE["position_m"], FIELD_TOLERANCE["alt_m"], FIELD_TOLERANCE["alt_m"]] + [FIELD_TOLERANCE["angle_deg"]] * 3
    altered = [n for n, d, lim in zip(names, diffs, limits) if d > lim]
    emptied = [n for n, d in zip(names, diffs) if math.isnan(d)]
    yaw_lo, yaw_hi = PHYSICAL["yaw"]
    impossible = (abs(rest[0]) > PHYSICAL["alt_m"] or abs(rest[1]) > PHYSICAL["alt_m"] or abs(rest[2]) > PHYSICAL["roll"]
                  or abs(rest[3]) > PHYSICAL["pitch"] or not yaw_lo <= rest[4] <= yaw_hi)
    return altered, emptied, impossible


def _nearest(times: list[int], t: int) -> int | None:
    """The intact event time (µs, sorted) nearest `t`, within 5 s: the event a returned one is
    (its time may be altered too)."""
    k = bisect.bisect_left(times, t)
    near = min(times[max(k - 1, 0):k + 1], key=lambda u: abs(u - t), default=None)
    return near if near is not None and abs(near - t) <= 5_000_000 else None


def _intact_events(path: Path) -> list[tuple[int, int, int, int, int]]:
    """(start, end, TimeUS, Lat e7, Lng e7) of each CAM message, as pymavlink reads the intact log."""
    from pymavlink import DFReader

    r = DFReader.DFReader_binary(str(path))
    length = r.formats[r.name_to_id["CAM"]].len
    out = []
    while (m := r.recv_match(type="CAM")) is not None:
        out.append((r.offset - length, r.offset, int(m.TimeUS), round(m.Lat * 1e7), round(m.Lng * 1e7)))
    return out


KINDS = ("junk-fmt", "copy-after", "copy-before", "copy-overlap", "truncated", "flipped-bits")


def damage(data: bytes, kind: str, rng: random.Random) -> tuple[bytes, list[tuple[int, int]]]:
    """A damaged copy and the byte ranges of the original that the damage touched."""
    if kind == "junk-fmt":  # random bytes after an FMT header, inserted at random places
        out, touched, last = bytearray(), [], 0
        for p in sorted(rng.randrange(len(data)) for _ in range(3)):
            out += data[last:p] + HEAD + b"\x80" + rng.randbytes(86)
            touched.append((p, p + 1))
            last = p
        return bytes(out + data[last:]), touched
    if kind.startswith("copy-"):  # a chunk of up to 200 kB written again after itself, before it, or inside it
        a = rng.randrange(len(data) - 1)
        b = min(len(data), a + rng.randrange(1, 200_000))
        at = {"copy-after": b, "copy-before": rng.randrange(0, a + 1), "copy-overlap": rng.randrange(a, b + 1)}[kind]
        return data[:at] + data[a:b] + data[at:], [(at, at + 1)]
    if kind == "truncated":  # the log cut off at a random place
        p = rng.randrange(1, len(data))
        return data[:p], [(p, len(data))]
    flipped = bytearray(data)  # 20 bits flipped at random places
    touched = []
    for _ in range(20):
        p = rng.randrange(len(data))
        flipped[p] ^= 1 << rng.randrange(8)
        touched.append((p, p + 1))
    return bytes(flipped), touched


@contextlib.contextmanager
def _quiet() -> Iterator[None]:
    """Standard error to /dev/null at the descriptor (pymavlink's indexer prints from C), standard output aside."""
    sys.stderr.flush()
    saved, null = os.dup(2), os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, 2)
    try:
        with contextlib.redirect_stdout(io.StringIO()):  # and its Python prints (bad FMT records)
            yield
    finally:
        sys.stderr.flush()
        os.dup2(saved, 2)
        os.close(saved)
        os.close(null)


Returned = list[tuple[int, int, int, Fields]]  # (TimeUS, lat e7, lon e7, every field) of each event returned


def _pymavlink_events(path: Path) -> tuple[Returned, str, int]:
    from pymavlink import DFReader

    out: Returned = []
    try:
        with _quiet():  # pymavlink prints a line per byte of damage
            r = DFReader.DFReader_binary(str(path))
            while (m := r.recv_match(type="CAM")) is not None:
                out.append((int(m.TimeUS), round(m.Lat * 1e7), round(m.Lng * 1e7), _cam_fields(m)))
    except Exception as exc:  # a damaged log may make pymavlink raise: what it returned so far counts
        return out, type(exc).__name__, 0
    return out, "", 0


def _our_events(path: Path) -> tuple[Returned, str, int]:
    """The events returned, what was raised, the events dropped as implausible."""
    from aerosurvey.errors import InputError
    from aerosurvey.flight.events import read_events

    try:
        ev, info = read_events(path)
    except InputError:
        return [], "", 0
    except Exception as exc:  # counted, not hidden: the damage tests say there are none
        return [], type(exc).__name__, 0
    rows = zip(ev.time_s.tolist(), ev.lat.tolist(), ev.lon.tolist(), ev.alt_m.tolist(), ev.rel_alt_m.tolist(),
               ev.roll.tolist(), ev.pitch.tolist(), ev.yaw.tolist())
    return ([(round(t * 1e6), round(la * 1e7), round(lo * 1e7), (la, lo, *rest)) for t, la, lo, *rest in rows], "",
            info["implausible_events"])


def _near(g: tuple[int, int, int], e: tuple[int, int, int]) -> bool:
    """A returned event within 5 s and about 60 m of an event the damage touched: that event, altered."""
    return abs(g[0] - e[0]) <= 5_000_000 and abs(g[1] - e[1]) <= 5_400 and abs(g[2] - e[2]) <= 8_000


def damaged_runs(per_kind: int, seed: int, readers: tuple[str, ...] = ("pymavlink", "ours")) -> dict[tuple[str, str], dict[str, int]]:
    """Totals per (reader, kind of damage), and per reader over every kind ("all")."""
    rng = random.Random(seed)
    counts = ("untouched", "recovered", "twice", "not_in_log", "altered", "raised", "copies", "judged",
              "fields_altered", "impossible", "fields_emptied", "untouched_dropped", "copies_altered", "implausible")
    totals: dict[tuple[str, str], dict[str, int]] = {(r, k): dict.fromkeys(counts, 0) for r in readers for k in (*KINDS, "all")}
    with tempfile.TemporaryDirectory() as td:
        for base in (DATA / "sitl_plane_kubad.bin", DATA / "sitl_copter_survey.bin"):
            data, intact, fields = base.read_bytes(), _intact_events(base), _intact_fields(base)
            times = sorted(fields)
            keys = {e[2:] for e in intact}
            for kind in KINDS:
                for _ in range(per_kind):
                    bad, touched = damage(data, kind, rng)
                    p = Path(td) / "damaged.bin"
                    p.write_bytes(bad)
                    hit = [not any(s < e[1] and e[0] < t for s, t in touched) for e in intact]
                    untouched = {e[2:] for e, ok in zip(intact, hit) if ok}
                    damaged_events = [e[2:] for e, ok in zip(intact, hit) if not ok]
                    for reader, read in (("pymavlink", _pymavlink_events), ("ours", _our_events)):
                        if reader not in readers:
                            continue
                        returned, raised, implausible = read(p)
                        got = [g[:3] for g in returned]
                        extra = [g for g in set(got) if g not in keys]
                        judged = [_altered(g[3], fields[t]) for g in returned if (t := _nearest(times, g[0])) is not None]
                        back = {g[0] for g in returned}
                        for tot in (totals[reader, kind], totals[reader, "all"]):
                            tot["copies"] += 1
                            tot["untouched"] += len(untouched)
                            tot["recovered"] += len(untouched & set(got))
                            tot["twice"] += len(got) - len(set(got))
                            tot["not_in_log"] += len(extra)
                            tot["altered"] += sum(1 for g in extra if any(_near(g, e) for e in damaged_events))
                            tot["raised"] += bool(raised)
                            tot["judged"] += len(judged)
                            tot["fields_altered"] += sum(bool(a) for a, _, _ in judged)
                            tot["impossible"] += sum(bad for _, _, bad in judged)
                            tot["fields_emptied"] += sum(bool(e) for _, e, _ in judged)
                            tot["untouched_dropped"] += sum(e[0] not in back for e in untouched)
                            tot["implausible"] += implausible
                            tot["copies_altered"] += any(a for a, _, _ in judged)
                            for a, _, _ in judged:
                                for name in a:
                                    tot[f"altered {name}"] = tot.get(f"altered {name}", 0) + 1
    return totals


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--log", default=str(DATA / "sitl_plane_kubad.bin"), help="the DataFlash log to read")
    ap.add_argument("--min-mb", type=float, default=110.0, help="repeat the log until it is at least this big")
    ap.add_argument("--damaged", type=int, default=20, help="damaged copies per kind of damage and per SITL log")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--no-speed", action="store_true", help="the damaged copies only, no speed and memory runs")
    ap.add_argument("--readers", default="pymavlink,ours", help="readers of the damaged copies (comma-separated)")
    ap.add_argument("--child", nargs=2, metavar=("READER", "TASK"))
    a = ap.parse_args()
    if a.child:
        print(json.dumps(child(a.child[0], a.child[1], a.log)))
        return
    if not a.no_speed:
        speed(a.log, a.min_mb)
    if a.damaged:
        print(f"damaged copies: {a.damaged} per kind of damage of each of the two SITL logs, seed {a.seed}; "
              "over the camera events the damage did not touch:")
        print("| damage | reader | untouched events returned | returned twice | altered | made up | raised |")
        print("| --- | --- | --- | --- | --- | --- | --- |")
        runs = damaged_runs(a.damaged, a.seed, tuple(a.readers.split(",")))
        for (reader, kind), t in runs.items():
            print(f"| {kind} | {reader} | {t['recovered']:,} of {t['untouched']:,} "
                  f"({100 * t['recovered'] / max(1, t['untouched']):.2f} %) | {t['twice']:,} | {t['altered']} | "
                  f"{t['not_in_log'] - t['altered']} | on {t['raised']} of {t['copies']} copies |")
        tol = FIELD_TOLERANCE
        print(f"\nevery field of each returned event against the intact event nearest in time (tolerance "
              f"{tol['position_m']:g} m of position, {tol['alt_m']:g} m of altitude and relative altitude, "
              f"{tol['angle_deg']:g}° of roll, pitch, yaw):")
        print("| damage | reader | returned within 5 s of an intact event | with a field altered (copies) | of them impossible "
              "| with a field emptied | dropped as implausible (of them untouched) | altered fields |")
        print("| --- | --- | --- | --- | --- | --- | --- | --- |")
        for (reader, kind), t in runs.items():
            which = ", ".join(f"{k.split()[1]} {v}" for k, v in sorted(t.items()) if k.startswith("altered "))
            print(f"| {kind} | {reader} | {t['judged']:,} | {t['fields_altered']} ({t['copies_altered']}) | "
                  f"{t['impossible']} | {t['fields_emptied']} | {t['implausible']} ({t['untouched_dropped']}) | {which or '-'} |")


def speed(log: str, min_mb: float) -> None:
    """Both readers on the two tasks, each in its own process, on the log repeated to `min_mb`."""
    src = Path(log).read_bytes()
    copies = max(1, -(-int(min_mb * 1e6) // len(src)))
    with tempfile.TemporaryDirectory() as td:
        big = Path(log) if copies == 1 else Path(td) / "big.bin"
        if copies > 1:
            with open(big, "wb") as fh:
                for _ in range(copies):
                    fh.write(src)
        mb = big.stat().st_size / 1e6
        print(f"log: {copies} x {Path(log).name} = {mb:.1f} MB")
        res: dict[tuple[str, str], dict[str, float]] = {}
        for task in TASKS:
            for reader in ("pymavlink", "ours"):
                p = subprocess.run([sys.executable, __file__, "--child", reader, task, "--log", str(big)],
                                   capture_output=True, text=True, check=True)
                r = res[reader, task] = json.loads(p.stdout.strip().splitlines()[-1])
                print(f"{task:>11} {reader:>9}: {r['messages']:>9,} messages in {r['seconds']:6.2f} s = "
                      f"{mb / r['seconds']:6.1f} MB/s, peak RSS {r['peak_rss_mb']:4.0f} MB "
                      f"({r['peak_rss_mb'] - r['base_rss_mb']:+.0f} MB over the {r['base_rss_mb']:.0f} MB after imports)")
            ratio = res["pymavlink", task]["seconds"] / res["ours", task]["seconds"]
            print(f"{task:>11} time pymavlink / ours: {ratio:.2f}")


if __name__ == "__main__":
    main()
