"""Route step: order the passes' runs, join them with detours around the zones, and fix
where the flight starts (the launch point given, else the area's edge nearest the first
waypoint)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.errors import InputError
from aerosurvey.plan.detours import Detours, approach_way
from aerosurvey.plan.flight_time import PlaneTakeoff, descent_time
from aerosurvey.plan.landing import (
    PLANE_TAKEOFF_PITCH_DEG,
    Landing,
    climb_out_m,
    home_clearance_m,
    lands_with_approach,
)
from aerosurvey.plan.passes import Route
from aerosurvey.plan.pattern import Layout
from aerosurvey.plan.progress import Progress, no_progress
from aerosurvey.plan.route import Transits, build_route
from aerosurvey.plan.sensor import SensorSolution
from aerosurvey.plan.site import Site
from aerosurvey.spec import MissionSpec


@dataclass(frozen=True, eq=False)
class RoutePlan:
    route: Route
    home_xy: tuple[float, float]  # planning CRS
    launch_given: bool
    detours: Detours
    transit_out: tuple[tuple[float, float], ...]  # detour corners from home to the first waypoint
    transit_back: tuple[tuple[float, float], ...]  # from the last waypoint home
    end_xy: tuple[float, float]  # where the way home ends: a landing plane's approach waypoint, else home_xy


def default_home(site: Site, first: tuple[float, float], clearance: float = 0.0,
                 obstacle: BaseGeometry | None = None) -> tuple[float, float]:
    """No launch point given: the area's edge nearest the first waypoint, `clearance` and a
    metre more outside every zone's margin and a metre outside `obstacle` (what a pattern's
    structure keeps the ways off, `Layout.obstacle`); where those take the whole edge, the
    nearest such place around the area (`launch_places`)."""
    return nearest(launch_places(site, clearance, obstacle), first)


def nearest(places: BaseGeometry, xy: tuple[float, float]) -> tuple[float, float]:
    near = shapely.get_point(shapely.shortest_line(places, shapely.Point(xy)), 0)
    return (float(near.x), float(near.y))


def launch_places(site: Site, clearance: float = 0.0, obstacle: BaseGeometry | None = None) -> BaseGeometry:
    """Where `default_home` may put the launch point (see there)."""
    area = site.area
    edge = area.exterior if area.geom_type == "Polygon" else area.boundary
    parts = [] if site.zones_buffered is None else [shapely.buffer(site.zones_buffered, clearance + 1.0, quad_segs=4)]
    parts += [] if obstacle is None else [shapely.buffer(obstacle, 1.0, quad_segs=4)]
    if not parts:
        allowed = edge
    else:
        keep_out = shapely.union_all(parts)
        allowed = shapely.difference(edge, keep_out)
        if allowed.is_empty:
            allowed = shapely.difference(shapely.buffer(area, 3.0 * clearance + 200.0, quad_segs=4), keep_out)
            if allowed.is_empty:
                raise InputError("no launch point can be found outside the exclusion zones and their margins near the area: "
                                 "give area.launch", key="area.launch")
    return allowed


def climb_out(spec: MissionSpec, site: Site, sensor: SensorSolution, detours: Detours, home: tuple[float, float],
              lead: tuple[float, float], first: tuple[float, float]) -> list[tuple[float, float]]:
    """Waypoints from the launch point to the survey's first line (its lead-in `lead`, its first station `first`):
    the detours round the zones, for a plane whose straight climb (at its take-off pitch) would end past the lead-in
    a first waypoint where the climb ends, in the clear direction nearest the way to the survey, and for a plane
    that would meet the lead-in heading away from the line a point behind it on the line (`approach_way`)."""
    climb = climb_out_m(spec, sensor.heights.max_agl_m) * site.grid_scale
    try:
        v = spec.vehicle
        takeoff = PlaneTakeoff(sensor.kinematics, sensor.heights.max_agl_m, v.climb_rate_ms, v.cruise_speed_ms, site.grid_scale)
        return approach_way(home, lead, first, climb, takeoff, detours)
    except ValueError:
        raise InputError("a plane taking off at the launch point climbs into an exclusion zone whichever way it heads "
                         f"({climb / site.grid_scale:.0f} m at {PLANE_TAKEOFF_PITCH_DEG:g}° to the survey height): give "
                         "area.launch farther from the zones", key="area.launch") from None


def end_of_flight(landing: Landing, site: Site, home: tuple[float, float]) -> tuple[float, float]:
    """Where the way home ends: a landing plane's approach waypoint, else the launch point."""
    if landing.approach_m is None:
        return home
    lon, lat = site.planar.lonlat(np.array([home[0]]), np.array([home[1]]))
    alon, alat = landing.approach_lonlat(float(lon[0]), float(lat[0]))
    ax, ay = site.planar.xy(np.array([alon]), np.array([alat]))
    return (float(ax[0]), float(ay[0]))


def check_launch(spec: MissionSpec, site: Site, home: tuple[float, float], what: str, key: str) -> None:
    """A launch point inside a zone's margin, too near one for a plane's loiter, or whose
    landing approach crosses one, is refused with the nearest valid place on the area's edge."""
    if site.zones_buffered is None:
        return
    clearance = home_clearance_m(spec) * site.grid_scale
    d = shapely.distance(site.zones_buffered, shapely.Point(home))
    problem = None
    if d <= 0:
        problem = f"lies inside an exclusion zone (or its {spec.flight.exclusion_margin_m:g} m margin)"
    elif d < clearance:
        problem = (f"lies {d / site.grid_scale:.0f} m from an exclusion zone's margin, inside the {home_clearance_m(spec):g} m "
                   "a plane circles home at after RTL (ArduPlane WP_LOITER_RAD)")
    elif lands_with_approach(spec):
        approach = end_of_flight(Landing.of(spec), site, home)
        if shapely.intersects(site.zones_buffered, shapely.LineString([approach, home])):
            problem = (f"has its landing approach (flight.approach_m = {spec.flight.approach_m:g} m into flight.wind_from_deg = "
                       f"{spec.flight.wind_from_deg:g}) across an exclusion zone or its margin; change the approach, the wind "
                       "or the launch point, or end with flight.end = 'rtl'")
    if problem is None:
        return
    ok = default_home(site, home, clearance)
    lon, lat = site.planar.lonlat(np.array([ok[0]]), np.array([ok[1]]))
    raise InputError(f"{what} {problem}; the nearest valid launch point on the area's edge is "
                     f"[{float(lon[0]):.6f}, {float(lat[0]):.6f}]", key=key)


def plan_route(spec: MissionSpec, site: Site, sensor: SensorSolution, layout: Layout,
               report: Progress = no_progress) -> RoutePlan:
    k = site.grid_scale
    launch_xy = None
    if spec.area.launch is not None:
        lx, ly = site.planar.xy(np.array([spec.area.launch[0]]), np.array([spec.area.launch[1]]))
        launch_xy = (float(lx[0]), float(ly[0]))
        check_launch(spec, site, launch_xy, f"area.launch = {list(spec.area.launch)}", "area.launch")
    zones = Detours(site.zones, spec.flight.exclusion_margin_m)
    # the ways from and back to the launch point go round the zones and the structure the pattern flies round
    transit = zones if layout.obstacle is None else \
        Detours(shapely.union_all([g for g in (zones.blocked, layout.obstacle) if g is not None]), 0.0)
    # where the runs keep off that structure (an orbit's rings, cut into pieces by the zones too), so do the ways the
    # route lays between them (a straight join of two pieces of a ring crossed it); a quarry's upper lanes lie over
    # its lower faces in plan, and their joins go round the zones only
    runs_clear = not any(shapely.intersects(layout.obstacle, shapely.LineString(s.path))
                         for p in layout.passes for s in p.strips if len(s.path) > 1) if layout.obstacle is not None else True
    detours = transit if runs_clear else zones
    numbers = sorted(p.index for p in layout.passes if not p.empty)
    starts = {}
    for n, (lon, lat) in spec.flight.pass_start:
        if n not in numbers:
            raise InputError(f"flight.pass_start.{n} = {[lon, lat]} is not allowed: the plan has pass "
                             f"{', '.join(map(str, numbers))}", key="flight.pass_start")
        sx, sy = site.planar.xy(np.array([lon]), np.array([lat]))
        starts[n] = (float(sx[0]), float(sy[0]))
    landing = Landing.of(spec)
    places = launch_xy if launch_xy is not None else launch_places(site, home_clearance_m(spec) * k, layout.obstacle)

    def home_from(first: tuple[float, float]) -> tuple[float, float]:  # where the way home of a flight from `first` ends
        return end_of_flight(landing, site, places if isinstance(places, tuple) else nearest(places, first))

    kin, v, climb = sensor.kinematics, spec.vehicle, sensor.heights.max_agl_m
    plane = kin.vehicle == "plane"  # a plane climbs and descends on its ways out and home (estimates.estimate)
    transits = Transits(kin.cruising(v.cruise_speed_ms), home_from, climb if plane else 0.0, v.climb_rate_ms,
                        v.cruise_speed_ms, descent_time(climb, v.descent_rate_ms, kin.vehicle) if plane else 0.0,
                        climb_out_m(spec, climb) * k, k, transit)
    try:
        route = build_route(list(layout.passes), sensor.lead_in_m * k, kin, [sensor.spacing_m * k] * len(layout.passes),
                            launch_xy, detours, report, sensor.base_m * k, starts, transits)
    except ValueError as exc:
        raise InputError(f"routing failed: {exc}") from None
    first = (route.waypoints[0].x, route.waypoints[0].y)
    last = (route.waypoints[-1].x, route.waypoints[-1].y)
    home = places if isinstance(places, tuple) else nearest(places, first)
    if launch_xy is None:
        check_launch(spec, site, home, "the launch point chosen on the area's edge", "area.launch")
    if layout.obstacle is not None and shapely.contains_xy(layout.obstacle, *home):
        raise InputError("the launch point lies within the stand-off of the structure the pattern flies round: "
                         "give area.launch farther from it", key="area.launch")
    try:
        run = route.runs[0]
        out = climb_out(spec, site, sensor, transit, home, first, (float(run.station_xy[0, 0]), float(run.station_xy[0, 1])))
        end = end_of_flight(landing, site, home)
        back = transit.path(last, end)
    except ValueError as exc:
        raise InputError(f"routing failed: {exc} (from the launch point to the survey or back)") from None
    return RoutePlan(route, home, launch_xy is not None, detours, tuple(out), tuple(back), end)
