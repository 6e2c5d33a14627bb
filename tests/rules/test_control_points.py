"""Control point layout over random areas: counts, places, spread, visibility."""

from __future__ import annotations

import json
import math

import numpy as np
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from aerosurvey.inputs import plan_from_files
from aerosurvey.rules.engine import Evidence, layout_settings
from aerosurvey.rules.load import plan_documents
from aerosurvey.rules.planview import PlanView
from aerosurvey.rules.profile import select_profiles
from aerosurvey.spec import load_spec
from conftest import make_spec, random_polygon
from rules.rectangles import rect_footprints


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(kind=st.sampled_from(["convex", "concave", "holed"]), seed=st.integers(0, 10_000), size=st.floats(200, 450))
def test_layout_on_random_areas(tmp_path_factory, kind, seed, size):
    tmp = tmp_path_factory.mktemp("cp")
    # coverage extends past the GCP ring (10 m out): every GCP can then be seen by the plan
    spec = make_spec(tmp, {"targets": {"images_beyond_boundary": 8, "coverage_margin_m": 12.0}},
                     rings=random_polygon(kind, seed, size))
    loaded = load_spec(spec)
    manifest, features = plan_documents(plan_from_files(loaded), loaded)
    view = PlanView.from_documents(json.loads(json.dumps(manifest)), features, "test")
    profiles = select_profiles(["cz-land-consolidation"])
    ev = Evidence(view, layout_settings(view, profiles))
    cps = ev.control_points("check")
    gcps = ev.control_points("gcp")

    # check points: at least one per 3 ha, all inside the area
    assert len(cps) >= math.ceil(view.area_ha / 3.0 - 1e-9)
    xy = np.array([(p.x, p.y) for p in cps])
    assert shapely.contains_xy(view.area, xy[:, 0], xy[:, 1]).all()

    # spread: every cell of a coarse grid that is mostly inside the area holds a check point
    cell = 3.0 * math.sqrt(3e4 / (math.sqrt(3) / 2))
    x0, y0, x1, y1 = view.area.bounds
    for cx in np.arange(x0, x1, cell):
        for cy in np.arange(y0, y1, cell):
            box = shapely.box(cx, cy, cx + cell, cy + cell)
            if shapely.intersection(view.area, box).area >= 0.75 * box.area:
                inside = (xy[:, 0] >= cx) & (xy[:, 0] < cx + cell) & (xy[:, 1] >= cy) & (xy[:, 1] < cy + cell)
                assert inside.any(), f"empty grid cell at {cx:.0f},{cy:.0f}"

    # GCPs: outside the area, seen by at least 6 planned photos, as many as the rule asks
    assert len(gcps) >= math.ceil(len(view.station_ids) / 100) + 1
    for g in gcps:
        assert not shapely.contains_xy(view.area, g.x, g.y)
        assert g.images >= 6, g
    # the images count is the footprints' own count, measured again
    recount = ev.footprints.count_at(np.array([g.x for g in gcps]), np.array([g.y for g in gcps]))
    assert list(recount) == [g.images for g in gcps]


def test_gcp_that_no_photo_reaches_says_how_to_extend_the_plan():
    from aerosurvey.rules.control_points import propose_gcps

    area = shapely.box(0, 0, 100, 100)
    # six photos over the middle only: nothing sees the outline
    fp = rect_footprints(np.full(6, 50.0), np.full(6, 50.0), np.zeros(6), np.full(6, 60.0), np.full(6, 60.0))
    gcps = propose_gcps(area, fp, count=4, min_images=6, offset=10.0, max_spacing=400.0, nogo=None)
    assert len(gcps) >= 4
    assert all(g.images == 0 and "targets.coverage_margin_m to at least 12 m" in g.note for g in gcps)
    assert all(not shapely.contains_xy(area, g.x, g.y) for g in gcps)


def test_gcp_moved_towards_the_outline_says_so():
    from aerosurvey.rules.control_points import propose_gcps

    area = shapely.box(0, 0, 100, 100)
    # photos reach 5 m past the outline, the ring is 10 m out
    fp = rect_footprints(np.full(6, 50.0), np.full(6, 50.0), np.zeros(6), np.full(6, 110.0), np.full(6, 110.0))
    gcps = propose_gcps(area, fp, count=4, min_images=6, offset=10.0, max_spacing=400.0, nogo=None)
    assert all(g.images == 6 and g.note.startswith("moved to") for g in gcps)


def test_count_at_is_the_count_of_footprints_holding_each_point() -> None:
    """Against a direct count, footprint by footprint, over every point (random rectangles; a
    point on an edge has probability zero here)."""
    rng = np.random.default_rng(7)
    n = 300
    x, y, h = rng.uniform(0, 1000, n), rng.uniform(0, 1000, n), rng.uniform(0, 2 * np.pi, n)
    across, along = rng.uniform(20, 80, n), rng.uniform(10, 60, n)
    fp = rect_footprints(x, y, h, across, along)
    px, py = rng.uniform(-50, 1050, 2000), rng.uniform(-50, 1050, 2000)
    want = np.zeros(len(px), int)
    for i in range(n):
        dx, dy = px - x[i], py - y[i]
        u, v = dx * np.sin(h[i]) + dy * np.cos(h[i]), dx * np.cos(h[i]) - dy * np.sin(h[i])
        want += (np.abs(u) <= along[i] / 2) & (np.abs(v) <= across[i] / 2)
    assert want.max() >= 2
    assert np.array_equal(fp.count_at(px, py), want)
    assert [int(fp.count_at(px[i:i + 1], py[i:i + 1])[0]) for i in range(200)] == want[:200].tolist()  # one at a time
    assert fp.count_at(np.array([]), np.array([])).tolist() == []


def test_count_at_counts_a_footprint_s_corners_and_edges() -> None:
    along, across = 80.0, 60.0
    h = float(np.arctan2(across, along))
    fp = rect_footprints([0.0], [0.0], [h], [across], [along])
    corners = fp.corners[0]
    mids = (corners + np.roll(corners, -1, axis=0)) / 2
    pts = np.concatenate([corners, mids, corners * 1.001])
    assert fp.count_at(pts[:, 0], pts[:, 1]).tolist() == [1] * 8 + [0] * 4


def test_the_layout_keeps_out_of_the_plan_s_exclusion_zones(tmp_path) -> None:
    """The control point layout's no-go ground holds the plan's exclusion zones, and any `nogo` given too."""
    from conftest import write_geojson

    zone = [[15.0024, 49.4013], [15.0036, 49.4013], [15.0036, 49.4022], [15.0024, 49.4022], [15.0024, 49.4013]]
    write_geojson(tmp_path / "zone.geojson", [zone])
    spec = make_spec(tmp_path, {"area": {"exclusions": ["zone.geojson"]}})
    loaded = load_spec(spec)
    manifest, features = plan_documents(plan_from_files(loaded), loaded)
    view = PlanView.from_documents(json.loads(json.dumps(manifest)), features, "test")
    assert view.exclusions is not None
    nogo = layout_settings(view, []).nogo
    assert nogo is not None and nogo.covers(view.exclusions)
    extra = shapely.box(*view.area.bounds).centroid.buffer(5.0)
    both = layout_settings(view, [], nogo=extra).nogo
    assert both is not None and both.covers(view.exclusions) and both.covers(extra)
