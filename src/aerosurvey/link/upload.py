"""Upload a Mission to a vehicle, read it back and compare item by item; the fence too.

The protocol decisions live in `mission_protocol`; this module turns the mission model into
wire items, pumps a protocol machine over a link, and compares what the vehicle stores with
what was planned. A transfer that did not end with the vehicle's MISSION_ACK(ACCEPTED) for
every item is an error, never a partial success.
"""

from __future__ import annotations

import math
import struct
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Protocol

from aerosurvey.errors import AerosurveyError, CheckFailed, InputError
from aerosurvey.link import mission_protocol as mp
from aerosurvey.link import vehicle_settings as vs
from aerosurvey.link.connection import LinkError, Vehicle
from aerosurvey.mission import mavlink_ids as mav
from aerosurvey.mission.items import Mission, MissionItem
from aerosurvey.mission.legs import PX4_PLACE_COMMANDS, great_circle_m, longest_leg

AUTOPILOT_ARDUPILOT = 3
AUTOPILOT_PX4 = 12
PLANE_TYPES = frozenset({1, *range(19, 26)})  # MAV_TYPE fixed wing and VTOLs: ArduPlane builds
COPTER_TYPES = frozenset({2, 3, 4, 13, 14, 15})  # MAV_TYPE multirotors and helicopters: ArduCopter builds

_COMMAND_NAMES = {v: k for k, v in vars(mav).items()
                  if k.isupper() and not k.startswith(("FRAME_", "AUTOPILOT_", "TYPE_", "GIMBAL_MANAGER_FLAGS_"))}


def command_name(command: int) -> str:
    """The MAV_CMD name of a command aerosurvey writes (`MAV_CMD <number>` for any other)."""
    return _COMMAND_NAMES.get(command, f"MAV_CMD {command}")


class Link(Protocol):
    """What a transfer needs from a link; MavLink implements it, tests add a simulated one."""

    vehicle: Vehicle | None

    def now(self) -> float: ...

    def send(self, msg: mp.Message) -> None: ...

    def recv(self, until: float) -> mp.Message | None: ...


Progress = Callable[[str, int, int], None]
"""Called as `progress(what, done, total)` (e.g. "mission upload", 350, 701) while a transfer runs."""


class VerificationFailed(CheckFailed):
    """The vehicle stores something other than the plan (exit code 1)."""

    def __init__(self, message: str, mismatches: Sequence[Mismatch]) -> None:
        super().__init__(message)
        self.mismatches = list(mismatches)


class DownloadFailed(LinkError):
    """A read-back did not finish; `count` is the number of items the vehicle said it holds, if it said."""

    def __init__(self, message: str, count: int | None) -> None:
        super().__init__(message)
        self.count = count


class UploadFailed(LinkError):
    """An upload did not finish. `confirmed`: the most items the vehicle confirmed, in order, in any
    attempt (None: the transport does not tell); `count`: the items it said it holds when asked
    after the failure (None: it did not say)."""

    def __init__(self, message: str, confirmed: int | None, count: int | None = None) -> None:
        super().__init__(message)
        self.confirmed = confirmed
        self.count = count


# --- the mission model on the wire -------------------------------------------------------

def f32(v: float) -> float:
    """`v` as the float32 MAVLink carries."""
    return struct.unpack("<f", struct.pack("<f", v))[0] if math.isfinite(v) else v


def deg_e7(v: float, what: str) -> int:
    """Degrees as int32 1e-7 degrees; NaN (QGroundControl's "unset") becomes 0 as MAVLink has no NaN integer."""
    if math.isnan(v):
        return 0
    e7 = round(v * 1e7)
    if not -(2**31) <= e7 < 2**31:
        raise InputError(f"{what} = {v!r} degrees does not fit a MAVLink int32 coordinate")
    return e7


def param_int(v: float, what: str) -> int:
    """A command's own parameter 5 or 6 as the plain integer MISSION_ITEM_INT carries (NaN: 0)."""
    if math.isnan(v):
        return 0
    if v != round(v) or not -(2**31) <= v < 2**31:
        raise InputError(f"{what} = {v!r}: a MAVLink mission command takes a whole number there")
    return int(v)


#: commands whose param5/6 are not a position: MISSION_ITEM_INT carries them as plain integers
#: (the exceptions of ArduPilot's AP_Mission::convert_MISSION_ITEM_to_MISSION_ITEM_INT that
#: aerosurvey writes; ArduPilot takes DO_DIGICAM_CONTROL's x as its shooting command, 1 = take a
#: picture; PX4's gimbal manager reads DO_GIMBAL_MANAGER_PITCHYAW's x as its flags, 12 = roll and
#: pitch locked to the horizon, which 1e-7 degrees would make 120,000,000)
PLAIN_XY_COMMANDS = frozenset({mav.DO_DIGICAM_CONTROL, mav.DO_GIMBAL_MANAGER_PITCHYAW})


def item_to_wire(it: MissionItem, seq: int, what: str) -> mp.WireItem:
    """The item as MISSION_ITEM_INT: x/y in 1e-7 degrees, or the parameters themselves for PLAIN_XY_COMMANDS."""
    if it.command in PLAIN_XY_COMMANDS:
        x, y = param_int(it.x, f"{what} param5"), param_int(it.y, f"{what} param6")
    else:
        x, y = deg_e7(it.x, f"{what} latitude"), deg_e7(it.y, f"{what} longitude")
    return mp.WireItem(seq, it.command, it.frame, it.param1, it.param2, it.param3, it.param4, x, y, it.z,
                       1 if it.autocontinue else 0, 0, mp.MISSION)


def home_on_wire(m: Mission) -> bool:
    """ArduPilot keeps home as mission item 0; PX4 does not."""
    return m.firmware == "ardupilot"


def mission_wire_items(m: Mission) -> list[mp.WireItem]:
    """The items to upload: home as seq 0 (frame 0, altitude AMSL) for ArduPilot, then the plan's items."""
    out: list[mp.WireItem] = []
    if home_on_wire(m):
        lat, lon, alt = m.home
        out.append(mp.WireItem(0, mav.NAV_WAYPOINT, mav.FRAME_GLOBAL, x=deg_e7(lat, "home latitude"),
                               y=deg_e7(lon, "home longitude"), z=alt))
    for it in m.items:
        out.append(item_to_wire(it, len(out), f"mission item {len(out)}"))
    return out


def held_mission(m: Mission, held: Sequence[mp.WireItem]) -> Mission:
    """The mission items a vehicle holds (a read-back) as a Mission beside the planned `m`: x/y back to degrees
    (the parameters themselves for PLAIN_XY_COMMANDS); ArduPilot's item 0 is its home (the planned home while it
    has none)."""
    items = list(held)
    home = m.home
    if home_on_wire(m) and items:
        h = items.pop(0)
        if h.x or h.y:
            home = (h.x * 1e-7, h.y * 1e-7, h.z)
    return replace(m, home=home, items=tuple(
        MissionItem(it.command, it.frame, it.param1, it.param2, it.param3, it.param4,
                    float(it.x) if it.command in PLAIN_XY_COMMANDS else it.x * 1e-7,
                    float(it.y) if it.command in PLAIN_XY_COMMANDS else it.y * 1e-7, it.z, bool(it.autocontinue))
        for it in items))


def fence_wire_items(m: Mission) -> list[mp.WireItem]:
    """Fence polygons as MAV_MISSION_TYPE_FENCE items: one item per vertex, param1 = vertex count."""
    out: list[mp.WireItem] = []
    for command, polys, kind in ((mav.NAV_FENCE_POLYGON_VERTEX_INCLUSION, m.fence_inclusion, "inclusion"),
                                 (mav.NAV_FENCE_POLYGON_VERTEX_EXCLUSION, m.fence_exclusion, "exclusion")):
        for k, poly in enumerate(polys, start=1):
            pts = list(poly)
            if len(pts) > 1 and pts[0] == pts[-1]:
                pts.pop()  # a closed ring repeats its first vertex; MAVLink fences do not
            if len(pts) < 3:
                raise InputError(f"fence {kind} polygon {k} has {len(pts)} distinct vertices; a polygon needs at least 3")
            for lat, lon in pts:
                out.append(mp.WireItem(len(out), command, mav.FRAME_GLOBAL, float(len(pts)),
                                       x=deg_e7(lat, f"fence {kind} polygon {k} latitude"),
                                       y=deg_e7(lon, f"fence {kind} polygon {k} longitude"),
                                       mission_type=mp.FENCE))
    return out


def rally_wire_items(m: Mission) -> list[mp.WireItem]:
    """Rally points as MAV_MISSION_TYPE_RALLY items: NAV_RALLY_POINT, altitude above home (frame 3)."""
    return [mp.WireItem(k, mav.NAV_RALLY_POINT, mav.FRAME_GLOBAL_RELATIVE_ALT, x=deg_e7(lat, f"rally point {k + 1} latitude"),
                        y=deg_e7(lon, f"rally point {k + 1} longitude"), z=alt, mission_type=mp.RALLY)
            for k, (lat, lon, alt) in enumerate(m.rally)]


# --- what ArduPilot keeps of an item ------------------------------------------------------
# ArduPilot packs each item into 15 bytes (AP_Mission::mavlink_int_to_mission_cmd) and rebuilds
# the MAVLink item on download (AP_Mission::mission_cmd_to_mavlink_int): parameters it has no
# room for come back as 0, integer fields are truncated, altitudes are whole centimetres,
# commands without a location come back with frame 0 and x = y = z = 0, and fence vertices
# (MissionItemProtocol_Fence) with frame 0 and z = 0. Comparing the download with the plan
# through this model checks every field ArduPilot keeps and says which ones it does not.

_LOCATION_COMMANDS = frozenset({mav.NAV_WAYPOINT, mav.NAV_LAND, mav.NAV_TAKEOFF, mav.DO_LAND_START,
                                mav.NAV_VTOL_TAKEOFF, mav.NAV_VTOL_LAND, mav.DO_SET_ROI_LOCATION})
_FRAME_STORED = {0: 0, 2: 0, 5: 0, 3: 3, 6: 3, 10: 10, 11: 10}


def _trunc(v: float) -> float:
    return float(math.trunc(v)) if math.isfinite(v) else 0.0


def _byte(v: float, signed: bool = False) -> float:
    b = int(_trunc(v)) & 0xFF
    return float(b - 256 if signed and b > 127 else b)


def _ardupilot_params(it: mp.WireItem, plane: bool) -> tuple[float, float, float, float] | None:
    p1, p2, p3, p4 = it.param1, it.param2, it.param3, it.param4
    c = it.command
    if c == mav.NAV_WAYPOINT:
        if plane:  # acceptance and pass-by radius, one byte each
            return (0.0, min(255.0, _trunc(p2)), min(255.0, _trunc(p3)), 0.0)
        return (_trunc(p1), 0.0, 0.0, 0.0)  # delay, whole seconds
    if c in (mav.NAV_TAKEOFF, mav.NAV_VTOL_LAND):
        return (_trunc(p1), 0.0, 0.0, 0.0)
    if c == mav.NAV_LAND:
        return (_trunc(p1), 0.0, 0.0, -1.0 if p4 < 0 else 1.0)
    if c in (mav.NAV_RETURN_TO_LAUNCH, mav.NAV_VTOL_TAKEOFF, mav.DO_LAND_START, mav.DO_SET_ROI_LOCATION):
        return (0.0, 0.0, 0.0, 0.0)
    if c == mav.CONDITION_YAW:
        return (f32(p1), f32(p2), _trunc(p3), _trunc(p4))
    if c == mav.DO_CHANGE_SPEED:
        return (_trunc(p1), f32(p2), f32(p3), 0.0)
    if c == mav.DO_SET_CAM_TRIGG_DIST:
        return (f32(p1), 0.0, _trunc(p3), 0.0)
    if c == mav.DO_MOUNT_CONTROL:  # pitch, roll, yaw as floats (the mode, param7, too: `ardupilot_stored`)
        return (f32(p1), f32(p2), f32(p3), 0.0)
    if c == mav.DO_GIMBAL_MANAGER_PITCHYAW:  # pitch and the rates int8, yaw int16: whole degrees (the flags: `ardupilot_stored`)
        return (_byte(p1, signed=True), _trunc(p2), _byte(p3, signed=True), _byte(p4, signed=True))
    if c == mav.DO_DIGICAM_CONTROL:  # session, zoom position, zoom step (signed), focus lock: a byte each
        return (_byte(p1), _byte(p2), _byte(p3, signed=True), _byte(p4))
    if c in (mav.NAV_FENCE_POLYGON_VERTEX_INCLUSION, mav.NAV_FENCE_POLYGON_VERTEX_EXCLUSION):
        return (_trunc(p1), 0.0, 0.0, 0.0)
    return None


def ardupilot_stored(it: mp.WireItem, plane: bool) -> mp.WireItem:
    """The item as ArduPilot returns it after storing it; unknown commands are left as they are.

    A rally point (MissionItemProtocol_Rally, AP_Rally's RallyLocation) keeps its position and
    its altitude as a whole number of metres (int16), nothing else."""
    if it.mission_type == mp.RALLY:
        return mp.WireItem(it.seq, it.command, it.frame, x=it.x, y=it.y, z=_trunc(f32(it.z)), mission_type=it.mission_type)
    params = _ardupilot_params(it, plane)
    if params is None:
        return it
    if it.mission_type == mp.FENCE:
        return mp.WireItem(it.seq, it.command, 0, *params, it.x, it.y, 0.0, 1, 0, it.mission_type)
    if it.command in _LOCATION_COMMANDS:
        z = f32(math.trunc(f32(f32(it.z) * 100.0)) * f32(0.01)) if math.isfinite(it.z) else it.z
        frame = _FRAME_STORED.get(it.frame, it.frame)
        return mp.WireItem(it.seq, it.command, frame, *params, it.x, it.y, z, 1, 0, it.mission_type)
    # DO_DIGICAM_CONTROL keeps its shooting command (x) and command id (y), a byte each;
    # DO_MOUNT_CONTROL its mount mode (z; ArduCopter 4.7 SITL returns it)
    # DO_GIMBAL_MANAGER_PITCHYAW its flags (x) and gimbal id (z), a byte each
    x, y = (it.x & 0xFF, it.y & 0xFF) if it.command == mav.DO_DIGICAM_CONTROL else (it.x & 0xFF, 0) \
        if it.command == mav.DO_GIMBAL_MANAGER_PITCHYAW else (0, 0)
    z = _trunc(it.z) if it.command == mav.DO_MOUNT_CONTROL else _byte(it.z) if it.command == mav.DO_GIMBAL_MANAGER_PITCHYAW else 0.0
    return mp.WireItem(it.seq, it.command, 0, *params, x, y, z, 1, 0, it.mission_type)


# --- what PX4 keeps of an item -----------------------------------------------------------
# PX4's MavlinkMissionManager (src/modules/mavlink/mavlink_mission.cpp) parses each item into a
# mission_item_s (parse_mavlink_mission_item) and rebuilds the MAVLink item on download
# (format_mavlink_mission_item). An item with a position keeps only the parameters PX4 has a field
# for, the yaw (param4) as radians wrapped to [0, 2π) and back; an item without one (frame 2)
# keeps its seven parameters as float32. Positions come back in the _INT frames (5, 6): the same
# frames (see `_SAME_FRAME`). Anything else PX4 refuses: MAV_MISSION_UNSUPPORTED for a command,
# MAV_MISSION_UNSUPPORTED_FRAME for a frame (terrain frames included).

_POSITION_FRAMES = frozenset({0, 3, 5, 6})
#: Items each mission type holds on PX4 (dataman: CONFIG_NUM_MISSION_ITMES_SUPPORTED, 2000 on flight
#: controllers; DM_KEY_FENCE_POINTS_MAX; DM_KEY_SAFE_POINTS_MAX)
PX4_MAX_ITEMS = {mp.MISSION: 2000, mp.FENCE: 64, mp.RALLY: 32}


def px4_refusal(it: mp.WireItem) -> str | None:
    """The MAV_MISSION_RESULT name PX4 answers `it` with when it does not take it, else None."""
    if it.frame in _POSITION_FRAMES:
        return None if it.command in mav.PX4_POSITION_COMMANDS else mp.result_name(mp.UNSUPPORTED)
    if it.frame == mav.FRAME_MISSION:
        return None if it.command in mav.PX4_MISSION_FRAME_COMMANDS else mp.result_name(mp.UNSUPPORTED)
    return mp.result_name(mp.UNSUPPORTED_FRAME)


def _px4_yaw(deg: float) -> float:
    """A yaw in degrees as PX4 gives it back, step by step in float32 as PX4 computes it:
    math::radians, matrix::wrap_2pi (into [0, 2π)), math::degrees."""
    if not math.isfinite(deg):
        return deg
    rad = f32(f32(deg) * f32(f32(math.pi) / f32(180.0)))
    two_pi = f32(2.0 * math.pi)
    if not 0.0 <= rad < two_pi:
        rad = f32(rad - f32(two_pi * math.floor(f32(rad * f32(1.0 / two_pi)))))
    return f32(rad * f32(f32(180.0) / f32(math.pi)))


def px4_stored(it: mp.WireItem) -> mp.WireItem:
    """The item as PX4 returns it after storing it (commands it has no rule for are left as they are)."""
    p1, p2, p4 = f32(it.param1), f32(it.param2), _px4_yaw(it.param4)
    if it.frame == mav.FRAME_MISSION:
        return mp.WireItem(it.seq, it.command, it.frame, p1, p2, f32(it.param3), f32(it.param4), round(f32(it.x)),
                           round(f32(it.y)), f32(it.z), it.autocontinue, 0, it.mission_type)
    params = {mav.NAV_WAYPOINT: (p1, p2, 0.0, p4), mav.NAV_LAND: (0.0, p2, 0.0, p4), mav.NAV_TAKEOFF: (0.0, 0.0, 0.0, p4),
              mav.NAV_VTOL_TAKEOFF: (0.0, 0.0, 0.0, p4), mav.NAV_VTOL_LAND: (0.0, 0.0, 0.0, p4),
              mav.NAV_FENCE_POLYGON_VERTEX_INCLUSION: (float(int(p1 + 0.5)), 0.0, 0.0, 0.0),
              mav.NAV_FENCE_POLYGON_VERTEX_EXCLUSION: (float(int(p1 + 0.5)), 0.0, 0.0, 0.0),
              mav.NAV_RALLY_POINT: (0.0, 0.0, 0.0, 0.0)}.get(it.command)
    if params is None:
        return it
    return mp.WireItem(it.seq, it.command, it.frame, *params, it.x, it.y, f32(it.z), it.autocontinue, 0, it.mission_type)


# --- comparison --------------------------------------------------------------------------

@dataclass(frozen=True)
class Mismatch:
    """One field of one item that differs between the plan and the vehicle."""

    seq: int | None
    field: str
    expected: object
    actual: object
    command: int | None = None
    mission_type: int = mp.MISSION

    def __str__(self) -> str:
        kind = mp.TYPE_NAMES.get(self.mission_type, str(self.mission_type))
        if self.seq is None:
            return f"{kind}: the vehicle has {self.actual} items, the plan {self.expected}"
        name = _COMMAND_NAMES.get(self.command, str(self.command)) if self.command is not None else "?"
        return f"{kind} item {self.seq} ({name}) {self.field}: planned {_show(self.expected)}, vehicle has {_show(self.actual)}"


def _show(v: object) -> str:
    """A float32 value with the 7 digits it holds (102.13, not 102.12999725341797)."""
    return f"{v:.7g}" if isinstance(v, float) else str(v)


#: MAV_FRAME_GLOBAL_INT, _RELATIVE_ALT_INT and _TERRAIN_ALT_INT mean what frames 0, 3 and 10 mean
#: (their x and y were int32 in MISSION_ITEM, as they always are in MISSION_ITEM_INT); PX4 answers with them
_SAME_FRAME = {5: 0, 6: 3, 11: 10}


def same_frame(frame: int) -> int:
    """The frame a frame number means (`_SAME_FRAME`)."""
    return _SAME_FRAME.get(frame, frame)


def _same_f32(a: float, b: float) -> bool:
    a, b = f32(a), f32(b)
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return math.isclose(a, b, rel_tol=2.0**-22, abs_tol=1e-6)


def compare_items(expected: Sequence[mp.WireItem], actual: Sequence[mp.WireItem], skip: frozenset[int] = frozenset(),
                  mission_type: int = mp.MISSION) -> list[Mismatch]:
    """Every differing field: command exactly, frame by meaning (`_SAME_FRAME`), params and z as float32,
    x/y as int32 1e-7 degrees."""
    out: list[Mismatch] = []
    if len(expected) != len(actual):
        out.append(Mismatch(None, "count", len(expected), len(actual), mission_type=mission_type))
    for e, a in zip(expected, actual):
        if e.seq in skip:
            continue

        def miss(name: str, ev: object, av: object, e: mp.WireItem = e) -> None:
            out.append(Mismatch(e.seq, name, ev, av, e.command, mission_type))

        if e.command != a.command:
            miss("command", e.command, a.command)
            continue
        if same_frame(e.frame) != same_frame(a.frame):
            miss("frame", e.frame, a.frame)
        for k, (ev, av) in enumerate(zip((e.param1, e.param2, e.param3, e.param4), (a.param1, a.param2, a.param3, a.param4)), 1):
            if not _same_f32(ev, av):
                miss(f"param{k}", f32(ev), f32(av))
        if e.x != a.x:
            miss("x (latitude·1e7)", e.x, a.x)
        if e.y != a.y:
            miss("y (longitude·1e7)", e.y, a.y)
        if not _same_f32(e.z, a.z):
            miss("z", f32(e.z), f32(a.z))
    return out


# --- transfers ---------------------------------------------------------------------------

def run_transfer(link: Link, machine: mp.Uploader | mp.Downloader, progress: Progress | None = None) -> None:
    """Drive one protocol machine over `link` until it succeeds (return) or fails (LinkError).

    The machine bounds the time itself (`Policy.limit`): its deadline is never later than
    that, and every pass through the loop polls it.
    """
    for m in machine.start(link.now()):
        link.send(m)
    while not machine.finished:
        if progress is not None:
            progress(machine.what, *machine.progress)
        msg = link.recv(machine.deadline)
        now = link.now()
        out = machine.handle(msg, now) if msg is not None else []
        out += machine.poll(now)
        for m in out:
            link.send(m)
    if progress is not None:
        progress(machine.what, *machine.progress)
    if machine.error is not None:
        raise LinkError(machine.error)


def upload_items(link: Link, items: Sequence[mp.WireItem], mission_type: int, policy: mp.Policy,
                 confirm_by_download: bool = False, progress: Progress | None = None,
                 timer: mp.ResendTimer | None = None) -> mp.Stats:
    """Upload one mission type's items; returns what the link cost (resends, restarts).

    With `confirm_by_download` the upload may end without the vehicle's final ACCEPTED
    (`stats.ack_lost`); the caller must then read the items back and compare them.
    Raises UploadFailed when the upload does not finish.
    """
    machine = mp.Uploader(items, mission_type, policy, confirm_by_download, timer)
    try:
        run_transfer(link, machine, progress)
    except LinkError as exc:
        raise UploadFailed(str(exc), machine.stats.most_confirmed, vehicle_count(link, mission_type, policy)) from None
    return machine.stats


def vehicle_count(link: Link, mission_type: int, policy: mp.Policy) -> int | None:
    """How many items of `mission_type` the vehicle says it holds: MISSION_REQUEST_LIST (again every
    `policy.timeout`) until its MISSION_COUNT, then our MISSION_ACK to end the transfer it began; None
    when it says nothing within `policy.silence` (a vehicle that died, or whose link did)."""
    end = link.now() + policy.silence
    while link.now() < end:
        link.send(mp.RequestList(mission_type))
        until = min(end, link.now() + policy.timeout)
        while link.now() < until:
            try:
                msg = link.recv(until)
            except LinkError:
                return None
            if isinstance(msg, mp.Count) and msg.mission_type == mission_type:
                link.send(mp.Ack(mp.ACCEPTED, mission_type))
                return msg.count
    return None


def download_items(link: Link, mission_type: int, policy: mp.Policy, expected: int | None = None,
                   progress: Progress | None = None, timer: mp.ResendTimer | None = None,
                   resume: bool = True) -> tuple[list[mp.WireItem], mp.Stats]:
    """Every item of one mission type as the vehicle stores it; `expected` sizes the time limit,
    `resume` (see mission_protocol.Downloader) is False for PX4.

    Raises DownloadFailed (with the vehicle's count, when it gave one) when the read-back does not finish.
    """
    machine = mp.Downloader(mission_type, policy, expected, timer, resume)
    try:
        run_transfer(link, machine, progress)
    except LinkError as exc:
        raise DownloadFailed(str(exc), machine.count) from None
    return machine.result(), machine.stats


# --- the whole job -----------------------------------------------------------------------

#: `UploadReport.via` for transfers through aerosurvey's own mission protocol
VIA_PROTOCOL = "aerosurvey's mission protocol"

@dataclass
class TransferReport:
    """One mission type's upload and its check."""

    mission_type: int
    items: int
    seconds: float
    stats: mp.Stats
    verified: bool = False
    verify_seconds: float = 0.0
    download_stats: mp.Stats | None = None
    held: list[mp.WireItem] | None = None  # the items read back: what the vehicle holds


@dataclass
class UploadReport:
    """What was uploaded and checked; only built when everything asked for succeeded."""

    vehicle: Vehicle
    mission: TransferReport
    fence: TransferReport | None
    compared_as: str
    home_note: str = ""
    notes: list[str] = field(default_factory=list)
    rally: TransferReport | None = None
    via: str = VIA_PROTOCOL

    @property
    def transfers(self) -> list[TransferReport]:
        return [r for r in (self.mission, self.fence, self.rally) if r is not None]


class Transfers(Protocol):
    """Uploads and downloads of one mission type at a time, by whatever speaks to the vehicle:
    `ProtocolTransfers` (aerosurvey's own mission protocol) or link.px4's MAVSDK transfers."""

    vehicle: Vehicle
    via: str  # what carries them, in words

    def upload(self, kind: int, items: Sequence[mp.WireItem]) -> mp.Stats:
        """Raises UploadFailed; may end with `stats.ack_lost` only when a read-back follows."""
        ...

    def download(self, kind: int, expected: int) -> tuple[list[mp.WireItem], mp.Stats]:
        """Raises DownloadFailed."""
        ...

    def said(self, since: float) -> str:
        """The vehicle's warnings since `since` (see `now`), as words to append to an error, or ""."""
        ...

    def now(self) -> float: ...


class ProtocolTransfers:
    """aerosurvey's own mission protocol (mission_protocol's machines) over a Link; one resend timer for all."""

    via = VIA_PROTOCOL

    def __init__(self, link: Link, policy: mp.Policy, verify: bool = True, progress: Progress | None = None) -> None:
        if link.vehicle is None:
            raise RuntimeError("the link has no vehicle yet: wait for its heartbeat first")
        self.link, self.policy, self.verify, self.progress = link, policy, verify, progress
        self.vehicle = link.vehicle
        self.timer = mp.ResendTimer(policy)  # the link's round trips, measured by every transfer on it

    def upload(self, kind: int, items: Sequence[mp.WireItem]) -> mp.Stats:
        return upload_items(self.link, items, kind, self.policy, self.verify, self.progress, self.timer)

    def download(self, kind: int, expected: int) -> tuple[list[mp.WireItem], mp.Stats]:
        return download_items(self.link, kind, self.policy, expected, self.progress, self.timer,
                              resume=self.vehicle.autopilot != AUTOPILOT_PX4)

    def said(self, since: float) -> str:
        return _vehicle_said(self.link, since)

    def now(self) -> float:
        return self.link.now()


def _stats_said(rep: TransferReport, via: str) -> str:
    lost = "its final MISSION_ACK never came" if via == VIA_PROTOCOL else f"the upload through {via} timed out"
    return (lost if rep.stats.ack_lost else "although it acknowledged the upload") + "; the read-back shows it"


def _vehicle_said(link: Link, since: float) -> str:
    """The vehicle's warnings during a failed transfer (ArduPilot explains NO_SPACE there)."""
    texts = [t for when, sev, t in getattr(link, "status_texts", []) if when >= since and sev <= 4]
    return f" (the vehicle said: {'; '.join(dict.fromkeys(texts))})" if texts else ""


class Refused(AerosurveyError):
    """The mission does not fit the vehicle; nothing was sent (exit code 3)."""

    exit_code = 3


#: How far (m) the vehicle may be from the planned launch point unless the pilot names a larger distance
LAUNCH_DISTANCE_M = 200.0
#: The most items a MISSION_COUNT can announce (uint16)
MAVLINK_MAX_ITEMS = 65535


@dataclass(frozen=True)
class MissionFacts:
    """What the checks before an upload compare with the vehicle: from the plan file and, when
    it lies in the plan folder that `aerosurvey plan` wrote, from that folder's manifest."""

    file: str  # the file's name, as messages show it
    vehicle: str  # "copter" or "plane"
    firmware: str  # "ardupilot" or "px4"
    launch: tuple[float, float]  # the planned launch point (home): latitude, longitude
    items: int  # items on the wire (home included for ArduPilot)
    max_items: int | None = None  # the spec's battery.max_mission_items
    estimated_min: float | None = None  # the file's estimated flight time
    battery: str | None = None  # what one battery of the spec gives, in words
    sorties: tuple[str, ...] = ()  # the sortie files, when this file is the whole mission and it needs several
    plan: vs.PlanFigures = vs.PlanFigures()  # the figures the vehicle's settings are compared with
    rules: tuple[str, ...] | None = None  # every rule the manifest evaluated (None: no manifest lists the file)
    failed_rules: tuple[str, ...] = ()  # those that fail at error level: `plan` wrote the folder for inspection only


def check_firmware(firmware: str, vehicle: Vehicle) -> None:
    """Refuse a plan made for the other autopilot: item numbering and commands differ. An
    autopilot that is neither ArduPilot nor PX4 (a generic MAVLink vehicle) is not refused."""
    said = {AUTOPILOT_ARDUPILOT: "ardupilot", AUTOPILOT_PX4: "px4"}.get(vehicle.autopilot)
    if said is not None and said != firmware:
        raise Refused(f"the plan is for {firmware} but the vehicle reports {vehicle.autopilot_name}: "
                      f"plan the mission for {said} and upload that")


def check_vehicle(facts: MissionFacts, vehicle: Vehicle, position: tuple[float, float] | None,
                  launch_distance: float | None = LAUNCH_DISTANCE_M) -> str:
    """Refuse (Refused, one line with the figures) a mission that does not fit the vehicle:
    another autopilot or vehicle type, more items than the vehicle takes, a whole mission that
    needs several batteries, a vehicle farther than `launch_distance` metres from the planned
    launch point or without a position (`launch_distance` None: not compared). Returns the
    line that says where the vehicle is."""
    check_firmware(facts.firmware, vehicle)
    types = COPTER_TYPES if facts.vehicle == "copter" else PLANE_TYPES
    if vehicle.mav_type not in types:
        said = ("a copter" if vehicle.mav_type in COPTER_TYPES else "a plane" if vehicle.mav_type in PLANE_TYPES
                else "neither a copter nor a plane")
        raise Refused(f"{facts.file} is a {facts.vehicle} mission but the vehicle reports MAV_TYPE {vehicle.mav_type} "
                      f"({said}): upload a mission planned for this vehicle")
    most = min(MAVLINK_MAX_ITEMS, facts.max_items or MAVLINK_MAX_ITEMS)
    if facts.items > most:
        whose = "MAVLink counts at most" if most == MAVLINK_MAX_ITEMS else "the spec's battery.max_mission_items allows"
        raise Refused(f"{facts.file} has {facts.items} mission items (home included) but {whose} {most}: "
                      "plan it with smaller sorties")
    if facts.sorties:
        est = f"an estimated {facts.estimated_min:.1f} min of flight" if facts.estimated_min is not None else "more"
        raise Refused(f"{facts.file} is the whole mission, {est}, but one battery gives {facts.battery}: upload its "
                      f"{len(facts.sorties)} sorties one at a time ({', '.join(facts.sorties)})")
    lat, lon = facts.launch
    where = f"the planned launch point {lat:.6f}, {lon:.6f}"
    if launch_distance is None:
        return f"launch point: not compared (--launch-distance off); {where}"
    if position is None:
        raise Refused(f"the vehicle reported no position and no home (no GPS fix?), so it cannot be compared with "
                      f"{where}: wait for a fix, or give --launch-distance off")
    d = great_circle_m(lat, lon, *position)
    if d > launch_distance:
        raise Refused(f"the vehicle is at {position[0]:.6f}, {position[1]:.6f}, {d:,.0f} m from {where} (limit "
                      f"{launch_distance:,.0f} m): move it there, or confirm with --launch-distance {math.ceil(d)}")
    return f"launch point: the vehicle is {d:,.0f} m from {where} (limit {launch_distance:,.0f} m)"


def check_px4(m: Mission, file: str, rally: bool) -> None:
    """Refuse (Refused) what PX4 would refuse or has no room for: more items of a mission type than
    its storage holds (`PX4_MAX_ITEMS`), or an item whose command or frame PX4 does not take
    (`px4_refusal`: it would answer MAV_MISSION_UNSUPPORTED(_FRAME) in the middle of the upload)."""
    kinds = [(mp.MISSION, mission_wire_items(m)), (mp.FENCE, fence_wire_items(m))] + (
        [(mp.RALLY, rally_wire_items(m))] if rally else [])
    for kind, items in kinds:
        if len(items) > PX4_MAX_ITEMS[kind]:
            raise Refused(f"{file} has {len(items)} {_ITEMS[kind]} but PX4 stores at most {PX4_MAX_ITEMS[kind]}: "
                          "plan it with smaller sorties" + (" or a simpler fence" if kind == mp.FENCE else ""))
        for it in items:
            answer = px4_refusal(it)
            if answer is not None:
                name = command_name(it.command)
                raise Refused(f"{file}: {mp.TYPE_NAMES[kind]} item {it.seq} ({name}, frame {it.frame}) is not one PX4 takes "
                              f"(it answers {answer}"
                              + ("; PX4 has no terrain frame: plan it with relative altitudes" if it.frame in (10, 11) else "")
                              + ")")


#: PX4's parameters the leg check reads (`vehicle_settings.SETTINGS`, check leg-length)
PX4_LEG_PARAMS = tuple(s.name for s in vs.SETTINGS if s.check == vs.LEGS)


def px4_longest_leg(m: Mission) -> tuple[float, int, int] | None:
    """The longest leg between two consecutive places as PX4 reads the wire items: (metres, item, item)."""
    return longest_leg([(it.seq, it.x * 1e-7, it.y * 1e-7) for it in mission_wire_items(m)
                        if it.command in PX4_PLACE_COMMANDS])


def check_px4_legs(m: Mission, file: str, params: dict[str, float]) -> str:
    """Refuse (Refused) a mission with a leg longer than the vehicle's MIS_DIST_WPS (`vehicle_settings.check_legs`);
    `params`: what the vehicle answered for PX4_LEG_PARAMS. Returns the line about the legs."""
    found = vs.check_legs(px4_longest_leg(m), vs.Values(params))
    if found.status == "refuse":
        raise Refused(f"{file}: {found.line}")
    return found.line


def settings_to_read(facts: MissionFacts, vehicle: Vehicle) -> tuple[str, ...]:
    """The parameters `check_settings` compares (`vehicle_settings.SETTINGS`); none for an autopilot
    that is neither ArduPilot nor PX4, whose names are not known."""
    if vehicle.autopilot not in (AUTOPILOT_ARDUPILOT, AUTOPILOT_PX4):
        return ()
    return vs.settings_for(facts.firmware, facts.vehicle)


def check_settings(facts: MissionFacts, m: Mission, vehicle: Vehicle, params: dict[str, float],
                   accept: frozenset[str]) -> list[str]:
    """Refuse (Refused, one line: the parameter, its value, what the mission needs) a mission the
    vehicle's settings would fly other than planned (`vehicle_settings`), unless the pilot names the
    check in `accept`; returns what the report says of every check."""
    if vehicle.autopilot not in (AUTOPILOT_ARDUPILOT, AUTOPILOT_PX4):
        return [f"settings: not read (the vehicle reports {vehicle.autopilot_name}, whose parameter names are not known)"]
    longest = px4_longest_leg(m) if m.firmware == vs.PX4 else None
    verdict = vs.judge(vs.check_settings(m, facts.vehicle, params, facts.plan, longest), accept)
    if verdict.refusal is not None:
        raise Refused(f"{facts.file}: {verdict.refusal}")
    return list(verdict.lines)


def check_rules(facts: MissionFacts, accept: frozenset[str]) -> str:
    """Refuse (Refused) a plan one of whose error-severity rules fails (`aerosurvey plan` wrote it
    for inspection only, exit code 1) unless the pilot names every such rule in `accept`; returns the report's line."""
    if facts.rules is None:
        return "rules: not checked (no manifest.json beside the plan lists this file)"
    failed = facts.failed_rules
    if not failed:
        return f"rules: {len(facts.rules)} evaluated, none fails at error level"
    missing = [r for r in failed if r not in accept]
    if missing:
        raise Refused(f"{facts.file}: the plan fails {len(failed)} error-severity rule(s) ({', '.join(failed)}): "
                      "`aerosurvey plan` wrote it for inspection only (`aerosurvey check` shows the evidence); upload it "
                      f"only by naming each: {' '.join('--accept ' + r for r in missing)}")
    return (f"rules: {len(failed)} error-severity rule(s) fail, ACCEPTED by the pilot "
            f"({', '.join('--accept ' + r for r in failed)})")


def accept_names(facts: MissionFacts, accept: Sequence[str], checks: Sequence[str] = ()) -> frozenset[str]:
    """The `--accept` names, each a check of `vehicle_settings.CHECKS`, of `checks` (the upload's others) or a rule of
    the plan (InputError otherwise)."""
    allowed = {*vs.CHECKS, *checks, *(facts.rules or ())}
    for name in accept:
        if name not in allowed:
            rules = f"; the plan's rules: {', '.join(sorted(set(facts.rules)))}" if facts.rules else ""
            raise InputError(f"--accept {name!r} is not a check of upload nor a rule of the plan: the checks are "
                             f"{', '.join((*vs.CHECKS, *checks))}{rules}", key="--accept")
    return frozenset(accept)


_ITEMS = {mp.MISSION: "mission items", mp.FENCE: "fence vertices", mp.RALLY: "rally points"}


def _holds(held: object, total: int, kind: int) -> str:
    return f"the vehicle holds {held} of {total} {_ITEMS.get(kind, 'items')}: do not fly it"


def _verify(transfers: Transfers, rep: TransferReport, expected: list[mp.WireItem], storage: str, plane: bool,
            skip: frozenset[int]) -> tuple[list[mp.WireItem], mp.Stats, list[Mismatch]]:
    """Read one mission type back and compare; a failed read-back is a LinkError that says what the vehicle holds."""
    kind, n = rep.mission_type, len(expected)
    try:
        actual, stats = transfers.download(kind, n)
    except DownloadFailed as exc:
        if exc.count is not None and exc.count != n:
            raise LinkError(f"{_holds(exc.count, n, kind)} (it says so; the read-back then failed: {exc})") from None
        if rep.stats.ack_lost and transfers.via == VIA_PROTOCOL:
            raise LinkError(f"{_holds(rep.stats.confirmed, n, kind)} (it asked for every item but never acknowledged the "
                            f"last one, and the read-back failed: {exc})") from None
        if rep.stats.ack_lost:
            raise LinkError(f"the {mp.TYPE_NAMES[kind]} upload through {transfers.via} timed out and the read-back failed "
                            f"({exc}): what the vehicle holds is not known: do not fly it") from None
        raise LinkError(f"upload acknowledged by the vehicle but not verified: {exc}") from None
    model = {"ardupilot": lambda it: ardupilot_stored(it, plane), "px4": px4_stored}.get(storage)
    wanted = [model(it) for it in expected] if model is not None else expected
    return actual, stats, compare_items(wanted, actual, skip, kind)


_COMPARED_AS = {"ardupilot": "as ArduPilot stores items (fields it does not keep are not compared)",
                "px4": "as PX4 stores items (fields it does not keep are not compared)",
                "verbatim": "field by field as uploaded"}


def _failed_upload(kind: int, exc: UploadFailed, n: int, said: str, done: list[TransferReport]) -> LinkError:
    """The one-line error for an upload that did not finish, saying what the vehicle is left with."""
    if kind == mp.MISSION:
        return LinkError(f"{exc}{said}; {_left_holding(exc, n)}: do not fly it")
    before = " and ".join(mp.TYPE_NAMES[r.mission_type] for r in done)
    whose = "fence is" if kind == mp.FENCE else "rally points are"
    return LinkError(f"the {before} {'was' if len(done) == 1 else 'were'} uploaded but the {exc}{said}; the vehicle's "
                     f"{whose} not the plan's")


def _left_holding(exc: UploadFailed, n: int) -> str:
    """What a failed upload left on the vehicle, in words: the count it gave when asked afterwards,
    else the items it confirmed in order (ArduPilot writes them in place as they come), else nothing known."""
    if exc.count is not None and not exc.confirmed:
        return (f"the vehicle holds {exc.count} mission item(s), none confirmed of the plan's {n} (it says so when asked "
                "after the failure)")
    if exc.count is not None:
        return (f"the vehicle holds {exc.count} of {n} mission items (it says so when asked after the failure; it "
                f"confirmed the first {exc.confirmed} as the plan's)")
    if exc.confirmed is not None:
        return (f"the vehicle holds at least {exc.confirmed} of {n} mission items (it confirmed them in order, and "
                "answered no count after the failure), or its earlier mission where it keeps a mission only whole")
    return "the vehicle's mission is incomplete or unchanged"


def upload_plan(transfers: Transfers, m: Mission, verify: bool = True, rally: bool = False,
                progress: Progress | None = None) -> UploadReport:
    """Upload the mission (its fence when it has one, its rally points when `rally` and it has
    some), then read each back and compare, through `transfers`.

    Raises LinkError when a transfer fails, VerificationFailed when the vehicle stores
    something else; returns a report only when everything asked for succeeded. With
    `verify`, an upload whose final ACCEPTED was lost (`stats.ack_lost`) is settled by the
    read-back instead of being sent again. A vehicle that holds only part of a mission type is
    reported as "the vehicle holds N of M mission items: do not fly it".
    `progress`: told when each transfer starts and ends, for transfers that do not report their own (MAVSDK's).
    """
    vehicle = transfers.vehicle
    check_firmware(m.firmware, vehicle)
    storage = {AUTOPILOT_ARDUPILOT: "ardupilot", AUTOPILOT_PX4: "px4"}.get(vehicle.autopilot, "verbatim")
    plane = vehicle.mav_type in PLANE_TYPES
    kinds = [(mp.MISSION, mission_wire_items(m)), (mp.FENCE, fence_wire_items(m))]
    if rally:
        kinds.append((mp.RALLY, rally_wire_items(m)))
    wanted = {kind: items for kind, items in kinds if items or kind == mp.MISSION}

    done: list[TransferReport] = []
    for kind, items in wanted.items():
        t0 = time.monotonic()
        started = transfers.now()
        coarse = progress if transfers.via != VIA_PROTOCOL else None
        if coarse is not None:
            coarse(f"{mp.TYPE_NAMES[kind]} upload through {transfers.via}", 0, len(items))
        try:
            stats = transfers.upload(kind, items)
        except UploadFailed as exc:
            raise _failed_upload(kind, exc, len(items), transfers.said(started), done) from None
        done.append(TransferReport(kind, len(items), time.monotonic() - t0, stats))
        if coarse is not None:
            coarse(f"{mp.TYPE_NAMES[kind]} upload through {transfers.via}", len(items), len(items))
    reps = {r.mission_type: r for r in done}
    report = UploadReport(vehicle, reps[mp.MISSION], reps.get(mp.FENCE), _COMPARED_AS[storage], rally=reps.get(mp.RALLY),
                          via=transfers.via)
    if not verify:
        return report

    # ArduPilot overwrites item 0 with its own home; another autopilot given home as item 0 keeps it
    skip = frozenset({0}) if home_on_wire(m) and storage == "ardupilot" else frozenset()
    mismatches: list[Mismatch] = []
    for rep in done:
        t0 = time.monotonic()
        actual, dstats, found = _verify(transfers, rep, wanted[rep.mission_type], storage, plane,
                                        skip if rep.mission_type == mp.MISSION else frozenset())
        rep.verify_seconds = time.monotonic() - t0
        rep.download_stats, rep.held = dstats, actual
        mismatches += found
        if rep.mission_type == mp.MISSION and skip and actual:
            h = actual[0]
            where = "has no home yet (0, 0)" if h.x == 0 and h.y == 0 else (
                f"home is {h.x * 1e-7:.7f}, {h.y * 1e-7:.7f}, "
                f"{great_circle_m(m.home[0], m.home[1], h.x * 1e-7, h.y * 1e-7):.0f} m from the planned home")
            report.home_note = f"item 0 (home) not compared: ArduPilot replaces it with its own home; the vehicle {where}"
    if mismatches:
        first = mismatches[0]
        if first.seq is None:  # the item count differs: the vehicle holds part of the mission (or more)
            n = len(wanted[first.mission_type])
            raise VerificationFailed(f"verification failed: {_holds(first.actual, n, first.mission_type)} "
                                     f"({_stats_said(reps[first.mission_type], transfers.via)})", mismatches)
        more = f" (and {len(mismatches) - 1} more difference(s))" if len(mismatches) > 1 else ""
        raise VerificationFailed(f"verification failed: {first}{more}; the vehicle stores something other than "
                                 "the plan: do not fly it", mismatches)
    for rep in done:
        rep.verified = True
    return report


def upload_mission(link: Link, m: Mission, policy: mp.Policy, verify: bool = True,
                   progress: Progress | None = None, rally: bool = False) -> UploadReport:
    """`upload_plan` through aerosurvey's own mission protocol on `link`. Without `verify`, an
    upload whose final ACCEPTED was lost is restarted. `progress` is called while each transfer runs."""
    return upload_plan(ProtocolTransfers(link, policy, verify, progress), m, verify, rally)
