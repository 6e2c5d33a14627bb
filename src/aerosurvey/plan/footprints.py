"""Photo footprints on the ground as polygons: one formula for every consumer (the plan's
coverage check, the GeoJSON layer, flown coverage)."""

from __future__ import annotations

import numpy as np


def footprint_corners(x: np.ndarray, y: np.ndarray, heading_deg: np.ndarray, across: np.ndarray, along: np.ndarray) -> np.ndarray:
    """(n, 4, 2) corners of nadir footprints centred at x, y, long axis `along` the heading."""
    h = np.radians(heading_deg)
    ux, uy = np.sin(h), np.cos(h)  # along track
    vx, vy = uy, -ux  # across track (to the right)
    a2, c2 = along[:, None] / 2.0, across[:, None] / 2.0
    su = np.array([1, 1, -1, -1])[None, :]
    sv = np.array([1, -1, -1, 1])[None, :]
    cx = x[:, None] + su * a2 * ux[:, None] + sv * c2 * vx[:, None]
    cy = y[:, None] + su * a2 * uy[:, None] + sv * c2 * vy[:, None]
    corners: np.ndarray = np.stack([cx, cy], axis=-1)
    return corners
