"""Lines along the zones' margins: where the layout's lines, cut short before a zone, leave
required ground next to it seen by fewer than two photos, one more line is flown along each
edge of the zone's margin that borders such ground, its strip reaching from the margin outwards.

A step after the coverage check: it returns extra passes (one line each) for the route to fly;
what they cannot reach (corners, ground farther out than a strip) stays in the coverage shortfall.
"""

from __future__ import annotations

import math

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.plan.frame import LineFrame
from aerosurvey.plan.lines import StripGeometry, band_intervals, cut_by_zones, segments_for_line
from aerosurvey.plan.passes import Pass
from aerosurvey.plan.pattern import strip_geometry
from aerosurvey.plan.sensor import SensorSolution
from aerosurvey.plan.site import Site


def edge_passes(site: Site, sensor: SensorSolution, uncovered: BaseGeometry, first_index: int) -> tuple[Pass, ...]:
    """One pass per edge of a zone's (simplified) margin that borders unphotographed ground."""
    if site.zones_buffered is None or uncovered.is_empty:
        return ()
    k = site.grid_scale
    g = strip_geometry(sensor, 0, k, k)
    tol = g.across / 8.0
    # the margin's outline, simplified to edges of about a footprint (the line keeps `tol` more away)
    outline = shapely.simplify(site.zones_buffered, tol, preserve_topology=True)
    target = shapely.buffer(uncovered, 1.0 * k, quad_segs=2)
    passes: list[Pass] = []
    index = first_index
    for poly in shapely.get_parts(outline):
        if poly.is_empty or poly.geom_type != "Polygon":
            continue
        ring = np.asarray(poly.exterior.coords)
        for p0, p1 in zip(ring[:-1], ring[1:]):
            d = p1 - p0
            if math.hypot(*d) < g.base:
                continue
            heading = math.degrees(math.atan2(d[0], d[1])) % 180.0
            fr = LineFrame(heading)
            (u0, u1), (v0, _) = fr.to_frame(np.array([p0[0], p1[0]]), np.array([p0[1], p1[1]]))
            seg = _edge_line(fr, site.zones_buffered, target, float(min(u0, u1)), float(max(u0, u1)), float(v0),
                             g.across / 2.0 + tol, strip_geometry(sensor, 0, k, site.autopilot_scale(heading)), index)
            if seg is not None:
                passes.append(seg)
                index += 1
    return tuple(passes)


def _edge_line(fr: LineFrame, zones: BaseGeometry, target: BaseGeometry, u0: float, u1: float, v_edge: float,
               offset: float, g: StripGeometry, index: int) -> Pass | None:
    zones_f = fr.geom_to_frame(zones)
    for side in (1.0, -1.0):
        v = v_edge + side * offset
        mx, my = fr.from_frame(np.array([(u0 + u1) / 2.0]), np.array([v]))
        if shapely.intersects(zones, shapely.Point(float(mx[0]), float(my[0]))):
            continue  # that side is the zone's
        # only the stretch of this edge whose strip holds unphotographed ground
        window = shapely.box(u0 - g.along, v - g.across / 2.0, u1 + g.along, v + g.across / 2.0)
        want = shapely.intersection(fr.geom_to_frame(target), window)
        if want.is_empty:
            return None
        intervals = band_intervals(want, np.array([v - g.across / 2.0]), np.array([v + g.across / 2.0]))[0]
        if not intervals:
            return None
        segs = segments_for_line(0, v, intervals, g.along, g.base, g.fwd_per_point, 0, merge_gap=g.along)
        segs = cut_by_zones(segs, zones_f, g.clearance)
        return Pass(index, fr, tuple(segs)) if segs else None
    return None
