"""Altitudes: station and waypoint heights for the terrain mode (`follow` adds waypoints
where the ground needs them), in the mission's altitude frame."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from aerosurvey import ids
from aerosurvey.area import Planar
from aerosurvey.plan.model import Heights, RouteWaypoint, Stations
from aerosurvey.plan.route import Route
from aerosurvey.plan.terrain import Dem, thin_profile


@dataclass(frozen=True, eq=False)
class Altitudes:
    stations: Stations
    waypoints: tuple[RouteWaypoint, ...]
    frame: str  # "relative" (above home) or "terrain"


def assign_altitudes(route: Route, heights: Heights, dem: Dem | None, home_ground: float, planar: Planar,
                     tolerance_m: float) -> Altitudes:
    """Stations with ids and altitudes, and the route's waypoints with theirs."""
    runs = route.runs
    sid = ids.station_ids_of_lines((r.pass_index, r.line, np.asarray(r.station_index, int).tolist()) for r in runs)
    counts = [len(r.station_index) for r in runs]
    xy = np.concatenate([np.asarray(r.station_xy, float).reshape(-1, 2) for r in runs]) if runs else np.zeros((0, 2))
    x, y = xy[:, 0].copy(), xy[:, 1].copy()
    run_idx = np.repeat(np.arange(len(runs)), counts)
    hd = np.repeat(np.asarray([r.heading_deg for r in runs], float), counts)
    ground = dem.sample(x, y, "photo stations") if dem is not None else np.full(len(x), np.nan)
    mode = heights.mode
    if mode == "fixed":
        assert heights.fixed_alt_amsl_m is not None
        alt_rel = np.full(len(x), heights.fixed_alt_amsl_m - home_ground)
        agl = heights.fixed_alt_amsl_m - ground
    elif mode == "follow":
        alt_rel = ground + heights.nominal_agl_m - home_ground
        agl = np.full(len(x), heights.nominal_agl_m)
    else:  # terrain-frame (above terrain) or none
        alt_rel = np.full(len(x), heights.nominal_agl_m)
        agl = np.full(len(x), heights.nominal_agl_m)
    start_of_run = np.searchsorted(run_idx, np.arange(len(runs)))
    end_of_run = np.searchsorted(run_idx, np.arange(len(runs)), side="right")
    pts: list[tuple[float, float, float, str, int, str]] = []

    def alt_at(px: float, py: float, what: str) -> float:
        if mode == "follow":
            assert dem is not None
            g = float(dem.sample(np.array([px]), np.array([py]), what)[0])
            return g + heights.nominal_agl_m - home_ground
        if mode == "fixed":
            assert heights.fixed_alt_amsl_m is not None
            return heights.fixed_alt_amsl_m - home_ground
        return heights.nominal_agl_m

    for w in route.waypoints:
        if w.kind == "line_start":
            a, b = start_of_run[w.run], end_of_run[w.run]
            pts.append((w.x, w.y, float(alt_rel[a]), "line_start", w.run, sid[a]))
            if mode == "follow" and b - a > 2:
                s = np.hypot(x[a:b] - x[a], y[a:b] - y[a])
                keep = thin_profile(s, alt_rel[a:b], tolerance_m)
                for k in keep[1:-1]:
                    pts.append((float(x[a + k]), float(y[a + k]), float(alt_rel[a + k]), "terrain", w.run, sid[a + k]))
            if mode == "follow" and b - a > 1:
                pts.append((float(x[b - 1]), float(y[b - 1]), float(alt_rel[b - 1]), "terrain", w.run, sid[b - 1]))
        elif w.kind == "line_end":
            b = end_of_run[w.run]
            pts.append((w.x, w.y, float(alt_rel[b - 1]) if mode == "follow" else alt_at(w.x, w.y, "line ends"), "line_end", w.run, ""))
        elif w.kind == "lead_in":
            a = start_of_run[w.run]
            pts.append((w.x, w.y, float(alt_rel[a]) if mode == "follow" else alt_at(w.x, w.y, "lead-ins"), "lead_in", w.run, ""))
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
    stations = Stations(sid, run_idx, x, y, lon, lat, ground, alt_rel, agl, hd)
    wps = tuple(RouteWaypoint(float(p[0]), float(p[1]), float(lo), float(la), float(al), p[3], p[4], p[5])
                for p, lo, la, al in zip(pts, wlon, wlat, alts))
    return Altitudes(stations, wps, "terrain" if mode == "terrain-frame" else "relative")
