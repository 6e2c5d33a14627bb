"""Zone outlines as polygons: a polygon as read, a circle as the polygon round it."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pyproj
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.airspace.model import Geozone

#: a circle becomes the polygon of this many sides drawn round it (its sides touch the circle,
#: its corners lie radius / cos(pi / CIRCLE_SIDES) out: 1.2 m beyond a 1 km circle)
CIRCLE_SIDES = 64
_GEOD = pyproj.Geod(ellps="WGS84")


def outlines_wgs84(zones: Sequence[Geozone]) -> list[BaseGeometry]:
    """Each zone's outline in longitude/latitude; a circle as the geodesic polygon round it (it holds the circle)."""
    out: list[BaseGeometry] = [z.outline for z in zones]
    circles = [i for i, z in enumerate(zones) if z.radius_m is not None]
    if circles:
        n = CIRCLE_SIDES
        az = np.tile(np.arange(n) * 360.0 / n, len(circles))
        lon0 = np.repeat([zones[i].outline.x for i in circles], n)
        lat0 = np.repeat([zones[i].outline.y for i in circles], n)
        r = np.repeat([float(zones[i].radius_m or 0.0) for i in circles], n) / math.cos(math.pi / n)
        lon, lat, _ = _GEOD.fwd(lon0, lat0, az, r)
        rings = np.stack([np.asarray(lon), np.asarray(lat)], axis=1).reshape(len(circles), n, 2)
        for i, ring in zip(circles, rings):
            out[i] = shapely.Polygon(ring)
    return out
