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


def narrowest(geom: BaseGeometry) -> tuple[float, float]:
    """(minimum width, the heading along which it is measured across): the compass direction
    (degrees, 0-180, x east and y north) of the convex hull's edge the width is smallest
    across, the heading of lines that need fewest strips."""
    hull = shapely.convex_hull(geom)
    if hull.geom_type != "Polygon":
        return 0.0, 0.0  # a point or a segment: no width
    xy = np.asarray(hull.exterior.coords)
    d = np.diff(xy, axis=0)
    length = np.hypot(d[:, 0], d[:, 1])
    keep = length > 0
    normal = np.column_stack([-d[keep, 1], d[keep, 0]]) / length[keep, None]
    proj = xy @ normal.T  # every vertex on every edge's normal
    width = proj.max(axis=0) - proj.min(axis=0)
    i = int(np.argmin(width))
    dx, dy = d[keep][i]
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
