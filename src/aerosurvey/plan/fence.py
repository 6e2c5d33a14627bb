"""Geofence: the hull of everything flown (and the launch points) grown by 50 m as the
inclusion polygon; the exclusion zones as exclusion polygons. (lat, lon) rings, not closed.

A hull of many vertices (an orbit's round rings: 81 fence items, where ArduPilot's SITL takes
70 and PX4 64) is first simplified by a tolerance t (doubling from 1 m until the inclusion has
at most `MAX_INCLUSION_VERTICES`) and grown by 50 m + t, so everything flown stays 50 m inside."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.area import Planar
from aerosurvey.plan.model import Fence, Ring

FENCE_MARGIN_M = 50.0
MAX_INCLUSION_VERTICES = 40


def geofence(planar: Planar, flown_xy: Sequence[tuple[float, float]], exclusions_wgs84: Sequence[BaseGeometry]) -> Fence:
    # the points as one array (shapely.MultiPoint of a list makes a Point of each first)
    points = shapely.multipoints(np.asarray(flown_xy, float).reshape(-1, 2)) if len(flown_xy) else shapely.MultiPoint()
    around = shapely.convex_hull(points)
    hull = shapely.buffer(around, FENCE_MARGIN_M, quad_segs=2)
    tolerance = 1.0
    while shapely.get_num_coordinates(hull) - 1 > MAX_INCLUSION_VERTICES:
        hull = shapely.buffer(shapely.simplify(around, tolerance), FENCE_MARGIN_M + tolerance, quad_segs=2)
        tolerance *= 2.0
    ring = np.asarray(hull.exterior.coords)[:-1]
    lon, lat = planar.lonlat(ring[:, 0], ring[:, 1])
    inclusion: Ring = tuple((round(float(a), 8), round(float(b), 8)) for a, b in zip(lat, lon))
    exclusion: list[Ring] = []
    for z in exclusions_wgs84:
        for poly in shapely.get_parts(z):
            c = np.asarray(poly.exterior.coords)[:-1]
            exclusion.append(tuple((round(float(b), 8), round(float(a), 8)) for a, b in c))
    return Fence((inclusion,), tuple(exclusion))
