"""MAVLink telemetry logs and PX4 ULogs."""

from __future__ import annotations

import math
import struct
import sys
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from aerosurvey.errors import InputError
from aerosurvey.flight.events import read_events

sys.path.insert(0, str(Path(__file__).resolve().parent))
from ulogwriter import ulog_of_rows  # noqa: E402

DATA = Path(__file__).resolve().parents[1] / "data"


def _tlog(path: Path, n: int, junk_at: int | None = None) -> None:
    mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    out = bytearray()
    for i in range(n):
        msg = mav.camera_feedback_encode(1_700_000_000_000_000 + i * 2_000_000, 1, 0, i, 494000000 + i * 1000,
                                         150000000, 420.0 + i, 100.0, 1.0, -2.0, 90.0, 16.0, i, 1)
        out += struct.pack(">Q", 1_700_000_000_000_000 + i * 2_000_000) + msg.pack(mav)
        if junk_at is not None and i == junk_at:
            out += b"\x01\x02\x03garbage\xfe\xfd"
    path.write_bytes(bytes(out))


def test_tlog_camera_feedback(tmp_path):
    _tlog(tmp_path / "f.tlog", 20)
    ev, info = read_events(tmp_path / "f.tlog")
    assert len(ev) == 20 and ev.source == "CAMERA_FEEDBACK"
    assert ev.lat[3] == pytest.approx(49.4003, abs=1e-7) and ev.alt_m[19] == pytest.approx(439.0)
    assert ev.yaw[0] == pytest.approx(90.0)


def test_tlog_with_garbage_keeps_the_events(tmp_path):
    _tlog(tmp_path / "g.tlog", 20, junk_at=7)
    ev, info = read_events(tmp_path / "g.tlog")
    assert len(ev) == 20 and info["skipped_bytes"] == len(b"\x01\x02\x03garbage\xfe\xfd")


def test_public_px4_ulog_without_camera_events():
    with pytest.raises(InputError, match="no camera_capture topic"):
        read_events(DATA / "px4_sample_events.ulg")


def test_unknown_log_type(tmp_path):
    (tmp_path / "x.csv").write_text("a")
    with pytest.raises(InputError, match="unknown log type"):
        read_events(tmp_path / "x.csv")


# --- every field of an event checked against the attitude and position the log holds ---------

SPEED_MS, ALT_AMSL, ALT_REL = 10.0, 300.0, 50.0
EVENTS = 12


def _roll(t: float) -> float:
    return 2.0 * math.sin(1.3 * t)


def _flight_rows(t: float) -> tuple[float, float, float, float, float]:
    """(lat, lon, roll, pitch, yaw degrees 0..360) of a vehicle flying east, level, at time t."""
    return 49.0, 15.0 + SPEED_MS * t / (111_320.0 * math.cos(math.radians(49.0))), _roll(t), -3.0, 90.0


def _events(alt_names: tuple[str, str], altered: dict[str, float], at: int) -> list[tuple[float, float, float, dict[str, float]]]:
    """(time, lat, lon, fields) of each camera event, every 2 s: the altitude and relative
    altitude under the log type's names, roll, pitch, yaw; the `altered` fields of event `at` changed."""
    out = []
    for i in range(EVENTS):
        t = 2.0 * (i + 1) + 0.05
        lat, lon, roll, pitch, yaw = _flight_rows(t)
        fields = {alt_names[0]: ALT_AMSL, alt_names[1]: ALT_REL, "roll": roll, "pitch": pitch, "yaw": yaw}
        out.append((t, lat, lon, {**fields, **(altered if i == at else {})}))
    return out


def _tlog_flight(path: Path, altered: dict[str, float], at: int = 5) -> None:
    """ATTITUDE and GLOBAL_POSITION_INT at 10 Hz, CAMERA_FEEDBACK every 2 s received 0.3 s late,
    with the `altered` fields of event `at` changed."""
    mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    epoch_us = 1_700_000_000_000_000
    rows = []
    for k in range(10 * 2 * (EVENTS + 1)):
        t = k / 10
        lat, lon, roll, pitch, yaw = _flight_rows(t)
        rows.append((t, mav.attitude_encode(int(t * 1000), math.radians(roll), math.radians(pitch), math.radians(yaw),
                                            0.0, 0.0, 0.0)))
        rows.append((t, mav.global_position_int_encode(int(t * 1000), round(lat * 1e7), round(lon * 1e7),
                                                       round(ALT_AMSL * 1000), round(ALT_REL * 1000), 1000, 0, 0, 9000)))
    for i, (t, lat, lon, f) in enumerate(_events(("alt_msl", "alt_rel"), altered, at)):
        rows.append((t + 0.3, mav.camera_feedback_encode(epoch_us + int(t * 1e6), 1, 0, i, round(lat * 1e7),
                                                         round(lon * 1e7), f["alt_msl"], f["alt_rel"], f["roll"],
                                                         f["pitch"], f["yaw"], 16.0, i, 1)))
    out = bytearray()
    for t, msg in sorted(rows, key=lambda r: r[0]):
        out += struct.pack(">Q", epoch_us + int(t * 1e6)) + msg.pack(mav)
    path.write_bytes(bytes(out))


ALTERED = [  # (field, value, what the reason says): impossible values, then possible ones that the log contradicts
    ("alt_msl", 3_838_300.0, "altitude 3838300.00 m"), ("alt_rel", 7_047_000.0, "relative altitude 7047000.00 m"),
    ("roll", -279.0, "roll -279.00°"), ("pitch", 210.0, "pitch 210.00°"), ("yaw", 606.0, "yaw 606.00°"),
    ("alt_msl", 340.0, "altitude 340.00 m"), ("alt_rel", 20.0, "relative altitude 20.00 m"), ("roll", 25.0, "roll 25.00°"),
    ("pitch", 12.0, "pitch 12.00°"), ("yaw", 180.0, "yaw 180.00°")]


def test_tlog_events_agree_with_the_attitude_and_position_received(tmp_path: Path) -> None:
    _tlog_flight(tmp_path / "f.tlog", {})
    ev, info = read_events(tmp_path / "f.tlog")
    assert len(ev) == EVENTS and info["dropped_events"] == 0
    assert "ATTITUDE" in info["checks"] and "GLOBAL_POSITION_INT" in info["checks"]


@pytest.mark.parametrize("field,value,said", ALTERED)
def test_a_tlog_event_with_a_field_the_log_contradicts_is_dropped(tmp_path: Path, field: str, value: float,
                                                                    said: str) -> None:
    _tlog_flight(tmp_path / "f.tlog", {field: value})
    ev, info = read_events(tmp_path / "f.tlog")
    assert len(ev) == EVENTS - 1 and 12.05 not in [round(t % 100, 2) for t in ev.time_s.tolist()]
    (s,) = info["skipped"]
    assert s["kind"] == "event" and said in s["reason"] and info["implausible_events"] == 1
    packet = (tmp_path / "f.tlog").read_bytes()[s["offset"] + 8:s["offset"] + s["length"]]  # after the time stamp
    assert packet[0] == 0xFD and int.from_bytes(packet[7:10], "little") == 180  # MAVLink 2, CAMERA_FEEDBACK
    assert len(packet) == 10 + packet[1] + 2

def _quaternion(roll: float, pitch: float, yaw: float) -> tuple[float, float, float, float]:
    """(w, x, y, z) of a roll, pitch, yaw in degrees (the Z-Y-X convention PX4 uses)."""
    cr, sr = math.cos(math.radians(roll) / 2), math.sin(math.radians(roll) / 2)
    cp, sp = math.cos(math.radians(pitch) / 2), math.sin(math.radians(pitch) / 2)
    cy, sy = math.cos(math.radians(yaw) / 2), math.sin(math.radians(yaw) / 2)
    return (cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy)


def _ulog_flight(path: Path, altered: dict[str, float], at: int = 5) -> None:
    """vehicle_attitude and vehicle_global_position at 10 Hz, camera_capture every 2 s, with the
    `altered` fields (alt, ground_distance, roll, pitch, yaw) of event `at` changed."""
    att, pos, cams = [], [], []
    for k in range(10 * 2 * (EVENTS + 1)):
        t = k / 10
        lat, lon, roll, pitch, yaw = _flight_rows(t)
        att.append((int(t * 1e6), *_quaternion(roll, pitch, yaw)))
        pos.append((int(t * 1e6), lat, lon, ALT_AMSL))
    for i, (t, lat, lon, f) in enumerate(_events(("alt", "ground_distance"), altered, at)):
        cams.append((int(t * 1e6), lat, lon, f["alt"], f["ground_distance"], *_quaternion(f["roll"], f["pitch"], f["yaw"]), i, 1))
    q = [("float[4]", "q")]
    path.write_bytes(ulog_of_rows({
        "camera_capture": ([("uint64_t", "timestamp"), ("double", "lat"), ("double", "lon"), ("float", "alt"),
                            ("float", "ground_distance"), *q, ("uint32_t", "seq"), ("int8_t", "result")], cams),
        "vehicle_attitude": ([("uint64_t", "timestamp"), *q], att),
        "vehicle_global_position": ([("uint64_t", "timestamp"), ("double", "lat"), ("double", "lon"), ("float", "alt")], pos)}))


def test_ulog_events_agree_with_the_attitude_and_position_logged(tmp_path: Path) -> None:
    _ulog_flight(tmp_path / "f.ulg", {})
    ev, info = read_events(tmp_path / "f.ulg")
    assert len(ev) == EVENTS and info["dropped_events"] == 0
    assert "vehicle_attitude" in info["checks"] and "vehicle_global_position" in info["checks"]
    assert ev.yaw == pytest.approx([90.0] * EVENTS, abs=1e-3)


@pytest.mark.parametrize("field,value,said", [
    ("alt", 3_838_300.0, "altitude 3838300.00 m"), ("ground_distance", 7_047_000.0, "relative altitude 7047000.00 m"),
    ("alt", 340.0, "altitude 340.00 m"), ("roll", 25.0, "roll 25.00°"), ("pitch", 12.0, "pitch 12.00°"),
    ("yaw", 180.0, "yaw 180.00°")])
def test_a_ulog_event_with_a_field_the_log_contradicts_is_dropped(tmp_path: Path, field: str, value: float,
                                                                    said: str) -> None:
    _ulog_flight(tmp_path / "f.ulg", {field: value})
    ev, info = read_events(tmp_path / "f.ulg")
    assert len(ev) == EVENTS - 1 and 12.05 not in [round(t, 2) for t in ev.time_s.tolist()]
    (s,) = info["skipped"]
    assert s["kind"] == "event" and said in s["reason"] and info["implausible_events"] == 1
