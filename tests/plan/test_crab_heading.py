"""The line heading of a plane whose camera is fixed to its body (camera.gimbal = "body", a plane's default) in a
wind: lines across the wind crab, the photos turn with the nose and the lines must lie closer; lines along the wind
do not crab and keep the still-air spacing. `flight.heading = "auto"` chooses the heading whose lines, laid at the
spacing its own crab needs, fly shortest: checked here against plans whose heading is fixed by the spec (each
solved and laid for its own crab by the planner), compared by the plans' total estimated times."""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import pytest
import shapely
from hypothesis import HealthCheck, assume, example, given, settings
from hypothesis import strategies as st
from tests.conftest import make_spec

from aerosurvey.inputs import plan_from_files
from aerosurvey.spec import load_spec

AIR = 18.0  # m/s: the plane's cruise (and survey) air speed
M_PER_DEG_LAT = 111_320.0
LAT0, LON0 = 49.4, 15.0


def _plan(folder: Path, area: list[list[float]], wind: dict | None, heading: float | None = None):
    over: dict = {"vehicle": {"type": "plane", "cruise_speed_ms": AIR},
                  "targets": {"gsd_cm": 2.5, "side_overlap": 0.6, "forward_overlap": 0.75}}
    if wind is not None:
        over["conditions"] = {"wind": wind}
    if heading is not None:
        over["flight"] = {"heading": heading}
    return plan_from_files(load_spec(make_spec(folder, over, area=area)))


def _total(plan) -> float:
    return float(plan.estimates["total_time_s"])


# a 2.2 km x 1.1 km block, its long side east-west: in still air its lines run east-west (fewest turns)
BLOCK = [[15.0, 49.4], [15.03, 49.4], [15.03, 49.41], [15.0, 49.41], [15.0, 49.4]]


def test_auto_flies_no_longer_than_any_fixed_heading_in_a_strong_crosswind(tmp_path):
    """9 m/s from the north at 18 m/s air speed: east-west lines crab by 30 degrees and need about half the still-air
    spacing; north-south lines (along the wind) keep it. Priced at the spacing solved for the first heading, the search
    chose east-west lines (11,944 s where north-south flew 8,702 s)."""
    wind = {"speed_ms": 9.0, "from_deg": 0.0}
    auto = _plan(tmp_path, BLOCK, wind)
    sweep = {h: _total(_plan(tmp_path, BLOCK, wind, float(h))) for h in range(0, 180, 15)}
    best = min(sweep.values())
    assert _total(auto) <= best * 1.005
    # the case decides: the crosswind heading (still air's choice) flies far longer
    assert sweep[90] > 1.3 * best
    # and its lines run along the wind (grid north within the meridian convergence), at the still-air spacing
    assert abs((auto.layout.heading_deg + 90.0) % 180.0 - 90.0) < 2.0
    still = _plan(tmp_path, BLOCK, None, 0.0)
    assert auto.sensor.spacing_m == pytest.approx(still.sensor.spacing_m, rel=1e-3)


@st.composite
def _quadrilateral(draw) -> list[list[float]]:
    """Four corners at random bearings and distances (300-1000 m) round a point, in their bearings' order, as lon/lat."""
    bearings = sorted(draw(st.lists(st.floats(0.0, 2.0 * math.pi, exclude_max=True), min_size=4, max_size=4)))
    radii = draw(st.lists(st.floats(300.0, 1000.0), min_size=4, max_size=4))
    ring = [[LON0 + r * math.cos(b) / (M_PER_DEG_LAT * math.cos(math.radians(LAT0))), LAT0 + r * math.sin(b) / M_PER_DEG_LAT]
            for b, r in zip(bearings, radii)]
    return ring + [ring[0]]


# the search prices each heading's lines and the turns between them over the ways the route flies them (`quick_cost`:
# the fastest of `line_orders`, from either end, the first line either way), but compared here are the plans' survey
# times, each laid and solved for its own crab: the ways from and back to the launch point are not the heading's (the
# area's edge nearest the route's start), nor are a concave area's cells. When the search priced the plain order from
# the lowest line alone, one case (7.0 m/s from 80.6 degrees) priced 72 degrees at 1,691.0 s and 81 degrees at
# 1,718.7 s, but the route flew 81 degrees' lines in 1,623.1 s (1.038x); measured then on 76 random quadrilaterals
# with winds up to 0.6 of the air speed, the auto heading's survey time was at most 1.038 of the better fixed one's
TOLERANCE = 0.06


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(area=_quadrilateral(), share=st.floats(0.0, 0.6), from_deg=st.floats(0.0, 360.0, exclude_max=True))
# a random case: the first round laid two pieces, the second one heading (26.3 degrees) for the spacing solved for all
# three directions, 30.8 m where its own is 55.1 m (2,899.3 s against 1,845.0 s): the settled layout is laid again for
# its own directions (planner._under_turned_camera)
@example(area=[[15.00861081050498, 49.4], [15.004141119075515, 49.4], [15.00282095778261, 49.40860794502196],
               [14.99593219041704, 49.39949516008396], [15.00861081050498, 49.4]], share=0.4496787678684726, from_deg=0.0)
def test_auto_is_never_worse_than_along_or_across_the_wind(area, share, from_deg):
    poly = shapely.Polygon(area)
    assume(poly.is_valid and poly.area > 0.0)
    wind = {"speed_ms": round(share * AIR, 2), "from_deg": from_deg} if share * AIR >= 0.01 else None
    with tempfile.TemporaryDirectory() as d:
        auto = _plan(Path(d), area, wind)
        along = auto.wind["grid_from_deg"] % 180.0 if auto.wind is not None else 0.0
        fixed = [_plan(Path(d), area, wind, h).estimates["survey_time_s"] for h in (along, (along + 90.0) % 180.0)]
    assert auto.estimates["survey_time_s"] <= min(fixed) * (1.0 + TOLERANCE)
