"""The final gate: every leg of every flight, as the vehicle will fly it, checked against the
exclusion zones and their margins once, before any emitter writes a file.

Legs are rebuilt from the flight program (mission/program.py), which every file format is
emitted from: home → take-off → every waypoint in order → the end (RTL: straight back to
home; landing: to the launch point, a plane through its approach waypoint). A leg that enters
a zone, or comes closer to it than the margin allows, stops the plan with the flight, the
point and the place.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.area import Planar
from aerosurvey.mission.program import FlightProgram, rtl_target
from aerosurvey.plan.landing import climb_at_pitch_m

#: the margin is checked a little inside its outline: the route keeps out of a polygon of it
#: (eight segments a quarter circle, whose chords lie up to 2 % of the margin inside the circle)
MARGIN_TOLERANCE = 0.95


@dataclass(frozen=True)
class Leg:
    flight: str  # "mission", "sortie-01", ...
    seq: int  # the point the leg flies to (0: home, 1: take-off, then the waypoints)
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
        return (f"{self.leg.flight}: the leg to point {self.leg.seq} ({self.leg.what}) flies {self.inside_m:.1f} m inside {where}, "
                f"first at lon {self.at_lonlat[0]:.6f}, lat {self.at_lonlat[1]:.6f}")


def program_legs(program: FlightProgram, flight: str, planar: Planar, rtl_loiter: float = 0.0,
                 grid_scale: float = 1.0) -> list[Leg]:
    """The horizontal legs the vehicle flies for `program`, named `flight` in messages.

    Points are numbered as the program has them: 0 home, 1 the take-off, then the waypoints,
    then the approach (a plane landing) and the landing or the return home. A plane's take-off
    climbs straight ahead at its pitch to the take-off altitude, taken towards the first
    waypoint; when that waypoint is nearer than the climb, the climb ends beyond it and the
    plane turns back to it. A plane's RTL ends circling home at `rtl_loiter` (planning-grid
    metres), and that circle is legs too."""
    lat0, lon0, _ = program.home
    pts = [("takeoff", lat0, lon0)] + [(w.tag, w.lat, w.lon) for w in program.waypoints]
    if program.approach is not None:
        pts.append(("approach", program.approach.lat, program.approach.lon))
    if program.end == "land":
        pts.append(("land", lat0, lon0))
    else:  # straight to the nearest rally point (or home) from the last place flown to
        last = (pts[-1][1], pts[-1][2])
        to = rtl_target(program.vehicle, (lat0, lon0), [(r[0], r[1]) for r in program.rally], last)
        pts.append(("rtl", to[0], to[1]))
    x, y = planar.xy(np.array([lon0] + [p[2] for p in pts]), np.array([lat0] + [p[1] for p in pts]))
    home = (float(x[0]), float(y[0]))
    climb = takeoff_climb(program) * grid_scale
    legs: list[Leg] = []
    prev = home
    for n, ((what, _, _), px, py) in enumerate(zip(pts, x[1:], y[1:]), start=1):
        cur = (float(px), float(py))
        d = math.dist(prev, cur)
        if climb > d > 0 and n == 2:
            out = (prev[0] + (cur[0] - prev[0]) * climb / d, prev[1] + (cur[1] - prev[1]) * climb / d)
            legs.append(Leg(flight, 1, "climb-out", prev, out))
            prev = out
        legs.append(Leg(flight, n, what, prev, cur))
        prev = cur
    if rtl_loiter > 0 and program.vehicle == "plane" and program.end == "rtl":
        a = np.linspace(0.0, 2 * np.pi, 37)
        ring = [(home[0] + rtl_loiter * float(np.cos(t)), home[1] + rtl_loiter * float(np.sin(t))) for t in a]
        legs += [Leg(flight, legs[-1].seq, "rtl-loiter", p, q) for p, q in zip(ring[:-1], ring[1:])]
    return legs


def takeoff_climb(program: FlightProgram) -> float:
    """Ground metres a plane flies straight ahead climbing at its take-off pitch to the take-off altitude; 0 for a copter."""
    if program.vehicle == "plane" and program.takeoff_pitch_deg > 0:
        return climb_at_pitch_m(program.takeoff_alt_m, program.takeoff_pitch_deg)
    return 0.0


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
