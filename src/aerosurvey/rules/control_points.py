"""Ground control and check point layout for the field crew (pure geometry).

GCPs: evenly spaced on a ring `offset` metres outside the area's outline (an envelope
around the boundary); a GCP seen by too few planned photos is moved towards the outline,
still outside it, until enough photos see it; if none does, it stays and is reported.
Check points: a hexagonal grid inside the area at the wanted density, kept away from the
edge and from the GCPs, densified until the count is reached.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.rules.footprints import BoolArray, FloatArray, Footprints, IntArray

#: A ground control point (used in the adjustment) or a check point (kept out of it).
Role = Literal["gcp", "check"]


@dataclass(frozen=True)
class ControlPoint:
    """A proposed ground control or check point in the planning CRS, with the number of photos that see it."""

    id: str
    role: Role
    x: float
    y: float
    images: int
    note: str = ""


def _outline(area: BaseGeometry) -> BaseGeometry:
    return shapely.union_all([shapely.Polygon(p.exterior) for p in shapely.get_parts(area)])


#: Where a GCP may go along its normal: the envelope (1) to 1/20 of the way from the outline
_FRACS = np.linspace(1.0, 0.0, 21)[:-1]


def propose_gcps(area: BaseGeometry, fp: Footprints, count: int, min_images: int, offset: float,
                 max_spacing: float, nogo: BaseGeometry | None) -> list[ControlPoint]:
    """GCPs as an envelope outside the outline, each checked against the planned photos."""
    outline = _outline(area)
    boundary = outline.boundary
    ring_geom = shapely.buffer(outline, offset, quad_segs=8)
    places: list[tuple[str, shapely.Point, shapely.Point]] = []  # (id, on the envelope, nearest on the outline)
    for part in shapely.get_parts(ring_geom):
        ring = part.exterior
        n = max(count if not places else 3, math.ceil(ring.length / max_spacing), 3)
        start = ring.project(shapely.Point(ring.bounds[0], ring.bounds[3]))
        for j in range(n):
            pos = (start + ring.length * j / n) % ring.length
            p = ring.interpolate(pos)
            places.append((f"GCP{len(places) + 1:02d}", p, shapely.get_point(shapely.shortest_line(boundary, p), 0)))
    if not places:
        return []
    # every GCP's candidate places along its normal, from the envelope in (the floats one at a time gives)
    near_x, near_y = np.array([q.x for _, _, q in places]), np.array([q.y for _, _, q in places])
    dx, dy = np.array([p.x - q.x for _, p, q in places]), np.array([p.y - q.y for _, p, q in places])
    xs, ys = near_x[:, None] + dx[:, None] * _FRACS, near_y[:, None] + dy[:, None] * _FRACS
    blocked = shapely.contains_xy(outline, xs, ys)
    if nogo is not None:
        blocked |= shapely.contains_xy(nogo, xs, ys)
    # photos seeing each GCP's first free place, counted for all at once (a point's count is its own:
    # the same as one at a time), then for the other places of those that too few photos see
    counts = np.full(xs.shape, -1)
    free = ~blocked
    rows = np.flatnonzero(free.any(axis=1))
    first = free[rows].argmax(axis=1)
    counts[rows, first] = fp.count_at(xs[rows, first], ys[rows, first])
    short = counts[rows, first] < min_images
    rest = free[rows[short]]
    rest[np.arange(len(rest)), first[short]] = False
    r, c = np.nonzero(rest)
    if len(r):
        counts[rows[short][r], c] = fp.count_at(xs[rows[short][r], c], ys[rows[short][r], c])
    return [_settle(pid, p, near, xs[i], ys[i], blocked[i], counts[i], min_images) for i, (pid, p, near) in enumerate(places)]


def _settle(pid: str, p: shapely.Point, near: shapely.Point, xs: FloatArray, ys: FloatArray, blocked: BoolArray,
            counts: IntArray, min_images: int) -> ControlPoint:
    """The first place along the GCP's normal, from the envelope towards the outline, that enough
    photos see (places inside the outline or a no-go zone skipped; `counts`: photos at each place)."""
    dist = math.hypot(p.x - near.x, p.y - near.y)
    best: tuple[float, float, int, float] | None = None
    for k, frac in enumerate(_FRACS):
        if blocked[k]:
            continue
        x, y, n = xs[k], ys[k], int(counts[k])
        if best is None or n > best[2]:
            best = (float(x), float(y), n, float(frac))
        if n >= min_images:
            note = "" if frac == 1.0 else f"moved to {dist * frac:.1f} m outside the outline to be seen by {n} photos"
            return ControlPoint(pid, "gcp", float(x), float(y), n, note)
    if best is None:
        return ControlPoint(pid, "gcp", float(p.x), float(p.y), 0, "no place outside the outline and the no-go zones")
    return ControlPoint(pid, "gcp", best[0], best[1], best[2],
                        f"seen by only {best[2]} photos even at {dist * best[3]:.1f} m from the outline: extend the plan "
                        f"(set targets.coverage_margin_m to at least {dist + 2:.0f} m) or place this GCP by hand")


def seen_by(fp: Footprints, points: list[ControlPoint]) -> list[ControlPoint]:
    """The points where they are, each with the number of the footprints (a view's photos) that see it."""
    if not points:
        return []
    counts = fp.count_at(np.array([p.x for p in points], float), np.array([p.y for p in points], float))
    return [dataclasses.replace(p, images=int(n)) for p, n in zip(points, counts)]


def ring_order(points: list[ControlPoint], area: BaseGeometry) -> list[ControlPoint]:
    """GCPs in order around the outline (for the envelope polygon)."""
    ring = _outline(area).convex_hull.exterior
    return sorted(points, key=lambda g: ring.project(shapely.Point(g.x, g.y)))


def hex_grid(geom: BaseGeometry, spacing: float) -> FloatArray:
    """(n, 2) points of a hexagonal grid with `spacing` between neighbours, inside `geom` (none in an empty one)."""
    if geom.is_empty:
        return np.empty((0, 2))
    x0, y0, x1, y1 = geom.bounds
    dy = spacing * math.sqrt(3) / 2
    rows = np.arange(y0 + dy / 2, y1, dy)
    pts: list[tuple[float, float]] = []
    for i, y in enumerate(rows):
        off = spacing / 2 if i % 2 else 0.0
        xs = np.arange(x0 + spacing / 4 + off, x1, spacing)
        pts.extend((float(x), float(y)) for x in xs)
    if not pts:
        return np.empty((0, 2))
    a = np.asarray(pts, float)
    inside: FloatArray = a[shapely.contains_xy(geom, a[:, 0], a[:, 1])]
    return inside


def propose_check_points(area: BaseGeometry, fp: Footprints, ha_per_point: float, minimum: int,
                         edge_margin: float, gcps: list[ControlPoint], gcp_clearance: float,
                         nogo: BaseGeometry | None) -> list[ControlPoint]:
    """Check points on a hexagonal grid: at least area / ha_per_point and `minimum`."""
    need = max(minimum, math.ceil(area.area / (ha_per_point * 1e4) - 1e-9), 1)
    usable = shapely.buffer(area, -edge_margin)
    if usable.is_empty or usable.area < 0.2 * area.area:
        usable = area
    if gcps:
        usable = shapely.difference(usable, shapely.buffer(shapely.MultiPoint([(g.x, g.y) for g in gcps]), gcp_clearance))
    if nogo is not None:
        usable = shapely.difference(usable, nogo)
    # hexagon cell area = sqrt(3)/2 * s^2 per point
    spacing = math.sqrt(area.area / need / (math.sqrt(3) / 2))
    pts = hex_grid(usable, spacing)
    for _ in range(200):
        if len(pts) >= need:
            break
        spacing *= 0.97
        pts = hex_grid(usable, spacing)
    if len(pts) == 0:
        return []
    counts = fp.count_at(pts[:, 0], pts[:, 1])
    return [ControlPoint(f"CP{i + 1:03d}", "check", float(x), float(y), int(c)) for i, ((x, y), c) in enumerate(zip(pts, counts))]
