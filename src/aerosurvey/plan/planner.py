"""The planning pipeline: plain inputs in, a frozen `Plan` out; no file, socket or clock.

    site        the area and zones in the planning CRS, the relief under the area   (site.py)
    sensor      heights, GSD, footprint, spacing, base, speed limit, trigger         (sensor.py)
    pattern     lines and photo stations over the site                               (pattern.py)
    route       line order, turns, detours, where the flight starts                  (routing.py)
    altitudes   station and waypoint heights for the terrain mode                     (altitudes.py)
    sorties     launch points, geofence, battery split                               (sorties.py, fence.py)
    estimates   distances, times, the sun                                            (estimates.py)

Each step is a function of frozen data from the steps before it and can be called alone.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, replace
from itertools import islice
from typing import TYPE_CHECKING

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.errors import InputError
from aerosurvey.ids import station_index
from aerosurvey.plan.altitudes import Altitudes, Slopes, assign_altitudes
from aerosurvey.plan.capture import Optics, Photos
from aerosurvey.plan.coverage import Coverage, coverage_shortfall
from aerosurvey.plan.detours import Detours
from aerosurvey.plan.estimates import estimate, sun_over_window
from aerosurvey.plan.fence import geofence
from aerosurvey.plan.flight_time import Kinematics
from aerosurvey.plan.inputs import PlanInputs
from aerosurvey.plan.landing import Landing, climb_out_m, home_clearance_m
from aerosurvey.plan.limits import check_limits
from aerosurvey.plan.model import Heights, Launch, Plan, RouteWaypoint, SortiePlan, Stations
from aerosurvey.plan.passes import aims_per_place
from aerosurvey.plan.pattern import Layout, Pattern, kind_of
from aerosurvey.plan.progress import Progress, no_progress
from aerosurvey.plan.routing import RoutePlan, check_launch, default_home, end_of_flight, plan_route
from aerosurvey.plan.sensor import SensorSolution, reach_beyond_area_m, solve_heights, solve_sensor, target_height
from aerosurvey.plan.site import Site, prepare_site
from aerosurvey.plan.sorties import Budget, FlightPath, LaunchSite, Sortie, split
from aerosurvey.plan.zone_edges import edge_passes
from aerosurvey.spec import MissionSpec

if TYPE_CHECKING:
    from aerosurvey.plan.surfaces import FacesCheck

__all__ = ["Flown", "Heights", "Plan", "PlanInputs", "Progress", "RouteWaypoint", "Stations", "flown_layout", "fly_layout",
           "plan_mission", "resume_mission"]


def plan_mission(spec: MissionSpec, inputs: PlanInputs, progress: Progress | None = None) -> Plan:
    """Plan a survey from a validated spec and its inputs. Raises InputError with numbers on
    any input that cannot be flown. `progress` hears of each stage."""
    return _plan(spec, inputs, progress or no_progress)


def resume_mission(spec: MissionSpec, inputs: PlanInputs, from_station: str, progress: Progress | None = None) -> Plan:
    """The plan of `spec` whose sorties fly only the stations from `from_station` on (the first
    station of a flight cut short not photographed as the mission asked): the same route,
    stations and ids, the rest split into sorties that each fit a battery ([battery]) and the
    autopilot's mission storage. The first sortie starts at that station with a lead-in, the
    gimbal set and the camera switched on there, mid-line or not."""
    return _plan(spec, inputs, progress or no_progress, from_station)


def _plan(spec: MissionSpec, inputs: PlanInputs, report: Progress, resume_from: str | None = None) -> Plan:
    report("the site", 0.0)
    h_target, gsd_target, cap_warnings = target_height(spec)
    # official zones the whole flight's heights may not enter join the exclusion zones (airspace/route.py);
    # the airspace modules load only for a plan given zones (~6 ms of every plan's start-up otherwise)
    outlines: tuple[BaseGeometry, ...] = ()
    zone_warnings: tuple[str, ...] = ()
    if inputs.airspace is not None:
        from aerosurvey.airspace.route import route_zones

        official = route_zones(inputs.airspace, inputs.area_wgs84, reach_beyond_area_m(spec), spec.vehicle.max_height_agl_m,
                               inputs.dem)
        outlines, zone_warnings = official.outlines, official.warnings
    site = prepare_site(spec, replace(inputs, exclusions_wgs84=inputs.exclusions_wgs84 + outlines), h_target)
    report("heights over the ground", 0.03)
    pattern = kind_of(spec.pattern.kind)
    foot = pattern.stands_on(site) if site.ground is not None else None
    if foot is not None:  # a structure's heights are above the ground it stands on (terrain.mode = "fixed")
        lowest = foot_ground(site, foot)
        site = replace(site, ground=(lowest, lowest))
    heights = solve_heights(spec, h_target, site.ground)
    stretch = site.autopilot_stretch()
    footprint = pattern.footprint(spec, heights)
    sensor = solve_sensor(spec, h_target, gsd_target, heights, cap_warnings, footprint=footprint, autopilot_stretch=stretch,
                          nose_turns=pattern.nose_turns_camera)
    limit_warnings = check_limits(spec, site, sensor)
    # the heading search, the line order and every time after them in conditions.wind (a wind the vehicle
    # cannot make headway against refused before any line is laid)
    kin, wind = in_wind(spec, site, sensor)
    sensor = replace(sensor, kinematics=kin)
    laying = pattern.from_spec(spec)
    turned = _camera_turn(spec, site, kin)
    if turned is None:
        layouts = laying.layouts(site, sensor, report)
    else:
        turn, refusal = turned

        @functools.cache
        def solve(turns: tuple[float, ...]) -> SensorSolution:
            solved = solve_sensor(spec, h_target, gsd_target, heights, cap_warnings, footprint=footprint,
                                  autopilot_stretch=stretch, camera_turns_deg=turns, nose_turns=pattern.nose_turns_camera)
            return replace(solved, kinematics=in_wind(spec, site, solved)[0], own_turn=own)

        def own(heading_deg: float) -> SensorSolution:  # each heading at its own turn (the heading search's prices)
            return solve((turn(heading_deg),))

        sensor = replace(sensor, own_turn=own)
        layouts = laying.layouts(site, sensor, report)
        sensor, layouts = _under_turned_camera(sensor, laying, layouts, site, solve, report, turn, refusal)
        kin = sensor.kinematics
    flown = flown_layout(spec, site, sensor, layouts, report)
    layout, routed, home_ground, alts, coverage = flown.layout, flown.routed, flown.home_ground, flown.alts, flown.coverage
    waypoints = _with_transits(alts.waypoints, routed, site)
    hlon, hlat = site.planar.lonlat(np.array([routed.home_xy[0]]), np.array([routed.home_xy[1]]))
    home = (float(hlon[0]), float(hlat[0]), home_ground)
    sites = launch_sites(spec, site, routed.home_xy, home)
    rally = rally_points(spec, site)
    landing = Landing.of(spec)
    budget: Budget | None = None
    sorties: tuple[SortiePlan, ...] = ()
    start = 0 if resume_from is None else station_index(alts.stations.ids, resume_from)
    launch_warnings: tuple[str, ...] = ()
    if spec.battery is not None or resume_from is not None:
        report("battery sorties", 0.88)

        def split_from(sites: tuple[LaunchSite, ...]) -> tuple[Budget, tuple[SortiePlan, ...]]:
            path = FlightPath(alts.stations, routed.route.runs, alts.waypoints, sensor.lead_in_m, sensor.base_m,
                              site.grid_scale, alts.frame, sensor.heights, home_ground, spec.camera.trigger, spec.vehicle,
                              tuple(end_of_flight(landing, site, (s.x, s.y)) for s in sites),
                              climb_out_m(spec, sensor.heights.max_agl_m) * site.grid_scale, sensor.hover_s,
                              sensor.hover_look_s, aims_per_place(routed.route.runs))
            return battery_sorties(spec, site, path, sites, kin, routed.detours, start, _share(report, 0.88, 0.98))

        try:
            budget, sorties = split_from(sites)
        except InputError:
            # the home is where the route starts: of a long area, its far end may lie out of one
            # battery's reach from there; sorties there take off from the route's end instead
            far = far_launch(spec, site, routed)
            if far is None:
                raise
            sites += (far,)
            budget, sorties = split_from(sites)
            launch_warnings = (f"battery: from the launch point alone one battery cannot reach every station and come back; "
                               f"sorties also take off at [{far.lon:.6f}, {far.lat:.6f}], the area's edge nearest the route's "
                               "end, each from the nearer (battery.launch_points chooses the places)",)
    fence = geofence(site.planar, [(w.x, w.y) for w in waypoints] + [(s.x, s.y) for s in (*sites, *rally)],
                     site.exclusions_wgs84)
    est = estimate(spec, routed.route, waypoints, alts.stations, kin, routed.home_xy, routed.end_xy, sensor.heights,
                   sensor.base_m, sensor.lead_in_m, site.grid_scale, sensor.hover_s, sensor.hover_look_s)
    sun, sun_warnings = sun_over_window(spec, home[0], home[1])
    report("planned", 1.0)
    return Plan(
        name=spec.name, vehicle=spec.vehicle, camera=spec.camera, pattern=spec.pattern, site=site, sensor=sensor,
        layout=layout, route=routed.route, altitudes=alts,
        launch=Launch(home, routed.home_xy, sites, rally, fence, landing,
                      None if spec.flight.fixed_yaw_deg is None else float(spec.flight.fixed_yaw_deg)),
        waypoints=waypoints, sorties=sorties, battery=budget, coverage=coverage,
        bounds=pattern.bounds(spec, site, sensor, layout),
        estimates=est, sun=sun,
        warnings=(site.warnings + sensor.warnings + limit_warnings + _terrain_warnings(sensor)
                  + alts.warnings + sun_warnings + _zone_warnings(spec, site) + zone_warnings + launch_warnings),
        airspace=inputs.airspace, wind=wind,
        faces=_faces(spec, inputs, site, alts.stations, home_ground, layout),
    )


def _faces(spec: MissionSpec, inputs: PlanInputs, site: Site, st: Stations, home_ground: float,
           layout: Layout) -> FacesCheck | None:
    """The faces as the stations' photos see them: the pattern's own surface (`Layout.surface`), else
    [structure]'s, the photos' heights on the surface's datum: the ground it stands on (`Surface.foot`: over
    a DEM the lowest ground under it, as `foot_ground` gives the pattern's heights; else the launch point's)."""
    if layout.surface is not None:
        surface, min_images, max_gsd_m = layout.surface.surface, layout.surface.min_images, layout.surface.max_gsd_m
    elif spec.structure is not None and inputs.structure_wgs84 is not None:
        from aerosurvey.plan.surfaces import Structure  # faces only: not loaded by every plan

        s = spec.structure
        surface, min_images, max_gsd_m = (Structure(site.planar.forward(inputs.structure_wgs84), s.base_m, s.top_m),
                                          s.min_images, s.max_gsd_m)
    else:
        return None
    from aerosurvey.plan.surfaces import check_faces

    ground = home_ground if site.dem is None else foot_ground(site, surface.foot)
    z = np.where(np.isfinite(st.ground_m), st.ground_m + st.agl_m - ground, st.agl_m)
    photos = Photos.looking(st.x, st.y, z, st.camera_yaw_deg, st.pitch_deg)
    return check_faces(surface, ground, photos, st.ids, st.run, Optics.of(spec.camera.camera, spec.camera.mount),
                       site.grid_scale, min_images, max_gsd_m)


def foot_ground(site: Site, foot: BaseGeometry) -> float:
    """The ground a structure stands on over the site's DEM: the lowest cell under `foot` (its footprint, a toe line)."""
    assert site.dem is not None
    return site.dem.range_over(foot, "structure's foot")[0]


#: how many times the layout is laid again for a camera turned against the lines (a fixed yaw, a crab)
#: before the plan is refused (each time with its turns against every line heading the layouts so far used)
FIXED_YAW_ROUNDS = 3


def _line_headings(layout: Layout) -> np.ndarray:
    """Every direction (grid bearing) the layout's lines run in: each frame's heading, each strip's at its stations."""
    out = [np.array([p.frame.heading_deg]) for p in layout.passes if p.frame is not None and p.aim.look == "along"]
    out += [np.asarray(s.heading_deg, float) for p in layout.passes if p.aim.look == "along" for s in p.strips]
    return np.round(np.concatenate(out) % 180.0, 6) if out else np.zeros(0)


def _camera_turn(spec: MissionSpec, site: Site, kin: Kinematics) -> tuple[Callable[[float], float], InputError] | None:
    """How far a camera looking along the flight is turned against lines of a grid heading, where it is,
    and the refusal when the layout does not settle (`_under_turned_camera`): a copter's held at one yaw
    (flight.fixed_yaw_deg, a true bearing) by the yaw minus the heading; a plane's fixed to the body
    (camera.gimbal = "body") in conditions.wind by its crab (`Kinematics.crab_deg`). None: along the lines."""
    if spec.flight.fixed_yaw_deg is not None:
        c = site.area.centroid
        nose = float(site.planar.grid_bearing(spec.flight.fixed_yaw_deg, c.x, c.y))
        return (lambda h: round((nose - h) % 180.0, 6)), InputError(
            f"flight.fixed_yaw_deg = {spec.flight.fixed_yaw_deg:g}: the line heading changes each time the spacing is laid "
            "for the camera turned against it; fix the lines' heading (flight.heading_deg)", key="flight.fixed_yaw_deg")
    if spec.camera.gimbal == "body" and kin.vehicle == "plane" and not kin.calm:
        assert spec.conditions.wind is not None
        return (lambda h: round(kin.crab_deg(90.0 - h), 6)), InputError(
            f"camera.gimbal = 'body' in conditions.wind = {spec.conditions.wind.text()}: the line heading changes each time "
            "the spacing is laid for the camera turned by the crab; fix the lines' heading (flight.heading)", key="camera.gimbal")
    return None


def _under_turned_camera(sensor: SensorSolution, pattern: Pattern, layouts: Iterator[Layout], site: Site,
                         solve: Callable[[tuple[float, ...]], SensorSolution], report: Progress,
                         turn: Callable[[float], float], refusal: InputError) -> tuple[SensorSolution, Iterator[Layout]]:
    """The sensor solution and layouts of a camera turned against the lines by `turn` of their grid heading
    (`_camera_turn`): a camera that looks along the flight (every pass whose look is not set) then photographs
    a turned footprint, so spacing and base are laid from the ground it surely photographs across and along
    each line (`photogrammetry.turned_footprint`). The heading search prices each heading at its own turn
    (`SensorSolution.at_heading`), so its choice does not change with the solution; a first layout whose lines
    run in a direction the solution was not made for (the first round's is the unturned camera's) is laid again
    with that direction too; of the pattern's alternatives only those whose lines run in the directions the
    solution was made for follow it.
    A layout that has not settled after FIXED_YAW_ROUNDS is `refusal`."""
    known: set[float] = set()

    def solved(first: Layout) -> Iterator[Layout]:  # the alternatives of the last round's layouts, laid for its solution
        yield first
        yield from (lay for lay in layouts if {float(h) for h in _line_headings(lay)} <= known)

    def exact(first: Layout) -> tuple[SensorSolution, Iterator[Layout]]:
        """A settled layout whose solution was made for more directions than its lines run in (a layout
        of an earlier round, passed over) is laid again for its own directions alone: the spacing is then
        no tighter than they need (the first of those layouts whose lines run in them; else as settled)."""
        own = {float(h) for h in _line_headings(first)}
        if own == known:
            return sensor, solved(first)
        again = solve(tuple(sorted({turn(h) for h in own})))
        fitting = (lay for lay in pattern.layouts(site, again, report) if {float(h) for h in _line_headings(lay)} <= own)
        better = next(fitting, None)
        if better is None:
            return sensor, solved(first)
        return again, itertools.chain((better,), fitting)

    layout = next(layouts)
    for _ in range(FIXED_YAW_ROUNDS):
        wanted = {float(h) for h in _line_headings(layout)}
        if wanted <= known:
            return exact(layout)
        known |= wanted
        sensor = solve(tuple(sorted({turn(h) for h in known})))
        layouts = pattern.layouts(site, sensor, report)
        layout = next(layouts)
    if {float(h) for h in _line_headings(layout)} <= known:
        return exact(layout)
    raise refusal


def _share(report: Progress, start: float, end: float) -> Progress:
    """`report` for a step that runs from `start` to `end` of the plan: its 0..1 passed on scaled."""
    return lambda stage, done: report(stage, start + (end - start) * done)


#: a pattern's layouts flown at most (routed, their coverage checked) while the earlier ones leave ground unseen
MAX_LAYOUTS = 8


@dataclass(frozen=True, eq=False)
class Flown:
    """A layout as flown: with the lines along the zones it needed, its route, altitudes and coverage."""

    layout: Layout
    routed: RoutePlan
    home_ground: float
    alts: Altitudes
    coverage: Coverage


def flown_layout(spec: MissionSpec, site: Site, sensor: SensorSolution, layouts: Iterable[Layout],
                 report: Progress = no_progress) -> Flown:
    """The layout the plan flies: of a pattern's layouts (`Pattern.layouts`, its own choice first),
    the first whose flight leaves no required ground unseen (`fly_layout`'s coverage, the plan's),
    else the one that leaves least (the earlier of equals); at most MAX_LAYOUTS are flown. The
    pattern orders them by its time estimate, which prices the lines, not the ground next to a zone
    that lines cut short leave to one photo: so no layout that gives up ground wins over one that
    sees it all, and the alternatives are laid and flown only when the first leaves ground unseen. An
    alternative whose flight is refused (InputError) is passed over; the first's refusal is the plan's."""
    best: Flown | None = None
    for i, layout in enumerate(islice(layouts, MAX_LAYOUTS)):
        if i:
            report("another layout: the faster ones leave ground next to the zones unseen", 0.72)
        try:
            flown = fly_layout(spec, site, sensor, layout, report if i == 0 else no_progress)
        except InputError:
            if i == 0:
                raise  # the pattern's own choice: its refusal is the plan's
            continue  # an alternative that cannot be flown as it is (its launch point's landing approach crosses a zone)
        if best is None or flown.coverage.uncovered_m2 < best.coverage.uncovered_m2:
            best = flown
        if best.coverage.uncovered_m2 <= 0:
            break
    assert best is not None, "a pattern lays at least one layout"
    return best


def fly_layout(spec: MissionSpec, site: Site, sensor: SensorSolution, layout: Layout,
               report: Progress = no_progress) -> Flown:
    """A layout routed with its altitudes and coverage, and lines along the zones' margins where its own
    lines, cut short, leave ground unphotographed (`zone_edges.edge_passes`)."""
    report("route", 0.72)
    routed, home_ground, alts, coverage = _fly(spec, site, sensor, layout, _share(report, 0.72, 0.84))
    extra = edge_passes(site, sensor, coverage.uncovered, len(layout.passes) + 1)
    if extra:
        report("lines along the zones", 0.85)
        layout = replace(layout, passes=layout.passes + extra)
        routed, home_ground, alts, coverage = _fly(spec, site, sensor, layout, _share(report, 0.85, 0.88))
    return Flown(layout, routed, home_ground, alts, coverage)


def _fly(spec: MissionSpec, site: Site, sensor: SensorSolution, layout: Layout,
         report: Progress = no_progress) -> tuple[RoutePlan, float, Altitudes, Coverage]:
    """Route, altitudes and the coverage check of a layout."""
    routed = plan_route(spec, site, sensor, layout, report)
    home_ground = _ground(site, routed.home_xy, "launch point")
    slopes = Slopes.of(spec.vehicle.climb_rate_ms, spec.vehicle.descent_rate_ms, sensor.speed.speed_ms)
    alts = assign_altitudes(routed.route, sensor.heights, site.dem, home_ground, site.planar, spec.terrain.tolerance_m, slopes,
                            spec.vehicle.max_height_agl_m, spec.flight.fixed_yaw_deg)
    return routed, home_ground, alts, coverage_shortfall(spec, site, sensor, alts.stations, layout.check_exactly)


def _with_transits(survey: tuple[RouteWaypoint, ...], routed: RoutePlan, site: Site) -> tuple[RouteWaypoint, ...]:
    """The survey waypoints with the detours from home and back home, where the straight way crosses a zone.

    Transit waypoints fly at the altitude of the survey waypoint they lead to or come from."""
    def transit(points: tuple[tuple[float, float], ...], alt: float) -> tuple[RouteWaypoint, ...]:
        if not points:
            return ()
        xy = np.asarray(points)
        lon, lat = site.planar.lonlat(xy[:, 0], xy[:, 1])
        return tuple(RouteWaypoint(float(x), float(y), float(lo), float(la), alt, "transit", -1, "")
                     for (x, y), lo, la in zip(points, lon, lat))

    return transit(routed.transit_out, survey[0].alt_m) + survey + transit(routed.transit_back, survey[-1].alt_m)


def _ground(site: Site, xy: tuple[float, float], what: str) -> float:
    if site.dem is None:
        return 0.0
    return float(site.dem.sample(np.array([xy[0]]), np.array([xy[1]]), what)[0])


def _terrain_warnings(sensor: SensorSolution) -> tuple[str, ...]:
    """One fixed height over ground that rises and falls: the GSD it gives over the highest and the lowest (none
    over level ground, a structure's foot among it)."""
    h = sensor.heights
    if h.mode != "fixed" or h.ground_min_m == h.ground_max_m:
        return ()
    return (f"fixed height over terrain from {h.ground_min_m:.1f} to {h.ground_max_m:.1f} m: GSD "
            f"{sensor.gsd_min_m * 100:.2f} cm over the highest ground and {sensor.gsd_max_m * 100:.2f} cm over the lowest",)


def _zone_warnings(spec: MissionSpec, site: Site) -> tuple[str, ...]:
    if site.zones_buffered is None:
        return ()
    lost = shapely.intersection(site.area, site.zones_buffered).area
    if lost <= 0:
        return ()
    return (f"{lost / 1e4:.2f} ha of the area lie in exclusion zones or their {spec.flight.exclusion_margin_m:g} m margin "
            "and are not photographed from above (the rule uncovered-ground gives what next to them no two photos see)",)


def launch_sites(spec: MissionSpec, site: Site, home_xy: tuple[float, float],
                 home: tuple[float, float, float]) -> tuple[LaunchSite, ...]:
    """The launch points sorties may start from: the battery's list, else the plan's home."""
    pts = spec.battery.launch_points if spec.battery is not None and spec.battery.launch_points else ()
    if not pts:
        return (LaunchSite(home_xy[0], home_xy[1], home[0], home[1], home[2]),)
    return _places(spec, site, pts, "battery.launch_points")


def rally_points(spec: MissionSpec, site: Site) -> tuple[LaunchSite, ...]:
    """The spec's rally points (`flight.rally_points`): places RTL may fly to and land at, so
    refused where a launch point would be (in or next to a zone, an approach across one)."""
    return _places(spec, site, spec.flight.rally_points, "flight.rally_points") if spec.flight.rally_points else ()


def _places(spec: MissionSpec, site: Site, pts: tuple[tuple[float, float], ...], key: str) -> tuple[LaunchSite, ...]:
    lon = np.array([p[0] for p in pts])
    lat = np.array([p[1] for p in pts])
    x, y = site.planar.xy(lon, lat)
    ground = site.dem.sample(x, y, key) if site.dem is not None else np.zeros(len(pts))
    for i, (px, py) in enumerate(zip(x, y)):
        check_launch(spec, site, (float(px), float(py)), f"{key}[{i + 1}] = {list(pts[i])}", key)
    return tuple(LaunchSite(float(px), float(py), float(lo), float(la), float(g)) for px, py, lo, la, g in zip(x, y, lon, lat, ground))


def far_launch(spec: MissionSpec, site: Site, routed: RoutePlan) -> LaunchSite | None:
    """A second place sorties may take off from when none are given (battery.launch_points) and
    the launch is the nearest: the area's edge nearest the route's last waypoint, as the home is
    the edge nearest its first (`routing.default_home`); None where it is the home, or is not a
    valid launch point (`routing.check_launch`)."""
    if spec.battery is None or spec.battery.launch_points or spec.battery.launch != "nearest":
        return None
    last = routed.route.waypoints[-1]
    clearance = home_clearance_m(spec) * site.grid_scale
    xy = default_home(site, (last.x, last.y), clearance)
    if math.dist(xy, routed.home_xy) < max(clearance, 1.0):
        return None
    try:
        check_launch(spec, site, xy, "the launch point at the route's end", "battery.launch_points")
    except InputError:
        return None
    lon, lat = site.planar.lonlat(np.array([xy[0]]), np.array([xy[1]]))
    return LaunchSite(xy[0], xy[1], float(lon[0]), float(lat[0]), _ground(site, xy, "launch point"))


def in_wind(spec: MissionSpec, site: Site, sensor: SensorSolution) -> tuple[Kinematics, dict[str, float] | None]:
    """The survey's kinematics in conditions.wind (the sensor's own, still air, without one) and the wind's
    record (`Plan.wind`): its direction, a true bearing, turned onto the planning grid at the area's centre
    (`Planar.grid_bearing`).
    A wind or gust the vehicle cannot make headway against is refused: a plane's survey and cruise air
    speeds, a copter's vehicle.max_airspeed_ms (its lean limit on the nose, the least in any direction:
    `flight_time.lean_drag`) must be above the gusts."""
    kin, wind, v = sensor.kinematics, spec.conditions.wind, spec.vehicle
    if wind is None:
        return kin, None
    if v.type == "copter":
        if v.max_airspeed_ms is None:
            raise InputError(f"conditions.wind = {wind.text()} needs vehicle.max_airspeed_ms for a copter: the air speed it "
                             "reaches at its lean limit (it holds its ground speed until then)", key="vehicle.max_airspeed_ms")
        air, what = v.max_airspeed_ms, "vehicle.max_airspeed_ms"
        if air < kin.speed_ms:
            raise InputError(f"vehicle.max_airspeed_ms = {air:g} is below the survey speed {kin.speed_ms:.2f} m/s: the copter "
                             "could not fly it even in still air", key="vehicle.max_airspeed_ms")
    else:
        air = min(kin.speed_ms, v.cruise_speed_ms)
        what = "the survey air speed" if air == kin.speed_ms else "vehicle.cruise_speed_ms (the transits)"
    if wind.gust_ms >= air:
        gusts = "" if wind.gust_ms == wind.speed_ms else f"gusts {wind.gust_ms:g} m/s "
        raise InputError(f"conditions.wind = {wind.text()}: {gusts}not below {what} {air:.2f} m/s: the vehicle could not "
                         "make headway against it on every leg; fly on a calmer day", key="conditions.wind")
    c = site.area.centroid
    grid_from = float(site.planar.grid_bearing(wind.from_deg, c.x, c.y)) % 360.0
    to = math.radians(grid_from + 180.0)  # the air moves towards the opposite bearing
    record = {"speed_ms": wind.speed_ms, "from_deg": wind.from_deg, "gust_ms": wind.gust_ms, "grid_from_deg": round(grid_from, 3)}
    return replace(kin, wind_x=wind.speed_ms * math.sin(to), wind_y=wind.speed_ms * math.cos(to),
                   airspeed_ms=air if v.type == "copter" else kin.airspeed_ms,
                   airspeed_diagonal_ms=v.max_airspeed_diagonal_ms), record


def wind_allowance(spec: MissionSpec, kin: Kinematics) -> float:
    """battery.wind_ms, a wind of unknown direction: level flight costs 1 / (1 − (w/v)²) times its still-air time, the
    time of legs flown out and back along a wind w (the worst direction for back-and-forth lines), at the survey
    speed v. A known wind is conditions.wind, which times every leg by its direction instead: not both."""
    b = spec.battery
    w = 0.0 if b is None else b.wind_ms
    if w <= 0.0:
        return 1.0
    if spec.conditions.wind is not None:
        raise InputError(f"battery.wind_ms = {w:g} and conditions.wind = {spec.conditions.wind.text()} are both given: "
                         "battery.wind_ms is an allowance for a wind of unknown direction; keep conditions.wind",
                         key="battery.wind_ms")
    v = kin.speed_ms
    if w >= v:
        raise InputError(f"battery.wind_ms = {w:g} is not below the survey speed {v:.2f} m/s: the vehicle could not make "
                         "headway against it; fly on a calmer day or give the real wind (conditions.wind)", key="battery.wind_ms")
    return 1.0 / (1.0 - (w / v) ** 2)


def battery_sorties(spec: MissionSpec, site: Site, path: FlightPath, sites: tuple[LaunchSite, ...],
                    kin: Kinematics, detours: Detours, start: int = 0,
                    report: Progress = no_progress) -> tuple[Budget, tuple[SortiePlan, ...]]:
    """Split the route from station `start` into sorties that each fit one battery (without a
    [battery] table: as few as the autopilot's mission storage allows), each leg timed in the wind of
    `kin` (`in_wind`); `report` hears of the balancing rounds."""
    b = spec.battery
    if b is None:
        from aerosurvey.spec import MAX_ITEMS

        budget = Budget(usable_s=math.inf, usable_j=None, cruise_w=None, climb_w=None,
                        max_items=MAX_ITEMS[spec.vehicle.firmware])
        return budget, _sortie_plans(site, split(path, sites, budget, kin, detours, None, start, report=report))
    keep = 1.0 - b.reserve
    budget = Budget(
        usable_s=b.usable_min * 60.0 * keep if b.usable_min is not None else None,
        usable_j=b.capacity_wh * 3600.0 * keep if b.capacity_wh is not None else None,
        cruise_w=b.cruise_power_w, climb_w=b.climb_power_w,
        max_items=b.max_mission_items, reserve=b.reserve, allowance=wind_allowance(spec, kin),
    )
    fixed = None if b.launch == "nearest" else int(b.launch) - 1
    return budget, _sortie_plans(site, split(path, sites, budget, kin, detours, fixed, start, report=report))


def _sortie_plans(site: Site, raw: list[Sortie]) -> tuple[SortiePlan, ...]:
    """The sorties with their waypoints' longitudes and latitudes."""
    out = []
    for s in raw:
        x = np.array([w.x for w in s.waypoints])
        y = np.array([w.y for w in s.waypoints])
        lon, lat = site.planar.lonlat(x, y)
        wps = tuple(RouteWaypoint(float(w.x), float(w.y), float(lo), float(la), float(w.alt_m), w.kind, w.run, w.station)
                    for w, lo, la in zip(s.waypoints, lon, lat))
        out.append(SortiePlan(s, wps))
    return tuple(out)
