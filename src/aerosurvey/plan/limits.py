"""Limits before work: what a plan would cost (photos, lines, path, flight hours, output size,
memory), estimated from the area's shape (each part's width and length, the distances between
the parts) and the sensor solution in milliseconds, and refused beyond the spec's `[limits]`
before any line is laid.

Also the overlap check, a warning: forward overlap under 50 % leaves ground between two
photos of a strip that only one photo sees, so it has no stereo pair at all (geometry, not
convention: a point is in two consecutive photos only when the base is under half the
footprint); side overlap under 20 % is below the 20-30 % classical film photogrammetry flew to
tie strips together (our own threshold; the Czech land-consolidation rules ask for 60 %).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from aerosurvey.errors import InputError
from aerosurvey.plan.corridor import strip_ordinates
from aerosurvey.plan.lines import strip_offsets_many
from aerosurvey.plan.sensor import SensorSolution
from aerosurvey.plan.site import Site
from aerosurvey.spec import MissionSpec

#: measured on the examples: all files of `aerosurvey plan` take about 1.5 kB per photo
#: (Obrataň: 1,756 photos, 2.6 MB), and planning holds about 20 kB per photo at its peak
BYTES_PER_PHOTO_FILES = 1_500
BYTES_PER_PHOTO_MEMORY = 20_000
MIN_STEREO_FORWARD = 0.5
MIN_TIE_SIDE = 0.2


@dataclass(frozen=True)
class CostEstimate:
    photos: int
    lines: int
    flight_hours: float
    output_mb: float
    memory_mb: float
    path_km: float  # the photo lines and the transit between the area's parts
    transit_km: float  # between the parts (the shortest tree joining them)


def estimate_cost(spec: MissionSpec, site: Site, sensor: SensorSolution) -> CostEstimate:
    """An upper-side estimate of the plan's size from the area's shape, before any line is laid.

    Each part of the area is taken as flown along the long side of its smallest enclosing
    rectangle (the heading search prefers few long lines): as many lines as `strip_offsets`
    lays over its width (grown by the coverage margin), each as long as the part's mean chord
    (its area over that width) plus the margins, with the photos beyond the ends; a cross-hatch
    pass the same way along the short side. The flight adds a turn per line and the shortest
    tree joining the parts (no tour between them is shorter)."""
    k = site.grid_scale
    if site.centreline is not None:
        return _corridor_cost(spec, site, sensor)
    passes = 2 if spec.flight.cross_hatch else 1
    parts = shapely.get_parts(site.area)
    rects = shapely.oriented_envelope(parts)
    corners = shapely.get_coordinates(shapely.get_exterior_ring(rects)).reshape(len(parts), -1, 2)[:, :3]
    sides = np.sort(np.hypot(*np.diff(corners, axis=1).transpose(2, 0, 1)), axis=1) / k  # (parts, [short, long])
    margin = spec.targets.coverage_margin_m
    areas = shapely.area(parts) / (k * k)
    extension = 2 * (spec.targets.images_beyond_boundary + sensor.forward_images_per_point)
    lines = photos = 0.0
    for side in range(passes):  # along the long side, then (cross-hatch) along the short one
        width = sides[:, side] + 2.0 * margin
        n = np.array([len(vs) for vs in strip_offsets_many(np.zeros(len(parts)), width, sensor.across_m,
                                                            sensor.spacing_m, sensor.side_images_per_point)])
        chord = areas / np.maximum(sides[:, side], 1e-9) + 2.0 * margin
        lines += float(n.sum())
        photos += float(np.sum(n * (chord / sensor.base_m + extension)))
    transit = _joining_tree_m(parts) / k
    path = photos * sensor.base_m + transit
    hours = (path / sensor.speed.speed_ms + lines * 30.0) / 3600.0
    n_photos = int(min(photos, 1e15))
    return CostEstimate(n_photos, int(lines), hours, n_photos * BYTES_PER_PHOTO_FILES / 1e6,
                        n_photos * BYTES_PER_PHOTO_MEMORY / 1e6, path / 1000.0, transit / 1000.0)


def _corridor_cost(spec: MissionSpec, site: Site, sensor: SensorSolution) -> CostEstimate:
    """A corridor's: each piece of the centreline flown once per strip (as many as `strip_offsets`
    lays over its width), as long as the piece with the photos beyond both ends."""
    assert site.centreline is not None and site.sides_m is not None
    k = site.grid_scale
    pieces = shapely.get_parts(shapely.line_merge(site.centreline))
    margin = spec.targets.coverage_margin_m
    strips = len(strip_ordinates(site.sides_m[0] + margin, site.sides_m[1] + margin, sensor.across_m,
                                 sensor.spacing_m, sensor.side_images_per_point))
    extension = 2 * (spec.targets.images_beyond_boundary + sensor.forward_images_per_point)
    lengths = shapely.length(pieces) / k
    photos = float(np.sum(strips * (lengths / sensor.base_m + extension)))
    lines = strips * len(pieces)
    transit = _joining_tree_m(pieces) / k
    path = photos * sensor.base_m + transit
    hours = (path / sensor.speed.speed_ms + lines * 30.0) / 3600.0
    n_photos = int(min(photos, 1e15))
    return CostEstimate(n_photos, lines, hours, n_photos * BYTES_PER_PHOTO_FILES / 1e6,
                        n_photos * BYTES_PER_PHOTO_MEMORY / 1e6, path / 1000.0, transit / 1000.0)


def _joining_tree_m(parts: np.ndarray) -> float:
    """The length of the shortest tree joining the parts, over the pairs of parts whose
    representative points are Delaunay neighbours (all pairs for three parts or fewer)."""
    if len(parts) < 2:
        return 0.0
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import minimum_spanning_tree
    from scipy.spatial import Delaunay

    if len(parts) <= 3:
        pairs = np.array([(i, j) for i in range(len(parts)) for j in range(i + 1, len(parts))])
    else:
        tri = Delaunay(shapely.get_coordinates(shapely.point_on_surface(parts)), qhull_options="QJ").simplices
        pairs = np.unique(np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [0, 2]]]), axis=1), axis=0)
    d = shapely.distance(parts[pairs[:, 0]], parts[pairs[:, 1]]) + 1e-9  # a touching pair still an edge
    graph = coo_matrix((d, (pairs[:, 0], pairs[:, 1])), shape=(len(parts), len(parts)))
    return float(minimum_spanning_tree(graph).sum())


def check_limits(spec: MissionSpec, site: Site, sensor: SensorSolution) -> tuple[str, ...]:
    """Refuse a plan beyond the limits (InputError naming the key that raises them); return warnings."""
    est = estimate_cost(spec, site, sensor)
    parts = len(shapely.get_parts(site.area))
    between = f", {est.transit_km:,.1f} km between its {parts} parts" if parts > 1 else ""
    what = (f"about {est.photos:,} photos on {est.lines:,} lines, {est.path_km:,.0f} km and {est.flight_hours:,.1f} h of flight, "
            f"{est.output_mb:,.0f} MB of files and {est.memory_mb:,.0f} MB of memory to plan "
            f"(GSD {sensor.gsd_target_m * 100:.2f} cm, line spacing {sensor.spacing_m:.1f} m, photo base {sensor.base_m:.1f} m, "
            f"area {site.area.area / site.grid_scale ** 2 / 1e4:,.1f} ha{between})")
    if est.photos > spec.limits.max_photos:
        raise InputError(f"the plan would take {what}: more than limits.max_photos = {spec.limits.max_photos:,}; "
                         "check targets.gsd_cm and the area, or raise limits.max_photos for a job this large",
                         key="limits.max_photos")
    if est.flight_hours > spec.limits.max_flight_hours:
        raise InputError(f"the plan would take {what}: more than limits.max_flight_hours = {spec.limits.max_flight_hours:g}; "
                         "check the area and the speed, or raise limits.max_flight_hours for a job this large",
                         key="limits.max_flight_hours")
    warnings = []
    t = spec.targets
    if t.forward_overlap < MIN_STEREO_FORWARD:
        warnings.append(f"targets.forward_overlap = {t.forward_overlap:g} is under {MIN_STEREO_FORWARD:g}: ground between "
                        "photos of a line is seen by one photo only, which gives no stereo for a 3D model or orthophoto")
    if t.side_overlap < MIN_TIE_SIDE:
        warnings.append(f"targets.side_overlap = {t.side_overlap:g} is under {MIN_TIE_SIDE:g}: neighbouring lines share "
                        "too little ground to be tied together reliably")
    return tuple(warnings)
