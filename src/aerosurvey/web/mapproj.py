"""The page's map frame: Web Mercator metres relative to an origin near the area.

Web Mercator lets a user's XYZ tiles line up with our vector layers; coordinates relative
to an origin keep the numbers small enough for the browser's single-precision drawing.
The page shows the cursor in the plan's CRS through a cubic fitted here (the page has no
PROJ); the fit's largest error over the frame is reported with it.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from shapely.geometry.base import BaseGeometry

if TYPE_CHECKING:
    from aerosurvey.area import Planar

R = 6378137.0  # the sphere of EPSG:3857
MAX_LAT = 85.05112878


def mercator(lon: np.ndarray, lat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    lon = np.asarray(lon, dtype=float)
    lat = np.clip(np.asarray(lat, dtype=float), -MAX_LAT, MAX_LAT)
    return R * np.radians(lon), R * np.log(np.tan(np.pi / 4 + np.radians(lat) / 2))


def inverse_mercator(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return np.degrees(np.asarray(x) / R), np.degrees(2 * np.arctan(np.exp(np.asarray(y) / R)) - np.pi / 2)


def _terms(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Cubic terms in the order the page evaluates them: 1 u v u² uv v² u³ u²v uv² v³."""
    return np.stack([np.ones_like(u), u, v, u * u, u * v, v * v, u ** 3, u * u * v, u * v * v, v ** 3], axis=-1)


@dataclass(frozen=True)
class MapFrame:
    ox: float  # origin, Web Mercator metres
    oy: float
    half: float  # half-width of the fitted square, metres
    crs: str
    cx: list[float]  # cubic coefficients: plan CRS x and y from (u, v) = relative mercator / half
    cy: list[float]
    fit_error_m: float
    proj4: str  # the plan CRS as a PROJ string, for the page's cursor readout (proj4js)

    @classmethod
    def around(cls, area_wgs84: BaseGeometry, planar: Planar) -> MapFrame:
        c = area_wgs84.centroid
        ox, oy = mercator(np.array([c.x]), np.array([c.y]))
        x0, y0, x1, y1 = area_wgs84.bounds
        mx, my = mercator(np.array([x0, x1]), np.array([y0, y1]))
        half = max(float(np.ptp(mx)), float(np.ptp(my)), 500.0) * 1.5
        g = np.linspace(-1.0, 1.0, 21)
        u, v = (a.ravel() for a in np.meshgrid(g, g))
        lon, lat = inverse_mercator(ox[0] + u * half, oy[0] + v * half)
        px, py = planar.xy(lon, lat)
        a = _terms(u, v)
        cx, *_ = np.linalg.lstsq(a, px, rcond=None)
        cy, *_ = np.linalg.lstsq(a, py, rcond=None)
        gt = np.linspace(-1.0, 1.0, 17)  # checked between the fitted nodes
        ut, vt = (b.ravel() for b in np.meshgrid(gt, gt))
        lon, lat = inverse_mercator(ox[0] + ut * half, oy[0] + vt * half)
        tx, ty = planar.xy(lon, lat)
        at = _terms(ut, vt)
        err = float(np.max(np.hypot(at @ cx - tx, at @ cy - ty)))
        with warnings.catch_warnings():  # PROJ warns that a PROJ string may lose details; the page only reads a cursor position
            warnings.simplefilter("ignore", UserWarning)
            proj4 = planar.crs.to_proj4()
        return cls(float(ox[0]), float(oy[0]), half, planar.name, cx.tolist(), cy.tolist(), err, proj4)

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
        return {"origin": [self.ox, self.oy], "half": self.half, "crs": self.crs, "cx": self.cx, "cy": self.cy,
                "fit_error_m": self.fit_error_m, "proj4": self.proj4,
                "lat0": math.degrees(2 * math.atan(math.exp(self.oy / R)) - math.pi / 2)}
