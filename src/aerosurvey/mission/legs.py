"""Legs between the places of a mission as PX4 measures them, and long legs cut into pieces.

PX4 v1.13 and earlier check, when the vehicle arms, the distance between each two consecutive
mission items that carry a place (MissionFeasibilityChecker::checkDistancesBetweenWaypoints:
NAV_WAYPOINT, NAV_LOITER_*, NAV_LAND, NAV_TAKEOFF, NAV_LOITER_TO_ALT, NAV_VTOL_*; the commands
in between are skipped) and refuse the mission when one is farther than MIS_DIST_WPS ("Distance
between waypoints too far: %d meters, %d max."). They measure it with
get_distance_to_next_waypoint: the haversine on a sphere of CONSTANTS_RADIUS_OF_EARTH, 6,371 km.
PX4 v1.14 removed the check (pull request 21262); v1.16's only distance check,
MIS_DIST_1WP, warns and does not refuse.
"""

from __future__ import annotations

import math

#: The commands whose item PX4 takes as a place (MissionBlock::item_contains_position)
PX4_PLACE_COMMANDS = frozenset({16, 17, 19, 21, 22, 31, 84, 85})
#: PX4's parameter for the longest leg (v1.13 and earlier; 0 or less: no limit)
MIS_DIST_WPS = "MIS_DIST_WPS"
#: PX4's CONSTANTS_RADIUS_OF_EARTH (metres)
PX4_EARTH_RADIUS_M = 6_371_000.0
#: A piece is kept this far (metres) under the limit, so that writing the places to MAVLink's
#: 1e-7 degrees (about a centimetre) cannot take it over
LEG_MARGIN_M = 1.0


def great_circle_m(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    """Great-circle distance in metres: the haversine on PX4's 6,371 km sphere, as PX4 measures
    the distance between two places (within 0.5 % of the ellipsoid's at any range)."""
    p1, p2, dlat, dlon = (math.radians(v) for v in (lat1, lat2, lat2 - lat1, lon2 - lon1))
    h = math.sin(dlat / 2) ** 2 + math.cos(p1) * math.cos(p2) * math.sin(dlon / 2) ** 2
    return 2 * PX4_EARTH_RADIUS_M * math.asin(min(1.0, math.sqrt(h)))


def leg_cuts(lat1: float, lon1: float, lat2: float, lon2: float, limit_m: float) -> list[tuple[float, float, float]]:
    """The places (lat, lon, fraction of the leg) that cut the leg from (lat1, lon1) to (lat2, lon2)
    into equal pieces of at most `limit_m` less LEG_MARGIN_M, on the great circle between its ends
    (a straight line on PX4's local map at these lengths); none when it is not longer than that."""
    d = great_circle_m(lat1, lon1, lat2, lon2)
    longest = limit_m - LEG_MARGIN_M
    if d <= longest:
        return []
    n = math.floor(d / longest) + 1
    p1, l1, p2, l2 = (math.radians(v) for v in (lat1, lon1, lat2, lon2))
    a = (math.cos(p1) * math.cos(l1), math.cos(p1) * math.sin(l1), math.sin(p1))
    b = (math.cos(p2) * math.cos(l2), math.cos(p2) * math.sin(l2), math.sin(p2))
    omega = d / PX4_EARTH_RADIUS_M
    out = []
    for k in range(1, n):
        f = k / n
        wa, wb = math.sin((1 - f) * omega) / math.sin(omega), math.sin(f * omega) / math.sin(omega)
        x, y, z = (wa * u + wb * v for u, v in zip(a, b))
        out.append((math.degrees(math.atan2(z, math.hypot(x, y))), math.degrees(math.atan2(y, x)), f))
    return out


def longest_leg(places: list[tuple[int, float, float]]) -> tuple[float, int, int] | None:
    """(metres, seq, seq) of the longest leg between consecutive places (seq, lat, lon) in mission
    order, as PX4 measures it; None with fewer than two places."""
    legs = [(great_circle_m(a[1], a[2], b[1], b[2]), a[0], b[0]) for a, b in zip(places, places[1:])]
    return max(legs) if legs else None
