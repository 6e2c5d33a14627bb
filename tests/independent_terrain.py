"""An independent DEM for terrain tests: GeoTIFFs written from the test's own array, and that
array's heights read back the way the planner documents its DEM sampling (plan/terrain.py):
cell values at cell centres, bilinear between the four nearest. Shares no code with the planner."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import rasterio
from rasterio.transform import from_origin


class TestDem:
    """A north-up grid: `heights[row, col]` at x = west + (col + 0.5)·cell, y = north − (row + 0.5)·cell."""

    __test__ = False  # not a test class

    def __init__(self, heights: np.ndarray, west: float, north: float, cell: float, epsg: int = 32633):
        self.heights = np.asarray(heights, np.float64)
        self.west, self.north, self.cell, self.epsg = west, north, cell, epsg

    def write(self, path: Path) -> Path:
        rows, cols = self.heights.shape
        with rasterio.open(path, "w", driver="GTiff", width=cols, height=rows, count=1, dtype="float32",
                           crs=f"EPSG:{self.epsg}", transform=from_origin(self.west, self.north, self.cell, self.cell),
                           nodata=-9999.0) as ds:
            ds.write(self.heights.astype(np.float32), 1)
        return path

    def cell_of(self, x: float, y: float) -> tuple[int, int]:
        """(row, col) of the cell whose centre is nearest."""
        return int(round((self.north - y) / self.cell - 0.5)), int(round((x - self.west) / self.cell - 0.5))

    def centre(self, row: int, col: int) -> tuple[float, float]:
        return self.west + (col + 0.5) * self.cell, self.north - (row + 0.5) * self.cell

    def ground(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        h = self.heights.astype(np.float32).astype(np.float64)  # as the file holds them
        u = (np.asarray(x, float) - self.west) / self.cell - 0.5
        v = (self.north - np.asarray(y, float)) / self.cell - 0.5
        i = np.clip(np.floor(u).astype(int), 0, h.shape[1] - 2)
        j = np.clip(np.floor(v).astype(int), 0, h.shape[0] - 2)
        fu, fv = u - i, v - j
        out: np.ndarray = (h[j, i] * (1 - fu) * (1 - fv) + h[j, i + 1] * fu * (1 - fv)
                           + h[j + 1, i] * (1 - fu) * fv + h[j + 1, i + 1] * fu * fv)
        return out

    def lowest_on(self, path: np.ndarray, heights: np.ndarray, step: float = 0.001) -> float:
        """The lowest height above this ground along a polyline (x, y) whose heights (above the DEM's datum) run
        straight with the distance along it, sampled every `step` metres."""
        seg = np.hypot(*np.diff(path, axis=0).T)
        cum = np.r_[0.0, np.cumsum(seg)]
        s = np.linspace(0.0, cum[-1], max(2, int(cum[-1] / step) + 1))
        x, y, z = np.interp(s, cum, path[:, 0]), np.interp(s, cum, path[:, 1]), np.interp(s, cum, heights)
        return float((z - self.ground(x, y)).min())
