"""Camera events from flight logs, and their match to the planned photo stations."""

from __future__ import annotations

import bisect
import functools
import math
import struct
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypedDict

import numpy as np

from aerosurvey.errors import InputError
from aerosurvey.flight.dataflash import DataFlashLog


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
    #: roll, pitch, yaw are the camera's own (a gimbal's, recorded with each photo: pitch 0 level,
    #: −90 straight down; yaw a true bearing), not the vehicle's (flight/photos.py)
    camera_attitude: bool = False

    def __len__(self) -> int:
        return len(self.time_s)


class SkipInfo(TypedDict):
    """One place of a log the reader did not take as it stands (log_report.json's read.skipped)."""

    offset: int  # byte offset in the log
    length: int  # bytes
    reason: str
    kind: str  # "damage", "format" (an FMT record rejected or ignored), "repeat" (a copied run of events),
    #            "event" (a camera event implausible for the log)


class ReadInfo(TypedDict):
    """What reading a log took and left (log_report.json's "read")."""

    bytes: int
    messages: int
    skipped_bytes: int  # every byte not taken, dropped events' messages included
    skipped: list[SkipInfo]  # the first MAX_SKIPS places, in file order
    skipped_places: int  # all places
    dropped_events: int  # camera events the log holds but the checks dropped (repeats, implausible)
    implausible_events: int  # of those, events whose fields disagree with the log (kind "event"), each once
    lost_bytes: int  # bytes skipped as damage or a rejected FMT record (kinds "damage", "format")
    checks: str  # what the events were checked against


MAX_SKIPS = 50
#: a camera event farther than this from every GPS fix logged within EVENT_WINDOW_S of it is not
#: plausible: in the SITL logs of tests/data events lie within 2.5 m of the GPS track at their
#: time; the window allows for the GPS's lag. A time stamp off by more than about
#: EVENT_WINDOW_S + EVENT_TRACK_M / speed puts the event off the track.
EVENT_TRACK_M = 30.0
EVENT_WINDOW_S = 1.0
#: without a GPS fix in the window, the bracketing fixes, with this much more per second away
EVENT_GAP_MS = 60.0
#: an event's own fields against the track: projected on the GPS track (the fixes within
#: EVENT_WINDOW_S of its time), its position gives the time the track passed there and its
#: distance from the track. Every event of a log shares one GPS lag, so the event's time minus
#: that track time is one constant and its distance one small figure, within a spread the log
#: shows itself; an event whose time or place lies more than EVENT_SPREAD robust standard
#: deviations (1.4826 median absolute deviations) off, and more than the floors below, is not
#: the event the autopilot logged. Measured on the SITL logs of tests/data (the track's times from
#: the fixes' own GPS time, `_on_track`): the time offsets lie within 7.5 ms of their median
#: (plane at 16 m/s, copter at 10 m/s), the distances within 0.04 m of the track. Events slower than TRACK_MIN_SPEED_MS along the
#: track are not checked for time (the place says little about the time when the vehicle hovers).
#: The track is searched LAG_WINDOW_S either side of the event's time: an event whose time is off
#: by more than EVENT_WINDOW_S but whose place is still near the track (a flipped bit in its time
#: stamp, seen: +1.57 s at 16 m/s, 25 m along the line) must still find where the track passed
#: it, or it goes unchecked.
LAG_WINDOW_S = 10.0
EVENT_SPREAD = 4.0
EVENT_TIME_FLOOR_S = 0.02
EVENT_CROSS_FLOOR_M = 2.0
TRACK_MIN_SPEED_MS = 2.0


def _info(size: int, messages: int, skips: list[SkipInfo], dropped: int, checks: str) -> ReadInfo:
    skips = sorted(skips, key=lambda s: s["offset"])
    return {"bytes": size, "messages": messages, "skipped_bytes": sum(s["length"] for s in skips),
            "skipped": skips[:MAX_SKIPS], "skipped_places": len(skips), "dropped_events": dropped,
            "implausible_events": sum(s["kind"] == "event" for s in skips),
            "lost_bytes": sum(s["length"] for s in skips if s["kind"] in ("damage", "format")), "checks": checks}


def _longest_increasing(t: np.ndarray) -> np.ndarray:
    """Mask of a longest strictly increasing subsequence of `t` (file order). Patience sorting run
    from the end keeps, of equally long choices, the earlier elements: a damaged event late in
    the log cannot push out an intact one before it."""
    n = len(t)
    tails: list[float] = []  # over the reversed, negated sequence
    tail_at: list[int] = []
    prev = [-1] * n
    for i in range(n - 1, -1, -1):
        v = -float(t[i])
        k = bisect.bisect_left(tails, v)
        if k == len(tails):
            tails.append(v)
            tail_at.append(i)
        else:
            tails[k], tail_at[k] = v, i
        prev[i] = tail_at[k - 1] if k else -1
    keep = np.zeros(n, bool)
    i = tail_at[-1] if tail_at else -1
    while i >= 0:
        keep[i] = True
        i = prev[i]
    return keep


def _local_m(lat: np.ndarray, lon: np.ndarray, lat0: float, lon0: float) -> tuple[np.ndarray, np.ndarray]:
    k = math.pi / 180.0 * 6_371_000.0
    return (lon - lon0) * k * math.cos(math.radians(lat0)), (lat - lat0) * k


@dataclass(frozen=True)
class _Track:
    """The log's GPS fixes in time order, each once (a copied chunk repeats some)."""

    t: np.ndarray  # seconds since boot, or NaN
    lat: np.ndarray
    lon: np.ndarray
    week: np.ndarray | None  # GPS week and milliseconds of the week of each fix, when logged
    ms: np.ndarray | None
    alt: np.ndarray | None = None  # metres above mean sea level, when logged

    @functools.cached_property
    def fix_times(self) -> np.ndarray:
        """The fixes' times on the boot clock, from their own GPS time where the log has it: a GPS
        message is logged up to a loop or two after its fix (tens of ms of jitter, and a damaged
        time stamp), the fix times are exact; the two clocks' offset is the median over the nearest
        51 fixes (it drifts slowly over a flight)."""
        gt = self.t
        if self.week is None or self.ms is None or len(gt) < 5:
            return gt
        gps_s = gps_seconds(self.week, self.ms)
        return np.asarray(gps_s + _running_median(gt - gps_s, 51))


def _running_median(v: np.ndarray, width: int) -> np.ndarray:
    """The median of each value and its nearest neighbours, `width` of them (odd; fewer when
    there are fewer values), in the given order; the first and last width // 2 values take the
    first and last full window's median."""
    w = min(width, len(v) - (len(v) + 1) % 2)
    if w < 1:
        return np.asarray(v, float).copy()
    core = np.median(np.lib.stride_tricks.sliding_window_view(v, w), axis=1)
    return np.asarray(np.r_[np.full(w // 2, core[0]), core, np.full(w // 2, core[-1])], float)


def gps_seconds(week: np.ndarray, ms_of_week: np.ndarray) -> np.ndarray:
    """Seconds of GPS time since the GPS epoch, from the week and the milliseconds of the week."""
    out: np.ndarray = week * 604_800.0 + ms_of_week / 1000.0
    return out


def _gps_track(log: DataFlashLog) -> _Track | None:
    """The log's GPS fixes that can be fixes: 3D fix where the layout logs its status, a
    position on the globe and not 0/0."""
    g = log.messages("GPS")
    if not g or "Lat" not in g or "Lng" not in g:
        return None
    lat, lon = np.asarray(g["Lat"], float), np.asarray(g["Lng"], float)
    ok = np.isfinite(lat) & np.isfinite(lon) & (np.abs(lat) <= 90) & (np.abs(lon) <= 180) & ((lat != 0) | (lon != 0))
    if "Status" in g:
        ok &= np.asarray(g["Status"]) >= 3
    if "I" in g:  # the first receiver's fixes (a second one has a clock and a lag of its own)
        ok &= np.asarray(g["I"]) == 0
    t = np.asarray(g["TimeUS"], float) / 1e6 if "TimeUS" in g else np.full(len(lat), np.nan)
    if not ok.any():
        return None
    clock = "GWk" in g and "GMS" in g
    week = np.asarray(g["GWk"], float) if clock else np.zeros(len(lat))
    ms = np.asarray(g["GMS"], float) if clock else np.zeros(len(lat))
    # in time order, repeats once: a fix's altitude does not make it another fix (a message cut
    # where a copied chunk begins may end in foreign bytes)
    rows, first = np.unique(np.column_stack([t, lat, lon, week, ms])[ok], axis=0, return_index=True)
    alt = np.asarray(g["Alt"], float)[ok][first] if "Alt" in g else None
    good = ~_damaged_fixes(rows, clock)
    rows = rows[good]
    return _Track(rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3] if clock else None, rows[:, 4] if clock else None,
                  alt[good] if alt is not None else None)


#: a GPS fix is damaged, and left out of the track the events are checked against, when its
#: GPS clock minus boot clock lies more than FIX_CLOCK_S from its neighbours' (the median of
#: five fixes), when its GPS time falls off the receiver's fix grid (the commonest step between
#: fixes) on both sides, or when its place lies off the line between the fixes either side by
#: more than the fixes around it do (a turn bends every fix alike), by FIX_PLACE_M and
#: EVENT_SPREAD robust standard deviations of the log's own fixes. Measured on the SITL logs of tests/data: the clocks
#: agree within 20 ms (the logging delay), the places within centimetres on straight legs.
FIX_CLOCK_S = 0.05
FIX_PLACE_M = 0.2
#: the logging delay of a GPS message after its fix varies by a loop or two (about 20 ms)
GPS_CLOCK_SLACK_S = 0.05


def _damaged_fixes(rows: np.ndarray, clock: bool) -> np.ndarray:
    """Mask of the fixes (rows of time, lat, lon, week, ms in time order) that disagree with
    their neighbours: a flipped bit in a GPS message would otherwise move the track."""
    n = len(rows)
    bad = np.zeros(n, bool)
    if n < 5 or not np.isfinite(rows[:, 0]).all():
        return bad
    t = rows[:, 0]
    if clock:
        gps_s = gps_seconds(rows[:, 3], rows[:, 4])
        r = gps_s - t
        near = np.median(np.lib.stride_tricks.sliding_window_view(np.pad(r, 2, mode="edge"), 5), axis=1)
        bad |= np.abs(r - near) > FIX_CLOCK_S
        step_ms = np.round(np.diff(gps_s) * 1000.0)
        steps, counts = np.unique(step_ms[step_ms > 0], return_counts=True)
        if len(steps):
            off = (step_ms % steps[np.argmax(counts)]) != 0
            bad |= np.r_[off[0], off[1:] & off[:-1], off[-1]]
    keep = np.flatnonzero(~bad)  # the places are judged among the fixes whose clocks hold
    if len(keep) < 5:
        return bad
    rows, t = rows[keep], t[keep]
    n = len(rows)
    x, y = _local_m(rows[:, 1], rows[:, 2], float(np.median(rows[:, 1])), float(np.median(rows[:, 2])))
    when = gps_seconds(rows[:, 3], rows[:, 4]) if clock else t  # the fixes' own time: no logging jitter
    span = when[2:] - when[:-2]
    f = np.where(span > 0, (when[1:-1] - when[:-2]) / np.where(span > 0, span, 1.0), 0.5)
    dev = np.zeros(n)
    dev[1:-1] = np.hypot(x[:-2] + f * (x[2:] - x[:-2]) - x[1:-1], y[:-2] + f * (y[2:] - y[:-2]) - y[1:-1])
    # a turn bends the track at every fix alike, a damaged fix bends it at itself (and half as much
    # at its neighbours): its deviation stands out from the median of the five around it
    excess = dev - np.median(np.lib.stride_tricks.sliding_window_view(np.pad(dev, 2, mode="edge"), 5), axis=1)
    limit = max(FIX_PLACE_M, EVENT_SPREAD * 1.4826 * float(np.median(np.abs(excess[1:-1]))))
    peak = np.zeros(n, bool)
    peak[1:-1] = (excess[1:-1] > limit) & (dev[1:-1] >= dev[:-2]) & (dev[1:-1] >= dev[2:])
    bad[keep[peak]] = True
    return bad


def _far_from_track(t: np.ndarray, lat: np.ndarray, lon: np.ndarray, track: _Track) -> np.ndarray:
    """Distance (m) from each event to the GPS track: to the nearest fix within EVENT_WINDOW_S of
    its time, less the allowance for the bracketing fixes when none is that near (events
    without a time: to the nearest fix of the whole track)."""
    gt, glat, glon = track.t, track.lat, track.lon
    gx, gy = _local_m(glat, glon, float(np.median(glat)), float(np.median(glon)))
    ex, ey = _local_m(lat, lon, float(np.median(glat)), float(np.median(glon)))
    timed = np.isfinite(gt).all() and len(gt) > 0
    out = np.full(len(t), np.inf)
    for i in range(len(t)):
        if not (np.isfinite(ex[i]) and np.isfinite(ey[i])):
            continue
        if timed and np.isfinite(t[i]):
            lo, hi = np.searchsorted(gt, t[i] - EVENT_WINDOW_S), np.searchsorted(gt, t[i] + EVENT_WINDOW_S, "right")
            if hi > lo:
                out[i] = float(np.min(np.hypot(gx[lo:hi] - ex[i], gy[lo:hi] - ey[i])))
            else:  # a gap in the GPS messages: the fixes either side, allowing for the time to them
                # (events outside the GPS messages' span are dropped before)
                near = [j for j in (lo - 1, lo) if 0 <= j < len(gt)]
                out[i] = min(float(np.hypot(gx[j] - ex[i], gy[j] - ey[i])) - EVENT_GAP_MS * abs(gt[j] - t[i]) for j in near)
        else:
            out[i] = float(np.min(np.hypot(gx - ex[i], gy - ey[i])))
    return out


#: a vehicle that stays at a place (a wait at a waypoint, hover-and-capture) passes it over an
#: interval, not at one instant: an event whose time falls within a stretch of the track that
#: stayed within EVENT_CROSS_FLOOR_M of its place for longer than a pass at TRACK_MIN_SPEED_MS
#: takes (the events of a slower track are not checked for time either) is where the track was
#: at its time; its time is not judged against the first time the track came there (seen: a
#: copter in wind at a corridor line's first waypoint from 119.8 s to 128.9 s, its photo at the
#: end of the wait dropped as 9.9 s off).
STAY_S = 2.0 * EVENT_CROSS_FLOOR_M / TRACK_MIN_SPEED_MS


def _stays(fix_t: np.ndarray, dist: np.ndarray, t: float) -> bool:
    """Whether the track (fix times in order, each fix's distance from an event's place) stayed
    within EVENT_CROSS_FLOOR_M of the place over a stretch of at least STAY_S that holds `t`
    (the fixes either side of `t` and every fix between the stretch's ends)."""
    near = dist <= EVENT_CROSS_FLOOR_M
    j = int(np.searchsorted(fix_t, t))  # the first fix after t
    if not (j > 0 and near[j - 1]) and not (j < len(near) and near[j]):
        return False
    at = j - 1 if j > 0 and near[j - 1] else j
    away = np.flatnonzero(~near)
    first = int(away[away < at][-1]) + 1 if (away < at).any() else 0
    last = int(away[away > at][0]) - 1 if (away > at).any() else len(near) - 1
    return bool(fix_t[last] - fix_t[first] >= STAY_S)


def _on_track(t: np.ndarray, lat: np.ndarray, lon: np.ndarray, track: _Track) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(the event's time minus the time the GPS track passed its place, its distance from the
    track (m), the track's speed there (m/s)) of each event: its position projected on the
    nearest segment between two fixes within LAG_WINDOW_S of its time (or the fix between two
    segments, a corner, where that is nearest); NaN where there is none, where the nearest point
    is the end of the track searched or a gap's edge (the event lies beyond it), where the
    segment spans a gap in the fixes (more than 2.5 periods of the GPS: damage took the fixes
    between), or where the track stayed at the event's place at its time
    (`_stays`: it was there, at whatever time it first came)."""
    gt = track.t
    n = len(t)
    dt_out, d_out, v_out = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan)
    if not (len(gt) > 1 and np.isfinite(gt).all()):
        return dt_out, d_out, v_out
    gt = track.fix_times
    lat0, lon0 = float(np.median(track.lat)), float(np.median(track.lon))
    gx, gy = _local_m(track.lat, track.lon, lat0, lon0)
    ex, ey = _local_m(lat, lon, lat0, lon0)
    gap = 2.5 * float(np.median(np.diff(gt)))
    for i in np.flatnonzero(np.isfinite(t) & np.isfinite(ex) & np.isfinite(ey)).tolist():
        a = max(int(np.searchsorted(gt, t[i] - LAG_WINDOW_S)) - 1, 0)
        b = min(int(np.searchsorted(gt, t[i] + LAG_WINDOW_S, "right")), len(gt) - 1)
        if b <= a or _stays(gt[a:b + 1], np.hypot(gx[a:b + 1] - ex[i], gy[a:b + 1] - ey[i]), float(t[i])):
            continue
        ax, ay, dx, dy = gx[a:b], gy[a:b], gx[a + 1:b + 1] - gx[a:b], gy[a + 1:b + 1] - gy[a:b]
        dur = gt[a + 1:b + 1] - gt[a:b]
        length2 = dx * dx + dy * dy
        ok = (length2 > 0) & (dur > 0) & (dur <= gap)
        if not ok.any():
            continue
        u = np.clip(((ex[i] - ax) * dx + (ey[i] - ay) * dy) / np.where(ok, length2, 1.0), 0.0, 1.0)
        d = np.where(ok, np.hypot(ax + u * dx - ex[i], ay + u * dy - ey[i]), np.inf)
        k = int(np.argmin(d))
        if not np.isfinite(d[k]):
            continue
        # nearest at a segment's end: a fix between two segments (a corner of the track) is a place of the
        # track like any other; the end of the track searched, or a gap's edge, is not (the event lies beyond)
        beyond = (u[k] == 0.0 and (k == 0 or not ok[k - 1])) or (u[k] == 1.0 and (k == len(ok) - 1 or not ok[k + 1]))
        if beyond:
            continue
        dt_out[i] = t[i] - (gt[a + k] + u[k] * dur[k])
        d_out[i] = d[k]
        v_out[i] = math.sqrt(length2[k]) / dur[k]
    return dt_out, d_out, v_out


def _off_spread(v: np.ndarray, floor: float, one_sided: bool = False) -> tuple[np.ndarray, float, float]:
    """(mask of the values farther from their median than the limit, the median, the limit):
    the limit is EVENT_SPREAD robust standard deviations of the values, and at least `floor`."""
    fin = v[np.isfinite(v)]
    if len(fin) < 5:  # too few to know the log's own spread
        return np.zeros(len(v), bool), math.nan, math.nan
    med = float(np.median(fin))
    limit = max(floor, EVENT_SPREAD * 1.4826 * float(np.median(np.abs(fin - med))))
    off = (v - med) if one_sided else np.abs(v - med)
    return np.isfinite(v) & (off > limit), med, limit


def _off_gps_clock(time_s: np.ndarray, week: np.ndarray, ms: np.ndarray, track: _Track) -> np.ndarray:
    """Events whose boot time lies outside the span from the GPS fix their own GPS time names
    to the next fix, by more than GPS_CLOCK_SLACK_S: ArduPilot writes the time of the last fix
    into a CAM message, so it was logged after that fix and before the next one. The fixes'
    times are `_Track.fix_times` (logging jitter and damaged GPS time stamps aside). Events whose fix
    is not in the log (or was left out as damaged) are not checked."""
    bad = np.zeros(len(time_s), bool)
    if track.week is None or track.ms is None or not np.isfinite(track.t).all():
        return bad
    keys = track.week * 604_800_000.0 + track.ms
    order = np.argsort(keys, kind="stable")
    ev = week * 604_800_000.0 + ms
    at = np.clip(np.searchsorted(keys[order], ev), 0, len(keys) - 1)
    fix = order[at]
    named = np.isfinite(ev) & (keys[fix] == ev) & np.isfinite(time_s)
    ft = track.fix_times
    t_next = np.append(ft[1:], np.inf)[fix]
    return np.asarray(named & ((time_s < ft[fix] - GPS_CLOCK_SLACK_S) | (time_s > t_next + GPS_CLOCK_SLACK_S)), bool)


# --- an event's altitude and attitude -------------------------------------------------------

#: what no vehicle logs: a roll beyond ±180°, a pitch beyond ±90°, a yaw outside -180..360°
#: (ArduPilot logs 0..360, a quaternion gives -180..180), an altitude or a relative altitude more
#: than ALT_BOUND_M from sea level or home. A damaged record is checked against these first.
ANGLE_BOUNDS = {"roll": (-180.0, 180.0), "pitch": (-90.0, 90.0), "yaw": (-180.0, 360.0)}
ALT_BOUND_M = 10_000.0
#: Then against what the log recorded around the event's time. Its altitude and relative
#: altitude against the GPS track's altitudes: each event's altitude minus the GPS altitude at
#: its time is one offset along a log (the barometer's and the GPS's heights drift apart slowly;
#: the relative altitude's offset also holds the home altitude), taken as the median over the
#: nearest FIELD_OFFSET_EVENTS events; with it, the event lies within the range of the GPS
#: altitudes from the last fix before FIELD_WINDOW_S ahead of its time to the first fix after
#: FIELD_WINDOW_S past it (a climb or the GPS's noise widens it), or it is off by how far it lies
#: beyond that range. Its roll, pitch and yaw alike against the vehicle's attitude logged within
#: ATT_WINDOW_S (ArduPilot's ATT, PX4's vehicle_attitude, MAVLink's ATTITUDE), without an
#: offset. A field off by more than its floor and more than EVENT_SPREAD robust standard
#: deviations of the log's own events is not the one the autopilot logged. Measured on the SITL
#: logs of tests/data: altitudes within 0.07 m of the GPS range, attitudes within 0.14° of ATT's.
#: Without GPS altitudes, an event's altitude minus its relative altitude (the home altitude) is
#: checked against the nearest FIELD_OFFSET_EVENTS events' median instead.
FIELD_WINDOW_S = 1.0
ATT_WINDOW_S = 0.5
FIELD_OFFSET_EVENTS = 21
ALT_FLOOR_M = 3.0
ATT_FLOOR_DEG = 5.0


@dataclass(frozen=True)
class Series:
    """One quantity the log recorded besides its camera events, in time order on the events' clock."""

    t: np.ndarray
    v: np.ndarray
    what: str  # for the reasons: "the GPS track's altitude", "ATT roll"


@dataclass(frozen=True)
class FieldReferences:
    """What an event's fields are checked against; None where the log has none. `rel_alt` may
    be an altitude above sea level: the offset the events show to it holds the home altitude."""

    alt: Series | None = None
    rel_alt: Series | None = None
    roll: Series | None = None
    pitch: Series | None = None
    yaw: Series | None = None
    window_s: float = 0.0  # more seconds either side, where the clocks differ (a telemetry log's reception)
    above_home: bool = True  # the events' relative altitude is above home (PX4's is above the ground)


def _range_around(t: np.ndarray, ref: Series, window: float) -> tuple[np.ndarray, np.ndarray]:
    """(lowest, highest) value of `ref` from its last sample before t - window to its first
    after t + window; NaN where `ref` does not reach beyond both ends."""
    rt, rv = ref.t, ref.v
    lo = np.searchsorted(rt, t - window) - 1
    hi = np.searchsorted(rt, t + window, "right")
    judged = np.isfinite(t) & (lo >= 0) & (hi < len(rt))
    lo, hi = np.where(judged, lo, 0), np.where(judged, hi, 0)
    bounds = np.column_stack([lo, hi + 1]).ravel()  # reduceat takes each [lo, hi] from the even places
    padded = np.append(rv, rv[-1:]) if len(rv) else np.zeros(1)
    low = np.where(judged, np.minimum.reduceat(padded, bounds)[::2], np.nan)
    high = np.where(judged, np.maximum.reduceat(padded, bounds)[::2], np.nan)
    return low, high


def _off_floor(dev: np.ndarray, floor: float) -> tuple[np.ndarray, float]:
    """(mask of the deviations beyond the limit, the limit): `floor`, or EVENT_SPREAD robust
    standard deviations of the finite deviations when they are more (five or more of them)."""
    fin = dev[np.isfinite(dev)]
    spread = EVENT_SPREAD * 1.4826 * float(np.median(np.abs(fin - np.median(fin)))) if len(fin) >= 5 else 0.0
    limit = max(floor, spread)
    return np.isfinite(dev) & (dev > limit), limit


FIELD_NAMES = {"alt": "altitude", "rel_alt": "relative altitude", "roll": "roll", "pitch": "pitch", "yaw": "yaw"}


def _bounds(key: str) -> tuple[float, float]:
    return ANGLE_BOUNDS.get(key, (-ALT_BOUND_M, ALT_BOUND_M))


@dataclass(frozen=True)
class _Judged:
    """One field of each event against its reference: how far it lies outside the range the
    reference took around its time (NaN: not judged), that range, and the limit."""

    dev: np.ndarray
    low: np.ndarray
    high: np.ndarray
    offset: np.ndarray  # the log's own offset of the field to the reference (altitudes), added to the range
    window: float
    limit: float


def _judge(key: str, t: np.ndarray, v: np.ndarray, ref: Series, window_s: float) -> _Judged | None:
    """A field (`key` of FIELD_NAMES; NaN where not to judge) against its reference's samples
    within physical bounds (the others are damage); None when there are none."""
    lo_b, hi_b = _bounds(key)
    sound = (ref.v >= lo_b) & (ref.v <= hi_b)
    if not sound.any():
        return None
    rt = ref.t[sound]
    rv = np.unwrap(ref.v[sound], period=360.0) if key == "yaw" else ref.v[sound]
    at = np.interp(t, rt, rv)
    offset = np.zeros(len(t))
    if key == "yaw":  # the turn nearest the vehicle's
        v = v + 360.0 * np.round((at - v) / 360.0)
    if key in ("alt", "rel_alt"):  # the log's own offset to the reference, over the nearest events in time
        order = np.argsort(np.where(np.isfinite(t), t, np.inf), kind="stable")
        resid = (v - at)[order]
        fin = np.isfinite(resid)
        offset[order[fin]] = _running_median(resid[fin], FIELD_OFFSET_EVENTS)
    window = (FIELD_WINDOW_S if key in ("alt", "rel_alt") else ATT_WINDOW_S) + window_s
    low, high = _range_around(t, Series(rt, rv, ref.what), window)
    low, high = low + offset, high + offset
    dev = np.maximum(np.maximum(low - v, v - high), 0.0)
    return _Judged(dev, low, high, offset, window, _off_floor(dev, ALT_FLOOR_M if key in ("alt", "rel_alt") else ATT_FLOOR_DEG)[1])


def _home_faults(t: np.ndarray, alt: np.ndarray, rel: np.ndarray, judged: np.ndarray) -> dict[int, str]:
    """Where no altitude was judged against a reference: the home altitude each event's altitude
    and relative altitude give, against that of the nearest events in time."""
    both = np.isfinite(alt) & np.isfinite(rel) & ~judged & np.isfinite(t)
    idx = np.flatnonzero(both)
    idx = idx[np.argsort(t[idx], kind="stable")]
    home = alt[idx] - rel[idx]
    usual = _running_median(home, FIELD_OFFSET_EVENTS)
    off, limit = _off_floor(np.abs(home - usual), ALT_FLOOR_M)
    return {int(idx[k]): f"altitude {alt[idx[k]]:.2f} m and relative altitude {rel[idx[k]]:.2f} m put home at "
                         f"{home[k]:.1f} m, the log's events at {usual[k]:.1f} m (allowed {limit:.1f} m)"
            for k in np.flatnonzero(off).tolist()}


def field_faults(t: np.ndarray, fields: dict[str, np.ndarray], refs: FieldReferences) -> tuple[list[str], str]:
    """What is wrong with each event's altitude, relative altitude and attitude ('' where
    nothing), and the checks that ran. `fields` holds the FIELD_NAMES (NaN where the log has no
    value: not judged); `t` is on the references' clock."""
    n = len(t)
    faults: list[list[str]] = [[] for _ in range(n)]
    ran = ["physical bounds"]
    judged_alt = np.zeros(n, bool)
    for key, name in FIELD_NAMES.items():
        v = np.asarray(fields[key], float)
        unit = "°" if key in ANGLE_BOUNDS else " m"
        lo_b, hi_b = _bounds(key)
        out = np.isfinite(v) & ((v < lo_b) | (v > hi_b))
        for i in np.flatnonzero(out).tolist():
            faults[i].append(f"{name} {v[i]:.2f}{unit} is outside {lo_b:g} to {hi_b:g}{unit}")
        ref: Series | None = getattr(refs, key)
        j = _judge(key, t, np.where(out, np.nan, v), ref, refs.window_s) if ref is not None else None
        if ref is None or j is None:
            continue
        ran.append(f"{name} on {ref.what}")
        if key in ("alt", "rel_alt"):
            judged_alt |= np.isfinite(j.dev)
        for i in np.flatnonzero(np.isfinite(j.dev) & (j.dev > j.limit)).tolist():
            span = f"{j.low[i] % 360:.1f} to {j.high[i] % 360:.1f}°" if key == "yaw" else f"{j.low[i]:.1f} to {j.high[i]:.1f}{unit}"
            shift = "" if key in ANGLE_BOUNDS else f" {j.offset[i]:+.1f} m, the log's offset to it"
            if key == "rel_alt" and ref is refs.alt:
                shift += " (home altitude included)"
            faults[i].append(f"{name} {v[i]:.2f}{unit} lies {j.dev[i]:.1f}{unit} outside {span}: {ref.what} within "
                             f"{j.window:g} s of its time{shift} (allowed {j.limit:.1f}{unit})")
    if refs.above_home:
        home = _home_faults(t, np.asarray(fields["alt"], float), np.asarray(fields["rel_alt"], float), judged_alt)
        if (~judged_alt).any() and np.isfinite(fields["rel_alt"]).any():
            ran.append("home altitude against the events'")
        for i, f in home.items():
            faults[i].append(f)
    return ["; ".join(f) for f in faults], ", ".join(ran)


def _dataflash_references(log: DataFlashLog, track: _Track | None) -> FieldReferences:
    """The GPS track's altitudes, and the vehicle's attitude from the ATT messages (each sample
    once, in time order), to check the camera events' other fields against."""
    alt = None
    if track is not None and track.alt is not None and np.isfinite(track.t).all():
        alt = Series(track.t, track.alt, "the GPS track's altitude")
    a = log.messages("ATT")
    clock = next((c for c in ("TimeUS", "TimeMS") if c in a), None)
    if clock is None or not all(k in a for k in ("Roll", "Pitch", "Yaw")):
        return FieldReferences(alt, alt)
    t = np.asarray(a[clock], float) / (1e6 if clock == "TimeUS" else 1e3)
    rows = np.column_stack([t] + [np.asarray(a[k], float) for k in ("Roll", "Pitch", "Yaw")])
    rows = np.unique(rows[np.isfinite(rows).all(axis=1)], axis=0)  # in time order, a copied chunk's repeats once
    roll, pitch, yaw = (Series(rows[:, 0], rows[:, k], f"ATT {name}") for k, name in ((1, "roll"), (2, "pitch"), (3, "yaw")))
    return FieldReferences(alt, alt, roll, pitch, yaw)


def from_dataflash(path: Path) -> tuple[Events, ReadInfo]:
    """CAM messages (or TRIG when no CAM was logged) of an ArduPilot DataFlash log, checked.

    Kept: one copy of every event. A copied chunk of the log repeats messages byte for byte
    (every message carries a time stamp, so no two real ones are equal), before, after or
    overlapping its source; of the copies, the one that fits the time order of the others is
    kept and the rest are reported as repeats. Dropped, each with its place and reason in the
    report, events whose own fields disagree with the log: no position on the globe; a time
    outside the span of the log's GPS messages; farther than EVENT_TRACK_M from every GPS fix
    logged within EVENT_WINDOW_S; a boot time outside the span of the GPS fix its own GPS time
    names; a time or a place off the GPS track beyond the log's own spread (`_on_track`); an
    altitude, relative altitude, roll, pitch or yaw that is impossible or that the GPS track's
    altitudes or the ATT messages contradict (`field_faults`); a time that breaks the order of
    the others (the fewest are dropped that leave the times strictly
    increasing in file order). One log is one boot of the autopilot (ArduPilot starts a new
    file at each), so its times increase.
    """
    with DataFlashLog(path) as log:
        source = "CAM"
        cam = log.messages("CAM")
        if not cam:
            source = "TRIG"
            cam = log.messages("TRIG")
        skips: list[SkipInfo] = [{"offset": s.offset, "length": s.length, "reason": s.reason, "kind": s.kind}
                                 for s in log.skipped]
        messages = sum(log.counts().values())
        if not cam:
            info = _info(log.size, messages, skips, 0, "none")
            raise InputError(f"{path.name}: no CAM or TRIG camera events in the log "
                             f"({messages} messages read, {info['skipped_bytes']} bytes skipped)")
        offs = log.message_offsets(source)
        fmt = log.type_of(source)
        assert fmt is not None  # it has messages
        rec_len = fmt.length
        rep = log.repeated(source)
        track = _gps_track(log)
        refs = _dataflash_references(log, track)
    n = len(offs)

    def get(*names: str) -> np.ndarray:  # the first of the column names the layout has
        k = next((k for k in names if k in cam), None)
        return np.asarray(cam[k], float) if k is not None else np.full(n, np.nan)

    # CAM/TRIG layouts differ between firmware versions (as seen in real logs): ArduCopter 3.1
    # logs GPSTime,GPSWeek,Lat,Lng,Alt,Roll,Pitch,Yaw (no boot time, no RelAlt), 3.2 adds RelAlt,
    # later versions add TimeUS (and GPSAlt), and ArduCopter 4.6 names the attitude R,P,Y.
    time_s = get("TimeUS") / 1e6 if "TimeUS" in cam else get("TimeMS") / 1e3
    has_clock = "GPSWeek" in cam and "GPSTime" in cam
    utc = gps_to_utc(get("GPSWeek"), get("GPSTime")) if has_clock else None
    lat, lon = get("Lat"), get("Lng")
    original = np.where(rep >= 0, rep, np.arange(n))  # the first copy of each message

    keep = np.ones(n, bool)

    def drop(mask: np.ndarray, kind: str, why: str | Callable[[int], str]) -> None:
        for i in np.flatnonzero(mask & keep & (original == np.arange(n))).tolist():
            skips.append({"offset": int(offs[i]), "length": rec_len, "kind": kind,
                          "reason": f"{source} event at {_when(time_s, utc, i)}: " + (why(i) if callable(why) else why)})
        keep[mask] = False

    bad_pos = ~(np.isfinite(lat) & np.isfinite(lon) & (np.abs(lat) <= 90) & (np.abs(lon) <= 180) & ((lat != 0) | (lon != 0)))
    drop(bad_pos, "event", lambda i: f"position {lat[i]:.7f}, {lon[i]:.7f} is not a place on the globe; dropped")
    tcheck = time_s if np.isfinite(time_s).all() else np.full(n, np.nan)
    if track is not None:
        checks = f"GPS track ({len(track.t)} fixes), time order"
        gt = track.t
        if np.isfinite(gt).all() and np.isfinite(tcheck).all():
            lo, hi = float(gt[0]) - EVENT_WINDOW_S, float(gt[-1]) + EVENT_WINDOW_S
            drop((tcheck < lo) | (tcheck > hi), "event",
                 f"its time lies outside the log's GPS messages ({gt[0]:.3f} to {gt[-1]:.3f} s); dropped")
        dist = np.full(n, np.inf)
        dist[keep] = _far_from_track(tcheck[keep], lat[keep], lon[keep], track)
        drop(dist > EVENT_TRACK_M, "event", lambda i: f"{lat[i]:.7f}, {lon[i]:.7f} lies {dist[i]:.0f} m from the "
             f"log's GPS track within {EVENT_WINDOW_S:g} s of its time (allowed {EVENT_TRACK_M:g} m); dropped")
        if has_clock:
            checks += ", GPS clock"
            week, ms = get("GPSWeek"), get("GPSTime")
            drop(_off_gps_clock(tcheck, week, ms, track), "event",
                 lambda i: f"its boot time lies outside the span of the GPS fix its GPS time ({week[i]:.0f}, "
                           f"{ms[i]:.0f} ms) names; dropped")
        lag, cross, speed = (np.full(n, np.nan) for _ in range(3))
        lag[keep], cross[keep], speed[keep] = _on_track(tcheck[keep], lat[keep], lon[keep], track)
        if np.isfinite(cross).any():
            checks += ", place and time on the GPS track"
        far, _, far_limit = _off_spread(cross, EVENT_CROSS_FLOOR_M, one_sided=True)
        drop(far, "event", lambda i: f"{lat[i]:.7f}, {lon[i]:.7f} lies {cross[i]:.2f} m off the log's GPS track, "
             f"more than the log's own spread allows ({far_limit:.2f} m); dropped")
        lag[speed < TRACK_MIN_SPEED_MS] = np.nan
        late, lag_med, lag_limit = _off_spread(lag, EVENT_TIME_FLOOR_S)
        drop(late, "event", lambda i: f"the GPS track passed its place at {time_s[i] - lag[i]:.3f} s, "
             f"{1e3 * (lag[i] - lag_med):+.0f} ms off the log's own lag ({1e3 * lag_med:.0f} ms, allowed "
             f"{1e3 * lag_limit:.0f} ms): its time or place is not the logged one; dropped")
    else:
        checks = "time order (no GPS fixes in the log)"
    columns = {"alt": ("Alt",), "rel_alt": ("RelAlt",), "roll": ("R", "Roll"), "pitch": ("P", "Pitch"), "yaw": ("Y", "Yaw")}
    fields = {field: get(*names) for field, names in columns.items()}
    faults = [""] * n
    found, ran = field_faults(tcheck[keep], {k: v[keep] for k, v in fields.items()}, refs)
    for i, f in zip(np.flatnonzero(keep).tolist(), found):
        faults[i] = f
    checks += ", " + ran
    for field, names in columns.items():  # an older layout, or a column name damaged into another one
        if not any(c in cam for c in names):
            checks += f"; {source} has no {' or '.join(names)} column: {FIELD_NAMES[field]} empty in every event"
    drop(np.array([bool(f) for f in faults]), "event", lambda i: f"{faults[i]}; dropped")
    key = time_s if np.isfinite(time_s).all() else utc if utc is not None and np.isfinite(utc).all() else None
    if key is not None:
        # copies of one message have one time, so an increasing sequence takes at most one of them
        idx = np.flatnonzero(keep)
        in_order = np.zeros(n, bool)
        in_order[idx[_longest_increasing(key[idx])]] = True
        kept_copy = np.zeros(n, bool)
        kept_copy[original[in_order]] = True
        repeat = keep & ~in_order & kept_copy[original]
    else:
        checks += " (events have no time)"
        in_order = keep.copy()
        repeat = keep & (rep >= 0)
        in_order[repeat] = False
    # a run of copies dropped (each the message after the previous one in the file) is one place
    runs = np.flatnonzero(repeat)
    for run in np.split(runs, np.flatnonzero(np.diff(runs) != 1) + 1) if len(runs) else []:
        first, last = int(run[0]), int(run[-1])
        skips.append({"offset": int(offs[first]), "length": int(offs[last] - offs[first]) + rec_len, "kind": "repeat",
                      "reason": f"{len(run)} {source} event(s) from {_when(time_s, utc, first)} to {_when(time_s, utc, last)} "
                                "repeat other messages of the log byte for byte (a copied chunk of the log); the copy "
                                "that fits the time order of the others is kept, these are dropped"})
    keep[repeat] = False
    drop(keep & ~in_order, "event", "its time breaks the order of the log's other events; dropped")
    info = _info(path.stat().st_size, messages, skips, int(n - keep.sum()), checks)
    if not keep.any():
        raise InputError(f"{path.name}: none of the {n} {source} events in the log is plausible "
                         f"(first reason: {next(s['reason'] for s in skips if s['kind'] in ('repeat', 'event'))})")
    k = np.flatnonzero(keep)
    sort_key = key if key is not None else np.arange(n, dtype=float)
    k = k[np.argsort(sort_key[k], kind="stable")]
    ev = Events(time_s[k], lat[k], lon[k], fields["alt"][k], fields["rel_alt"][k], fields["roll"][k], fields["pitch"][k],
                fields["yaw"][k], source, utc[k] if utc is not None else None)
    return ev, info


def _when(time_s: np.ndarray, utc: np.ndarray | None, i: int) -> str:
    if np.isfinite(time_s[i]):
        return f"{time_s[i]:.3f} s"
    if utc is not None and np.isfinite(utc[i]):
        return f"UTC {utc[i]:.3f} s"
    return f"#{i + 1}"


#: GPS time runs ahead of UTC by the leap seconds since 1980 (18 s since 2017)
GPS_EPOCH_UNIX, LEAP_SECONDS = 315_964_800, 18


def gps_to_utc(week: np.ndarray, ms_of_week: np.ndarray) -> np.ndarray:
    return GPS_EPOCH_UNIX + gps_seconds(week, ms_of_week) - LEAP_SECONDS


def _tlog_packets(data: bytes, mav: Any) -> tuple[list[tuple[int, int, Any]], int]:
    """Walk [8-byte time stamp][MAVLink packet] records: (offset, length, message) of each
    record, and the bytes skipped; on a packet that does not decode (bad CRC, cut off), move
    one byte on and look for the next one that does."""
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
                out.append((o, 8 + size, m))
                o = p + size
                continue
        o += 1
        skipped += 1
    return out, skipped + max(0, n - o)


def tlog_messages(path: Path) -> list[Any]:
    """The MAVLink messages of a telemetry log that decode, in file order (damage skipped)."""
    from pymavlink.dialects.v20 import ardupilotmega as mavlink

    packets, _ = _tlog_packets(path.read_bytes(), mavlink.MAVLink(None))
    return [m for _, _, m in packets]


#: a telemetry log stamps each message when the ground station received it; the camera feedback
#: and the attitude and position messages cross the link on their own schedules, so their
#: stamps differ by the link's delays: their windows are this much wider
TLOG_RECEPTION_S = 1.0


def _series(rows: list[tuple[float, float]], what: str) -> Series | None:
    """(time, value) samples as a Series in time order, finite ones only; None when there are none."""
    a = np.asarray(rows, float).reshape(-1, 2)
    a = a[np.isfinite(a).all(axis=1)]
    a = a[np.argsort(a[:, 0], kind="stable")]
    return Series(a[:, 0], a[:, 1], what) if len(a) else None


def _drop_faulty(source: str, ev: Events, check_t: np.ndarray, refs: FieldReferences, places: list[tuple[int, int]],
                 log_name: str) -> tuple[Events, list[SkipInfo], str]:
    """The events whose fields hold (`field_faults` on `check_t`, the references' clock), the
    dropped ones' reports at their (offset, length) in the log, and the checks that ran."""
    fields = {"alt": ev.alt_m, "rel_alt": ev.rel_alt_m, "roll": ev.roll, "pitch": ev.pitch, "yaw": ev.yaw}
    faults, ran = field_faults(check_t, fields, refs)
    skips: list[SkipInfo] = [{"offset": places[i][0], "length": places[i][1], "kind": "event",
                              "reason": f"{source} event at {_when(ev.time_s, None, i)}: {f}; dropped"}
                             for i, f in enumerate(faults) if f]
    keep = np.array([not f for f in faults], bool)
    if not keep.any():
        raise InputError(f"{log_name}: none of the {len(ev)} {source} events in the log is plausible "
                         f"(first reason: {skips[0]['reason']})")
    k = np.flatnonzero(keep)
    return Events(ev.time_s[k], ev.lat[k], ev.lon[k], ev.alt_m[k], ev.rel_alt_m[k], ev.roll[k], ev.pitch[k], ev.yaw[k],
                  source, ev.utc_s[k] if ev.utc_s is not None else None), skips, ran


def from_tlog(path: Path) -> tuple[Events, ReadInfo]:
    """CAMERA_FEEDBACK messages of a MAVLink telemetry log; damage costs only what it touches.
    Each event's altitude and attitude are checked (`field_faults`) against the ATTITUDE and
    GLOBAL_POSITION_INT messages received around it, where the log has them."""
    from pymavlink.dialects.v20 import ardupilotmega as mavlink

    data = path.read_bytes()
    packets, skipped = _tlog_packets(data, mavlink.MAVLink(None))

    def received(name: str) -> list[tuple[float, int, int, Any]]:  # (reception time s, offset, length, message)
        return [(struct.unpack_from(">Q", data, o)[0] / 1e6, o, ln, m) for o, ln, m in packets if m.get_type() == name]

    cams = sorted(received("CAMERA_FEEDBACK"), key=lambda c: c[3].time_usec)
    if not cams:
        raise InputError(f"{path.name}: no CAMERA_FEEDBACK messages in the telemetry log ({len(packets)} messages read)")
    a = np.asarray([(m.time_usec, m.lat * 1e-7, m.lng * 1e-7, m.alt_msl, m.alt_rel, m.roll, m.pitch, m.yaw)
                    for _, _, _, m in cams], float)
    ev = Events(a[:, 0] / 1e6, a[:, 1], a[:, 2], a[:, 3], a[:, 4], a[:, 5], a[:, 6], a[:, 7], "CAMERA_FEEDBACK")
    att, pos = received("ATTITUDE"), received("GLOBAL_POSITION_INT")
    refs = FieldReferences(
        alt=_series([(t, m.alt / 1000.0) for t, _, _, m in pos], "GLOBAL_POSITION_INT altitude"),
        rel_alt=_series([(t, m.relative_alt / 1000.0) for t, _, _, m in pos], "GLOBAL_POSITION_INT relative altitude"),
        roll=_series([(t, math.degrees(m.roll)) for t, _, _, m in att], "ATTITUDE roll"),
        pitch=_series([(t, math.degrees(m.pitch)) for t, _, _, m in att], "ATTITUDE pitch"),
        yaw=_series([(t, math.degrees(m.yaw)) for t, _, _, m in att], "ATTITUDE yaw"), window_s=TLOG_RECEPTION_S)
    ev, skips, ran = _drop_faulty("CAMERA_FEEDBACK", ev, np.array([c[0] for c in cams]), refs,
                                  [(o, ln) for _, o, ln, _ in cams], path.name)
    info = _info(len(data), len(packets), skips, len(skips), ran)
    info["skipped_bytes"] += skipped  # the walker counts bytes, not places
    info["lost_bytes"] = skipped
    return ev, info


def _euler(q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Roll, pitch, yaw (degrees) of PX4 attitude quaternions (rows w, x, y, z)."""
    w, x, y, z = q.T
    roll = np.degrees(np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y)))
    pitch = np.degrees(np.arcsin(np.clip(2 * (w * y - z * x), -1, 1)))
    yaw = np.degrees(np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))
    return roll, pitch, yaw


def from_ulog(path: Path) -> tuple[Events, ReadInfo]:
    """camera_capture topics of a PX4 ULog (pyulog). Each event's altitude and attitude are
    checked (`field_faults`) against the vehicle_global_position and vehicle_attitude topics
    logged around it, where the log has them (its ground distance against physical bounds
    only). pyulog tells no message's place in the file: a dropped event's report has offset
    and length 0."""
    from pyulog import ULog

    try:
        u = ULog(str(path), ["camera_capture", "vehicle_attitude", "vehicle_global_position"])
    except Exception as exc:  # pyulog raises plain exceptions for files it cannot parse
        raise InputError(f"{path.name}: not a readable ULog ({exc})") from None
    topics = {d.name: d.data for d in reversed(u.data_list)}  # the first instance of each
    messages = sum(len(d.data["timestamp"]) for d in u.data_list)
    if "camera_capture" not in topics:
        raise InputError(f"{path.name}: no camera_capture topic in the ULog")
    d = topics["camera_capture"]
    n = len(d["timestamp"])
    q = np.column_stack([d[f"q[{i}]"] for i in range(4)]) if "q[0]" in d else np.full((n, 4), np.nan)
    rel = np.asarray(d.get("ground_distance", np.full(n, np.nan)), float)
    t = np.asarray(d["timestamp"], float) / 1e6
    ev = Events(t, np.asarray(d["lat"], float), np.asarray(d["lon"], float), np.asarray(d["alt"], float), rel, *_euler(q),
                "camera_capture")
    att, pos = topics.get("vehicle_attitude", {}), topics.get("vehicle_global_position", {})
    alt = _series(list(zip(pos["timestamp"] / 1e6, pos["alt"])), "vehicle_global_position altitude") if "alt" in pos else None
    angles: dict[str, Series | None] = {}
    if "q[0]" in att:
        at = att["timestamp"] / 1e6
        q_att = np.column_stack([att[f"q[{i}]"] for i in range(4)]).astype(float)
        angles = {k: _series(list(zip(at, v)), f"vehicle_attitude {k}") for k, v in zip(("roll", "pitch", "yaw"), _euler(q_att))}
    refs = FieldReferences(alt, None, angles.get("roll"), angles.get("pitch"), angles.get("yaw"), above_home=False)
    ev, skips, ran = _drop_faulty("camera_capture", ev, t, refs, [(0, 0)] * n, path.name)
    return ev, _info(path.stat().st_size, messages, skips, len(skips), ran)


#: the flight log kinds by file name suffix
LOG_KINDS = {".bin": "dataflash", ".log": "dataflash", ".tlog": "tlog", ".ulg": "ulog"}


def log_kind(path: Path) -> str:
    """The kind of a flight log (LOG_KINDS) by its file name's suffix; InputError for another."""
    kind = LOG_KINDS.get(path.suffix.lower())
    if kind is None:
        raise InputError(f"{path.name}: unknown log type {path.suffix.lower()!r}; allowed: .bin (DataFlash), .tlog (MAVLink), "
                         ".ulg (PX4 ULog)")
    return kind


def read_events(path: Path) -> tuple[Events, ReadInfo]:
    if not path.exists():
        raise InputError(f"flight log {str(path)!r} does not exist")
    return {"dataflash": from_dataflash, "tlog": from_tlog, "ulog": from_ulog}[log_kind(path)](path)


@dataclass(frozen=True)
class Match:
    station: list[str | None]  # the planned station of each event (None: an extra trigger)
    distance_m: np.ndarray
    missed: list[str]  # planned stations no event was matched to
    extra: list[int]  # event indices matched to no station
    far: list[int]  # matched events farther than the tolerance


@dataclass(frozen=True)
class Aims:
    """Where the camera looked: each planned station's aim and each event's recorded one (a photo flight's
    gimbal), as pitch (−90 straight down) and bearing, both bearings on the same grid; NaN: not recorded."""

    station_pitch_deg: np.ndarray
    station_bearing_deg: np.ndarray
    event_pitch_deg: np.ndarray
    event_bearing_deg: np.ndarray

    @staticmethod
    def _sight(pitch_deg: np.ndarray, bearing_deg: np.ndarray) -> np.ndarray:
        p, b = np.radians(pitch_deg), np.radians(bearing_deg)
        return np.stack([np.cos(p) * np.sin(b), np.cos(p) * np.cos(b), np.sin(p)], axis=-1)

    def nearest(self, event: int, candidates: np.ndarray) -> int:
        """Of the candidate stations (indices), the one whose line of sight lies nearest the event's (the
        first when the event's aim is not recorded)."""
        mine = self._sight(self.event_pitch_deg[event], self.event_bearing_deg[event])
        if not np.isfinite(mine).all():
            return int(candidates[0])
        theirs = self._sight(self.station_pitch_deg[candidates], self.station_bearing_deg[candidates])
        return int(candidates[int(np.argmax(theirs @ mine))])


#: metres within which stations count as one place (the looks of a smart oblique's station share it)
SAME_PLACE_M = 0.05


def match_to_stations(ev: Events, stations: list[dict[str, Any]], tolerance_m: float, window: int = 60,
                      unmatched: np.ndarray | None = None, aims: Aims | None = None) -> Match:
    """Match events to planned stations, both in flight order.

    Each event takes the nearest station among the next `window` not yet matched ones,
    within 3 × tolerance; stations passed over are missed, events with none near are
    extra triggers, as are the events `unmatched` marks (photos on the ground). Order is
    kept, so a photo over a cross-hatch crossing cannot take a station of the other pass.
    Where several stations share the nearest place (the looks of a smart oblique's station)
    and `aims` records where the event's camera looked, it takes the one aimed nearest that:
    a look not photographed is then the station missed, not the place's last.
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
        if j >= hi or (unmatched is not None and unmatched[i]):
            continue
        d = np.hypot(sx[j:hi] - ex[i], sy[j:hi] - ey[i])
        q = int(np.argmin(d))
        if aims is not None:
            q = aims.nearest(i, j + np.flatnonzero(d <= d[q] + SAME_PLACE_M)) - j
        if d[q] <= gap:
            station[i] = stations[j + q]["id"]
            dist[i] = float(d[q])
            matched[j + q] = True
            j = j + q + 1
    missed = [s["id"] for q, s in enumerate(stations) if not matched[q]]
    extra = [q for q in range(len(ex)) if station[q] is None]
    far = [q for q in range(len(ex)) if station[q] is not None and dist[q] > tolerance_m]
    return Match(station, dist, missed, extra, far)
