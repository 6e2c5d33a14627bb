"""Estimates: distances and times of the whole mission, and the sun over the planned window."""

from __future__ import annotations

from typing import Any

import numpy as np

from aerosurvey.plan.flight_time import (
    Climbs,
    Kinematics,
    descent_time,
    hover_time,
    lanes_in_place,
    path_time,
    plane_transit_time,
)
from aerosurvey.plan.landing import way_home
from aerosurvey.plan.model import Heights, RouteWaypoint, Stations
from aerosurvey.plan.passes import Route, aims_per_place
from aerosurvey.plan.sun import elevation_over_window
from aerosurvey.spec import MissionSpec


def estimate(spec: MissionSpec, route: Route, wps: tuple[RouteWaypoint, ...], stations: Stations, kin: Kinematics,
             home_xy: tuple[float, float], end_xy: tuple[float, float], heights: Heights, base: float, lead: float,
             k: float, hover_s: float | None = None, hover_look_s: float = 0.0) -> dict[str, float]:
    """Distances and times on the ground (grid lengths divided by the scale factor k), each leg at
    its ground speed in the wind of `kin` (planner.in_wind); the way home to `end_xy` (a landing plane's
    approach waypoint, else the launch point) and on to the touchdown, as each sortie's (`landing.way_home`); with
    hover-and-capture (`hover_s` at rest at each place, `hover_look_s` at each further aim there) the stops
    at the stations too, the first of each run after its `lead`-metre lead-in."""
    home = (home_xy[0] / k, home_xy[1] / k)
    # the detours from home and back home fly at transit speed, like the straight legs
    n_out = next((i for i, w in enumerate(wps) if w.kind != "transit"), len(wps))
    n_back = next((i for i, w in enumerate(reversed(wps)) if w.kind != "transit"), 0)
    xy = np.asarray([(w.x, w.y) for w in wps]) / k
    pts = xy[n_out: len(xy) - n_back]
    leg_out = np.vstack([[home], xy[: n_out + 1]])
    via = [(float(x), float(y)) for x, y in xy[len(xy) - n_back:]]
    leg_back = np.vstack([xy[len(xy) - n_back - 1], *way_home(via, (end_xy[0] / k, end_xy[1] / k), home)])
    survey_len = float(np.hypot(*np.diff(pts, axis=0).T).sum()) if len(pts) > 1 else 0.0
    survey_time = path_time(pts, kin)
    if hover_s is not None:
        rises, arrivals = lanes_in_place(stations.x, stations.y, stations.alt_rel_m, stations.run, k)
        survey_time += hover_time(len(stations.ids), len(route.runs), base, lead, hover_s, kin, aims_per_place(route.runs),
                                  hover_look_s, rises, Climbs(spec.vehicle.climb_rate_ms, spec.vehicle.descent_rate_ms),
                                  arrivals)
    transit_out = float(np.hypot(*np.diff(leg_out, axis=0).T).sum())
    transit_back = float(np.hypot(*np.diff(leg_back, axis=0).T).sum())
    climb = float(np.max(stations.alt_rel_m)) if len(stations.alt_rel_m) else heights.nominal_agl_m
    v = spec.vehicle
    if kin.vehicle == "plane":  # a plane climbs and descends while it flies to and from the survey
        t_out, t_back, t_climb, t_descent = plane_transit_time(leg_out, leg_back, climb, v.climb_rate_ms,
                                                               v.cruise_speed_ms, v.descent_rate_ms, kin,
                                                               v.landing_speed_ms if end_xy != home_xy else None)
    else:
        transit_kin = kin.cruising(v.cruise_speed_ms)
        t_out, t_back = path_time(leg_out, transit_kin), path_time(leg_back, transit_kin)
        t_climb, t_descent = climb / v.climb_rate_ms, descent_time(climb, v.descent_rate_ms, v.type)
    photo_len = float(sum((r.station_xy.shape[0] - 1) * base for r in route.runs))
    return {
        "survey_distance_m": round(survey_len, 1),
        "photo_line_length_m": round(photo_len, 1),
        "transit_distance_m": round(transit_out + transit_back, 1),
        "total_distance_m": round(survey_len + transit_out + transit_back, 1),
        "survey_time_s": round(survey_time, 1),
        "climb_time_s": round(t_climb, 1),
        "transit_time_s": round(t_out + t_back, 1),
        "descent_time_s": round(t_descent, 1),
        "total_time_s": round(survey_time + t_climb + t_descent + t_out + t_back, 1),
        "photos": float(len(stations.ids)),
    }


def sun_over_window(spec: MissionSpec, lon: float, lat: float) -> tuple[dict[str, Any] | None, tuple[str, ...]]:
    """The sun's elevation over `conditions.start`..`end` at the launch point, and a warning when it is low."""
    c = spec.conditions
    if c.start is None or c.end is None:
        return None, ()
    samples = elevation_over_window(lon, lat, c.start, c.end)
    elev = [e for _, e in samples]
    sun = {
        "start": c.start.isoformat(),
        "end": c.end.isoformat(),
        "min_elevation_deg": round(min(elev), 2),
        "max_elevation_deg": round(max(elev), 2),
        "threshold_deg": c.min_sun_elevation_deg,
        "samples": [[t.isoformat(), round(e, 2)] for t, e in samples],
    }
    if min(elev) >= c.min_sun_elevation_deg:
        return sun, ()
    low = [t.isoformat() for t, e in samples if e < c.min_sun_elevation_deg]
    return sun, (f"sun elevation drops to {min(elev):.1f}° (below conditions.min_sun_elevation_deg = "
                 f"{c.min_sun_elevation_deg:g}°) between {low[0]} and {low[-1]}: long shadows hurt image matching",)
