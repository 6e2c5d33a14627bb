"""Choose the line heading that gives the shortest estimated flight time."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.plan.frame import LineFrame


def candidate_headings(area: BaseGeometry, step_deg: float = 10.0) -> list[float]:
    """A coarse sweep plus the directions of the convex hull's edges (the narrowest width
    of a convex area is always across one of them)."""
    cands = set(np.round(np.arange(0.0, 180.0, step_deg), 6).tolist())
    hull = np.asarray(shapely.convex_hull(area).exterior.coords)
    d = np.diff(hull, axis=0)
    length = np.hypot(d[:, 0], d[:, 1])
    for (dx, dy), ln in zip(d, length):
        if ln > 0:
            cands.add(round(float(np.degrees(np.arctan2(dx, dy)) % 180.0), 6))
    return sorted(cands)


def best_heading(area: BaseGeometry, cost: Callable[[LineFrame], float], step_deg: float = 10.0) -> tuple[float, float]:
    """(heading, cost) of the cheapest candidate, refined by 1° steps around it."""
    scores = {h: cost(LineFrame(h)) for h in candidate_headings(area, step_deg)}
    best = min(scores, key=lambda h: (scores[h], h))
    for delta in range(-int(step_deg // 2), int(step_deg // 2) + 1):
        h = round((best + delta) % 180.0, 6)
        if h not in scores:
            scores[h] = cost(LineFrame(h))
    best = min(scores, key=lambda h: (scores[h], h))
    return best, scores[best]
