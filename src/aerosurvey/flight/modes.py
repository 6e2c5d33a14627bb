"""Flight modes from flight logs: the mode the vehicle flew in at each camera event.

A log records each change of the flight mode: an ArduPilot DataFlash log a MODE message (the
mode's number, and from ArduPilot 4.0 on the reason, Rsn), a MAVLink telemetry log the
autopilot's HEARTBEAT (custom_mode), a PX4 ULog the vehicle_status topic (nav_state). A
mode's number means a mode only for one firmware: ArduCopter's AUTO is 3, ArduPlane's 10. The
firmware is the one the log names (a DataFlash log's MSG text "ArduCopter V4.5.7 …" or VER
message, a HEARTBEAT's autopilot and vehicle type), else the plan's vehicle.

The mission's own mode (ArduPilot's AUTO, PX4's AUTO_MISSION, `MISSION_MODES`) is the one in
which the photos are the planned ones: ArduPilot keeps triggering by distance in every mode
(CAM_AUTO_ONLY = 0, its default), so a return to launch across the lines takes photos too.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aerosurvey.flight.dataflash import DataFlashLog

#: the modes in which a vehicle flies its mission: ArduCopter's and ArduPlane's AUTO, PX4's Mission
MISSION_MODES = frozenset({"AUTO", "AUTO_MISSION"})

#: ArduPilot's ModeReason (libraries/AP_Vehicle/ModeReason.h), as its own strings name them
_REASONS = ("Unknown", "RC Command", "GCS Command", "Radio Failsafe", "Battery Failsafe", "GCS Failsafe",
            "EKF Failsafe", "GPS Glitch", "Mission End", "Throttle Land Escape", "Fence Breached", "Terrain Failsafe",
            "Brake Timeout", "Flip Complete", "Avoidance", "Avoidance Recovery", "Throw Complete", "Terminate",
            "Toy Mode", "Crash Failsafe")

#: PX4's vehicle_status nav_state (msg/VehicleStatus.msg); the free slots are left out
_PX4_NAV_STATES = {0: "MANUAL", 1: "ALTCTL", 2: "POSCTL", 3: "AUTO_MISSION", 4: "AUTO_LOITER", 5: "AUTO_RTL",
                   6: "POSITION_SLOW", 10: "ACRO", 12: "DESCEND", 13: "TERMINATION", 14: "OFFBOARD", 15: "STAB",
                   17: "AUTO_TAKEOFF", 18: "AUTO_LAND", 19: "AUTO_FOLLOW_TARGET", 20: "AUTO_PRECLAND", 21: "ORBIT",
                   22: "AUTO_VTOL_TAKEOFF"}
#: PX4's HEARTBEAT custom_mode (px4_custom_mode.h): main mode, and the AUTO sub-modes, named as nav_state names them
_PX4_MAIN = {1: "MANUAL", 2: "ALTCTL", 3: "POSCTL", 5: "ACRO", 6: "OFFBOARD", 7: "STAB", 10: "TERMINATION"}
_PX4_AUTO = {2: "AUTO_TAKEOFF", 3: "AUTO_LOITER", 4: "AUTO_MISSION", 5: "AUTO_RTL", 6: "AUTO_LAND",
             8: "AUTO_FOLLOW_TARGET", 9: "AUTO_PRECLAND", 10: "AUTO_VTOL_TAKEOFF"}

#: MAVLink's MAV_TYPE of the vehicles an ArduCopter or an ArduPlane reports
_COPTER_TYPES = frozenset({2, 3, 4, 13, 14, 15, 29})  # quad, coaxial, helicopter, hexa, octo, tri, dodeca
_PLANE_TYPES = frozenset({1, 19, 20, 21, 22, 23, 24})  # fixed wing and the VTOL planes
_MAV_AUTOPILOT_ARDUPILOT, _MAV_AUTOPILOT_PX4, _MAV_COMP_AUTOPILOT = 3, 12, 1

#: a DataFlash log's firmware line (MSG) and its VER message's vehicle build type (APM_BUILD_*)
_FIRMWARE_TEXT = re.compile(rb"\b(ArduCopter|APM:Copter|ArduPlane|APM:Plane)\b")
_BUILD_TYPES = {2: "copter", 3: "plane", 13: "copter"}  # ArduCopter, ArduPlane, Heli
#: the changes listed in log_report.json's `modes.changes` (all are counted)
MAX_CHANGES = 50


@dataclass(frozen=True)
class Modes:
    """The flight modes a log records, as a step function of time in the camera events' clock:
    mode `name[k]` from `time_s[k]` on. `source` is empty when the log records none (`note`
    says why)."""

    source: str  # "MODE", "HEARTBEAT", "vehicle_status", or ""
    firmware: str  # "ArduCopter", "ArduPlane", "PX4", or "" when unknown
    firmware_from: str  # where the firmware was found: "log", "plan", or ""
    time_s: np.ndarray
    name: tuple[str, ...]
    reason: tuple[str | None, ...]  # why the mode was entered (ArduPilot's Rsn), where logged
    note: str | None = None

    def at(self, t: np.ndarray) -> list[str | None]:
        """The mode at each time (None before the first mode logged, or for a time that is not a number)."""
        if not len(self.time_s):
            return [None] * len(t)
        k = np.searchsorted(self.time_s, np.asarray(t, float), side="right") - 1
        return [self.name[i] if i >= 0 and np.isfinite(x) else None for i, x in zip(k.tolist(), np.asarray(t, float))]


def _none(note: str, firmware: str = "", firmware_from: str = "") -> Modes:
    return Modes("", firmware, firmware_from, np.zeros(0), (), (), note)


def _changes(t: np.ndarray, names: list[str], reasons: list[str | None], source: str, firmware: str,
             firmware_from: str) -> Modes:
    """The samples (time, name, reason) in time order, each run of one mode once (its first sample)."""
    order = np.argsort(t, kind="stable")
    keep = [int(i) for k, i in enumerate(order) if np.isfinite(t[i]) and (k == 0 or names[i] != names[order[k - 1]])]
    return Modes(source, firmware, firmware_from, t[keep], tuple(names[i] for i in keep),
                 tuple(reasons[i] for i in keep))


def _dataflash_firmware(log: DataFlashLog) -> str:
    """"copter", "plane" or "" from the log's firmware line (MSG) or its VER message."""
    for text in log.messages("MSG").get("Message", ()):
        found = _FIRMWARE_TEXT.search(bytes(text))
        if found:
            return "plane" if found.group(1).endswith(b"Plane") else "copter"
    builds = {_BUILD_TYPES.get(int(b), "") for b in log.messages("VER").get("BU", ())} - {""}
    return builds.pop() if len(builds) == 1 else ""


def _ardupilot_name(vehicle: str, number: int) -> str:
    from pymavlink import mavutil

    table = mavutil.mode_mapping_apm if vehicle == "plane" else mavutil.mode_mapping_acm
    return str(table.get(number, f"MODE_{number}"))


def _firmware_name(vehicle: str) -> str:
    return {"copter": "ArduCopter", "plane": "ArduPlane"}[vehicle]


def from_dataflash(path: Path, plan_vehicle: str | None = None) -> Modes:
    """The MODE messages of an ArduPilot DataFlash log, named for the firmware that wrote it."""
    with DataFlashLog(path) as log:
        mode = log.messages("MODE")
        vehicle = _dataflash_firmware(log)
    found = "log" if vehicle else ""
    if not vehicle and plan_vehicle in ("copter", "plane"):
        vehicle, found = plan_vehicle, "plan"
    firmware = _firmware_name(vehicle) if vehicle else ""
    if not mode:
        return _none("the log records no flight modes (no MODE messages)", firmware, found)
    if "TimeUS" in mode:
        t = np.asarray(mode["TimeUS"], float) / 1e6
    elif "TimeMS" in mode:
        t = np.asarray(mode["TimeMS"], float) / 1e3
    else:
        return _none("the log's MODE messages carry no time (a layout before ArduPilot 3.2)", firmware, found)
    if not vehicle:
        return _none("the log does not name its firmware (no MSG or VER message) and no plan says the vehicle: "
                     "a MODE number means a mode only for one firmware", firmware, found)
    column = next((c for c in ("ModeNum", "Mode") if c in mode), None)
    if column is None:
        return _none("the log's MODE messages have no mode column that decodes (a damaged FMT record)", firmware, found)
    numbers = np.asarray(mode[column], int)
    names = [_ardupilot_name(vehicle, int(n)) for n in numbers]
    rsn = mode.get("Rsn")
    reasons: list[str | None] = [None] * len(t) if rsn is None else \
        [_REASONS[int(r)] if int(r) < len(_REASONS) else f"reason {int(r)}" for r in rsn]
    return _changes(t, names, reasons, "MODE", firmware, found)


def _heartbeat_mode(m: Any) -> tuple[str, str] | None:
    """(firmware, mode name) of an autopilot's HEARTBEAT, None for another sender or vehicle."""
    autopilot, kind, custom = m.autopilot, m.type, int(m.custom_mode)
    if autopilot == _MAV_AUTOPILOT_PX4:
        main, sub = (custom >> 16) & 0xFF, (custom >> 24) & 0xFF
        name = _PX4_AUTO.get(sub, f"AUTO_{sub}") if main == 4 else _PX4_MAIN.get(main, f"MAIN_MODE_{main}")
        return "PX4", name
    if autopilot != _MAV_AUTOPILOT_ARDUPILOT:
        return None
    vehicle = "copter" if kind in _COPTER_TYPES else "plane" if kind in _PLANE_TYPES else None
    if vehicle is None:
        return None
    return _firmware_name(vehicle), _ardupilot_name(vehicle, custom)


def from_tlog(path: Path) -> Modes:
    """The autopilot's HEARTBEATs of a MAVLink telemetry log, at its camera events.

    A HEARTBEAT carries no time of the vehicle's clock, and CAMERA_FEEDBACK's time is the
    camera's (UNIX time): the mode at an event is that of the last HEARTBEAT before it in the
    log, and the step function is sampled at the events' own times."""
    # the events' reader walks the packets: one walker, damage skipped alike
    from aerosurvey.flight.events import tlog_messages

    msgs = tlog_messages(path)
    current: tuple[str, str] | None = None
    firmware = ""
    times: list[float] = []
    names: list[str] = []
    for m in msgs:
        kind = m.get_type()
        if kind == "HEARTBEAT" and m.get_srcComponent() == _MAV_COMP_AUTOPILOT:
            current = _heartbeat_mode(m) or current
            firmware = current[0] if current else firmware
        elif kind == "CAMERA_FEEDBACK" and current is not None:
            times.append(float(m.time_usec))
            names.append(current[1])
    if not firmware:
        return _none("the telemetry log holds no autopilot HEARTBEAT of an ArduPilot copter or plane or of PX4")
    t = np.asarray(times, float) / 1e6  # as the events' reader makes their times
    return _changes(t, names, [None] * len(names), "HEARTBEAT", firmware, "log")


def from_ulog(path: Path) -> Modes:
    """vehicle_status.nav_state of a PX4 ULog."""
    from pyulog import ULog

    try:
        u = ULog(str(path), ["vehicle_status"])
    except Exception as exc:  # pyulog raises plain exceptions for files it cannot parse
        return _none(f"the ULog's vehicle_status cannot be read ({exc})", "PX4", "log")
    data = [d for d in u.data_list if d.name == "vehicle_status" and "nav_state" in d.data]
    if not data:
        return _none("the ULog has no vehicle_status topic with nav_state", "PX4", "log")
    d = data[0].data
    t = np.asarray(d["timestamp"], float) / 1e6
    names = [_PX4_NAV_STATES.get(int(n), f"NAV_STATE_{int(n)}") for n in d["nav_state"]]
    return _changes(t, names, [None] * len(names), "vehicle_status", "PX4", "log")


def read_modes(path: Path, plan_vehicle: str | None = None) -> Modes:
    """The flight modes of a log (.bin/.log, .tlog, .ulg; the events' reader has checked its type);
    none for a folder of photos (a DJI flight's record: its photos carry no flight mode)."""
    if path.is_dir():
        return _none("a folder of photos records no flight mode")
    suffix = path.suffix.lower()
    if suffix in (".bin", ".log"):
        return from_dataflash(path, plan_vehicle)
    if suffix == ".tlog":
        return from_tlog(path)
    return from_ulog(path)


def modes_report(modes: Modes, at_events: list[str | None]) -> dict[str, Any]:
    """log_report.json's `modes`: where they came from, the changes, the camera events per mode."""
    counts: dict[str, int] = {}
    for name in at_events:
        if name is not None:
            counts[name] = counts.get(name, 0) + 1
    changes = [{"time_s": round(float(t), 3), "mode": n, "reason": r}
               for t, n, r in zip(modes.time_s.tolist(), modes.name, modes.reason)]
    return {"source": modes.source or None, "firmware": modes.firmware or None, "firmware_from": modes.firmware_from or None,
            "changes": changes[:MAX_CHANGES], "change_count": len(changes), "events_by_mode": counts,
            "events_without_mode": sum(n is None for n in at_events),
            "events_in_mission_mode": sum(n in MISSION_MODES for n in at_events), "note": modes.note}


def modes_text(report: dict[str, Any]) -> str:
    """One line of what the modes say about the camera events (the command's output)."""
    counts = report["events_by_mode"]
    if not counts:
        return f"flight modes: none known ({report['note'] or 'no mode logged before the camera events'}); events.csv's mode is empty"
    parts = ", ".join(f"{n} in {m}" for m, n in sorted(counts.items(), key=lambda kv: -kv[1]))
    unknown = report["events_without_mode"]
    return (f"flight modes ({report['source']}, {report['firmware']}): camera events {parts}"
            + (f", {unknown} before the first mode logged" if unknown else ""))
