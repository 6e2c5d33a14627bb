"""Fly planned sorties in PX4's SITL with its SIH simulator (no graphics, no Gazebo).

The harness only launches a PX4 SITL build the user already has (`--px4-bin`,
AEROSURVEY_PX4_BIN, or `px4` on PATH): the build's `bin/px4` and its ROMFS folder `etc/` next
to `bin/` (build/px4_sitl_default/bin/px4 and build/px4_sitl_default/etc after
`make px4_sitl_default`). It starts PX4 as its own SIH quadrotor (airframe 10040,
sihsim_quadx) in an empty working folder, at the sortie's launch point (PX4_HOME_LAT/LON/ALT),
with the parameters of sitl/aerosurvey-px4.params given the way PX4's start script takes them
(PX4_PARAM_<NAME> in its environment, set before its modules start: the camera trigger starts
at boot only when TRIG_MODE > 0), and the logger's topics from sitl/px4-logger-topics.txt
(PX4 reads etc/logging/logger_topics.txt in its working folder instead of its profiles).

Instance N of PX4 SITL (-i N) listens for a ground station on udp 18570+N and sends its
API/offboard link to udp 14540+N; it locks /tmp/px4_lock-N. The harness takes the lowest N
whose lock and ports are free. It flies on the ground station link (udpout, its first packet
makes PX4 answer that socket for good) and uploads on the API link (udpin 14540+N, which the
upload's checks and then MAVSDK open one after the other), through aerosurvey's PX4 upload
(`link.px4`): the same checks, MAVSDK transfer and read-back as `aerosurvey upload`.
"""

from __future__ import annotations

import fcntl
import os
import shutil
import socket
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from aerosurvey.errors import InputError
from aerosurvey.link.connection import LinkError, MavLink, connect, param_value, param_wire_value
from aerosurvey.link.sitl import SitlError, SitlVehicle, port_free, survey_params
from aerosurvey.link.upload import AUTOPILOT_PX4

SITL_DIR = Path(__file__).resolve().parents[3] / "sitl"
PARAMS_FILE = SITL_DIR / "aerosurvey-px4.params"
LOGGER_TOPICS_FILE = SITL_DIR / "px4-logger-topics.txt"
#: PX4 SITL's ports for instance N are these plus N (ROMFS init.d-posix/px4-rc.mavlink): the
#: ground station link, the API link (PX4's end and ours), the camera and gimbal links, SIH's display
GCS_PORT, API_PORT, API_REMOTE_PORT = 18570, 14580, 14540
OTHER_PORTS = (14280, 13030, 19450)
#: instances above 9 share one API port (px4-rc.mavlink)
MAX_INSTANCE = 9
#: PX4's SIH quadrotor: the airframe and the simulator model its start script takes
SIH_QUAD = {"PX4_SIMULATOR": "sihsim", "PX4_SIM_MODEL": "sihsim_quadx", "PX4_SYS_AUTOSTART": "10040"}
#: PX4's custom mode AUTO.MISSION (px4_custom_mode.h): main mode 4 (AUTO), sub mode 4 (MISSION)
AUTO_MISSION = (4.0, 4.0)
#: PX4's default MPC_XY_VEL_MAX: the fastest it flies a mission's speed (m/s)
PX4_XY_VEL_MAX = 12.0


def find_px4(explicit: str | None) -> Path:
    """PX4's SITL binary: the option, then AEROSURVEY_PX4_BIN (the binary or its bin/ folder), then
    `px4` on PATH; its ROMFS folder etc/ must lie next to its bin/ folder."""
    found: Path | None = None
    for source, value in (("--px4-bin", explicit), ("AEROSURVEY_PX4_BIN", os.environ.get("AEROSURVEY_PX4_BIN"))):
        if not value:
            continue
        p = Path(value)
        if p.is_dir():
            p = p / "px4"
        if not (p.is_file() and os.access(p, os.X_OK)):
            raise InputError(f"{source} = {value!r}: no executable px4 there")
        found = p
        break
    else:
        which = shutil.which("px4")
        if which is None:
            raise InputError("no PX4 SITL binary: give --px4-bin, set AEROSURVEY_PX4_BIN, or put px4 on PATH "
                             "(the build's bin/px4 after make px4_sitl_default; see sitl/README.md)")
        found = Path(which)
    romfs(found)
    return found


def romfs(binary: Path) -> Path:
    """The ROMFS folder etc/ of a PX4 SITL build, next to the binary's bin/ folder."""
    etc = binary.absolute().parent.parent / "etc"
    if not (etc / "init.d-posix" / "rcS").is_file():
        raise InputError(f"{str(binary)!r}: no PX4 ROMFS next to it ({etc}/init.d-posix/rcS is missing): give the px4 "
                         "binary of a SITL build, build/px4_sitl_default/bin/px4, whose etc/ folder lies beside bin/")
    return etc


def _lock_free(instance: int) -> bool:
    """True when no PX4 holds /tmp/px4_lock-N (PX4 keeps a write lock on it while it runs)."""
    path = Path(f"/tmp/px4_lock-{instance}")
    if not path.exists():
        return True
    try:
        with open(path, "rb+") as f:
            fcntl.lockf(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
            fcntl.lockf(f, fcntl.LOCK_UN)
    except OSError:
        return False
    return True


def free_instance() -> int:
    """The lowest PX4 SITL instance whose lock file and ports no one holds."""
    for n in range(MAX_INSTANCE + 1):
        ports = (GCS_PORT + n, API_PORT + n, API_REMOTE_PORT + n, *(p + n for p in OTHER_PORTS))
        if _lock_free(n) and all(port_free(p, socket.SOCK_DGRAM) for p in ports):
            return n
    raise SitlError(f"no free PX4 SITL instance: instances 0 to {MAX_INSTANCE} are all in use (their /tmp/px4_lock-N "
                    f"or udp ports {GCS_PORT}+N, {API_PORT}+N, {API_REMOTE_PORT}+N are held)")


def flight_params(cruise_ms: float, speed_ms: float) -> list[tuple[str, float]]:
    """PX4's parameters for a survey: the file's, then the plan's cruise speed as MPC_XY_CRUISE
    (PX4 flies its RTL at it, the plan's estimate its way home), and MPC_XY_VEL_MAX raised when a
    speed of the plan is above PX4's default limit."""
    out = [*survey_params("copter", False, PARAMS_FILE), ("MPC_XY_CRUISE", cruise_ms)]
    if max(cruise_ms, speed_ms) > PX4_XY_VEL_MAX:
        out.append(("MPC_XY_VEL_MAX", max(cruise_ms, speed_ms)))
    return out


class Px4Vehicle(SitlVehicle):
    """One PX4 SITL (SIH quadrotor) process and a control connection to it on its ground station link."""

    def __init__(self, binary: Path, home: tuple[float, float, float], speedup: float, params: list[tuple[str, float]],
                 workdir: Path, boot_timeout: float = 60.0):
        super().__init__(binary, "copter", home, speedup, [], workdir, boot_timeout)
        self.params = params
        self.instance = -1

    @property
    def upload_url(self) -> str:
        """The API link, where PX4 sends: the upload's checks and MAVSDK open it one after the other."""
        return f"udpin:127.0.0.1:{API_REMOTE_PORT + self.instance}"

    def start(self) -> None:
        self.instance = free_instance()
        # PX4 links its working folder's etc/ to the ROMFS unless etc/ is a folder: here it is one, with
        # the ROMFS's entries linked into it and logging/logger_topics.txt of our own
        etc = self.workdir / "etc"
        (etc / "logging").mkdir(parents=True, exist_ok=True)
        for entry in romfs(self.binary).iterdir():
            if entry.name != "logging":
                (etc / entry.name).symlink_to(entry)
        shutil.copyfile(LOGGER_TOPICS_FILE, etc / "logging" / "logger_topics.txt")
        lat, lon, alt = self.home
        env = {k: v for k, v in os.environ.items() if not k.startswith("PX4_")}
        env |= SIH_QUAD | {"PX4_HOME_LAT": f"{lat:.8f}", "PX4_HOME_LON": f"{lon:.8f}", "PX4_HOME_ALT": f"{alt:.2f}",
                           "PX4_SIM_SPEED_FACTOR": f"{self.speedup:g}"}
        env |= {f"PX4_PARAM_{name}": f"{value:g}" for name, value in self.params}
        self.launch([str(self.binary), "-d", "-i", str(self.instance), "-w", str(self.workdir),
                     str(romfs(self.binary))], env)
        url = f"udpout:127.0.0.1:{GCS_PORT + self.instance}"
        # one socket for the whole flight: PX4's ground station link answers the first one it hears for good
        link = connect(url, self.boot_timeout)
        self.conn = link.conn
        deadline = time.monotonic() + self.boot_timeout
        while True:
            self.check_running("at start")
            try:
                link.wait_heartbeat(min(1.0, max(0.1, deadline - time.monotonic())))
                break
            except LinkError:
                if time.monotonic() >= deadline:
                    raise self.error(f"no heartbeat from PX4 SITL instance {self.instance} on {url} within "
                                     f"{self.boot_timeout:g} s") from None
        self._check_params(link)

    def _check_params(self, link: MavLink) -> None:
        """Every parameter holds what was asked (PX4's start script may set a default over a value
        given as PX4_PARAM_ that equals the compiled-in default)."""
        names = tuple(name for name, _ in self.params)
        got = link.read_params(names, self.boot_timeout, settle=self.boot_timeout)  # every one of them, asked again
        for name, value in self.params:
            if name not in got:
                raise self.error(f"PX4 SITL has no parameter {name} (or did not answer for it)")
            if abs(got[name] - value) > 1e-4 * max(1.0, abs(value)):
                raise self.error(f"PX4 SITL did not take parameter {name} = {value:g}: it holds {got[name]:g}")

    def set_param(self, name: str, value: float, timeout: float = 10.0) -> None:
        """PARAM_SET as PX4 takes it, on the ground station link: in the type PX4 answers the parameter with,
        an integer's bytes in the float (PX4 copies the float's bytes whatever the type sent); done when PX4
        answers with the value."""
        ts, tc = self.conn.target_system, self.conn.target_component
        deadline = time.monotonic() + timeout
        now = self._answer(name, lambda: self.conn.mav.param_request_read_send(ts, tc, name.encode(), -1), deadline)
        if now is None:
            raise self.error(f"PX4 SITL has no parameter {name} (or did not answer for it)")
        kind = int(now.param_type)
        wire = param_wire_value(value, kind, AUTOPILOT_PX4)

        def held(m: Any) -> bool:
            return abs(param_value(float(m.param_value), kind, AUTOPILOT_PX4) - value) <= 1e-4 * max(1.0, abs(value))

        if self._answer(name, lambda: self.conn.mav.param_set_send(ts, tc, name.encode(), wire, kind), deadline,
                        held) is None:
            raise self.error(f"PX4 SITL did not take parameter {name} = {value:g}")

    def _answer(self, name: str, ask: Callable[[], None], deadline: float,
                wanted: Callable[[Any], bool] = lambda m: True) -> Any:
        """The first PARAM_VALUE for `name` that is `wanted`, asked for by `ask` every second; None at `deadline`."""
        while time.monotonic() < deadline:
            ask()
            until = min(deadline, time.monotonic() + 1.0)
            while (left := until - time.monotonic()) > 0:
                m = self.conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=left)
                if m is not None and m.param_id == name and wanted(m):
                    return m
        return None

    def request_messages(self) -> None:
        """The track, mission progress and battery as for ArduPilot, and the 50 Hz streams PX4
        SITL adds to its ground station link (px4-rc.mavlink) stopped: the harness reads none of
        them, and at a speed-up they are thousands of messages a second."""
        from pymavlink import mavutil

        super().request_messages()
        # ATTITUDE, ATTITUDE_QUATERNION, LOCAL_POSITION_NED, SERVO_OUTPUT_RAW, RC_CHANNELS, ATTITUDE_TARGET,
        # POSITION_TARGET_LOCAL_NED, OPTICAL_FLOW_RAD
        for msg_id in (30, 31, 32, 36, 65, 83, 85, 106):
            self.command(mavutil.mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, -1)

    def start_mission(self, params: Sequence[tuple[str, float]] = ()) -> None:
        """`params` set, AUTO.MISSION, then arm: PX4 takes off and flies the mission from its first item."""
        from pymavlink import mavutil

        for name, value in params:
            self.set_param(name, value)
        self.command(mavutil.mavlink.MAV_CMD_DO_SET_MODE, mavutil.mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, *AUTO_MISSION)
        self.arm(timeout=120.0)

    def ulog(self) -> Path | None:
        """The newest ULog PX4 wrote in its working folder (log/DATE/TIME.ulg), if any."""
        logs = sorted((self.workdir / "log").glob("*/*.ulg"), key=lambda p: (p.parent.name, p.name))
        return logs[-1] if logs else None
