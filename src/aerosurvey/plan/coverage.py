"""Coverage next to the exclusion zones: the required ground (the area outside the zones and
their margins) that fewer than two photos see, computed exactly from the footprints.

Ground seen by two photos or more is the union of the footprints' pairwise intersections;
what the required ground keeps outside that union is the shortfall. Footprints come from the
capture model (plan/capture.py). Away from the zones the
line layout's own rule (every point in ⌊1/(1−side)⌋ strips and ⌊1/(1−forward)⌋ photos of
each) holds by construction and is proved by the independent coverage tests, so the exact
computation runs where lines are cut: within a few footprints of a zone.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.plan.capture import Optics, Photos, footprint_polygons
from aerosurvey.plan.model import Stations
from aerosurvey.plan.sensor import SensorSolution
from aerosurvey.plan.site import Site
from aerosurvey.spec import MissionSpec

#: photos that must see a point for it to be reconstructed (a stereo pair)
MIN_IMAGES = 2
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


def coverage_shortfall(spec: MissionSpec, site: Site, sensor: SensorSolution, stations: Stations) -> Coverage:
    k = site.grid_scale
    k2 = k * k
    if site.zones_buffered is None:
        return Coverage(site.area.area / k2, 0.0, shapely.Polygon(), 0.0)
    required = shapely.difference(site.area, site.zones_buffered)
    reach = (max(sensor.across_m, sensor.along_m) + sensor.lead_in_m + sensor.base_m) * k
    near = shapely.intersection(required, shapely.buffer(site.zones_buffered, reach, quad_segs=4))
    if near.is_empty:
        return Coverage(required.area / k2, 0.0, shapely.Polygon(), 0.0)
    if not len(stations.ids):
        return Coverage(required.area / k2, near.area / k2, near, near.area / k2)
    photos = Photos.nadir(stations.x, stations.y, stations.agl_m, stations.heading_deg)
    fps = footprint_polygons(photos, Optics.of(spec.camera.camera, spec.camera.mount), 0.0, k)
    fps = shapely.buffer(fps, -EDGE_TOLERANCE_M * k, join_style="mitre")
    near_photos = np.sort(shapely.STRtree(fps).query(near, predicate="intersects"))
    # what two consecutive photos of one run see needs no pairwise search
    runs = np.asarray(stations.run)
    follows = (np.diff(near_photos) == 1) & (runs[near_photos[1:]] == runs[near_photos[:-1]])
    a, b = near_photos[:-1][follows], near_photos[1:][follows]
    rest = shapely.difference(near, shapely.union_all(shapely.intersection(fps[a], fps[b])))
    if rest.is_empty:
        return Coverage(required.area / k2, near.area / k2, shapely.Polygon(), 0.0)
    fps = fps[near_photos]
    fps = fps[shapely.STRtree(fps).query(rest, predicate="intersects")]
    fps = shapely.intersection(fps, shapely.buffer(rest, 1.0, quad_segs=2))
    pairs = shapely.STRtree(fps).query(fps, predicate="intersects")
    i, j = pairs[:, pairs[0] < pairs[1]]
    twice = shapely.union_all(shapely.intersection(fps[i], fps[j])) if len(i) else shapely.Polygon()
    short = shapely.difference(rest, twice)
    parts = [p for p in shapely.get_parts(short) if p.geom_type == "Polygon" and p.area / k2 >= SLIVER_M2]
    uncovered = shapely.union_all(parts) if parts else shapely.Polygon()
    return Coverage(required.area / k2, near.area / k2, uncovered, uncovered.area / k2)
