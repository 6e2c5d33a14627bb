"""A MAVLink link to one vehicle through pymavlink: open, wait for its heartbeat, send, receive, close.

Any pymavlink connection string works (tcp:HOST:PORT, udpin:HOST:PORT, udpout:HOST:PORT,
a serial device such as /dev/ttyACM0 or /dev/ttyUSB0,57600, opened through pyserial).
Failures become one line a pilot can act on: LinkError (exit 1) when the vehicle cannot be
reached, InputError (exit 2) when the connection string or the serial device it names is
wrong; pymavlink's own console chatter on TCP disconnects is replaced by that error. The
codec between pymavlink messages and the pure protocol messages of `mission_protocol` lives
here too.
"""

from __future__ import annotations

import errno
import os
import socket
import struct
import time
from dataclasses import dataclass
from typing import Any

from aerosurvey.errors import CheckFailed, InputError
from aerosurvey.link import mission_protocol as mp

GCS_SYSTEM = 255
GCS_COMPONENT = 190  # MAV_COMP_ID_MISSIONPLANNER
_MAV_TYPE_GCS = 6
_MAV_AUTOPILOT_INVALID = 8
_MAV_CMD_REQUEST_MESSAGE = 512
_GLOBAL_POSITION_INT = 33
_HOME_POSITION = 242
AUTOPILOT_NAMES = {0: "generic", 3: "ArduPilot", 12: "PX4"}


class LinkError(CheckFailed):
    """The vehicle could not be reached or did not finish a transfer (exit code 1)."""


@dataclass(frozen=True)
class Vehicle:
    """Who answered: the ids to address and what its heartbeat says it is."""

    system: int
    component: int
    autopilot: int
    mav_type: int

    @property
    def autopilot_name(self) -> str:
        return AUTOPILOT_NAMES.get(self.autopilot, f"autopilot {self.autopilot}")


def _mavutil() -> Any:
    """pymavlink's mavutil set to MAVLink 2: fence uploads need the mission_type extension field."""
    os.environ["MAVLINK20"] = "1"
    from pymavlink import mavutil

    if getattr(mavutil.mavlink, "WIRE_PROTOCOL_VERSION", "") != "2.0" or mavutil.current_dialect != "ardupilotmega":
        mavutil.set_dialect("ardupilotmega")
    return mavutil


def encode(mav: Any, msg: mp.Message, target: tuple[int, int]) -> Any:
    """The pymavlink message for a protocol message, addressed to `target` (system, component)."""
    ts, tc = target
    if isinstance(msg, mp.Count):
        return mav.mission_count_encode(ts, tc, msg.count, mission_type=msg.mission_type)
    if isinstance(msg, mp.RequestList):
        return mav.mission_request_list_encode(ts, tc, mission_type=msg.mission_type)
    if isinstance(msg, mp.Request):
        if msg.legacy:
            return mav.mission_request_encode(ts, tc, msg.seq, mission_type=msg.mission_type)
        return mav.mission_request_int_encode(ts, tc, msg.seq, mission_type=msg.mission_type)
    if isinstance(msg, mp.Ack):
        return mav.mission_ack_encode(ts, tc, msg.result, mission_type=msg.mission_type)
    if isinstance(msg, mp.Item):
        it = msg.item
        return mav.mission_item_int_encode(ts, tc, it.seq, it.frame, it.command, it.current, it.autocontinue,
                                           it.param1, it.param2, it.param3, it.param4, it.x, it.y, it.z,
                                           mission_type=it.mission_type)
    raise TypeError(f"not a mission protocol message: {msg!r}")


def decode(m: Any) -> mp.Message | None:
    """The protocol message for a received pymavlink message, or None for anything else.

    A legacy MISSION_ITEM (float lat/lon) becomes the int32 1e-7 degree form of MISSION_ITEM_INT.
    """
    kind = m.get_type()
    mtype = int(getattr(m, "mission_type", 0) or 0)
    if kind in ("MISSION_REQUEST_INT", "MISSION_REQUEST"):
        return mp.Request(int(m.seq), mtype, legacy=kind == "MISSION_REQUEST")
    if kind == "MISSION_ACK":
        return mp.Ack(int(m.type), mtype)
    if kind == "MISSION_COUNT":
        return mp.Count(int(m.count), mtype)
    if kind in ("MISSION_ITEM_INT", "MISSION_ITEM"):
        x, y = (int(m.x), int(m.y)) if kind == "MISSION_ITEM_INT" else (round(m.x * 1e7), round(m.y * 1e7))
        return mp.Item(mp.WireItem(int(m.seq), int(m.command), int(m.frame), float(m.param1), float(m.param2),
                                   float(m.param3), float(m.param4), x, y, float(m.z), int(m.autocontinue),
                                   int(m.current), mtype))
    if kind == "MISSION_REQUEST_LIST":
        return mp.RequestList(mtype)
    return None


class MavLink:
    """One open pymavlink connection with the vehicle it talks to (after `wait_heartbeat`)."""

    def __init__(self, url: str, conn: Any) -> None:
        self.url = url
        self.conn = conn
        self.vehicle: Vehicle | None = None
        self.status_texts: list[tuple[float, int, str]] = []  # (time, severity, text) from the vehicle
        self._peer_closed = False
        self._last_gcs_heartbeat = -1.0
        if hasattr(conn, "handle_eof"):
            conn.handle_eof = self._on_peer_closed
            conn.handle_disconnect = self._on_peer_closed

    def _on_peer_closed(self) -> None:
        self._peer_closed = True

    @staticmethod
    def now() -> float:
        return time.monotonic()

    def close(self) -> None:
        try:
            self.conn.close()
        except OSError:
            pass

    def __enter__(self) -> MavLink:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _check_open(self) -> None:
        if self._peer_closed:
            raise LinkError(f"{self.url}: the vehicle closed the connection")

    def send_gcs_heartbeat(self) -> None:
        """Our heartbeat: a UDP or TCP vehicle learns where to answer from it."""
        self._write(self.conn.mav.heartbeat_encode(_MAV_TYPE_GCS, _MAV_AUTOPILOT_INVALID, 0, 0, 0))
        self._last_gcs_heartbeat = self.now()

    def _write(self, m: Any) -> None:
        self._check_open()
        try:
            self.conn.mav.send(m)
        except OSError as exc:
            raise LinkError(f"{self.url}: cannot send: {exc.strerror or exc}") from None
        self._check_open()

    def _recv_raw(self, until: float) -> Any | None:
        """The next pymavlink message before `until` (monotonic seconds), or None."""
        while True:
            self._check_open()
            try:
                m = self.conn.recv_msg()
            except OSError as exc:
                if exc.errno == errno.ECONNREFUSED:
                    raise LinkError(f"{self.url}: connection refused by the vehicle's port") from None
                raise LinkError(f"{self.url}: receive failed: {exc.strerror or exc}") from None
            self._check_open()
            if m is not None and m.get_type() != "BAD_DATA":
                return m
            left = until - self.now()
            if left <= 0:
                return None
            if m is None:
                self.conn.select(min(left, 0.05))

    def wait_heartbeat(self, timeout: float) -> Vehicle:
        """The first vehicle heartbeat within `timeout` s; ours goes out every 0.5 s meanwhile."""
        end = self.now() + timeout
        while self.now() < end:
            if self.now() - self._last_gcs_heartbeat >= 0.5:
                self.send_gcs_heartbeat()
            m = self._recv_raw(min(end, self._last_gcs_heartbeat + 0.5))
            if m is None or m.get_type() != "HEARTBEAT":
                continue
            if m.type == _MAV_TYPE_GCS or m.autopilot == _MAV_AUTOPILOT_INVALID:
                continue
            self.vehicle = Vehicle(m.get_srcSystem(), m.get_srcComponent(), int(m.autopilot), int(m.type))
            return self.vehicle
        raise LinkError(f"{self.url}: no heartbeat from a vehicle within {timeout:g} s "
                        "(is it powered and is this the right connection string?)")

    def vehicle_position(self, wait: float) -> tuple[float, float] | None:
        """Where the vehicle is (latitude, longitude): its GLOBAL_POSITION_INT, else its HOME_POSITION.

        Both are asked for with MAV_CMD_REQUEST_MESSAGE (again every 0.5 s) and taken from the
        stream too; None when neither came within `wait` seconds with a position other than 0, 0
        (no GPS fix), or the vehicle refused both requests.
        """
        if self.vehicle is None:
            raise RuntimeError("wait_heartbeat() first: the target ids come from the vehicle's heartbeat")
        end, asked, home, refused = self.now() + wait, -1.0, None, 0
        while self.now() < end and refused < 2:
            if self.now() - asked >= 0.5:
                for msg_id in (_GLOBAL_POSITION_INT, _HOME_POSITION):
                    self._write(self.conn.mav.command_long_encode(self.vehicle.system, self.vehicle.component,
                                                                  _MAV_CMD_REQUEST_MESSAGE, 0, msg_id, 0, 0, 0, 0, 0, 0))
                asked = self.now()
            m = self._recv_raw(min(end, asked + 0.5))
            if m is None or m.get_srcSystem() != self.vehicle.system:
                continue
            kind = m.get_type()
            if kind == "GLOBAL_POSITION_INT" and (m.lat, m.lon) != (0, 0):
                return (m.lat * 1e-7, m.lon * 1e-7)
            if kind == "HOME_POSITION" and (m.latitude, m.longitude) != (0, 0):
                home = (m.latitude * 1e-7, m.longitude * 1e-7)
            elif kind == "COMMAND_ACK" and m.command == _MAV_CMD_REQUEST_MESSAGE and m.result != 0:
                refused += 1  # MAV_RESULT_FAILED: e.g. no position yet
        return home

    def read_params(self, names: tuple[str, ...], wait: float, settle: float = 2.0) -> dict[str, float]:
        """The values of the parameters `names` the vehicle answered PARAM_REQUEST_READ for,
        asked again every 0.5 s until all have answered, or `settle` seconds after the first
        answer (a vehicle answers every name it has together; the names still unanswered are asked
        again meanwhile, so that on a lossy link a lost answer is not taken for a parameter the
        vehicle does not have), or `wait` seconds in all. A vehicle
        without a parameter does not answer for it (PX4) or sends PARAM_ERROR (unknown to
        pymavlink's dialect: ignored), so a name missing from the result was not answered.
        Integer parameters come as PX4 sends them, their bytes in the float (MAVLink's bytewise
        encoding), as ArduPilot sends them, cast to the float."""
        if self.vehicle is None:
            raise RuntimeError("wait_heartbeat() first: the target ids come from the vehicle's heartbeat")
        got: dict[str, float] = {}
        end, asked, first = self.now() + wait, -1.0, None
        while self.now() < end and len(got) < len(names) and (first is None or self.now() < first + settle):
            if self.now() - asked >= 0.5:
                for name in names:
                    if name not in got:
                        self._write(self.conn.mav.param_request_read_encode(self.vehicle.system, self.vehicle.component,
                                                                            name.encode(), -1))
                asked = self.now()
            m = self._recv_raw(min(end, asked + 0.5))
            if m is None or m.get_type() != "PARAM_VALUE" or m.get_srcSystem() != self.vehicle.system:
                continue
            name = m.param_id if isinstance(m.param_id, str) else m.param_id.decode(errors="replace")
            if name in names:
                got[name] = param_value(float(m.param_value), int(m.param_type), self.vehicle.autopilot)
                first = self.now() if first is None else first
        return got

    def send(self, msg: mp.Message) -> None:
        if self.vehicle is None:
            raise RuntimeError("wait_heartbeat() first: the target ids come from the vehicle's heartbeat")
        self._write(encode(self.conn.mav, msg, (self.vehicle.system, self.vehicle.component)))
        if self.now() - self._last_gcs_heartbeat >= 1.0:
            self.send_gcs_heartbeat()

    def recv(self, until: float) -> mp.Message | None:
        """The next mission protocol message from our vehicle addressed to us, or None at `until`."""
        assert self.vehicle is not None
        while True:
            m = self._recv_raw(until)
            if m is None:
                return None
            if m.get_srcSystem() != self.vehicle.system:
                continue
            if m.get_type() == "STATUSTEXT":
                self.status_texts = [*self.status_texts[-19:], (self.now(), int(m.severity), str(m.text))]
                continue
            if getattr(m, "target_system", GCS_SYSTEM) not in (0, GCS_SYSTEM):
                continue
            msg = decode(m)
            if msg is not None:
                return msg


#: MAV_PARAM_TYPE of the integers (UINT8 … INT32) and their struct formats
_INT_PARAM_FORMATS = {1: "<B3x", 2: "<b3x", 3: "<H2x", 4: "<h2x", 5: "<I", 6: "<i"}
_AUTOPILOT_PX4 = 12


def param_value(value: float, param_type: int, autopilot: int) -> float:
    """A PARAM_VALUE's value: PX4 puts an integer's bytes into the float (bytewise encoding)."""
    fmt = _INT_PARAM_FORMATS.get(param_type)
    if fmt is None or autopilot != _AUTOPILOT_PX4:
        return value
    return float(struct.unpack(fmt, struct.pack("<f", value))[0])


def param_wire_value(value: float, param_type: int, autopilot: int) -> float:
    """The float a PARAM_SET carries for `value`, as `param_value` reads it back: PX4 copies the float's
    bytes into an integer parameter (bytewise encoding), ArduPilot casts the float."""
    fmt = _INT_PARAM_FORMATS.get(param_type)
    if fmt is None or autopilot != _AUTOPILOT_PX4:
        return value
    return float(struct.unpack("<f", struct.pack(fmt, int(value)))[0])


# pymavlink's network and other non-serial prefixes (mavutil.mavlink_connection); anything else
# without a colon, that is not a file, it opens as a serial device
_NETWORK_PREFIXES = ("tcp:", "tcpin:", "udp:", "udpin:", "udpout:", "udpbcast:", "mcast:", "uds:", "unix:",
                     "ws:", "wss:", "wsserver:", "csv:")


def serial_device(url: str) -> str | None:
    """The serial device pymavlink opens for `url` (without a ",BAUD" suffix), or None for any other link."""
    if url.lower().startswith(_NETWORK_PREFIXES) or ":" in url or os.path.isfile(url):
        return None
    if "," in url and not os.path.exists(url):
        return url.split(",", 1)[0]
    return url


def _serial_reason(exc: OSError) -> str:
    """Why a serial device did not open, in words a pilot can act on (pyserial's SerialException is an OSError)."""
    if exc.errno == errno.ENOENT:
        return "no such device (is the autopilot plugged in? over USB it is usually /dev/ttyACM0 or /dev/ttyUSB0)"
    if exc.errno in (errno.EACCES, errno.EPERM):
        return "permission denied (add your user to the dialout group and log in again)"
    if exc.errno == errno.EBUSY:
        return "the device is busy (another program has it open)"
    why = os.strerror(exc.errno) if exc.errno else (str(exc).splitlines() or [type(exc).__name__])[0]
    return f"not a serial port ({why})"


def open_link(url: str, timeout: float) -> MavLink:
    """Open `url` and wait for a vehicle heartbeat; LinkError (exit 1) or InputError (exit 2) otherwise."""
    link = connect(url, timeout)
    try:
        link.wait_heartbeat(timeout)
    except BaseException:
        link.close()
        raise
    return link


def connect(url: str, timeout: float) -> MavLink:
    """Open `url` (`timeout`: seconds for a TCP connect), not yet waiting for the vehicle;
    LinkError (exit 1) or InputError (exit 2) when it cannot be opened."""
    if not url or not url.strip():
        raise InputError("--connect is empty: give a pymavlink connection string such as tcp:127.0.0.1:5760")
    if os.path.isfile(url):
        raise InputError(f"--connect {url!r} is a file; give a link such as tcp:HOST:PORT, udpin:HOST:PORT or a serial device")
    device = serial_device(url)
    if device is not None and device != url and not url.rsplit(",", 1)[1].strip().isdigit():
        raise InputError(f"--connect {url!r}: the baud rate after the comma must be a whole number such as 57600 or 115200")
    mavutil = _mavutil()
    previous = socket.getdefaulttimeout()
    socket.setdefaulttimeout(timeout)  # bounds a TCP connect to a host that never answers
    try:
        conn = mavutil.mavlink_connection(url, source_system=GCS_SYSTEM, source_component=GCS_COMPONENT,
                                          retries=0, autoreconnect=False)
    except ValueError as exc:
        raise InputError(f"--connect {url!r}: {exc}") from None
    except ImportError as exc:  # pymavlink imports pyserial only when it opens a serial device
        raise InputError(f"--connect {url!r} names a serial device, and serial devices need pyserial, which is "
                         f"missing ({exc}): reinstall aerosurvey with its dependencies or pip install pyserial") from None
    except OSError as exc:
        if device is None:
            raise _network_error(url, exc, timeout) from None
        raise InputError(f"--connect {url!r}: cannot open the serial device {device}: {_serial_reason(exc)}") from None
    finally:
        socket.setdefaulttimeout(previous)
    return MavLink(url, conn)


def _network_error(url: str, exc: OSError, timeout: float) -> LinkError:
    """The one-line error for a network link that did not open."""
    if isinstance(exc, ConnectionRefusedError):
        return LinkError(f"{url}: connection refused (nothing listens there: is the vehicle or SITL running?)")
    if isinstance(exc, socket.gaierror):
        return LinkError(f"{url}: cannot resolve the host: {exc.strerror or exc}")
    if isinstance(exc, TimeoutError):
        return LinkError(f"{url}: no connection within {timeout:g} s")
    return LinkError(f"{url}: cannot open: {exc.strerror or exc}")
