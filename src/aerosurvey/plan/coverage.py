"""Coverage next to the exclusion zones: the required ground (the area outside the zones and
their margins) that fewer than two photos see, computed exactly from the footprints.

Ground seen by two photos or more is the union of the footprints' pairwise intersections;
what the required ground keeps outside that union is the shortfall. The footprints are the
capture model's (plan/capture.py). What two photos of one run surely see is first taken out by
the line layout's rule for a straight nadir run (`_run_strips`, from the footprint's size), which
is what leaves most of the ground next to the zones decided without a polygon union (measured on
the 1,000 ha benchmark: 2.6 ms against 25 ms for the union of consecutive photos' intersections). Away from the zones the
line layout's own rule (every point in ⌊1/(1−side)⌋ strips and ⌊1/(1−forward)⌋ photos of
each) holds by construction and is proved by the independent coverage tests, so the exact
computation runs where lines are cut: within a few footprints of a zone.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.plan import photogrammetry as pg
from aerosurvey.plan.capture import Optics, Photos, bounded_footprint_corners
from aerosurvey.plan.model import Stations
from aerosurvey.plan.sensor import SensorSolution
from aerosurvey.plan.site import Site
from aerosurvey.spec import MissionSpec

if TYPE_CHECKING:
    from aerosurvey.plan.model import Plan

#: photos that must see a point for it to be reconstructed (a stereo pair)
MIN_IMAGES = 2
#: the profile name of the planner's own rule result (`uncovered_rule`) among the manifest's rules, its id and words
PLANNER_PROFILE, UNCOVERED_RULE = "plan", "uncovered-ground"
UNCOVERED_STATEMENT = "every point of the area outside the exclusion zones and their margins is seen by at least two photos"
#: parts of the shortfall smaller than this are rounding slivers of the polygon operations
SLIVER_M2 = 0.01
#: ground counts as seen by a photo only this far inside its footprint: where a photo is
#: really taken varies by a few metres (ArduPilot's 50 Hz distance trigger, the track; SITL
#: showed up to 5 m along the line), so the shortfall reported errs on the side of too much
EDGE_TOLERANCE_M = 2.0


@dataclass(frozen=True, eq=False)
class Coverage:
    required_m2: float  # the area outside the zones and their margins
    checked_m2: float  # of it, the part next to zones where the footprints were intersected
    uncovered: BaseGeometry  # planning CRS; empty when every point there has two photos
    uncovered_m2: float

    def polygons(self) -> list[BaseGeometry]:
        """The shortfall's parts, largest first."""
        if self.uncovered.is_empty:
            return []
        return sorted(shapely.get_parts(self.uncovered).tolist(), key=lambda p: -p.area)

    @property
    def parts(self) -> int:
        return len(self.polygons())


def _run_strips(stations: Stations, across: np.ndarray, along: np.ndarray, base: float) -> BaseGeometry:
    """Ground that two photos of one straight stretch of a run are sure to see: with a photo base
    of at most half the footprint, every point from the first station less (L/2 − B) to the last
    plus (L/2 − B) lies in two consecutive footprints (L, W the smallest footprint of the stretch,
    squared with the run: a camera turned off it, the rectangle inside its footprint, `photogrammetry.turned_footprint`).
    Empty below 50 % forward overlap.

    Every run's strip is made in one numpy step (the same operations, element by element, as
    one run at a time; sine and cosine once per heading, as numpy scalars)."""
    runs = stations.run
    if not len(runs):
        return shapely.Polygon()
    # a straight stretch: consecutive photos of one run with one heading (a bent run has several)
    heading = np.asarray(stations.heading_deg, float)
    starts = np.flatnonzero(np.r_[True, (runs[1:] != runs[:-1]) | (heading[1:] != heading[:-1])])
    ends = np.r_[starts[1:], len(runs)] - 1
    turn = np.asarray(stations.camera_yaw_deg, float) - heading
    sides = zip(np.maximum(across, 1e-9).tolist(), np.maximum(along, 1e-9).tolist(), turn.tolist())  # no footprint: none
    across, along = np.array([pg.turned_footprint(a, b, t) for a, b, t in sides]).reshape(-1, 2).T
    L = np.minimum.reduceat(along, starts)
    W = np.minimum.reduceat(across, starts)
    reach = L / 2.0 - base
    tilted = np.maximum.reduceat(np.asarray(stations.pitch_deg, float), starts) > -90.0  # an oblique run is checked exactly
    keep = (ends > starts) & ~(reach <= 0) & (W > 0) & ~tilted  # one photo sees its ground once; below 50 % no two
    if not keep.any():
        return shapely.Polygon()
    a, b, reach, W = starts[keep], ends[keep], reach[keep], W[keep]
    heading = heading[a]
    trig = {h: (np.sin(np.radians(np.float64(h))), np.cos(np.radians(np.float64(h)))) for h in set(heading.tolist())}
    ux, uy = (np.array(c, float) for c in zip(*(trig[h] for h in heading.tolist())))
    vx, vy = uy, -ux
    x, y = np.asarray(stations.x, float), np.asarray(stations.y, float)
    p0x, p0y = x[a] - ux * reach, y[a] - uy * reach
    p1x, p1y = x[b] + ux * reach, y[b] + uy * reach
    hx, hy = vx * W / 2, vy * W / 2
    ring = np.stack([np.column_stack([p0x + hx, p0y + hy]), np.column_stack([p1x + hx, p1y + hy]),
                     np.column_stack([p1x - hx, p1y - hy]), np.column_stack([p0x - hx, p0y - hy])], axis=1)
    return shapely.union_all(shapely.polygons(ring))


def coverage_shortfall(spec: MissionSpec, site: Site, sensor: SensorSolution, stations: Stations,
                       check_exactly: BaseGeometry | None = None) -> Coverage:
    """The shortfall next to the zones and on `check_exactly` (where the pattern's own rule does
    not prove the overlaps, e.g. a corridor's bends)."""
    k = site.grid_scale
    k2 = k * k
    if site.zones_buffered is None and check_exactly is None:
        return Coverage(site.area.area / k2, 0.0, shapely.Polygon(), 0.0)
    required = site.area if site.zones_buffered is None else shapely.difference(site.area, site.zones_buffered)
    reach = (max(sensor.across_m, sensor.along_m) + sensor.lead_in_m + sensor.base_m) * k
    around = [g for g in (shapely.buffer(site.zones_buffered, reach, quad_segs=4) if site.zones_buffered is not None else None,
                          check_exactly) if g is not None]
    near = shapely.intersection(required, shapely.union_all(around))
    if near.is_empty:
        return Coverage(required.area / k2, 0.0, shapely.Polygon(), 0.0)
    if not len(stations.ids):
        return Coverage(required.area / k2, near.area / k2, near, near.area / k2)
    across, along = pg.footprint(np.asarray(stations.agl_m, float), spec.camera.camera, spec.camera.mount)
    across = (np.asarray(across, float) - 2 * EDGE_TOLERANCE_M) * k
    along = (np.asarray(along, float) - 2 * EDGE_TOLERANCE_M) * k
    # what two photos of one run surely see needs no pairwise intersection
    rest = shapely.difference(near, _run_strips(stations, across, along, sensor.base_m * k))
    if rest.is_empty:
        return Coverage(required.area / k2, near.area / k2, shapely.Polygon(), 0.0)
    photos = Photos.looking(stations.x, stations.y, stations.agl_m, stations.camera_yaw_deg, stations.pitch_deg)
    optics = Optics.of(spec.camera.camera, spec.camera.mount)
    # a photo with no ground footprint (a level camera's) sees no ground point
    corners, _ = bounded_footprint_corners(photos, optics, 0.0, k)
    lo, hi = corners.min(axis=1), corners.max(axis=1)
    meet = shapely.STRtree(shapely.box(lo[:, 0], lo[:, 1], hi[:, 0], hi[:, 1])).query(rest, predicate="intersects")
    fps = shapely.buffer(shapely.polygons(corners[meet]), -EDGE_TOLERANCE_M * k, join_style="mitre")
    fps = shapely.intersection(fps, shapely.buffer(rest, 1.0, quad_segs=2))
    pairs = shapely.STRtree(fps).query(fps, predicate="intersects")
    i, j = pairs[:, pairs[0] < pairs[1]]
    twice = shapely.union_all(shapely.intersection(fps[i], fps[j])) if len(i) else shapely.Polygon()
    short = shapely.difference(rest, twice)
    parts = [p for p in shapely.get_parts(short) if p.geom_type == "Polygon" and p.area / k2 >= SLIVER_M2]
    uncovered = shapely.union_all(parts) if parts else shapely.Polygon()
    return Coverage(required.area / k2, near.area / k2, uncovered, uncovered.area / k2)


def uncovered_rule(c: Coverage) -> dict[str, Any]:
    """The planner's own rule result, as the manifest records rule results: required ground fewer
    than two photos see (next to the zones)."""
    where = [{"xy": [round(p.x, 2), round(p.y, 2)]} for p in (part.representative_point() for part in c.polygons()[:50])]
    return {"profile": PLANNER_PROFILE, "rule": UNCOVERED_RULE, "status": "fail" if c.uncovered_m2 > 0 else "pass",
            "severity": "error", "statement": UNCOVERED_STATEMENT,
            "measured": f"{c.uncovered_m2:.2f} m² in {c.parts} part(s) seen by fewer than {MIN_IMAGES} photos",
            "required": "0 m²", "evidence": ["the layer 'uncovered' of plan.geojson"] if c.parts else [],
            "where": where, "source": "aerosurvey planner (plan/coverage.py)"}


def planner_rules(plan: Plan) -> list[dict[str, Any]]:
    """The planner's own rule results, as the manifest records them: the uncovered ground, and with a
    [structure] its faces (plan/surfaces.py)."""
    if plan.faces is None:
        return [uncovered_rule(plan.coverage)]
    from aerosurvey.plan.surfaces import faces_rule  # faces only: not loaded by every plan

    return [uncovered_rule(plan.coverage), faces_rule(plan.faces, PLANNER_PROFILE)]
