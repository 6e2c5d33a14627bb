"""What each target holds: the limits of the autopilots and controllers aerosurvey writes
missions for, in one place, and which DJI aircraft carries which camera (`dji_aircraft`: a
plan writes DJI files, and loads their writer, only for those).

- ArduPilot and PX4: mission items, home included (`spec.MAX_ITEMS`, the default of the
  spec's battery.max_mission_items, which overrides it): ArduCopter 4.7 SITL refuses more than
  650 ("Only 650 items are supported"); PX4's dataman holds 2000.
- DJI WPML (DJI Pilot 2): a wayline's waypoints are numbered by wpml:index, 0 to 65535, and
  an action group's wpml:actionGroupId is 0 to 65535 (DJI Cloud API, DJI WPML reference,
  waylines.wpml and common elements); DJI's Mobile SDK refuses a waypoint mission of more
  than 65535 waypoints or fewer than 2 (WaypointV2Error MISSION_COUNT_OVER_RANGE,
  MISSION_COUNT_TOO_FEW). The speed of a wayline is at most 15 m/s
  (wpml:globalTransitionalSpeed [0, 15]; the Mobile SDK's maximum flight speed).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from aerosurvey.spec import MAX_ITEMS

if TYPE_CHECKING:
    from aerosurvey.plan.sorties import Budget

DJI_MAX_WAYPOINTS = 65535
DJI_MIN_WAYPOINTS = 2
DJI_MAX_ACTION_GROUPS = 65536  # ids 0..65535
DJI_MAX_SPEED_MS = 15.0


def mavlink_item_limit(firmware: str, battery: Budget | None) -> int:
    """Mission items (home included) the autopilot holds: the battery budget's when a battery
    is given (battery.max_mission_items), else the firmware's default."""
    if battery is not None:
        return battery.max_items
    return MAX_ITEMS[firmware]


@dataclass(frozen=True)
class DjiAircraft:
    name: str
    drone_enum: int  # wpml:droneEnumValue
    drone_sub_enum: int  # wpml:droneSubEnumValue
    payload_enum: int  # wpml:payloadEnumValue
    image_format: str  # wpml:imageFormat: which lens' photos are stored


#: DJI WPML reference, common elements (droneEnumValue, payloadEnumValue) and the Cloud API's
#: product list: M3E 77/0 with the Mavic 3E camera 66; M30 67/0 with its camera 52; M350 RTK 89/0
#: with the Zenmuse P1 50 (payloadEnumValue 50 as the reference listed it up to its 2023 versions).
M3E = DjiAircraft("DJI Mavic 3 Enterprise (M3E)", 77, 0, 66, "wide")
M30 = DjiAircraft("DJI Matrice 30 (M30)", 67, 0, 52, "wide")
M350_P1 = DjiAircraft("DJI Matrice 350 RTK with Zenmuse P1", 89, 0, 50, "visible")
#: aerosurvey's camera ids (data/cameras.toml) flown by an aircraft DJI Pilot 2 flies WPML with.
#: The M30's camera is not in cameras.toml: M30 is ready for when it is.
AIRCRAFT_BY_CAMERA = {
    "dji-mavic-3-enterprise": M3E,
    "dji-zenmuse-p1-24mm": M350_P1,
    "dji-zenmuse-p1-35mm": M350_P1,
    "dji-zenmuse-p1-50mm": M350_P1,
}


def dji_aircraft(camera_id: str) -> DjiAircraft | None:
    """The DJI aircraft that carries this camera, or None when it is not one DJI Pilot 2 flies WPML with."""
    return AIRCRAFT_BY_CAMERA.get(camera_id)
