"""Damaged DataFlash logs: junk FMT records, duplicated chunks, flipped bytes.

The truth is what pymavlink's DFReader (an independent reader) finds in the intact log. On
every damaged copy: no exception escapes (a log with no plausible event left is bad input),
every camera event wholly before the first damaged byte comes back exactly, and no event is
returned twice or made up (each returned event is one of the logged ones: within 5 s and
60 m of a distinct logged event; a flipped byte may still nudge a real event's values, and
no reader can tell a time stamp a few seconds off while the vehicle flies on the same line).
Every field of every returned event is that logged event's, within FIELD_TOLERANCE: position,
altitude, relative altitude, roll, pitch and yaw.
"""

from __future__ import annotations

import functools
import math
import struct
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from pymavlink import DFReader

from aerosurvey.errors import InputError
from aerosurvey.flight.dataflash import DataFlashLog
from aerosurvey.flight.events import read_events

DATA = Path(__file__).resolve().parents[1] / "data"
PLANE = DATA / "sitl_plane_kubad.bin"
COPTER = DATA / "sitl_copter_survey.bin"
REAL = DATA / "dronekit_la_log171.bin"  # a Pixhawk log: no camera events, 91,530 messages
HEAD = b"\xa3\x95"
SETTINGS = settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


#: how far a returned field may lie from the logged one: metres of position, metres of altitude
#: and relative altitude, degrees of roll, pitch, yaw (a flipped low bit changes a field by less;
#: a field off by more is damage the reader must not return as real)
FIELD_TOLERANCE = {"position": 2.5, "alt": 4.0, "rel_alt": 4.0, "roll": 6.0, "pitch": 6.0, "yaw": 6.0}
FIELD_COLUMNS = {"position": {"Lat", "Lng"}, "alt": {"Alt"}, "rel_alt": {"RelAlt"}, "roll": {"R", "Roll"},
                 "pitch": {"P", "Pitch"}, "yaw": {"Y", "Yaw"}}


@functools.cache
def truth_fields(path: Path) -> dict[int, tuple[float, ...]]:
    """Each CAM event's (lat, lon, alt, rel_alt, roll, pitch, yaw) by its TimeUS, as pymavlink
    reads the intact log."""
    r = DFReader.DFReader_binary(str(path))
    out = {}
    while (m := r.recv_match(type="CAM")) is not None:
        out[int(m.TimeUS)] = (m.Lat, m.Lng, m.Alt, m.RelAlt, m.R, m.P, m.Y)
    return out


def field_differences(got: tuple[float, ...], true: tuple[float, ...]) -> dict[str, float]:
    """How far each field of a returned event lies from the logged event's (NaN: emptied)."""
    lat, lon, *rest = got
    diffs = {"position": _metres(lat, lon, true[0], true[1])}
    for name, g, t in zip(("alt", "rel_alt", "roll", "pitch"), rest, true[2:]):
        diffs[name] = abs(g - t)
    diffs["yaw"] = abs((rest[4] - true[6] + 180.0) % 360.0 - 180.0)
    return diffs


@functools.cache
def truth(path: Path) -> tuple[bytes, list[tuple[int, float, float, float]]]:
    """The log's bytes and its CAM events as pymavlink reads them: (end offset, time s, lat, lon)."""
    r = DFReader.DFReader_binary(str(path))
    out = []
    while (m := r.recv_match(type="CAM")) is not None:
        out.append((r.offset, m.TimeUS / 1e6, m.Lat, m.Lng))
    return path.read_bytes(), out


def _metres(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    k = math.pi / 180 * 6_371_000
    return math.hypot((lat1 - lat2) * k, (lon1 - lon2) * k * math.cos(math.radians(lat1)))


def check_events(tmp: Path, base: Path, damaged: bytes, first_damage: int, only_at: bool = False) -> None:
    """`only_at`: the damage touched the original log at `first_damage` only (a chunk inserted
    there), so every event but one straddling that place must come back."""
    data, true = truth(base)
    path = tmp / "damaged.bin"
    path.write_bytes(damaged)
    length = cam_length(base)
    before = [e for e in true if e[0] <= first_damage or (only_at and e[0] - length >= first_damage)]
    try:
        ev, info = read_events(path)
    except InputError:
        assert not before, "a log with intact events before the damage was refused"
        return
    got = list(zip(ev.time_s.tolist(), ev.lat.tolist(), ev.lon.tolist()))
    # every event before the damage, exactly
    have = {(round(t * 1e6), round(la * 1e7), round(lo * 1e7)) for t, la, lo in got}
    for _, t, la, lo in before:
        assert (round(t * 1e6), round(la * 1e7), round(lo * 1e7)) in have, f"event at {t} s before the damage lost"
    # none twice, none made up: each returned event takes a distinct logged one (the one of its
    # time, else the nearest within 5 s and 60 m), and every field of it is that event's
    times = np.array([e[1] for e in true])
    fields = truth_fields(base)
    # a field may be empty only where the report says why: its CAM column's format character was
    # damaged, or its column name (the layout has no such column)
    undecoded = {s["reason"].split("column ")[1].split()[0] for s in info["skipped"] if "is not decoded" in s["reason"]}
    absent = {c for part in info["checks"].split("; ") if " column: " in part
              for c in part.split(" has no ")[1].split(" column")[0].split(" or ")}
    emptied = {k for k, columns in FIELD_COLUMNS.items() if (undecoded | absent) & columns}
    returned = zip(got, ev.alt_m.tolist(), ev.rel_alt_m.tolist(), ev.roll.tolist(), ev.pitch.tolist(), ev.yaw.tolist())
    taken: set[int] = set()
    for (t, la, lo), *rest in returned:
        near = [j for j in np.flatnonzero(np.abs(times - t) <= 5.0)
                if j not in taken and _metres(la, lo, true[j][2], true[j][3]) <= 60.0]
        assert near, f"event at {t:.3f} s ({la:.7f}, {lo:.7f}) is none of the logged ones"
        j = min(near, key=lambda j: (times[j] != t, _metres(la, lo, true[j][2], true[j][3])))
        taken.add(int(j))
        diffs = field_differences((la, lo, *rest), fields[round(times[j] * 1e6)])
        off = {k: d for k, d in diffs.items() if not d <= FIELD_TOLERANCE[k] and k not in emptied}
        assert not off, f"event at {t:.3f} s returned with fields off the logged ones: {off}"
    assert info["dropped_events"] >= 0 and info["skipped_places"] >= len(info["skipped"])
    # whatever was dropped or skipped is said, with where and why
    for s in info["skipped"]:
        assert 0 <= s["offset"] < len(damaged) and s["length"] > 0 and s["reason"]
        assert s["kind"] in ("damage", "format", "repeat", "event")


bases = st.sampled_from([PLANE, COPTER])


def _fmt_record(typ: int, length: int, name: bytes, fmt: bytes, cols: bytes) -> bytes:
    return HEAD + bytes([128]) + struct.pack("<BB4s16s64s", typ, length, name, fmt, cols)


def _fmt_offsets(data: bytes) -> list[int]:
    """Offsets of the FMT records at the head of the log (independently of the reader)."""
    out, o = [], 0
    while data[o:o + 3] == HEAD + b"\x80":
        out.append(o)
        o += 89
    return out


# The strategies draw small descriptions of the damage (hypothesis prints them on a failure);
# the damaged bytes are made from them in the test.

@SETTINGS
@given(base=bases, at=st.floats(0, 1), random_bytes=st.booleans(), junk=st.binary(min_size=86, max_size=86),
       typ=st.integers(0, 10**6), fmt=st.text("BHIQfLe", min_size=1, max_size=16),
       name=st.text("ABCDEFGPS0123456789", min_size=1, max_size=4))
def test_junk_fmt_records(tmp_path: Path, base: Path, at: float, random_bytes: bool, junk: bytes, typ: int, fmt: str,
                          name: str) -> None:
    """Random bytes after an FMT header, or a well-formed FMT record giving a type of the log
    another layout, inserted anywhere (also inside a message)."""
    data = truth(base)[0]
    pos = int(at * len(data))
    if random_bytes:
        rec = HEAD + b"\x80" + junk
    else:
        types = sorted({data[o + 3] for o in _fmt_offsets(data)})
        length = 3 + struct.calcsize("<" + fmt.replace("L", "i").replace("e", "i"))
        cols = ",".join(f"C{i}" for i in range(len(fmt)))
        rec = _fmt_record(types[typ % len(types)], length, name.encode(), fmt.encode(), cols.encode())
    check_events(tmp_path, base, data[:pos] + rec + data[pos:], pos)


@SETTINGS
# the log's first 95 bytes (its first FMT record and an FMT header) copied just before a CAM
# message: the FMT header read 89 bytes over the CAM message (found by a run on 2026-11-26)
@example(base=PLANE, a=0.0, size=95, after_itself=False, to=0.5027708058682548)
@example(base=PLANE, a=0.01, size=294, after_itself=False, to=0.5027708058682548)  # its 89 bytes end where the CAM's end
# 305 bytes: three FMT records and the start of a fourth, cut after its (short) column names, copied just
# before a CAM message: an identical FMT copy whose 89 bytes took the CAM (found by a run on 2026-11-28)
@example(base=PLANE, a=0.0, size=305, after_itself=False, to=0.9413715868230008)
# the log's first 2,871 bytes copied before it, cut 23 bytes into CAM's FMT record: the log's first bytes read
# as CAM's column names (kept for its layout), and the log's own CAM FMT, intact, was ignored as a redefinition:
# no CAM decoded (found by a run on 2026-11-29); an intact copy now names the columns
@example(base=COPTER, a=0.0, size=2871, after_itself=False, to=0.0)
@given(base=bases, a=st.floats(0, 1), size=st.integers(1, 200_000), after_itself=st.booleans(), to=st.floats(0, 1))
def test_duplicated_chunks(tmp_path: Path, base: Path, a: float, size: int, after_itself: bool, to: float) -> None:
    """A chunk of the log copied again, right after itself or anywhere else (before it, inside
    it): every event comes back once, but the one the insertion cuts."""
    data = truth(base)[0]
    start = int(a * (len(data) - 1))
    end = min(len(data), start + size)
    pos = end if after_itself else int(to * len(data))
    check_events(tmp_path, base, data[:pos] + data[start:end] + data[pos:], pos, only_at=True)


@SETTINGS
@example(base=COPTER, flips=[(0.0, 1)], cam_flips=[(150, 328, 1)])  # an event 16.8 s late, after the last one
@example(base=COPTER, flips=[(0.0, 1)], cam_flips=[(150, 329, 1)])  # an event 4295 s late, after the GPS messages
@example(base=PLANE, flips=[(0.0, 1)], cam_flips=[(1008, 235, 40)])  # found by a run on 2026-11-25
# one field of a CAM record (46 bytes: header, TimeUS, I, Img, GPSTime, GPSWeek, Lat, Lng, Alt at 28,
# RelAlt at 32, GPSAlt, R at 40, P at 42, Y at 44) altered, its time and place intact
@example(base=PLANE, flips=[(0.0, 1)], cam_flips=[(200, 30, 4)])  # altitude 2,621 m higher
@example(base=PLANE, flips=[(0.0, 1)], cam_flips=[(201, 35, 1)])  # relative altitude 168 km higher
@example(base=COPTER, flips=[(0.0, 1)], cam_flips=[(60, 41, 0x10)])  # roll 41° more
@example(base=COPTER, flips=[(0.0, 1)], cam_flips=[(61, 43, 0x40)])  # pitch 164° more
@example(base=COPTER, flips=[(0.0, 1)], cam_flips=[(62, 45, 0x80)])  # yaw 328° more
# longitude 28 m off, its nearest place on the GPS track a fix at a corner of the track, which the check took for the
# track's end (CI, 2026-11-29)
@example(base=COPTER, flips=[(0.0, 1)], cam_flips=[(0, 19479, 14)])
@given(base=bases, flips=st.lists(st.tuples(st.floats(0, 1), st.integers(1, 255)), min_size=1, max_size=30),
       cam_flips=st.lists(st.tuples(st.integers(0, 10**6), st.integers(0, 10**6), st.integers(1, 255)), max_size=10))
def test_flipped_bytes(tmp_path: Path, base: Path, flips: list[tuple[float, int]],
                       cam_flips: list[tuple[int, int, int]]) -> None:
    """Bytes flipped anywhere, and bytes flipped inside camera messages (a small share of the log)."""
    data = bytearray(truth(base)[0])
    ends, length = [e[0] for e in truth(base)[1]], cam_length(base)
    positions = [min(len(data) - 1, int(f * len(data))) for f, _ in flips]
    positions += [ends[i % len(ends)] - length + j % length for i, j, _ in cam_flips]
    for p, x in zip(positions, [x for _, x in flips] + [x for _, _, x in cam_flips]):
        data[p] ^= x
    check_events(tmp_path, base, bytes(data), min(positions))


@functools.cache
def cam_length(path: Path) -> int:
    """Bytes of a CAM message, as pymavlink knows it."""
    r = DFReader.DFReader_binary(str(path))
    return int(r.formats[r.name_to_id["CAM"]].len)


def test_a_chunk_copied_after_itself_returns_each_event_once_and_says_so(tmp_path: Path) -> None:
    data, true = truth(PLANE)
    a, b = len(data) // 3, len(data) // 2
    damaged = data[:b] + data[a:b] + data[b:]
    path = tmp_path / "dup.bin"
    path.write_bytes(damaged)
    ev, info = read_events(path)
    assert len(ev) == len(true) and len(set(ev.time_s.tolist())) == len(true)
    (run,) = [s for s in info["skipped"] if s["kind"] == "repeat"]  # one copied run, one place
    copied = [e for e in true if a + 200 <= e[0] <= b]  # CAM messages wholly in the copy (they are < 200 bytes)
    assert len(copied) <= info["dropped_events"] <= len(copied) + 1 and len(copied) > 0
    # it starts at the copy of the first event copied whole, and ends inside the copy
    assert copied[0][0] - 200 <= run["offset"] - b + a < copied[0][0] and run["offset"] + run["length"] <= b + (b - a)
    assert f"{info['dropped_events']} CAM event(s)" in run["reason"]
    assert not [s for s in info["skipped"] if s["kind"] == "event"]  # a copy, not events out of order


def test_an_event_moved_off_the_track_is_dropped_and_reported(tmp_path: Path) -> None:
    data, true = truth(COPTER)
    end, t, lat, lon = true[40]
    with DataFlashLog(COPTER) as log:
        cam = log.type_of("CAM")
        assert cam is not None
        names = cam.columns
        at = int(log.message_offsets("CAM")[40])
    lat_at = at + 3 + struct.calcsize("<" + "".join({"Q": "Q", "B": "B", "H": "H", "I": "I"}[c] for c in
                                                    cam.fmt[:names.index("Lat")]))
    damaged = bytearray(data)
    damaged[lat_at:lat_at + 4] = struct.pack("<i", round((lat + 0.01) * 1e7))  # 1.1 km north
    path = tmp_path / "moved.bin"
    path.write_bytes(bytes(damaged))
    ev, info = read_events(path)
    assert len(ev) == len(true) - 1 and t not in ev.time_s.tolist()
    (s,) = [s for s in info["skipped"] if s["kind"] == "event"]
    assert s["offset"] == at and "GPS track" in s["reason"] and info["dropped_events"] == 1


def test_an_event_out_of_time_order_is_dropped(tmp_path: Path) -> None:
    data, true = truth(COPTER)
    with DataFlashLog(COPTER) as log:
        at = int(log.message_offsets("CAM")[60])
    damaged = bytearray(data)
    damaged[at + 3:at + 11] = struct.pack("<Q", round(true[10][1] * 1e6))  # the time of event 11
    path = tmp_path / "time.bin"
    path.write_bytes(bytes(damaged))
    ev, info = read_events(path)
    assert len(ev) == len(true) - 1 and np.all(np.diff(ev.time_s) > 0)
    assert [s["offset"] for s in info["skipped"] if s["kind"] == "event"] == [at]


# --- FMT records, on the real Pixhawk log -------------------------------------------------


@functools.cache
def _intact(path: Path) -> tuple[dict[str, int], np.ndarray]:
    """Message counts of the intact log, and every 997th message start (places to insert at).
    The reader's counts of this log are pymavlink's (test_real_log_layouts.py)."""
    with DataFlashLog(path) as log:
        starts = np.sort(np.concatenate([np.frombuffer(a, np.uint64) for a in log.offsets.values()]))
        return log.counts(), starts[::997].astype(np.int64)


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(junk=st.binary(min_size=86, max_size=86), where=st.integers(0, 10**9))
def test_random_bytes_after_an_fmt_header_cost_no_gps_message(tmp_path: Path, junk: bytes, where: int) -> None:
    data = REAL.read_bytes()
    counts0, starts = _intact(REAL)
    at = int(starts[where % len(starts)])
    path = tmp_path / "junk.bin"
    path.write_bytes(data[:at] + HEAD + b"\x80" + junk + data[at:])
    with DataFlashLog(path) as log:
        assert log.counts() == counts0 and counts0["GPS"] > 1000
        assert sum(s.length for s in log.skipped) <= 89 and all(at <= s.offset < at + 89 for s in log.skipped)
        assert log.skipped[0].offset == at and log.skipped[0].kind == "format"


def test_a_redefinition_of_gps_is_ignored_and_reported(tmp_path: Path) -> None:
    data = REAL.read_bytes()
    with DataFlashLog(REAL) as log:
        gps = log.type_of("GPS")
        assert gps is not None
        n_gps = len(log.message_offsets("GPS"))
        at = int(log.message_offsets("GPS")[n_gps // 2])
    rec = _fmt_record(gps.type, 7, b"GPS", b"I", b"TimeMS")
    path = tmp_path / "redef.bin"
    path.write_bytes(data[:at] + rec + data[at:])
    with DataFlashLog(path) as log:
        assert len(log.message_offsets("GPS")) == n_gps == _intact(REAL)[0]["GPS"]
        assert len(log.messages("GPS")["Lat"]) == n_gps
        (s,) = log.skipped
        assert (s.offset, s.length, s.kind) == (at, 89, "format") and "redefines type" in s.reason


@pytest.mark.parametrize("field,value", [("name", b"G\xefS"), ("fmt", b"QBz"), ("length", 200)])
def test_an_fmt_record_that_does_not_hold_together_is_damage(tmp_path: Path, field: str, value: bytes | int) -> None:
    rec: dict[str, Any] = {"typ": 201, "length": 3 + 8 + 1 + 2, "name": b"XYZ", "fmt": b"QBH", "cols": b"TimeUS,A,B"}
    rec[field] = value
    good = _fmt_record(201, 14, b"XYZ", b"QBH", b"TimeUS,A,B")
    msg = HEAD + bytes([201]) + struct.pack("<QBH", 5, 1, 2)
    path = tmp_path / "fmt.bin"
    path.write_bytes(_fmt_record(**rec) + good + msg)
    with DataFlashLog(path) as log:
        # one damaged format character: its size follows from the length, so the record frames its
        # messages; the damage is reported at that character
        at = 3 + 6 + 2 if field == "fmt" else 0
        assert [(s.offset, s.kind) for s in log.skipped] == [(at, "format")]
        assert log.messages("XYZ")["B"].tolist() == [2]


def test_a_damaged_format_character_leaves_its_column_undecoded_and_the_rest_decoded(tmp_path: Path) -> None:
    rec = _fmt_record(201, 3 + 8 + 1 + 2, b"XYZ", b"Q%H", b"TimeUS,A,B")
    msg = HEAD + bytes([201]) + struct.pack("<QBH", 5, 1, 2)
    path = tmp_path / "fmt.bin"
    path.write_bytes(rec + msg + msg)
    with DataFlashLog(path) as log:
        (s,) = log.skipped
        assert (s.offset, s.length, s.kind) == (3 + 6 + 1, 1, "format") and "column A is not decoded" in s.reason
        cols = log.messages("XYZ")
        assert sorted(cols) == ["B", "TimeUS"] and cols["B"].tolist() == [2, 2] and cols["TimeUS"].tolist() == [5, 5]


def test_after_damage_a_header_counts_only_when_another_follows_its_message(tmp_path: Path) -> None:
    data = COPTER.read_bytes()
    with DataFlashLog(COPTER) as log:
        cam = log.type_of("CAM")
        assert cam is not None
        at = int(log.message_offsets("GPS")[500])
        counts = log.counts()
    # damage, then what reads as a CAM header followed by bytes that are no message
    junk = b"\x01\x02\x03" + HEAD + bytes([cam.type]) + b"\x11" * (cam.length + 7)
    path = tmp_path / "fake.bin"
    path.write_bytes(data[:at] + junk + data[at:])
    with DataFlashLog(path) as log:
        assert log.counts() == counts
        assert [(s.offset, s.length) for s in log.skipped] == [(at, len(junk))]


def test_an_fmt_record_with_damaged_column_names_keeps_its_messages(tmp_path: Path) -> None:
    data, true = truth(PLANE)
    at = data.find(b"TimeUS,I,Img,GPSTime,GPSWeek,Lat")  # the CAM FMT record's column names
    damaged = bytearray(data)
    damaged[at + 26] ^= 0x80  # 'W' of GPSWeek
    path = tmp_path / "cols.bin"
    path.write_bytes(bytes(damaged))
    ev, info = read_events(path)
    assert len(ev) == len(true) and info["dropped_events"] == 0
    (s,) = info["skipped"]
    assert (s["offset"], s["length"], s["kind"]) == (at + 26, 1, "format") and "damaged column names" in s["reason"]


def test_a_column_name_damaged_into_another_empties_that_field_and_says_so(tmp_path: Path) -> None:
    """A flipped bit that turns the CAM record's column name RelAlt into RelAmt (printable, so
    not seen as damage): the layout has no RelAlt, every event comes back without one, and the
    report says why."""
    data, true = truth(COPTER)
    at = data.find(b"Lat,Lng,Alt,RelAlt,GPSAlt")
    damaged = bytearray(data)
    damaged[at + len("Lat,Lng,Alt,RelA")] ^= 0x01  # l -> m
    path = tmp_path / "name.bin"
    path.write_bytes(bytes(damaged))
    ev, info = read_events(path)
    assert len(ev) == len(true) and info["dropped_events"] == 0 and np.isnan(ev.rel_alt_m).all()
    assert "CAM has no RelAlt column: relative altitude empty in every event" in info["checks"]
    assert ev.alt_m == pytest.approx([fields[2] for fields in truth_fields(COPTER).values()], abs=1e-6)


@pytest.mark.parametrize("base", [PLANE, COPTER])
@pytest.mark.parametrize("shift_us", [-65_280, -51_200, 51_200, 65_280])  # bits of the time stamp's second byte flipped
def test_an_event_some_tens_of_ms_off_in_time_is_dropped_and_reported(tmp_path: Path, base: Path, shift_us: int) -> None:
    data, true = truth(base)
    damaged = bytearray(data)
    with DataFlashLog(base) as log:
        offs = log.message_offsets("CAM")
    picked = list(range(10, len(true) - 10, len(true) // 8))
    for i in picked:
        at = int(offs[i])
        (t,) = struct.unpack_from("<Q", damaged, at + 3)
        struct.pack_into("<Q", damaged, at + 3, t + shift_us)
    path = tmp_path / "late.bin"
    path.write_bytes(bytes(damaged))
    ev, info = read_events(path)
    times = {round(t * 1e6) for t in ev.time_s.tolist()}
    assert len(ev) == len(true) - len(picked)
    assert not times & {round(true[i][1] * 1e6) + shift_us for i in picked}
    dropped = [s for s in info["skipped"] if s["kind"] == "event"]
    assert sorted(s["offset"] for s in dropped) == [int(offs[i]) for i in picked]
