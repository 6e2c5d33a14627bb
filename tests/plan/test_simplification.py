"""Boundaries simplified outwards (plan/site.py): the simplified polygon covers the given one,
lies within the tolerance of it, and has fewer vertices; a plan reports the counts.

Checked with shapely's own predicates and distances (not with the simplifier's reasoning):
`covers` for containment, distances from points along the simplified boundary for the growth."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from aerosurvey.plan.inputs import PlanInputs
from aerosurvey.plan.planner import plan_mission
from aerosurvey.plan.sensor import target_height
from aerosurvey.plan.site import grown_simplification, prepare_site
from aerosurvey.spec import parse_spec


def _wobbly(n: int, radius: float, wobble: float, seed: int, centre: tuple[float, float] = (0.0, 0.0)) -> shapely.Polygon:
    """A ring of n vertices whose radius wanders by up to `wobble` (random, seeded)."""
    rng = np.random.default_rng(seed)
    a = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
    r = radius + wobble * rng.uniform(-1.0, 1.0, n)
    return shapely.Polygon(np.c_[centre[0] + r * np.cos(a), centre[1] + r * np.sin(a)])


shapes = st.builds(
    lambda n, radius, wobble, seed, holes, parts: _shape(n, radius, wobble, seed, holes, parts),
    st.integers(8, 1500), st.floats(50.0, 1000.0), st.floats(0.0, 5.0), st.integers(0, 2**32 - 1),
    st.integers(0, 3), st.integers(1, 3))


def _shape(n: int, radius: float, wobble: float, seed: int, holes: int, parts: int) -> shapely.Geometry:
    polys = []
    for p in range(parts):
        c = (p * 3.0 * radius, 0.0)
        shell = _wobbly(n, radius, wobble, seed + p, c)
        inner = [_wobbly(max(8, n // 4), radius * 0.1, wobble * 0.1, seed + 10 * h + p,
                         (c[0] + radius * 0.5 * math.cos(h * 2.0), c[1] + radius * 0.5 * math.sin(h * 2.0)))
                 for h in range(holes)]
        polys.append(shapely.difference(shell, shapely.union_all(inner)) if inner else shell)
    return shapely.union_all(polys)


@settings(max_examples=60, deadline=None)
@given(shapes, st.floats(0.1, 5.0))
def test_the_simplified_polygon_covers_the_given_one_within_the_tolerance(geom: shapely.Geometry, tol: float):
    out = grown_simplification(geom, tol)
    assert out.is_valid
    if out is geom:
        return
    n_in, n_out = shapely.get_num_coordinates(geom), shapely.get_num_coordinates(out)
    assert n_out < n_in
    # covers: nothing of the given polygon is left out (to a rounding of 1e-9 of the size)
    slack = 1e-9 * (1.0 + max(abs(v) for v in geom.bounds))
    assert shapely.buffer(out, slack).covers(geom)
    # every point of the simplified polygon within the tolerance of the given one: its boundary
    # sampled every tol/20 (a distance changes no faster than along the boundary), the samples
    # outside the given polygon measured to its nearest edge
    probes = shapely.points(shapely.get_coordinates(shapely.segmentize(out.boundary, tol / 20.0)))
    outside = probes[~shapely.contains_xy(geom, *shapely.get_coordinates(probes).T)]
    if len(outside):
        xy = shapely.get_coordinates(geom.boundary, return_index=False)
        rings = shapely.get_coordinates(shapely.get_rings(shapely.get_parts(geom)), return_index=True)[1]
        same = rings[1:] == rings[:-1]
        edges = shapely.linestrings(np.stack([xy[:-1][same], xy[1:][same]], axis=1))
        _, dist = shapely.STRtree(edges).query_nearest(outside, return_distance=True, all_matches=False)
        assert dist.max() <= tol * 1.03 + slack


def test_a_detailed_circle_is_simplified_and_reported():
    """20,000 vertices of a 380 ha circle: the plan's area covers it, the manifest's counts say so."""
    lat0, lon0 = 49.43, 14.96
    r = math.sqrt(380e4 / math.pi)
    a = np.linspace(0.0, 2 * math.pi, 20_000, endpoint=False)
    kx, ky = 111_320.0 * math.cos(math.radians(lat0)), 110_574.0
    area = shapely.Polygon(np.c_[lon0 + r * np.cos(a) / kx, lat0 + r * np.sin(a) / ky])
    zone = shapely.Polygon(np.c_[lon0 + 60 * np.cos(a) / kx, lat0 + 60 * np.sin(a) / ky])
    spec = parse_spec({"area": {"wkt": "POLYGON((0 0, 1 0, 1 1, 0 0))"}, "camera": {"model": "sony-a6000-16mm"},
                       "targets": {"gsd_cm": 2.5}, "vehicle": {"type": "copter", "cruise_speed_ms": 10.0}}, base=Path("."))
    site = prepare_site(spec, PlanInputs(area, (zone,)), target_height(spec)[0])
    s = site.simplification
    assert s.area_vertices[0] == 20_001 and s.area_vertices[1] < 1000
    assert s.zone_vertices[0] == 20_001 and s.zone_vertices[1] < 200
    given_area = site.planar.forward(area)
    assert site.area.covers(shapely.buffer(given_area, -1e-6))
    assert site.zones is not None and site.zones.covers(shapely.buffer(site.planar.forward(zone), -1e-6))
    tol = s.tolerance_m * site.grid_scale
    assert 0.0 < site.area.area - given_area.area <= tol * given_area.length
    plan = plan_mission(spec, PlanInputs(area, (zone,)))
    assert plan.site.simplification == s
    assert shapely.get_num_coordinates(plan.site.area_wgs84) == s.area_vertices[1]
