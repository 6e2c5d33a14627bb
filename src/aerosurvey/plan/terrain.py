"""Terrain from a DEM GeoTIFF: windowed sampling, area statistics, and the waypoint
thinning used by the `follow` height mode.

The DEM is read with rasterio, one window covering what is asked (never the whole file
when the area is a small part of it). Heights are metres above the DEM's vertical datum.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyproj
from shapely.geometry.base import BaseGeometry

from aerosurvey.area import Planar
from aerosurvey.errors import InputError


class Dem:
    """A DEM opened for sampling in the planning CRS."""

    def __init__(self, path: Path, planar: Planar):
        # rasterio (with GDAL, attrs, affine) loads only when a DEM is given: most plans have none
        import rasterio
        import rasterio.errors

        self.path = path
        try:
            self.ds = rasterio.open(path)
        except rasterio.errors.RasterioIOError as exc:
            raise InputError(f"terrain.dem: {str(path)!r} cannot be opened as a raster: {exc}") from None
        if self.ds.crs is None:
            raise InputError(f"terrain.dem: {str(path)!r} has no CRS; give the DEM a georeference (e.g. gdal_edit.py -a_srs)")
        self.crs = pyproj.CRS.from_user_input(self.ds.crs.to_wkt())
        self.to_dem = pyproj.Transformer.from_crs(planar.crs, self.crs, always_xy=True)
        self.nodata = self.ds.nodata
        self._cache: tuple[tuple[int, int, int, int], np.ndarray] | None = None

    def close(self) -> None:
        self.ds.close()

    def _window_array(self, cols: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, int, int]:
        c0, c1 = int(np.floor(cols.min())) - 1, int(np.ceil(cols.max())) + 2
        r0, r1 = int(np.floor(rows.min())) - 1, int(np.ceil(rows.max())) + 2
        c0, r0 = max(c0, 0), max(r0, 0)
        c1, r1 = min(c1, self.ds.width), min(r1, self.ds.height)
        key = (c0, r0, c1, r1)
        if self._cache is not None:
            (k0, k1, k2, k3), arr = self._cache
            if k0 <= c0 and k1 <= r0 and k2 >= c1 and k3 >= r1:
                return arr, k0, k1
        import rasterio.windows

        arr = self.ds.read(1, window=rasterio.windows.Window(c0, r0, c1 - c0, r1 - r0), masked=True)
        arr = arr.astype(np.float64).filled(np.nan)
        self._cache = (key, arr)
        return arr, c0, r0

    def sample(self, x: np.ndarray, y: np.ndarray, what: str) -> np.ndarray:
        """Bilinear heights at planning-CRS points; an error names points off the DEM or on nodata."""
        x = np.atleast_1d(np.asarray(x, float))
        y = np.atleast_1d(np.asarray(y, float))
        dx, dy = self.to_dem.transform(x, y)
        inv = ~self.ds.transform
        dx, dy = np.asarray(dx), np.asarray(dy)
        cols = inv.a * dx + inv.b * dy + inv.c - 0.5
        rows = inv.d * dx + inv.e * dy + inv.f - 0.5
        outside = (cols < -0.5) | (rows < -0.5) | (cols > self.ds.width - 0.5) | (rows > self.ds.height - 0.5)
        if outside.any():
            i = int(np.flatnonzero(outside)[0])
            raise InputError(
                f"terrain.dem {self.path.name!r} does not cover the {what}: {int(outside.sum())} point(s) off the DEM, "
                f"first at planning x {x[i]:.1f}, y {y[i]:.1f}"
            )
        cols = np.clip(cols, 0, self.ds.width - 1)
        rows = np.clip(rows, 0, self.ds.height - 1)
        arr, c0, r0 = self._window_array(cols, rows)
        cc, rr = cols - c0, rows - r0
        i0 = np.clip(np.floor(cc).astype(int), 0, arr.shape[1] - 1)
        j0 = np.clip(np.floor(rr).astype(int), 0, arr.shape[0] - 1)
        i1 = np.minimum(i0 + 1, arr.shape[1] - 1)
        j1 = np.minimum(j0 + 1, arr.shape[0] - 1)
        fx, fy = cc - i0, rr - j0
        z = (arr[j0, i0] * (1 - fx) * (1 - fy) + arr[j0, i1] * fx * (1 - fy)
             + arr[j1, i0] * (1 - fx) * fy + arr[j1, i1] * fx * fy)
        bad = ~np.isfinite(z)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(
                f"terrain.dem {self.path.name!r} has nodata under the {what}: {int(bad.sum())} point(s), "
                f"first at planning x {x[i]:.1f}, y {y[i]:.1f}"
            )
        return z

    def range_over(self, geom_plan: BaseGeometry, what: str) -> tuple[float, float]:
        """Lowest and highest DEM cell under a polygon (planning CRS); nodata there is an error."""
        import rasterio.features
        import rasterio.windows
        import shapely

        t = self.to_dem
        g = shapely.transform(geom_plan, lambda xy: np.column_stack(t.transform(xy[:, 0], xy[:, 1])))
        l, b, r, tp = g.bounds
        db = self.ds.bounds
        if l < db.left or r > db.right or b < db.bottom or tp > db.top:
            raise InputError(
                f"terrain.dem {self.path.name!r} does not cover the {what}: the {what} spans "
                f"x {l:.1f}..{r:.1f}, y {b:.1f}..{tp:.1f} in the DEM's CRS, the DEM "
                f"x {db.left:.1f}..{db.right:.1f}, y {db.bottom:.1f}..{db.top:.1f}"
            )
        win = rasterio.windows.from_bounds(l, b, r, tp, transform=self.ds.transform).round_offsets().round_lengths()
        win = rasterio.windows.Window(win.col_off, win.row_off, win.width + 1, win.height + 1).intersection(
            rasterio.windows.Window(0, 0, self.ds.width, self.ds.height))
        arr = self.ds.read(1, window=win, masked=True)
        inside = rasterio.features.geometry_mask([g], out_shape=arr.shape,
                                                 transform=self.ds.window_transform(win), invert=True, all_touched=True)
        vals = arr[inside]
        if np.ma.count_masked(vals) > 0:
            raise InputError(f"terrain.dem {self.path.name!r} has {int(np.ma.count_masked(vals))} nodata cell(s) under the {what}")
        data = np.asarray(vals, float)
        if data.size == 0:
            raise InputError(f"terrain.dem {self.path.name!r}: no DEM cell under the {what}")
        return float(data.min()), float(data.max())


def thin_profile(s: np.ndarray, alt: np.ndarray, tolerance: float) -> np.ndarray:
    """Indices of the profile points to keep as waypoints so that straight climbs and
    descents between them stay within `tolerance` of every wanted altitude.

    Greedy: from each kept point, go as far as the straight line still fits.
    """
    n = len(s)
    if n <= 2:
        return np.arange(n)
    keep = [0]
    i = 0
    while i < n - 1:
        j = i + 1
        while j + 1 < n:
            cand = j + 1
            seg = slice(i, cand + 1)
            frac = (s[seg] - s[i]) / (s[cand] - s[i])
            line = alt[i] + frac * (alt[cand] - alt[i])
            if np.max(np.abs(line - alt[seg])) > tolerance:
                break
            j = cand
        keep.append(j)
        i = j
    return np.asarray(keep)
