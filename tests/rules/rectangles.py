"""Rectangular footprints of given sizes for the rules' tests, made here (not by the capture model)."""

from __future__ import annotations

import numpy as np

from aerosurvey.rules.footprints import Footprints


def rect_footprints(x, y, heading_rad, across, along) -> Footprints:
    """Footprints centred at x, y, `along` long in the compass direction heading_rad and `across`
    wide, corners in the order the rules' Footprints keep (image top-right, top-left, bottom-left,
    bottom-right; the image's top ahead)."""
    x, y, h, w, ln = (np.asarray(a, float) for a in (x, y, heading_rad, across, along))
    fwd = np.stack([np.sin(h), np.cos(h)], axis=-1)
    right = np.stack([np.cos(h), -np.sin(h)], axis=-1)
    centre = np.stack([x, y], axis=-1)
    signs = [(1, 1), (-1, 1), (-1, -1), (1, -1)]  # (right, ahead)
    corners = np.stack([centre + r * right * w[:, None] / 2 + a * fwd * ln[:, None] / 2 for r, a in signs], axis=1)
    return Footprints(np.arange(len(x)), x, y, h, corners)
