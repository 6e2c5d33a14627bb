"""Terrain following within the vehicle's climb and descent rates (plan/altitudes.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import rasterio
from hypothesis import given, settings
from hypothesis import strategies as st
from rasterio.transform import from_origin

from aerosurvey.errors import InputError
from aerosurvey.inputs import plan_from_files
from aerosurvey.plan.altitudes import Slopes, flyable_profile
from aerosurvey.spec import load_spec
from conftest import make_spec


def _least_dominating(s: np.ndarray, wanted: np.ndarray, climb: float, descent: float) -> np.ndarray:
    """Brute force: each point as high as every later point less the climb to it, and as every
    earlier point less the descent from it."""
    d = s[None, :] - s[:, None]  # d[i, j] = s_j - s_i
    reach = np.where(d >= 0, wanted[None, :] - climb * d, wanted[None, :] + descent * d)
    return reach.max(axis=1)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.floats(0.1, 50.0), st.floats(-80.0, 80.0)), min_size=1, max_size=60),
       st.floats(0.01, 2.0), st.floats(0.01, 2.0))
def test_the_profile_is_the_lowest_flyable_one_above_the_wanted(steps, climb, descent) -> None:
    s = np.cumsum([d for d, _ in steps]) - steps[0][0]
    wanted = np.array([a for _, a in steps])
    h = flyable_profile(s, wanted, Slopes(climb, descent))
    assert (h >= wanted - 1e-9).all()
    slope = np.diff(h) / np.diff(s)
    assert (slope <= climb + 1e-9).all() and (slope >= -descent - 1e-9).all()
    assert np.allclose(h, _least_dominating(s, wanted, climb, descent), atol=1e-9)


def test_a_flyable_profile_is_kept() -> None:
    s = np.arange(0.0, 200.0, 20.0)
    wanted = 100 + 0.1 * s
    assert np.array_equal(flyable_profile(s, wanted, Slopes(0.25, 0.15)), wanted)


def _cliff_dem(path: Path, height: float) -> None:
    """Ground at 400 m west of x = 500,000 (UTM 33N) and `height` m higher east of it, rising over 20 m."""
    west, north, res, n = 499_700.0, 5_472_400.0, 5.0, 280
    x = west + res * (np.arange(n) + 0.5)
    z = 400.0 + height * np.clip((x - 499_990.0) / 20.0, 0.0, 1.0)
    profile = dict(driver="GTiff", width=n, height=n, count=1, dtype="float32", crs="EPSG:32633",
                   transform=from_origin(west, north, res, res), nodata=-9999.0)
    with rasterio.open(path, "w", **profile) as ds:
        ds.write(np.tile(z, (n, 1)).astype("float32"), 1)


def test_a_cliff_is_climbed_early_and_reported(tmp_path: Path) -> None:
    _cliff_dem(tmp_path / "dem.tif", 12.0)
    spec = make_spec(tmp_path, {"terrain": {"dem": "dem.tif", "mode": "follow", "tolerance_m": 2.0},
                                "flight": {"heading": 90.0, "cross_hatch": False},
                                "vehicle": {"climb_rate_ms": 2.0, "descent_rate_ms": 1.0}})
    plan = plan_from_files(load_spec(spec))
    st_ = plan.stations
    speed = plan.sensor.speed.speed_ms
    wanted_agl = plan.sensor.heights.nominal_agl_m
    assert (st_.agl_m >= wanted_agl - 1e-6).all()  # never below the height the GSD needs
    for r in np.unique(st_.run):
        i = np.flatnonzero(st_.run == r)
        ds = np.hypot(np.diff(st_.x[i]), np.diff(st_.y[i]))
        slope = np.diff(st_.alt_rel_m[i]) / ds
        assert slope.max() <= 2.0 / speed + 1e-6 and slope.min() >= -1.0 / speed - 1e-6
    assert st_.agl_m.max() > wanted_agl + 2.0  # the cliff cannot be followed within the tolerance ...
    warning = [w for w in plan.warnings if w.startswith("terrain: the ground along")]
    assert len(warning) == 1 and "runs P1-L001-R1" in warning[0], plan.warnings  # ... and that is said


def test_a_cliff_that_would_take_the_photos_over_the_cap_is_refused(tmp_path: Path) -> None:
    _cliff_dem(tmp_path / "dem.tif", 60.0)
    spec = make_spec(tmp_path, {"terrain": {"dem": "dem.tif", "mode": "follow", "tolerance_m": 2.0},
                                "flight": {"heading": 90.0, "cross_hatch": False},
                                "vehicle": {"climb_rate_ms": 2.0, "descent_rate_ms": 1.0}})
    with pytest.raises(InputError, match=r"m above ground, over the 120 m cap \(vehicle.max_height_agl_m\)"):
        plan_from_files(load_spec(spec))
