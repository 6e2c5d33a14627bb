"""Where a plane's landing approach starts, and how far a plane circles home after RTL."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from aerosurvey.spec import MissionSpec

#: ArduPlane circles home after RTL at WP_LOITER_RAD (default 60 m; RTL_RADIUS 0 uses it)
PLANE_RTL_LOITER_M = 60.0
#: a plane's NAV_TAKEOFF pitch (param1): it climbs straight ahead at this angle to the take-off altitude
PLANE_TAKEOFF_PITCH_DEG = 15.0


def climb_at_pitch_m(altitude_m: float, pitch_deg: float = PLANE_TAKEOFF_PITCH_DEG) -> float:
    """How far a plane flies straight ahead while it climbs to `altitude_m` at `pitch_deg`: the take-off's climb-out
    the zones are checked along (the planner's, `climb_out_m`, and the exported mission's, `mission.gate`)."""
    return max(altitude_m, 0.0) / math.tan(math.radians(pitch_deg))


def climb_out_m(spec: MissionSpec, altitude_m: float) -> float:
    """How far a plane flies straight ahead while it climbs to `altitude_m` (0 for a copter)."""
    return climb_at_pitch_m(altitude_m) if spec.vehicle.type == "plane" else 0.0


@dataclass(frozen=True)
class Landing:
    """How a flight ends: "land" at its launch point or "rtl"; a plane that lands flies its
    approach from `approach_m` downwind (into the wind from `wind_from_deg`) at `approach_alt_m`."""

    end: str
    approach_m: float | None = None  # None: no approach (a copter, or RTL)
    wind_from_deg: float = 0.0
    approach_alt_m: float = 0.0

    @classmethod
    def of(cls, spec: MissionSpec) -> Landing:
        f = spec.flight
        if not lands_with_approach(spec):
            return cls(f.end)
        assert f.wind_from_deg is not None
        return cls(f.end, f.approach_m, f.wind_from_deg, f.approach_alt_m)

    def approach_lonlat(self, lon: float, lat: float) -> tuple[float, float]:
        """The approach waypoint `approach_m` downwind of the touchdown point at (lon, lat)."""
        assert self.approach_m is not None, "a landing without an approach"
        back = math.radians((self.wind_from_deg + 180.0) % 360.0)
        d_north, d_east = self.approach_m * math.cos(back), self.approach_m * math.sin(back)
        return lon + d_east / (111_320.0 * math.cos(math.radians(lat))), lat + d_north / 111_320.0


XY = tuple[float, float]


def way_home(via: Sequence[XY], end: XY, home: XY) -> list[XY]:
    """A flight's way home after its last place, the one path of the whole mission's estimate and of each sortie's:
    the detours `via` to where the way home ends (`end`: a landing plane's approach waypoint, else the launch point),
    then on to the touchdown at `home` where that is another place (the approach, flown at the landing speed:
    `flight_time.plane_transit_time`)."""
    return [*via, *([end] if end != home else []), home]


def lands_with_approach(spec: MissionSpec) -> bool:
    return spec.vehicle.type == "plane" and spec.flight.end == "land"


def home_clearance_m(spec: MissionSpec) -> float:
    """How far from every zone's margin the launch point must lie: a plane ending with RTL
    circles it at the loiter radius."""
    return PLANE_RTL_LOITER_M if spec.vehicle.type == "plane" and spec.flight.end == "rtl" else 0.0
