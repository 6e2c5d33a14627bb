"""The planning pipeline: spec → heights and spacing → lines → stations → route → heights.

Each step is a function of plain data from the modules beside this one; this module
only wires them together and records what was decided and why (warnings, estimates).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.area import Planar, planning_crs, read_area
from aerosurvey.errors import InputError
from aerosurvey.plan import photogrammetry as pg
from aerosurvey.plan.frame import LineFrame
from aerosurvey.plan.heading import best_heading, candidate_headings
from aerosurvey.plan.lines import build_lines
from aerosurvey.plan.route import Detours, Kinematics, Pass, Route, build_route, descent_time, path_time, quick_cost
from aerosurvey.plan.sun import elevation_over_window
from aerosurvey.plan.terrain import Dem, thin_profile
from aerosurvey.spec import MissionSpec

#: Called with a stage name and the share of the work done (0..1). It may raise to stop the
#: planning (a web page cancelling a long plan does); the exception passes through unchanged.
Progress = Callable[[str, float], None]


def _no_progress(stage: str, done: float) -> None:
    return None


@dataclass(frozen=True)
class Heights:
    """What the terrain mode decided: the AGL heights that drive GSD and spacing."""

    mode: str
    target_agl_m: float  # height giving the target GSD over flat ground
    nominal_agl_m: float  # the height flown over the station's ground (follow) or the lowest ground (fixed)
    spacing_agl_m: float  # smallest height above ground anywhere: footprint and spacing from it
    max_agl_m: float  # largest height above ground: the coarsest GSD
    fixed_alt_amsl_m: float | None
    ground_min_m: float | None
    ground_max_m: float | None


@dataclass(frozen=True)
class Stations:
    """Photo stations in flight order (arrays of equal length)."""

    ids: list[str]
    run: np.ndarray
    x: np.ndarray
    y: np.ndarray
    lon: np.ndarray
    lat: np.ndarray
    ground_m: np.ndarray  # NaN without a DEM
    alt_rel_m: np.ndarray  # above home, as flown (terrain-frame: above terrain)
    agl_m: np.ndarray
    heading_deg: np.ndarray


@dataclass(frozen=True)
class RouteWaypoint:
    x: float
    y: float
    lon: float
    lat: float
    alt_m: float  # in the mission's altitude frame
    kind: str
    run: int
    station: str  # station id for waypoints placed on a station, else ""


@dataclass
class PlanResult:
    spec: MissionSpec
    planar: Planar
    area_wgs84: BaseGeometry
    area: BaseGeometry
    exclusions_wgs84: list[BaseGeometry]
    exclusions: BaseGeometry | None
    heights: Heights
    gsd_target_m: float
    gsd_min_m: float
    gsd_max_m: float
    across_m: float
    along_m: float
    spacing_m: float
    base_m: float
    side_images_per_point: int
    forward_images_per_point: int
    speed: pg.SpeedLimit
    trigger_interval_s: float | None
    lead_in_m: float
    turn_radius_m: float
    heading_deg: float
    heading_chosen: str
    passes: list[Pass]
    route: Route
    stations: Stations
    waypoints: list[RouteWaypoint]
    home: tuple[float, float, float]  # lon, lat, ground AMSL (0 without a DEM)
    home_xy: tuple[float, float]
    altitude_frame: str  # "relative" or "terrain"
    grid_scale: float  # planning-CRS metres per ground metre at the area
    trigger_distance_m: float | None  # DO_SET_CAM_TRIGG_DIST (distance triggering); base_m is the mean spacing flown
    estimates: dict[str, float]
    sun: dict[str, object] | None
    warnings: list[str] = field(default_factory=list)
    fence_inclusion: tuple = ()
    fence_exclusion: tuple = ()
    launch_sites: list = field(default_factory=list)
    sorties: list = field(default_factory=list)
    battery: object = None  # the sortie Budget when a battery is given


def _read_geometry(spec: MissionSpec) -> tuple[BaseGeometry, list[BaseGeometry]]:
    area = read_area(spec.area.file, spec.area.wkt, spec.area.wkt_crs, "area")
    excl = [read_area(p, None, "EPSG:4326", f"exclusion zone {p.name}") for p in spec.area.exclusions]
    return area, excl


def _heights(spec: MissionSpec, h_target: float, dem: Dem | None, area: BaseGeometry) -> Heights:
    mode = spec.terrain.mode
    tol = spec.terrain.tolerance_m
    if mode == "fixed":
        assert dem is not None
        gmin, gmax = dem.range_over(area, "area")
        relief = gmax - gmin
        spacing_h = h_target - relief
        if spacing_h < spec.terrain.min_clearance_m:
            raise InputError(
                f"terrain.mode = 'fixed': the ground under the area rises {relief:.1f} m (from {gmin:.1f} to {gmax:.1f} m), "
                f"so one height of {h_target:.1f} m above the lowest ground leaves {spacing_h:.1f} m above the highest, "
                f"less than terrain.min_clearance_m = {spec.terrain.min_clearance_m:g} m; use terrain.mode = 'follow'"
            )
        return Heights(mode, h_target, h_target, spacing_h, h_target, gmin + h_target, gmin, gmax)
    if mode in ("follow", "terrain-frame"):
        nominal = h_target - tol
        low = h_target - 2 * tol
        if low <= spec.terrain.min_clearance_m:
            raise InputError(
                f"terrain.tolerance_m = {tol:g} is too large for a flying height of {h_target:.1f} m "
                f"(the lowest allowed height {low:.1f} m is under terrain.min_clearance_m = {spec.terrain.min_clearance_m:g} m)"
            )
        gmin = gmax = None
        if dem is not None:
            gmin, gmax = dem.range_over(area, "area")
        return Heights(mode, h_target, nominal, low, h_target, None, gmin, gmax)
    return Heights("none", h_target, h_target, h_target, h_target, None, None, None)


def _target_height(spec: MissionSpec, warnings: list[str]) -> tuple[float, float]:
    """(height AGL, target GSD) honouring the height cap."""
    cam = spec.camera.camera
    cap = spec.vehicle.max_height_agl_m
    if spec.targets.gsd_m is not None:
        gsd = spec.targets.gsd_m
        h = pg.height_from_gsd(gsd, cam)
    else:
        h = spec.targets.height_m or 0.0
        gsd = pg.gsd_from_height(h, cam)
    if h > cap + 1e-9:
        at_cap = pg.gsd_from_height(cap, cam)
        if not spec.targets.plan_at_cap:
            raise InputError(
                f"targets: GSD {gsd * 100:.2f} cm needs {h:.1f} m above ground with {cam.name}, above the cap "
                f"vehicle.max_height_agl_m = {cap:g} m; at the cap the GSD is {at_cap * 100:.2f} cm. Ask for that GSD, "
                f"or set targets.plan_at_cap = true"
            )
        warnings.append(f"flying at the height cap {cap:g} m: GSD {at_cap * 100:.2f} cm instead of the {gsd * 100:.2f} cm asked for")
        return cap, at_cap
    return h, gsd


def plan_mission(spec: MissionSpec, progress: Progress | None = None) -> PlanResult:
    """Plan a survey from a validated spec. Raises InputError with numbers on any input that cannot be flown.

    `progress` hears of each stage; the heading search, most of the time, reports per candidate.
    """
    report = progress or _no_progress
    warnings: list[str] = []
    report("reading the area", 0.0)
    area_wgs, excl_wgs = _read_geometry(spec)
    planar = planning_crs(spec.crs, area_wgs)
    area = shapely.normalize(planar.forward(area_wgs))
    zones = shapely.union_all([planar.forward(e) for e in excl_wgs]) if excl_wgs else None
    margin = spec.flight.exclusion_margin_m
    zones_buf = shapely.buffer(zones, margin) if zones is not None else None
    if zones is not None:
        remaining = shapely.difference(area, zones_buf)
        if remaining.area < 0.01 * area.area:
            raise InputError(
                f"the exclusion zones (with the {margin:g} m margin, flight.exclusion_margin_m) cover "
                f"{100 * (1 - remaining.area / area.area):.1f} % of the area: nothing is left to survey"
            )

    h_target, gsd_target = _target_height(spec, warnings)
    dem = Dem(spec.terrain.dem, planar) if spec.terrain.dem is not None else None
    try:
        return _plan(spec, planar, area_wgs, excl_wgs, area, zones, zones_buf, h_target, gsd_target, dem, warnings, report)
    finally:
        if dem is not None:
            dem.close()


def _plan(spec, planar, area_wgs, excl_wgs, area, zones, zones_buf, h_target, gsd_target, dem, warnings,
          report: Progress) -> PlanResult:
    cam = spec.camera.camera
    report("heights over the ground", 0.03)
    heights = _heights(spec, h_target, dem, area)
    if heights.max_agl_m > spec.vehicle.max_height_agl_m + 1e-9:
        raise InputError(f"the plan would fly {heights.max_agl_m:.1f} m above ground, above vehicle.max_height_agl_m = {spec.vehicle.max_height_agl_m:g} m")
    across, along = pg.footprint(heights.spacing_agl_m, cam, spec.camera.mount)
    spacing = pg.line_spacing(across, spec.targets.side_overlap)
    # whole centimetres, rounded down: the mission carries the trigger distance to 1 cm, and
    # the stations must lie exactly where the autopilot's distance trigger will fire
    base = math.floor(pg.trigger_distance(along, spec.targets.forward_overlap) * 100.0) / 100.0
    gsd_min = pg.gsd_from_height(heights.spacing_agl_m, cam)
    gsd_max = pg.gsd_from_height(heights.max_agl_m, cam)
    speed = pg.survey_speed(spec.vehicle.cruise_speed_ms, base, gsd_min, cam, spec.camera.max_blur_px,
                            spec.camera.min_cycle_s, spec.camera.exposure_s)
    interval = None
    if spec.camera.trigger in ("time", "camera"):
        interval = spec.camera.interval_s or max(spec.camera.min_cycle_s, base / speed.speed_ms)
        if interval < spec.camera.min_cycle_s - 1e-9:
            raise InputError(f"camera.interval_s = {interval:g} is shorter than the camera's cycle time {spec.camera.min_cycle_s:g} s")
        v = min(speed.speed_ms, base / interval)
        speed = pg.SpeedLimit(v, speed.reason if v == speed.speed_ms else f"trigger interval {interval:g} s",
                              speed.cruise_ms, speed.cycle_limit_ms, speed.blur_limit_ms)
    trigger_cmd = None
    if spec.camera.trigger == "distance":
        try:
            trigger_cmd, base = pg.distance_trigger(base, speed.speed_ms)
        except ValueError as exc:
            raise InputError(f"{exc}: fly slower or ask for a larger photo base") from None
    radius = pg.turn_radius(speed.speed_ms, spec.vehicle.bank_angle_deg) if spec.vehicle.type == "plane" else 0.0
    if spec.flight.lead_in_m is not None:
        lead_in = spec.flight.lead_in_m
    elif spec.vehicle.type == "copter":
        lead_in = max(5.0, pg.stop_distance(speed.speed_ms, spec.vehicle.acceleration_ms2))
    else:
        lead_in = max(radius, pg.plane_lead_in(speed.speed_ms, spec.vehicle.nav_period_s))
    kin = Kinematics(spec.vehicle.type, speed.speed_ms, spec.vehicle.acceleration_ms2, radius)
    k_side = pg.images_per_point(spec.targets.side_overlap)
    k_fwd = pg.images_per_point(spec.targets.forward_overlap)
    beyond = spec.targets.images_beyond_boundary
    clearance = max(lead_in, base / 2.0) + 1.0

    c = area_wgs.centroid
    k = planar.scale_factor(c.x, c.y)
    margin = spec.targets.coverage_margin_m * k
    covered = shapely.buffer(area, margin, quad_segs=4) if margin > 0 else area
    g_across, g_along, g_spacing, g_base = across * k, along * k, spacing * k, base * k
    g_lead, g_clear = lead_in * k, clearance * k

    def lines_for(h: float):
        fr = LineFrame(h)
        zf = fr.geom_to_frame(zones_buf) if zones_buf is not None else None
        return fr, build_lines(fr.geom_to_frame(covered), zf, g_across, g_along, g_spacing, g_base, k_side, k_fwd, beyond, g_clear)

    def cost(fr: LineFrame) -> float:
        _, segs = lines_for(fr.heading_deg)
        return quick_cost(segs, g_lead, kin) if segs else math.inf

    if spec.flight.heading_deg is None:
        n_cand = len(candidate_headings(covered)) + 10
        tried = [0]

        def counted(fr: LineFrame) -> float:
            tried[0] += 1
            report("choosing the heading", 0.05 + 0.6 * min(1.0, tried[0] / n_cand))
            return cost(fr)

        heading, _ = best_heading(covered, counted)
        chosen = "auto: the shortest estimated flight time"
    else:
        heading = spec.flight.heading_deg
        chosen = "fixed by the spec"
    headings = [heading] + ([(heading + 90.0) % 180.0] if spec.flight.cross_hatch else [])
    report("flight lines and photo stations", 0.66)
    passes = []
    for i, h in enumerate(headings, start=1):
        fr, segs = lines_for(h)
        passes.append(Pass(i, fr, tuple(segs)))
    if not any(p.segments for p in passes):
        raise InputError("no flight line fits: the area is smaller than one photo or entirely blocked by exclusion zones")

    launch_xy = None
    if spec.area.launch is not None:
        lx, ly = planar.xy(np.array([spec.area.launch[0]]), np.array([spec.area.launch[1]]))
        launch_xy = (float(lx[0]), float(ly[0]))
        if zones_buf is not None and shapely.intersects(zones_buf, shapely.Point(launch_xy)):
            raise InputError(f"area.launch = {list(spec.area.launch)} lies inside an exclusion zone (or its {spec.flight.exclusion_margin_m:g} m margin)")
    detours = Detours(zones, spec.flight.exclusion_margin_m)
    report("route", 0.72)
    try:
        route = build_route(passes, g_lead, kin, [g_spacing] * len(passes), launch_xy, detours)
    except ValueError as exc:
        raise InputError(f"routing failed: {exc}") from None
    if launch_xy is None:
        first = route.waypoints[0]
        # no launch point given: take off at the area's edge nearest the first waypoint
        near = shapely.get_point(shapely.shortest_line(area.exterior if area.geom_type == "Polygon" else area.boundary,
                                                       shapely.Point(first.x, first.y)), 0)
        home_xy = (float(near.x), float(near.y))
    else:
        home_xy = launch_xy
    home_ground = float(dem.sample(np.array([home_xy[0]]), np.array([home_xy[1]]), "launch point")[0]) if dem is not None else 0.0
    hlon, hlat = planar.lonlat(np.array([home_xy[0]]), np.array([home_xy[1]]))

    report("heights along the route", 0.8)
    stations, wps, frame_name = _heights_along_route(spec, route, heights, dem, home_ground, planar)
    if heights.mode == "fixed":
        warnings.append(
            f"fixed height over terrain from {heights.ground_min_m:.1f} to {heights.ground_max_m:.1f} m: GSD "
            f"{gsd_min * 100:.2f} cm over the highest ground and {gsd_max * 100:.2f} cm over the lowest"
        )
    est = _estimates(spec, route, wps, stations, kin, home_xy, heights, base, k)
    sun = None
    if spec.conditions.start is not None:
        samples = elevation_over_window(float(hlon[0]), float(hlat[0]), spec.conditions.start, spec.conditions.end)
        elev = [e for _, e in samples]
        sun = {
            "start": spec.conditions.start.isoformat(),
            "end": spec.conditions.end.isoformat(),
            "min_elevation_deg": round(min(elev), 2),
            "max_elevation_deg": round(max(elev), 2),
            "threshold_deg": spec.conditions.min_sun_elevation_deg,
            "samples": [[t.isoformat(), round(e, 2)] for t, e in samples],
        }
        if min(elev) < spec.conditions.min_sun_elevation_deg:
            low = [t.isoformat() for t, e in samples if e < spec.conditions.min_sun_elevation_deg]
            warnings.append(
                f"sun elevation drops to {min(elev):.1f}° (below conditions.min_sun_elevation_deg = "
                f"{spec.conditions.min_sun_elevation_deg:g}°) between {low[0]} and {low[-1]}: long shadows hurt image matching"
            )
    if zones is not None:
        lost = shapely.intersection(area, zones_buf).area
        if lost > 0:
            warnings.append(
                f"{lost / 1e4:.2f} ha of the area lie in exclusion zones or their {spec.flight.exclusion_margin_m:g} m margin "
                "and are not photographed from above; coverage next to them is reduced"
            )
    result = PlanResult(
        spec=spec, planar=planar, area_wgs84=area_wgs, area=area, exclusions_wgs84=excl_wgs, exclusions=zones,
        heights=heights, gsd_target_m=gsd_target, gsd_min_m=gsd_min, gsd_max_m=gsd_max, across_m=across,
        along_m=along, spacing_m=spacing, base_m=base, side_images_per_point=k_side,
        forward_images_per_point=k_fwd, speed=speed, trigger_interval_s=interval, lead_in_m=lead_in,
        turn_radius_m=radius, heading_deg=heading, heading_chosen=chosen, passes=passes, route=route,
        stations=stations, waypoints=wps, home=(float(hlon[0]), float(hlat[0]), home_ground), home_xy=home_xy,
        grid_scale=k, trigger_distance_m=trigger_cmd,
        altitude_frame=frame_name, estimates=est, sun=sun, warnings=warnings,
    )
    sites = _launch_sites(spec, planar, dem, zones_buf, home_xy, (float(hlon[0]), float(hlat[0]), home_ground))
    result.launch_sites = sites
    result.fence_inclusion, result.fence_exclusion = _fence(result, sites, excl_wgs)
    if spec.battery is not None:
        report("battery sorties", 0.88)
        result.battery, result.sorties = _sorties(result, sites, kin, detours)
    report("planned", 1.0)
    return result


def _launch_sites(spec: MissionSpec, planar: Planar, dem, zones_buf, home_xy, home) -> list:
    """The launch points sorties may start from: the battery's list, else the plan's home."""
    from aerosurvey.plan.sorties import LaunchSite

    pts = spec.battery.launch_points if spec.battery is not None and spec.battery.launch_points else ()
    if not pts:
        return [LaunchSite(home_xy[0], home_xy[1], home[0], home[1], home[2])]
    lon = np.array([p[0] for p in pts])
    lat = np.array([p[1] for p in pts])
    x, y = planar.xy(lon, lat)
    ground = dem.sample(x, y, "launch points") if dem is not None else np.zeros(len(pts))
    for i, (px, py) in enumerate(zip(x, y)):
        if zones_buf is not None and shapely.intersects(zones_buf, shapely.Point(px, py)):
            raise InputError(f"battery.launch_points[{i + 1}] = {list(pts[i])} lies inside an exclusion zone "
                             f"(or its {spec.flight.exclusion_margin_m:g} m margin)")
    return [LaunchSite(float(px), float(py), float(lo), float(la), float(g)) for px, py, lo, la, g in zip(x, y, lon, lat, ground)]


def _fence(plan: PlanResult, sites: list, excl_wgs: list) -> tuple[tuple, tuple]:
    """Geofence: the hull of everything flown (and the launch points) grown by 50 m;
    the exclusion zones as exclusion polygons. (lat, lon) rings, not closed."""
    pts = [(w.x, w.y) for w in plan.waypoints] + [(s.x, s.y) for s in sites]
    hull = shapely.buffer(shapely.convex_hull(shapely.MultiPoint(pts)), 50.0, quad_segs=2)
    ring = np.asarray(hull.exterior.coords)[:-1]
    lon, lat = plan.planar.lonlat(ring[:, 0], ring[:, 1])
    inclusion = (tuple((round(float(a), 8), round(float(b), 8)) for a, b in zip(lat, lon)),)
    exclusion = []
    for z in excl_wgs:
        for poly in shapely.get_parts(z):
            c = np.asarray(poly.exterior.coords)[:-1]
            exclusion.append(tuple((round(float(b), 8), round(float(a), 8)) for a, b in c))
    return inclusion, tuple(exclusion)


def _sorties(plan: PlanResult, sites: list, kin: Kinematics, detours: Detours):
    from aerosurvey.plan.sorties import Budget, split, wind_factor

    b = plan.spec.battery
    keep = 1.0 - b.reserve
    budget = Budget(
        usable_s=b.usable_min * 60.0 * keep if b.usable_min is not None else None,
        usable_j=b.capacity_wh * 3600.0 * keep if b.capacity_wh is not None else None,
        cruise_w=b.cruise_power_w, climb_w=b.climb_power_w,
        wind_factor=wind_factor(b.wind_ms, kin.speed_ms), max_items=b.max_mission_items,
    )
    fixed = None if b.launch == "nearest" else int(b.launch) - 1
    raw = split(plan, sites, budget, kin, detours, fixed)
    out = []
    for s in raw:
        x = np.array([w.x for w in s.waypoints])
        y = np.array([w.y for w in s.waypoints])
        lon, lat = plan.planar.lonlat(x, y)
        wps = [RouteWaypoint(float(w.x), float(w.y), float(lo), float(la), float(w.alt_m), w.kind, w.run, w.station)
               for w, lo, la in zip(s.waypoints, lon, lat)]
        out.append((s, wps))
    return budget, out


def _heights_along_route(spec, route: Route, heights: Heights, dem: Dem | None, home_ground: float, planar: Planar):
    """Station and waypoint altitudes for the terrain mode; `follow` adds waypoints where the ground needs them."""
    runs = route.runs
    ids: list[str] = []
    run_idx, xs, ys, hd = [], [], [], []
    for i, r in enumerate(runs):
        for j, sidx in enumerate(r.station_index):
            ids.append(f"P{r.pass_index}-L{r.line + 1:03d}-S{int(sidx) + 1:04d}")
            run_idx.append(i)
            xs.append(r.station_xy[j, 0])
            ys.append(r.station_xy[j, 1])
            hd.append(r.heading_deg)
    x, y = np.asarray(xs), np.asarray(ys)
    ground = dem.sample(x, y, "photo stations") if dem is not None else np.full(len(x), np.nan)
    mode = heights.mode
    if mode == "fixed":
        alt_rel = np.full(len(x), heights.fixed_alt_amsl_m - home_ground)
        agl = heights.fixed_alt_amsl_m - ground
    elif mode == "follow":
        alt_rel = ground + heights.nominal_agl_m - home_ground
        agl = np.full(len(x), heights.nominal_agl_m)
    elif mode == "terrain-frame":
        alt_rel = np.full(len(x), heights.nominal_agl_m)
        agl = np.full(len(x), heights.nominal_agl_m)
    else:
        alt_rel = np.full(len(x), heights.nominal_agl_m)
        agl = np.full(len(x), heights.nominal_agl_m)
    lon, lat = planar.lonlat(x, y)
    stations = Stations(ids, np.asarray(run_idx, int), x, y, lon, lat, ground, alt_rel, agl, np.asarray(hd))

    start_of_run = np.searchsorted(stations.run, np.arange(len(runs)))
    end_of_run = np.searchsorted(stations.run, np.arange(len(runs)), side="right")
    pts: list[tuple[float, float, float, str, int, str]] = []

    def alt_at(px: float, py: float, what: str) -> float:
        if mode == "follow":
            g = float(dem.sample(np.array([px]), np.array([py]), what)[0])
            return g + heights.nominal_agl_m - home_ground
        if mode == "fixed":
            return heights.fixed_alt_amsl_m - home_ground
        return heights.nominal_agl_m

    for w in route.waypoints:
        if w.kind == "line_start":
            a, b = start_of_run[w.run], end_of_run[w.run]
            pts.append((w.x, w.y, float(alt_rel[a]), "line_start", w.run, ids[a]))
            if mode == "follow" and b - a > 2:
                s = np.hypot(x[a:b] - x[a], y[a:b] - y[a])
                keep = thin_profile(s, alt_rel[a:b], spec.terrain.tolerance_m)
                for k in keep[1:-1]:
                    pts.append((float(x[a + k]), float(y[a + k]), float(alt_rel[a + k]), "terrain", w.run, ids[a + k]))
            if mode == "follow" and b - a > 1:
                pts.append((float(x[b - 1]), float(y[b - 1]), float(alt_rel[b - 1]), "terrain", w.run, ids[b - 1]))
        elif w.kind == "line_end":
            a, b = start_of_run[w.run], end_of_run[w.run]
            pts.append((w.x, w.y, float(alt_rel[b - 1]) if mode == "follow" else alt_at(w.x, w.y, "line ends"), "line_end", w.run, ""))
        elif w.kind == "lead_in":
            a = start_of_run[w.run]
            pts.append((w.x, w.y, float(alt_rel[a]) if mode == "follow" else alt_at(w.x, w.y, "lead-ins"), "lead_in", w.run, ""))
        else:
            pts.append((w.x, w.y, math.nan, w.kind, w.run, ""))
    # detours keep the higher of their neighbours' altitudes
    alts = [p[2] for p in pts]
    for i, a in enumerate(alts):
        if math.isnan(a):
            prev = next((alts[j] for j in range(i - 1, -1, -1) if not math.isnan(alts[j])), None)
            nxt = next((alts[j] for j in range(i + 1, len(alts)) if not math.isnan(alts[j])), None)
            alts[i] = max(v for v in (prev, nxt) if v is not None)
    wx = np.asarray([p[0] for p in pts])
    wy = np.asarray([p[1] for p in pts])
    wlon, wlat = planar.lonlat(wx, wy)
    wps = [RouteWaypoint(float(p[0]), float(p[1]), float(lo), float(la), float(al), p[3], p[4], p[5])
           for p, lo, la, al in zip(pts, wlon, wlat, alts)]
    return stations, wps, ("terrain" if mode == "terrain-frame" else "relative")


def _estimates(spec, route: Route, wps: list[RouteWaypoint], stations: Stations, kin: Kinematics,
               home_xy: tuple[float, float], heights: Heights, base: float, k: float) -> dict[str, float]:
    """Distances and times on the ground (grid lengths divided by the scale factor k)."""
    pts = np.asarray([(w.x, w.y) for w in wps]) / k
    home_xy = (home_xy[0] / k, home_xy[1] / k)
    survey_len = float(np.hypot(*np.diff(pts, axis=0).T).sum()) if len(pts) > 1 else 0.0
    survey_time = path_time(pts, kin)
    transit_out = math.dist(home_xy, tuple(pts[0]))
    transit_back = math.dist(tuple(pts[-1]), home_xy)
    transit_kin = Kinematics(kin.vehicle, spec.vehicle.cruise_speed_ms, kin.accel_ms2, kin.turn_radius_m)
    climb = float(np.max(stations.alt_rel_m)) if len(stations.alt_rel_m) else heights.nominal_agl_m
    t_climb = climb / spec.vehicle.climb_rate_ms
    t_descent = descent_time(climb, spec.vehicle.descent_rate_ms, spec.vehicle.type)
    t_out = path_time(np.array([home_xy, pts[0]]), transit_kin)
    t_back = path_time(np.array([pts[-1], home_xy]), transit_kin)
    if kin.vehicle == "plane":  # a plane climbs and descends while it flies to and from the survey
        t_climb, t_descent = max(0.0, t_climb - t_out), max(0.0, t_descent - t_back)
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
