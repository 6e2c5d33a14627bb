"""The reprojection helper: cached per CRS, and the same numbers as a transformer of our own."""

from __future__ import annotations

import numpy as np
import pyproj
import pytest
import shapely

from aerosurvey.area import transformer
from aerosurvey.reproject import planar, reproject, reproject_xy

LON = np.array([14.9, 15.0, 15.3, 16.1])
LAT = np.array([49.2, 49.4, 49.45, 50.0])


@pytest.mark.parametrize("crs", ["EPSG:32633", "EPSG:5514"])
def test_planar_matches_pyproj_and_round_trips(crs):
    own = pyproj.Transformer.from_crs("EPSG:4326", crs, always_xy=True)
    ex, ey = own.transform(LON, LAT)
    x, y = planar(crs).xy(LON, LAT)
    np.testing.assert_allclose(x, ex, atol=1e-6)
    np.testing.assert_allclose(y, ey, atol=1e-6)
    lon, lat = planar(crs).lonlat(x, y)
    np.testing.assert_allclose(lon, LON, atol=1e-9)
    np.testing.assert_allclose(lat, LAT, atol=1e-9)
    assert planar(crs).crs.equals(pyproj.CRS.from_user_input(crs))


def test_planar_is_made_once_per_crs_from_the_cached_transformers():
    p = planar("EPSG:32633")
    assert planar("EPSG:32633") is p
    assert p.to_plan is transformer("EPSG:4326", "EPSG:32633")
    assert p.to_wgs84 is transformer("EPSG:32633", "EPSG:4326")


def test_reproject_geometry_and_points():
    own = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:5514", always_xy=True)
    ring = list(zip(LON.tolist(), LAT.tolist()))
    poly = shapely.Polygon(ring)
    out = reproject(poly, "EPSG:4326", "EPSG:5514")
    ex, ey = own.transform(LON, LAT)
    got = shapely.get_coordinates(out)[:-1]
    np.testing.assert_allclose(got[:, 0], ex, atol=1e-6)
    np.testing.assert_allclose(got[:, 1], ey, atol=1e-6)
    x, y = reproject_xy(LON, LAT, "EPSG:4326", "EPSG:5514")
    np.testing.assert_allclose(x, ex, atol=1e-6)
    np.testing.assert_allclose(y, ey, atol=1e-6)
    back = reproject(out, "EPSG:5514", "EPSG:4326")
    np.testing.assert_allclose(shapely.get_coordinates(back)[:-1], np.column_stack([LON, LAT]), atol=1e-9)


def test_unknown_crs_is_refused():
    with pytest.raises(pyproj.exceptions.CRSError):
        planar("EPSG:999999")
