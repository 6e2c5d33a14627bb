"""Areas with a notch laid in bands across it (plan/area_grid.py cheapest_cells): the plan must
still put every point on k_side x k_fwd photos with the asked overlaps (side overlap between the
bands' lines too) and the images beyond the boundary, checked from the exported mission alone
by the independent replay (tests/test_plan_coverage.py check_mission)."""

from __future__ import annotations

import math

import pytest
import shapely

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
    assert "bands" in res["manifest"]["derived"]["heading_chosen"]
