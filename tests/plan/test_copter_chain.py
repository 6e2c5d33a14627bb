"""A copter flies on through waypoints joined at gentle corners (or straight on) as ArduCopter's S-curves
do: each leg is its own stop-to-stop motion and the next starts as it brakes (AP_Math/SCurve.cpp). In
ArduCopter SITL the orbit's ring of 4.68 m chords flew 1.63 m/s for 5.34 m/s commanded, each chord in
2.87 s: the speed a stop-to-stop run over one chord peaks at (docs/planning.md, "An orbit round a
structure"). The flight-time model (`path_time`) against the test's own stepped motions
(`independent_motion.flown_through_time`), and never below a stop-to-stop run of the whole length, which
the heading search's lower bounds rely on (`quick_cost_lower_bounds`)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aerosurvey.plan.flight_time import Kinematics, _straight_time, path_time
from independent_motion import flown_through_time, stop_to_stop_time


def _along(legs: list[float], turn_deg: float) -> np.ndarray:
    """A polyline of `legs` turning `turn_deg` at each waypoint, one way."""
    angles = np.radians(turn_deg * np.arange(len(legs)))
    steps = np.column_stack([np.cos(angles), np.sin(angles)]) * np.asarray(legs)[:, None]
    return np.vstack([[0.0, 0.0], np.cumsum(steps, axis=0)])


@settings(max_examples=15, deadline=None)
@given(legs=st.lists(st.floats(0.5, 120.0), min_size=1, max_size=4), turn=st.floats(0.0, 25.0),
       speed=st.floats(2.0, 14.0), accel=st.floats(0.5, 5.0), jerk=st.sampled_from([0.0, 1.0, 5.0]))
def test_legs_flown_through_take_the_stepped_motions_time(legs, turn, speed, accel, jerk):
    k = Kinematics("copter", speed, accel, 0.0, jerk)
    flown = path_time(_along(legs, turn), k)
    assert flown == pytest.approx(flown_through_time(legs, speed, accel, jerk), rel=5e-3, abs=0.02)
    # never faster than one stop-to-stop run over the whole length, never slower than a stop at every waypoint
    assert _straight_time(sum(legs), k) * (1.0 - 1e-9) <= flown <= sum(_straight_time(d, k) for d in legs) * (1.0 + 1e-9)


def test_a_ring_of_short_chords_is_flown_at_a_chords_peak_speed():
    """Twenty chords of 4.68 m turning 22.5° (ArduCopter's default WPNAV_ACCEL 2.5 m/s², WPNAV_JERK 1 m/s³),
    5.34 m/s commanded: each chord after the first takes half its stop-to-stop run, flown at the peak
    speed (d/2)^(2/3)·J^(1/3), about 1.76 m/s."""
    k = Kinematics("copter", 5.34, 2.5, 0.0, 1.0)
    one, twenty = (path_time(_along([4.68] * n, 22.5), k) for n in (1, 20))
    assert one == pytest.approx(stop_to_stop_time(4.68, 5.34, 2.5, 1.0), rel=5e-3)
    assert 4.68 / ((twenty - one) / 19) == pytest.approx((4.68 / 2.0) ** (2.0 / 3.0), rel=5e-3)
