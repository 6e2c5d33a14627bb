"""The vehicle's own settings a mission depends on: which parameters, what the mission needs of them.

Pure: the parameters' values come in (as `MavLink.read_params` read them with PARAM_REQUEST_READ),
the mission and the plan's figures come in, and each check gives a `Finding`: passed, refused
(one line naming the parameter, its value and what the mission needs) or not checked (the line
says why: the mission does not need it, or the figures it needs are missing). `SETTINGS` is the
one table of the parameters read, ArduPilot's and PX4's; docs/upload.md shows it.

A parameter the vehicle did not answer is "not answered": when the vehicle answered others it
does not have that one (a firmware without it, e.g. ArduPilot built without terrain, PX4 v1.14
and later without MIS_DIST_WPS); when it answered none, nothing is known of its settings. A
check that needs a parameter nobody answered refuses; the pilot may name it with `--accept`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from aerosurvey.mission import mavlink_ids as mav
from aerosurvey.mission.items import Mission

# the checks, by the names `--accept` takes
TERRAIN = "terrain"
CAMERA = "camera"
RTL = "rtl-altitude"
SPEED = "speed"
BATTERY = "battery-failsafe"
LEGS = "leg-length"
CHECKS = (TERRAIN, CAMERA, RTL, SPEED, BATTERY, LEGS)

ARDUPILOT = "ardupilot"
PX4 = "px4"


@dataclass(frozen=True)
class Setting:
    """One parameter read before an upload: its name, the check that reads it, the autopilot and
    vehicle (None: copters and planes) that have it, the factor to its unit, and what it means."""

    name: str
    check: str
    firmware: str
    vehicle: str | None
    scale: float
    unit: str
    meaning: str


SETTINGS: tuple[Setting, ...] = (
    Setting("TERRAIN_ENABLE", TERRAIN, ARDUPILOT, None, 1, "", "1: terrain data in use; 0: terrain-frame altitudes are "
            "flown as heights above home once armed (ArduPilot #32942). No answer: built without terrain"),
    Setting("CAM1_TYPE", CAMERA, ARDUPILOT, None, 1, "", "camera 1's trigger (ArduPilot 4.5 and later): 0 none, 1 servo, "
            "2 relay, 3 GoPro, 4 mount, 5 MAVLink, 6 MAVLink camera v2, 7 scripting, 8 RunCam"),
    Setting("CAM_TRIGG_TYPE", CAMERA, ARDUPILOT, None, 1, "", "the camera trigger before ArduPilot 4.5 (0 servo, 1 relay, "
            "2 GoPro, 3 mount): a camera is always there"),
    Setting("TRIG_MODE", CAMERA, PX4, None, 1, "", "0 disabled, 1 by time on command, 2 by time always, 3 by distance "
            "always, 4 by distance on command (the mission's DO_SET_CAM_TRIGG_DIST switches it)"),
    Setting("TRIG_INTERFACE", CAMERA, PX4, None, 1, "", "how the camera is wired: 1 GPIO, 2 Seagull MAP2, 3 MAVLink, "
            "4 generic PWM (reported)"),
    Setting("RTL_ALT", RTL, ARDUPILOT, "copter", 0.01, "m", "the altitude above home RTL climbs to before it returns "
            "(cm); 0: it returns where it is"),
    Setting("RTL_ALTITUDE", RTL, ARDUPILOT, "plane", 1, "m", "the altitude above home RTL returns at (ArduPlane 4.5 and "
            "later); -1: where it is"),
    Setting("ALT_HOLD_RTL", RTL, ARDUPILOT, "plane", 0.01, "m", "the same before ArduPlane 4.5 (cm); -1: where it is"),
    Setting("RTL_RETURN_ALT", RTL, PX4, None, 1, "m", "the altitude above home RTL climbs to before it returns"),
    Setting("WPNAV_SPEED", SPEED, ARDUPILOT, "copter", 0.01, "m/s", "the speed in missions until a DO_CHANGE_SPEED "
            "(cm/s); a DO_CHANGE_SPEED replaces it, uncapped"),
    Setting("AIRSPEED_MAX", SPEED, ARDUPILOT, "plane", 1, "m/s", "the highest airspeed (ArduPlane 4.5 and later): a "
            "DO_CHANGE_SPEED airspeed above it is cut to it"),
    Setting("ARSPD_FBW_MAX", SPEED, ARDUPILOT, "plane", 1, "m/s", "the same before ArduPlane 4.5"),
    Setting("AIRSPEED_CRUISE", SPEED, ARDUPILOT, "plane", 1, "m/s", "the airspeed in missions until a DO_CHANGE_SPEED "
            "(ArduPlane 4.5 and later)"),
    Setting("TRIM_ARSPD_CM", SPEED, ARDUPILOT, "plane", 0.01, "m/s", "the same before ArduPlane 4.5 (cm/s)"),
    Setting("MPC_XY_VEL_MAX", SPEED, PX4, "copter", 1, "m/s", "the highest horizontal speed: a DO_CHANGE_SPEED above "
            "it is cut to it"),
    Setting("MPC_XY_CRUISE", SPEED, PX4, "copter", 1, "m/s", "the speed in missions until a DO_CHANGE_SPEED"),
    Setting("FW_AIRSPD_MAX", SPEED, PX4, "plane", 1, "m/s", "the highest airspeed: a DO_CHANGE_SPEED above it is cut"),
    Setting("FW_AIRSPD_TRIM", SPEED, PX4, "plane", 1, "m/s", "the airspeed in missions until a DO_CHANGE_SPEED"),
    Setting("BATT_MONITOR", BATTERY, ARDUPILOT, None, 1, "", "0: no battery monitor, so no battery failsafe"),
    Setting("BATT_FS_LOW_ACT", BATTERY, ARDUPILOT, None, 1, "", "the low-battery failsafe's action; 0: none"),
    Setting("BATT_LOW_MAH", BATTERY, ARDUPILOT, None, 1, "mAh", "the charge left that triggers it; 0: by voltage only "
            "(BATT_LOW_VOLT)"),
    Setting("BATT_CAPACITY", BATTERY, ARDUPILOT, None, 1, "mAh", "the battery's capacity"),
    Setting("COM_LOW_BAT_ACT", BATTERY, PX4, None, 1, "", "the battery failsafe's action at BAT_CRIT_THR: 0 a warning "
            "only, 2 land, 3 return (land at BAT_EMERGEN_THR)"),
    Setting("BAT_CRIT_THR", BATTERY, PX4, None, 1, "", "the share of the charge left at which that action comes"),
    Setting("BAT_LOW_THR", BATTERY, PX4, None, 1, "", "the share at which PX4 warns (reported)"),
    Setting("MIS_DIST_WPS", LEGS, PX4, None, 1, "m", "the longest leg between two mission places PX4 v1.13 and earlier "
            "arm with (0 or less: no limit; v1.14 and later have no such parameter)"),
    Setting("MIS_DIST_1WP", LEGS, PX4, None, 1, "m", "not compared: every PX4 has it, so its answer shows that the "
            "vehicle answers parameter requests when MIS_DIST_WPS gets none"),
)

_BY_NAME = {s.name: s for s in SETTINGS}


def settings_for(firmware: str, vehicle: str) -> tuple[str, ...]:
    """The names of the parameters read from a `firmware` `vehicle` ("copter" or "plane")."""
    return tuple(s.name for s in SETTINGS if s.firmware == firmware and s.vehicle in (None, vehicle))


@dataclass(frozen=True)
class PlanFigures:
    """What the checks take from the plan folder's manifest (None: not known, the check says so)."""

    reserve: float | None = None  # the battery's share kept in reserve (battery.reserve)
    ground_above_home_m: float | None = None  # the highest ground under the plan above the launch point's ground (DEM)
    zones_near: tuple[str, ...] | None = None  # official zones near the flights that restrict them; None: no zone file


@dataclass(frozen=True)
class Finding:
    """One check's outcome: `status` "pass", "refuse" or "not checked"; `line` says it with the figures."""

    check: str
    status: str
    line: str


@dataclass(frozen=True)
class Values:
    """The parameters the vehicle answered, in their units (`Setting.scale`); `answered`: it answered any."""

    raw: Mapping[str, float]

    @property
    def answered(self) -> bool:
        return bool(self.raw)

    def get(self, name: str) -> float | None:
        v = self.raw.get(name)
        return None if v is None else v * _BY_NAME[name].scale

    def first(self, *names: str) -> tuple[str, float] | None:
        """The first of `names` the vehicle answered (a parameter renamed between versions), in its unit."""
        for n in names:
            v = self.get(n)
            if v is not None:
                return n, v
        return None

    def said(self, name: str, value: float) -> str:
        """`NAME = raw value` as the vehicle holds it (RTL_ALT = 1500), with the unit aerosurvey reads it in."""
        s = _BY_NAME[name]
        raw = f"{self.raw[name]:g}"
        return f"{name} = {raw}" + (f" ({value:g} {s.unit})" if s.scale != 1 else f" {s.unit}" if s.unit else "")


def _missing(values: Values, names: Sequence[str]) -> str:
    """Why none of `names` has a value: the vehicle has none of them, or it answered no request at all."""
    said = " or ".join(names)
    return f"the vehicle has no {said}" if values.answered else f"{said} not known: the vehicle answered no parameter request"


#: MAV_FRAME_GLOBAL_TERRAIN_ALT(_INT) and MAV_FRAME_GLOBAL_RELATIVE_ALT(_INT)
_TERRAIN_FRAMES = (mav.FRAME_GLOBAL_TERRAIN_ALT, 11)
_RELATIVE_FRAMES = (mav.FRAME_GLOBAL_RELATIVE_ALT, 6)


def _terrain(m: Mission, values: Values) -> Finding:
    n = sum(1 for it in m.items if it.frame in _TERRAIN_FRAMES)
    if m.firmware != ARDUPILOT or n == 0:
        return Finding(TERRAIN, "not checked", "terrain: no item in the terrain frame")
    needs = f"the mission flies {n} item(s) in the terrain frame"
    v = values.get("TERRAIN_ENABLE")
    if v is None:
        return Finding(TERRAIN, "refuse", f"{_missing(values, ['TERRAIN_ENABLE'])} but {needs}: ArduPilot without terrain "
                                          "data flies them as heights above home; plan it with relative altitudes")
    if v == 0:
        return Finding(TERRAIN, "refuse", f"TERRAIN_ENABLE = 0 but {needs}: ArduPilot without terrain data flies them as "
                                          "heights above home; set TERRAIN_ENABLE = 1 (with terrain data on its SD card "
                                          "or from the ground station), or plan it with relative altitudes")
    return Finding(TERRAIN, "pass", f"terrain: TERRAIN_ENABLE = {v:g} for {n} item(s) in the terrain frame")


def _photo_items(m: Mission) -> list[str]:
    """The items that take photos: DO_SET_CAM_TRIGG_DIST and _INTERVAL with a distance or an
    interval, DO_DIGICAM_CONTROL, IMAGE_START_CAPTURE."""
    names = {mav.DO_SET_CAM_TRIGG_DIST: "DO_SET_CAM_TRIGG_DIST", mav.DO_SET_CAM_TRIGG_INTERVAL: "DO_SET_CAM_TRIGG_INTERVAL",
             mav.DO_DIGICAM_CONTROL: "DO_DIGICAM_CONTROL", mav.IMAGE_START_CAPTURE: "IMAGE_START_CAPTURE"}
    out = []
    for it in m.items:
        name = names.get(it.command)
        if name is None or (it.command in (mav.DO_SET_CAM_TRIGG_DIST, mav.DO_SET_CAM_TRIGG_INTERVAL) and not it.param1 > 0):
            continue
        out.append(name)
    return out


def _camera(m: Mission, values: Values) -> Finding:
    photos = _photo_items(m)
    if not photos:
        return Finding(CAMERA, "not checked", "camera: no item takes photos")
    kinds = ", ".join(dict.fromkeys(photos))
    needs = f"the mission takes photos with {len(photos)} item(s) ({kinds})"
    if m.firmware == ARDUPILOT:
        got = values.first("CAM1_TYPE", "CAM_TRIGG_TYPE")
        if got is None:
            return Finding(CAMERA, "refuse", f"{_missing(values, ['CAM1_TYPE', 'CAM_TRIGG_TYPE'])} but {needs}: "
                                             "configure the camera (CAM1_TYPE)")
        name, v = got
        if name == "CAM1_TYPE" and v == 0:
            return Finding(CAMERA, "refuse", f"CAM1_TYPE = 0 (no camera) but {needs}: no photo would be taken; set "
                                             "CAM1_TYPE to the camera's trigger (1 servo, 2 relay, 5 MAVLink …) and reboot")
        return Finding(CAMERA, "pass", f"camera: {name} = {v:g}, and {needs}")
    got = values.first("TRIG_MODE")
    if got is None:
        return Finding(CAMERA, "refuse", f"{_missing(values, ['TRIG_MODE'])} but {needs}: set TRIG_MODE = 4")
    v = got[1]
    wiring = values.get("TRIG_INTERFACE")
    via = f", TRIG_INTERFACE = {wiring:g}" if wiring is not None else ""
    by_distance = "DO_SET_CAM_TRIGG_DIST" in photos
    if v == 0 or (by_distance and v != 4):
        what = ("0 (the camera trigger is disabled)" if v == 0 else
                f"{v:g} (not by distance on command: the mission's DO_SET_CAM_TRIGG_DIST would not switch it)")
        return Finding(CAMERA, "refuse", f"TRIG_MODE = {what} but {needs}: set TRIG_MODE = 4 and reboot")
    return Finding(CAMERA, "pass", f"camera: TRIG_MODE = {v:g}{via}, and {needs}")


#: the least a return at the RTL altitude clears the highest ground under the plan by (m): trees and masts
RTL_GROUND_CLEARANCE_M = 30.0


def _return_altitude(m: Mission) -> float | None:
    """The altitude above home the plan's legs flew the return at: that of the last place before the
    mission's NAV_RETURN_TO_LAUNCH, else (a mission that lands) the highest place; None when it is
    not above home (terrain or AMSL frames)."""
    places = [it for it in m.items if it.has_position]
    rtl = next((k for k, it in enumerate(m.items) if it.command == mav.NAV_RETURN_TO_LAUNCH), None)
    if rtl is not None:
        before = [it for it in m.items[:rtl] if it.has_position]
        places = before[-1:] if before else []
    if not places or any(it.frame not in _RELATIVE_FRAMES for it in places):
        return None
    return max(it.z for it in places)


def _rtl_names(firmware: str, vehicle: str) -> list[str]:
    return ["RTL_RETURN_ALT"] if firmware == PX4 else ["RTL_ALT"] if vehicle == "copter" else ["RTL_ALTITUDE", "ALT_HOLD_RTL"]


def rtl_altitude(firmware: str, vehicle: str, params: Mapping[str, float]) -> float | None:
    """The altitude above home (m) the vehicle returns at on RTL, from its parameters (raw values); None when it
    returns at the altitude it is at (0 or less) or does not say."""
    got = Values(params).first(*_rtl_names(firmware, vehicle))
    return got[1] if got is not None and got[1] > 0 else None


def _rtl(m: Mission, vehicle: str, values: Values, plan: PlanFigures) -> Finding:
    names = _rtl_names(m.firmware, vehicle)
    got = values.first(*names)
    if got is None:
        return Finding(RTL, "refuse", f"{_missing(values, names)}: the altitude the vehicle returns at cannot be compared "
                                      "with the ground and the zones")
    name, r = got
    said = values.said(name, r)
    if r <= 0:
        return Finding(RTL, "pass", f"rtl-altitude: {said}: the vehicle returns at the altitude it is at, as the plan's "
                                    "legs were checked")
    problems, notes = [], []
    if plan.ground_above_home_m is None:
        notes.append("the ground on the way home not checked (no DEM figures in the manifest)")
    elif r < plan.ground_above_home_m + RTL_GROUND_CLEARANCE_M:
        problems.append(f"the plan's ground rises {plan.ground_above_home_m:.0f} m above the launch point, and a return at "
                        f"{r:g} m clears it by less than {RTL_GROUND_CLEARANCE_M:g} m")
    else:
        notes.append(f"clears the highest ground under the plan ({plan.ground_above_home_m:.0f} m above the launch point) "
                     f"by {r - plan.ground_above_home_m:.0f} m")
    back = _return_altitude(m)
    if plan.zones_near is None:
        notes.append("no official zone file in the plan")
    elif not plan.zones_near:
        notes.append("no restricting official zone near the flights")
    elif back is None:
        problems.append(f"{len(plan.zones_near)} official zone(s) lie near the flights ({plan.zones_near[0]} …) and the "
                        "return altitude the plan checked is not above home (check not possible)")
    elif r > back:
        problems.append(f"the plan's return was checked at {back:g} m against {len(plan.zones_near)} official zone(s) near "
                        f"the flights ({plan.zones_near[0]}{' …' if len(plan.zones_near) > 1 else ''}), and the vehicle "
                        f"climbs to {r:g} m first")
    else:
        notes.append(f"at or below the {back:g} m the plan's return was checked at against the official zones")
    if problems:
        return Finding(RTL, "refuse", f"{said} but {'; and '.join(problems)}: set {name} to fit, or plan again")
    return Finding(RTL, "pass", f"rtl-altitude: {said}: " + "; ".join(notes))


def _commanded_speed(m: Mission) -> tuple[float, bool] | None:
    """The fastest speed the mission's DO_CHANGE_SPEED items command, and whether it is an airspeed (type 0)."""
    speeds = [(it.param2, it.param1 == 0) for it in m.items if it.command == mav.DO_CHANGE_SPEED and it.param2 > 0]
    return max(speeds) if speeds else None


#: (the cap, the default speed) each autopilot and vehicle reads, each with its names before a rename
_SPEED_NAMES = {(ARDUPILOT, "copter"): ((), ("WPNAV_SPEED",)),
                (ARDUPILOT, "plane"): (("AIRSPEED_MAX", "ARSPD_FBW_MAX"), ("AIRSPEED_CRUISE", "TRIM_ARSPD_CM")),
                (PX4, "copter"): (("MPC_XY_VEL_MAX",), ("MPC_XY_CRUISE",)),
                (PX4, "plane"): (("FW_AIRSPD_MAX",), ("FW_AIRSPD_TRIM",))}
#: how far (m/s) a default speed may lie from the plan's before the mission is flown other than planned
SPEED_TOLERANCE_MS = 0.5


def _speed(m: Mission, vehicle: str, values: Values) -> Finding:
    caps, defaults = _SPEED_NAMES[(m.firmware, vehicle)]
    commanded = _commanded_speed(m)
    if commanded is None:  # the vehicle flies its own default speed
        planned = m.hover_speed if vehicle == "copter" else m.cruise_speed
        got = values.first(*defaults)
        if got is None:
            return Finding(SPEED, "refuse", f"{_missing(values, defaults)} and the mission commands no speed: the speed it "
                                            f"flies at cannot be compared with the planned {planned:g} m/s")
        name, v = got
        if abs(v - planned) > SPEED_TOLERANCE_MS:
            return Finding(SPEED, "refuse", f"{values.said(name, v)} but the mission commands no speed and was planned at "
                                            f"{planned:g} m/s (photo spacing and flight time follow it): set {name} to it")
        return Finding(SPEED, "pass", f"speed: {values.said(name, v)}, the planned {planned:g} m/s (no DO_CHANGE_SPEED)")
    speed, airspeed = commanded
    if not caps:
        return Finding(SPEED, "pass", f"speed: the mission commands {speed:g} m/s; ArduCopter flies it whatever its "
                                      "WPNAV_SPEED")
    if vehicle == "plane" and not airspeed:
        return Finding(SPEED, "not checked", f"speed: the mission commands a ground speed of {speed:g} m/s; "
                                             f"{' or '.join(caps)} caps airspeeds")
    got = values.first(*caps)
    if got is None:
        return Finding(SPEED, "refuse", f"{_missing(values, caps)}: the mission's {speed:g} m/s cannot be compared with "
                                        "the vehicle's limit")
    name, cap = got
    if cap < speed:
        return Finding(SPEED, "refuse", f"{values.said(name, cap)} but the mission commands {speed:g} m/s (DO_CHANGE_SPEED): "
                                        "the vehicle would fly slower and the photos' timing, blur and the flight time "
                                        f"would change; raise {name} to at least {speed:g}")
    return Finding(SPEED, "pass", f"speed: the mission commands {speed:g} m/s, within {values.said(name, cap)}")


def _battery(m: Mission, values: Values, plan: PlanFigures) -> Finding:
    if m.firmware == ARDUPILOT:
        names = ("BATT_MONITOR", "BATT_FS_LOW_ACT", "BATT_LOW_MAH", "BATT_CAPACITY")
        monitor, action, low, capacity = (values.get(n) for n in names)
        if monitor is None or action is None:
            return Finding(BATTERY, "refuse", f"{_missing(values, ['BATT_MONITOR', 'BATT_FS_LOW_ACT'])}: the battery "
                                              "failsafe cannot be checked")
        if monitor == 0 or action == 0:
            what = "BATT_MONITOR = 0 (no battery monitor)" if monitor == 0 else "BATT_FS_LOW_ACT = 0 (no action)"
            return Finding(BATTERY, "refuse", f"{what}: nothing brings the vehicle back on a low battery; the plan keeps "
                                              f"{_share(plan.reserve)} in reserve: set a battery failsafe")
        if plan.reserve is None:
            return Finding(BATTERY, "not checked", f"battery-failsafe: BATT_FS_LOW_ACT = {action:g}; the plan's reserve is "
                                                   "not known (no manifest), so its level is not compared")
        if not low or not capacity:
            said = ", ".join(f"{n} = {v:g}" if v is not None else f"no {n}" for n, v in (("BATT_LOW_MAH", low),
                                                                                          ("BATT_CAPACITY", capacity)))
            return Finding(BATTERY, "not checked", f"battery-failsafe: BATT_FS_LOW_ACT = {action:g}, {said}: by voltage "
                                                   f"only, which cannot be compared with the plan's "
                                                   f"{_share(plan.reserve)} reserve")
        level = low / capacity
        said = f"BATT_LOW_MAH = {low:g} of BATT_CAPACITY = {capacity:g} mAh ({level:.0%})"
        fix = f"raise BATT_LOW_MAH to at least {math.ceil(plan.reserve * capacity)}"
    else:
        action = values.get("COM_LOW_BAT_ACT")
        crit = values.get("BAT_CRIT_THR")
        if action is None or crit is None:
            return Finding(BATTERY, "refuse", f"{_missing(values, ['COM_LOW_BAT_ACT', 'BAT_CRIT_THR'])}: the battery "
                                              "failsafe cannot be checked")
        if action == 0:
            return Finding(BATTERY, "refuse", f"COM_LOW_BAT_ACT = 0 (a warning only): nothing brings the vehicle back on a "
                                              f"low battery; the plan keeps {_share(plan.reserve)} in reserve: set it to 3")
        if plan.reserve is None:
            return Finding(BATTERY, "not checked", f"battery-failsafe: COM_LOW_BAT_ACT = {action:g}; the plan's reserve is "
                                                   "not known (no manifest), so its level is not compared")
        level = crit
        said = f"BAT_CRIT_THR = {crit:g} ({crit:.0%}, COM_LOW_BAT_ACT = {action:g})"
        fix = f"raise BAT_CRIT_THR to at least {plan.reserve:g}"
    if level + 1e-9 < plan.reserve:
        return Finding(BATTERY, "refuse", f"{said} but the plan keeps {plan.reserve:.0%} in reserve: the failsafe would act "
                                          f"only after the reserve is spent; {fix}")
    return Finding(BATTERY, "pass", f"battery-failsafe: {said}, at or above the plan's {plan.reserve:.0%} reserve")


def _share(reserve: float | None) -> str:
    return "an unknown share" if reserve is None else f"{reserve:.0%}"


def check_legs(longest: tuple[float, int, int] | None, values: Values) -> Finding:
    """PX4's MIS_DIST_WPS against the longest leg between consecutive places (`longest`: metres, items)."""
    if longest is None:
        return Finding(LEGS, "not checked", "legs: fewer than two places, nothing to compare")
    d, a, b = longest
    said = f"legs: the longest, items {a} to {b}, is {d:,.0f} m"
    limit = values.get("MIS_DIST_WPS")
    if limit is None:
        if values.answered:
            return Finding(LEGS, "pass", said + "; the vehicle has no MIS_DIST_WPS (PX4 v1.14 and later do not limit legs)")
        return Finding(LEGS, "refuse", f"MIS_DIST_WPS not known: the vehicle answered no parameter request, and the longest "
                                       f"leg, items {a} to {b}, is {d:,.0f} m")
    if limit <= 0:
        return Finding(LEGS, "pass", f"{said}; the vehicle's MIS_DIST_WPS = {limit:g} does not limit legs")
    if d > limit:
        return Finding(LEGS, "refuse", f"mission items {a} and {b} lie {d:,.0f} m apart but the vehicle's MIS_DIST_WPS = "
                                       f"{limit:g} m (PX4 refuses such a mission at arming): plan it again with "
                                       f"vehicle.max_leg_m = {limit:g}, or raise MIS_DIST_WPS")
    return Finding(LEGS, "pass", f"{said}, within the vehicle's MIS_DIST_WPS = {limit:g} m")


def check_settings(m: Mission, vehicle: str, params: Mapping[str, float], plan: PlanFigures,
                   longest: tuple[float, int, int] | None = None) -> list[Finding]:
    """Every check of the table for `m` on a `vehicle` whose parameters answered `params` (raw values);
    `longest`: the longest leg between consecutive places as PX4 reads the wire items (PX4 only)."""
    values = Values(params)
    out = [_terrain(m, values), _camera(m, values), _rtl(m, vehicle, values, plan), _speed(m, vehicle, values),
           _battery(m, values, plan)]
    if m.firmware == PX4:
        out.append(check_legs(longest, values))
    return out


@dataclass(frozen=True)
class Verdict:
    """The findings with the pilot's `--accept` names applied: `refusal` is the first refusal no name
    accepts (one line), `lines` what the report says of every check."""

    refusal: str | None
    lines: tuple[str, ...]


def judge(findings: Sequence[Finding], accept: frozenset[str]) -> Verdict:
    lines: list[str] = []
    refusal = None
    for f in findings:
        if f.status != "refuse":
            lines.append(f.line)
        elif f.check in accept:
            lines.append(f"{f.check}: ACCEPTED by the pilot (--accept {f.check}): {f.line}")
        elif refusal is None:
            refusal = f"{f.line} (or give --accept {f.check})"
    return Verdict(refusal, tuple(lines))
