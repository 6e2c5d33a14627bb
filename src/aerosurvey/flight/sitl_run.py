"""Fly a plan folder's sorties in ArduPilot or PX4 SITL: the work of `aerosurvey sitl fly`.

The plan is read through the manifest reader; each sortie's stations and photo runs come
from it, each sortie's mission from its `.plan` file. The SITL processes themselves are
run by aerosurvey.link.sitl and aerosurvey.link.px4_sitl (a binary the user has).
"""

from __future__ import annotations

import json
import shutil
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aerosurvey import resumefile
from aerosurvey.errors import InputError
from aerosurvey.fileio import atomic_write_text
from aerosurvey.link import sitl as harness
from aerosurvey.manifest import WHOLE_MISSION_FILE, Manifest
from aerosurvey.mission import mavlink_ids as mav
from aerosurvey.mission.items import Mission


@dataclass(frozen=True)
class SortieRoute:
    """One sortie as SITL flies it: its mission file, planned stations and photo runs."""

    name: str  # sortie id (S01 …), or "mission" for an unsplit plan
    mission_file: Path
    stations: tuple[tuple[float, float], ...]  # (lat, lon) in flight order
    runs: tuple[tuple[int, int], ...]  # (first, last) index within `stations`, per photo run
    estimated_s: float
    pitches: tuple[float, ...] = ()  # each station's planned camera pitch (-90 = nadir), in flight order


#: the mission commands that point a camera: a flight with one of them flies with the harness's mount
GIMBAL_COMMANDS = frozenset({mav.DO_MOUNT_CONTROL, mav.DO_GIMBAL_MANAGER_PITCHYAW, mav.DO_SET_ROI_LOCATION})


def _runs(run_of: tuple[str, ...]) -> tuple[tuple[int, int], ...]:
    out: list[tuple[int, int]] = []
    for k, run in enumerate(run_of):
        if out and run_of[out[-1][0]] == run:
            out[-1] = (out[-1][0], k)
        else:
            out.append((k, k))
    return tuple(out)


def sortie_routes(doc: Manifest, plan_dir: Path, resume_dir: Path | None = None) -> list[SortieRoute]:
    """Every sortie of the plan (the whole mission when it is not split), or with `resume_dir`
    every sortie `aerosurvey resume` wrote there, with the plan's stations each flies."""
    out = []
    parts = [(s.id, s.files[0], doc.sortie_stations(s.id), s.time_s) for s in doc.sorties]
    if not parts:
        parts = [("mission", WHOLE_MISSION_FILE, doc.stations, doc.estimates.get("total_time_s"))]
    folder = plan_dir
    if resume_dir is not None:
        resumed = resumefile.read(resume_dir)
        if resumed.mission != doc.mission.name:
            raise InputError(f"--resume {str(resume_dir)!r} resumes mission {resumed.mission!r}, not {doc.mission.name!r}")
        folder = resume_dir
        st = doc.stations
        parts = [(Path(s.files[0]).stem, s.files[0], st.select(st.index(s.first_station), st.index(s.last_station)), s.time_s)
                 for s in resumed.sorties]
    for name, file, st, est in parts:
        path = folder / file
        if not path.is_file():
            raise InputError(f"{str(plan_dir)!r}: {file} is missing (the manifest lists it); plan again with `aerosurvey plan`")
        if est is None:
            raise InputError(f"{doc.where}: sortie {name} has no time estimate; plan again with `aerosurvey plan`")
        out.append(SortieRoute(name, path, tuple(zip(st.lat.tolist(), st.lon.tolist())), _runs(st.run), float(est),
                               tuple(st.pitch_deg.tolist())))
    return out


@dataclass(frozen=True)
class SitlSettings:
    vehicle: str
    binary: Path
    defaults: tuple[Path, ...]
    speedup: float
    timeout_factor: float
    boot_timeout: float = 60.0  # seconds for SITL to listen and send its first heartbeat
    rtl_after_photos: int | None = None  # a flight cut short: the first sortie switched to RTL after this photo
    firmware: str = "ardupilot"  # "ardupilot" or "px4": which SITL `binary` is
    wind: tuple[float, float] | None = None  # the plan's wind (speed m/s, from degrees true), simulated steady


def fly_sorties(doc: Manifest, plan_dir: Path, settings: SitlSettings, report_dir: Path,
                on_sortie: Callable[[dict[str, Any]], None] = lambda row: None,
                resume_dir: Path | None = None, only: tuple[str, ...] | None = None) -> list[dict[str, Any]]:
    """Upload, verify and fly every sortie in SITL (those of `resume_dir` when given; those named
    in `only`, when given, in the plan's order); copy each
    flight log (ArduPilot's DataFlash, PX4's ULog) into `report_dir` and write sitl_report.json /
    .txt there. Returns one comparison row per sortie. With `settings.rtl_after_photos`, only the
    first sortie flies, switched to RTL after that photo (a flight cut short, for `aerosurvey
    resume`; ArduPilot only); its row says so."""
    from aerosurvey.mission.formats.qgc_plan import loads_plan

    results = []
    routes = sortie_routes(doc, plan_dir, resume_dir)
    if only is not None:
        unknown = sorted(set(only) - {r.name for r in routes})
        if unknown:
            raise InputError(f"sorties {', '.join(unknown)}: not sorties of {str(plan_dir)!r} "
                             f"(it has {', '.join(r.name for r in routes)})")
        routes = [r for r in routes if r.name in only]
    for route in routes[:1] if settings.rtl_after_photos is not None else routes:
        mission = loads_plan(route.mission_file.read_text(encoding="utf-8"), str(route.mission_file))
        # SITL's working folder (its logs, eeprom, output): removed however the sortie ends
        with tempfile.TemporaryDirectory(prefix="aerosurvey-sitl-") as tmp:
            fly = _fly_px4 if settings.firmware == "px4" else _fly_ardupilot
            flight, mount = fly(route, mission, settings, Path(tmp), report_dir)
        row = harness.compare(flight, list(route.stations), list(route.runs), route.estimated_s)
        if settings.rtl_after_photos is not None:
            row["rtl_after_photos"] = settings.rtl_after_photos if flight.cut_ms is not None else None
        if doc.camera.trigger == "camera":
            # the camera's own intervalometer is not simulated: no picture, so neither the photos nor their aim are judged
            row["triggers_match"] = None
        elif mount:
            # the camera's pitch flown at each picture against its station's: the flight fails beyond the tolerance
            row["mount_pitch_deg"] = mount_pitch_at_photos(report_dir / flight.log) if flight.log else []
            row["max_aim_error_deg"] = aim_error_deg(row["mount_pitch_deg"], route.pitches)
            row["aim_ok"] = row["max_aim_error_deg"] is not None and row["max_aim_error_deg"] <= AIM_TOLERANCE_DEG
        results.append(row)
        on_sortie(row)
    report_dir.mkdir(parents=True, exist_ok=True)
    atomic_write_text(report_dir / "sitl_report.json", json.dumps({
        "firmware": settings.firmware, "vehicle": settings.vehicle, "binary": str(settings.binary),
        "speedup": settings.speedup, "sorties": results}, indent=1) + "\n")
    text = "\n".join(f"{r['sortie']}: " + ", ".join(f"{k}={v}" for k, v in r.items() if k != "sortie") for r in results)
    atomic_write_text(report_dir / "sitl_report.txt", text + "\n")
    return results


def _fly_ardupilot(route: SortieRoute, mission: Mission, settings: SitlSettings, work: Path,
                   report_dir: Path) -> tuple[harness.Flight, bool]:
    """One sortie in ArduPilot SITL in the folder `work`, its DataFlash log copied into
    `report_dir`; (what it did, whether it flew with a mount)."""
    from aerosurvey.link.connection import open_link
    from aerosurvey.link.mission_protocol import Policy
    from aerosurvey.link.upload import upload_mission

    # a mission that points the camera (every flight's first run sets it, straight down too) flies with a servo mount,
    # whose servo outputs the log then records and the flight's aim is judged by (`mount_pitch_at_photos`); the
    # harness's mount tilts past straight down, so a nadir camera is held there while the vehicle leans nose up
    mount = any(item.command in GIMBAL_COMMANDS for item in mission.items)
    sv = harness.SitlVehicle(settings.binary, settings.vehicle, mission.home, settings.speedup,
                             list(settings.defaults), work, settings.boot_timeout,
                             heading_deg=harness.launch_heading_deg(mission) if settings.vehicle == "plane" else 0.0)
    try:
        sv.start()
        harness.prepare(sv, mount, settings.wind)

        def upload(m: Mission) -> str:
            with open_link(sv.upload_url, 30.0) as link:
                rep = upload_mission(link, m, Policy())
            return f"{rep.mission.items} items uploaded and verified"

        flight = harness.fly(sv, mission, route.name, route.estimated_s, len(mission.items),
                             settings.timeout_factor, upload, rtl_after_photos=settings.rtl_after_photos,
                             wind=settings.wind)
    finally:
        sv.stop()
    logs = sorted((work / "logs").glob("*.BIN")) if (work / "logs").exists() else []
    if logs:
        report_dir.mkdir(parents=True, exist_ok=True)
        dest = report_dir / f"{route.name}.BIN"
        shutil.copyfile(logs[-1], dest)
        flight.log = dest.name
    return flight, mount


def _fly_px4(route: SortieRoute, mission: Mission, settings: SitlSettings, work: Path,
             report_dir: Path) -> tuple[harness.Flight, bool]:
    """One sortie in PX4 SITL (SIH) in the folder `work`, uploaded through aerosurvey's PX4 upload
    (its checks, MAVSDK, the read-back), its ULog copied into `report_dir`; the photos are the
    ULog's camera_capture (PX4's CAMERA_TRIGGER messages over MAVLink are not all delivered at a
    SITL speed-up), each placed in the track by its time. (what it did, False: no mount flown)."""
    import bisect

    from aerosurvey.flight.events import from_ulog
    from aerosurvey.link import px4_sitl
    from aerosurvey.link.connection import open_link
    from aerosurvey.link.mission_protocol import Policy
    from aerosurvey.link.px4 import MavsdkTransfers, px4_checks
    from aerosurvey.link.upload import upload_plan

    policy = Policy()
    sv = px4_sitl.Px4Vehicle(settings.binary, mission.home, settings.speedup,
                             px4_sitl.flight_params(mission.cruise_speed, _speed(mission)), work, settings.boot_timeout)
    try:
        sv.start()
        sv.request_messages()

        def upload(m: Mission) -> str:
            with open_link(sv.upload_url, policy.silence) as link:
                legs = px4_checks(link, m, route.mission_file.name, False, policy.silence)
            assert link.vehicle is not None
            with MavsdkTransfers(sv.upload_url, link.vehicle, policy.timeout, policy.silence) as transfers:
                rep = upload_plan(transfers, m)
            return f"{rep.mission.items} items uploaded through MAVSDK and verified; {legs}"

        # PX4 numbers the items from 0 (no home): the last is len - 1
        flight = harness.fly(sv, mission, route.name, route.estimated_s, len(mission.items) - 1,
                             settings.timeout_factor, upload)
    finally:
        sv.stop()
    ulog = sv.ulog()
    if ulog is None:
        flight.messages.append("PX4 wrote no ULog")
        return flight, False
    report_dir.mkdir(parents=True, exist_ok=True)
    dest = report_dir / f"{route.name}.ulg"
    shutil.copyfile(ulog, dest)
    flight.log = dest.name
    try:
        ev, _ = from_ulog(dest)
    except InputError as exc:  # no camera_capture topic: PX4 took no photo
        flight.messages.append(str(exc))
        return flight, False
    times = [t for t, *_ in flight.track]
    flight.triggers = [(float(a), float(b), float(h) - mission.home[2]) for a, b, h in zip(ev.lat, ev.lon, ev.alt_m)]
    flight.trigger_track_index = [bisect.bisect_left(times, t * 1000.0) for t in ev.time_s]
    return flight, False


def _speed(mission: Mission) -> float:
    """The survey speed the mission commands (its DO_CHANGE_SPEED's), 0 without one."""
    return max((it.param2 for it in mission.items if it.command == mav.DO_CHANGE_SPEED), default=0.0)


#: a servo mount's three servos: ArduPilot's servo function (SERVOn_FUNCTION: SRV_Channel::k_mount_pan, _tilt,
#: _roll) and the MNT1_ limits (degrees) its travel spans
MOUNT_SERVOS = {"pan": (6, "MNT1_YAW"), "tilt": (7, "MNT1_PITCH"), "roll": (8, "MNT1_ROLL")}  # in this order
#: RCOU logs the first 14 outputs (C1 … C14)
LOGGED_OUTPUTS = 14
#: ArduPilot's servo outputs (SERVO1 … SERVO32): a mount servo on one RCOU does not log leaves the aim unknown
SERVO_OUTPUTS = 32

#: the camera's line of sight turned by more than this (degrees) between two outputs logged 100 ms apart: a new
#: aim commanded (a servo mount's stabilisation holds it through the vehicle's rotation, within 0.3° in SITL)
MOUNT_STEP_DEG = 10.0


def mount_pitch_at_photos(log_path: Path) -> list[float | None]:
    """The camera's pitch against the horizon (degrees, -90 = nadir) at each picture of a SITL
    DataFlash log with the harness's servo mount, None before the mount's first message (MNT) or
    when the log does not say where its servos were.

    A servo mount has no attitude feedback: it drives three servos, relative to the vehicle's
    body, chained pan, then roll, then tilt (yaw-roll-pitch): AP_Mount_Servo::update_angle_outputs
    gives the pan the yaw relative to the body and takes the vehicle's lean, turned into the
    panned frame, off the roll and tilt. Each servo's angle is read from its own output (RCOU:
    the PWM of the channel whose SERVOn_FUNCTION is the mount's pan, tilt or roll, mapped back
    through SERVOn_MIN/MAX/REVERSED onto the MNT1_ limits, as SRV_Channels::move_servo maps the
    angle; the values from the log's PARM), and the camera's attitude at that output is the vehicle's
    logged in the same loop (the ATT message with the RCOU's TimeUS: yaw-pitch-roll) turned by them.
    The camera's line of sight at a picture is interpolated between the outputs either side (a picture
    before the first output or after the last takes that output's: RCOU is logged from the start of the
    log to its end, and a log cut short loses pictures too), or is the
    one before it where the camera turned to a new aim in between (`MOUNT_STEP_DEG`: a
    hover-and-capture's next aim, commanded as the photo is taken, would else leak into it). Not the
    servos' angles interpolated under the picture's own attitude (CAM): ArduPilot SITL at speedup 20
    drops log messages when its writer falls behind (RCOU 300-400 ms apart in a quiet run), and the
    vehicle pitching 14°/s as it brakes at a line end does not turn at a constant rate across such a gap
    (the servos interpolated over 0.8 s read a nadir camera 1.9° off, 6.9° with the step taken on a
    servo's move; the pitch at the outputs 0.3°, over 2 s too). Not from MNT's Roll/Pitch/YawB either:
    ArduPilot logs the servo angles as yaw-pitch-roll Euler angles of a quaternion made from them, which
    at a tilt of -90° loses the roll (a nadir hover read +89.8°: Roll and YawB 180) and past it (a tilt
    beyond -90 that holds the camera straight down while the vehicle leans nose up) comes back as the
    other solution.
    """
    import numpy as np

    from aerosurvey.flight.dataflash import DataFlashLog

    with DataFlashLog(log_path) as log:
        cam, mnt, out, att, parm = (log.messages(name) for name in ("CAM", "MNT", "RCOU", "ATT", "PARM"))
    if not cam:
        return []
    n = len(cam["TimeUS"])
    # the last value of each parameter the log records
    params = dict(zip((bytes(name).decode("ascii", "replace") for name in parm.get("Name", ())),
                      np.asarray(parm.get("Value", ()), np.float64).tolist()))
    # the outputs whose loop logged the vehicle's attitude too, each with it
    out_us, att_us = np.asarray(out.get("TimeUS", ()), np.float64), np.asarray(att.get("TimeUS", ()), np.float64)
    both = np.isin(out_us, att_us)
    if not mnt or not both.any():
        return [None] * n
    out = {k: np.asarray(v)[both] for k, v in out.items()}
    row = np.searchsorted(att_us, out_us[both])
    pan, tilt, roll = (_servo_angle(params, out, function, limits, axis != "tilt")
                       for axis, (function, limits) in MOUNT_SERVOS.items())
    if pan is None or tilt is None or roll is None:
        return [None] * n
    body = _turn("z", att["Yaw"][row]) @ _turn("y", att["Pitch"][row]) @ _turn("x", att["Roll"][row])
    camera = body @ _turn("z", pan) @ _turn("x", roll) @ _turn("y", tilt)
    sight = camera[:, :, 0]  # the camera's x axis, its line of sight (gimbal convention: pitch about y)
    times, at = out_us[both], np.asarray(cam["TimeUS"], np.float64)
    before = np.clip(np.searchsorted(times, at, side="right") - 1, 0, len(times) - 1)
    after = np.minimum(before + 1, len(times) - 1)
    turned = np.degrees(np.arccos(np.clip(np.sum(sight[before] * sight[after], axis=1), -1.0, 1.0)))
    span = np.maximum(times[after] - times[before], 1.0)
    share = np.where(turned > MOUNT_STEP_DEG, 0.0, np.clip((at - times[before]) / span, 0.0, 1.0))[:, None]
    look = sight[before] + share * (sight[after] - sight[before])
    pitch = np.degrees(np.arcsin(np.clip(-look[:, 2] / np.linalg.norm(look, axis=1), -1.0, 1.0)))  # its elevation
    known = at >= mnt["TimeUS"][0]
    return [round(float(p), 2) if k else None for p, k in zip(pitch, known)]


def _servo_angle(params: dict[str, float], out: dict[str, Any], function: int, limits: str, optional: bool) -> Any:
    """The angle (degrees) of the mount servo with SERVOn_FUNCTION `function` at each of the logged
    outputs `out`; 0 when no output has that function and the servo is `optional` (a mount without it
    holds that axis at 0); None when it is not, or the log lacks the output (one past the LOGGED_OUTPUTS
    RCOU holds) or a value the mapping needs."""
    import numpy as np

    channel = next((c for c in range(1, SERVO_OUTPUTS + 1) if params.get(f"SERVO{c}_FUNCTION") == function), None)
    if channel is None:
        return np.zeros(len(out["TimeUS"])) if optional else None
    names = (f"SERVO{channel}_MIN", f"SERVO{channel}_MAX", f"{limits}_MIN", f"{limits}_MAX")
    if f"C{channel}" not in out or any(k not in params for k in names):
        return None
    low, high, least, most = (params[k] for k in names)
    if high <= low or most <= least:
        return None
    v = (np.asarray(out[f"C{channel}"], np.float64) - low) / (high - low)
    if params.get(f"SERVO{channel}_REVERSED", 0.0):
        v = 1.0 - v
    return least + np.clip(v, 0.0, 1.0) * (most - least)


#: the flown camera pitch may differ from the planned by this much (degrees) before the flight fails
AIM_TOLERANCE_DEG = 2.0


def aim_error_deg(flown: list[float | None], planned: tuple[float, ...]) -> float | None:
    """The largest difference between the camera pitch flown at each picture and its station's
    planned pitch (in order); None when a picture has no mount reading (its aim is not known) or
    there are none."""
    n = min(len(flown), len(planned))
    if n == 0 or any(p is None for p in flown[:n]):
        return None
    return round(max(abs(float(f) - p) for f, p in zip(flown[:n], planned[:n]) if f is not None), 2)


def _turn(axis: str, deg: Any) -> Any:
    """Rotation matrices (n, 3, 3) about one body axis ("x", "y" or "z") by angles in degrees."""
    import numpy as np

    a = np.radians(np.asarray(deg, dtype=np.float64))
    c, s, o, i = np.cos(a), np.sin(a), np.zeros_like(a), np.ones_like(a)
    rows = {"x": [[i, o, o], [o, c, -s], [o, s, c]],
            "y": [[c, o, s], [o, i, o], [-s, o, c]],
            "z": [[c, -s, o], [s, c, o], [o, o, i]]}[axis]
    return np.stack([np.stack(r, -1) for r in rows], -2)
