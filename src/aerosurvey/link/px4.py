"""Uploads to PX4 through MAVSDK, the PX4 ecosystem's own SDK: its `mission_raw` plugin.

The `mavsdk` 4.x package calls MAVSDK's C++ library (libcmavsdk, shipped inside its wheel)
through ctypes: no mavsdk_server process, no gRPC. `MavsdkTransfers` is a `Transfers` backend of
`link.upload.upload_plan`, so a PX4 upload is checked, counted and compared item by item exactly
as one through aerosurvey's own protocol (against `px4_stored`, what PX4 keeps of an item).

What MAVSDK does not give, and what is done instead:
- the vehicle's raw HEARTBEAT (MAV_TYPE; MAVSDK says only "multicopter" or "fixed wing") and a
  position to compare with the launch point: the checks before an upload run on aerosurvey's own
  link (`connection.open_link`), which is closed before MAVSDK opens the same connection;
- which item the vehicle refused and the resends and restarts a transfer needed: MAVSDK reports
  one result per transfer (e.g. UNSUPPORTED), so the refusals PX4 would answer are checked before
  anything is sent (`upload.check_px4`), and the report says that MAVSDK does not count resends;
- the vehicle's STATUSTEXT during a failed transfer (PX4 explains little there anyway).
Fences and rally points it does carry (`upload_geofence`, `upload_rally_points`).
"""

from __future__ import annotations

import ctypes
import logging
import time
from collections.abc import Sequence
from typing import Any

from aerosurvey.errors import InputError
from aerosurvey.link import mission_protocol as mp
from aerosurvey.link.connection import GCS_COMPONENT, GCS_SYSTEM, LinkError, MavLink, Vehicle, serial_device
from aerosurvey.link.upload import PX4_LEG_PARAMS, DownloadFailed, UploadFailed, check_px4, check_px4_legs
from aerosurvey.mission.items import Mission

log = logging.getLogger(__name__)

#: pymavlink's connection prefixes and MAVSDK's scheme for the same link (pymavlink's "udp:" listens)
_SCHEMES = {"udpin:": "udpin://", "udp:": "udpin://", "udpout:": "udpout://", "tcp:": "tcpout://", "tcpin:": "tcpin://"}
#: pymavlink's serial speed when a device is given without one
_DEFAULT_BAUD = 115200

#: What MAVSDK's results mean in the words of the mission protocol
_RESULT_WORDS = {
    "TOO_MANY_MISSION_ITEMS": "the vehicle answered MAV_MISSION_NO_SPACE (it has no room for that many items)",
    "UNSUPPORTED": "the vehicle answered MAV_MISSION_UNSUPPORTED or MAV_MISSION_UNSUPPORTED_FRAME (a command or frame it "
                   "does not take)",
    "TIMEOUT": "the vehicle stopped answering (MAVSDK's timeout and retries ran out)",
    "DENIED": "the vehicle answered MAV_MISSION_DENIED (another transfer is under way, or it refuses changes)",
    "BUSY": "MAVSDK is busy with another transfer",
    "NO_SYSTEM": "MAVSDK lost the vehicle",
    "INVALID_SEQUENCE": "the vehicle answered MAV_MISSION_INVALID_SEQUENCE",
    "PROTOCOL_ERROR": "the vehicle answered MAV_MISSION_ERROR, or an ACK came that MAVSDK did not expect",
    "INT_MESSAGES_NOT_SUPPORTED": "the vehicle asked with the legacy MISSION_REQUEST, which MAVSDK does not serve",
    "ERROR": "the vehicle answered MAV_MISSION_ERROR",
}


def mavsdk_url(url: str) -> str:
    """MAVSDK's connection URL for a pymavlink connection string (InputError for one MAVSDK cannot open)."""
    low = url.strip().lower()
    for prefix, scheme in _SCHEMES.items():
        if low.startswith(prefix):
            return scheme + url.strip()[len(prefix):]
    device = serial_device(url)
    if device is not None:
        baud = url.rsplit(",", 1)[1].strip() if device != url else str(_DEFAULT_BAUD)
        return f"serial://{device}:{baud}"
    raise InputError(f"--connect {url!r}: a PX4 upload goes through MAVSDK, which opens udpin:, udpout:, tcp:, tcpin: "
                     "and serial devices")


def px4_checks(link: MavLink, m: Mission, file: str, rally: bool, wait: float) -> str:
    """Refuse (Refused) what this PX4 would refuse, before anything is sent: what it has no room
    for or does not take (`check_px4`), and a leg longer than its MIS_DIST_WPS, read from it
    (`check_px4_legs`; `wait`: seconds for its answers). Returns the line about the legs."""
    check_px4(m, file, rally)
    return check_px4_legs(m, file, link.read_params(PX4_LEG_PARAMS, wait))


def _quiet_mavsdk() -> None:
    """MAVSDK's own log lines go to this module's logger (debug) instead of stdout."""
    import mavsdk

    def to_logging(level: Any, message: str, file: str | None, line: int) -> bool:
        log.debug("MAVSDK %s: %s", level.name, message)
        return True

    mavsdk.log_subscribe(to_logging)


def to_mavsdk(it: mp.WireItem) -> Any:
    """A MAVSDK mission_raw MissionItem; the first item is the current one (MAVSDK refuses a list
    without exactly one: CURRENT_INVALID)."""
    from mavsdk.plugins.mission_raw import MissionItem

    return MissionItem(it.seq, it.frame, it.command, 1 if it.seq == 0 else 0, it.autocontinue, it.param1, it.param2,
                       it.param3, it.param4, it.x, it.y, it.z, it.mission_type)


def from_mavsdk(it: Any) -> mp.WireItem:
    return mp.WireItem(int(it.seq), int(it.command), int(it.frame), float(it.param1), float(it.param2), float(it.param3),
                       float(it.param4), int(it.x), int(it.y), float(it.z), int(it.autocontinue), int(it.current),
                       int(it.mission_type))


def _words(name: str) -> str:
    return _RESULT_WORDS.get(name, f"MAVSDK answered {name}")


class MavsdkTransfers:
    """MAVSDK's mission_raw plugin on `url` (a pymavlink connection string) for the vehicle the
    checks saw (`vehicle`, from its heartbeat). MAVSDK speaks as aerosurvey's GCS (system 255,
    component 190), and waits `timeout` seconds for each answer before it resends; `wait` bounds
    the wait for the vehicle; `verify`: a read-back follows every upload (see `upload`);
    `restarts`: how often one transfer may be started again (see `upload`, `download`)."""

    via = "MAVSDK's mission_raw plugin"

    def __init__(self, url: str, vehicle: Vehicle, timeout: float, wait: float, verify: bool = True,
                 restarts: int = mp.Policy().restarts) -> None:
        self.vehicle = vehicle
        self.verify = verify
        self.restarts = restarts
        self.url = url
        self._address = mavsdk_url(url)
        self._timeout = timeout
        self._wait = wait
        self._sdk: Any = None
        self._plugin: Any = None

    def __enter__(self) -> MavsdkTransfers:
        try:
            from mavsdk import Configuration, ConnectionResult, Mavsdk
            from mavsdk.plugins.mission_raw import MissionRaw
        except ImportError as exc:
            raise InputError(f"a PX4 upload needs MAVSDK's Python package, which is missing ({exc}): reinstall aerosurvey "
                             "with its dependencies or pip install 'mavsdk>=4.1,<5'") from None
        _quiet_mavsdk()
        config = Configuration.create_manual(GCS_SYSTEM, GCS_COMPONENT, True)
        self._sdk = Mavsdk(config)
        config.destroy()
        try:
            self._set_timeout()
            result = self._sdk.add_any_connection(self._address)
            if result != ConnectionResult.SUCCESS:
                raise LinkError(f"{self.url}: MAVSDK cannot open {self._address}: {ConnectionResult(result).name}")
            self._plugin = MissionRaw(self._find_system())
        except BaseException:
            self.close()
            raise
        return self

    def _set_timeout(self) -> None:
        """MAVSDK's answer timeout (0.5 s by default) set to ours: the C library has the call
        (mavsdk_set_timeout_s), the Python binding does not wrap it."""
        from mavsdk.cmavsdk_loader import _cmavsdk_lib

        setter = getattr(_cmavsdk_lib, "mavsdk_set_timeout_s", None)
        if setter is None:
            log.debug("MAVSDK has no mavsdk_set_timeout_s: its own timeout stays")
            return
        setter.argtypes = [ctypes.c_void_p, ctypes.c_double]
        setter.restype = None
        setter(self._sdk._handle, float(self._timeout))

    def _find_system(self) -> Any:
        end = time.monotonic() + self._wait
        while time.monotonic() < end:
            for system in self._sdk.get_systems():
                if system.get_system_id() == self.vehicle.system and system.has_autopilot():
                    return system
            time.sleep(0.02)
        raise LinkError(f"{self.url}: MAVSDK heard no autopilot with system id {self.vehicle.system} within {self._wait:g} s")

    def close(self) -> None:
        if self._sdk is not None:
            self._plugin = None
            self._sdk.destroy()
            self._sdk = None

    def __exit__(self, *exc: object) -> None:
        self.close()

    def now(self) -> float:
        return time.monotonic()

    def said(self, since: float) -> str:
        return ""

    def upload(self, kind: int, items: Sequence[mp.WireItem]) -> mp.Stats:
        """One upload, restarted (up to `restarts` times) after MAVSDK's PROTOCOL_ERROR; with
        `verify`, MAVSDK's TIMEOUT ends it with `ack_lost` for the read-back to settle.

        PROTOCOL_ERROR: MAVSDK takes any MISSION_ACK as the answer to its transfer, so a late or
        duplicated ACCEPTED of the transfer before (measured on a link that duplicates packets)
        ends the next one at once; PX4 stores a mission type only once every item has arrived,
        so sending it again is safe. TIMEOUT: MAVSDK (MavlinkMissionTransferClient) does not send
        the last item again when the vehicle's final MISSION_ACK is lost: it waits for the
        vehicle to ask again, which PX4 does not do once it holds every item, and ends in TIMEOUT
        although the vehicle may hold the whole mission. The read-back then counts and compares
        every item, as after aerosurvey's own protocol lost that ACK."""
        call = {mp.MISSION: self._plugin.upload_mission, mp.FENCE: self._plugin.upload_geofence,
                mp.RALLY: self._plugin.upload_rally_points}[kind]
        stats = mp.Stats(confirmed=len(items))
        outcome = self._call(lambda: call([to_mavsdk(it) for it in items]), stats)
        if outcome == "TIMEOUT" and self.verify:
            return mp.Stats(ack_lost=True, restarts=stats.restarts)
        if outcome is not None:
            raise UploadFailed(f"{mp.TYPE_NAMES[kind]} upload through MAVSDK failed: {_words(outcome)}"
                               + _after(stats), None)
        return stats

    def download(self, kind: int, expected: int) -> tuple[list[mp.WireItem], mp.Stats]:
        """One download, restarted (up to `restarts` times) after PROTOCOL_ERROR or TIMEOUT."""
        call = {mp.MISSION: self._plugin.download_mission, mp.FENCE: self._plugin.download_geofence,
                mp.RALLY: self._plugin.download_rallypoints}[kind]
        stats = mp.Stats()
        got: list[Any] = []
        outcome = self._call(lambda: got.extend(call()), stats, also=("TIMEOUT",))
        if outcome is not None:
            raise DownloadFailed(f"{mp.TYPE_NAMES[kind]} download through MAVSDK failed: {_words(outcome)}"
                                 + _after(stats), None)
        return [from_mavsdk(it) for it in got], stats

    def _call(self, call: Any, stats: mp.Stats, also: tuple[str, ...] = ()) -> str | None:
        """Run a MAVSDK transfer, again after PROTOCOL_ERROR (and `also`) while restarts are left;
        None when it succeeded, else the name of MAVSDK's last result."""
        from mavsdk import MavsdkError

        while True:
            try:
                call()
                return None
            except MavsdkError as exc:
                name = getattr(getattr(exc, "result", None), "name", None) or str(exc)
            if name not in ("PROTOCOL_ERROR", *also) or stats.restarts >= self.restarts:
                return name
            stats.restarts += 1
            log.debug("MAVSDK answered %s: transfer restarted (%d)", name, stats.restarts)


def _after(stats: mp.Stats) -> str:
    return f" (after {stats.restarts} restart(s))" if stats.restarts else ""
