"""PX4 missions through MAVSDK's mission_raw plugin (mavsdk 4.x native binding).

PX4 numbers mission items from 0 (no home item) and reads the MAVLink commands the
builder writes for it: NAV_TAKEOFF, NAV_WAYPOINT (a fixed heading in param4),
DO_CHANGE_SPEED, DO_SET_CAM_TRIGG_DIST / DO_SET_CAM_TRIGG_INTERVAL, NAV_RETURN_TO_LAUNCH,
NAV_LAND, DO_LAND_START. The upload is read back and compared item by item.
"""

from __future__ import annotations

import math
import struct

from aerosurvey.errors import CheckFailed, InputError
from aerosurvey.mission.items import Mission

MISSION_TYPE_MISSION = 0


def _f32(v: float) -> float:
    return struct.unpack("f", struct.pack("f", v))[0]


def px4_items(m: Mission) -> list:
    """The mission as MAVSDK mission_raw items (seq from 0, lat/lon in 1e-7 degrees)."""
    from mavsdk.plugins import mission_raw as mr

    if m.firmware != "px4":
        raise InputError(f"the mission is planned for {m.firmware}; plan it with vehicle.firmware = 'px4' for PX4")
    out = []
    for seq, it in enumerate(m.items):
        p = [0.0 if math.isnan(v) else float(v) for v in it.params]
        out.append(mr.MissionItem(seq=seq, frame=it.frame, command=it.command, current=1 if seq == 0 else 0,
                                  autocontinue=1 if it.autocontinue else 0, param1=p[0], param2=p[1], param3=p[2],
                                  param4=p[3], x=int(round(it.x * 1e7)), y=int(round(it.y * 1e7)), z=float(it.z),
                                  mission_type=MISSION_TYPE_MISSION))
    return out


def compare(expected: list, actual: list) -> list[str]:
    """Differences between what was sent and what the vehicle holds, one line each."""
    diffs = []
    if len(expected) != len(actual):
        diffs.append(f"the vehicle holds {len(actual)} items, {len(expected)} were sent")
    for a, b in zip(expected, actual):
        for field in ("command", "frame", "x", "y"):
            if getattr(a, field) != getattr(b, field):
                diffs.append(f"item {a.seq}: {field} sent {getattr(a, field)}, stored {getattr(b, field)}")
        for field in ("param1", "param2", "param3", "param4", "z"):
            if abs(_f32(getattr(a, field)) - _f32(getattr(b, field))) > 1e-4 * max(1.0, abs(getattr(a, field))):
                diffs.append(f"item {a.seq}: {field} sent {getattr(a, field)}, stored {getattr(b, field)}")
    return diffs


def upload_px4(url: str, m: Mission, timeout_s: float = 10.0) -> int:
    """Upload to a PX4 vehicle at `url` (e.g. udp://:14540) and verify; returns the item count."""
    import mavsdk
    from mavsdk.plugins import mission_raw as mr

    items = px4_items(m)
    sdk = mavsdk.Mavsdk(mavsdk.Configuration.create_with_component_type(mavsdk.ComponentType.GROUND_STATION))
    try:
        result = sdk.add_any_connection(url)
        if "SUCCESS" not in str(result).upper():
            raise CheckFailed(f"{url}: MAVSDK could not open the connection ({result})")
        system = sdk.first_autopilot(timeout_s)
        if system is None:
            raise CheckFailed(f"{url}: no autopilot within {timeout_s:g} s")
        raw = mr.MissionRaw(system)
        raw.upload_mission(items)
        diffs = compare(items, list(raw.download_mission()))
        if diffs:
            raise CheckFailed("the PX4 vehicle stores a different mission: " + "; ".join(diffs[:5]))
        return len(items)
    finally:
        sdk.destroy()
