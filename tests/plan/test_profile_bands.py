"""The zones' height bands on the route's terrain profile (mission/clearance.py `terrain_profile`, the page's
profile): for random zones over the forest example, every band lies where the exported route (mission.waypoints,
rebuilt by the independent leg reader in its own projection) is inside the zone, and its limits are the zone's,
converted to heights above sea level (AGL over the profile's ground, AMSL as given, WGS84 as the widest span)."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import independent_airspace as ia
from aerosurvey.airspace.model import Limit
from aerosurvey.inputs import plan_from_files
from aerosurvey.mission.clearance import ProfileZone, terrain_profile
from aerosurvey.mission.program import flight_program
from aerosurvey.outputs import write_outputs
from aerosurvey.plan.landing import PLANE_RTL_LOITER_M
from aerosurvey.spec import load_spec
from independent_legs import Local

REPO = Path(__file__).resolve().parents[2]
LON0, LAT0 = 8.7375, 50.8437  # the forest block's middle
#: the geoid lies this far either side of the ellipsoid (model.amsl_span's bounds, from EGM96)
GEOID = (-106.2, 85.8)


@pytest.fixture(scope="module")
def forest(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("bands")
    (tmp / "areas").mkdir()
    for name in ("forest-dem.toml", "areas/forest-block.geojson", "areas/forest-block-dem.tif"):
        shutil.copy(REPO / "missions" / name, tmp / name)
    spec = load_spec(tmp / "forest-dem.toml")
    plan = plan_from_files(spec)
    write_outputs(plan, spec, tmp / "out")
    local = Local(LON0, LAT0)
    legs, _ = ia.flight_legs(tmp / "out" / "mission.waypoints", local)
    return plan, local, legs




limits = st.one_of(st.none(), st.builds(Limit, st.floats(0, 900).map(lambda v: round(v, 1)),
                                        st.sampled_from(["AGL", "AMSL", "WGS84"])))


@st.composite
def zones(draw):
    """A rectangle turned by a random angle (or a triangle) over or near the forest block, 20 to 700 m across."""
    cx, cy = draw(st.floats(-500, 500)), draw(st.floats(-400, 400))
    w, h = draw(st.floats(20, 700)), draw(st.floats(20, 700))
    turn = math.radians(draw(st.floats(0, 180)))
    corners = [(-w / 2, -h / 2), (w / 2, -h / 2), (w / 2, h / 2), (-w / 2, h / 2)]
    if draw(st.booleans()):
        corners = corners[:3]
    c, s = math.cos(turn), math.sin(turn)
    return [(cx + x * c - y * s, cy + x * s + y * c) for x, y in corners], draw(limits), draw(limits)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(drawn=st.lists(zones(), min_size=1, max_size=3))
def test_bands_lie_where_the_route_is_inside_each_zone(forest, drawn):
    plan, local, legs = forest
    site = plan.site
    pzones, outlines = [], []
    for i, (ring, lower, upper) in enumerate(drawn):
        lon, lat = local.inv.transform([p[0] for p in ring], [p[1] for p in ring])
        ll = shapely.Polygon(list(zip(lon, lat)))
        outlines.append(local.geom(ll))
        pzones.append(ProfileZone(f"Z{i}", "official", site.planar.forward(ll), "band", lower, upper))
    p = terrain_profile(flight_program(plan), "mission", site.dem, site.planar, site.grid_scale, site.min_clearance_m,
                        PLANE_RTL_LOITER_M * site.grid_scale, zones=pzones)
    assert p.distance_m[-1] == pytest.approx(sum(math.dist(leg.a, leg.b) for leg in legs), abs=1.0)
    starts = [b.distance_m[0] for b in p.bands]
    assert starts == sorted(starts)
    for i, (_, lower, upper) in enumerate(drawn):
        got = [b for b in p.bands if b.name == f"Z{i}"]
        # stretches under 1 m (a corner clipped) are where the two projections may disagree on touching
        want = [s for s in ia.stretches_inside(legs, outlines[i]) if s[1] - s[0] > 1.0]
        got_long = [b for b in got if b.distance_m[-1] - b.distance_m[0] > 1.0]
        assert len(got_long) == len(want), (i, [(b.distance_m[0], b.distance_m[-1]) for b in got], want)
        for b, (a, e) in zip(got_long, want):
            assert b.distance_m[0] == pytest.approx(a, abs=1.0) and b.distance_m[-1] == pytest.approx(e, abs=1.0)
        for b in got:
            d = np.array(b.distance_m)
            assert np.all(np.diff(d) > 0)
            ground = np.interp(d, p.distance_m, p.ground_m)
            assert np.allclose(b.lower_m, ground if lower is None else _amsl(lower, ground, low=True), atol=1e-6)
            if upper is None:
                assert b.upper_m is None
            else:
                assert b.upper_m is not None and np.allclose(b.upper_m, _amsl(upper, ground, low=False), atol=1e-6)


def _amsl(limit: Limit, ground: np.ndarray, low: bool) -> np.ndarray:
    """A limit above sea level as the test reads ED-269: AGL over the ground, AMSL as it is, a WGS84 height as the
    lowest (a lower limit) or highest (an upper one) sea-level height the geoid's range allows."""
    if limit.reference == "AGL":
        return ground + limit.value_m
    if limit.reference == "AMSL":
        return np.full(len(ground), limit.value_m)
    return np.full(len(ground), limit.value_m - (GEOID[1] if low else GEOID[0]))
