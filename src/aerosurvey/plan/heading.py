"""Choose the line heading that gives the shortest estimated flight time."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.plan.frame import LineFrame

#: hull edges whose directions are candidates: the longest ones (a detailed, rounded outline has
#: hundreds of hull edges a degree or less apart, each costing a layout of the whole area)
MAX_HULL_DIRECTIONS = 64


def candidate_headings(area: BaseGeometry, step_deg: float = 10.0) -> list[float]:
    """A coarse sweep plus the directions of the convex hull's edges (the narrowest width
    of a convex area is always across one of them), the MAX_HULL_DIRECTIONS longest."""
    cands = set(np.round(np.arange(0.0, 180.0, step_deg), 6).tolist())
    hull = np.asarray(shapely.convex_hull(area).exterior.coords)
    d = np.diff(hull, axis=0)
    length = np.hypot(d[:, 0], d[:, 1])
    longest = np.argsort(-length, kind="stable")[:MAX_HULL_DIRECTIONS]
    for (dx, dy), ln in zip(d[longest], length[longest]):
        if ln > 0:
            cands.add(round(float(np.degrees(np.arctan2(dx, dy)) % 180.0), 6))
    return sorted(cands)


def best_heading(area: BaseGeometry, cost: Callable[[LineFrame], float], step_deg: float = 10.0,
                 bound: Callable[[list[LineFrame]], Sequence[float]] | None = None) -> tuple[float, float]:
    """(heading, cost) of the cheapest candidate, refined by 1° steps around it; ties go to
    the smaller heading.

    With `bound` (lower bounds of `cost` for a list of frames, cheap to compute) candidates are
    costed in order of their bound, and the search stops at the first whose (bound, heading)
    exceeds the best (cost, heading) found so far: that candidate and every later one costs at
    least its bound, so none of them can be the minimum. The result is the one costing every
    candidate gives."""
    cands = candidate_headings(area, step_deg)
    if bound is None:
        def bound(frames: list[LineFrame]) -> list[float]:
            return [-math.inf] * len(frames)  # every candidate costed, in order of heading
    best_h, best_c = _bounded_min(cands, cost, bound, (math.inf, math.inf))
    known = set(cands)
    refine = []
    for delta in range(-int(step_deg // 2), int(step_deg // 2) + 1):
        h = round((best_h + delta) % 180.0, 6)
        if h not in known:
            known.add(h)
            refine.append(h)
    return _bounded_min(refine, cost, bound, (best_c, best_h))


def _bounded_min(headings: list[float], cost: Callable[[LineFrame], float],
                 bound: Callable[[list[LineFrame]], Sequence[float]], best: tuple[float, float]) -> tuple[float, float]:
    """(heading, cost) of min by (cost, heading) over `headings` and the incumbent `best`
    (cost, heading), costing candidates in order of their lower bound."""
    order = sorted(zip([float(b) for b in bound([LineFrame(h) for h in headings])], headings)) if headings else []
    best_c, best_h = best
    for lower, h in order:
        if (lower, h) > (best_c, best_h):
            break
        c = cost(LineFrame(h))
        if (c, h) < (best_c, best_h):
            best_c, best_h = c, h
    return best_h, best_c
