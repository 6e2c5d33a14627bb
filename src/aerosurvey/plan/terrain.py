"""Terrain from a DEM window held in memory (`plan.inputs.DemGrid`): sampling in the
planning CRS, area statistics, and the waypoint thinning used by the `follow` height mode.

The loader (`aerosurvey.inputs`) reads the window; nothing here opens a file. Heights are
metres above the DEM's vertical datum.
"""

from __future__ import annotations

import numpy as np
import pyproj
import rasterio.features
import rasterio.windows
import shapely
from affine import Affine
from shapely.geometry.base import BaseGeometry

from aerosurvey.area import Planar, transformer
from aerosurvey.errors import InputError
from aerosurvey.plan.inputs import DemGrid


class Dem:
    """A DEM window for sampling in the planning CRS."""

    def __init__(self, grid: DemGrid, planar: Planar):
        self.grid = grid
        self.name = grid.name
        self.crs = pyproj.CRS.from_wkt(grid.crs_wkt)
        self.to_dem = transformer(planar.crs.srs, self.crs.srs)
        self.window = Affine(*grid.transform)
        c0, r0 = grid.offset
        self.full = self.window * Affine.translation(-c0, -r0)

    def sample(self, x: np.ndarray, y: np.ndarray, what: str) -> np.ndarray:
        """Bilinear heights at planning-CRS points; an error names points off the DEM or on nodata."""
        x = np.atleast_1d(np.asarray(x, float))
        y = np.atleast_1d(np.asarray(y, float))
        dx, dy = self.to_dem.transform(x, y)
        inv = ~self.full
        dx, dy = np.asarray(dx), np.asarray(dy)
        cols = inv.a * dx + inv.b * dy + inv.c - 0.5
        rows = inv.d * dx + inv.e * dy + inv.f - 0.5
        n_rows, n_cols = self.grid.full_shape
        outside = (cols < -0.5) | (rows < -0.5) | (cols > n_cols - 0.5) | (rows > n_rows - 0.5)
        if outside.any():
            i = int(np.flatnonzero(outside)[0])
            raise InputError(
                f"terrain.dem {self.name!r} does not cover the {what}: {int(outside.sum())} point(s) off the DEM, "
                f"first at planning x {x[i]:.1f}, y {y[i]:.1f}"
            )
        cols = np.clip(cols, 0, n_cols - 1)
        rows = np.clip(rows, 0, n_rows - 1)
        arr = self.grid.heights
        c0, r0 = self.grid.offset
        cc, rr = cols - c0, rows - r0
        if (cc < 0).any() or (rr < 0).any() or (cc > arr.shape[1] - 1).any() or (rr > arr.shape[0] - 1).any():
            bad = (cc < 0) | (rr < 0) | (cc > arr.shape[1] - 1) | (rr > arr.shape[0] - 1)
            i = int(np.flatnonzero(bad)[0])
            raise InputError(
                f"terrain.dem {self.name!r}: the {what} reach beyond the part of the DEM read around the area "
                f"({int(bad.sum())} point(s), first at planning x {x[i]:.1f}, y {y[i]:.1f})"
            )
        i0 = np.clip(np.floor(cc).astype(int), 0, arr.shape[1] - 1)
        j0 = np.clip(np.floor(rr).astype(int), 0, arr.shape[0] - 1)
        i1 = np.minimum(i0 + 1, arr.shape[1] - 1)
        j1 = np.minimum(j0 + 1, arr.shape[0] - 1)
        fx, fy = cc - i0, rr - j0
        z: np.ndarray = (arr[j0, i0] * (1 - fx) * (1 - fy) + arr[j0, i1] * fx * (1 - fy)
                         + arr[j1, i0] * (1 - fx) * fy + arr[j1, i1] * fx * fy)
        bad = ~np.isfinite(z)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(
                f"terrain.dem {self.name!r} has nodata under the {what}: {int(bad.sum())} point(s), "
                f"first at planning x {x[i]:.1f}, y {y[i]:.1f}"
            )
        return z

    def range_over(self, geom_plan: BaseGeometry, what: str) -> tuple[float, float]:
        """Lowest and highest DEM cell under a polygon (planning CRS); nodata there is an error."""
        t = self.to_dem
        g = shapely.transform(geom_plan, lambda xy: np.column_stack(t.transform(xy[:, 0], xy[:, 1])))
        left, b, r, tp = g.bounds
        dl, db, dr, dt = self.grid.full_bounds
        if left < dl or r > dr or b < db or tp > dt:
            raise InputError(
                f"terrain.dem {self.name!r} does not cover the {what}: the {what} spans "
                f"x {left:.1f}..{r:.1f}, y {b:.1f}..{tp:.1f} in the DEM's CRS, the DEM "
                f"x {dl:.1f}..{dr:.1f}, y {db:.1f}..{dt:.1f}"
            )
        n_rows, n_cols = self.grid.full_shape
        win = rasterio.windows.from_bounds(left, b, r, tp, transform=self.full).round_offsets().round_lengths()
        win = rasterio.windows.Window(win.col_off, win.row_off, win.width + 1, win.height + 1).intersection(
            rasterio.windows.Window(0, 0, n_cols, n_rows))
        c0, r0 = self.grid.offset
        rs, cs = int(win.row_off) - r0, int(win.col_off) - c0
        arr = self.grid.heights[max(rs, 0): rs + int(win.height), max(cs, 0): cs + int(win.width)]
        if rs < 0 or cs < 0 or arr.shape != (int(win.height), int(win.width)):
            raise InputError(f"terrain.dem {self.name!r}: the {what} reaches beyond the part of the DEM read around it")
        inside = rasterio.features.geometry_mask([g], out_shape=arr.shape, transform=rasterio.windows.transform(win, self.full),
                                                invert=True, all_touched=True)
        vals = arr[inside]
        if not np.isfinite(vals).all():
            raise InputError(f"terrain.dem {self.name!r} has {int((~np.isfinite(vals)).sum())} nodata cell(s) under the {what}")
        if vals.size == 0:
            raise InputError(f"terrain.dem {self.name!r}: no DEM cell under the {what}")
        return float(vals.min()), float(vals.max())


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
