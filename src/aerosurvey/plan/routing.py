"""Route step: order the passes' runs, join them with detours around the zones, and fix
where the flight starts (the launch point given, else the area's edge nearest the first
waypoint)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from aerosurvey.errors import InputError
from aerosurvey.plan.pattern import Layout
from aerosurvey.plan.route import Detours, Route, build_route
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


def default_home(site: Site, first: tuple[float, float]) -> tuple[float, float]:
    """No launch point given: the area's edge nearest the first waypoint, outside every zone
    and its margin (the first waypoint itself when zones cover the whole edge)."""
    area = site.area
    edge = area.exterior if area.geom_type == "Polygon" else area.boundary
    if site.zones_buffered is not None:
        # a metre more than the margin, so that the launch point is not on its line
        edge = shapely.difference(edge, shapely.buffer(site.zones_buffered, 1.0, quad_segs=2))
        if edge.is_empty:
            return first
    near = shapely.get_point(shapely.shortest_line(edge, shapely.Point(first)), 0)
    return (float(near.x), float(near.y))


def plan_route(spec: MissionSpec, site: Site, sensor: SensorSolution, layout: Layout) -> RoutePlan:
    k = site.grid_scale
    launch_xy = None
    if spec.area.launch is not None:
        lx, ly = site.planar.xy(np.array([spec.area.launch[0]]), np.array([spec.area.launch[1]]))
        launch_xy = (float(lx[0]), float(ly[0]))
        if site.zones_buffered is not None and shapely.intersects(site.zones_buffered, shapely.Point(launch_xy)):
            raise InputError(f"area.launch = {list(spec.area.launch)} lies inside an exclusion zone "
                             f"(or its {spec.flight.exclusion_margin_m:g} m margin)", key="area.launch")
    detours = Detours(site.zones, spec.flight.exclusion_margin_m)
    try:
        route = build_route(list(layout.passes), sensor.lead_in_m * k, sensor.kinematics,
                            [sensor.spacing_m * k] * len(layout.passes), launch_xy, detours)
    except ValueError as exc:
        raise InputError(f"routing failed: {exc}") from None
    first = (route.waypoints[0].x, route.waypoints[0].y)
    last = (route.waypoints[-1].x, route.waypoints[-1].y)
    home = launch_xy if launch_xy is not None else default_home(site, first)
    try:
        out, back = detours.path(home, first), detours.path(last, home)
    except ValueError as exc:
        raise InputError(f"routing failed: {exc} (from the launch point to the survey or back)") from None
    return RoutePlan(route, home, launch_xy is not None, detours, tuple(out), tuple(back))
