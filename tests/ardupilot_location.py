"""ArduPilot's flat-earth distance (AP_Common/Location.cpp), for the independent checks: written
from ArduPilot's source, sharing no code with the planner.

Location holds a place as whole 1e-7 degrees (int32 lat and lng). Location::get_distance takes
the latitude difference and the longitude difference (the short way round, diff_longitude)
times the cosine of the two latitudes' mean (an int32 mean; longitude_scale, at least 0.01),
and multiplies their hypotenuse by LOCATION_SCALING_FACTOR, the metres of 1e-7 degree on a
sphere of 6,378,100 m. The camera's distance trigger measures with it, and the vehicle's
navigation turns places into metres from its origin the same way, so it flies its speed in
these metres too.
"""

from __future__ import annotations

import math

#: ArduPilot's LOCATION_SCALING_FACTOR: metres per 1e-7 degree of latitude
LOCATION_SCALING_FACTOR = 0.011131884502145034


def e7(deg: float) -> int:
    """A coordinate as ArduPilot's Location holds it: whole 1e-7 degrees."""
    return round(deg * 1e7)


def _flat(dlat: float, dlng: float, mean_lat: float) -> float:
    """The hypotenuse of the latitude and the scaled longitude differences (1e-7 degrees), in metres."""
    if dlng > 1_800_000_000:  # diff_longitude: the short way round
        dlng -= 3_600_000_000
    elif dlng < -1_800_000_000:
        dlng += 3_600_000_000
    scale = max(math.cos(mean_lat * 1.0e-7 * math.pi / 180.0), 0.01)  # longitude_scale
    return math.hypot(dlat, dlng * scale) * LOCATION_SCALING_FACTOR


def distance_e7(lat1: int, lon1: int, lat2: int, lon2: int) -> float:
    """Location::get_distance on places in 1e-7 degrees (AP_Common/Location.cpp)."""
    return _flat(lat2 - lat1, lon2 - lon1, math.trunc((lat1 + lat2) / 2))  # C's int32 mean


def distance_m(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    """ArduPilot's distance between two places given in degrees (held as 1e-7 degrees first)."""
    return distance_e7(e7(lat1), e7(lon1), e7(lat2), e7(lon2))


def metres_per_ground_metre(lat1: float, lon1: float, lat2: float, lon2: float, ground_m: float) -> float:
    """ArduPilot's metres per ground metre from one place to another `ground_m` away: its formula
    on the unrounded degrees (a ratio, not a measurement the autopilot makes)."""
    return _flat((lat2 - lat1) * 1e7, (lon2 - lon1) * 1e7, (lat1 + lat2) / 2 * 1e7) / ground_m
