"""A copter's take-off, way out, RTL and landing as ArduCopter flies them (docs/planning.md, "Time model"):
the take-off and the landing against figures worked out here from ArduCopter's parameters (SITL's defaults:
WPNAV_SPEED_UP 2.5 m/s, WPNAV_SPEED_DN 1.5 m/s, WPNAV_ACCEL_Z 1 m/s², PSC_JERK_Z 5 m/s³, RTL_ALT 15 m,
RTL_LOIT_TIME 5 s, LAND_ALT_LOW 10 m, LAND_SPEED 0.5 m/s) and the vertical speed changes of the test's own
stepped motion (`independent_motion.stop_to_stop_time`), against what ArduCopter SITL flew; and the estimate's
ways: out at the survey speed (the mission's one DO_CHANGE_SPEED follows the take-off), an RTL home at the
cruise speed (ArduCopter's RTL flies WPNAV_SPEED), a way round the zones at the survey speed before NAV_LAND."""

from __future__ import annotations

import json
import math

import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

import independent_coverage as ic
from aerosurvey.cli import main
from aerosurvey.plan.flight_time import copter_landing_time, copter_takeoff_time
from conftest import make_spec
from independent_motion import stop_to_stop_time

#: measured in ArduCopter SITL (the logs of tests/test_sitl.py's flights): arming to leaving the ground
SPOOL_S = 3.9
#: measured: over the landing point before the descent, and after the touchdown until disarmed
SETTLE_S = 3.5


def test_the_take_off_is_the_spool_up_and_a_vertical_run_from_rest_to_rest():
    # 102.13 m at 2.5 m/s, speed changes of 2.5 / 1 + 1 / 5 s each (the acceleration held once the jerk reaches
    # it), covering 2.5 m/s × 2.7 s between them: 102.13 / 2.5 + 2.7 s
    assert copter_takeoff_time(102.13, 2.5) == pytest.approx(SPOOL_S + 102.13 / 2.5 + 2.5 + 0.2, abs=1e-9)
    # ArduCopter SITL, arming to the take-off's end (MISE of the next item): 47.18 s to 102.13 m, 12.76 s to 16.06 m
    assert copter_takeoff_time(102.13, 2.5) == pytest.approx(47.18, abs=0.5)
    assert copter_takeoff_time(16.06, 2.5) == pytest.approx(12.76, abs=0.5)


@settings(max_examples=40, deadline=None)
@given(alt=st.floats(0.5, 300.0), rate=st.floats(0.5, 6.0))
def test_the_take_off_climbs_as_the_stepped_motion(alt, rate):
    assert copter_takeoff_time(alt, rate) == pytest.approx(SPOOL_S + stop_to_stop_time(alt, rate, 1.0, 5.0),
                                                           rel=5e-3, abs=0.02)


def test_an_rtl_waits_over_home_and_lands_at_the_descent_rate_then_land_speed():
    # from 102.12 m: 5 s over home, 92.12 m at 1.5 m/s and 10 m at 0.5 m/s, the descent begun from rest (half
    # a speed change to 1.5 m/s: (1.5 / 1 + 1 / 5) / 2 s), and the settling
    down = 92.12 / 1.5 + 10.0 / 0.5 + (1.5 + 0.2) / 2.0
    assert copter_landing_time(102.12, 2.5, 1.5, rtl=True) == pytest.approx(5.0 + down + SETTLE_S, abs=1e-9)
    assert copter_landing_time(102.12, 2.5, 1.5, rtl=False) == pytest.approx(down + SETTLE_S, abs=1e-9)


def test_an_rtl_from_below_rtl_alt_climbs_to_it_first():
    # a facade's last lane at 11.94 m: RTL climbs 3.06 m (too short to reach 2.5 m/s: the stepped motion's
    # run), waits 5 s, and descends from 15 m
    climb = stop_to_stop_time(15.0 - 11.94, 2.5, 1.0, 5.0)
    down = 5.0 / 1.5 + 10.0 / 0.5 + (1.5 + 0.2) / 2.0
    assert copter_landing_time(11.94, 2.5, 1.5, rtl=True) == pytest.approx(climb + 5.0 + down + SETTLE_S, rel=5e-3)
    # NAV_LAND lands from where it is: 1.94 m at 1.5 m/s, then 10 m at 0.5 m/s
    assert copter_landing_time(11.94, 2.5, 1.5, rtl=False) == pytest.approx(
        1.94 / 1.5 + 10.0 / 0.5 + (1.5 + 0.2) / 2.0 + SETTLE_S, abs=1e-9)


def _stop_to_stop(d: float, v: float, a: float) -> float:
    """Seconds over `d` metres from rest to rest, top speed v, acceleration a reached at a jerk of 1 m/s³
    (ArduCopter's WPNAV_JERK), long enough to cruise: d / v + v / a + a / 1."""
    assert d >= v * (v / a + a), "long enough to cruise"
    return d / v + v / a + a


def _plan(tmp_path, end: str) -> tuple[dict, list[list[float]]]:
    """A one-line block flown east, its launch point 280 m south of the block's west end (the way out meets the
    line at a corner of more than 30°: a stop), the survey at 5 m/s, the vehicle's cruise speed 10 m/s."""
    ring = [[15.000, 49.400], [15.004, 49.400], [15.004, 49.4003], [15.000, 49.4003], [15.000, 49.400]]
    spec = make_spec(tmp_path, {"flight": {"heading": 90.0, "end": end}, "area": {"launch": [15.0, 49.3975]},
                                "vehicle": {"cruise_speed_ms": 10.0}, "targets": {"gsd_cm": 1.0}}, area=ring)
    out = tmp_path / end
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)])
    assert res.exit_code == 0, res.output
    _, rows = ic.read_wpl(out / "mission.waypoints")
    return json.loads((out / "manifest.json").read_text()), rows


def _ways_m(rows: list[list[float]]) -> tuple[float, float, float]:
    """From the .waypoints: the way out (home to the first place), the way home (the last place to home), and
    the turn at the first place from the way out onto the next leg (degrees)."""
    to_xy = ic.local_projection(15.0, 49.3975)
    x, y = to_xy.transform([r[9] for r in rows if r[3] == 16], [r[8] for r in rows if r[3] == 16])
    first, second, last = (x[0], y[0]), (x[1], y[1]), (x[-1], y[-1])
    out, home = math.hypot(*first), math.hypot(*last)
    turn = math.degrees(abs(math.atan2(first[0] * (second[1] - first[1]) - first[1] * (second[0] - first[0]),
                                       first[0] * (second[0] - first[0]) + first[1] * (second[1] - first[1]))))
    return out, home, turn


def test_the_way_out_is_flown_at_the_survey_speed_and_an_rtl_home_at_the_cruise_speed(tmp_path):
    m, rows = _plan(tmp_path, "rtl")
    v = m["derived"]["speed_ms"]
    assert v < 9.0 and rows[-1][3] == 20  # the survey slower than the cruise speed; the mission ends with RTL
    out, home, turn = _ways_m(rows)
    assert turn > 30.0 and out > 100.0 and home > 100.0
    # the way out at v from rest (after the take-off) to rest (the corner), the RTL at 10 m/s from rest to rest
    assert m["estimates"]["transit_time_s"] == pytest.approx(_stop_to_stop(out, v, 2.5) + _stop_to_stop(home, 10.0, 2.5),
                                                             abs=0.3)
    assert m["estimates"]["climb_time_s"] == pytest.approx(copter_takeoff_time(rows[0][10], 2.5), abs=0.1)


def test_a_flight_that_lands_flies_home_at_the_survey_speed_and_lands_without_waiting(tmp_path):
    rtl, _ = _plan(tmp_path, "rtl")
    m, rows = _plan(tmp_path, "land")
    v = m["derived"]["speed_ms"]
    assert rows[-1][3] == 21  # NAV_LAND
    out, home, _ = _ways_m(rows)
    assert m["estimates"]["transit_time_s"] == pytest.approx(_stop_to_stop(out, v, 2.5) + _stop_to_stop(home, v, 2.5),
                                                             abs=0.3)
    assert rtl["estimates"]["descent_time_s"] - m["estimates"]["descent_time_s"] == pytest.approx(5.0, abs=0.15)
