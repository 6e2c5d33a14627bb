"""The rules' side overlaps and GCP layout as computed before they were made faster (commit
5cd63bf), verbatim: the reference the new code must match exactly (tests/rules/test_rules_exact.py)."""

from __future__ import annotations

import math

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.rules.control_points import ControlPoint, _outline
from aerosurvey.rules.footprints import Footprints


def reference_propose_gcps(area: BaseGeometry, fp: Footprints, count: int, min_images: int, offset: float,
                 max_spacing: float, nogo: BaseGeometry | None) -> list[ControlPoint]:
    """GCPs as an envelope outside the outline, each checked against the planned photos."""
    outline = _outline(area)
    ring_geom = shapely.buffer(outline, offset, quad_segs=8)
    points: list[ControlPoint] = []
    k = 0
    for part in shapely.get_parts(ring_geom):
        ring = part.exterior
        n = max(count if k == 0 else 3, math.ceil(ring.length / max_spacing), 3)
        start = ring.project(shapely.Point(ring.bounds[0], ring.bounds[3]))
        for j in range(n):
            pos = (start + ring.length * j / n) % ring.length
            p = ring.interpolate(pos)
            near = shapely.get_point(shapely.shortest_line(outline.boundary, p), 0)
            k += 1
            points.append(reference_settle(f"GCP{k:02d}", p, near, outline, fp, min_images, nogo))
    return points


def reference_settle(pid: str, p: shapely.Point, near: shapely.Point, outline: BaseGeometry, fp: Footprints,
            min_images: int, nogo: BaseGeometry | None) -> ControlPoint:
    """Move a GCP along its normal towards the outline until enough photos see it."""
    dx, dy = p.x - near.x, p.y - near.y
    dist = math.hypot(dx, dy)
    best: tuple[float, float, int, float] | None = None
    for frac in np.linspace(1.0, 0.0, 21)[:-1]:
        x, y = near.x + dx * frac, near.y + dy * frac
        if shapely.contains_xy(outline, x, y) or (nogo is not None and shapely.contains_xy(nogo, x, y)):
            continue
        n = int(fp.count_at(np.array([x]), np.array([y]))[0])
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
