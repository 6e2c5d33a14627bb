"""Camera events from flight logs, and their match to the planned photo stations."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aerosurvey.errors import InputError


@dataclass(frozen=True)
class Events:
    """One row per picture the autopilot logged, in time order."""

    time_s: np.ndarray  # seconds since boot (NaN where the log layout has no boot time)
    lat: np.ndarray
    lon: np.ndarray
    alt_m: np.ndarray  # AMSL
    rel_alt_m: np.ndarray  # above home
    roll: np.ndarray
    pitch: np.ndarray
    yaw: np.ndarray
    source: str
    utc_s: np.ndarray | None = None  # seconds since 1970 (UTC) from the GPS time, when logged

    def __len__(self) -> int:
        return len(self.time_s)


def from_dataflash(path: Path) -> tuple[Events, dict]:
    """CAM messages (or TRIG when no CAM was logged) of an ArduPilot DataFlash log."""
    from aerosurvey.flight.dataflash import DataFlashLog

    with DataFlashLog(path) as log:
        cam = log.messages("CAM")
        source = "CAM"
        if not cam:
            cam, source = log.messages("TRIG"), "TRIG"
        info = {"bytes": log.size, "skipped_bytes": log.skipped_bytes,
                "skipped": [{"offset": s.offset, "length": s.length, "reason": s.reason} for s in log.skipped[:50]],
                "messages": sum(log.counts().values())}
    if not cam:
        raise InputError(f"{path.name}: no CAM or TRIG camera events in the log "
                         f"({info['messages']} messages read, {info['skipped_bytes']} bytes skipped)")
    n = len(next(iter(cam.values())))

    def get(*names: str) -> np.ndarray:  # the first of the column names the layout has
        k = next((k for k in names if k in cam), None)
        return np.asarray(cam[k], float) if k is not None else np.full(n, np.nan)

    # CAM/TRIG layouts differ between firmware versions (as seen in real logs): ArduCopter 3.1
    # logs GPSTime,GPSWeek,Lat,Lng,Alt,Roll,Pitch,Yaw (no boot time, no RelAlt), 3.2 adds RelAlt,
    # later versions add TimeUS (and GPSAlt), and ArduCopter 4.6 names the attitude R,P,Y.
    time_s = get("TimeUS") / 1e6 if "TimeUS" in cam else get("TimeMS") / 1e3
    utc = gps_to_utc(get("GPSWeek"), get("GPSTime")) if "GPSWeek" in cam and "GPSTime" in cam else None
    key = time_s if np.isfinite(time_s).all() else utc if utc is not None and np.isfinite(utc).all() else np.arange(n)
    order = np.argsort(key, kind="stable")
    ev = Events(time_s[order], get("Lat")[order], get("Lng")[order], get("Alt")[order], get("RelAlt")[order],
                get("R", "Roll")[order], get("P", "Pitch")[order], get("Y", "Yaw")[order], source,
                utc[order] if utc is not None else None)
    return ev, info


#: GPS time runs ahead of UTC by the leap seconds since 1980 (18 s since 2017)
GPS_EPOCH_UNIX, LEAP_SECONDS = 315_964_800, 18


def gps_to_utc(week: np.ndarray, ms_of_week: np.ndarray) -> np.ndarray:
    return GPS_EPOCH_UNIX + week * 604_800.0 + ms_of_week / 1000.0 - LEAP_SECONDS


def _tlog_packets(data: bytes, mav) -> tuple[list, int]:
    """Walk [8-byte time stamp][MAVLink packet] records; on a packet that does not decode
    (bad CRC, cut off), move one byte on and look for the next one that does."""
    out, skipped, o, n = [], 0, 0, len(data)
    while o + 8 + 8 <= n:
        p = o + 8
        start = data[p]
        size = None
        if start == 0xFD and p + 10 <= n:
            size = 10 + data[p + 1] + 2 + (13 if data[p + 2] & 1 else 0)
        elif start == 0xFE and p + 6 <= n:
            size = 6 + data[p + 1] + 2
        if size is not None and p + size <= n:
            try:
                m = mav.decode(bytearray(data[p:p + size]))
            except Exception:  # pymavlink raises MAVError (and others) for a packet that does not check out
                m = None
            # an unknown message id is decoded without a CRC check: not evidence of a packet
            if m is not None and not m.get_type().startswith("UNKNOWN"):
                out.append(m)
                o = p + size
                continue
        o += 1
        skipped += 1
    return out, skipped + max(0, n - o)


def from_tlog(path: Path) -> tuple[Events, dict]:
    """CAMERA_FEEDBACK messages of a MAVLink telemetry log; damage costs only what it touches."""
    from pymavlink.dialects.v20 import ardupilotmega as mavlink

    data = path.read_bytes()
    msgs, skipped = _tlog_packets(data, mavlink.MAVLink(None))
    rows = [(m.time_usec, m.lat * 1e-7, m.lng * 1e-7, m.alt_msl, m.alt_rel, m.roll, m.pitch, m.yaw)
            for m in msgs if m.get_type() == "CAMERA_FEEDBACK"]
    info = {"bytes": len(data), "skipped_bytes": skipped, "skipped": [], "messages": len(msgs)}
    if not rows:
        raise InputError(f"{path.name}: no CAMERA_FEEDBACK messages in the telemetry log ({len(msgs)} messages read)")
    a = np.asarray(rows, float)
    a = a[np.argsort(a[:, 0], kind="stable")]
    return Events(a[:, 0] / 1e6, a[:, 1], a[:, 2], a[:, 3], a[:, 4], a[:, 5], a[:, 6], a[:, 7], "CAMERA_FEEDBACK"), info


def from_ulog(path: Path) -> tuple[Events, dict]:
    """camera_capture topics of a PX4 ULog (pyulog)."""
    from pyulog import ULog

    try:
        u = ULog(str(path), ["camera_capture"])
    except Exception as exc:  # pyulog raises plain exceptions for files it cannot parse
        raise InputError(f"{path.name}: not a readable ULog ({exc})") from None
    data = [d for d in u.data_list if d.name == "camera_capture"]
    info = {"bytes": path.stat().st_size, "skipped_bytes": 0, "skipped": [], "messages": sum(len(d.data["timestamp"]) for d in data)}
    if not data:
        raise InputError(f"{path.name}: no camera_capture topic in the ULog")
    d = data[0].data
    q = np.column_stack([d[f"q[{i}]"] for i in range(4)]) if "q[0]" in d else np.full((len(d["timestamp"]), 4), np.nan)
    w, x, y, z = q.T
    roll = np.degrees(np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y)))
    pitch = np.degrees(np.arcsin(np.clip(2 * (w * y - z * x), -1, 1)))
    yaw = np.degrees(np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))
    rel = np.asarray(d.get("ground_distance", np.full(len(d["timestamp"]), np.nan)), float)
    ev = Events(np.asarray(d["timestamp"], float) / 1e6, np.asarray(d["lat"], float), np.asarray(d["lon"], float),
                np.asarray(d["alt"], float), rel, roll, pitch, yaw, "camera_capture")
    return ev, info


def read_events(path: Path) -> tuple[Events, dict]:
    if not path.exists():
        raise InputError(f"flight log {str(path)!r} does not exist")
    suffix = path.suffix.lower()
    if suffix in (".bin", ".log"):
        return from_dataflash(path)
    if suffix == ".tlog":
        return from_tlog(path)
    if suffix == ".ulg":
        return from_ulog(path)
    raise InputError(f"{path.name}: unknown log type {suffix!r}; allowed: .bin (DataFlash), .tlog (MAVLink), .ulg (PX4 ULog)")


@dataclass(frozen=True)
class Match:
    station: list[str | None]  # the planned station of each event (None: an extra trigger)
    distance_m: np.ndarray
    missed: list[str]  # planned stations no event was matched to
    extra: list[int]  # event indices matched to no station
    far: list[int]  # matched events farther than the tolerance


def match_to_stations(ev: Events, stations: list[dict], tolerance_m: float, window: int = 60) -> Match:
    """Match events to planned stations, both in flight order.

    Each event takes the nearest station among the next `window` not yet matched ones,
    within 3 × tolerance; stations passed over are missed, events with none near are
    extra triggers. Order is kept, so a photo over a cross-hatch crossing cannot take a
    station of the other pass.
    """
    k = math.pi / 180.0
    lat0 = float(np.nanmean(ev.lat)) if len(ev) else 0.0
    ex = ev.lon * k * math.cos(lat0 * k) * 6_371_000.0
    ey = ev.lat * k * 6_371_000.0
    sx = np.array([s["lon"] for s in stations]) * k * math.cos(lat0 * k) * 6_371_000.0
    sy = np.array([s["lat"] for s in stations]) * k * 6_371_000.0
    gap = 3.0 * tolerance_m
    station: list[str | None] = [None] * len(ex)
    dist = np.full(len(ex), np.nan)
    matched = np.zeros(len(sx), bool)
    j = 0
    for i in range(len(ex)):
        hi = min(j + window, len(sx))
        if j >= hi:
            continue
        d = np.hypot(sx[j:hi] - ex[i], sy[j:hi] - ey[i])
        q = int(np.argmin(d))
        if d[q] <= gap:
            station[i] = stations[j + q]["id"]
            dist[i] = float(d[q])
            matched[j + q] = True
            j = j + q + 1
    missed = [s["id"] for q, s in enumerate(stations) if not matched[q]]
    extra = [q for q in range(len(ex)) if station[q] is None]
    far = [q for q in range(len(ex)) if station[q] is not None and dist[q] > tolerance_m]
    return Match(station, dist, missed, extra, far)
