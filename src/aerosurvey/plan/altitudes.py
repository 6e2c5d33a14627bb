"""Altitudes: station and waypoint heights for the terrain mode (`follow` adds waypoints
where the ground needs them), in the mission's altitude frame.

Following the ground, the vehicle climbs and descends at most at its rates
(`vehicle.climb_rate_ms`, `vehicle.descent_rate_ms`) at the survey speed, as QGroundControl's
TerrainAdjustMaxClimbRate and TerrainAdjustMaxDescentRate limit its survey: where the ground
rises or falls faster, the run climbs earlier and descends later (the lowest profile at or
above the wanted one whose slopes the vehicle can fly), and every run where that takes the
photos more than the terrain tolerance above their height is reported with the figures.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from aerosurvey import ids
from aerosurvey.area import Planar
from aerosurvey.errors import InputError
from aerosurvey.plan.model import Heights, RouteWaypoint, Stations
from aerosurvey.plan.passes import Aim, Route, Run, look_pass
from aerosurvey.plan.terrain import Dem, thin_profile


@dataclass(frozen=True, eq=False)
class Altitudes:
    stations: Stations
    waypoints: tuple[RouteWaypoint, ...]
    frame: str  # "relative" (above home) or "terrain"
    tolerance_m: float  # how far the height above the ground may stray from the one asked between waypoints
    warnings: tuple[str, ...] = ()


@dataclass(frozen=True)
class Slopes:
    """The steepest climb and descent the vehicle flies along a run, in metres a metre flown."""

    climb: float
    descent: float

    @classmethod
    def of(cls, climb_rate_ms: float, descent_rate_ms: float, speed_ms: float) -> Slopes:
        return cls(climb_rate_ms / speed_ms, descent_rate_ms / speed_ms)


def flyable_profile(s: np.ndarray, wanted: np.ndarray, slopes: Slopes) -> np.ndarray:
    """The lowest altitudes at or above `wanted` (at distances `s` along a run, increasing)
    whose slope between any two points stays within +climb and -descent: each point is at
    least as high as every later one less the climb there, and as every earlier one less the
    descent from it (two running maxima; the second pass keeps what the first made)."""
    h = np.maximum.accumulate(wanted + slopes.descent * s) - slopes.descent * s
    out: np.ndarray = np.maximum.accumulate((h - slopes.climb * s)[::-1])[::-1] + slopes.climb * s
    return out


def assign_altitudes(route: Route, heights: Heights, dem: Dem | None, home_ground: float, planar: Planar,
                     tolerance_m: float, slopes: Slopes | None = None, cap_agl_m: float = math.inf,
                     fixed_yaw_deg: float | None = None) -> Altitudes:
    """Stations with ids and altitudes, and the route's waypoints with theirs; in follow mode
    each run's profile within `slopes` (None: as steep as the ground), refused (InputError)
    where that takes a photo above `cap_agl_m`. With `fixed_yaw_deg` (the nose's one true heading)
    a camera that looks along the nose (a run without its own look) faces that yaw, turned into the
    grid at each station."""
    runs = route.runs
    sid = _station_ids(runs)
    # a run shooting several aims at each station (`Run.looks`) has a row for each: station by station, aim by aim
    counts = [len(r.station_index) * len(r.aims) for r in runs]
    xy = np.concatenate([np.repeat(np.asarray(r.station_xy, float).reshape(-1, 2), len(r.aims), axis=0) for r in runs]) \
        if runs else np.zeros((0, 2))
    x, y = xy[:, 0].copy(), xy[:, 1].copy()
    run_idx = np.repeat(np.arange(len(runs)), counts)
    hd = np.concatenate([np.repeat(r.headings(), len(r.aims)) for r in runs]) if runs else np.zeros(0)
    if fixed_yaw_deg is not None and runs:  # a camera looking along the flight looks along the nose
        nose = planar.grid_bearing(np.full(len(x), fixed_yaw_deg), x, y)
        along_nose = np.repeat(np.array([r.aim.look == "along" for r in runs]), counts)
        hd_camera = np.where(along_nose, nose, hd)
    else:
        hd_camera = hd
    look = np.concatenate([_by_aim(r, xy[a:b], hd_camera[a:b], Aim.bearings)
                           for r, a, b in _spans(runs, counts)]) if runs else np.zeros(0)
    rise = np.concatenate([np.repeat(r.rises(), len(r.aims)) for r in runs]) if runs else np.zeros(0)
    ground = dem.sample(x, y, "photo stations") if dem is not None else np.full(len(x), np.nan)
    mode = heights.mode
    warnings: tuple[str, ...] = ()
    if mode == "fixed":
        assert heights.fixed_alt_amsl_m is not None
        alt_rel = heights.fixed_alt_amsl_m - home_ground + rise
        agl = heights.fixed_alt_amsl_m - ground + rise
    elif mode == "follow":
        alt_rel = ground + heights.nominal_agl_m + rise - home_ground
        agl = heights.nominal_agl_m + rise
    else:  # terrain-frame (above terrain) or none
        alt_rel = heights.nominal_agl_m + rise
        agl = alt_rel.copy()
    _stations_under_cap(sid, runs, run_idx, agl, cap_agl_m)
    if mode == "follow" and slopes is not None:
        alt_rel, agl, warnings = _within_slopes(runs, run_idx, x, y, alt_rel, ground, home_ground, slopes, tolerance_m)
        _under_cap(runs, run_idx, agl, cap_agl_m, slopes)
    pitch = np.concatenate([_by_aim(r, xy[a:b], alt_rel[a:b], station_pitches)
                            for r, a, b in _spans(runs, counts)]) if runs else np.zeros(0)
    start_of_run = np.searchsorted(run_idx, np.arange(len(runs)))
    end_of_run = np.searchsorted(run_idx, np.arange(len(runs)), side="right")
    pts: list[tuple[float, float, float, str, int, str]] = []

    def alt_at(px: float, py: float, what: str, i: int) -> float:
        """The altitude at (px, py) of a waypoint flown at station row `i`'s rise (a lead-in at its run's first, a
        line end at its last)."""
        if mode == "follow":
            assert dem is not None
            g = float(dem.sample(np.array([px]), np.array([py]), what)[0])
            return g + heights.nominal_agl_m + float(rise[i]) - home_ground
        if mode == "fixed":
            assert heights.fixed_alt_amsl_m is not None
            return heights.fixed_alt_amsl_m - home_ground + float(rise[i])
        return heights.nominal_agl_m + float(rise[i])

    for w in route.waypoints:
        if w.kind == "line_start":
            a, b = start_of_run[w.run], end_of_run[w.run]
            pts.append((w.x, w.y, float(alt_rel[a]), "line_start", w.run, sid[a]))
            # terrain waypoints on stations and the run's bends (between two stations), in flight order
            inner: list[tuple[float, tuple[float, float, float, str, int, str]]] = []
            if mode == "follow" and b - a > 2:
                s = np.r_[0.0, np.cumsum(np.hypot(np.diff(x[a:b]), np.diff(y[a:b])))]
                keep = thin_profile(s, alt_rel[a:b], tolerance_m)
                inner += [(float(k), (float(x[a + k]), float(y[a + k]), float(alt_rel[a + k]), "terrain", w.run, sid[a + k]))
                          for k in keep[1:-1]]
            if mode == "follow" and b - a > 1:
                inner.append((float(b - 1 - a), (float(x[b - 1]), float(y[b - 1]), float(alt_rel[b - 1]), "terrain", w.run, sid[b - 1])))
            r = runs[w.run]
            for (bx, by), k in zip(r.bends_xy.tolist(), r.bend_after.tolist()):
                i = a + int(k)
                inner.append((k + 0.5, (bx, by, float(max(alt_rel[i], alt_rel[min(i + 1, b - 1)])), "bend", w.run, "")))
            pts += [p for _, p in sorted(inner, key=lambda t: t[0])]
        elif w.kind == "bend":
            continue  # placed with its run's line start
        elif w.kind == "line_end":
            b = end_of_run[w.run]
            end_alt = float(alt_rel[b - 1]) if mode == "follow" else alt_at(w.x, w.y, "line ends", b - 1)
            pts.append((w.x, w.y, end_alt, "line_end", w.run, ""))
        elif w.kind == "lead_in":
            a = start_of_run[w.run]
            pts.append((w.x, w.y, float(alt_rel[a]) if mode == "follow" else alt_at(w.x, w.y, "lead-ins", a), "lead_in", w.run, ""))
        else:
            pts.append((w.x, w.y, math.nan, w.kind, w.run, ""))
    # detours keep the higher of their neighbours' altitudes
    alts = [p[2] for p in pts]
    for i, a_ in enumerate(alts):
        if math.isnan(a_):
            prev = next((alts[j] for j in range(i - 1, -1, -1) if not math.isnan(alts[j])), None)
            nxt = next((alts[j] for j in range(i + 1, len(alts)) if not math.isnan(alts[j])), None)
            alts[i] = max(v for v in (prev, nxt) if v is not None)
    # the stations' and the waypoints' longitudes and latitudes in one transform (point by point alike)
    lon, lat = planar.lonlat(np.concatenate([x, [p[0] for p in pts]]), np.concatenate([y, [p[1] for p in pts]]))
    lon, lat, wlon, wlat = lon[:len(x)].copy(), lat[:len(x)].copy(), lon[len(x):], lat[len(x):]
    stations = Stations(sid, run_idx, x, y, lon, lat, ground, alt_rel, agl, hd, pitch, look)
    wps = tuple(RouteWaypoint(float(p[0]), float(p[1]), float(lo), float(la), float(al), p[3], p[4], p[5])
                for p, lo, la, al in zip(pts, wlon, wlat, alts))
    return Altitudes(stations, wps, "terrain" if mode == "terrain-frame" else "relative", tolerance_m, warnings)


def _station_ids(runs: tuple[Run, ...]) -> list[str]:
    """Each station row's id: a run's own for its first aim, and for each further look the same
    line and station numbers in the look's pass (`passes.look_pass`)."""
    def lines(r: Run) -> list[tuple[int, int, list[int]]]:
        stations = np.asarray(r.station_index, int).tolist()
        if not r.looks:
            return [(r.pass_index, r.line, stations)]
        numbers = [look_pass(runs, r.pass_index, j) for j in range(len(r.aims))]
        return [(p, r.line, [s]) for s in stations for p in numbers]

    return ids.station_ids_of_lines(line for r in runs for line in lines(r))


def _by_aim(run: Run, xy: np.ndarray, values: np.ndarray, of: Callable[[Aim, np.ndarray, np.ndarray], np.ndarray]) -> np.ndarray:
    """A value of each of a run's station rows (`xy` and `values` theirs, station by station, aim
    by aim): `of(aim, xy, values)` over each aim's rows."""
    k = len(run.aims)
    return np.stack([np.asarray(of(aim, xy[j::k], values[j::k]), float) for j, aim in enumerate(run.aims)], axis=1).reshape(-1)


def _spans(runs: tuple[Run, ...], counts: list[int]) -> list[tuple[Run, int, int]]:
    """Each run with the first and past-the-last index of its stations."""
    ends = np.cumsum(counts).tolist()
    return [(r, e - n, e) for r, n, e in zip(runs, counts, ends)]


def station_pitches(aim: Aim, xy: np.ndarray, alt_m: np.ndarray, point_alt_m: float | None = None) -> np.ndarray:
    """The camera's pitch at each place of a run (`xy` (n, 2), `alt_m` their altitudes): the aim's,
    or looking at a point, towards it at `point_alt_m` (None: the height `look_at_height` sets
    from the first place)."""
    if aim.point is None or not len(xy):
        return np.full(len(xy), aim.pitch_deg)
    z = look_at_height(aim, xy[0], float(alt_m[0])) if point_alt_m is None else point_alt_m
    d = np.hypot(*(np.asarray(aim.point, float) - np.asarray(xy, float).reshape(-1, 2)).T)
    out: np.ndarray = np.degrees(np.arctan2(z - np.asarray(alt_m, float), d))
    return out


def look_at_height(aim: Aim, first_xy: np.ndarray, first_alt_m: float) -> float:
    """The altitude (in the stations' frame) of the point an aim looks at: where the ray from a
    run's first station at the aim's pitch meets the point's vertical (the region of interest
    an autopilot is given; it then pitches the camera at every station towards it)."""
    assert aim.point is not None
    d = math.hypot(aim.point[0] - float(first_xy[0]), aim.point[1] - float(first_xy[1]))
    return first_alt_m + d * math.tan(math.radians(aim.pitch_deg))


def _stations_under_cap(sid: list[str], runs: tuple[Run, ...], run_idx: np.ndarray, agl: np.ndarray, cap_agl_m: float) -> None:
    """InputError naming the highest station above `cap_agl_m` (vehicle.max_height_agl_m), its height and its pass's rise."""
    if not len(agl) or not np.nanmax(agl, initial=-math.inf) > cap_agl_m + 1e-6:
        return
    i = int(np.nanargmax(agl))
    r = runs[int(run_idx[i])]
    rise = f" (its pass flies {r.rise_m:g} m above the plan's height)" if r.rise_m else ""
    raise InputError(f"station {sid[i]} would be {agl[i]:.1f} m above ground{rise}, over vehicle.max_height_agl_m = "
                     f"{cap_agl_m:g} m", key="vehicle.max_height_agl_m")


def _under_cap(runs: tuple[Run, ...], run_idx: np.ndarray, agl: np.ndarray, cap_agl_m: float, slopes: Slopes) -> None:
    if not len(agl) or agl.max() <= cap_agl_m + 1e-6:
        return
    i = int(np.argmax(agl))
    r = runs[int(run_idx[i])]
    raise InputError(
        f"terrain: along run {ids.run_id(r.pass_index, r.line, r.part)} the ground rises or falls faster than the vehicle "
        f"climbs ({slopes.climb:.3f} m/m) or descends ({slopes.descent:.3f} m/m) at the survey speed, and following it "
        f"would take the photos to {agl[i]:.1f} m above ground, over the {cap_agl_m:g} m cap (vehicle.max_height_agl_m): "
        "raise vehicle.climb_rate_ms or descent_rate_ms if the vehicle can, lower vehicle.cruise_speed_ms, or leave "
        "this ground out of the area", key="vehicle.climb_rate_ms")


def _within_slopes(runs: tuple[Run, ...], run_idx: np.ndarray, x: np.ndarray, y: np.ndarray, wanted: np.ndarray,
                   ground: np.ndarray, home_ground: float, slopes: Slopes,
                   tolerance_m: float) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """Each run's station altitudes made flyable (`flyable_profile`), their heights above ground,
    and a warning naming the runs flown more than `tolerance_m` above the wanted height."""
    alt = wanted.copy()
    bounds = np.searchsorted(run_idx, np.arange(len(runs) + 1))
    for a, b in zip(bounds[:-1], bounds[1:]):
        if b - a > 1:
            s = np.r_[0.0, np.cumsum(np.hypot(np.diff(x[a:b]), np.diff(y[a:b])))]
            alt[a:b] = flyable_profile(s, wanted[a:b], slopes)
    excess = alt - wanted
    agl = alt + home_ground - ground
    over = np.flatnonzero(excess > tolerance_m)
    if not len(over):
        return alt, agl, ()
    bad_runs = sorted({int(run_idx[i]) for i in over})
    names = [ids.run_id(runs[r].pass_index, runs[r].line, runs[r].part) for r in bad_runs]
    worst = int(over[np.argmax(excess[over])])
    return alt, agl, (
        f"terrain: the ground along {len(bad_runs)} run(s) rises or falls faster than the vehicle climbs "
        f"({slopes.climb:.3f} m/m) or descends ({slopes.descent:.3f} m/m) at the survey speed: their photos are "
        f"taken up to {excess[worst]:.1f} m above the wanted height ({agl[worst]:.1f} m above ground), more than the "
        f"terrain tolerance of {tolerance_m:g} m; runs "
        f"{', '.join(names[:8])}{' …' if len(names) > 8 else ''} (raise vehicle.climb_rate_ms or descent_rate_ms if the "
        "vehicle can, or slow down)",)
