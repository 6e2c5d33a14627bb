"""The way home takes part in where a pass starts (`route.order_pass`): of a pass's starts, the one whose survey, way
there and way home fly shortest in the wind. Checked on a copter's plan whose launch point lies south of a block of
east-west lines in a wind from the south-west: the way there alone (as before) started it at the south-east corner,
leaving a long way home from the north-east one, partly into the wind; with the way home it starts at the north-west
corner and ends at the south-west one, next to the launch point. The estimate's ways out and home are those of an
independent integration of the track (`test_wind`'s copter velocity, `independent_motion`'s stop-to-stop time)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from tests.independent_motion import stop_to_stop_time
from tests.plan.test_wind import _copter_velocity, _fly

from aerosurvey.inputs import plan_from_files
from aerosurvey.spec import load_spec
from conftest import make_spec

SPEED, MOST_AIR, ACCEL, JERK = 12.0, 14.0, 2.5, 1.0  # the copter's cruise speed, air speed at its lean limit
WIND = "8@225"
# about 1.4 km east-west by 0.8 km north-south; the launch point about 220 m south of the middle of its south edge
AREA = [[15.0, 49.4], [15.02, 49.4], [15.02, 49.4072], [15.0, 49.4072], [15.0, 49.4]]
LAUNCH = [15.01, 49.398]


def _plan(folder, wind: str | None, pass_start: list[float] | None = None):
    flight: dict = {"heading": 90.0}
    if pass_start is not None:
        flight["pass_start"] = {"1": pass_start}
    over: dict = {"vehicle": {"type": "copter", "cruise_speed_ms": SPEED, "acceleration_ms2": ACCEL,
                              "max_airspeed_ms": MOST_AIR},
                  "flight": flight, "area": {"launch": LAUNCH}}
    if wind is not None:
        over["conditions"] = {"wind": wind}
    folder.mkdir()
    return plan_from_files(load_spec(make_spec(folder, over, area=AREA)))


def _integrated_transit(plan) -> float:
    """The way from the launch point to the first waypoint and from the last one home, each a straight leg from rest to
    rest: its still-air stop-to-stop time, plus what the wind adds to cruising it (the track integrated, its ground
    velocity at most the cruise speed, and where that takes more air speed than the lean limit allows, less)."""
    k = plan.site.grid_scale
    home = np.array(plan.launch.home_xy) / k
    assert plan.waypoints[0].kind != "transit" and plan.waypoints[-1].kind != "transit"  # no detours: one leg each way
    first = np.array([plan.waypoints[0].x, plan.waypoints[0].y]) / k
    last = np.array([plan.waypoints[-1].x, plan.waypoints[-1].y]) / k
    to = math.radians(plan.wind["grid_from_deg"] + 180.0)
    wind = plan.wind["speed_ms"] * np.array([math.sin(to), math.cos(to)])  # x east, y north of the grid
    total = 0.0
    for a, b in ((home, first), (last, home)):
        d = float(np.hypot(*(b - a)))
        flown = _fly(np.array([a, b]), lambda u: _copter_velocity(u, wind, SPEED, MOST_AIR))
        total += stop_to_stop_time(d, SPEED, ACCEL, JERK) + flown - d / SPEED
    return total


def test_the_way_home_chooses_the_start_when_that_is_shorter(tmp_path):
    auto = _plan(tmp_path / "auto", WIND)
    k = auto.site.grid_scale
    start, end = auto.route.runs[0].station_xy[0] / k, auto.route.runs[-1].station_xy[-1] / k
    centre = np.array(auto.site.area.centroid.coords[0]) / k
    assert start[0] < centre[0] and start[1] > centre[1]  # north-west
    assert end[0] < centre[0] and end[1] < centre[1]  # south-west, next to the launch point
    # the start the way there alone chose: the south-east corner, pinned by flight.pass_start
    before = _plan(tmp_path / "before", WIND, pass_start=[15.02, 49.4])
    first = before.route.runs[0].station_xy[0] / k
    assert first[0] > centre[0] and first[1] < centre[1]
    assert auto.estimates["total_time_s"] < before.estimates["total_time_s"] - 30.0
    # every corner pinned flies no shorter than the one chosen
    for i, corner in enumerate([[15.0, 49.4], [15.0, 49.4072], [15.02, 49.4072]]):
        pinned = _plan(tmp_path / f"corner{i}", WIND, pass_start=corner)
        assert auto.estimates["total_time_s"] <= pinned.estimates["total_time_s"] + 0.05
    # the estimate's ways out and home are those of the flight integrated here
    for plan in (auto, before):
        assert plan.estimates["transit_time_s"] == pytest.approx(_integrated_transit(plan), rel=5e-3)
