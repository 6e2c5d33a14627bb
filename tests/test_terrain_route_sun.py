"""Terrain modes and DEM errors, line ordering and turns, sun elevation."""

from __future__ import annotations

import datetime as dt
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from aerosurvey.errors import InputError
from aerosurvey.inputs import plan_from_files
from aerosurvey.plan.route import line_orders
from aerosurvey.plan.sun import sun_elevation_deg
from aerosurvey.plan.terrain import thin_profile
from aerosurvey.spec import load_spec
from conftest import REPO, make_spec

sys.path.insert(0, str(REPO / "missions" / "tools"))
from synthetic_dem import write_dem  # noqa: E402

# the default test area spans about 15.000..15.006 E, 49.400..49.4035 N: UTM 33N x ~500000, y ~5471700
WEST, NORTH = 499700.0, 5472400.0


def _dem(tmp: Path, name: str = "dem.tif", west: float = WEST, north: float = NORTH, size: int = 140,
         relief: float = 30.0, hole: bool = False) -> str:
    p = tmp / name
    write_dem(str(p), 32633, west, north, size, size, 10.0, 400.0, relief)
    if hole:
        import rasterio

        with rasterio.open(p, "r+") as ds:
            a = ds.read(1)
            a[20:35, 40:55] = ds.nodata
            ds.write(a, 1)
    return name


def test_dem_not_covering_the_area(tmp_path):
    name = _dem(tmp_path, west=WEST + 900)
    spec = make_spec(tmp_path, {"terrain": {"dem": name, "mode": "fixed"}})
    with pytest.raises(InputError, match="does not cover the area"):
        plan_from_files(load_spec(spec))


def test_nodata_under_the_area(tmp_path):
    name = _dem(tmp_path, hole=True)
    spec = make_spec(tmp_path, {"terrain": {"dem": name, "mode": "fixed"}})
    with pytest.raises(InputError, match="nodata"):
        plan_from_files(load_spec(spec))


def test_fixed_mode_reports_relief_and_keeps_overlap_at_the_highest_ground(tmp_path):
    name = _dem(tmp_path, relief=30.0)
    plan = plan_from_files(load_spec(make_spec(tmp_path, {"terrain": {"dem": name, "mode": "fixed"}})))
    h = plan.sensor.heights
    relief = h.ground_max_m - h.ground_min_m
    assert relief > 5
    assert h.spacing_agl_m == pytest.approx(h.target_agl_m - relief)
    assert plan.sensor.gsd_max_m == pytest.approx(0.025)
    assert any("fixed height over terrain" in w for w in plan.warnings)
    # every station flies the same altitude, its AGL is that altitude over its own ground
    assert np.ptp(plan.stations.alt_rel_m) == 0
    assert plan.stations.agl_m.min() >= h.spacing_agl_m - 1e-6


def test_fixed_mode_fails_when_relief_eats_the_clearance(tmp_path):
    name = _dem(tmp_path, relief=300.0)
    spec = make_spec(tmp_path, {"terrain": {"dem": name, "mode": "fixed"}})
    with pytest.raises(InputError, match="use terrain.mode = 'follow'"):
        plan_from_files(load_spec(spec))


def test_follow_mode_keeps_agl_within_tolerance_with_few_waypoints(tmp_path):
    name = _dem(tmp_path, relief=40.0)
    spec = make_spec(tmp_path, {"terrain": {"dem": name, "mode": "follow", "tolerance_m": 2.0}})
    plan = plan_from_files(load_spec(spec))
    terrain_wps = [w for w in plan.waypoints if w.kind == "terrain"]
    assert 0 < len(terrain_wps) < len(plan.stations.ids)
    assert np.allclose(plan.stations.agl_m, plan.sensor.heights.nominal_agl_m)
    assert plan.sensor.heights.max_agl_m <= 120


def test_terrain_frame_items(tmp_path):
    plan = plan_from_files(load_spec(make_spec(tmp_path, {"terrain": {"mode": "terrain-frame"}})))
    from aerosurvey.mission.builder import build_mission

    m = build_mission(plan)
    wps = [it for it in m.items if it.command == 16]
    assert {it.frame for it in wps} == {10}
    assert all(it.z == pytest.approx(plan.sensor.heights.nominal_agl_m, abs=0.01) for it in wps)


def test_thin_profile_keeps_ends_and_tolerance():
    s = np.linspace(0, 1000, 101)
    alt = 50 + 20 * np.sin(s / 150)
    keep = thin_profile(s, alt, 1.0)
    assert keep[0] == 0 and keep[-1] == 100 and len(keep) < 101
    interp = np.interp(s, s[keep], alt[keep])
    assert np.max(np.abs(interp - alt)) <= 1.0 + 1e-9


@given(st.integers(2, 40), st.floats(5, 200), st.floats(10, 200))
def test_line_orders_are_permutations(n, spacing, radius):
    for order in line_orders(n, spacing, radius, "plane"):
        assert sorted(order) == list(range(n))


def test_plane_skip_orders_offered_when_spacing_below_turn_diameter():
    assert len(line_orders(10, 40.0, 50.0, "plane")) > 1
    assert len(line_orders(10, 120.0, 50.0, "plane")) == 1
    assert len(line_orders(10, 40.0, 50.0, "copter")) == 1


def test_sun_elevation_known_values():
    # Greenwich at the June solstice, 12:00 UTC: 90 - 51.48 + 23.44 = 61.96 deg (solar noon ~12:02)
    e = sun_elevation_deg(0.0, 51.48, dt.datetime(2026, 6, 21, 12, 0, tzinfo=dt.UTC))
    assert e == pytest.approx(61.9, abs=0.2)
    # midnight is below the horizon
    assert sun_elevation_deg(0.0, 51.48, dt.datetime(2026, 6, 21, 0, 0, tzinfo=dt.UTC)) < 0
    # equator at the March equinox near local noon: close to the zenith
    assert sun_elevation_deg(0.0, 0.0, dt.datetime(2026, 3, 20, 12, 7, tzinfo=dt.UTC)) > 89.0


def test_low_sun_warning(tmp_path):
    spec = make_spec(tmp_path, {"conditions": {"start": "2026-12-21T07:30:00+01:00", "end": "2026-12-21T09:30:00+01:00",
                                               "min_sun_elevation_deg": 15}})
    plan = plan_from_files(load_spec(spec))
    assert plan.sun is not None and plan.sun["min_elevation_deg"] < 15
    assert any("sun elevation drops" in w for w in plan.warnings)


def test_cross_hatch_adds_a_perpendicular_pass(tmp_path):
    plan = plan_from_files(load_spec(make_spec(tmp_path, {"flight": {"heading": 30.0, "cross_hatch": True}})))
    heads = {round(r.heading_deg % 180, 3) for r in plan.route.runs}
    assert heads == {30.0, 120.0}
    assert {r.pass_index for r in plan.route.runs} == {1, 2}
