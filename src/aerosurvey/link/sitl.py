"""Fly planned sorties in ArduPilot SITL and compare what was flown with what was planned.

The harness only launches a SITL binary the user already has (`--sitl-bin`,
AEROSURVEY_SITL_BIN, or `arducopter`/`arduplane` on PATH). It starts it in an empty
working folder on loopback, sets the parameters a survey needs (a servo camera so that
pictures are logged, AUTO_OPTIONS so a copter arms in AUTO, simulation-friendly
failsafes), reboots it as ArduPilot's own autotest does for the camera backend, uploads
and verifies each sortie with aerosurvey's link layer (SERIAL1), flies it on SERIAL0,
records camera feedback and the track, waits for the landing, copies the DataFlash log, and
stops every process it started.

Instance N of ArduPilot SITL (-I N) listens on tcp 5760+10N (SERIAL0), 5762+10N (SERIAL1) and
5763+10N (SERIAL2) (ArduPilot's SITL_cmdline: base port 5760 + 10 × instance). The harness
takes the lowest N whose ports no one listens on, so several SITL flights can run side by side.
"""

from __future__ import annotations

import errno
import math
import os
import shutil
import socket
import subprocess
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from aerosurvey.errors import CheckFailed, InputError
from aerosurvey.mission import mavlink_ids as mav
from aerosurvey.mission.items import Mission

PARAMS_FILE = Path(__file__).resolve().parents[3] / "sitl" / "aerosurvey-sitl.parm"
COPTER_MODES = {"AUTO": 3, "RTL": 6, "LAND": 9}
PLANE_MODES = {"MANUAL": 0, "AUTO": 10, "RTL": 11}
#: lines of SITL's own output an error quotes
OUTPUT_LINES = 5
#: ArduPilot SITL's tcp ports for instance N are these plus 10 N: SERIAL0 (the harness flies on
#: it), SERIAL1 (uploads), SERIAL2
SERIAL0_PORT, SERIAL1_PORT, SERIAL2_PORT = 5760, 5762, 5763
#: the instances the harness tries (0 to 9: ports 5760 to 5853)
MAX_INSTANCE = 9


class SitlError(CheckFailed):
    """SITL could not be started or the flight did not complete."""


def find_binary(vehicle: str, explicit: str | None) -> Path:
    """The SITL binary: the option, then AEROSURVEY_SITL_BIN (a file or a folder), then PATH."""
    name = "arduplane" if vehicle == "plane" else "arducopter"
    for source, value in (("--sitl-bin", explicit), ("AEROSURVEY_SITL_BIN", os.environ.get("AEROSURVEY_SITL_BIN"))):
        if not value:
            continue
        p = Path(value)
        if p.is_dir():
            p = p / name
        if not (p.is_file() and os.access(p, os.X_OK)):
            raise InputError(f"{source} = {value!r}: no executable {name} there")
        return p
    found = shutil.which(name)
    if found is None:
        raise InputError(f"no ArduPilot SITL binary: give --sitl-bin, set AEROSURVEY_SITL_BIN, or put {name} on PATH "
                         "(see sitl/README.md)")
    return Path(found)


def port_free(port: int, kind: int = socket.SOCK_STREAM) -> bool:
    """True when nothing holds `port` of the loopback: for tcp (`kind` SOCK_STREAM) nothing
    listens there (a closed connection still waiting out its TIME_WAIT does not count: SITL
    reuses the address, as this check does), for udp (SOCK_DGRAM) nothing is bound there."""
    with socket.socket(socket.AF_INET, kind) as s:
        if kind == socket.SOCK_STREAM:
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind(("127.0.0.1", port))
        except OSError as exc:
            if exc.errno == errno.EADDRINUSE:
                return False
            raise
    return True


def free_instance() -> int:
    """The lowest ArduPilot SITL instance N whose tcp ports (5760+10N, 5762+10N, 5763+10N) are free."""
    for n in range(MAX_INSTANCE + 1):
        if all(port_free(p + 10 * n) for p in (SERIAL0_PORT, SERIAL1_PORT, SERIAL2_PORT)):
            return n
    raise SitlError(f"no free ArduPilot SITL instance: instances 0 to {MAX_INSTANCE} are all in use (tcp ports "
                    f"{SERIAL0_PORT}+10N, {SERIAL1_PORT}+10N or {SERIAL2_PORT}+10N are held)")


def default_params(vehicle: str) -> tuple[Path, ...]:
    """copter.parm or plane.parm from the folder AEROSURVEY_SITL_DEFAULTS, when it is set."""
    folder = os.environ.get("AEROSURVEY_SITL_DEFAULTS")
    if not folder:
        return ()
    p = Path(folder) / ("plane.parm" if vehicle == "plane" else "copter.parm")
    if not p.is_file():
        raise InputError(f"AEROSURVEY_SITL_DEFAULTS = {folder!r}: no {p.name} there")
    return (p,)


@dataclass
class Flight:
    """What one sortie did in SITL."""

    name: str
    triggers: list[tuple[float, float, float]] = field(default_factory=list)  # lat, lon, alt rel
    trigger_track_index: list[int] = field(default_factory=list)  # len(track) when each trigger arrived
    track: list[tuple[int, float, float, float]] = field(default_factory=list)  # time_boot_ms, lat, lon, alt rel
    armed_ms: int | None = None
    disarmed_ms: int | None = None
    completed: bool = False
    cut_ms: int | None = None  # when the flight was switched to RTL on purpose (`fly`'s rtl_after_photos)
    battery_mah: float | None = None
    log: str | None = None
    upload_note: str = ""
    messages: list[str] = field(default_factory=list)


class SitlVehicle:
    """One SITL process and a control connection to it."""

    def __init__(self, binary: Path, vehicle: str, home: tuple[float, float, float], speedup: float,
                 defaults: list[Path], workdir: Path, boot_timeout: float = 60.0, heading_deg: float = 0.0):
        # SITL runs in `workdir`: paths the caller gave relative to its own folder are made absolute first
        self.binary, self.vehicle, self.home, self.speedup = binary.absolute(), vehicle, home, speedup
        self.heading_deg = heading_deg  # where the vehicle faces at home (a plane takes off that way)
        self.defaults = [p.absolute() for p in defaults]
        self.workdir = workdir
        self.boot_timeout = boot_timeout
        self.proc: subprocess.Popen[bytes] | None = None
        self.conn: Any = None
        self.log: IO[bytes] | None = None
        self.instance = -1  # the SITL instance (-I N), chosen at start

    def error(self, message: str) -> SitlError:
        """A SitlError that quotes the last lines SITL printed (where it says why it failed)."""
        try:
            lines = [ln.strip() for ln in (self.workdir / "sitl.out").read_text(errors="replace").splitlines() if ln.strip()]
        except OSError:
            lines = []
        said = " | ".join(lines[-OUTPUT_LINES:]) if lines else "nothing"
        return SitlError(f"{message}; SITL's last output: {said}")

    @property
    def upload_url(self) -> str:
        """SERIAL1 of this instance, where the harness uploads."""
        return f"tcp:127.0.0.1:{SERIAL1_PORT + 10 * self.instance}"

    def start(self) -> None:
        from pymavlink import mavutil

        lat, lon, alt = self.home
        model = "plane" if self.vehicle == "plane" else "quad"
        self.instance = free_instance()
        url = f"tcp:127.0.0.1:{SERIAL0_PORT + 10 * self.instance}"
        cmd = [str(self.binary), "--model", model, "--speedup", f"{self.speedup:g}", f"-I{self.instance}",
               "--home", f"{lat:.8f},{lon:.8f},{alt:.2f},{self.heading_deg:.1f}"]
        if self.defaults:
            cmd += ["--defaults", ",".join(str(p) for p in self.defaults)]
        self.launch(cmd)
        deadline = time.monotonic() + self.boot_timeout
        last_exc: Exception | None = None
        while time.monotonic() < deadline:
            self.check_running("at start")
            try:
                self.conn = mavutil.mavlink_connection(url, source_system=255, retries=0, autoreconnect=True)
                break
            except OSError as exc:
                last_exc = exc
                time.sleep(0.5)
        else:
            raise self.error(f"SITL ({self.binary.name}) did not listen on {url} within "
                             f"{self.boot_timeout:g} s ({last_exc})")
        if self.conn.wait_heartbeat(timeout=max(0.1, deadline - time.monotonic())) is None:
            self.check_running("at start")
            raise self.error(f"no heartbeat from SITL ({self.binary.name}) within {self.boot_timeout:g} s")

    def launch(self, cmd: list[str], env: dict[str, str] | None = None) -> None:
        """Start the SITL process in the working folder, its output into sitl.out there."""
        self.log = open(self.workdir / "sitl.out", "wb")
        self.proc = subprocess.Popen(cmd, cwd=self.workdir, stdout=self.log, stderr=subprocess.STDOUT, env=env)

    def check_running(self, when: str) -> None:
        """A SitlError quoting its output if the SITL process has ended."""
        if self.proc is not None and self.proc.poll() is not None:
            raise self.error(f"SITL ({self.binary.name}) exited with code {self.proc.returncode} {when}")

    def stop(self) -> None:
        if self.conn is not None:
            try:
                self.conn.close()
            except OSError:
                pass
            self.conn = None
        if self.proc is not None and self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(timeout=10)
        self.proc = None
        if self.log is not None:
            self.log.close()
            self.log = None

    # --- parameters and commands -------------------------------------------------------
    def set_param(self, name: str, value: float, timeout: float = 10.0) -> None:
        from pymavlink import mavutil

        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            self.conn.mav.param_set_send(self.conn.target_system, self.conn.target_component, name.encode(),
                                         float(value), mavutil.mavlink.MAV_PARAM_TYPE_REAL32)
            m = self.conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=1.0)
            while m is not None:
                if m.param_id == name and abs(m.param_value - value) < 1e-4:
                    return
                m = self.conn.recv_match(type="PARAM_VALUE", blocking=False)
        raise self.error(f"SITL did not accept parameter {name} = {value}")

    def command(self, cmd: int, *params: float, timeout: float = 5.0) -> int:
        p = list(params) + [0.0] * (7 - len(params))
        self.conn.mav.command_long_send(self.conn.target_system, self.conn.target_component, cmd, 0, *p)
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            m = self.conn.recv_match(type="COMMAND_ACK", blocking=True, timeout=0.5)
            if m is not None and m.command == cmd:
                return int(m.result)
        return -1

    def reboot(self) -> None:
        from pymavlink import mavutil

        self.command(mavutil.mavlink.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1)
        time.sleep(2.0)
        if self.conn.wait_heartbeat(timeout=self.boot_timeout) is None:
            raise self.error("no heartbeat from SITL after the reboot")

    def request_messages(self) -> None:
        """Ask for the track, mission progress and camera feedback at fixed rates (stream
        parameters are named differently across ArduPilot versions; this command is not)."""
        from pymavlink import mavutil

        for msg_id, hz in ((33, 5.0), (42, 2.0), (147, 1.0)):  # GLOBAL_POSITION_INT, MISSION_CURRENT, BATTERY_STATUS
            self.command(mavutil.mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 1e6 / hz)

    def set_mode(self, mode: int) -> None:
        from pymavlink import mavutil

        self.command(mavutil.mavlink.MAV_CMD_DO_SET_MODE, mavutil.mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, mode)

    def start_mission(self, params: Sequence[tuple[str, float]] = ()) -> None:
        """Arm and start the uploaded mission, `params` set just before it starts (a plane's once armed)."""
        from pymavlink import mavutil

        if self.vehicle == "plane":
            # ArduPlane does not arm in AUTO: arm in MANUAL (throttle low), then hand over to the mission
            self.set_mode(PLANE_MODES["MANUAL"])
            self.arm(timeout=120.0)
            for name, value in params:
                self.set_param(name, value)
            self.set_mode(PLANE_MODES["AUTO"])
        else:
            for name, value in params:
                self.set_param(name, value)
            self.set_mode(COPTER_MODES["AUTO"])  # AUTO_OPTIONS = 3: arms in AUTO and takes off without throttle
            self.arm(timeout=120.0)
        self.command(mavutil.mavlink.MAV_CMD_MISSION_START, 0, 0)

    def arm(self, timeout: float) -> None:
        """Arm as soon as the pre-arm checks pass (EKF and GPS ready)."""
        from pymavlink import mavutil

        deadline = time.monotonic() + timeout
        said: list[str] = []
        while time.monotonic() < deadline:
            if self.command(mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) == 0:
                return
            end = time.monotonic() + 1.0
            while time.monotonic() < end:
                m = self.conn.recv_match(type="STATUSTEXT", blocking=True, timeout=0.2)
                if m is not None and m.text not in said:
                    said.append(m.text)
        raise self.error(f"SITL did not arm within {timeout:g} s; it said: {' | '.join(said[-4:]) or 'nothing'}")


def survey_params(vehicle: str, mount: bool, path: Path = PARAMS_FILE) -> list[tuple[str, float]]:
    """The parameters of the file `path` (PARAMS_FILE: ArduPilot's) for `vehicle`, with its
    MOUNT: lines when `mount` (a mission that points a gimbal), in the file's order."""
    out = []
    for line in path.read_text().splitlines():
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        name, value = line.split()[:2]
        kind, _, bare = name.rpartition(":")
        if kind == "MOUNT" and not mount or kind in ("COPTER", "PLANE") and (kind == "PLANE") != (vehicle == "plane"):
            continue
        out.append((bare, float(value)))
    return out


def wind_params(speed_ms: float, from_deg: float) -> list[tuple[str, float]]:
    """SITL's wind: a steady `speed_ms` from the true bearing `from_deg` at every height (SIM_WIND_T 1: no
    weaker wind near the ground), without turbulence: the wind the plan was made for."""
    return [("SIM_WIND_SPD", speed_ms), ("SIM_WIND_DIR", from_deg), ("SIM_WIND_TURB", 0.0), ("SIM_WIND_T", 1.0)]


def prepare(sv: SitlVehicle, mount: bool = False, wind: tuple[float, float] | None = None) -> None:
    """Parameters for a survey in simulation (a servo mount too when `mount`; still air when a wind is to be
    flown: `fly` sets it as the mission starts), then a reboot so the camera and mount backends exist."""
    for name, value in survey_params(sv.vehicle, mount) + (wind_params(0.0, wind[1]) if wind is not None else []):
        sv.set_param(name, value)
    sv.reboot()
    sv.request_messages()


#: a landing plane has touched down below this height above home (m)
TOUCHDOWN_M = 1.0


def fly(sv: SitlVehicle, mission: Mission, name: str, est_time_s: float, last_item: int, timeout_factor: float,
        upload: Callable[[Mission], str], rtl_after_photos: int | None = None,
        wind: tuple[float, float] | None = None) -> Flight:
    """Upload (with verification), arm, fly AUTO to the end, and record what happened.

    The `wind` (speed m/s, from degrees true) is set as the mission starts, a plane's once it is armed: SITL's
    plane on the ground slides with the wind until it is launched (in 5 m/s of wind, up to 323 m from home by the
    time it was armed, the take-off then started there; with the wind set before the arming, 115 m in 8 m/s while
    ArduPlane's pre-arm checks took 20 s), so from the reboot to the start the air is still; and it is stilled
    again once a copter is below TOUCHDOWN_M after its last item (in 8 m/s a landed quad was never disarmed).

    With `rtl_after_photos`, a flight cut short: switched to RTL as the camera feedback of that
    photo arrives (ArduPilot keeps triggering by distance in RTL, CAM_AUTO_ONLY = 0), and over
    once it is back (a copter landed and disarmed, a plane over home). A plane whose mission lands is
    over at its touchdown (below TOUCHDOWN_M), where the estimate ends: over home it still had its
    approach's last 150 m and its descent to fly (20 to 30 s in ArduPlane SITL, 5 m/s of wind)."""
    from pymavlink import mavutil

    flight = Flight(name)
    flight.upload_note = upload(mission)
    lands = bool(mission.items) and mission.items[-1].command == mav.NAV_LAND
    sv.start_mission(wind_params(*wind) if wind is not None else [])
    # the limit runs on simulated time (SITL may not reach the asked speed-up); a wall-clock cap bounds a stalled SITL
    wall_limit = time.monotonic() + 600.0 + 10.0 * est_time_s / max(sv.speedup, 1.0)
    sim_start: int | None = None
    armed = True
    reached_last = False
    # a copter landed in SITL's wind is pushed on by it: the land detector (at most 1 m/s² felt) never disarms it
    windy_landing = wind is not None and wind[0] > 0.0 and sv.vehicle == "copter"
    while time.monotonic() < wall_limit:
        if flight.track and sim_start is not None and flight.track[-1][0] - sim_start > timeout_factor * est_time_s * 1000:
            break
        m = sv.conn.recv_match(blocking=True, timeout=1.0)
        if m is None:
            sv.check_running(f"while flying {name}")
            continue
        t = m.get_type()
        if t == "CAMERA_FEEDBACK":
            flight.triggers.append((m.lat * 1e-7, m.lng * 1e-7, float(m.alt_rel)))
            flight.trigger_track_index.append(len(flight.track))
            if flight.cut_ms is None and len(flight.triggers) == rtl_after_photos:
                sv.set_mode((PLANE_MODES if sv.vehicle == "plane" else COPTER_MODES)["RTL"])
                flight.cut_ms = flight.track[-1][0] if flight.track else 0
                flight.messages.append(f"switched to RTL after photo {rtl_after_photos}")
        elif t == "GLOBAL_POSITION_INT":
            if flight.armed_ms is None:
                flight.armed_ms = m.time_boot_ms
                sim_start = m.time_boot_ms
            flight.track.append((m.time_boot_ms, m.lat * 1e-7, m.lon * 1e-7, m.relative_alt / 1000.0))
            if windy_landing and reached_last and m.relative_alt / 1000.0 < TOUCHDOWN_M:
                assert wind is not None
                for param, value in wind_params(0.0, wind[1]):
                    sv.set_param(param, value)
                windy_landing = False
        elif t == "BATTERY_STATUS" and m.current_consumed >= 0:
            flight.battery_mah = float(m.current_consumed)
        elif t == "MISSION_CURRENT" and m.seq >= last_item:
            reached_last = True
        elif t == "STATUSTEXT":
            flight.messages.append(m.text)
        elif (t == "HEARTBEAT" and m.type != mavutil.mavlink.MAV_TYPE_GCS
              and m.autopilot != mavutil.mavlink.MAV_AUTOPILOT_INVALID):  # the autopilot's, not a camera's or gimbal's
            armed = bool(m.base_mode & mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
            if not armed and flight.armed_ms is not None and len(flight.track) > 10:
                flight.disarmed_ms = flight.track[-1][0]
                flight.completed = reached_last
                break
        if sv.vehicle == "plane" and (reached_last or flight.cut_ms is not None) and flight.track:
            # a plane's RTL loiters: the sortie is over when it is back over home; one that lands, at the touchdown
            _, lat, lon, rel_alt = flight.track[-1]
            if (rel_alt < TOUCHDOWN_M if lands and flight.cut_ms is None
                    else _dist(lat, lon, sv.home[0], sv.home[1]) < 150.0):
                flight.disarmed_ms = flight.track[-1][0]
                flight.completed = reached_last
                break
    if not flight.completed and flight.cut_ms is None:
        flight.messages.append(f"not completed within the time limit (armed={armed}, reached the last item={reached_last})")
    return flight


def launch_heading_deg(mission: Mission) -> float:
    """The true bearing from home to the mission's first place after its take-off, where a plane is
    launched: ArduPlane climbs out along the heading it is launched on, and the plan's climb-out heads
    for that place (`detours.climb_out_path`, which the zones are checked along and the estimate times);
    0 (north) for a mission without one."""
    lat, lon, _ = mission.home
    first = next((it for it in mission.items if it.has_position and it.command != mav.NAV_TAKEOFF), None)
    if first is None:
        return 0.0
    k = math.pi / 180.0
    return math.degrees(math.atan2((first.y - lon) * math.cos(lat * k), first.x - lat)) % 360.0


def _dist(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    k = math.pi / 180.0
    x = (lon2 - lon1) * k * math.cos((lat1 + lat2) * k / 2)
    return 6_371_000.0 * math.hypot(x, (lat2 - lat1) * k)


def compare(flight: Flight, stations: list[tuple[float, float]], runs: list[tuple[int, int]],
            est_time_s: float) -> dict[str, Any]:
    """Triggers against planned stations (in order), cross-track error on the lines, time.

    `runs` are (first, last) station indices of each photo run; the track flown between
    the triggers of a run's first and last photo is measured against that run's line.
    """
    n = min(len(flight.triggers), len(stations))
    d = [_dist(flight.triggers[i][0], flight.triggers[i][1], stations[i][0], stations[i][1]) for i in range(n)]
    xte = []
    if len(flight.triggers) == len(stations):
        for a, b in runs:
            if b <= a:
                continue
            t0, t1 = flight.trigger_track_index[a], flight.trigger_track_index[b]
            for _, lat, lon, _ in flight.track[t0:t1]:
                xte_m = _cross_track(lat, lon, stations[a], stations[b])
                if xte_m is not None:
                    xte.append(xte_m)
    flown = (flight.disarmed_ms - flight.armed_ms) / 1000.0 if flight.disarmed_ms and flight.armed_ms else None
    speeds = []
    if len(flight.triggers) == len(stations):
        for a, b in runs:
            if b > a:
                ms0 = flight.track[flight.trigger_track_index[a]][0] if flight.trigger_track_index[a] < len(flight.track) else None
                ms1 = flight.track[flight.trigger_track_index[b]][0] if flight.trigger_track_index[b] < len(flight.track) else None
                if ms0 is not None and ms1 is not None and ms1 > ms0:
                    length = sum(_dist(*stations[i], *stations[i + 1]) for i in range(a, b))
                    speeds.append(length / ((ms1 - ms0) / 1000.0))
    return {
        "sortie": flight.name, "completed": flight.completed, "photos_planned": len(stations),
        "triggers_flown": len(flight.triggers), "triggers_match": len(flight.triggers) == len(stations),
        "max_trigger_offset_m": round(max(d), 2) if d else None,
        "trigger_offsets_m": [round(x, 2) for x in d],  # each trigger's distance from its station, in order
        "max_cross_track_m": round(max(xte), 2) if xte else None,
        "flown_time_s": round(flown, 1) if flown else None, "estimated_time_s": round(est_time_s, 1),
        "time_ratio": round(flown / est_time_s, 3) if flown else None,
        "line_speed_ms": round(float(sorted(speeds)[len(speeds) // 2]), 2) if speeds else None,
        "battery_mah": flight.battery_mah, "log": flight.log, "upload": flight.upload_note,
    }


def _cross_track(lat: float, lon: float, a: tuple[float, float], b: tuple[float, float]) -> float | None:
    """Distance of a track point from the segment a–b (lat, lon), when it lies alongside it."""
    k = math.pi / 180.0
    cos0 = math.cos(a[0] * k)
    ax, ay = 0.0, 0.0
    bx, by = (b[1] - a[1]) * k * cos0 * 6_371_000.0, (b[0] - a[0]) * k * 6_371_000.0
    px, py = (lon - a[1]) * k * cos0 * 6_371_000.0, (lat - a[0]) * k * 6_371_000.0
    length2 = bx * bx + by * by
    if length2 <= 0:
        return None
    t = (px * bx + py * by) / length2
    if not 0.0 <= t <= 1.0:
        return None
    cx, cy = ax + t * bx, ay + t * by
    return math.hypot(px - cx, py - cy)

