"""What planning reads from files, as plain data: the loader (`aerosurvey.inputs`) makes it,
`plan_mission` takes it and touches no file.

A web page, a test or a plug-in that has its geometry in memory builds `PlanInputs` itself.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from shapely.geometry.base import BaseGeometry

if TYPE_CHECKING:
    from aerosurvey.airspace.model import Airspace


#: reads cells of a DEM window: (row, col, rows, cols) within the window → float32 heights, NaN where the DEM has no data
DemReader = Callable[[int, int, int, int], np.ndarray]
#: a DEM window is held in tiles of TILE × TILE cells
TILE = 512


@dataclass(frozen=True, eq=False)
class DemGrid:
    """A window of a DEM, held in memory in tiles of TILE × TILE float32 cells (NaN where the DEM has no data), each
    compressed without loss (its bytes shuffled by significance, then deflated): the planner unpacks the tiles it
    needs (plan/terrain.py), so a plan holds the window's cells compressed and a few tiles unpacked.

    `transform` is the affine (a, b, c, d, e, f) of the window (x = a·col + b·row + c,
    y = d·col + e·row + f, cell corners), `offset` the window's first column and row in the
    whole DEM, `full_shape` and `full_bounds` (left, bottom, right, top) the whole DEM's, so
    that messages can tell "off the DEM" from "outside the part that was read".
    """

    name: str  # the file name, for messages
    shape: tuple[int, int]  # (rows, cols) of the window
    tiles: Mapping[tuple[int, int], bytes]  # (tile row, tile column) → its cells, packed (`pack`)
    transform: tuple[float, float, float, float, float, float]
    crs_wkt: str
    offset: tuple[int, int]  # (col, row) of the window in the whole DEM
    full_shape: tuple[int, int]  # (rows, cols) of the whole DEM
    full_bounds: tuple[float, float, float, float]

    @classmethod
    def read_tiles(cls, name: str, shape: tuple[int, int], read: DemReader,
                   transform: tuple[float, float, float, float, float, float], crs_wkt: str, offset: tuple[int, int],
                   full_shape: tuple[int, int], full_bounds: tuple[float, float, float, float]) -> DemGrid:
        """A window of `shape` whose cells `read` gives, read and packed a tile at a time."""
        rows, cols = shape
        tiles = {(tj, ti): pack(read(tj * TILE, ti * TILE, min(TILE, rows - tj * TILE), min(TILE, cols - ti * TILE)))
                 for tj in range(-(-rows // TILE)) for ti in range(-(-cols // TILE))}
        return cls(name, shape, tiles, transform, crs_wkt, offset, full_shape, full_bounds)

    @classmethod
    def of_array(cls, name: str, heights: np.ndarray, transform: tuple[float, float, float, float, float, float],
                 crs_wkt: str, offset: tuple[int, int], full_shape: tuple[int, int],
                 full_bounds: tuple[float, float, float, float]) -> DemGrid:
        """A window whose heights (rows, cols; NaN for no data) are in memory."""
        heights = np.asarray(heights, np.float32)

        def read(row: int, col: int, rows: int, cols: int) -> np.ndarray:
            return heights[row:row + rows, col:col + cols]

        return cls.read_tiles(name, (int(heights.shape[0]), int(heights.shape[1])), read, transform, crs_wkt, offset,
                              full_shape, full_bounds)

    def tile(self, tj: int, ti: int) -> np.ndarray:
        """Tile (row tj, column ti) unpacked: (up to TILE, up to TILE) float32."""
        rows, cols = self.shape
        shape = (min(TILE, rows - tj * TILE), min(TILE, cols - ti * TILE))
        planes = np.frombuffer(zlib.decompress(self.tiles[(tj, ti)]), np.uint8).reshape(4, -1)
        return np.ascontiguousarray(planes.T).view(np.float32).reshape(shape)

    def height_range(self) -> tuple[float, float] | None:
        """The lowest and highest height in the window (None when it has no data), a tile at a time."""
        lo, hi = math.inf, -math.inf
        for tj, ti in self.tiles:
            t = self.tile(tj, ti)
            if np.isfinite(t).any():
                lo, hi = min(lo, float(np.nanmin(t))), max(hi, float(np.nanmax(t)))
        return None if lo > hi else (lo, hi)


def pack(cells: np.ndarray) -> bytes:
    """float32 cells, their bytes grouped by significance (each byte of every cell, then the next: a smooth surface's
    high bytes repeat) and deflated; `DemGrid.tile` unpacks them."""
    planes = np.ascontiguousarray(cells, np.float32).view(np.uint8).reshape(-1, 4).T
    return zlib.compress(np.ascontiguousarray(planes).tobytes(), 1)


@dataclass(frozen=True, eq=False)
class PlanInputs:
    """The geometry a plan is made from, in WGS84 longitude/latitude, and the terrain."""

    area_wgs84: BaseGeometry
    exclusions_wgs84: tuple[BaseGeometry, ...] = ()
    dem: DemGrid | None = None
    airspace: Airspace | None = None  # official UAS zones ([airspace]), the authorisations and the planned window
    structure_wgs84: BaseGeometry | None = None  # [structure]'s footprint, one polygon
