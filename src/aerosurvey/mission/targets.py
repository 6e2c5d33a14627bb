"""What each target holds: the limits of the autopilots and controllers aerosurvey writes
missions for, in one place.

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
