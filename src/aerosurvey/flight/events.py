"""Camera events from flight logs, and their match to the planned photo stations."""

from __future__ import annotations

import bisect
import functools
import math
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
        w = min(51, len(gt) - (len(gt) + 1) % 2)
        core = np.median(np.lib.stride_tricks.sliding_window_view(gt - gps_s, w), axis=1)
        return np.asarray(gps_s + np.r_[np.full(w // 2, core[0]), core, np.full(w // 2, core[-1])])  # ends: first, last w


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
    rows = np.unique(np.column_stack([t, lat, lon, week, ms])[ok], axis=0)  # in time order, repeats once
    rows = rows[~_damaged_fixes(rows, clock)]
    return _Track(rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3] if clock else None, rows[:, 4] if clock else None)


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


def _on_track(t: np.ndarray, lat: np.ndarray, lon: np.ndarray, track: _Track) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(the event's time minus the time the GPS track passed its place, its distance from the
    track (m), the track's speed there (m/s)) of each event: its position projected on the
    nearest segment between two fixes within LAG_WINDOW_S of its time; NaN where there is none,
    where the nearest point is a segment's end (the event lies beyond it: the track's end, a
    gap), or where the segment spans a gap in the fixes (more than 2.5 periods of the GPS:
    damage took the fixes between)."""
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
        if b <= a:
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
        if not np.isfinite(d[k]) or u[k] in (0.0, 1.0):  # beyond the segment: a gap, or the track's end
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


def from_dataflash(path: Path) -> tuple[Events, ReadInfo]:
    """CAM messages (or TRIG when no CAM was logged) of an ArduPilot DataFlash log, checked.

    Kept: one copy of every event. A copied chunk of the log repeats messages byte for byte
    (every message carries a time stamp, so no two real ones are equal), before, after or
    overlapping its source; of the copies, the one that fits the time order of the others is
    kept and the rest are reported as repeats. Dropped, each with its place and reason in the
    report, events whose own fields disagree with the log: no position on the globe; a time
    outside the span of the log's GPS messages; farther than EVENT_TRACK_M from every GPS fix
    logged within EVENT_WINDOW_S; a boot time outside the span of the GPS fix its own GPS time
    names; a time or a place off the GPS track beyond the log's own spread (`_on_track`); a time
    that breaks the order of the others (the fewest are dropped that leave the times strictly
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
    if track is not None:
        checks = f"GPS track ({len(track.t)} fixes), time order"
        tcheck = time_s if np.isfinite(time_s).all() else np.full(n, np.nan)
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
    ev = Events(time_s[k], lat[k], lon[k], get("Alt")[k], get("RelAlt")[k], get("R", "Roll")[k], get("P", "Pitch")[k],
                get("Y", "Yaw")[k], source, utc[k] if utc is not None else None)
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


def _tlog_packets(data: bytes, mav: Any) -> tuple[list[Any], int]:
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


def from_tlog(path: Path) -> tuple[Events, ReadInfo]:
    """CAMERA_FEEDBACK messages of a MAVLink telemetry log; damage costs only what it touches."""
    from pymavlink.dialects.v20 import ardupilotmega as mavlink

    data = path.read_bytes()
    msgs, skipped = _tlog_packets(data, mavlink.MAVLink(None))
    rows = [(m.time_usec, m.lat * 1e-7, m.lng * 1e-7, m.alt_msl, m.alt_rel, m.roll, m.pitch, m.yaw)
            for m in msgs if m.get_type() == "CAMERA_FEEDBACK"]
    info = _info(len(data), len(msgs), [], 0, "none")
    info["skipped_bytes"] = info["lost_bytes"] = skipped  # the walker counts bytes, not places
    if not rows:
        raise InputError(f"{path.name}: no CAMERA_FEEDBACK messages in the telemetry log ({len(msgs)} messages read)")
    a = np.asarray(rows, float)
    a = a[np.argsort(a[:, 0], kind="stable")]
    return Events(a[:, 0] / 1e6, a[:, 1], a[:, 2], a[:, 3], a[:, 4], a[:, 5], a[:, 6], a[:, 7], "CAMERA_FEEDBACK"), info


def from_ulog(path: Path) -> tuple[Events, ReadInfo]:
    """camera_capture topics of a PX4 ULog (pyulog)."""
    from pyulog import ULog

    try:
        u = ULog(str(path), ["camera_capture"])
    except Exception as exc:  # pyulog raises plain exceptions for files it cannot parse
        raise InputError(f"{path.name}: not a readable ULog ({exc})") from None
    data = [d for d in u.data_list if d.name == "camera_capture"]
    info = _info(path.stat().st_size, sum(len(d.data["timestamp"]) for d in data), [], 0, "none")
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


def match_to_stations(ev: Events, stations: list[dict[str, Any]], tolerance_m: float, window: int = 60,
                      unmatched: np.ndarray | None = None) -> Match:
    """Match events to planned stations, both in flight order.

    Each event takes the nearest station among the next `window` not yet matched ones,
    within 3 × tolerance; stations passed over are missed, events with none near are
    extra triggers, as are the events `unmatched` marks (photos on the ground). Order is
    kept, so a photo over a cross-hatch crossing cannot take a station of the other pass.
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
        if d[q] <= gap:
            station[i] = stations[j + q]["id"]
            dist[i] = float(d[q])
            matched[j + q] = True
            j = j + q + 1
    missed = [s["id"] for q, s in enumerate(stations) if not matched[q]]
    extra = [q for q in range(len(ex)) if station[q] is None]
    far = [q for q in range(len(ex)) if station[q] is not None and dist[q] > tolerance_m]
    return Match(station, dist, missed, extra, far)
