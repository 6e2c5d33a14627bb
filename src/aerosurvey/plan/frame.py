"""A frame rotated so that flight lines of a given heading run along +x.

Heading is a compass bearing of the lines (0 = grid north, 90 = grid east), so the line
direction in the planning CRS is (sin h, cos h).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry


@dataclass(frozen=True)
class LineFrame:
    heading_deg: float

    @property
    def _cs(self) -> tuple[float, float]:
        h = math.radians(self.heading_deg)
        return math.sin(h), math.cos(h)  # unit vector along the lines

    def to_frame(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ux, uy = self._cs
        return x * ux + y * uy, -x * uy + y * ux

    def from_frame(self, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ux, uy = self._cs
        return u * ux - v * uy, u * uy + v * ux

    def geom_to_frame(self, geom: BaseGeometry) -> BaseGeometry:
        return shapely.transform(geom, lambda xy: np.column_stack(self.to_frame(xy[:, 0], xy[:, 1])))

    def geom_from_frame(self, geom: BaseGeometry) -> BaseGeometry:
        return shapely.transform(geom, lambda xy: np.column_stack(self.from_frame(xy[:, 0], xy[:, 1])))


def to_frames(frames: list[LineFrame], x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`to_frame` of the points in every frame, (frames, points) arrays: the same operations,
    element by element (each frame's sine and cosine broadcast along its row)."""
    cs = np.array([fr._cs for fr in frames], float).reshape(-1, 2)
    ux, uy = cs[:, :1], cs[:, 1:]
    return x * ux + y * uy, -x * uy + y * ux
