"""Reprojection between a named CRS and WGS84 longitude/latitude, with cached transformers.

The one place to turn a CRS name (a manifest's crs.planning, a spec's mission.crs) into
transformations: PROJ takes 40-70 ms to set some up (S-JTSK/Krovak), so the transformers
come from area.transformer's cache and a Planar is made once per CRS. Planar does the
work: forward/inverse for geometries, xy/lonlat for coordinate arrays.
"""

from __future__ import annotations

import functools

import numpy as np
import numpy.typing as npt
import pyproj
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.area import Planar, transformer

WGS84 = "EPSG:4326"


@functools.lru_cache(maxsize=64)
def planar(crs: str) -> Planar:
    """The Planar of a projected CRS given by name (EPSG:32633, a WKT, a PROJ string).

    Raises pyproj.exceptions.CRSError for a name pyproj does not know.
    """
    return Planar(crs=pyproj.CRS.from_user_input(crs), to_plan=transformer(WGS84, crs), to_wgs84=transformer(crs, WGS84))


def reproject(geom: BaseGeometry, src: str, dst: str) -> BaseGeometry:
    """A geometry from CRS `src` to CRS `dst` (both by name; x/east first, as always_xy)."""
    t = transformer(src, dst)
    return shapely.transform(geom, lambda xy: np.column_stack(t.transform(xy[:, 0], xy[:, 1])))


def reproject_xy(x: npt.ArrayLike, y: npt.ArrayLike, src: str, dst: str) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Coordinate arrays from CRS `src` to CRS `dst`."""
    tx, ty = transformer(src, dst).transform(np.asarray(x, float), np.asarray(y, float))
    return np.asarray(tx, float), np.asarray(ty, float)
