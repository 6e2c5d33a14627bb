"""A copter's lean limit in a wind as a force, not one air speed (vehicle.max_airspeed_ms on the nose,
vehicle.max_airspeed_diagonal_ms 45° off it): `Kinematics.ground_speed` against a force balance solved
here by bisection, the law's two air speeds where they are defined, and the spec's refusals."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aerosurvey.errors import InputError
from aerosurvey.inputs import plan_from_files
from aerosurvey.plan.flight_time import Kinematics
from aerosurvey.spec import load_spec
from conftest import make_spec


def _drag_coefficients(nose: float, diagonal: float) -> np.ndarray:
    """(quadratic, linear) of the drag per body axis, as a share of the lean's most force: the force is
    that share at `nose` m/s straight on the nose, and at `diagonal` m/s 45° off it (each axis d/√2)."""
    half = diagonal / math.sqrt(2.0)
    # at 45° each axis drags q·h² + l·h, and the two together √2 times that: q·h² + l·h = 1/√2
    return np.linalg.solve(np.array([[nose * nose, nose], [half * half, half]]), np.array([1.0, 1.0 / math.sqrt(2.0)]))


def _force_share(air_nose: float, air_side: float, coeffs: np.ndarray) -> float:
    """The horizontal force the air velocity (along the nose, across it) drags, as a share of the lean's most."""
    q, lin = coeffs
    return math.hypot(q * air_nose * air_nose + lin * abs(air_nose), q * air_side * air_side + lin * abs(air_side))


def _balanced_ground_speed(speed: float, track_deg: float, wind: np.ndarray, coeffs: np.ndarray) -> float:
    """The fastest ground speed up to `speed` along the track whose air velocity (ground − wind, the nose along
    the track) the lean holds: bisection between rest (held: the wind is below the least limit) and `speed`."""
    u = np.array([math.cos(math.radians(track_deg)), math.sin(math.radians(track_deg))])
    n = np.array([-u[1], u[0]])

    def held(g: float) -> bool:
        air = g * u - wind
        return _force_share(float(air @ u), float(air @ n), coeffs) <= 1.0

    if held(speed):
        return speed
    lo, hi = 0.0, speed
    for _ in range(80):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if held(mid) else (lo, mid)
    return lo


@settings(max_examples=200, deadline=None)
@given(nose=st.floats(5, 20), gain=st.floats(1.0, 2.0 ** 0.25), speed=st.floats(3, 25), share=st.floats(0, 0.95),
       towards=st.floats(0, 360), track=st.floats(0, 360))
def test_a_copter_makes_good_what_its_lean_holds(nose, gain, speed, share, towards, track):
    """Any wind below the air speed on the nose, any track, any shape between a circle and per-axis quadratic drag."""
    a = math.radians(towards)
    wind = share * nose * np.array([math.cos(a), math.sin(a)])
    kin = Kinematics("copter", speed, 2.5, 0.0, wind_x=float(wind[0]), wind_y=float(wind[1]), airspeed_ms=nose,
                     airspeed_diagonal_ms=nose * gain)
    expected = _balanced_ground_speed(speed, track, wind, _drag_coefficients(nose, nose * gain))
    assert kin.ground_speed(track) == pytest.approx(expected, rel=1e-7, abs=1e-7)


@pytest.mark.parametrize("diagonal", [None, 10.0, 11.2, 10.0 * 2.0 ** 0.25])
def test_the_limits_air_speeds_on_the_nose_and_45_degrees_off_it(diagonal):
    """Into a headwind the copter makes good its nose's air speed less the wind; in a crosswind as strong as the
    diagonal's part across, it makes good the same (the air 45° off the nose): d/√2 over the ground."""
    d = 10.0 if diagonal is None else diagonal
    head = Kinematics("copter", 30.0, 2.5, 0.0, wind_x=-4.0, airspeed_ms=10.0, airspeed_diagonal_ms=diagonal)
    assert head.ground_speed(0.0) == pytest.approx(6.0, rel=1e-12)
    across = Kinematics("copter", 30.0, 2.5, 0.0, wind_y=d / math.sqrt(2.0), airspeed_ms=10.0, airspeed_diagonal_ms=diagonal)
    assert across.ground_speed(0.0) == pytest.approx(d / math.sqrt(2.0), rel=1e-12)
    assert across.ground_speed(180.0) == pytest.approx(d / math.sqrt(2.0), rel=1e-12)


def test_a_diagonal_limit_shortens_a_crosswind_plan(tmp_path):
    """The same plan in 8 m/s across its lines: the larger air speed 45° off the nose makes each sortie shorter."""
    ring = [[15.000, 49.400], [15.0035, 49.400], [15.0035, 49.4017], [15.000, 49.4017], [15.000, 49.400]]
    base = {"battery": {"usable_min": 30.0}, "flight": {"heading": 90.0}, "conditions": {"wind": "8@135"}}
    same = plan_from_files(load_spec(make_spec(tmp_path, {**base, "vehicle": {"max_airspeed_ms": 10.0}}, area=ring)))
    shaped = plan_from_files(load_spec(make_spec(tmp_path, {**base, "vehicle": {"max_airspeed_ms": 10.0,
                                                                                 "max_airspeed_diagonal_ms": 11.2}}, area=ring)))
    assert shaped.estimates["total_time_s"] < 0.97 * same.estimates["total_time_s"]


@pytest.mark.parametrize("vehicle,needle", [
    ({"type": "plane", "max_airspeed_diagonal_ms": 12.0}, "vehicle.max_airspeed_diagonal_ms is for copters"),
    ({"max_airspeed_diagonal_ms": 12.0}, "vehicle.max_airspeed_diagonal_ms = 12 needs vehicle.max_airspeed_ms"),
    ({"max_airspeed_ms": 10.0, "max_airspeed_diagonal_ms": 9.9}, "vehicle.max_airspeed_diagonal_ms = 9.9 is not allowed: from"),
    ({"max_airspeed_ms": 10.0, "max_airspeed_diagonal_ms": 12.0}, "to 2^¼ times it (11.892)"),
    ({"max_airspeed_ms": 10.0, "max_airspeed_diagonal_ms": "fast"}, "vehicle.max_airspeed_diagonal_ms = 'fast'"),
])
def test_a_bad_diagonal_air_speed_is_refused_in_one_line(tmp_path, vehicle, needle):
    with pytest.raises(InputError) as e:
        load_spec(make_spec(tmp_path, {"vehicle": vehicle}))
    assert needle in str(e.value) and "\n" not in str(e.value)
