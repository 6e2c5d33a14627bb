"""Which official zones the route keeps clear as it keeps the drawn exclusion zones clear.

A zone that blocks (airspace/model.py `Airspace.blocks`), applies in the planned window and
whose band holds every height the flight can have over it (from the ground up to
vehicle.max_height_agl_m above the ground) cannot be flown in at all: its outline joins the
exclusion zones before planning, so the route, its detours, the launch point and the geofence
keep out of it (with flight.exclusion_margin_m). Any other blocking zone is left to the 4-D
check of every leg (airspace/check.py), which refuses the plan if a leg meets it in its band.

Heights above sea level need the DEM: without one, a limit in AMSL or WGS84 height cannot be
placed against the ground, and the zone is taken as reaching from the ground (lower) and
without ceiling (upper), as the check takes it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.airspace.model import Airspace, Geozone, Limit, amsl_span
from aerosurvey.airspace.outline import outlines_wgs84
from aerosurvey.plan.inputs import DemGrid


@dataclass(frozen=True)
class RouteZones:
    """The outlines (WGS84) the route keeps clear, and the warnings that say which zones they are."""

    outlines: tuple[BaseGeometry, ...]
    warnings: tuple[str, ...]


def _covers_ground(lower: Limit | None, ground_lo: float | None) -> bool:
    if lower is None:
        return True
    if lower.reference == "AGL":
        return lower.value_m <= 0.0
    return ground_lo is None or amsl_span(lower)[0] <= ground_lo


def _covers_top(upper: Limit | None, cap_agl_m: float, ground_hi: float | None) -> bool:
    if upper is None:
        return True
    if upper.reference == "AGL":
        return upper.value_m >= cap_agl_m
    return ground_hi is None or amsl_span(upper)[1] >= ground_hi + cap_agl_m


def route_zones(airspace: Airspace | None, area_wgs84: BaseGeometry, reach_m: float, cap_agl_m: float,
                dem: DemGrid | None) -> RouteZones:
    """The blocking zones within `reach_m` of the area whose band holds every height from the ground to `cap_agl_m`
    above it (the ground's range: the DEM window's lowest and highest cells; unknown without a DEM)."""
    if airspace is None or not airspace.zones:
        return RouteZones((), ())
    ground = dem.height_range() if dem is not None else None
    ground_lo, ground_hi = ground if ground is not None else (None, None)
    picked: list[Geozone] = [z for z in airspace.zones if airspace.blocks(z) and airspace.applies(z)
                             and _covers_ground(z.lower, ground_lo) and _covers_top(z.upper, cap_agl_m, ground_hi)]
    if not picked:
        return RouteZones((), ())
    outlines = outlines_wgs84(picked)
    c = area_wgs84.centroid
    reach_deg = reach_m / (111_320.0 * max(0.05, math.cos(math.radians(c.y))))
    near = shapely.dwithin(np.array(outlines, dtype=object), area_wgs84, reach_deg)
    kept = [(z, o) for z, o, n in zip(picked, outlines, near) if n]
    return RouteZones(tuple(o for _, o in kept), tuple(
        f"{z.label}: {z.restriction}, {z.band_text()}, applies in the planned window; the route keeps it clear as an "
        "exclusion zone" for z, _ in kept))
