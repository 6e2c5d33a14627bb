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
    if launch_xy is not None:
        return RoutePlan(route, launch_xy, True, detours)
    first = route.waypoints[0]
    area = site.area
    # no launch point given: take off at the area's edge nearest the first waypoint
    edge = area.exterior if area.geom_type == "Polygon" else area.boundary
    near = shapely.get_point(shapely.shortest_line(edge, shapely.Point(first.x, first.y)), 0)
    return RoutePlan(route, (float(near.x), float(near.y)), False, detours)
