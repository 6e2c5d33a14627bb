"""Lower bounds of an area grid: the fewest strips and photos any plan of parallel strips at
the plan's spacing and photo base can fly for the same guarantee, so every plan shows how far
it is from the floor.

- Strips: the area's minimum width W (rotating calipers over its convex hull's edges: the
  narrowest width of a convex set is across one of them) and the side rule, every point in
  k = `side_images_per_point` strips of width A, at the outer edges too. Lines at spacing S
  covering an ordinate range W that way number at least ⌈(W − A)/S⌉ + 2k − 1 (the k-th line
  from each end must still reach its edge), and at least k; a width under A takes k lines
  (closer than S, so that all k strips hold it) unless they would lie within 1 % of S of one
  another (the same photos twice: `lines.strip_count`, the planner's own count). No heading gives a smaller range
  than W, so for a convex area no parallel-line plan at spacing S has fewer strips; a
  concave area may need fewer where whole lines fall in a notch.
- Photos: the area over base × spacing (each photo accounts for at most one base × spacing
  cell of new ground), a floor that ignores the forward rule's photos beyond the ends.

Both are per pass, times the passes (a cross-hatch flies two). A corridor's strips follow its
centreline: its strip bound is the same count across its width (left + right), not across the
minimum width of its outline (a bent corridor's outline is wide).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.plan.lines import strip_count


@dataclass(frozen=True)
class GridBounds:
    min_width_m: float  # the area's minimum width (ground metres)
    strips: int
    photos: int


def minimum_width(geom: BaseGeometry) -> float:
    """The smallest distance between two parallel lines enclosing `geom` (rotating calipers:
    the width across each edge of its convex hull, the smallest of them)."""
    return narrowest(geom)[0]


def _hull_ring(geom: BaseGeometry) -> np.ndarray:
    """The convex hull's vertices anticlockwise, each once, every turn a left one ((n, 2); n < 3: no area).

    GEOS's hull is the start: on slivers it can keep a vertex the hull turns right at (seen on 3 % of random ellipses
    flattened 10⁴:1 to 1:1, measured against Qhull); a monotone chain over its vertices drops those. Qhull itself (scipy)
    would add 0.2 s of import to every plan."""
    hull = shapely.convex_hull(geom)
    if hull.geom_type != "Polygon":
        return np.empty((0, 2))  # a point or a segment: no width
    # each vertex once, sorted by x, then y (not np.unique(axis=0): it imports numpy.ma, 12-17 ms of every plan)
    pts = [list(p) for p in sorted(set(map(tuple, shapely.get_coordinates(hull).tolist())))]

    def chain(points: list[list[float]]) -> list[list[float]]:
        out: list[list[float]] = []
        for p in points:
            while len(out) >= 2 and ((out[-1][0] - out[-2][0]) * (p[1] - out[-2][1])
                                     - (out[-1][1] - out[-2][1]) * (p[0] - out[-2][0])) <= 0:
                out.pop()
            out.append(p)
        return out

    lower, upper = chain(pts), chain(pts[::-1])
    return np.asarray(lower[:-1] + upper[:-1])


def narrowest(geom: BaseGeometry) -> tuple[float, float]:
    """(minimum width, the heading along which it is measured across): the compass direction
    (degrees, 0-180, x east and y north) of the convex hull's edge the width is smallest
    across, the heading of lines that need fewest strips.

    Rotating calipers: the width across an edge is the distance to the hull's vertex farthest from
    it, the one where the hull's boundary turns to run opposite the edge; the edges' directions
    rise round the hull, so each edge finds that vertex by a binary search of them (time n log n,
    memory n: a round area's hull has many thousand vertices)."""
    xy = _hull_ring(geom)
    if len(xy) < 3:
        return 0.0, 0.0
    d = np.roll(xy, -1, axis=0) - xy  # edge k: from vertex k to k + 1
    n = len(d)
    nxt = np.roll(d, -1, axis=0)
    turn = np.arctan2(d[:, 0] * nxt[:, 1] - d[:, 1] * nxt[:, 0], (d * nxt).sum(axis=1))  # left, in (0, π)
    turned = np.arctan2(d[0, 1], d[0, 0]) + np.r_[0.0, np.cumsum(turn[:-1])]  # each edge's direction, rising by 2π
    # the first edge at or past the opposite direction starts at the farthest vertex; its neighbours too (rounding)
    far = np.searchsorted(np.concatenate([turned, turned + 2 * np.pi, turned + 4 * np.pi]), turned + np.pi) % n
    length = np.hypot(d[:, 0], d[:, 1])
    width = np.zeros(n)
    for step in (-1, 0, 1):
        v = xy[(far + step) % n] - xy
        width = np.maximum(width, (d[:, 0] * v[:, 1] - d[:, 1] * v[:, 0]) / length)  # to the edge's left: inside
    i = int(np.argmin(width))
    dx, dy = d[i]
    return float(width[i]), float(np.degrees(np.arctan2(dx, dy)) % 180.0)


def grid_bounds(area: BaseGeometry, grid_scale: float, across_m: float, spacing_m: float, base_m: float,
                side_per_point: int, passes: int, width_m: float | None = None, one_strip_when_narrow: bool = False) -> GridBounds:
    """The strip and photo bounds of `area` (planning-grid coordinates, `grid_scale` grid metres
    per ground metre) for strips of width `across_m` at `spacing_m`, photos every `base_m`.
    `width_m`: the width the strips run along instead (a corridor's, its strips following its
    centreline); None: the area's minimum width. `one_strip_when_narrow`: the pattern's guarantee
    for ground narrower than a footprint is one strip down its middle (a corridor's), not
    `side_per_point` strips: then one strip, and each photo sees at most base × footprint of new ground."""
    width = minimum_width(area) / grid_scale if width_m is None else width_m
    k = side_per_point
    ground = area.area / grid_scale**2
    if one_strip_when_narrow and width < across_m:
        return GridBounds(width, passes, passes * math.ceil(ground / (base_m * across_m) - 1e-9))
    strips = strip_count(width, across_m, spacing_m, k)
    photos = math.ceil(ground / (base_m * spacing_m) - 1e-9)
    return GridBounds(width, passes * strips, passes * photos)


def covered(area: BaseGeometry, margin_m: float, grid_scale: float) -> BaseGeometry:
    """The ground the photos must see: the area (planning CRS) grown by the coverage margin (ground metres)."""
    margin = margin_m * grid_scale
    return shapely.buffer(area, margin, quad_segs=4) if margin > 0 else area


__all__ = ["GridBounds", "covered", "grid_bounds", "minimum_width", "narrowest"]
