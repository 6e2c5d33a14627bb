"""A plane's ways out and home as the route step and the whole mission's estimate time them, against an independent
integration of the track (`test_wind`'s `_steer`: the air velocity steered against the wind along each leg): the way
out (`route.Transits`, where a pass starts) climbs at the take-off's air speed along its first leg and flies the
rest at the survey speed; the whole mission's way home (manifest `estimates`) flies through the landing's approach
waypoint and the approach at the landing speed, as each sortie's does."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tests.plan.test_wind import _steer

from aerosurvey.inputs import plan_from_files
from aerosurvey.plan.flight_time import Kinematics, plane_reversal
from aerosurvey.plan.route import Transits
from aerosurvey.spec import load_spec
from conftest import make_spec

SURVEY, TAKEOFF, LANDING = 12.5, 22.0, 18.4  # air speeds, m/s: the survey's, the climb-out's, the approach's
CLIMB_M, CLIMB_RATE = 100.0, 5.0


def _ground_speed(direction: np.ndarray, wind: np.ndarray, air: float) -> float:
    return float(_steer(direction, wind, air) @ direction)


def _after_climb(u: np.ndarray, wind: np.ndarray, rest: float, survey: float, slowing_s: float = 15.0) -> float:
    """Seconds over the `rest` of a leg after the climb (longer than the slowing): its air speed falling evenly from
    the take-off's to `survey` over `slowing_s` (stepped through; ArduPlane SITL, 8 m/s from 270°: from 27.8 m/s at
    the climb's end to 12.5 m/s some 15 s on), then at that speed."""
    steps = 3000
    slowed = sum(_ground_speed(u, wind, TAKEOFF + (survey - TAKEOFF) * (i + 0.5) / steps) for i in range(steps)) * slowing_s / steps
    assert slowed < rest
    return slowing_s + (rest - slowed) / _ground_speed(u, wind, survey)


@settings(max_examples=40, deadline=None)
@given(towards=st.floats(0.0, 2.0 * math.pi), w=st.floats(0.0, 8.0), bearing=st.floats(0.0, 2.0 * math.pi),
       length=st.floats(1100.0, 3000.0))
def test_the_routes_way_out_climbs_at_the_take_off_speed(towards, w, bearing, length):
    """A leg longer than the climb-out (20 s at up to 30 m/s over the ground): 20 s of climb at 22 m/s through the
    air along the leg, 15 s slowing evenly to the survey's 12.5 m/s (`_after_climb`) and the rest of it at that speed (before: the whole
    leg at the survey speed, at least the climb's 20 s; then without the slowing)."""
    wind = np.array([w * math.cos(towards), w * math.sin(towards)])
    u = np.array([math.cos(bearing), math.sin(bearing)])
    kin = Kinematics("plane", SURVEY, 2.0, 27.6, wind_x=float(wind[0]), wind_y=float(wind[1]))
    transits = Transits(kin, lambda first: (0.0, 0.0), CLIMB_M, CLIMB_RATE, TAKEOFF)
    climb_s = CLIMB_M / CLIMB_RATE
    climbed = climb_s * _ground_speed(u, wind, TAKEOFF)
    assert length - climbed > 15.0 * _ground_speed(u, wind, TAKEOFF)  # longer than the slowing
    expected = climb_s + _after_climb(u, wind, length - climbed, SURVEY)
    lead, first = u * length, u * (length + 150.0)  # its line runs on from the lead-in the way the leg came
    assert transits.out_s((0.0, 0.0), (float(lead[0]), float(lead[1])),
                          (float(first[0]), float(first[1]))) == pytest.approx(expected, rel=1e-4)  # Simpson's rule


@pytest.mark.parametrize("scale", [0.9996, 1.25])
def test_the_routes_way_out_is_timed_in_metres_whatever_the_grids_scale(scale):
    """The way out laid in planning-grid metres (`scale` of them a metre: a transverse Mercator's 0.9996 at its
    central meridian; 1.25 to make it plain) takes the time of the same way in metres: a 300 m leg, shorter than the
    climb-out (about 440 m), climbed past and turned back to (it once compared grid lengths with the climb-out in
    metres: 1.25 took a 375 m leg for 300)."""
    kin = Kinematics("plane", SURVEY, 2.0, 27.6, reach_m=40.0)
    u = np.array([0.6, 0.8])

    def out_s(k: float) -> float:
        transits = Transits(kin, lambda first: (0.0, 0.0), CLIMB_M, CLIMB_RATE, TAKEOFF, climb_out=0.0, grid_scale=k)
        lead, first = u * 300.0 * k, u * 450.0 * k
        return transits.out_s((0.0, 0.0), (float(lead[0]), float(lead[1])), (float(first[0]), float(first[1])))

    assert out_s(scale) == pytest.approx(out_s(1.0), rel=1e-9)


def test_the_whole_missions_way_home_flies_the_landing_approach(tmp_path):
    """A plane landing into a wind from the east (its approach waypoint 800 m west of home, downwind) in 5 m/s
    from the east, its lines ending east of home: the whole mission's estimate times the way home from the last
    line's end to the approach waypoint at the survey speed and the approach at the landing speed, as the sorties
    do (before: straight to the launch point at the survey speed)."""
    area = [[15.0, 49.4], [15.012, 49.4], [15.012, 49.405], [15.0, 49.405], [15.0, 49.4]]
    over = {"vehicle": {"type": "plane", "cruise_speed_ms": TAKEOFF, "climb_rate_ms": 6.9, "landing_speed_ms": LANDING},
            "flight": {"heading": 90.0, "end": "land", "wind_from_deg": 90.0, "approach_m": 800.0},
            "targets": {"gsd_cm": 2.5, "side_overlap": 0.6, "forward_overlap": 0.75},
            "conditions": {"wind": "5@90"}, "area": {"launch": [15.006, 49.3985]}}
    plan = plan_from_files(load_spec(make_spec(tmp_path, over, area=area)))
    k = plan.site.grid_scale
    to = math.radians(plan.wind["grid_from_deg"] + 180.0)
    wind = 5.0 * np.array([math.sin(to), math.cos(to)])
    survey = plan.sensor.kinematics.speed_ms
    home = np.asarray(plan.launch.home_xy) / k
    # the approach waypoint 800 m downwind of home, along the wind's grid bearing (the meridian convergence here
    # is under 0.1°: under 1.4 m, up to 0.1 s on each of the two legs it ends and begins, besides the estimate's
    # rounding to 0.05 s)
    approach = home + 800.0 * np.array([math.sin(to), math.cos(to)])
    wps = plan.waypoints
    last = max(i for i, w in enumerate(wps) if w.kind != "transit")
    way = [np.array([w.x, w.y]) / k for w in wps[last:]] + [approach]

    def leg_time(a: np.ndarray, b: np.ndarray, air: float) -> float:
        d = float(np.hypot(*(b - a)))
        return 0.0 if d == 0.0 else d / _ground_speed((b - a) / d, wind, air)

    back = sum(leg_time(a, b, survey) for a, b in zip(way, way[1:])) + leg_time(approach, home, LANDING)
    # the way out: to a point behind the first line's lead-in (met from home, it would be met heading away from the
    # line), there round onto the line (the turn as `plane_reversal`, the one price of a plane's turn, times it)
    behind, lead, start = (np.array([w.x, w.y]) / k for w in wps[:3])
    line = start - lead
    assert [w.kind for w in wps[:3]] == ["transit", "lead_in", "line_start"]
    u = (behind - home) / float(np.hypot(*(behind - home)))
    assert float(u @ line) < 0.0 and float((lead - behind) @ line) > 0.0
    climb_s = max(s for s in plan.altitudes.stations.alt_rel_m) / 6.9
    climbed = climb_s * _ground_speed(u, wind, TAKEOFF)
    assert climbed < float(np.hypot(*(behind - home)))  # the first leg is longer than the climb-out
    after_climb = _after_climb(u, wind, float(np.hypot(*(behind - home))) - climbed, survey)
    kin = plan.sensor.kinematics
    ahead, along = float(np.hypot(*(behind - home))), float(np.hypot(*(lead - behind)))
    (turned,) = plane_reversal(np.full(1, ahead), np.zeros(1), np.full(1, along), np.full(1, math.degrees(math.atan2(u[1], u[0]))),
                               np.full(1, math.degrees(math.atan2(line[1], line[0]))), kin)
    turn = float(turned) - ahead / _ground_speed(u, wind, survey) - leg_time(behind, lead, survey)
    assert plan.estimates["climb_time_s"] == pytest.approx(climb_s, abs=0.05)
    assert plan.estimates["transit_time_s"] == pytest.approx(after_climb + leg_time(behind, lead, survey) + turn + back, abs=0.25)
    straight = sum(leg_time(a, b, survey) for a, b in zip(way[:-1], [*way[1:-1], home]))
    assert abs(straight - back) > 5.0  # the approach counts
