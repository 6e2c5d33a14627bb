"""The final gate: every leg of an exported mission, as the autopilot will fly it, checked
against the exclusion zones and their margins before any file is written.

Legs are rebuilt from the mission items themselves (not from the planner's waypoints):
home → take-off → every navigation item in order → the end (RTL: straight back to home;
NAV_LAND: to its point). A leg that enters a zone, or comes closer to it than the margin
allows, stops the plan with the file, the item and the place.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.area import Planar
from aerosurvey.mission import mavlink_ids as mav
from aerosurvey.mission.items import Mission

#: commands whose latitude/longitude the vehicle flies to
_NAV = {mav.NAV_WAYPOINT, mav.NAV_TAKEOFF, mav.NAV_LAND}
#: the margin is checked a little inside its outline: the route keeps out of a polygon of it
#: (eight segments a quarter circle, whose chords lie up to 2 % of the margin inside the circle)
MARGIN_TOLERANCE = 0.95


@dataclass(frozen=True)
class Leg:
    file: str
    seq: int  # the mission item the leg flies to (0: home)
    what: str
    start: tuple[float, float]  # planning CRS
    end: tuple[float, float]


@dataclass(frozen=True)
class Violation:
    leg: Leg
    inside_m: float  # length of the leg inside the zone (or the margin)
    zone: bool  # True: inside a zone itself; False: inside its margin only
    at_lonlat: tuple[float, float]

    def message(self) -> str:
        where = "an exclusion zone" if self.zone else "the margin around an exclusion zone"
        return (f"{self.leg.file}: the leg to item {self.leg.seq} ({self.leg.what}) flies {self.inside_m:.1f} m inside {where}, "
                f"first at lon {self.at_lonlat[0]:.6f}, lat {self.at_lonlat[1]:.6f}")


def mission_legs(mission: Mission, file: str, planar: Planar, rtl_loiter: float = 0.0, grid_scale: float = 1.0) -> list[Leg]:
    """The horizontal legs the autopilot flies for `mission` (home is item 0).

    A plane's NAV_TAKEOFF climbs straight ahead at its pitch (param1) to the take-off altitude,
    taken towards the next waypoint; when that waypoint is nearer than the climb, the climb
    ends beyond it and the plane turns back to it. A plane's RTL ends circling home at
    `rtl_loiter` (planning-grid metres), and that circle is legs too."""
    home_lat, home_lon, _ = mission.home
    hx, hy = planar.xy(np.array([home_lon]), np.array([home_lat]))
    home = (float(hx[0]), float(hy[0]))
    pts: list[tuple[int, str, float, float]] = []
    for seq, it in enumerate(mission.items, start=1):
        if it.command in _NAV:
            pts.append((seq, it.tag or str(it.command), it.x, it.y))  # an item's x is latitude, y longitude
        elif it.command == mav.NAV_RETURN_TO_LAUNCH:
            pts.append((seq, "rtl", home_lat, home_lon))
    if not pts:
        return []
    lat = np.array([p[2] for p in pts])
    lon = np.array([p[3] for p in pts])
    # latitude/longitude 0 means "where the vehicle is" (a take-off or land in place)
    here = (lat == 0) & (lon == 0)
    x, y = planar.xy(np.where(here, home_lon, lon), np.where(here, home_lat, lat))
    climb = 0.0
    if mission.vehicle == "plane":
        takeoff = next((it for it in mission.items if it.command == mav.NAV_TAKEOFF), None)
        if takeoff is not None and takeoff.param1 > 0:
            climb = max(takeoff.z, 0.0) / math.tan(math.radians(takeoff.param1)) * grid_scale
    legs: list[Leg] = []
    prev = home
    for (seq, what, _, _), px, py, h in zip(pts, x, y, here):
        cur = prev if h else (float(px), float(py))
        d = math.dist(prev, cur)
        if climb > d > 0 and prev == home and legs and legs[-1].what == "takeoff":
            out = (prev[0] + (cur[0] - prev[0]) * climb / d, prev[1] + (cur[1] - prev[1]) * climb / d)
            legs.append(Leg(file, legs[-1].seq, "climb-out", prev, out))
            prev = out
        legs.append(Leg(file, seq, what, prev, cur))
        prev = cur
    if rtl_loiter > 0 and mission.vehicle == "plane" and legs and legs[-1].what == "rtl":
        a = np.linspace(0.0, 2 * np.pi, 37)
        ring = [(home[0] + rtl_loiter * float(np.cos(t)), home[1] + rtl_loiter * float(np.sin(t))) for t in a]
        legs += [Leg(file, legs[-1].seq, "rtl-loiter", p, q) for p, q in zip(ring[:-1], ring[1:])]
    return legs


def check_legs(legs: list[Leg], zones: BaseGeometry | None, margin_m: float, grid_scale: float,
               planar: Planar) -> list[Violation]:
    if zones is None or zones.is_empty or not legs:
        return []
    margin = shapely.buffer(zones, margin_m * grid_scale * MARGIN_TOLERANCE) if margin_m > 0 else zones
    shapely.prepare(zones)
    shapely.prepare(margin)
    out = []
    lines = shapely.linestrings([[leg.start, leg.end] for leg in legs])
    for leg, line, hit in zip(legs, lines, shapely.intersects(margin, lines)):
        if not hit:
            continue
        in_zone = shapely.intersection(line, zones)
        inside = in_zone if not in_zone.is_empty and in_zone.length > 0 else shapely.intersection(line, margin)
        if inside.is_empty:
            continue
        length = inside.length / grid_scale
        if length <= 0.01 and in_zone.is_empty:
            continue
        p = shapely.get_point(shapely.get_parts(inside)[0], 0) if inside.geom_type != "Point" else inside
        lon, lat = planar.lonlat(np.array([p.x]), np.array([p.y]))
        out.append(Violation(leg, length, not in_zone.is_empty, (float(lon[0]), float(lat[0]))))
    return out
