"""Areas with a notch laid in bands across it (plan/area_grid.py cheapest_cells): the plan must
still put every point on k_side x k_fwd photos with the asked overlaps (side overlap between the
bands' lines too) and the images beyond the boundary, checked from the exported mission alone
by the independent replay (tests/test_plan_coverage.py check_mission). Its size:
AEROSURVEY_CELLS_EXAMPLES (8)."""

from __future__ import annotations

import math
import os

import pytest
import shapely
import shapely.affinity
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from conftest import make_spec
from test_plan_coverage import check_mission

K_LAT, K_LON = 1 / 111_320.0, 1 / (111_320.0 * math.cos(math.radians(49.4)))


def ring(poly: shapely.Polygon) -> list[list[float]]:
    return [[15.0 + x * K_LON, 49.4 + y * K_LAT] for x, y in poly.exterior.coords]


# an L (a long low arm and a tall narrow one) and a U (a wide base and two legs), metres; the
# footprint at GSD 2.5 cm is about 150 m across, the spacing 60 m
L = shapely.difference(shapely.box(0, 0, 600, 330), shapely.box(220, 120, 600, 330))
U = shapely.difference(shapely.box(0, 0, 900, 600), shapely.box(200, 130, 700, 600))


@pytest.mark.parametrize(("shape", "heading"), [(L, "auto"), (L, 90.0), (U, "auto")])
def test_banded_layouts_keep_the_guarantee(tmp_path, shape, heading):
    spec = make_spec(tmp_path, {"flight": {"heading": heading}}, area=ring(shape))
    res = check_mission(spec, tmp_path / "out", samples=60)
    how = res["manifest"]["derived"]["heading_chosen"]
    assert "bands" in how or (heading == "auto" and "pieces" in how), how


# a strip 100 m wide bent once: each arm flown at a heading of its own
BENT = shapely.LineString([(0, 0), (700, 0), (1100, 350)]).buffer(50, cap_style="flat", join_style="mitre")


@pytest.mark.parametrize("speed", [10.0, 5.0])
def test_a_bent_strip_is_flown_in_two_pieces(tmp_path, speed):
    spec = make_spec(tmp_path, {"vehicle": {"cruise_speed_ms": speed}}, area=ring(BENT))
    res = check_mission(spec, tmp_path / "out", samples=60)
    assert "two pieces" in res["manifest"]["derived"]["heading_chosen"]


EXAMPLES = int(os.environ.get("AEROSURVEY_CELLS_EXAMPLES", "8"))


@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(width=st.floats(300, 900), height=st.floats(250, 700), notch_w=st.floats(0.2, 0.7), notch_h=st.floats(0.3, 0.8),
       where=st.sampled_from(["corner", "side"]), turn=st.floats(0, 180), side=st.sampled_from([0.6, 0.7]),
       heading=st.one_of(st.just("auto"), st.floats(0, 179.9)))
def test_notched_areas_keep_the_guarantee(tmp_path_factory, width, height, notch_w, notch_h, where, turn, side, heading):
    """An L (a corner notch) or a U (a notch in the middle of a side), turned, planned banded or
    not: every point on k_side x k_fwd photos, the asked overlaps, from the mission file alone."""
    tmp = tmp_path_factory.mktemp("notch")
    nw, nh = notch_w * width, notch_h * height
    w, h, y = width, height, height - nh
    if where == "corner":
        xy = [(0, 0), (w, 0), (w, y), (w - nw, y), (w - nw, h), (0, h)]
    else:
        x0 = (w - nw) / 2.0
        xy = [(0, 0), (w, 0), (w, h), (x0 + nw, h), (x0 + nw, y), (x0, y), (x0, h), (0, h)]
    shape = shapely.affinity.rotate(shapely.Polygon(xy), turn, origin="centroid")
    spec = make_spec(tmp, {"targets": {"side_overlap": side}, "flight": {"heading": heading}}, area=ring(shape))
    check_mission(spec, tmp / "out", samples=50)
