"""Every leg of a flight with its heights: the final gate's legs (mission/gate.py `program_legs`,
rebuilt from the flight program) with the altitudes the vehicle flies them at, in the program's
altitude frame (above the launch point, or above the terrain).

The heights along a leg run straight from its start to its end. Where the autopilot may fly
anywhere between two heights (RTL: it returns at the higher of where it is and the return
altitude), the leg holds that span all along. A copter's take-off and landing are vertical legs
at the launch point; a plane climbs at its take-off pitch to the take-off altitude straight
towards the first waypoint, and glides from its approach waypoint to the ground; a copter that
returns (RTL) lands at the point it returns to, a plane circles it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from aerosurvey.area import Planar
from aerosurvey.mission.gate import Leg, program_legs, takeoff_climb
from aerosurvey.mission.program import FlightProgram, rtl_target


@dataclass(frozen=True)
class Leg3:
    leg: Leg  # flight, point number, what, start and end (planning CRS)
    alt_start: tuple[float, float]  # lowest and highest altitude at the start, in the program's frame
    alt_end: tuple[float, float]
    #: the altitude frames of the start's and the end's heights: "relative" (above the launch point) or "terrain" (above
    #: the terrain under the point); the autopilot flies the leg in the end's frame (ArduPilot converts the start into it)
    frames: tuple[str, str] = ("relative", "relative")


def _level(a: float) -> tuple[float, float]:
    return (a, a)


def flight_legs(program: FlightProgram, flight: str, planar: Planar, rtl_loiter: float, grid_scale: float,
                rtl_m: float | None = None) -> list[Leg3]:
    """The legs of `program` (named `flight`) with their heights; `rtl_loiter` is a plane's circle after RTL (grid
    metres); `rtl_m` the vehicle's own RTL altitude above home when it is known (None: it returns where it is)."""
    out: list[Leg3] = []
    alt = 0.0  # on the ground at the launch point
    frame = "relative"  # of `alt`: take-off, landing and RTL altitudes are above the launch point, waypoints in the program's frame
    wp_frame = program.altitude_frame
    climb = takeoff_climb(program) * grid_scale
    wps = program.waypoints
    rtl_span = (0.0, 0.0)
    for leg in program_legs(program, flight, planar, rtl_loiter, grid_scale):
        if leg.what == "takeoff":
            end = program.takeoff_alt_m if program.vehicle == "copter" else 0.0
            out.append(Leg3(leg, _level(alt), _level(end)))
            alt = end
        elif leg.what == "climb-out":
            out.append(Leg3(leg, _level(alt), _level(program.takeoff_alt_m)))
            alt = program.takeoff_alt_m
        elif 2 <= leg.seq < 2 + len(wps) and leg.what == wps[leg.seq - 2].tag:
            target = wps[leg.seq - 2].alt_m
            d = math.dist(leg.start, leg.end)
            if leg.seq == 2 and 0 < climb <= d and alt < program.takeoff_alt_m:
                # the plane's climb ends on the way to the first waypoint
                f = climb / d
                mid = (leg.start[0] + f * (leg.end[0] - leg.start[0]), leg.start[1] + f * (leg.end[1] - leg.start[1]))
                out.append(Leg3(Leg(leg.flight, 1, "climb-out", leg.start, mid), _level(alt), _level(program.takeoff_alt_m)))
                out.append(Leg3(Leg(leg.flight, leg.seq, leg.what, mid, leg.end), _level(program.takeoff_alt_m), _level(target),
                                ("relative", wp_frame)))
            else:
                out.append(Leg3(leg, _level(alt), _level(target), (frame, wp_frame)))
            alt, frame = target, wp_frame
        elif leg.what == "approach":
            assert program.approach is not None
            out.append(Leg3(leg, _level(alt), _level(program.approach.alt_m), (frame, "relative")))
            alt, frame = program.approach.alt_m, "relative"
        elif leg.what == "land":
            if program.vehicle == "plane":  # glides from its approach to the ground
                out.append(Leg3(leg, _level(alt), _level(0.0), (frame, "relative")))
            else:  # flies to the launch point at its height, then descends
                out.append(Leg3(leg, _level(alt), _level(alt), (frame, frame)))
                out.append(Leg3(Leg(leg.flight, leg.seq, "descent", leg.end, leg.end), _level(alt), _level(0.0), (frame, "relative")))
            alt, frame = 0.0, "relative"
        elif leg.what == "rtl":
            back = _rtl_altitude(program, alt, rtl_m)
            rtl_span = (min(alt, back), max(alt, back))
            out.append(Leg3(leg, rtl_span, rtl_span, (frame, "relative")))
            if program.vehicle == "copter":
                out.append(Leg3(Leg(leg.flight, leg.seq, "rtl-descent", leg.end, leg.end), _level(rtl_span[1]), _level(0.0)))
        elif leg.what == "rtl-loiter":
            out.append(Leg3(leg, rtl_span, rtl_span))
        else:
            raise ValueError(f"{flight}: leg {leg.seq} ({leg.what}) has no height model")
    return out


def _rtl_altitude(program: FlightProgram, alt: float, rtl_m: float | None) -> float:
    """The altitude RTL flies to: a rally point's, else where it is when it returns home. With the vehicle's own
    RTL altitude `rtl_m`, a copter climbs to it when lower (ArduCopter and PX4 climb to at least it, rally point
    or home) and a plane returns home at it (a plane flies to a rally point at the point's altitude)."""
    lat0, lon0, _ = program.home
    last = (program.waypoints[-1].lat, program.waypoints[-1].lon) if program.waypoints else (lat0, lon0)
    to = rtl_target(program.vehicle, (lat0, lon0), [(r[0], r[1]) for r in program.rally], last)
    rally = next((r[2] for r in program.rally if (r[0], r[1]) == to), None)
    if rtl_m is None:
        return alt if rally is None else rally
    if program.vehicle == "copter":
        return max(alt, rtl_m, rally or 0.0)
    return rtl_m if rally is None else rally
