"""QGroundControl .plan files (JSON): write and read SimpleItem missions with a geofence.

Field names and enums follow QGroundControl's plan format (version 1 file, mission
version 2, SimpleItem with a 7-value params array; AltitudeMode 1 relative, 2 absolute,
4 terrain frame). The manifest tag of an item is not stored: MAVLink has no place for it.
"""

from __future__ import annotations

import json
import math
from typing import Any

from aerosurvey.errors import InputError
from aerosurvey.mission import mavlink_ids as mav
from aerosurvey.mission.items import Mission, MissionItem

_ALT_MODE = {mav.FRAME_GLOBAL_RELATIVE_ALT: 1, mav.FRAME_GLOBAL: 2, mav.FRAME_GLOBAL_TERRAIN_ALT: 4}
_FIRMWARE = {"ardupilot": mav.AUTOPILOT_ARDUPILOTMEGA, "px4": mav.AUTOPILOT_PX4}
_VEHICLE = {"copter": mav.TYPE_QUADROTOR, "plane": mav.TYPE_FIXED_WING}


def _num(v: float) -> float | int | None:
    if isinstance(v, float) and math.isnan(v):
        return None
    if float(v).is_integer() and abs(v) < 2**53:
        return int(v)
    return v


def _item_dict(it: MissionItem, jump_id: int) -> dict[str, Any]:
    d: dict[str, Any] = {
        "autoContinue": bool(it.autocontinue),
        "command": it.command,
        "doJumpId": jump_id,
        "frame": it.frame,
        "params": [_num(v) for v in (*it.params, it.x, it.y, it.z)],
        "type": "SimpleItem",
    }
    if it.has_position:
        d["AMSLAltAboveTerrain"] = None
        d["Altitude"] = _num(it.z)
        d["AltitudeMode"] = _ALT_MODE.get(it.frame, 1)
    return d


def mission_to_plan_dict(m: Mission) -> dict[str, Any]:
    polygons = [{"inclusion": True, "polygon": [[lat, lon] for lat, lon in poly], "version": 1} for poly in m.fence_inclusion]
    polygons += [{"inclusion": False, "polygon": [[lat, lon] for lat, lon in poly], "version": 1} for poly in m.fence_exclusion]
    frames = {it.frame for it in m.items if it.has_position}
    return {
        "fileType": "Plan",
        "geoFence": {"circles": [], "polygons": polygons, "version": 2},
        "groundStation": "QGroundControl",
        "mission": {
            "cruiseSpeed": _num(m.cruise_speed),
            "firmwareType": _FIRMWARE[m.firmware],
            "globalPlanAltitudeMode": _ALT_MODE.get(frames.pop(), 1) if len(frames) == 1 else 0,
            "hoverSpeed": _num(m.hover_speed),
            "items": [_item_dict(it, i + 1) for i, it in enumerate(m.items)],
            "plannedHomePosition": [_num(v) for v in m.home],
            "vehicleType": _VEHICLE[m.vehicle],
            "version": 2,
        },
        "rallyPoints": {"points": [], "version": 2},
        "version": 1,
    }


def dumps_plan(m: Mission) -> str:
    """The plan as JSON text: fixed key order, indent 4, newline at the end (deterministic)."""
    return json.dumps(mission_to_plan_dict(m), indent=4, allow_nan=False) + "\n"


def _f(v: Any, where: str) -> float:
    if v is None:
        return math.nan
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise InputError(f"{where} = {v!r} is not a number")
    return float(v)


def loads_plan(text: str, source: str = "<string>") -> Mission:
    """A Mission from QGroundControl plan text; ComplexItems are refused with a reason."""
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"{source}: not a QGroundControl plan (invalid JSON: {exc})") from None
    if not isinstance(doc, dict) or doc.get("fileType") != "Plan":
        raise InputError(f"{source}: fileType is {doc.get('fileType') if isinstance(doc, dict) else None!r}, not 'Plan'")
    mis = doc.get("mission")
    if not isinstance(mis, dict) or not isinstance(mis.get("items"), list):
        raise InputError(f"{source}: the 'mission' section with its 'items' list is missing")
    firmware = {v: k for k, v in _FIRMWARE.items()}.get(mis.get("firmwareType"), "ardupilot")
    vehicle = {v: k for k, v in _VEHICLE.items()}.get(mis.get("vehicleType"), "copter")
    home = mis.get("plannedHomePosition")
    if not isinstance(home, list) or len(home) != 3:
        raise InputError(f"{source}: mission.plannedHomePosition must be [lat, lon, alt], got {home!r}")
    items = []
    for i, d in enumerate(mis["items"], start=1):
        where = f"{source}: mission item {i}"
        if not isinstance(d, dict):
            raise InputError(f"{where} is not an object")
        if d.get("type") != "SimpleItem":
            raise InputError(f"{where} is a {d.get('type')!r} ({d.get('complexItemType', '')}); aerosurvey reads SimpleItems "
                             "only: in QGroundControl, convert survey/corridor items to simple waypoints first")
        for key in ("command", "frame", "params"):
            if key not in d:
                raise InputError(f"{where}: field '{key}' is missing")
        params = d["params"]
        if not isinstance(params, list) or len(params) != 7:
            raise InputError(f"{where}: field 'params' must hold 7 values, got {params!r}")
        vals = [_f(v, f"{where} params[{k}]") for k, v in enumerate(params)]
        if not isinstance(d["command"], int) or not isinstance(d["frame"], int):
            raise InputError(f"{where}: 'command' and 'frame' must be whole numbers")
        items.append(MissionItem(d["command"], d["frame"], *vals, autocontinue=bool(d.get("autoContinue", True))))
    fence = doc.get("geoFence", {}) or {}
    inc, exc = [], []
    for k, poly in enumerate(fence.get("polygons", []) or []):
        pts = tuple((float(a), float(b)) for a, b in poly.get("polygon", []))
        if len(pts) < 3:
            raise InputError(f"{source}: geoFence polygon {k + 1} has fewer than 3 points")
        (inc if poly.get("inclusion", True) else exc).append(pts)
    return Mission(
        vehicle=vehicle, firmware=firmware, home=(_f(home[0], "home lat"), _f(home[1], "home lon"), _f(home[2], "home alt")),
        items=tuple(items), cruise_speed=_f(mis.get("cruiseSpeed", 0.0), "cruiseSpeed"),
        hover_speed=_f(mis.get("hoverSpeed", 0.0), "hoverSpeed"), fence_inclusion=tuple(inc), fence_exclusion=tuple(exc),
    )
