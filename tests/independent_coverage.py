"""An independent coverage check: from the exported QGC WPL file only.

It does not use the planner's spacing, stations or CRS. It parses `mission.waypoints`
itself, replays ArduPilot's distance trigger along the waypoints (a picture at once when
DO_SET_CAM_TRIGG_DIST has param3 = 1, then one at the first 50 Hz check, at the
DO_CHANGE_SPEED ground speed, where the vehicle has moved the trigger distance from the
last picture, as AP_Camera does; none after the distance is set to 0), builds each
photo's footprint from the camera's sensor and the height above ground, in a local
azimuthal equidistant projection centred on the area, and measures coverage on a grid.
The trigger distance and the speed are ArduPilot's metres (its flat earth,
`ardupilot_location`): along each leg they are turned into ground metres by the
leg's own ratio of the two.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyproj
import shapely

from ardupilot_location import metres_per_ground_metre

NAV_WAYPOINT, DO_CHANGE_SPEED, DO_SET_CAM_TRIGG_DIST, DO_SET_CAM_TRIGG_INTERVAL = 16, 178, 206, 214
FRAME_RELATIVE, FRAME_TERRAIN = 3, 10


@dataclass
class Photos:
    x: np.ndarray
    y: np.ndarray
    heading: np.ndarray  # radians, direction of flight (math angle from +x)
    agl: np.ndarray
    run: np.ndarray  # index of the trigger-on block


def read_wpl(path: Path) -> tuple[tuple[float, float, float], list[list[float]]]:
    lines = path.read_text().splitlines()
    assert lines[0].strip() == "QGC WPL 110", lines[0]
    rows = [[float(v) for v in ln.split("\t")] for ln in lines[1:] if ln.strip()]
    home = rows[0]
    return (home[9], home[8], home[10]), rows[1:]


def local_projection(lon: float, lat: float) -> pyproj.Transformer:
    aeqd = pyproj.CRS.from_proj4(f"+proj=aeqd +lat_0={lat} +lon_0={lon} +datum=WGS84 +units=m")
    return pyproj.Transformer.from_crs("EPSG:4326", aeqd, always_xy=True)


def replay_triggers(rows: list[list[float]], to_xy: pyproj.Transformer,
                    ground: Callable[[np.ndarray, np.ndarray], np.ndarray] | None,
                    home_amsl: float, camera_interval_s: float | None = None) -> Photos:
    """Photo positions as ArduPilot's distance trigger takes them along the mission.

    Time triggering (DO_SET_CAM_TRIGG_INTERVAL, or a camera on its own intervalometer
    when `camera_interval_s` is given) is replayed as a photo every speed × interval
    metres at the DO_CHANGE_SPEED ground speed; a camera on its own intervalometer runs
    from the first waypoint to the last, and its runs split where the heading changes.
    """
    xs, ys, hs, zs, runs = [], [], [], [], []
    pos = None
    lat_lon = (0.0, 0.0)
    alt_prev = None
    frame_prev = FRAME_RELATIVE
    dist = 0.0
    last = None
    run = -1
    speed = 0.0
    prev_dir = None
    phase = 0.0
    time_trigger = camera_interval_s is not None
    pending: list[int] = []  # pictures taken at a waypoint: they fly the heading of the next leg
    for r in rows:
        cmd, frame = int(r[3]), int(r[2])
        if cmd == DO_CHANGE_SPEED:
            speed = r[5]
        elif cmd == DO_SET_CAM_TRIGG_INTERVAL:
            time_trigger = True
            dist = speed * r[4] / 1000.0 if r[4] > 0 else 0.0
            if dist > 0:
                run += 1
                last = pos.copy()
                xs.append(pos[0])
                ys.append(pos[1])
                hs.append(None)
                zs.append((alt_prev, frame_prev))
                runs.append(run)
            else:
                last = None
        if cmd == NAV_WAYPOINT:
            x, y = to_xy.transform(r[9], r[8])
            new = np.array([x, y])
            if camera_interval_s is not None and pos is not None:
                d = math.atan2(new[1] - pos[1], new[0] - pos[0])
                if last is None:
                    dist = speed * camera_interval_s
                    run += 1
                    last = pos.copy()
                    xs.append(pos[0])
                    ys.append(pos[1])
                    hs.append(None)
                    zs.append((alt_prev, frame_prev))
                    runs.append(run)
                elif prev_dir is not None and (abs(math.sin(d - prev_dir)) > 1e-3 or math.cos(d - prev_dir) < 0):
                    run += 1
                prev_dir = d
            if pos is not None and pending and float(np.hypot(*(new - pos))) > 0:
                for i in pending:
                    hs[i] = math.atan2(new[1] - pos[1], new[0] - pos[0])
                pending = []
            if pos is not None and dist > 0 and last is not None:
                leg = new - pos
                length = float(np.hypot(*leg))
                if length > 0:
                    u = leg / length
                    # ArduPilot's metres per ground metre along this leg
                    scale = metres_per_ground_metre(lat_lon[0], lat_lon[1], r[8], r[9], length)
                    if time_trigger:
                        ts = _crossings(pos, u, length, last, dist / scale)
                    else:
                        # ArduPilot checks the distance at 50 Hz: samples every v/50 of its metres along the path
                        step = speed / 50.0 if speed > 0 else 0.1
                        length_ap = length * scale
                        first = (step - phase) % step
                        samples = first + step * np.arange(int(max(length_ap - first, 0) // step) + 1)
                        samples = samples[samples <= length_ap + 1e-9]
                        phase = ((length_ap - (samples[-1] if len(samples) else -phase)) % step if len(samples)
                                 else (phase + length_ap) % step)
                        ts = []
                        lx, ly = last
                        for t in samples / scale:
                            p = pos + u * t
                            if math.hypot(p[0] - lx, p[1] - ly) * scale >= dist:
                                ts.append(float(t))
                                lx, ly = p
                    for t in ts:
                        p = pos + u * t
                        alt = alt_prev + (r[10] - alt_prev) * (t / length)
                        xs.append(p[0])
                        ys.append(p[1])
                        hs.append(math.atan2(u[1], u[0]))
                        zs.append((alt, frame))
                        runs.append(run)
                        last = p
            alt_prev = r[10]
            frame_prev = frame
            pos = new
            lat_lon = (r[8], r[9])
        elif cmd == DO_SET_CAM_TRIGG_DIST:
            dist = r[4]
            if dist > 0:
                run += 1
                last = pos.copy()
                if r[6] == 1:
                    # picture now; its heading is that of the next leg, found above at the next waypoint
                    pending.append(len(xs))
                    xs.append(pos[0])
                    ys.append(pos[1])
                    hs.append(None)
                    zs.append((alt_prev, frame_prev))
                    runs.append(run)
            else:
                last = None
    x, y = np.asarray(xs), np.asarray(ys)
    run_arr = np.asarray(runs)
    heading = np.asarray([np.nan if h is None else h for h in hs])
    # the at-once picture flies the heading of its run
    for i in np.flatnonzero(np.isnan(heading)):
        same = np.flatnonzero((run_arr == run_arr[i]) & ~np.isnan(heading))
        heading[i] = heading[same[0]] if len(same) else 0.0
    alt = np.asarray([z[0] for z in zs])
    frames = np.asarray([z[1] for z in zs])
    if ground is not None:
        g = ground(x, y)
        agl = np.where(frames == FRAME_TERRAIN, alt, alt + home_amsl - g)
    else:
        agl = alt
    return Photos(x, y, heading, agl, run_arr)


def _crossings(pos: np.ndarray, u: np.ndarray, length: float, last: np.ndarray, dist: float) -> list[float]:
    """Positions along a leg where the distance from the last photo reaches `dist` (continuous)."""
    out = []
    t = 0.0
    last = np.asarray(last, float)
    while True:
        w = pos + u * t - last
        b = float(np.dot(w, u))
        c = float(np.dot(w, w)) - dist * dist
        s = -b + math.sqrt(max(b * b - c, 0.0))
        if t + s > length - 1e-9:
            return out
        t += s
        out.append(t)
        last = pos + u * t


def footprint_counts(ph: Photos, px: np.ndarray, py: np.ndarray, sensor: tuple[float, float, int, int, float], mount: str) -> np.ndarray:
    """How many photos see each sample point (nadir, footprint from sensor and AGL)."""
    sw, sh, nw, nh, f = sensor
    long_ = sw / f * ph.agl
    short = sh / f * ph.agl
    across, along = (long_, short) if mount == "landscape" else (short, long_)
    counts = np.zeros(len(px), int)
    for i in range(len(ph.x)):
        dx, dy = px - ph.x[i], py - ph.y[i]
        c, s = math.cos(ph.heading[i]), math.sin(ph.heading[i])
        u = dx * c + dy * s
        v = -dx * s + dy * c
        counts += (np.abs(u) <= along[i] / 2 + 1e-6) & (np.abs(v) <= across[i] / 2 + 1e-6)
    return counts


def grid_inside(geom: shapely.Geometry, n: int = 60) -> tuple[np.ndarray, np.ndarray]:
    x0, y0, x1, y1 = geom.bounds
    step = max(x1 - x0, y1 - y0) / n
    gx, gy = np.meshgrid(np.arange(x0 + step / 2, x1, step), np.arange(y0 + step / 2, y1, step))
    gx, gy = gx.ravel(), gy.ravel()
    inside = shapely.contains_xy(geom, gx, gy)
    return gx[inside], gy[inside]


def realized_overlaps(ph: Photos, sensor, mount: str) -> tuple[float, float]:
    """(min forward overlap between consecutive photos of a run, min side overlap between
    neighbouring parallel runs), from the photo positions alone."""
    sw, sh, nw, nh, f = sensor
    fwd = []
    runs = {}
    for r in np.unique(ph.run):
        idx = np.flatnonzero(ph.run == r)
        runs[r] = idx
        for a, b in zip(idx[:-1], idx[1:]):
            d = math.hypot(ph.x[b] - ph.x[a], ph.y[b] - ph.y[a])
            agl = min(ph.agl[a], ph.agl[b])
            along = (sh if mount == "landscape" else sw) / f * agl
            fwd.append(1 - d / along)
    side = []
    keys = list(runs)
    for r in keys:
        ia = runs[r]
        h = ph.heading[ia[0]]
        c, s = math.cos(h), math.sin(h)
        best = None
        for q in keys:
            if q == r:
                continue
            ib = runs[q]
            hq = ph.heading[ib[0]]
            if abs(math.sin(hq - h)) > 1e-3:
                continue
            # perpendicular offset and along-track overlap of the two runs
            ua = ph.x[ia] * c + ph.y[ia] * s
            ub = ph.x[ib] * c + ph.y[ib] * s
            if ub.max() < ua.min() or ub.min() > ua.max():
                continue
            va = float(np.mean(-ph.x[ia] * s + ph.y[ia] * c))
            vb = float(np.mean(-ph.x[ib] * s + ph.y[ib] * c))
            d = abs(vb - va)
            if d < 1e-6:
                continue
            if best is None or d < best[0]:
                best = (d, float(min(ph.agl[ia].min(), ph.agl[ib].min())))
        if best is not None:
            across = (sw if mount == "landscape" else sh) / f * best[1]
            side.append(1 - best[0] / across)
    return (min(fwd) if fwd else math.nan, min(side) if side else math.nan)
