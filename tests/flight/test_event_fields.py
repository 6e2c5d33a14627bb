"""Every field of a camera event checked against what the log recorded around it: a wait at a
waypoint keeps its photo; an altitude, relative altitude or attitude that a damaged record
altered is dropped with its reason.

The flights are built here (tests/flight/dfwriter.py writes them as ArduPilot logs them): a
copter flies west to a corridor line's first waypoint, waits there about 9 s drifting in the
wind, and flies the line north, climbing with the terrain, its yaw wobbling across north (359°
to 1°), photographing every 21 m from the end of the wait.
"""

from __future__ import annotations

import math
import struct
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from pymavlink import DFReader

sys.path.insert(0, str(Path(__file__).resolve().parent))
from dfwriter import camera_log, flight_log  # noqa: E402

CAM_LENGTH = 3 + struct.calcsize("<QBHIHiiiiihhH")  # CAM's layout QBHIHLLeeeccC

from aerosurvey.flight.events import read_events  # noqa: E402

DATA = Path(__file__).resolve().parents[1] / "data"

LAT0, LON0 = 49.4, 15.0
HOME_AMSL, HEIGHT = 200.0, 50.0
WEEK, GPS_MS0 = 2300, 300_000_000  # the GPS time at boot time 0
FIX_S, FIX_LOG_DELAY_S = 0.2, 0.03  # the receiver's period; a fix is logged 30 ms after it
ACCEL, BRAKE, SPEED = 2.5, 3.0, 8.0  # m/s², m/s², m/s
ARRIVE_S, LEAVE_S = 119.8, 128.9  # the wait at the line's first waypoint
STOP_X = -0.5  # the approach overshoots the waypoint by 0.5 m, then the wind pushes the copter east
LEAVE_X = 0.5  # where it is when the wait ends and the first photo is taken
PHOTO_EVERY_M, PHOTOS = 21.0, 16
CLIMB_MS = 1.0  # along the line


def _approach_x(t: float) -> float:
    """East of the waypoint (m) while flying west at SPEED, braking at BRAKE to stop at ARRIVE_S."""
    brake = SPEED / BRAKE
    left = ARRIVE_S - t
    if left >= brake:
        return STOP_X + SPEED * brake / 2 + SPEED * (left - brake)
    return STOP_X + BRAKE * left * left / 2


def _line_y(t: float) -> float:
    """North of the waypoint (m) after the wait: accelerating at ACCEL to SPEED."""
    s = t - LEAVE_S
    ramp = SPEED / ACCEL
    return ACCEL * s * s / 2 if s <= ramp else SPEED * ramp / 2 + SPEED * (s - ramp)


def position(t: float) -> tuple[float, float]:
    """Metres east and north of the waypoint at time t."""
    if t <= ARRIVE_S:
        return _approach_x(t), 0.0
    if t < LEAVE_S:  # drifting east in the wind, wobbling by centimetres across
        f = (t - ARRIVE_S) / (LEAVE_S - ARRIVE_S)
        return STOP_X + f * (LEAVE_X - STOP_X) + 0.05 * math.sin(7.0 * t), 0.12 * math.sin(3.1 * t)
    return LEAVE_X, _line_y(t)


def attitude(t: float) -> tuple[float, float, float]:
    """Roll, pitch, yaw (degrees, yaw 0..360) at time t: pitched into the acceleration, yaw
    turning from west to north during the wait."""
    roll = 1.5 * math.sin(0.9 * t)
    if t <= ARRIVE_S:
        brake = ARRIVE_S - t <= SPEED / BRAKE
        return roll, 12.0 if brake else -2.0, 270.0
    if t < LEAVE_S:
        return roll, 0.5 * math.sin(2.0 * t), 270.0 + 90.0 * min(1.0, (t - ARRIVE_S) / 4.0) - (360.0 if t - ARRIVE_S >= 4.0 else 0.0)
    return roll, -12.0 if t - LEAVE_S <= SPEED / ACCEL else -4.0, (1.5 * math.sin(1.1 * t)) % 360.0


def altitude(t: float) -> float:
    """Metres above sea level at time t."""
    return HOME_AMSL + HEIGHT + CLIMB_MS * max(0.0, t - LEAVE_S)


def _latlon(x: float, y: float) -> tuple[float, float]:
    k = math.pi / 180 * 6_378_137.0
    return LAT0 + y / k, LON0 + x / (k * math.cos(math.radians(LAT0)))


@dataclass(frozen=True)
class Flight:
    fixes: list[tuple[float, int, int, float, float, float]]
    attitudes: list[tuple[float, float, float, float]]
    cams: list[tuple[float, int, int, float, float, float, float, float, float, float]]


def corridor_wait() -> Flight:
    """From 100 s to the last photo plus 5 s: GPS fixes at 5 Hz, attitude at 10 Hz, and the
    photos: the first at the end of the wait, then every PHOTO_EVERY_M along the line."""
    photo_t = [LEAVE_S]
    for k in range(1, PHOTOS):  # the times the line reaches each photo's distance (bisection)
        lo, hi = LEAVE_S, LEAVE_S + 200.0
        for _ in range(60):
            mid = (lo + hi) / 2
            lo, hi = (mid, hi) if _line_y(mid) < k * PHOTO_EVERY_M else (lo, mid)
        photo_t.append(round(hi, 3))
    end = photo_t[-1] + 5.0
    fixes = []
    for k in range(round(100.0 / FIX_S), round(end / FIX_S)):
        t = k * FIX_S
        lat, lon = _latlon(*position(t))
        fixes.append((t + FIX_LOG_DELAY_S, WEEK, GPS_MS0 + round(t * 1000), lat, lon, altitude(t)))
    attitudes = [(k / 10, *attitude(k / 10)) for k in range(1000, round(end * 10))]
    cams = []
    for t in photo_t:
        last_fix = max(f for f in fixes if f[0] <= t)
        lat, lon = _latlon(*position(t))
        cams.append((t, WEEK, last_fix[2], lat, lon, altitude(t), altitude(t) - HOME_AMSL, *attitude(t)))
    return Flight(fixes, attitudes, cams)


def _write(tmp_path: Path, flight: Flight, name: str = "corridor.bin") -> Path:
    path = tmp_path / name
    path.write_bytes(flight_log(flight.fixes, flight.attitudes, flight.cams))
    return path


def test_the_flight_is_what_the_test_says() -> None:
    """The wait: the copter passes the first photo's place at braking speed (over 2 m/s, faster
    than a hover) less than 10 s before the photo, then stays within 2 m of it until the photo."""
    f = corridor_wait()
    px, py = position(LEAVE_S)
    near = [round((t - FIX_LOG_DELAY_S) / FIX_S) for t, *_ in f.fixes
            if math.dist(position(t - FIX_LOG_DELAY_S), (px, py)) <= 2.0]
    assert near == list(range(near[0], near[-1] + 1))  # one stay, no fix away between
    assert near[0] * FIX_S < ARRIVE_S - 1.0 and near[-1] * FIX_S >= LEAVE_S
    before = ARRIVE_S - math.sqrt(2 * (LEAVE_X - STOP_X) / BRAKE)  # when the approach passes the photo's place
    assert BRAKE * (ARRIVE_S - before) > 2.0 and LEAVE_S - before < 10.0
    assert len(f.cams) == PHOTOS and f.cams[0][0] == LEAVE_S


def test_a_photo_at_the_end_of_a_wait_at_a_waypoint_is_kept(tmp_path: Path) -> None:
    flight = corridor_wait()
    ev, info = read_events(_write(tmp_path, flight))
    assert len(ev) == len(flight.cams), [s["reason"] for s in info["skipped"]]
    assert ev.time_s[0] == pytest.approx(LEAVE_S) and info["dropped_events"] == 0
    assert np.allclose(ev.alt_m - ev.rel_alt_m, HOME_AMSL) and ev.alt_m[-1] - ev.alt_m[0] > 30.0
    assert ev.yaw.min() < 1.0 and ev.yaw.max() > 359.0  # both sides of north


def _altered(flight: Flight, at: int, field: str, value: float) -> Flight:
    names = ("time", "week", "ms", "lat", "lon", "alt", "rel_alt", "roll", "pitch", "yaw")
    cams = list(flight.cams)
    cams[at] = tuple(value if name == field else v for name, v in zip(names, cams[at]))  # type: ignore[assignment]
    return Flight(flight.fixes, flight.attitudes, cams)


# the figures of issue 32 (a CAM record completed with foreign bytes, bit flips), then values a
# vehicle could log that the GPS track or the attitude log contradicts
ALTERED = [("alt", 3_838_000.0, "altitude 3838000.00 m"), ("rel_alt", 7_047_000.0, "relative altitude 7047000.00 m"),
           ("roll", -279.0, "roll -279.00°"), ("pitch", 210.0, "pitch 210.00°"), ("yaw", 606.0, "yaw 606.00°"),
           ("alt", 300.0, "altitude 300.00 m"), ("rel_alt", 20.0, "relative altitude 20.00 m"),
           ("roll", 20.0, "roll 20.00°"), ("pitch", 10.0, "pitch 10.00°"), ("yaw", 90.0, "yaw 90.00°")]


@pytest.mark.parametrize("at", [0, 7])  # the photo at the end of the wait, and one on the line
@pytest.mark.parametrize("field,value,said", ALTERED)
def test_an_event_with_a_field_the_log_contradicts_is_dropped_with_the_field_and_value(
        tmp_path: Path, at: int, field: str, value: float, said: str) -> None:
    flight = corridor_wait()
    ev, info = read_events(_write(tmp_path, _altered(flight, at, field, value)))
    kept = [round(t, 3) for t in ev.time_s.tolist()]
    assert len(ev) == len(flight.cams) - 1 and flight.cams[at][0] not in kept
    (s,) = info["skipped"]
    assert s["kind"] == "event" and said in s["reason"] and s["length"] == CAM_LENGTH
    assert info["implausible_events"] == info["dropped_events"] == 1
    assert np.all(np.abs(ev.roll) <= 180.0) and np.all(np.abs(ev.pitch) <= 90.0)


@pytest.mark.parametrize("field,change", [("alt", 1.0), ("rel_alt", -1.0), ("roll", 2.0), ("pitch", -2.0), ("yaw", 2.0)])
def test_a_field_within_the_checks_floor_is_kept(tmp_path: Path, field: str, change: float) -> None:
    """A field off by less than the floor (3 m, 5°) cannot be told from the log: it comes back as logged."""
    flight = corridor_wait()
    names = ("alt", "rel_alt", "roll", "pitch", "yaw")
    value = flight.cams[7][5 + names.index(field)] + change
    ev, info = read_events(_write(tmp_path, _altered(flight, 7, field, value % 360.0 if field == "yaw" else value)))
    assert len(ev) == len(flight.cams) and info["dropped_events"] == 0
    got = {"alt": ev.alt_m, "rel_alt": ev.rel_alt_m, "roll": ev.roll, "pitch": ev.pitch, "yaw": ev.yaw}[field][7]
    assert got == pytest.approx(value % 360.0 if field == "yaw" else value, abs=0.01)


@pytest.mark.parametrize("name", ["sitl_copter_survey.bin", "sitl_plane_kubad.bin"])
def test_every_event_of_the_undamaged_sitl_logs_comes_back_with_every_field(name: str) -> None:
    """No false drop: every CAM event pymavlink reads comes back, each field as logged, and the
    checks against the GPS track's altitude and ATT ran."""
    r = DFReader.DFReader_binary(str(DATA / name))
    logged = []
    while (m := r.recv_match(type="CAM")) is not None:
        logged.append((m.TimeUS / 1e6, m.Lat, m.Lng, m.Alt, m.RelAlt, m.R, m.P, m.Y))
    ev, info = read_events(DATA / name)
    assert info["dropped_events"] == 0 and info["skipped"] == []
    got = np.column_stack([ev.time_s, ev.lat, ev.lon, ev.alt_m, ev.rel_alt_m, ev.roll, ev.pitch, ev.yaw])
    assert got == pytest.approx(np.array(logged), abs=1e-6)
    assert "GPS track's altitude" in info["checks"] and "ATT" in info["checks"]


def test_without_gps_altitudes_the_home_altitude_is_checked(tmp_path: Path) -> None:
    """A log of camera events only: an event whose altitude and relative altitude put home 40 m
    off the others' is dropped."""
    events = [(10.0 + 2 * i, 49.4 + i * 1e-4, 15.0, 250.0 + 0.5 * i, 50.0 + 0.5 * i) for i in range(20)]
    events[6] = (*events[6][:3], events[6][3] + 40.0, events[6][4])
    path = tmp_path / "cams.bin"
    path.write_bytes(camera_log(events))
    ev, info = read_events(path)
    assert len(ev) == 19 and 22.0 not in ev.time_s.tolist()
    (s,) = info["skipped"]
    assert "put home at 240.0 m" in s["reason"] and "home altitude" in info["checks"]
