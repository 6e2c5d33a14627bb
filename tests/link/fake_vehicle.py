"""An in-process MAVLink vehicle for the link tests and the upload benchmark.

`VehicleModel` answers the mission protocol the way ArduPilot's MissionItemProtocol does
(libraries/GCS_MAVLink/MissionItemProtocol.cpp): it requests items one by one, re-requests
after its own timeout, cancels a stalled upload with OPERATION_CANCELLED, answers a late or
duplicated item with INVALID_SEQUENCE and an item outside an upload with ERROR, and writes
mission items in place as they arrive. With `px4=True` it answers as PX4's MavlinkMissionManager
(src/modules/mavlink/mavlink_mission.cpp): it identifies as PX4, re-requests every 250 ms,
drops an item it did not ask for without an answer, answers a repeat of the last item after
the upload with ACCEPTED, refuses a MISSION_COUNT in the middle of an upload with ERROR, gives
up silently after 5 s without an item, stores the mission only when it is complete, and during
a download answers only the next item or the one before (anything else: ERROR, transfer over);
it keeps what PX4's mission_item_s keeps of an item (`px4_parse`), answers in the _INT frames with
the yaw wrapped to [0, 360) (`px4_format`), refuses the commands and frames PX4 does not take
(MAV_MISSION_UNSUPPORTED, _UNSUPPORTED_FRAME) and counts more than its dataman holds per mission
type (`PX4_ROOM`) as MAV_MISSION_NO_SPACE. Both keep rally points (MAV_MISSION_TYPE_RALLY;
ArduPilot in whole metres) and answer whichever system asked.
Both answer MAV_CMD_REQUEST_MESSAGE for GLOBAL_POSITION_INT and HOME_POSITION at `home`
(COMMAND_ACK MAV_RESULT_FAILED without `fix`). It reads and writes pymavlink messages with its
own field handling, independent of aerosurvey's codec.

`FakeVehicle` runs a model on a loopback UDP or TCP socket, or on a pseudo-terminal that
stands for a serial port (`url` is then its device, e.g. /dev/pts/3), in a thread and can
drop, duplicate and reorder packets both ways (seeded). `SimLink` runs a model on a simulated clock
with the same faults, for fast property tests. `LossyRelay` is a UDP relay on loopback that
drops a share of datagrams (seeded), for the benchmark's lossy case.
"""

from __future__ import annotations

import heapq
import math
import os
import random
import select
import socket
import struct
import threading
import time
import tty
from dataclasses import dataclass
from typing import Any

os.environ["MAVLINK20"] = "1"
from pymavlink.dialects.v20 import ardupilotmega as mavlink2  # noqa: E402

from aerosurvey.link import connection  # noqa: E402
from aerosurvey.link import mission_protocol as mp  # noqa: E402
from aerosurvey.mission import mavlink_ids as mav  # noqa: E402
from aerosurvey.mission.items import Mission, MissionItem  # noqa: E402

LOOPBACK = "127.0.0.1"


def _f32(v: float) -> float:
    return struct.unpack("<f", struct.pack("<f", v))[0] if math.isfinite(v) else v


@dataclass
class Stored:
    """One item as the vehicle keeps it."""

    command: int
    frame: int
    params: tuple[float, float, float, float]
    x: int
    y: int
    z: float


class Unsupported(Exception):
    """The vehicle refuses an item with this MAV_MISSION_RESULT."""

    def __init__(self, result: int) -> None:
        super().__init__(result)
        self.result = result


def ardupilot_pack(command: int, frame: int, p: tuple[float, float, float, float], x: int, y: int, z: float,
                   plane: bool) -> Stored:
    """Store an item the way AP_Mission does (p1 uint16, one-byte fields, altitude in whole cm)."""
    u16 = lambda v: struct.unpack("<H", struct.pack("<H", int(v) & 0xFFFF))[0]  # noqa: E731
    u8 = lambda v: int(v) & 0xFF  # noqa: E731
    i8 = lambda v: struct.unpack("<b", struct.pack("<B", int(v) & 0xFF))[0]  # noqa: E731
    location = command in (16, 21, 22, 84, 85, 189)
    if command == 16:
        params = (0.0, float(min(255, u16(p[1]))), float(min(255, u16(p[2]))), 0.0) if plane else (float(u16(p[0])), 0.0, 0.0, 0.0)
    elif command in (22, 85):
        params = (float(u16(p[0])), 0.0, 0.0, 0.0)
    elif command == 21:
        params = (float(u16(p[0])), 0.0, 0.0, -1.0 if (not math.isnan(p[3]) and p[3] < 0) else 1.0)
    elif command in (20, 84, 189):
        params = (0.0, 0.0, 0.0, 0.0)
    elif command == 178:
        params = (float(u8(p[0])), _f32(p[1]), _f32(p[2]), 0.0)
    elif command == 206:
        params = (_f32(p[0]), 0.0, float(u8(p[2])), 0.0)
    elif command == 115:
        params = (_f32(p[0]), _f32(p[1]), float(i8(p[2])), float(u8(p[3])))
    elif command == 205:  # mount_control: pitch, roll, yaw as floats; the mount mode (param7) comes back too (ArduCopter 4.7 SITL)
        params = (_f32(p[0]), _f32(p[1]), _f32(p[2]), 0.0)
    else:
        raise Unsupported(mp.UNSUPPORTED)
    if command == 205:
        return Stored(command, 0, params, 0, 0, float(int(z)))
    if not location:
        return Stored(command, 0, params, 0, 0, 0.0)
    if frame in (0, 2, 5):
        frame_back = 0
    elif frame in (3, 6):
        frame_back = 3
    elif frame in (10, 11):
        frame_back = 10
    else:
        raise Unsupported(mp.UNSUPPORTED_FRAME)
    alt_cm = int(_f32(_f32(z) * 100.0))
    return Stored(command, frame_back, params, x, y, _f32(alt_cm * _f32(0.01)))


# What PX4's MavlinkMissionManager takes (mavlink_mission.cpp, parse_mavlink_mission_item), written
# out here from its source, apart from aerosurvey's own table: commands with a position ...
PX4_WITH_POSITION = {16, 17, 19, 21, 22, 31, 80, 84, 85, 195, 201, 212, 400, 4501, 5000, 5001, 5002, 5003, 5004, 5100}
# ... and commands in MAV_FRAME_MISSION (2)
PX4_WITHOUT_POSITION = {20, 80, 93, 112, 114, 177, 178, 179, 187, 189, 197, 200, 201, 203, 204, 205, 206, 211, 212, 213,
                        214, 260, 400, 530, 532, 534, 1000, 1001, 2000, 2001, 2003, 2500, 2501, 3000, 42600}
# dataman's room per mission type: CONFIG_NUM_MISSION_ITMES_SUPPORTED (2000 on a flight controller),
# DM_KEY_FENCE_POINTS_MAX, DM_KEY_SAFE_POINTS_MAX
PX4_ROOM = {0: 2000, 1: 64, 2: 32}


def px4_parse(command: int, frame: int, p: tuple[float, float, float, float], x: int, y: int, z: float) -> Stored:
    """Store an item as PX4 does: the fields its mission_item_s has, yaw in radians (float32)."""
    if frame in (0, 3, 5, 6):
        if command not in PX4_WITH_POSITION:
            raise Unsupported(mp.UNSUPPORTED)
        # math::radians in float: degrees * (float(M_PI) / 180.f)
        yaw = _f32(_f32(p[3]) * _f32(_f32(math.pi) / 180.0)) if math.isfinite(p[3]) else p[3]
        kept = {16: (p[0], p[1], 0.0, yaw), 21: (0.0, p[1], 0.0, yaw), 22: (0.0, 0.0, 0.0, yaw), 84: (0.0, 0.0, 0.0, yaw),
                85: (0.0, 0.0, 0.0, yaw), 5001: (float(int(p[0] + 0.5)), 0.0, 0.0, 0.0),
                5002: (float(int(p[0] + 0.5)), 0.0, 0.0, 0.0), 5100: (0.0, 0.0, 0.0, 0.0)}.get(command, p)
        return Stored(command, frame, tuple(_f32(v) for v in kept), x, y, _f32(z))  # type: ignore[arg-type]
    if frame == 2:
        if command not in PX4_WITHOUT_POSITION:
            raise Unsupported(mp.UNSUPPORTED)
        return Stored(command, 2, tuple(_f32(v) for v in p), int(_f32(x)), int(_f32(y)), _f32(z))  # type: ignore[arg-type]
    raise Unsupported(mp.UNSUPPORTED_FRAME)


def px4_format(s: Stored, mtype: int) -> Stored:
    """The item PX4 sends back for what it stored (format_mavlink_mission_item, MISSION_ITEM_INT): positions in
    the _INT frames (a fence vertex always in MAV_FRAME_GLOBAL_INT), the yaw in degrees wrapped to [0, 360)."""
    if s.frame == 2:
        return s
    yaw = s.params[3]
    if math.isfinite(yaw):  # matrix::wrap_2pi (float: x - range * floor(x * (1 / range)) outside [0, range)), math::degrees
        two_pi = _f32(2 * math.pi)
        if not 0.0 <= yaw < two_pi:
            yaw = _f32(yaw - _f32(two_pi * math.floor(_f32(yaw * _f32(1.0 / two_pi)))))
        yaw = _f32(yaw * _f32(180.0 / _f32(math.pi)))
    relative = s.frame in (3, 6) and mtype != 1
    return Stored(s.command, 6 if relative else 5, (*s.params[:3], yaw), s.x, s.y, s.z)


#: The parameters the fake answers unless told otherwise: an ArduCopter, an ArduPlane and a PX4 set up
#: for a survey (a camera, terrain data, a battery failsafe above a 25 % reserve, RTL above the
#: test plans' flat ground, speed limits above their speeds). Names and units as each autopilot
#: has them (ArduPilot's parameter docs, PX4's parameter reference); MIS_DIST_WPS is absent as
#: from PX4 v1.14 on, MIS_DIST_1WP present as in every PX4.
SURVEY_PARAMS: dict[str, dict[str, float | int]] = {
    "copter": {"TERRAIN_ENABLE": 1, "CAM1_TYPE": 1, "RTL_ALT": 6000, "WPNAV_SPEED": 1000.0, "BATT_MONITOR": 4,
               "BATT_FS_LOW_ACT": 2, "BATT_LOW_MAH": 1000.0, "BATT_CAPACITY": 3300.0},
    "plane": {"TERRAIN_ENABLE": 1, "CAM1_TYPE": 1, "RTL_ALTITUDE": 100.0, "AIRSPEED_MAX": 25.0, "AIRSPEED_CRUISE": 16.0,
              "BATT_MONITOR": 4, "BATT_FS_LOW_ACT": 1, "BATT_LOW_MAH": 1000.0, "BATT_CAPACITY": 3300.0},
    "px4": {"TRIG_MODE": 4, "TRIG_INTERFACE": 3, "RTL_RETURN_ALT": 60.0, "MPC_XY_VEL_MAX": 15.0, "MPC_XY_CRUISE": 10.0,
            "FW_AIRSPD_MAX": 25.0, "FW_AIRSPD_TRIM": 16.0, "COM_LOW_BAT_ACT": 3, "BAT_CRIT_THR": 0.3, "BAT_LOW_THR": 0.35,
            "MIS_DIST_1WP": 10000.0},
}


class VehicleModel:
    """The vehicle side of the mission protocol, driven by messages and a clock it is given."""

    def __init__(self, *, system: int = 1, component: int = 1, storage: str = "verbatim", plane: bool = False,
                 home: tuple[float, float, float] = (49.4, 15.0, 400.0), no_space_first: int = 0,
                 capacity: int = 2000, answer_missions: bool = True, alter: dict[int, dict[str, float]] | None = None,
                 legacy_requests: bool = False, request_resend: float = 0.2, upload_timeout: float = 2.0,
                 early_accept_after: int | None = None, fail_item: int | None = None,
                 silent_after_request: int | None = None, px4: bool = False, fix: bool = True,
                 mav_type: int | None = None, lose_final_acks: int = 0, params: dict[str, float | int | None] | None = None,
                 answer_params: bool = True) -> None:
        self.mav = mavlink2.MAVLink(None, srcSystem=system, srcComponent=component)
        self.system, self.component = system, component
        self.storage = storage
        self.plane = plane
        self.px4 = px4
        self.fix = fix
        self.autopilot = 12 if px4 else 3 if storage == "ardupilot" else 0
        self.mav_type = mav_type if mav_type is not None else 1 if plane else 2
        if px4:  # MAVLINK_MISSION_RETRY_TIMEOUT_DEFAULT and MAVLINK_MISSION_PROTOCOL_TIMEOUT_DEFAULT
            request_resend, upload_timeout = 0.25, 5.0
        self.home = home
        self.no_space_left = no_space_first
        self.capacity = capacity
        self.answer_missions = answer_missions
        self.alter = alter or {}
        self.legacy_requests = legacy_requests
        self.request_resend = request_resend
        self.upload_timeout = upload_timeout
        self.early_accept_after = early_accept_after  # a faulty vehicle: ACCEPTED before the last item
        self.fail_item = fail_item  # a mission item whose storage fails (ERROR, upload ends)
        self.silent_after_request = silent_after_request  # asks for this mission item, then never answers again
        self.lose_final_acks = lose_final_acks  # the final ACCEPTED of this many uploads never leaves the vehicle
        # parameters it answers PARAM_REQUEST_READ for (a float REAL32, an int INT32): a vehicle set up for a survey
        # (`SURVEY_PARAMS`), with `params` over them (None: the vehicle has no such parameter); it says nothing
        # for a name it does not have, and nothing at all without `answer_params`
        defaults = SURVEY_PARAMS["px4" if px4 else "plane" if plane else "copter"] if storage == "ardupilot" or px4 else {}
        merged = {**defaults, **(params or {})}
        self.params = {k: v for k, v in merged.items() if v is not None} if answer_params else {}
        self.stored: dict[int, list[Stored]] = {0: [], 1: [], 2: []}
        self.receiving: int | None = None  # mission type being uploaded
        self._staging: list[Stored] = []
        self._count = 0
        self._next = 0
        self._gcs = (255, 190)
        self._last_receive = 0.0
        self._last_request = 0.0
        self.log: dict[str, int] = {}
        self.completed_uploads = 0
        self._last_done: tuple[int, int] | None = None  # PX4: (mission type, count) of the last completed upload
        self._send_seq: int | None = None  # PX4: the next item its download expects to be asked for

    def _note(self, what: str) -> None:
        self.log[what] = self.log.get(what, 0) + 1

    def heartbeat(self) -> Any:
        return self.mav.heartbeat_encode(self.mav_type, self.autopilot, 0, 0, 4)

    def _ack(self, result: int, mtype: int) -> Any:
        self._note(f"ack {mp.result_name(result)}")
        return self.mav.mission_ack_encode(*self._gcs, result, mission_type=mtype)

    def _request(self, seq: int, mtype: int) -> Any:
        if self.legacy_requests:
            return self.mav.mission_request_encode(*self._gcs, seq, mission_type=mtype)
        return self.mav.mission_request_int_encode(*self._gcs, seq, mission_type=mtype)

    def _store(self, m: Any, mtype: int) -> Stored:
        if mtype == 0 and m.seq == self.fail_item:
            raise Unsupported(mp.ERROR)
        params = (float(m.param1), float(m.param2), float(m.param3), float(m.param4))
        x, y = int(m.x), int(m.y)
        if m.get_type() == "MISSION_ITEM":
            x, y = int(m.x * 1e7), int(m.y * 1e7)
        if self.px4:
            s = px4_parse(int(m.command), int(m.frame), params, x, y, float(m.z))
        elif mtype == 1:
            if m.command not in (5001, 5002):
                raise Unsupported(mp.UNSUPPORTED)
            return Stored(int(m.command), 0, (float(int(m.param1) & 0xFF), 0.0, 0.0, 0.0), x, y, 0.0)
        elif mtype == 2 and self.storage == "ardupilot":  # ArduPilot's RallyLocation: relative altitude in whole metres (int16)
            if m.command != 5100:
                raise Unsupported(mp.UNSUPPORTED)
            if m.frame not in (3, 6):
                raise Unsupported(mp.UNSUPPORTED_FRAME)
            return Stored(5100, 6, (0.0, 0.0, 0.0, 0.0), x, y, float(int(m.z)))
        elif self.storage == "ardupilot":
            s = ardupilot_pack(int(m.command), int(m.frame), params, x, y, float(m.z), self.plane)
        else:
            s = Stored(int(m.command), int(m.frame), tuple(_f32(p) for p in params), x, y, _f32(float(m.z)))  # type: ignore[arg-type]
        for name, value in self.alter.get(int(m.seq), {}).items():
            if name.startswith("param"):
                ps = list(s.params)
                ps[int(name[-1]) - 1] = value
                s.params = tuple(ps)  # type: ignore[assignment]
            else:
                setattr(s, name, type(getattr(s, name))(value))
        return s

    def _item_out(self, seq: int, mtype: int, legacy: bool) -> Any:
        if mtype == 0 and seq == 0 and self.storage == "ardupilot":
            lat, lon, alt = self.home
            s = Stored(16, 0, (0.0, 0.0, 0.0, 0.0), round(lat * 1e7), round(lon * 1e7), alt)
        else:
            s = self.stored[mtype][seq]
        if self.px4:
            s = px4_format(s, mtype)
        if legacy:
            return self.mav.mission_item_encode(*self._gcs, seq, s.frame, s.command, 0, 1, *s.params,
                                                s.x * 1e-7, s.y * 1e-7, s.z, mission_type=mtype)
        return self.mav.mission_item_int_encode(*self._gcs, seq, s.frame, s.command, 0, 1, *s.params,
                                                s.x, s.y, s.z, mission_type=mtype)

    def _position(self, msg_id: float) -> list[Any]:
        lat, lon, alt = (round(self.home[0] * 1e7), round(self.home[1] * 1e7), round(self.home[2] * 1000))
        answer = {33: lambda: self.mav.global_position_int_encode(0, lat, lon, alt, 0, 0, 0, 0, 0),
                  242: lambda: self.mav.home_position_encode(lat, lon, alt, 0, 0, 0, [1, 0, 0, 0], 0, 0, 0)}.get(int(msg_id))
        if answer is None or not self.fix:
            return [self.mav.command_ack_encode(512, 4)]  # MAV_RESULT_FAILED
        return [self.mav.command_ack_encode(512, 0), answer()]

    def handle(self, m: Any, now: float) -> list[Any]:
        kind = m.get_type()
        if kind == "COMMAND_LONG" and m.command == 512:  # MAV_CMD_REQUEST_MESSAGE
            self._note("got REQUEST_MESSAGE")
            return self._position(m.param1)
        if kind == "PARAM_REQUEST_READ":
            self._note(f"got PARAM_REQUEST_READ {m.param_id}")
            if m.param_id not in self.params:
                return []
            value = self.params[m.param_id]
            if isinstance(value, int) and self.px4:  # MAV_PARAM_TYPE_INT32, its bytes in the float (PX4's bytewise encoding)
                return [self.mav.param_value_encode(m.param_id.encode(), struct.unpack("<f", struct.pack("<i", value))[0],
                                                    6, len(self.params), 0)]
            if isinstance(value, int):  # ArduPilot casts an integer parameter to the float, its type says which
                return [self.mav.param_value_encode(m.param_id.encode(), float(value), 6, len(self.params), 0)]
            return [self.mav.param_value_encode(m.param_id.encode(), value, 9, len(self.params), 0)]
        if kind == "HEARTBEAT" or not kind.startswith("MISSION_"):
            return []
        self._note(f"got {kind}")
        if not self.answer_missions:
            return []
        self._gcs = (m.get_srcSystem(), m.get_srcComponent())  # answers go to whoever asked (PX4: its transfer partner)
        if getattr(m, "target_system", self.system) not in (0, self.system):
            return []
        mtype = int(getattr(m, "mission_type", 0))
        if mtype not in self.stored:
            return [self._ack(mp.UNSUPPORTED, mtype)]
        if kind == "MISSION_COUNT":
            if self.px4 and self.receiving is not None:
                self._last_receive = now
                if self._next == 0:  # "looks like our MISSION_REQUEST was lost, try again"
                    return [self._request(0, mtype)]
                return [self._ack(mp.ERROR, mtype)]  # busy, already receiving
            if self.no_space_left > 0:
                self.no_space_left -= 1
                return [self._ack(mp.NO_SPACE, mtype)]
            room = min(self.capacity, PX4_ROOM[mtype]) if self.px4 else self.capacity
            if m.count > room:
                if self.px4:  # PX4 says nothing more (a PX4_DEBUG line only)
                    return [self._ack(mp.NO_SPACE, mtype)]
                text = f"Only {self.capacity} items are supported".encode()  # ArduPilot says why in a STATUSTEXT
                return [self._ack(mp.NO_SPACE, mtype), self.mav.statustext_encode(4, text)]
            self.receiving = mtype
            self._count, self._next = int(m.count), 0
            self._staging = []
            if mtype == 0 and not self.px4:  # ArduPilot truncates, then writes items in place
                del self.stored[0][self._count:]
            self._last_receive = self._last_request = now
            if self._count == 0:
                return self._complete(mtype)
            return [self._request(0, mtype)]
        if kind in ("MISSION_ITEM_INT", "MISSION_ITEM"):
            if self.receiving is None or self.receiving != mtype:
                if self.px4 and self._last_done == (mtype, int(m.seq) + 1):
                    return [self._ack(mp.ACCEPTED, mtype)]  # a repeat of the last item: its ACK was lost
                return [self._ack(mp.ERROR, mtype)]
            if m.seq != self._next:
                if self.px4:
                    self._last_receive = now
                    self._note("item dropped")
                    return []
                return [self._ack(mp.INVALID_SEQUENCE, mtype)]
            try:
                s = self._store(m, mtype)
            except Unsupported as exc:
                self.receiving = None
                return [self._ack(exc.result, mtype)]
            if mtype == 0 and not self.px4:
                if m.seq < len(self.stored[0]):
                    self.stored[0][m.seq] = s
                else:
                    self.stored[0].append(s)
            else:
                self._staging.append(s)
            self._next += 1
            self._last_receive = self._last_request = now
            if self._next == self._count or self._next == self.early_accept_after:
                return self._complete(mtype)
            if mtype == 0 and self._next == self.silent_after_request:
                self.answer_missions = False  # e.g. the telemetry radio lost power
            return [self._request(self._next, mtype)]
        if kind == "MISSION_REQUEST_LIST":
            if self.receiving is not None:
                return [] if self.px4 else [self._ack(mp.DENIED, mtype)]  # PX4: "ignored, already active"
            self._send_seq = 0
            return [self.mav.mission_count_encode(*self._gcs, len(self.stored[mtype]), mission_type=mtype)]
        if kind in ("MISSION_REQUEST_INT", "MISSION_REQUEST"):
            if self.receiving is not None:
                return [] if self.px4 else [self._ack(mp.DENIED, mtype)]
            if self.px4:
                if self._send_seq is None:
                    return []  # no transfer: ignored
                if m.seq == self._send_seq and m.seq < len(self.stored[mtype]):
                    self._send_seq += 1
                elif m.seq != self._send_seq - 1:
                    self._send_seq = None
                    return [self._ack(mp.ERROR, mtype)]
            if m.seq >= len(self.stored[mtype]):
                return [self._ack(mp.INVALID_SEQUENCE, mtype)]
            return [self._item_out(int(m.seq), mtype, kind == "MISSION_REQUEST")]
        return []

    def _complete(self, mtype: int) -> list[Any]:
        if mtype != 0 or self.px4:
            self.stored[mtype] = list(self._staging)
        self._last_done = (mtype, self._count)
        self.receiving = None
        self.completed_uploads += 1
        if self.lose_final_acks > 0:
            self.lose_final_acks -= 1
            self._note("final ack lost")
            return []
        return [self._ack(mp.ACCEPTED, mtype)]

    def poll(self, now: float) -> list[Any]:
        if self.receiving is None or not self.answer_missions:
            return []
        if now - self._last_receive > self.upload_timeout:
            mtype, self.receiving = self.receiving, None
            return [] if self.px4 else [self._ack(mp.OPERATION_CANCELLED, mtype)]  # PX4: "Operation timeout" only
        if now - self._last_request > self.request_resend:
            self._last_request = now
            self._note("request resend")
            return [self._request(self._next, self.receiving)]
        return []


@dataclass
class Faults:
    """Per-packet fault probabilities, the same both ways; `seed` makes a run repeatable."""

    drop: float = 0.0
    dup: float = 0.0
    reorder: float = 0.0
    seed: int = 0
    max_hold: float = 0.03  # seconds a reordered packet is held back

    def plan(self, rng: random.Random) -> list[float]:
        """Delays (s) of the copies of one packet to deliver: [] drops it, two entries duplicate it."""
        if rng.random() < self.drop:
            return []
        copies = 2 if rng.random() < self.dup else 1
        return [rng.uniform(0.001, self.max_hold) if rng.random() < self.reorder else 0.0 for _ in range(copies)]


class FakeVehicle:
    """A VehicleModel on a loopback socket (UDP or TCP) or a pseudo-terminal ("pty") in a thread, with packet faults."""

    def __init__(self, model: VehicleModel, transport: str = "udp", faults: Faults | None = None,
                 heartbeat_interval: float = 0.25, heartbeats: bool = True) -> None:
        self.model = model
        self.transport = transport
        self.faults = faults or Faults()
        self.rng = random.Random(self.faults.seed)
        self.heartbeat_interval = heartbeat_interval
        self.heartbeats = heartbeats
        self.parser = mavlink2.MAVLink(None, srcSystem=model.system, srcComponent=model.component)
        self.parser.robust_parsing = True
        self._stop = threading.Event()
        self._held: list[tuple[float, int, str, Any]] = []
        self._n = 0
        self._peer: Any = None
        self._client: socket.socket | None = None
        self._pty: tuple[int, int] | None = None
        if transport == "pty":
            master, slave = os.openpty()
            tty.setraw(slave)  # a serial line: no echo, no line editing (pyserial sets the same when it opens it)
            self._pty = (master, slave)
            self.device = os.ttyname(slave)
            self._thread = threading.Thread(target=self._run, name="fake-vehicle", daemon=True)
            return
        if transport == "udp":
            self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        else:
            self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.sock.bind((LOOPBACK, 0))
        if transport == "tcp":
            self.sock.listen(1)
        self.port = self.sock.getsockname()[1]
        self._thread = threading.Thread(target=self._run, name="fake-vehicle", daemon=True)

    @property
    def url(self) -> str:
        if self._pty is not None:
            return self.device
        return f"udpout:{LOOPBACK}:{self.port}" if self.transport == "udp" else f"tcp:{LOOPBACK}:{self.port}"

    def __enter__(self) -> FakeVehicle:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        if self._pty is not None:
            for fd in self._pty:
                os.close(fd)
            self._pty = None
            return
        for s in (self._client, self.sock):
            if s is not None:
                s.close()

    def _schedule(self, now: float, direction: str, payload: Any) -> None:
        for delay in self.faults.plan(self.rng):
            self._n += 1
            heapq.heappush(self._held, (now + delay, self._n, direction, payload))

    def _emit(self, msg: Any, now: float) -> None:
        self._schedule(now, "out", msg.pack(self.parser))

    def _write(self, data: bytes) -> None:
        try:
            if self._pty is not None:
                os.write(self._pty[0], data)
            elif self.transport == "udp" and self._peer is not None:
                self.sock.sendto(data, self._peer)
            elif self._client is not None:
                self._client.sendall(data)
        except OSError:
            pass

    def _run(self) -> None:
        next_hb = 0.0
        while not self._stop.is_set():
            now = time.monotonic()
            connected = self._peer is not None or self._client is not None or self._pty is not None
            if self.heartbeats and now >= next_hb and connected:
                self._write(self.model.heartbeat().pack(self.parser))
                next_hb = now + self.heartbeat_interval
            while self._held and self._held[0][0] <= now:
                _, _, direction, payload = heapq.heappop(self._held)
                if direction == "out":
                    self._write(payload)
                else:
                    for out in self.model.handle(payload, now):
                        self._emit(out, now)
            for out in self.model.poll(now):
                self._emit(out, now)
            wait = 0.005 if self._held else 0.02
            if self._pty is not None:
                readable, _, _ = select.select([self._pty[0]], [], [], wait)
                if readable:
                    for m in self.parser.parse_buffer(os.read(self._pty[0], 65535)) or []:
                        self._schedule(time.monotonic(), "in", m)
                continue
            socks = [self.sock] + ([self._client] if self._client is not None else [])
            readable, _, _ = select.select(socks, [], [], wait)
            for s in readable:
                self._read(s, time.monotonic())

    def _read(self, s: socket.socket, now: float) -> None:
        if self.transport == "tcp" and s is self.sock:
            client, _ = s.accept()
            if self._client is not None:
                self._client.close()
            self._client = client
            return
        try:
            if self.transport == "udp":
                data, self._peer = s.recvfrom(65535)
            else:
                data = s.recv(65535)
        except OSError:
            return
        if not data and self._client is not None:
            self._client.close()
            self._client = None
            return
        for m in self.parser.parse_buffer(data) or []:
            self._schedule(now, "in", m)


class SimLink:
    """aerosurvey's Link on a simulated clock, to a VehicleModel through a faulty simulated channel.

    Uses aerosurvey's own codec (connection.encode/decode) and real MAVLink bytes both ways,
    so only the sockets and the clock are simulated.
    """

    def __init__(self, model: VehicleModel, faults: Faults | None = None, drop_packets: frozenset[int] = frozenset(),
                 latency: float = 0.002) -> None:
        self.model = model
        self.latency = latency  # seconds each way
        self.faults = faults or Faults()
        self.drop_packets = drop_packets  # numbers (1, 2, …, both ways) of packets to lose on purpose
        self.rng = random.Random(self.faults.seed)
        self.t = 0.0
        self.gcs = mavlink2.MAVLink(None, srcSystem=connection.GCS_SYSTEM, srcComponent=connection.GCS_COMPONENT)
        self.gcs_parser = mavlink2.MAVLink(None, srcSystem=connection.GCS_SYSTEM, srcComponent=connection.GCS_COMPONENT)
        self.veh_parser = mavlink2.MAVLink(None, srcSystem=model.system, srcComponent=model.component)
        self.vehicle = connection.Vehicle(model.system, model.component, model.autopilot, model.mav_type)
        self._q: list[tuple[float, int, str, bytes]] = []
        self._n = 0
        self._next_poll = 0.0
        self.packets = 0

    def now(self) -> float:
        return self.t

    def _put(self, direction: str, data: bytes) -> None:
        self.packets += 1
        if self.packets in self.drop_packets:
            return
        for delay in self.faults.plan(self.rng):
            self._n += 1
            heapq.heappush(self._q, (self.t + self.latency + delay, self._n, direction, data))

    def send(self, msg: mp.Message) -> None:
        m = connection.encode(self.gcs, msg, (self.vehicle.system, self.vehicle.component))
        self._put("up", m.pack(self.gcs))

    def recv(self, until: float) -> mp.Message | None:
        for _ in range(10_000_000):
            next_t = min(self._q[0][0] if self._q else math.inf, self._next_poll, until)
            if next_t > self.t:
                self.t = next_t
            if self.t >= self._next_poll:
                for out in self.model.poll(self.t):
                    self._put("down", out.pack(self.veh_parser))
                self._next_poll = self.t + 0.01
            while self._q and self._q[0][0] <= self.t:
                _, _, direction, data = heapq.heappop(self._q)
                if direction == "up":
                    for m in self.veh_parser.parse_buffer(data) or []:
                        for out in self.model.handle(m, self.t):
                            self._put("down", out.pack(self.veh_parser))
                else:
                    for m in self.gcs_parser.parse_buffer(data) or []:
                        msg = connection.decode(m)
                        if msg is not None:
                            return msg
            if self.t >= until:
                return None
        raise RuntimeError("simulation did not advance")


class LossyRelay:
    """A UDP relay on loopback between one client and a vehicle that drops a share of datagrams.

    The vehicle is at `target_port`, or (None) it sends first to `back_port` and is learnt from
    that (ArduPilot SITL with `--serial0 udpclient:127.0.0.1:PORT`).
    """

    def __init__(self, target_port: int | None, drop: float, seed: int) -> None:
        self.target: Any = (LOOPBACK, target_port) if target_port is not None else None
        self.drop = drop
        self.rng = random.Random(seed)
        self.front = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.front.bind((LOOPBACK, 0))
        self.back = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.back.bind((LOOPBACK, 0))
        self.port = self.front.getsockname()[1]
        self.back_port = self.back.getsockname()[1]
        self.client: Any = None
        self.counts = {"forwarded": 0, "dropped": 0}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="lossy-relay", daemon=True)

    @property
    def url(self) -> str:
        return f"udpout:{LOOPBACK}:{self.port}"

    def __enter__(self) -> LossyRelay:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        self.front.close()
        self.back.close()

    def _pass(self, data: bytes, sock: socket.socket, to: Any) -> None:
        if to is None:  # the other side has not shown up yet
            self.counts["unrouted"] = self.counts.get("unrouted", 0) + 1
            return
        if self.rng.random() < self.drop:
            self.counts["dropped"] += 1
            return
        self.counts["forwarded"] += 1
        sock.sendto(data, to)

    def _run(self) -> None:
        while not self._stop.is_set():
            readable, _, _ = select.select([self.front, self.back], [], [], 0.02)
            for s in readable:
                try:
                    data, addr = s.recvfrom(65535)
                except OSError:
                    continue
                if s is self.front:
                    self.client = addr
                    self._pass(data, self.back, self.target)
                else:
                    if self.target is None:
                        self.target = addr
                    self._pass(data, self.front, self.client)



def survey_mission(n_waypoints: int, *, fence: bool = False, firmware: str = "ardupilot", vehicle: str = "copter",
                   seed: int = 0) -> Mission:
    """A survey-shaped mission near 49.4 N 15.0 E: takeoff, speed, camera on, waypoints, camera off, RTL."""
    rng = random.Random(seed)
    lat0, lon0 = 49.4, 15.0
    items = [MissionItem(mav.NAV_TAKEOFF, mav.FRAME_GLOBAL_RELATIVE_ALT, 0, 0, 0, math.nan, lat0, lon0, 80.0),
             MissionItem(mav.DO_CHANGE_SPEED, mav.FRAME_MISSION, 1, 12.5, -1, 0),
             MissionItem(mav.DO_SET_CAM_TRIGG_DIST, mav.FRAME_MISSION, 21.37, 0, 1, 0)]
    for k in range(n_waypoints):
        items.append(MissionItem(mav.NAV_WAYPOINT, mav.FRAME_GLOBAL_RELATIVE_ALT, 0, 0, 0, math.nan,
                                 round(lat0 + 0.0004 * (k // 2) + rng.uniform(-1e-6, 1e-6), 8),
                                 round(lon0 + 0.006 * ((k // 2 + k) % 2) + rng.uniform(-1e-6, 1e-6), 8),
                                 round(80.0 + rng.uniform(-5, 5), 2)))
    items += [MissionItem(mav.DO_SET_CAM_TRIGG_DIST, mav.FRAME_MISSION, 0, 0, 0, 0),
              MissionItem(mav.NAV_RETURN_TO_LAUNCH, mav.FRAME_MISSION)]
    inc = (((lat0 - 0.001, lon0 - 0.001), (lat0 + 0.02, lon0 - 0.001), (lat0 + 0.02, lon0 + 0.008),
            (lat0 - 0.001, lon0 + 0.008)),) if fence else ()
    exc = (((lat0 + 0.005, lon0 + 0.002), (lat0 + 0.006, lon0 + 0.002), (lat0 + 0.006, lon0 + 0.003),
            (lat0 + 0.005, lon0 + 0.002)),) if fence else ()
    return Mission(vehicle=vehicle, firmware=firmware, home=(lat0 - 0.0005, lon0 - 0.0005, 402.5), items=tuple(items),
                   cruise_speed=12.5, hover_speed=5.0, fence_inclusion=inc, fence_exclusion=exc)
