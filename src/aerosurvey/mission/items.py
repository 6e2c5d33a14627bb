"""The mission model: MAVLink mission items, ready to be split into sorties and written."""

from __future__ import annotations

from dataclasses import dataclass, field

from aerosurvey.mission import mavlink_ids as mav

#: the commands whose x/y/z are a place the vehicle flies to
POSITION_COMMANDS = (mav.NAV_WAYPOINT, mav.NAV_TAKEOFF, mav.NAV_LAND, mav.NAV_VTOL_TAKEOFF, mav.NAV_VTOL_LAND)


@dataclass(frozen=True)
class MissionItem:
    """One MAVLink MISSION_ITEM_INT as it will be uploaded.

    `x`/`y` are latitude/longitude in degrees (0 for items without a position),
    `z` the altitude in metres in `frame`. `tag` links the item to the manifest
    (a station, line or sortie id); it is not part of the MAVLink item.
    """

    command: int
    frame: int = mav.FRAME_GLOBAL_RELATIVE_ALT
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    autocontinue: bool = True
    tag: str = ""

    @property
    def params(self) -> tuple[float, float, float, float]:
        return (self.param1, self.param2, self.param3, self.param4)

    @property
    def has_position(self) -> bool:
        """True for items whose x/y/z are a place the vehicle flies to."""
        return self.command in POSITION_COMMANDS


@dataclass(frozen=True)
class Mission:
    """A flyable mission for one flight: home plus the items after it (sequence 1…n).

    `home` is (latitude, longitude, altitude AMSL in metres); it becomes item 0 in a
    QGC WPL file and `plannedHomePosition` in a QGroundControl plan.
    """

    vehicle: str  # "copter" or "plane"
    firmware: str  # "ardupilot" or "px4"
    home: tuple[float, float, float]
    items: tuple[MissionItem, ...]
    cruise_speed: float
    hover_speed: float
    name: str = "mission"
    fence_inclusion: tuple[tuple[tuple[float, float], ...], ...] = field(default=())
    fence_exclusion: tuple[tuple[tuple[float, float], ...], ...] = field(default=())
    # rally points: (latitude, longitude, altitude above home in metres), where RTL may go instead of home
    rally: tuple[tuple[float, float, float], ...] = field(default=())

    @property
    def autopilot_id(self) -> int:
        return mav.AUTOPILOT_PX4 if self.firmware == "px4" else mav.AUTOPILOT_ARDUPILOTMEGA

    @property
    def vehicle_type_id(self) -> int:
        return mav.TYPE_FIXED_WING if self.vehicle == "plane" else mav.TYPE_QUADROTOR
