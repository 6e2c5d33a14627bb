"""Geofence: the hull of everything flown (and the launch points) grown by 50 m as the
inclusion polygon; the exclusion zones as exclusion polygons. (lat, lon) rings, not closed."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.area import Planar
from aerosurvey.plan.model import Fence, Ring

FENCE_MARGIN_M = 50.0


def geofence(planar: Planar, flown_xy: Sequence[tuple[float, float]], exclusions_wgs84: Sequence[BaseGeometry]) -> Fence:
    # the points as one array (shapely.MultiPoint of a list makes a Point of each first)
    points = shapely.multipoints(np.asarray(flown_xy, float).reshape(-1, 2)) if len(flown_xy) else shapely.MultiPoint()
    hull = shapely.buffer(shapely.convex_hull(points), FENCE_MARGIN_M, quad_segs=2)
    ring = np.asarray(hull.exterior.coords)[:-1]
    lon, lat = planar.lonlat(ring[:, 0], ring[:, 1])
    inclusion: Ring = tuple((round(float(a), 8), round(float(b), 8)) for a, b in zip(lat, lon))
    exclusion: list[Ring] = []
    for z in exclusions_wgs84:
        for poly in shapely.get_parts(z):
            c = np.asarray(poly.exterior.coords)[:-1]
            exclusion.append(tuple((round(float(b), 8), round(float(a), 8)) for a, b in c))
    return Fence((inclusion,), tuple(exclusion))
