"""Limits before work: what a plan would cost (photos, flight hours, mission items, output
size, memory), estimated from the site and the sensor solution in microseconds, and refused
beyond the spec's `[limits]` before any line is laid.

Also the overlap check, a warning: forward overlap under 50 % leaves ground between two
photos of a strip that only one photo sees, so it has no stereo pair at all (geometry, not
convention: a point is in two consecutive photos only when the base is under half the
footprint); side overlap under 20 % is below the 20-30 % classical film photogrammetry flew to
tie strips together (our own threshold; the Czech land-consolidation rules ask for 60 %).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from aerosurvey.errors import InputError
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


def estimate_cost(spec: MissionSpec, site: Site, sensor: SensorSolution) -> CostEstimate:
    """An upper-side estimate of the plan's size from areas and spacings alone."""
    k = site.grid_scale
    passes = 2 if spec.flight.cross_hatch else 1
    area_m2 = site.area.area / (k * k)
    grown = math.sqrt(area_m2) + 2.0 * spec.targets.coverage_margin_m + sensor.across_m
    lines = passes * max(1, math.ceil(grown / sensor.spacing_m) + sensor.side_images_per_point)
    extension = 2 * (spec.targets.images_beyond_boundary + sensor.forward_images_per_point)
    photos = int(passes * area_m2 / (sensor.spacing_m * sensor.base_m) + lines * extension)
    hours = (photos * sensor.base_m / sensor.speed.speed_ms + lines * 30.0) / 3600.0
    return CostEstimate(photos, lines, hours, photos * BYTES_PER_PHOTO_FILES / 1e6, photos * BYTES_PER_PHOTO_MEMORY / 1e6)


def check_limits(spec: MissionSpec, site: Site, sensor: SensorSolution) -> tuple[str, ...]:
    """Refuse a plan beyond the limits (InputError naming the key that raises them); return warnings."""
    est = estimate_cost(spec, site, sensor)
    what = (f"about {est.photos:,} photos on {est.lines:,} lines, {est.flight_hours:,.1f} h of flight, "
            f"{est.output_mb:,.0f} MB of files and {est.memory_mb:,.0f} MB of memory to plan "
            f"(GSD {sensor.gsd_target_m * 100:.2f} cm, line spacing {sensor.spacing_m:.1f} m, photo base {sensor.base_m:.1f} m, "
            f"area {site.area.area / site.grid_scale ** 2 / 1e4:,.1f} ha)")
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
