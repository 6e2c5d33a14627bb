"""A copter's stop-to-stop run (the flight-time model's `_straight_time`) against the test's own stepped
motion (`independent_motion`): equal to it at every length, with no step where a run becomes long enough to
cruise (a 100 m leg at 13 m/s is the case that showed one: 0.28 s added by 0.5 m more)."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aerosurvey.plan.flight_time import Kinematics, _straight_time
from independent_motion import stop_to_stop_time


@settings(max_examples=25, deadline=None)
@given(d=st.floats(0.5, 400.0), speed=st.floats(2.0, 16.0), accel=st.floats(0.5, 5.0),
       jerk=st.sampled_from([0.0, 0.5, 1.0, 5.0]))
def test_a_straight_run_takes_the_stepped_motions_time(d, speed, accel, jerk):
    k = Kinematics("copter", speed, accel, 0.0, jerk)
    assert _straight_time(d, k) == pytest.approx(stop_to_stop_time(d, speed, accel, jerk), rel=5e-3, abs=0.02)


@pytest.mark.parametrize("speed,accel,jerk", [(13.0, 2.5, 1.0), (5.0, 2.5, 1.0), (8.0, 2.0, 0.0), (3.0, 5.0, 5.0)])
def test_the_time_rises_with_the_length_without_a_step(speed, accel, jerk):
    k = Kinematics("copter", speed, accel, 0.0, jerk)
    lengths = [0.05 * i for i in range(1, 8001)]  # to 400 m
    times = [_straight_time(x, k) for x in lengths]
    steps = [b - a for a, b in zip(times, times[1:])]
    assert min(steps) > 0.0
    # each 5 cm adds no more than the 5 cm before it (the peak speed rises with the length) or, once the run cruises,
    # 5 cm at the top speed: a step where the run starts to cruise would add more
    assert all(b <= max(a, 0.05 / speed) + 1e-9 for a, b in zip(steps, steps[1:]))
