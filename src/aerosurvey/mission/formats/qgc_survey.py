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
from pyproj import Transformer

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
#: Newton steps refining the polygon's outer margins after a grid search (they put QGroundControl's line grid on ours)
_ROUNDS = 4


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


def _clamp90(a: float) -> float:
    """A line's bearing as QGroundControl keeps it, in [-90, 90) (a line has two directions)."""
    return (a + 90.0) % 180.0 - 90.0


def _fold(v: float, s: float) -> float:
    """`v` modulo `s`, in [-s/2, s/2)."""
    return (v + s / 2.0) % s - s / 2.0


@dataclass(frozen=True)
class _PassLines:
    """A pass's lines as flown: per line (by line number), the lon/lat where the camera is
    switched on and off on each of its runs; and how the pass starts."""

    numbers: np.ndarray  # line numbers, ascending
    points: list[np.ndarray]  # per line, (n, 2) lon/lat of its runs' starts and ends
    first_run: tuple[np.ndarray, np.ndarray]  # lon/lat of the first run's start and end
    first_line: int  # position in `numbers` of the line flown first


def _pass_lines(plan: Plan, pass_index: int) -> _PassLines:
    runs = plan.route.runs
    ends: dict[int, list[tuple[float, float]]] = {}
    first: dict[int, tuple[float, float]] = {}
    first_run = -1
    for w in plan.waypoints:
        if w.kind in ("line_start", "line_end") and runs[w.run].pass_index == pass_index:
            ends.setdefault(runs[w.run].line, []).append((w.lon, w.lat))
            if first_run < 0:
                first_run = w.run
            if w.run == first_run:
                first[0 if w.kind == "line_start" else 1] = (w.lon, w.lat)
    numbers = np.array(sorted(ends))
    return _PassLines(numbers, [np.array(ends[k]) for k in numbers], (np.array(first[0]), np.array(first[1])),
                      int(np.searchsorted(numbers, runs[first_run].line)))


@dataclass(frozen=True)
class _Strips:
    """A pass's lines on QGroundControl's plane: what the strips polygon is drawn from."""

    angle: float  # compass bearing of the lines, in [-90, 90)
    along: np.ndarray  # unit vector (east, north) along the bearing
    across: np.ndarray  # unit vector towards the bearing + 90°: the order QGroundControl lays its lines in
    v: np.ndarray  # each line's offset across, ascending
    lo: np.ndarray  # where its runs start and end, along
    hi: np.ndarray
    spacing: float
    reverse_points: bool  # our first run flies along the bearing (QGroundControl's lines run against it here)
    reverse_lines: bool  # our first line is the last of QGroundControl's


def _strips(plan: Plan, lines: _PassLines, tr: Transformer) -> _Strips:
    pts = [np.column_stack(tr.transform(p[:, 0], p[:, 1])) for p in lines.points]
    start, end = (np.array(tr.transform(*q)) for q in lines.first_run)
    longest = max(pts, key=lambda p: float(np.ptp(p[:, 0]) ** 2 + np.ptp(p[:, 1]) ** 2))
    d = longest[np.argmax(longest @ (end - start))] - longest[np.argmin(longest @ (end - start))]
    angle = _clamp90(math.degrees(math.atan2(d[0], d[1])))
    a = math.radians(angle)
    along, across = np.array([math.sin(a), math.cos(a)]), np.array([math.cos(a), -math.sin(a)])
    v = np.array([float(np.mean(p @ across)) for p in pts])
    order = np.argsort(v)
    lo = np.array([float((pts[k] @ along).min()) for k in order])
    hi = np.array([float((pts[k] @ along).max()) for k in order])
    # the spacing the lines lie at on this plane: a least-squares line through their offsets by line number
    spacing = abs(float(np.polyfit(lines.numbers[order], v[order], 1)[0])) if len(v) > 1 else plan.spacing_m
    first_pos = int(np.flatnonzero(order == lines.first_line)[0])
    return _Strips(angle, along, across, v[order], lo, hi, spacing, float((end - start) @ along) > 0.0,
                   len(v) > 1 and first_pos == len(v) - 1)


def _ring(st: _Strips, margins: tuple[float, float]) -> np.ndarray:
    """The strips polygon (east, north), open. Each line's strip reaches half-way to its
    neighbours (`margins` beyond the outer lines) and runs from where its runs start to where
    they end. Vertex 0 is the first line's strip's corner towards the second line (where its
    runs start): it does not move with the margins, and the ring's first edge leads away from
    the first line, so QGroundControl meets the first line's front end (the ring's second last
    edge) before its back end (the closing edge) and runs its lines against the bearing."""
    mid = (st.v[1:] + st.v[:-1]) / 2.0
    below = np.concatenate([[st.v[0] - margins[0]], mid])
    above = np.concatenate([mid, [st.v[-1] + margins[1]]])
    n = len(st.v)
    uv = [(st.lo[0], above[0])]
    for k in range(1, n):
        uv += [(st.lo[k], below[k]), (st.lo[k], above[k])]
    for k in reversed(range(n)):
        uv += [(st.hi[k], above[k]), (st.hi[k], below[k])]
    uv.append((st.lo[0], below[0]))
    return np.array([u * st.along + w * st.across for u, w in uv])


def _grid_errors(st: _Strips, m0: np.ndarray, m1: np.ndarray) -> np.ndarray:
    """How far QGroundControl's grid lies from our lines, across them, folded into ±spacing/2, for
    strips polygons with outer margins `m0`, `m1` (arrays of one shape): its line k lies at
    -h + k·spacing from the centre of the polygon's east-north box, h = (the box's larger side
    + 2000 m) / 2. Only the outer line's corners move with the margins."""
    fixed = _ring(st, (0.0, 0.0))
    m0, m1 = np.asarray(m0, float)[..., None], np.asarray(m1, float)[..., None]
    # the corners (east, north) on the margins: the first line's two, at v0 - m0; the last line's two, at v_last + m1
    corners = [st.lo[0] * st.along + (st.v[0] - m0) * st.across[None], st.hi[0] * st.along + (st.v[0] - m0) * st.across[None],
               st.lo[-1] * st.along + (st.v[-1] + m1) * st.across[None], st.hi[-1] * st.along + (st.v[-1] + m1) * st.across[None]]
    pts = np.stack(np.broadcast_arrays(*corners), axis=-2)  # (..., 4, 2)
    lo = np.minimum(pts.min(axis=-2), fixed.min(axis=0))
    hi = np.maximum(pts.max(axis=-2), fixed.max(axis=0))
    centre = (lo + hi) / 2.0
    half = ((hi - lo).max(axis=-1) + QGC_LINE_MARGIN_M) / 2.0
    off = st.v - (centre @ st.across)[..., None] + half[..., None]
    s = st.spacing
    each = (off + s / 2.0) % s - s / 2.0
    return np.asarray((each.mean(axis=-1) + s / 2.0) % s - s / 2.0, float)


def _grid_error(st: _Strips, margins: tuple[float, float]) -> float:
    """`_grid_errors` for one polygon."""
    return float(_grid_errors(st, np.array([margins[0]]), np.array([margins[1]]))[0])


@lru_cache(maxsize=16)
def survey_geometry(plan: Plan, pass_index: int) -> tuple[np.ndarray, _Strips]:
    """The polygon (lon/lat, open, vertex 0 the origin of QGroundControl's plane) and the
    lines QGroundControl regenerates a pass from.

    The polygon is the ground the pass's lines are flown over, one strip per line (`_ring`):
    each of QGroundControl's lines then crosses its own strip's two ends, where our runs start
    and end. The margins beyond the outer lines (under one spacing, so no extra line fits) are
    chosen so that QGroundControl's line grid falls on our lines: they move and widen the
    polygon's east-north box, which QGroundControl starts its grid from. One line stays in the
    middle of its strip (QGroundControl lays a single line through the box's centre)."""
    lines = _pass_lines(plan, pass_index)
    origin = lines.points[0][0]
    for _ in range(3):  # the plane's origin is vertex 0, which depends a little on the bearing measured on it
        tr = _to_tangent(float(origin[1]), float(origin[0]))
        st = _strips(plan, lines, tr)
        e, n = _ring(st, (0.45 * st.spacing, 0.45 * st.spacing))[0]
        origin = np.array(tr.transform(e, n, direction="INVERSE"))
    s = st.spacing
    margins = (0.45 * s, 0.45 * s)
    if len(st.v) > 1:
        grid = np.linspace(0.02 * s, 0.98 * s, 97)
        g0, g1 = np.meshgrid(grid, grid, indexing="ij")
        err = np.abs(_grid_errors(st, g0, g1))
        i, j = np.unravel_index(int(np.argmin(err)), err.shape)
        margins = (float(grid[i]), float(grid[j]))
        for _ in range(_ROUNDS):  # Newton steps on the margin the error moves most with
            e = _grid_error(st, margins)
            h = 1e-3 * s
            slopes = [(_grid_error(st, (margins[0] + h, margins[1])) - e) / h, (_grid_error(st, (margins[0], margins[1] + h)) - e) / h]
            k = int(np.argmax(np.abs(slopes)))
            if abs(e) < 1e-6 or abs(slopes[k]) < 1e-6:
                break
            m = list(margins)
            m[k] = min(max(m[k] - e / slopes[k], 0.02 * s), 0.98 * s)
            if abs(_grid_error(st, (m[0], m[1]))) >= abs(e):
                break
            margins = (m[0], m[1])
    ring = _ring(st, margins)
    lon, lat = tr.transform(ring[:, 0], ring[:, 1], direction="INVERSE")
    return np.column_stack([lon, lat]), st


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
    for p, a, b in survey_blocks(m):
        ring, fit = survey_geometry(plan, p)
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
            first=a, last=b, pass_index=p, polygon=tuple((float(lat), float(lon)) for lon, lat in ring),
            angle_deg=fit.angle, entry_location=2 * fit.reverse_points + fit.reverse_lines,
            fly_alternate=_alternate(plan, p), spacing_m=spacing, trigger_m=trigger,
            turnaround_m=plan.lead_in_m, distance_m=distance, distance_mode=mode, hover=spec.camera.trigger == "hover",
            camera_shots=shots, camera=camera, terrain_tolerance_m=spec.terrain.tolerance_m if mode == DISTANCE_CALC_ABOVE_TERRAIN else 0.0,
            max_climb_ms=spec.vehicle.climb_rate_ms, max_descent_ms=spec.vehicle.descent_rate_ms,
            flight_speed_ms=plan.speed.speed_ms,
            visual_points=tuple((it.x, it.y) for it in items if it.has_position),
        ))
    return tuple(out)
