"""The wind as a vector (conditions.wind): each leg's time from the wind triangle, checked against
an independent integration of the track written here (the vehicle stepped along its legs, its
air velocity steered so that air velocity + wind carries it along the leg), and the plan's
records and refusals."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import example, given, settings
from hypothesis import strategies as st

from aerosurvey.cli import main
from aerosurvey.errors import InputError
from aerosurvey.inputs import plan_from_files
from aerosurvey.plan.flight_time import Kinematics, path_time, plane_reversal, plane_transit_time
from aerosurvey.spec import load_spec, parse_wind
from conftest import make_spec

DT = 0.5  # seconds per integration step at most (a leg's last step ends on its end)
STEP_M = 2.0  # metres per step at most: under half the pursuit's 5 m carrot (17 m steps at 34 m/s swung 1.3 m off a leg)


def _steer(direction: np.ndarray, wind: np.ndarray, air: float) -> np.ndarray:
    """The ground velocity of a vehicle flying `air` m/s through the air with its track along the unit
    vector `direction`: the nose turned by the angle d off the track, found by bisection, where the
    air velocity's and the wind's parts across the track cancel (air·sin d + w·n = 0)."""
    n = np.array([-direction[1], direction[0]])
    lo, hi = -math.pi / 2, math.pi / 2
    for _ in range(40):
        mid = (lo + hi) / 2
        if air * math.sin(mid) + float(wind @ n) > 0:
            hi = mid
        else:
            lo = mid
    c, s = math.cos(lo), math.sin(lo)
    nose = np.array([c * direction[0] - s * direction[1], s * direction[0] + c * direction[1]])
    return air * nose + wind


def _copter_velocity(direction: np.ndarray, wind: np.ndarray, speed: float, most_air: float) -> np.ndarray:
    """A copter told to fly `speed` over the ground along `direction`: that, where the air speed it takes
    (|ground − wind|) is within `most_air`; else the fastest ground speed along it that is (bisection)."""
    if np.hypot(*(speed * direction - wind)) <= most_air:
        return speed * direction
    lo, hi = 0.0, speed
    for _ in range(60):
        mid = (lo + hi) / 2
        if np.hypot(*(mid * direction - wind)) <= most_air:
            lo = mid
        else:
            hi = mid
    return lo * direction


def _fly(points: np.ndarray, velocity) -> float:
    """Seconds to fly the polyline by stepping its position: at each step the velocity `velocity(towards)`
    gives for the unit vector from where it is to a point 5 m ahead on the leg (pursuit), until its
    projection passes each leg's end."""
    t = 0.0
    pos = points[0].astype(float)
    for a, b in zip(points[:-1], points[1:]):
        leg = b - a
        length = float(np.hypot(*leg))
        u = leg / length
        pos = a.astype(float)
        while True:
            along = float((pos - a) @ u)
            if along >= length - 1e-6:
                break
            carrot = a + u * min(along + 5.0, length + 5.0)
            d = carrot - pos
            v = velocity(d / np.hypot(*d))
            step = min(DT, STEP_M / float(np.hypot(*v)))  # short of the carrot: a longer step swings about the leg
            ahead = float(v @ u)
            if along + ahead * step > length:  # the last part of a step
                step = (length - along) / ahead
            pos = pos + v * step
            t += step
    return t


def _wind(speed: float, towards_deg: float) -> np.ndarray:
    a = math.radians(towards_deg)
    return np.array([speed * math.cos(a), speed * math.sin(a)])


def _gentle_polyline(start_deg: float, turns: list[float], lengths: list[float]) -> np.ndarray:
    """A polyline whose corners turn by less than 75° (no plane reversal among them)."""
    pts, ang = [np.zeros(2)], start_deg
    for turn, length in zip([0.0, *turns], lengths):
        ang += turn
        pts.append(pts[-1] + length * np.array([math.cos(math.radians(ang)), math.sin(math.radians(ang))]))
    return np.asarray(pts)


legs = st.integers(1, 4).flatmap(lambda n: st.tuples(st.lists(st.floats(-70, 70), min_size=n - 1, max_size=n - 1),
                                                       st.lists(st.floats(100, 400), min_size=n, max_size=n)))


@settings(max_examples=10, deadline=None)
@given(air=st.floats(12, 25), share=st.floats(0, 0.8), towards=st.floats(0, 360), start=st.floats(0, 360), shape=legs)
def test_a_planes_legs_take_the_integrated_time(air, share, towards, start, shape):
    pts = _gentle_polyline(start, *shape)
    wind = _wind(share * air, towards)
    kin = Kinematics("plane", air, 2.5, 60.0, wind_x=float(wind[0]), wind_y=float(wind[1]))
    flown = _fly(pts, lambda u: _steer(u, wind, air))
    assert path_time(pts, kin) == pytest.approx(flown, rel=2e-3, abs=0.05)


@settings(max_examples=10, deadline=None)
@example(speed=13.0, margin=0.0, share=0.5, towards=0.0, start=76.0, shape=([], [100.0]))  # a run just past cruising
@example(speed=14.0, margin=0.0, share=0.75, towards=0.0, start=71.0, shape=([], [100.0]))  # a random case (0.328 s for 0.382 s)
@given(speed=st.floats(5, 15), margin=st.floats(0, 10), share=st.floats(0, 0.9), towards=st.floats(0, 360),
       start=st.floats(0, 360), shape=legs)
def test_a_copters_legs_take_the_integrated_time_more_than_in_still_air(speed, margin, share, towards, start, shape):
    """Over the same polyline, the wind adds to a copter's time what the integrated track adds to
    cruising it in still air (the stops at the corners as in still air)."""
    most_air = speed + margin  # (a copter that cannot fly its speed in still air is refused: see below)
    pts = _gentle_polyline(start, *shape)
    wind = _wind(share * most_air, towards)
    calm = Kinematics("copter", speed, 2.5, 0.0, airspeed_ms=most_air)
    windy = Kinematics("copter", speed, 2.5, 0.0, wind_x=float(wind[0]), wind_y=float(wind[1]), airspeed_ms=most_air)
    flown = _fly(pts, lambda u: _copter_velocity(u, wind, speed, most_air))
    cruised = float(np.hypot(*np.diff(pts, axis=0).T).sum()) / speed
    added = path_time(pts, windy) - path_time(pts, calm)
    assert added == pytest.approx(flown - cruised, rel=2e-3, abs=0.05)
    assert added >= -1e-9


def _reversal(air: float, radius: float, reach: float, wind: np.ndarray, u: np.ndarray, ahead: float, lateral: float,
              leg: np.ndarray, side: float) -> float:
    """Seconds from a line's end (the origin; the line along the unit vector u) to the end of the leg `leg` after a
    waypoint `ahead` along the line and `lateral` to its left, flown by stepping: along the line (the nose steered
    against the wind, `_steer`) until one L1 distance short of abreast of the waypoint (`reach` at the air speed,
    in proportion to the ground speed; at once where the waypoint is nearer or behind), then a half circle through
    the air to the left (side 1) or right (-1) at `radius`, its nose turned at air/radius rad/s from where it
    pointed and the wind added, in 4000 steps, then straight to the leg's end (`_fly`)."""
    ground = _steer(u, wind, air)
    speed = float(ground @ u)
    start = max(ahead - reach * speed / air, 0.0)
    t, pos = start / speed, start * u
    nose = math.atan2(*(ground - wind)[::-1])
    steps, turn = 4000, math.pi * radius / air
    for i in range(steps):  # the nose's direction at each step's middle
        a = nose + side * math.pi * (i + 0.5) / steps
        pos = pos + (air * np.array([math.cos(a), math.sin(a)]) + wind) * (turn / steps)
    end = ahead * u + lateral * np.array([-u[1], u[0]]) + leg
    if np.hypot(*(end - pos)) > 1e-6:
        t += _fly(np.array([pos, end]), lambda d: _steer(d, wind, air))
    return t + turn


@settings(max_examples=40, deadline=None)
@given(air=st.floats(12, 25), share=st.floats(0, 0.7), towards=st.floats(0, 360), heading=st.floats(0, 360),
       radius=st.floats(15, 80), reach=st.floats(0, 80), ahead=st.floats(-300, 300),
       lateral=st.one_of(st.just(0.0), st.floats(-250, 250)), back=st.floats(0, 300), off=st.floats(-30, 30))
@example(air=12.0, share=0.5, towards=1.0, heading=0.0, radius=15.0, reach=0.0, ahead=0.0, lateral=0.0, back=0.0,
         off=1.192092896e-07)  # no leg after the waypoint, its direction a hair off the line's: either side
@example(air=12.0, share=0.5, towards=1.0, heading=0.0, radius=15.0, reach=0.0, ahead=0.0, lateral=0.0, back=150.0,
         off=1e-6)  # a lead-in back along the line to within 3 µm: either side
def test_a_planes_reversal_takes_the_integrated_time(air, share, towards, heading, radius, reach, ahead, lateral, back,
                                                     off):
    """plane_reversal against the reversal stepped through (`_reversal`): on to the turn, the half circle in the
    moving air, straight on to the end of the leg after the waypoint (a waypoint on the line, 0 across: to the side
    the leg after it goes; onto the same line: the longer of the two sides)."""
    wind = _wind(share * air, towards)
    kin = Kinematics("plane", air, 2.5, radius, wind_x=float(wind[0]), wind_y=float(wind[1]), reach_m=reach)
    h, o = math.radians(heading), math.radians(heading + 180.0 + off)
    u, leg = np.array([math.cos(h), math.sin(h)]), back * np.array([math.cos(o), math.sin(o)])
    goes = back * (u[0] * math.sin(o) - u[1] * math.cos(o))  # the leg after the waypoint ends left (> 0) or right
    across = lateral if lateral != 0.0 else goes if abs(goes) > 0.01 else 0.0  # within 1 cm: back along the line
    flown = [_reversal(air, radius, reach, wind, u, ahead, lateral, leg, side)
             for side in ((1.0,) if across > 0 else (-1.0,) if across < 0 else (1.0, -1.0))]
    (timed,) = plane_reversal(np.array([ahead]), np.array([lateral]), np.array([back]), np.array([heading]),
                              np.array([heading + 180.0 + off]), kin)
    assert timed == pytest.approx(max(flown), rel=1e-5, abs=1e-5)


@settings(max_examples=30, deadline=None)
@given(air=st.floats(12, 25), share=st.floats(0, 0.7), towards=st.floats(0, 360), heading=st.floats(0, 360),
       jog=st.one_of(st.floats(1e-6, 1e-2), st.floats(1e-2, 60.0)), left=st.booleans())
def test_a_planes_jog_or_s_bend_is_no_reversal(air, share, towards, heading, jog, left):
    """A line with a jog across it (a corner one way, a short leg, a corner back: an S-bend, heading on as before) is
    timed as its legs flown straight in the wind, not as a half circle (a 1 mm jog once cost 15 s); the same corners
    both the same way (a U, heading back) stay a reversal, not its legs straight."""
    wind = _wind(share * air, towards)
    kin = Kinematics("plane", air, 2.5, 40.0, wind_x=float(wind[0]), wind_y=float(wind[1]), reach_m=30.0)
    h = math.radians(heading)
    u = np.array([math.cos(h), math.sin(h)])
    n = np.array([-u[1], u[0]]) * (jog if left else -jog)
    s_bend = np.array([np.zeros(2), 300.0 * u, 300.0 * u + n, 600.0 * u + n])
    u_turn = np.array([np.zeros(2), 300.0 * u, 300.0 * u + n, n])

    def straight(pts: np.ndarray) -> float:
        legs = np.diff(pts, axis=0)
        return sum(float(np.hypot(*d)) / float(_steer(d / np.hypot(*d), wind, air) @ (d / np.hypot(*d))) for d in legs)

    assert path_time(s_bend, kin) == pytest.approx(straight(s_bend), rel=1e-6)
    if jog >= 1.0:  # the U is timed as a reversal (`test_a_planes_lines_and_reversal_take_the_integrated_time`)
        assert path_time(u_turn, kin) != pytest.approx(straight(u_turn), rel=1e-6)


@settings(max_examples=15, deadline=None)
@given(air=st.floats(12, 25), share=st.floats(0, 0.7), towards=st.floats(0, 360), heading=st.floats(0, 360),
       spacing=st.floats(20, 200), left=st.booleans(), beyond=st.floats(-100, 200))
@example(air=21.0, share=0.625, towards=1.0, heading=1.0, spacing=20.0, left=False, beyond=0.0)  # 34 m/s downwind
def test_a_planes_lines_and_reversal_take_the_integrated_time(air, share, towards, heading, spacing, left, beyond):
    """path_time over a line, the connector to the next line's lead-in waypoint `beyond` past the line's end and
    `spacing` across, that lead-in (150 m) and the next line (300 m): each line flown straight in the wind, the
    connector and the lead-in as `_reversal` flies them (a 30 m turn radius, a 40 m reach)."""
    wind = _wind(share * air, towards)
    kin = Kinematics("plane", air, 2.5, 30.0, wind_x=float(wind[0]), wind_y=float(wind[1]), reach_m=40.0)
    h = math.radians(heading)
    u = np.array([math.cos(h), math.sin(h)])
    across = np.array([-u[1], u[0]]) * (spacing if left else -spacing)
    waypoint = (500.0 + beyond) * u + across
    pts = np.array([np.zeros(2), 500.0 * u, waypoint, waypoint - 150.0 * u, waypoint - 450.0 * u])
    flown = (_fly(pts[:2], lambda d: _steer(d, wind, air))
             + _reversal(air, 30.0, 40.0, wind, u, beyond, spacing if left else -spacing, -150.0 * u, 1.0 if left else -1.0)
             + _fly(pts[3:], lambda d: _steer(d, wind, air)))
    assert path_time(pts, kin) == pytest.approx(flown, rel=1e-4)


@pytest.mark.parametrize("vehicle", ["plane", "copter"])
def test_an_out_and_back_is_never_faster_in_wind(vehicle):
    """Flown out and back along any direction, a wind below the air speed only adds time."""
    speed = 16.0 if vehicle == "plane" else 10.0
    calm = Kinematics(vehicle, speed, 2.5, 50.0, airspeed_ms=13.0 if vehicle == "copter" else math.inf)
    for towards in range(0, 360, 15):
        w = _wind(6.0, towards)
        windy = Kinematics(vehicle, speed, 2.5, 50.0, wind_x=float(w[0]), wind_y=float(w[1]), airspeed_ms=calm.airspeed_ms)
        for a in range(0, 180, 20):
            u = np.array([math.cos(math.radians(a)), math.sin(math.radians(a))])
            pts = np.array([np.zeros(2), 800 * u, np.zeros(2)])
            assert path_time(pts, windy) >= path_time(pts, calm) - 1e-9


# ---- the spec, the flag, the plan's records and refusals ----------------------------------------

def test_wind_in_the_spec_and_on_the_command_line(tmp_path):
    spec = load_spec(make_spec(tmp_path, {"conditions": {"wind": {"speed_ms": 6, "from_deg": 240, "gust_ms": 9}},
                                          "vehicle": {"max_airspeed_ms": 15.0}}))
    w = spec.conditions.wind
    assert (w.speed_ms, w.from_deg, w.gust_ms) == (6.0, 240.0, 9.0) and spec.vehicle.max_airspeed_ms == 15.0
    assert load_spec(make_spec(tmp_path, {"conditions": {"wind": "6@240G9"}})).conditions.wind == w
    assert parse_wind("6@240") == parse_wind("6 @ 240") and parse_wind("6@240").gust_ms == 6.0
    assert parse_wind("4.5@0G7.5").text() == "4.5@0G7.5"


@pytest.mark.parametrize("table,needle", [
    ({"conditions": {"wind": {"speed_ms": 6}}}, "conditions.wind.from_deg is missing"),
    ({"conditions": {"wind": {"speed_ms": 6, "from_deg": 360}}}, "conditions.wind.from_deg = 360"),
    ({"conditions": {"wind": {"speed_ms": -1, "from_deg": 10}}}, "conditions.wind.speed_ms = -1"),
    ({"conditions": {"wind": {"speed_ms": 6, "from_deg": 10, "gust_ms": 5}}}, "conditions.wind.gust_ms = 5"),
    ({"conditions": {"wind": {"speed_ms": 6, "from_deg": 10, "dir": 5}}}, "unknown key(s) in [conditions.wind]: dir"),
    ({"conditions": {"wind": "six@240"}}, "conditions.wind = 'six@240'"),
    ({"conditions": {"wind": 6}}, "conditions.wind = 6"),
    ({"battery": {"usable_min": 20, "wind_ms": -1}}, "battery.wind_ms = -1"),
    ({"vehicle": {"type": "plane", "max_airspeed_ms": 20}}, "vehicle.max_airspeed_ms is for copters"),
    ({"vehicle": {"max_airspeed_ms": 0}}, "vehicle.max_airspeed_ms = 0"),
    ({"vehicle": {"landing_speed_ms": 15}}, "vehicle.landing_speed_ms is for planes"),
    ({"vehicle": {"type": "plane", "landing_speed_ms": 0}}, "vehicle.landing_speed_ms = 0"),
    ({"vehicle": {"type": "plane", "landing_speed_ms": "fast"}}, "vehicle.landing_speed_ms = 'fast'"),
])
def test_bad_winds_are_refused_in_one_line(tmp_path, table, needle):
    with pytest.raises(InputError) as e:
        load_spec(make_spec(tmp_path, table))
    assert needle in str(e.value) and "\n" not in str(e.value)


@pytest.mark.parametrize("text", ["6", "6@", "@240", "6@240G", "6@240X9", "-6@240", "6@240G3", "6@361"])
def test_bad_wind_flags_are_refused(text):
    with pytest.raises(InputError) as e:
        parse_wind(text)
    assert "--wind" in str(e.value) and "\n" not in str(e.value)


@pytest.mark.parametrize("vehicle,wind,needle", [
    ({"type": "copter"}, "6@240G9", "needs vehicle.max_airspeed_ms for a copter"),
    ({"type": "copter", "max_airspeed_ms": 9.0}, "1@240", "vehicle.max_airspeed_ms = 9 is below the survey speed 10.00 m/s"),
    ({"type": "copter", "cruise_speed_ms": 6.0, "max_airspeed_ms": 8.0}, "8@240", "8@240: not below vehicle.max_airspeed_ms 8.00 m/s"),
    ({"type": "copter", "cruise_speed_ms": 6.0, "max_airspeed_ms": 8.0}, "6@240G9",
     "gusts 9 m/s not below vehicle.max_airspeed_ms 8.00 m/s"),
    ({"type": "plane", "cruise_speed_ms": 16.0}, "6@240G16", "gusts 16 m/s not below the survey air speed"),
])
def test_a_wind_the_vehicle_cannot_make_good_is_refused(tmp_path, vehicle, wind, needle):
    spec = make_spec(tmp_path, {"vehicle": vehicle, "conditions": {"wind": wind}})
    with pytest.raises(InputError) as e:
        plan_from_files(load_spec(spec))
    assert needle in str(e.value) and "\n" not in str(e.value)


def test_a_copter_within_its_lean_limit_flies_as_in_still_air(tmp_path):
    """Its air speed never reaches the limit (speed + wind below it): the same sorties, times and battery, none of it the wind's."""
    table = {"battery": {"usable_min": 6.0}, "vehicle": {"cruise_speed_ms": 10.0, "max_airspeed_ms": 16.5}}
    calm = plan_from_files(load_spec(make_spec(tmp_path, table)))
    windy = plan_from_files(load_spec(make_spec(tmp_path, {**table, "conditions": {"wind": "6@200"}})))
    assert len(calm.sorties) == len(windy.sorties) >= 2
    for (a, _), (b, _) in zip(calm.sorties, windy.sorties):
        assert (a.first, a.last, a.horizontal_s, a.vertical_s) == (b.first, b.last, b.horizontal_s, b.vertical_s)
        assert b.battery_used == b.still_air_used
    assert calm.estimates == windy.estimates


def test_the_plan_records_the_wind_and_what_it_takes(tmp_path):
    """`plan --wind` over the spec's: the manifest's wind (its grid bearing: the true one less the
    meridian convergence, S-JTSK here), each sortie's still-air time and the battery share the wind
    takes; more sorties than in still air for a copter at its lean limit, each within the battery."""
    base = {"mission": {"crs": "EPSG:5514"}, "battery": {"usable_min": 8.0},
            "vehicle": {"cruise_speed_ms": 10.0, "max_airspeed_ms": 11.0}, "flight": {"heading": 90.0}}
    spec = make_spec(tmp_path, {**base, "conditions": {"wind": "2@90"}})
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(out), "--wind", "5@270G7"])
    assert res.exit_code == 0, res.output
    assert "wind            5 m/s from 270 deg true, gusts 7 m/s" in res.output and "wind %" in res.output
    m = json.loads((out / "manifest.json").read_text())
    w = m["wind"]
    assert (w["speed_ms"], w["from_deg"], w["gust_ms"]) == (5.0, 270.0, 7.0)
    assert w["grid_from_deg"] == pytest.approx((270.0 - m["crs"]["convergence_deg"]) % 360.0, abs=0.05)
    usable = 8.0 * 60 * 0.75
    for s in m["sorties"]:
        assert s["time_s"] <= usable + 0.05
        assert s["still_air_time_s"] < s["time_s"]  # lines across the wind: every one of them flown upwind once
        assert s["wind_used_pct"] == pytest.approx(100 * (s["time_s"] - s["still_air_time_s"]) / usable, abs=0.1)
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(tmp_path / "calm"), "--wind", "0@0"])
    assert res.exit_code == 0, res.output
    calm = json.loads((tmp_path / "calm" / "manifest.json").read_text())
    assert len(calm["sorties"]) < len(m["sorties"])
    assert all(s["wind_used_pct"] == 0.0 for s in calm["sorties"])


def test_check_takes_the_wind_for_a_spec_only(tmp_path):
    spec = make_spec(tmp_path, {"vehicle": {"max_airspeed_ms": 11.0}})
    res = CliRunner().invoke(main, ["check", str(spec), "--wind", "12@10"])
    assert res.exit_code == 2 and "not below vehicle.max_airspeed_ms" in res.output
    out = tmp_path / "out"
    assert CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)]).exit_code == 0
    res = CliRunner().invoke(main, ["check", str(out), "--wind", "3@10"])
    assert res.exit_code == 2 and "--wind is for a mission spec" in res.output


sharp_legs = st.integers(1, 4).flatmap(lambda n: st.tuples(st.lists(st.floats(-175, 175), min_size=n - 1, max_size=n - 1),
                                                             st.lists(st.floats(30, 700), min_size=n, max_size=n)))


@settings(max_examples=10, deadline=None)
# ArduPlane SITL's way home from the last line's east end to a landing approach 400 m south of home, then
# into a wind from the north to the touchdown: timed as a 9 s turn before, flown in 65 s + 53 s
@example(air=12.5, share=0.4, towards=270.0, start=0.0, shape=([172.0, -98.0], [1.0, 688.0, 400.0]),
         climb=102.0, rate=3.0, takeoff=22.0)
# 9 m/s of crosswind on a 12 m/s plane slowing from 25 m/s: Simpson's rule in one panel read it 1e-4 of its time off
@example(air=12.0, share=0.75, towards=0.0, start=98.0, shape=([], [202.0]), climb=10.0, rate=8.0, takeoff=25.0)
@given(air=st.floats(12, 25), share=st.floats(0, 0.8), towards=st.floats(0, 360), start=st.floats(0, 360),
       shape=sharp_legs, climb=st.floats(10, 300), rate=st.floats(1, 8), takeoff=st.floats(25, 35))
def test_a_planes_ways_out_and_home_take_the_wind_triangle_time_of_their_legs(air, share, towards, start, shape, climb,
                                                                              rate, takeoff):
    """A plane's way out or home, whatever its corners (a landing's approach turns back on the way home), is
    its legs flown straight in the wind (each at the ground speed the steered nose makes along it), but for the way
    out's last corner where it turns by more than 90° (an approach point behind the first line's lead-in), which
    takes longer. The way out starts after the take-off: the climb's time at `takeoff` m/s of air speed straight
    along the first leg; a first leg shorter than that climb-out is flown back at least (its overshoot's turn
    besides). The descent is what the way home leaves of it."""
    pts = _gentle_polyline(start, *shape)
    wind = _wind(share * air, towards)
    kin = Kinematics("plane", air, 2.5, 60.0, wind_x=float(wind[0]), wind_y=float(wind[1]))

    def legs(p: np.ndarray) -> float:
        t = 0.0
        for a, b in zip(p[:-1], p[1:]):
            if np.hypot(*(b - a)) > 0.0:
                u = (b - a) / np.hypot(*(b - a))
                t += float(np.hypot(*(b - a))) / float(_steer(u, wind, air) @ u)
        return t

    first = float(np.hypot(*(pts[1] - pts[0])))
    u = (pts[1] - pts[0]) / first
    climb_out = climb / rate * float(_steer(u, wind, takeoff) @ u)
    t_out, t_back, t_climb, t_descent = plane_transit_time(pts, pts[::-1], climb, rate, takeoff, rate / 2, kin)
    # the way out's last corner as flown: from the leg before it (the first flown back where it was climbed past)
    came = (pts[-2] - pts[-3]) * (-1.0 if len(pts) == 3 and climb_out > first else 1.0) if len(pts) > 2 else None
    sharp = came is not None and float(came @ (pts[-1] - pts[-2])) < 0.0
    # the rest of the first leg after the climb: the air speed falling evenly from the take-off's to the survey's
    # over 15 s (ArduPlane SITL: from 27.8 m/s at the climb's end to 12.5 m/s some 15 s on), stepped through
    rest, t_rest, steps = first - climb_out, 0.0, 3000
    for i in range(steps):
        if rest <= 0.0:
            break
        g = float(_steer(u, wind, takeoff + (air - takeoff) * (i + 0.5) / steps) @ u)
        dt = min(15.0 / steps, rest / g)
        t_rest, rest = t_rest + dt, rest - g * dt
    after = t_rest + (legs(np.array([pts[1] - rest * u, pts[1]])) if rest > 1e-9 else 0.0) + legs(pts[1:])
    if climb_out < first and sharp:
        assert t_out > after
    elif climb_out < first:
        assert t_out == pytest.approx(after, rel=1e-4, abs=1e-6)  # the slowing by Simpson's rule
    else:
        back = legs(np.array([pts[0] + climb_out * u, pts[1]]))
        assert t_out >= (back + legs(pts[1:])) * (1 - 1e-9)
    assert t_back == pytest.approx(legs(pts[::-1]), rel=1e-6)
    assert t_climb == pytest.approx(climb / rate, rel=1e-9)
    assert t_descent == pytest.approx(max(0.0, climb / (rate / 2) - legs(pts[::-1])), rel=1e-6, abs=1e-6)


def test_a_planes_landing_approach_is_flown_at_its_landing_speed():
    """5 m/s of wind from the east, 12.5 m/s over the lines: the way home west 300 m (17.5 m/s over the ground),
    then the approach east 400 m to the touchdown into the wind, at 18.4 m/s of air speed (13.4 over the ground);
    without a landing speed at 12.5 (7.5)."""
    kin = Kinematics("plane", 12.5, 2.5, 30.0, wind_x=-5.0)
    home = np.array([[300.0, 0.0], [-400.0, 0.0], [0.0, 0.0]])
    out = np.array([[0.0, 0.0], [1000.0, 0.0]])
    assert plane_transit_time(out, home, 100.0, 7.0, 22.0, 1.0, kin, 18.4)[1] == pytest.approx(700.0 / 17.5 + 400.0 / 13.4)
    assert plane_transit_time(out, home, 100.0, 7.0, 22.0, 1.0, kin)[1] == pytest.approx(700.0 / 17.5 + 400.0 / 7.5)


@pytest.mark.parametrize("first_m", [0.0, 185.0, 370.0])
def test_a_plane_overshoots_a_first_place_nearer_than_its_climb_out_and_turns_back_to_it(first_m):
    """Still air, 12.5 m/s over the lines, a 30 m turn radius; the take-off at 27 m/s of air speed and 7 m/s up
    to 98 m: 14 s and 378 m straight ahead. A first place nearer is reached after the climb, a half circle (π R)
    that ends 2R beside the leg, and the way straight back to it; one farther takes the rest of its leg slowing to
    12.5 m/s."""
    kin = Kinematics("plane", 12.5, 2.5, 30.0)
    out = np.array([[0.0, 0.0], [0.0, first_m]])
    home = np.array([[0.0, first_m], [0.0, 0.0]])
    t_out, _, t_climb, _ = plane_transit_time(out, home, 98.0, 7.0, 27.0, 2.0, kin)
    assert t_climb == pytest.approx(14.0)
    assert t_out == pytest.approx((math.pi * 30.0 + math.hypot(378.0 - first_m, 60.0)) / 12.5)
    far = np.array([[0.0, 0.0], [0.0, 600.0]])
    # slowing evenly from 27 to 12.5 m/s over 15 s (296 m), the rest of the leg within it: 27 t − 14.5 t²/30 = 222
    a, b = 14.5 / 30.0, 27.0
    within = (b - math.sqrt(b * b - 4.0 * a * 222.0)) / (2.0 * a)
    assert plane_transit_time(far, far[::-1], 98.0, 7.0, 27.0, 2.0, kin)[0] == pytest.approx(within)


@pytest.mark.parametrize("beyond_m", [0.0, 30.0, 143.0])
def test_a_plane_flies_on_towards_the_next_lead_in_before_it_turns(beyond_m):
    """Still air, 12.5 m/s, a 27.6 m turn radius, ArduPlane turning 44.8 m short of a waypoint: a line east ends,
    the next line's lead-in waypoint lies `beyond_m` farther east and 60 m north, its line runs west 152 m to its
    start. The plane flies on east until 44.8 m short of abreast of the lead-in (none when it is nearer), turns
    (π R, ending 2R = 55.2 m north of where it began) and flies straight to the line's start."""
    kin = Kinematics("plane", 12.5, 2.5, 27.6, reach_m=44.8)
    pts = np.array([[0.0, 0.0], [500.0, 0.0], [500.0 + beyond_m, 60.0], [500.0 + beyond_m - 152.0, 60.0]])
    on = max(0.0, beyond_m - 44.8)
    expected = 500.0 + on + math.pi * 27.6 + math.hypot(152.0 - (beyond_m - on), 60.0 - 55.2)
    assert path_time(pts, kin) == pytest.approx(expected / 12.5)
