"""QGroundControl Survey items for a mission's photo passes: which items each one holds and
the settings QGroundControl regenerates the pass from when the pilot edits it.

A Survey complex item (SurveyComplexItem, its TransectStyleComplexItem and CameraCalc in
QGroundControl's sources) stores two things: the mission items QGroundControl uploads as they
are while the plan is loaded unedited (`Items`), and the settings its own generator rebuilds
the lines from once anything of the item is edited (polygon, angle, spacing, turnaround,
camera). `survey_blocks` picks the items (each run of items of one pass, with the detours
between its lines); `survey_settings` chooses the settings so that QGroundControl's lines fall
on ours (docs/clients/qgroundcontrol.md has the measured differences).

How QGroundControl lays its lines (SurveyComplexItem::_rebuildTransectsPhase1), which the
choices below follow:
- the polygon is projected onto a plane tangent at its first vertex (an azimuthal equidistant
  projection on a sphere of the WGS84 equatorial radius, x east, y north);
- lines run at the compass bearing `angle` (clamped to -90..90); line k lies at
  -h + k·s from the centre of the polygon's east-north bounding box, measured towards the
  bearing angle + 90°, with s the spacing (CameraCalc's AdjustedFootprintSide) and
  h = (max(box width, box height) + 2000 m) / 2;
- each line is cut to the two farthest crossings with the polygon's edges, directed from the
  crossing on the edge listed first; all lines take the first line's direction;
- `entryLocation` reverses the points of every line (2, 3) and/or the order of the lines (1, 3),
  then every second line is reversed (a lawnmower).

So the polygon written is the area grown by less than one spacing, by the amount that puts
QGroundControl's line grid on ours (growing the area by b grows h by b and leaves the box's
centre in place), listed counter-clockwise from its vertex furthest to the left of the lines:
QGroundControl's first line then runs in the direction of `angle`, and `entryLocation` says
whether our first run flies with or against it and starts at the left or the right line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import shapely
from pyproj import Transformer
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry

from aerosurvey import ids
from aerosurvey.mission import mavlink_ids as mav
from aerosurvey.mission.items import Mission
from aerosurvey.plan.planner import Plan

#: QGroundControl's CameraCalc distance modes (QGroundControlQmlGlobal::AltMode)
DISTANCE_RELATIVE = 1
DISTANCE_CALC_ABOVE_TERRAIN = 3
DISTANCE_TERRAIN_FRAME = 4
#: the sphere QGroundControl projects on (QGCGeo::convertGeoToNed: GeographicLib's WGS84_a)
QGC_SPHERE_M = 6378137.0
#: QGroundControl lengthens its lines by this much beyond the polygon's bounding box
QGC_LINE_MARGIN_M = 2000.0
#: rounds of growing the polygon: each one corrects the last (the buffer's round corners make
#: the box grow by a little less than the buffer distance); three leave well under a millimetre
_ROUNDS = 3


@dataclass(frozen=True)
class QgcCamera:
    """CameraCalc's camera and overlaps (a "Custom Camera": QGroundControl knows cameras by its own names)."""

    sensor_width_mm: float
    sensor_height_mm: float
    image_width_px: int
    image_height_px: int
    focal_mm: float
    landscape: bool
    min_trigger_interval_s: float
    image_density_cm: float  # GSD at the distance to surface, by QGroundControl's formula
    frontal_overlap: float  # percent: QGroundControl's footprint x (1 - overlap) = our photo base
    side_overlap: float  # percent: ... = our line spacing


@dataclass(frozen=True)
class QgcSurvey:
    """One Survey complex item: mission items `first`..`last` (indices into Mission.items) and its settings."""

    first: int
    last: int
    pass_index: int
    polygon: tuple[tuple[float, float], ...]  # (latitude, longitude), open ring, vertex 0 the projection's origin
    grown_m: float  # how far the polygon lies outside the area
    angle_deg: float
    entry_location: int
    fly_alternate: bool
    spacing_m: float  # AdjustedFootprintSide
    trigger_m: float  # AdjustedFootprintFrontal
    turnaround_m: float
    distance_m: float  # DistanceToSurface
    distance_mode: int
    hover: bool
    camera_shots: int
    camera: QgcCamera
    terrain_tolerance_m: float
    max_climb_ms: float
    max_descent_ms: float
    flight_speed_ms: float
    visual_points: tuple[tuple[float, float], ...]  # (latitude, longitude) of the items' positions, in order


def survey_blocks(m: Mission) -> list[tuple[int, int, int]]:
    """(pass, first, last) for each stretch of items that fly one pass: from a run's first item
    to its pass's last run's last item, with the detours between its lines; takeoff, transits,
    detours before or after a pass, landing and RTL stay outside."""
    blocks: list[list[int]] = []
    for i, it in enumerate(m.items):
        p = ids.pass_of(it.tag)
        if p is None:
            continue
        if blocks and blocks[-1][0] == p and all(m.items[j].tag == "detour" for j in range(blocks[-1][2] + 1, i)):
            blocks[-1][2] = i
        else:
            blocks.append([p, i, i])
    return [(p, a, b) for p, a, b in blocks]


@lru_cache(maxsize=64)
def _to_tangent(lat0: float, lon0: float) -> Transformer:
    """lon/lat -> metres east/north on QGroundControl's tangent plane at (lat0, lon0)."""
    return Transformer.from_crs("EPSG:4326", f"+proj=aeqd +lat_0={float(lat0)!r} +lon_0={float(lon0)!r} +R={QGC_SPHERE_M} "
                                "+units=m +no_defs", always_xy=True)


def _outline(area: BaseGeometry) -> Polygon:
    """The area as one ring: its exterior, or the convex hull of its parts (QGroundControl's polygon has no holes)."""
    if isinstance(area, Polygon):
        return Polygon(area.exterior)
    return Polygon(shapely.convex_hull(area).exterior)


def _clamp90(a: float) -> float:
    """A line's bearing as QGroundControl keeps it, in [-90, 90) (a line has two directions)."""
    return (a + 90.0) % 180.0 - 90.0


def _fold(v: float, s: float) -> float:
    """`v` modulo `s`, in [-s/2, s/2)."""
    return (v + s / 2.0) % s - s / 2.0


@dataclass(frozen=True)
class _Lines:
    """A pass's stations on the tangent plane: per line, its stations' east/north."""

    lines: list[np.ndarray]  # per line of the pass (by line number), (n, 2)
    first_line: int  # position in `lines` of the line flown first
    first_dir: np.ndarray  # direction of the first run (unit east/north)


def _pass_lines(plan: Plan, pass_index: int, tr: Transformer) -> _Lines:
    st, runs = plan.stations, plan.route.runs
    run_pass = np.array([r.pass_index for r in runs])
    run_line = np.array([r.line for r in runs])
    mine = run_pass[st.run] == pass_index
    e, n = tr.transform(st.lon[mine], st.lat[mine])
    xy = np.column_stack([e, n])
    line_of = run_line[st.run[mine]]
    numbers = sorted(set(line_of.tolist()))
    lines = [xy[line_of == k] for k in numbers]
    first_run = next(k for k, r in enumerate(runs) if r.pass_index == pass_index)
    pts = xy[st.run[mine] == first_run]
    d = pts[-1] - pts[0] if len(pts) > 1 else np.array([math.sin(math.radians(runs[first_run].heading_deg)),
                                                         math.cos(math.radians(runs[first_run].heading_deg))])
    return _Lines(lines, numbers.index(runs[first_run].line), d / np.hypot(*d))


def _bearing(lines: list[np.ndarray]) -> float:
    """The compass bearing of the pass's lines, from its longest line's end stations."""
    longest = max(lines, key=lambda p: float(np.hypot(*(p[-1] - p[0]))) if len(p) > 1 else 0.0)
    d = longest[-1] - longest[0]
    return math.degrees(math.atan2(d[0], d[1]))


def _ring_from_left(ring_lonlat: np.ndarray, angle: float, tr: Transformer) -> np.ndarray:
    """The open ring counter-clockwise (on the map), starting at its vertex furthest to the left of lines at `angle`."""
    e, n = tr.transform(ring_lonlat[:, 0], ring_lonlat[:, 1])
    if not shapely.is_ccw(shapely.linearrings(np.column_stack([e, n]))):
        ring_lonlat, e, n = ring_lonlat[::-1], e[::-1], n[::-1]
    a = math.radians(angle)
    across = e * math.cos(a) - n * math.sin(a)  # towards the bearing angle + 90°: to the right of the lines
    k = int(np.argmin(across))
    return np.roll(ring_lonlat, -k, axis=0)


@dataclass(frozen=True)
class _Fit:
    """Our lines on QGroundControl's plane for one polygon: what its generator would be given and how far off its grid lies."""

    ring: np.ndarray  # lon/lat, open, counter-clockwise from the vertex furthest left of the lines
    angle: float
    spacing: float
    offsets: np.ndarray  # each line's distance from the polygon box's centre towards the bearing angle + 90°
    error: float  # how far QGroundControl's grid lies from our lines, across them, folded into ±spacing/2
    lines: _Lines


def _fit(plan: Plan, pass_index: int, ring: np.ndarray) -> _Fit:
    tr = _to_tangent(ring[0, 1], ring[0, 0])
    ring = _ring_from_left(ring, _clamp90(_bearing(_pass_lines(plan, pass_index, tr).lines)), tr)
    tr = _to_tangent(ring[0, 1], ring[0, 0])  # the plane QGroundControl projects on: tangent at vertex 0
    lines = _pass_lines(plan, pass_index, tr)
    angle = _clamp90(_bearing(lines.lines))
    a = math.radians(angle)
    across = np.array([math.cos(a), -math.sin(a)])
    e, n = tr.transform(ring[:, 0], ring[:, 1])
    centre = np.array([(e.min() + e.max()) / 2.0, (n.min() + n.max()) / 2.0])
    offsets = np.array([float(np.mean(p @ across)) for p in lines.lines]) - centre @ across
    # the spacing the lines lie at on this plane: a least-squares line through their offsets
    spacing = abs(float(np.polyfit(np.arange(len(offsets)), offsets, 1)[0])) if len(offsets) > 1 else plan.spacing_m
    half = (max(float(np.ptp(e)), float(np.ptp(n))) + QGC_LINE_MARGIN_M) / 2.0
    # QGroundControl's line k lies at -half + k·spacing
    error = _fold(float(np.mean([_fold(o + half, spacing) for o in offsets])), spacing)
    return _Fit(ring, angle, spacing, offsets, error, lines)


def survey_geometry(plan: Plan, pass_index: int) -> tuple[_Fit, float, int, bool]:
    """The polygon, angle and spacing QGroundControl regenerates a pass from, how far the
    polygon is grown beyond the area, the entry location and whether lines are flown alternately."""
    outline = _outline(plan.area_wgs84)
    c = outline.centroid
    local = _to_tangent(c.y, c.x)
    back = Transformer.from_crs(local.target_crs, "EPSG:4326", always_xy=True)
    area_local = shapely.transform(outline, lambda xy: np.column_stack(local.transform(xy[:, 0], xy[:, 1])))
    grown = 0.0
    fit = _fit(plan, pass_index, np.asarray(outline.exterior.coords)[:-1])
    for _ in range(_ROUNDS):
        if abs(fit.error) < 1e-4:
            break
        grown = (grown - fit.error) % fit.spacing  # growing by b moves QGroundControl's grid by -b
        coords = np.asarray(_outline(shapely.buffer(area_local, grown, quad_segs=16)).exterior.coords)[:-1]
        fit = _fit(plan, pass_index, np.column_stack(back.transform(coords[:, 0], coords[:, 1])))
    a = math.radians(fit.angle)
    reverse_points = float(fit.lines.first_dir @ np.array([math.sin(a), math.cos(a)])) < 0.0
    reverse_lines = fit.offsets[fit.lines.first_line] > fit.offsets.min() + fit.spacing / 2.0
    entry = (2 if reverse_points else 0) + (1 if reverse_lines else 0)
    return fit, grown, entry, _alternate(plan, pass_index)


def _alternate(plan: Plan, pass_index: int) -> bool:
    """True when our lines are flown in QGroundControl's alternate order: every second line
    one way, then the skipped ones on the way back."""
    order: list[int] = []
    for r in plan.route.runs:
        if r.pass_index == pass_index and (not order or order[-1] != r.line):
            order.append(r.line)
    n = len(order)
    if n < 3 or sorted(order) != list(range(min(order), min(order) + n)):
        return False
    k = [x - min(order) for x in order]
    if k[0] != 0:
        k = [n - 1 - x for x in k]
    want = list(range(0, n, 2)) + [i for i in range(n - 1, 0, -1) if i % 2]
    return k == want


def survey_items(plan: Plan, m: Mission, first_station: int = 0, last_station: int | None = None) -> tuple[QgcSurvey, ...]:
    """A Survey item for each of the mission's pass blocks; the mission flies stations
    `first_station`..`last_station` (flight order) of the plan (a sortie flies a part)."""
    last_station = len(plan.stations.ids) - 1 if last_station is None else last_station
    spec, cam = plan.spec, plan.spec.camera.camera
    run_ids = [ids.run_id(r.pass_index, r.line, r.part) for r in plan.route.runs]
    station_run = np.asarray(plan.stations.run)[first_station:last_station + 1]
    if plan.altitude_frame == "terrain":
        mode = DISTANCE_TERRAIN_FRAME
    elif plan.heights.mode == "follow":
        mode = DISTANCE_CALC_ABOVE_TERRAIN
    else:
        mode = DISTANCE_RELATIVE
    out = []
    geometry: dict[int, tuple[_Fit, float, int, bool]] = {}
    for p, a, b in survey_blocks(m):
        if p not in geometry:
            geometry[p] = survey_geometry(plan, p)
        fit, grown, entry, alternate = geometry[p]
        spacing = fit.spacing
        items = m.items[a:b + 1]
        tags = {it.tag.split(":")[0] for it in items}
        runs = [k for k, rid in enumerate(run_ids) if rid in tags]
        shots = int(np.isin(station_run, runs).sum())
        line_alts = [it.z for it in items if it.command == mav.NAV_WAYPOINT and ids.pass_of(it.tag) is not None]
        distance = line_alts[0] if mode == DISTANCE_RELATIVE else plan.heights.nominal_agl_m
        gsd_cm = distance * cam.sensor_width_mm * 100.0 / (cam.image_width_px * cam.focal_mm)
        landscape = spec.camera.mount == "landscape"
        side_px, front_px = (cam.image_width_px, cam.image_height_px) if landscape else (cam.image_height_px, cam.image_width_px)
        trigger = plan.trigger_distance_m if plan.trigger_distance_m is not None else plan.base_m
        camera = QgcCamera(cam.sensor_width_mm, cam.sensor_height_mm, cam.image_width_px, cam.image_height_px, cam.focal_mm,
                           landscape, cam.min_cycle_s, gsd_cm,
                           100.0 * (1.0 - trigger / (front_px * gsd_cm / 100.0)),
                           100.0 * (1.0 - spacing / (side_px * gsd_cm / 100.0)))
        out.append(QgcSurvey(
            first=a, last=b, pass_index=p, polygon=tuple((float(lat), float(lon)) for lon, lat in fit.ring), grown_m=grown,
            angle_deg=fit.angle, entry_location=entry, fly_alternate=alternate, spacing_m=spacing, trigger_m=trigger,
            turnaround_m=plan.lead_in_m, distance_m=distance, distance_mode=mode, hover=spec.camera.trigger == "hover",
            camera_shots=shots, camera=camera, terrain_tolerance_m=spec.terrain.tolerance_m if mode == DISTANCE_CALC_ABOVE_TERRAIN else 0.0,
            max_climb_ms=spec.vehicle.climb_rate_ms, max_descent_ms=spec.vehicle.descent_rate_ms,
            flight_speed_ms=plan.speed.speed_ms,
            visual_points=tuple((it.x, it.y) for it in items if it.has_position),
        ))
    return tuple(out)
