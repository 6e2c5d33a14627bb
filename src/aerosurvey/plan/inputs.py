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
#: the lowest and highest height of every BLOCK × BLOCK cells are kept unpacked (`DemGrid.blocks`); TILE is a multiple
BLOCK = 64


@dataclass(frozen=True, eq=False)
class DemGrid:
    """A window of a DEM, held in memory in tiles of TILE × TILE float32 cells (NaN where the DEM has no data), each
    compressed without loss (its bytes grouped by significance, then deflated): the planner unpacks the tiles it
    needs (plan/terrain.py), so a plan holds the window's cells compressed and a few tiles unpacked.

    `transform` is the affine (a, b, c, d, e, f) of the window (x = a·col + b·row + c,
    y = d·col + e·row + f, cell corners), `offset` the window's first column and row in the
    whole DEM, `full_shape` and `full_bounds` (left, bottom, right, top) the whole DEM's, so
    that messages can tell "off the DEM" from "outside the part that was read".

    `blocks` holds, unpacked, the lowest and highest height of each BLOCK × BLOCK cells of the window ((2, block rows,
    block columns), −∞ and +∞ where a block has no data): bounds of the ground that need no tile (`block_range`).
    """

    name: str  # the file name, for messages
    shape: tuple[int, int]  # (rows, cols) of the window
    tiles: Mapping[tuple[int, int], tuple[bytes, ...]]  # (tile row, tile column) → its cells, packed (`pack`)
    transform: tuple[float, float, float, float, float, float]
    crs_wkt: str
    offset: tuple[int, int]  # (col, row) of the window in the whole DEM
    full_shape: tuple[int, int]  # (rows, cols) of the whole DEM
    full_bounds: tuple[float, float, float, float]
    blocks: np.ndarray

    @classmethod
    def read_tiles(cls, name: str, shape: tuple[int, int], read: DemReader,
                   transform: tuple[float, float, float, float, float, float], crs_wkt: str, offset: tuple[int, int],
                   full_shape: tuple[int, int], full_bounds: tuple[float, float, float, float]) -> DemGrid:
        """A window of `shape` whose cells `read` gives, read and packed a tile at a time."""
        rows, cols = shape
        tiles = {}
        blocks = np.empty((2, -(-rows // BLOCK), -(-cols // BLOCK)), np.float32)
        for tj in range(-(-rows // TILE)):
            for ti in range(-(-cols // TILE)):
                cells = read(tj * TILE, ti * TILE, min(TILE, rows - tj * TILE), min(TILE, cols - ti * TILE))
                tiles[(tj, ti)] = pack(cells)
                lo, hi = _block_ranges(cells)
                j, i = tj * TILE // BLOCK, ti * TILE // BLOCK
                blocks[:, j:j + lo.shape[0], i:i + lo.shape[1]] = lo, hi
        return cls(name, shape, tiles, transform, crs_wkt, offset, full_shape, full_bounds, blocks)

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
        n = shape[0] * shape[1]
        cells = np.empty((n, 4), np.uint8)
        for k, group in enumerate(self.tiles[(tj, ti)]):  # each group of bytes back into its place in the cells
            cells[:, k] = np.frombuffer(group if len(group) == n else zlib.decompress(group), np.uint8)
        return cells.view(np.float32).reshape(shape)

    def height_range(self) -> tuple[float, float] | None:
        """The lowest and highest height in the window (None when it has no data), a tile at a time."""
        lo, hi = math.inf, -math.inf
        for tj, ti in self.tiles:
            t = self.tile(tj, ti)
            if np.isfinite(t).any():
                lo, hi = min(lo, float(np.nanmin(t))), max(hi, float(np.nanmax(t)))
        return None if lo > hi else (lo, hi)

    def block_range(self, r0: np.ndarray, r1: np.ndarray, c0: np.ndarray, c1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For each rectangle of window cells, rows r0..r1 and columns c0..c1 (integer arrays, ends included, clipped to
        the window), the lowest and highest height of the blocks it overlaps (−∞ and +∞ where one has no data)."""
        last_j, last_i = self.blocks.shape[1] - 1, self.blocks.shape[2] - 1
        bj0, bj1 = (np.clip(r, 0, self.shape[0] - 1) // BLOCK for r in (r0, r1))
        bi0, bi1 = (np.clip(c, 0, self.shape[1] - 1) // BLOCK for c in (c0, c1))
        lo = np.full(len(bj0), np.inf)
        hi = np.full(len(bj0), -np.inf)
        for dj in range(int((bj1 - bj0).max(initial=0)) + 1):  # the blocks a rectangle spans, an offset at a time
            for di in range(int((bi1 - bi0).max(initial=0)) + 1):
                j, i = np.minimum(bj0 + dj, last_j), np.minimum(bi0 + di, last_i)
                inside = (bj0 + dj <= bj1) & (bi0 + di <= bi1)
                lo = np.where(inside, np.minimum(lo, self.blocks[0, j, i]), lo)
                hi = np.where(inside, np.maximum(hi, self.blocks[1, j, i]), hi)
        return lo, hi


def _block_ranges(cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The lowest and highest height of each BLOCK × BLOCK cells of a tile (the last row and column of blocks maybe
    smaller), −∞ and +∞ for a block with a cell of no data."""
    rows, cols = cells.shape
    filled = np.pad(cells, ((0, -rows % BLOCK), (0, -cols % BLOCK)), mode="edge")  # repeats real cells: same ranges
    parts = filled.reshape(filled.shape[0] // BLOCK, BLOCK, filled.shape[1] // BLOCK, BLOCK)
    lo, hi = parts.min(axis=(1, 3)), parts.max(axis=(1, 3))  # NaN where a block has one
    return np.where(np.isnan(lo), -np.inf, lo), np.where(np.isnan(hi), np.inf, hi)


def pack(cells: np.ndarray) -> tuple[bytes, ...]:
    """float32 cells as four groups of bytes, by significance (each byte of every cell, then the next: a smooth surface's
    high bytes repeat), each deflated unless that saves under a tenth of it: then kept as it is (as long as the tile has
    cells). The lowest bytes of real heights are noise: deflating them saved ~3 % of them and took half a tile's unpacking
    (measured on a 512 × 512 tile of hills: 3.5 ms → 1.9 ms); `DemGrid.tile` unpacks them."""
    by_cell = np.ascontiguousarray(cells, np.float32).view(np.uint8).reshape(-1, 4)
    groups = []
    for k in range(4):
        raw = by_cell[:, k].tobytes()
        deflated = zlib.compress(raw, 1)
        groups.append(deflated if len(deflated) < 0.9 * len(raw) else raw)
    return tuple(groups)


@dataclass(frozen=True, eq=False)
class PlanInputs:
    """The geometry a plan is made from, in WGS84 longitude/latitude, and the terrain."""

    area_wgs84: BaseGeometry
    exclusions_wgs84: tuple[BaseGeometry, ...] = ()
    dem: DemGrid | None = None
    airspace: Airspace | None = None  # official UAS zones ([airspace]), the authorisations and the planned window
    structure_wgs84: BaseGeometry | None = None  # [structure]'s footprint, one polygon
