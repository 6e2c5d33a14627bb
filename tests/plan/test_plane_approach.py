"""A plane's way out onto its first line (issue 36), read from the exported missions as ArduPilot reads them: the
nav item into each sortie's first lead-in waypoint comes from behind it (within 90° of the line's direction; a
take-off's leg is met from its start where it is longer than the climb-out, from beyond its end where shorter, the
plane turning back to it after the climb, and not within two L1 distances of it, where it may be either), and where it
first turns
by more than 90° onto the line's extension, it does so at least the turn's diameter 2R and one L1 distance behind
the lead-in (R from the bank angle, L1 as ArduPlane's AP_L1_Control sets it: damping × period × speed / π).

Met heading away from the line, ArduPlane SITL (8 m/s from 270°, S03) turned round at the lead-in and passed the
line's first station 68 m off it, where its camera started a base early: 61 photos for 60 planned."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from aerosurvey.cli import main
from conftest import make_spec

G = 9.80665
BANK_DEG, PERIOD_S, DAMPING = 30.0, 17.0, 0.75  # the spec's bank angle and NAVL1_PERIOD; ArduPlane's NAVL1_DAMPING
TAKEOFF_MS, CLIMB_RATE_MS = 22.0, 6.9  # the spec's cruise speed (the take-off's air speed) and climb rate
WAYPOINT, TAKEOFF, CHANGE_SPEED, CAM_TRIGG_DIST = 16, 22, 178, 206


def _items(path: Path) -> list[list[float]]:
    """The QGC WPL 110 rows: seq, current, frame, command, p1..p4, lat, lon, alt, autocontinue."""
    lines = path.read_text().splitlines()
    assert lines[0].startswith("QGC WPL 110")
    return [[float(x) for x in line.split("\t")] for line in lines[1:]]


def _first_line_ways_in(path: Path) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None, bool, float]]:
    """Per line whose way in is not a turn from the line before (the nav item before its lead-in is no line's end,
    which the camera's stop follows): (the place before the lead-in, the lead-in, the line's first station, the
    place before that place or None, whether that place is the take-off, the survey speed), east and north metres
    of home."""
    rows = _items(path)
    lat0, lon0 = rows[0][8], rows[0][9]
    k = math.pi / 180.0 * 6_371_000.0

    def xy(r: list[float]) -> np.ndarray:
        return np.array([(r[9] - lon0) * k * math.cos(math.radians(lat0)), (r[8] - lat0) * k])

    speed = next(r[5] for r in rows if int(r[3]) == CHANGE_SPEED)
    nav: list[tuple[int, list[float]]] = []  # (row index, row) of the items with a place
    out = []
    for i, r in enumerate(rows[1:], start=1):
        cmd = int(r[3])
        if cmd in (WAYPOINT, TAKEOFF):
            nav.append((i, r))
        elif cmd == CAM_TRIGG_DIST and r[4] > 0.0:  # the camera starts at the nav item before: the first station
            assert len(nav) >= 3, "a line's first station, its lead-in and a place before them"
            (_, start), (_, lead), (j, before) = nav[-1], nav[-2], nav[-3]
            after_before = rows[j + 1]
            if int(after_before[3]) == CAM_TRIGG_DIST and after_before[4] == 0.0:
                continue  # from the line before's end: a reversal between lines
            takeoff = int(before[3]) == TAKEOFF
            prior = None if takeoff or len(nav) < 4 else xy(nav[-4][1])
            out.append((xy(rows[0]) if takeoff else xy(before), xy(lead), xy(start), prior, takeoff,
                        float(speed)))
    return out


def _climb_out(direction: np.ndarray, climb_s: float, wind: np.ndarray) -> float:
    """Metres over the ground the take-off climbs along `direction` (a unit vector): `climb_s` at 22 m/s of air speed
    (the spec's cruise speed, ArduPlane's take-off speed), its nose steered so that the wind `wind` adds up to a
    ground velocity along it."""
    across = float(wind @ np.array([-direction[1], direction[0]]))
    return climb_s * (float(wind @ direction) + math.sqrt(TAKEOFF_MS**2 - across**2))


def _check_ways_in(path: Path, climb_s: float, wind: np.ndarray) -> int:
    checked = 0
    for before, lead, start, prior, takeoff, speed in _first_line_ways_in(path):
        line = (start - lead) / np.hypot(*(start - lead))
        came = lead - before
        l1 = DAMPING * PERIOD_S * speed / math.pi
        if takeoff:  # the plane climbs along the leg and meets the lead-in after its climb, or turns back to it
            climbed = _climb_out(came / np.hypot(*came), climb_s, wind)
            # not either way (a metre's play: the planning grid's bearings and scale, the altitude's rounding)
            assert abs(np.hypot(*came) - climbed) > 2.0 * l1 - 1.0, (path.name, before, lead, climbed)
            came = came if np.hypot(*came) > climbed else -came
        assert float(came @ line) >= -1e-6 * np.hypot(*came), (path.name, before, lead, start)
        checked += 1
        if prior is not None and float((before - prior) @ (lead - before)) < 0.0:  # a turn of more than 90° there
            radius = speed**2 / (G * math.tan(math.radians(BANK_DEG)))
            assert np.hypot(*came) >= 2.0 * radius + l1 - 1e-6, (path.name, before, lead)
    return checked


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(width=st.floats(300.0, 900.0), depth=st.floats(200.0, 600.0), heading=st.floats(0.0, 180.0),
       launch_bearing=st.floats(0.0, 2.0 * math.pi), launch_m=st.floats(0.0, 900.0), wind_ms=st.sampled_from([0.0, 5.0, 8.0]),
       wind_from=st.integers(0, 359), minutes=st.sampled_from([8.0, 12.0, 40.0]))
def test_a_planes_way_out_meets_its_first_line_from_behind(tmp_path_factory, width, depth, heading, launch_bearing,
                                                          launch_m, wind_ms, wind_from, minutes):
    """Random rectangles, line headings, launch points (inside and round the area), winds and batteries (one to
    several sorties): in every sortie's mission and the whole one, every line not flown into from the line before
    is met from behind its lead-in, and a turn of more than 90° onto its extension lies 2R + L1 behind it at least."""
    tmp = tmp_path_factory.mktemp("approach")
    k_lat, k_lon = 1 / 111_320.0, 1 / (111_320.0 * math.cos(math.radians(49.4)))
    ring = [[15.0 + x * k_lon, 49.4 + y * k_lat] for x, y in ((0, 0), (width, 0), (width, depth), (0, depth), (0, 0))]
    cx, cy = width / 2.0 + launch_m * math.cos(launch_bearing), depth / 2.0 + launch_m * math.sin(launch_bearing)
    over = {"vehicle": {"type": "plane", "cruise_speed_ms": TAKEOFF_MS, "climb_rate_ms": CLIMB_RATE_MS, "bank_angle_deg": BANK_DEG,
                        "nav_period_s": PERIOD_S},
            "flight": {"heading": heading}, "battery": {"usable_min": minutes},
            "targets": {"gsd_cm": 2.5, "side_overlap": 0.6, "forward_overlap": 0.75},
            "conditions": {"wind": f"{wind_ms:g}@{wind_from}"}, "area": {"launch": [15.0 + cx * k_lon, 49.4 + cy * k_lat]}}
    out = tmp / "plan"
    res = CliRunner().invoke(main, ["plan", str(make_spec(tmp, over, area=ring)), "-o", str(out)])
    assert res.exit_code == 0, res.output
    files = sorted(out.glob("*.waypoints"))
    to = math.radians(wind_from + 180.0)  # east and north: where the wind blows to
    wind = wind_ms * np.array([math.sin(to), math.cos(to)])
    checked = 0
    for f in files:
        takeoff = next(r for r in _items(f) if int(r[3]) == TAKEOFF)
        checked += _check_ways_in(f, takeoff[10] / CLIMB_RATE_MS, wind)  # to the take-off's altitude
    assert checked >= len(files)
