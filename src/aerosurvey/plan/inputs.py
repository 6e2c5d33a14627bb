"""What planning reads from files, as plain data: the loader (`aerosurvey.inputs`) makes it,
`plan_mission` takes it and touches no file.

A web page, a test or a plug-in that has its geometry in memory builds `PlanInputs` itself.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from shapely.geometry.base import BaseGeometry

if TYPE_CHECKING:
    from aerosurvey.airspace.model import Airspace


#: reads cells of a DEM window: (row, col, rows, cols) within the window → float32 heights, NaN where the DEM has no data
DemReader = Callable[[int, int, int, int], np.ndarray]


@dataclass(frozen=True, eq=False)
class DemGrid:
    """A window of a DEM: its grid, and how to read its cells. The loader's `read` makes windowed reads of the file
    (`aerosurvey.inputs.read_dem_window`), `DemGrid.of_array` reads an array in memory; the planner reads the cells
    it needs a tile at a time (plan/terrain.py), so a plan holds a bounded cache of tiles, not the window.

    `transform` is the affine (a, b, c, d, e, f) of the window (x = a·col + b·row + c,
    y = d·col + e·row + f, cell corners), `offset` the window's first column and row in the
    whole DEM, `full_shape` and `full_bounds` (left, bottom, right, top) the whole DEM's, so
    that messages can tell "off the DEM" from "outside the part that was read".
    """

    name: str  # the file name, for messages
    shape: tuple[int, int]  # (rows, cols) of the window
    read: DemReader
    transform: tuple[float, float, float, float, float, float]
    crs_wkt: str
    offset: tuple[int, int]  # (col, row) of the window in the whole DEM
    full_shape: tuple[int, int]  # (rows, cols) of the whole DEM
    full_bounds: tuple[float, float, float, float]

    @classmethod
    def of_array(cls, name: str, heights: np.ndarray, transform: tuple[float, float, float, float, float, float],
                 crs_wkt: str, offset: tuple[int, int], full_shape: tuple[int, int],
                 full_bounds: tuple[float, float, float, float]) -> DemGrid:
        """A window whose heights (rows, cols; NaN for no data) are in memory."""
        heights = np.asarray(heights, np.float32)

        def read(row: int, col: int, rows: int, cols: int) -> np.ndarray:
            return heights[row:row + rows, col:col + cols]

        return cls(name, (int(heights.shape[0]), int(heights.shape[1])), read, transform, crs_wkt, offset, full_shape,
                   full_bounds)

    def height_range(self, band_rows: int = 256) -> tuple[float, float] | None:
        """The lowest and highest height in the window (None when it has no data), read a band of rows at a time."""
        lo, hi = math.inf, -math.inf
        rows, cols = self.shape
        for r in range(0, rows, band_rows):
            band = self.read(r, 0, min(band_rows, rows - r), cols)
            if np.isfinite(band).any():
                lo, hi = min(lo, float(np.nanmin(band))), max(hi, float(np.nanmax(band)))
        return None if lo > hi else (lo, hi)


@dataclass(frozen=True, eq=False)
class PlanInputs:
    """The geometry a plan is made from, in WGS84 longitude/latitude, and the terrain."""

    area_wgs84: BaseGeometry
    exclusions_wgs84: tuple[BaseGeometry, ...] = ()
    dem: DemGrid | None = None
    airspace: Airspace | None = None  # official UAS zones ([airspace]), the authorisations and the planned window
