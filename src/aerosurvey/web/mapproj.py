"""The page's map frame: Web Mercator metres relative to an origin near the area, and the plan
CRS as a PROJ string for the page's cursor readout.

Web Mercator lets a user's XYZ tiles line up with our vector layers; coordinates relative
to an origin keep the layers' numbers short. The page converts the cursor to the plan's CRS
with proj4js, which reads PROJ strings: the string is that of the plan CRS with the datum
shift the planner's own transformation uses (`+towgs84`, from its Helmert step), checked
here against that transformation over the frame (`proj4_error_m`).
"""

from __future__ import annotations

import functools
import math
import re
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pyproj
from shapely.geometry.base import BaseGeometry

if TYPE_CHECKING:
    from aerosurvey.area import Planar

R = 6378137.0  # the sphere of EPSG:3857
MAX_LAT = 85.05112878
_HELMERT = re.compile(r"proj=helmert((?: \+?\w+=[-\d.e]+)+)")


def mercator(lon: np.ndarray, lat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    lon = np.asarray(lon, dtype=float)
    lat = np.clip(np.asarray(lat, dtype=float), -MAX_LAT, MAX_LAT)
    return R * np.radians(lon), R * np.log(np.tan(np.pi / 4 + np.radians(lat) / 2))


def inverse_mercator(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return np.degrees(np.asarray(x) / R), np.degrees(2 * np.arctan(np.exp(np.asarray(y) / R)) - np.pi / 2)


def proj4_for_page(planar: Planar, lon: np.ndarray, lat: np.ndarray) -> tuple[str, float]:
    """The plan CRS as a PROJ string proj4js reads, and its largest error (metres) at the given
    points against the planner's transformation. A CRS whose datum PROJ shifts with a Helmert
    transformation gets that shift as `+towgs84` (PROJ strings of EPSG CRSs leave it out)."""
    px, py = planar.xy(lon, lat)
    best, err = "", math.inf
    for text in _proj4_candidates(planar.crs.srs):
        qx, qy = _from_wgs84(text).transform(lon, lat)
        e = float(np.max(np.hypot(np.asarray(qx) - px, np.asarray(qy) - py)))
        if e < err:
            best, err = text, e
    return best, err


@functools.lru_cache(maxsize=16)
def _proj4_candidates(srs: str) -> tuple[str, ...]:
    """The CRS's PROJ string, and with each Helmert shift PROJ knows for its datum (cached: PROJ's
    search for the operations takes a few tenths of a second)."""
    crs = pyproj.CRS.from_user_input(srs)
    with warnings.catch_warnings():  # PROJ warns that a PROJ string may lose details (measured by the caller),
        warnings.simplefilter("ignore", UserWarning)  # and of grids it does not have
        base = crs.to_proj4()
        if "+towgs84" in base or "+datum=WGS84" in base:
            return (base,)
        ops = pyproj.transformer.TransformerGroup("EPSG:4326", crs, always_xy=True).transformers[:8]
    out = [base]
    for op in ops:
        m = _HELMERT.search(op.definition or "")
        if m is None:
            continue
        p = dict(kv.lstrip("+").split("=") for kv in m.group(1).split())
        rot = [float(p.get(k, 0.0)) for k in ("rx", "ry", "rz")]
        if p.get("convention") == "coordinate_frame":  # towgs84 is position vector
            rot = [-r for r in rot]
        shift = [float(p.get(k, 0.0)) for k in ("x", "y", "z")]
        for sign in (1.0, -1.0):  # a pipeline may hold the shift written from either side
            towgs84 = ",".join(f"{sign * x:.10g}" for x in [*shift, *rot, float(p.get("s", 0.0))])
            out.append(base.replace(" +no_defs", f" +towgs84={towgs84} +no_defs"))
    return tuple(out)


@functools.lru_cache(maxsize=64)
def _from_wgs84(proj4: str) -> pyproj.Transformer:
    return pyproj.Transformer.from_crs("EPSG:4326", pyproj.CRS.from_proj4(proj4), always_xy=True)


@dataclass(frozen=True)
class MapFrame:
    ox: float  # origin, Web Mercator metres
    oy: float
    half: float  # half-width of the frame around the area, metres
    crs: str
    proj4: str  # the plan CRS for the page's cursor readout (proj4js)
    proj4_error_m: float  # its largest error over the frame against the planner's transformation

    @classmethod
    def around(cls, area_wgs84: BaseGeometry, planar: Planar) -> MapFrame:
        c = area_wgs84.centroid
        ox, oy = mercator(np.array([c.x]), np.array([c.y]))
        x0, y0, x1, y1 = area_wgs84.bounds
        mx, my = mercator(np.array([x0, x1]), np.array([y0, y1]))
        half = max(float(np.ptp(mx)), float(np.ptp(my)), 500.0) * 1.5
        g = np.linspace(-1.0, 1.0, 9)
        u, v = (a.ravel() for a in np.meshgrid(g, g))
        lon, lat = inverse_mercator(ox[0] + u * half, oy[0] + v * half)
        proj4, err = proj4_for_page(planar, lon, lat)
        return cls(float(ox[0]), float(oy[0]), half, planar.name, proj4, err)

    def from_lonlat(self, lon: np.ndarray, lat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x, y = mercator(lon, lat)
        return x - self.ox, y - self.oy

    def rings(self, polygon: BaseGeometry) -> list[list[list[float]]]:
        out = []
        for ring in [polygon.exterior, *polygon.interiors]:
            xy = np.asarray(ring.coords)
            x, y = self.from_lonlat(xy[:, 0], xy[:, 1])
            out.append(np.round(np.column_stack([x, y]), 2).tolist())
        return out

    def as_dict(self) -> dict[str, Any]:
        return {"origin": [self.ox, self.oy], "half": self.half, "crs": self.crs, "proj4": self.proj4,
                "proj4_error_m": self.proj4_error_m,
                "lat0": math.degrees(2 * math.atan(math.exp(self.oy / R)) - math.pi / 2)}
