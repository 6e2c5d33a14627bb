"""QGroundControl Survey items for a mission's photo passes: which items each one holds and
the settings QGroundControl regenerates the pass from when the pilot edits it; and the one
Structure Scan item of the rings round a structure a flight flies (`QgcStructureScan`, from
the passes' `ring`: docs/clients/qgroundcontrol.md "Structures").

A Survey complex item (SurveyComplexItem, its TransectStyleComplexItem and CameraCalc in
QGroundControl's sources) stores two things: the mission items QGroundControl uploads as they
are while the plan is loaded unedited (`Items`), and the settings its own generator rebuilds
the lines from once anything of the item is edited (polygon, angle, spacing, turnaround,
camera). `survey_blocks` picks the items (each run of items of one pass, with the detours
between its lines); `survey_geometry` chooses the polygon, angle and spacing so that
QGroundControl's generator lays our lines again (docs/clients/qgroundcontrol.md has the
measured differences; tests/independent_qgc.py ports the generator).

How QGroundControl lays its lines (SurveyComplexItem::_rebuildTransectsPhase1WorkerSinglePolygon),
which the choices below follow:
- the polygon is projected onto a plane tangent at its first vertex, x east, y north: up to
  QGroundControl 5.0 an azimuthal equidistant projection on a sphere of the WGS84 equatorial
  radius ("sphere"), from 5.1 GeographicLib's LocalCartesian on the WGS84 ellipsoid, heights 0
  ("ellipsoid"); the two place a line 1 km from the vertex up to 2.3 m apart, so the file is
  written for one of them (`QGC_FRAMES`, docs/clients/qgroundcontrol.md);
- lines run at the compass bearing `angle`, which it clamps to -90..90 by turning it by 180°;
  line k lies at -h + k·s from the centre of the polygon's east-north bounding box, measured
  towards the bearing angle + 90°, with s the spacing (CameraCalc's AdjustedFootprintSide) and
  h = (max(box width, box height) + 2000 m) / 2;
- each line is cut to the two farthest crossings with the polygon's edges, directed from the
  crossing on the edge listed first; all lines take the first line's direction;
- `entryLocation` reverses the points of every line (2, 3) and/or the order of the lines (1, 3),
  then every second line is reversed (a lawnmower).

So the polygon written is the ground our lines are flown over, one strip per line from where
its runs start to where they end, with thin rails beyond the outer lines whose distance from
them puts QGroundControl's grid on our lines (`_ring`, `survey_geometry`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace
from functools import lru_cache
from types import MappingProxyType

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
#: the sphere QGroundControl up to 5.0 projects on (QGCGeo::convertGeoToNed: GeographicLib's WGS84_a)
QGC_SPHERE_M = 6378137.0
#: QGroundControl's plane (QGCGeo::convertGeoToNed) by the file layout written for it (`aerosurvey plan --qgc`)
QGC_FRAMES = MappingProxyType({"survey": "ellipsoid", "survey-5.0": "sphere"})
#: QGroundControl lengthens its lines by this much beyond the polygon's bounding box
QGC_LINE_MARGIN_M = 2000.0


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
    polygon: tuple[tuple[float, float], ...]  # (latitude, longitude), open ring, vertex 0 the projection's origin; () for a corridor
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
    # a corridor's pass: a Corridor Scan item (its polyline and width; polygon, angle and alternate unused)
    corridor_polyline: tuple[tuple[float, float], ...] = ()  # (latitude, longitude)
    corridor_width_m: float = 0.0


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
def tangent_plane(lat0: float, lon0: float, frame: str) -> Transformer:
    """lon/lat -> metres east/north on QGroundControl's plane `frame` (a value of QGC_FRAMES) at (lat0, lon0):
    QGCGeo::convertGeoToNed."""
    if frame == "sphere":
        return Transformer.from_crs("EPSG:4326", f"+proj=aeqd +lat_0={float(lat0)!r} +lon_0={float(lon0)!r} "
                                    f"+R={QGC_SPHERE_M} +units=m +no_defs", always_xy=True)
    if frame == "ellipsoid":  # LocalCartesian: geocentric, then east-north-up at the origin; heights 0 both ways
        return Transformer.from_pipeline(
            "+proj=pipeline +step +proj=unitconvert +xy_in=deg +xy_out=rad +step +proj=cart +ellps=WGS84 "
            f"+step +proj=topocentric +ellps=WGS84 +lat_0={float(lat0)!r} +lon_0={float(lon0)!r} +h_0=0")
    raise ValueError(f"QGroundControl frame {frame!r}: one of {', '.join(sorted(set(QGC_FRAMES.values())))}")


@dataclass(frozen=True)
class _PassLines:
    """A pass's lines as flown: the lon/lat where the camera is switched on and off on each run,
    grouped by line (line numbers ascending, each line's points from `starts[k]` on); and how
    the pass starts."""

    numbers: np.ndarray  # line numbers, ascending
    points: np.ndarray  # (n, 2) lon/lat of the runs' starts and ends, line after line
    starts: np.ndarray  # index in `points` of each line's first point
    first_run: tuple[np.ndarray, np.ndarray]  # lon/lat of the first run's start and end
    first_line: int  # position in `numbers` of the line flown first


def _pass_lines(plan: Plan, pass_index: int, flown: frozenset[int]) -> _PassLines:
    """The lines of the pass's runs in `flown` (run indices)."""
    runs = plan.route.runs
    ends: dict[int, list[tuple[float, float]]] = {}
    first: dict[int, tuple[float, float]] = {}
    first_run = -1
    for w in plan.waypoints:
        if w.kind in ("line_start", "line_end") and w.run in flown and runs[w.run].pass_index == pass_index:
            ends.setdefault(runs[w.run].line, []).append((w.lon, w.lat))
            if first_run < 0:
                first_run = w.run
            if w.run == first_run:
                first[0 if w.kind == "line_start" else 1] = (w.lon, w.lat)
    numbers = np.array(sorted(ends))
    counts = [len(ends[k]) for k in numbers]
    return _PassLines(numbers, np.array([p for k in numbers for p in ends[k]]), np.cumsum([0, *counts[:-1]]),
                      (np.array(first[0]), np.array(first[1])), int(np.searchsorted(numbers, runs[first_run].line)))


@dataclass(frozen=True)
class _Strips:
    """A pass's lines on QGroundControl's plane, along and across the direction our first run
    flies: what the strips polygon is drawn from."""

    angle: float  # the bearing written: our first run's, in -90..90 as QGroundControl keeps it
    sign: float  # +1 when that is our first run's bearing, -1 when it is the opposite one
    along: np.ndarray  # unit vector (east, north) our first run flies along
    across: np.ndarray  # unit vector 90° to its right
    v: np.ndarray  # each line's offset across, ascending
    lo: np.ndarray  # where its runs start and end, along
    hi: np.ndarray
    spacing: float
    reverse_lines: bool  # our first line is the last of QGroundControl's (it lays them along sign·across)

    @property
    def reverse_points(self) -> bool:
        """QGroundControl's lines run against our first run (see `_ring`): it meets the first line's
        front end first when its first line is ours (sign +1, or a single line); our last line's
        back end first otherwise."""
        return self.sign > 0 or len(self.v) == 1


def _strips(plan: Plan, lines: _PassLines, tr: Transformer) -> _Strips:
    en = np.column_stack(tr.transform(lines.points[:, 0], lines.points[:, 1]))  # every line's points in one transform
    start, end = (np.array(tr.transform(*q)) for q in lines.first_run)
    at = lines.starts  # each line's points: en[at[k]:at[k + 1]] (per-line statistics by reduceat)
    extent = np.maximum.reduceat(en, at) - np.minimum.reduceat(en, at)
    k = int(np.argmax((extent ** 2).sum(axis=1)))  # the longest line
    longest = en[at[k]:at[k + 1] if k + 1 < len(at) else len(en)]
    d = longest[np.argmax(longest @ (end - start))] - longest[np.argmin(longest @ (end - start))]
    bearing = math.degrees(math.atan2(d[0], d[1]))
    # SurveyComplexItem::_clampGridAngle90 keeps -90..90 and turns the rest by 180°
    angle = bearing - 180.0 if bearing > 90.0 else bearing + 180.0 if bearing < -90.0 else bearing
    a = math.radians(bearing)
    along, across = np.array([math.sin(a), math.cos(a)]), np.array([math.cos(a), -math.sin(a)])
    v = np.add.reduceat(en @ across, at) / np.diff([*at, len(en)])  # each line's mean offset across
    order = np.argsort(v)
    u = en @ along
    lo, hi = np.minimum.reduceat(u, at)[order], np.maximum.reduceat(u, at)[order]
    # the spacing the lines lie at on this plane: a least-squares line through their offsets by line number
    spacing = abs(float(np.polyfit(lines.numbers[order], v[order], 1)[0])) if len(v) > 1 else plan.sensor.spacing_m
    sign = 1.0 if angle == bearing else -1.0
    first_pos = int(np.flatnonzero(order == lines.first_line)[0])
    last = len(v) - 1 if sign > 0 else 0
    return _Strips(angle, sign, along, across, v[order], lo, hi, spacing, len(v) > 1 and first_pos == last)


#: a rail is this share of its margin wide; the outer line's strip fills the rest
_RAIL = 0.1
#: the margins stay within this share of a spacing from 0 and from a whole spacing
_MARGIN_MIN = 0.01


def _ring(st: _Strips, margins: tuple[float, float], tail: float = 0.0) -> np.ndarray:
    """The strips polygon (east, north), open.

    Each line's strip reaches half-way to its neighbours and runs from where its runs start
    to where they end. Beyond each outer line, `margins` away (less than a spacing, so no
    other line of QGroundControl's fits), a thin rail runs the whole length of the pass; the
    outer line's strip reaches to the rail. The rails' outer corners bound the polygon: its
    east-north box, which QGroundControl starts its line grid from, is theirs. The first rail
    reaches `tail` further back than the pass.

    Vertex 0 is the first line's strip's back corner towards the second line (it does not move
    with the margins). The first line's front end is an edge before its back end (the closing
    edge), and the last line's back end one before its front end: QGroundControl, which turns
    every line the way its first one runs, runs them against our first run when its first line
    is our first line, along it when it is our last."""
    m0, m1 = margins
    u_lo, u_hi = float(st.lo.min()), float(st.hi.max())
    mid = (st.v[1:] + st.v[:-1]) / 2.0
    below = np.concatenate([[st.v[0] - (1.0 - _RAIL) * m0], mid])
    above = np.concatenate([mid, [st.v[-1] + (1.0 - _RAIL) * m1]])
    bottom, top = st.v[0] - m0, st.v[-1] + m1
    uv = [(st.lo[0], above[0])]
    for k in range(1, len(st.v)):
        uv += [(st.lo[k], below[k]), (st.lo[k], above[k])]
    uv += [(u_lo, above[-1]), (u_lo, top), (u_hi, top), (u_hi, above[-1])]
    for k in reversed(range(len(st.v))):
        uv += [(st.hi[k], above[k]), (st.hi[k], below[k])]
    uv += [(u_hi, below[0]), (u_hi, bottom), (u_lo - tail, bottom), (u_lo - tail, below[0]), (st.lo[0], below[0])]
    pts = np.array(uv)
    pts = pts[np.concatenate([[True], np.abs(np.diff(pts, axis=0)).max(axis=1) > 1e-6])]  # no repeated vertex
    return np.asarray(pts[:, :1] * st.along + pts[:, 1:] * st.across, float)


def _grid_offsets(st: _Strips, m0: np.ndarray, m1: np.ndarray, tail: np.ndarray) -> np.ndarray:
    """Where QGroundControl's nearest line lies from our first line, across the lines (+ towards
    the bearing + 90°), folded into ±spacing/2, for margins `m0`, `m1` and a first rail's `tail`
    (arrays of one shape): its line k lies at -h + k·spacing from the centre of the polygon's
    east-north box, h = (the box's larger side + 2000 m) / 2; the box is that of the rails'
    four outer corners and the first rail's tail (every other vertex lies between them)."""
    u_lo, u_hi = float(st.lo.min()), float(st.hi.max())
    bottom, top = st.v[0] - np.asarray(m0, float), st.v[-1] + np.asarray(m1, float)
    back = u_lo - np.asarray(tail, float)
    uv = [(back, bottom), (back, st.v[0] - (1.0 - _RAIL) * np.asarray(m0, float)), (u_hi, bottom), (u_lo, top), (u_hi, top)]
    # the corners' east and north, corner by corner along axis 0 (the box: their min and max over it)
    east = np.stack(np.broadcast_arrays(*[u * st.along[0] + w * st.across[0] for u, w in uv]))
    north = np.stack(np.broadcast_arrays(*[u * st.along[1] + w * st.across[1] for u, w in uv]))
    e_lo, e_hi, n_lo, n_hi = east.min(axis=0), east.max(axis=0), north.min(axis=0), north.max(axis=0)
    centre_across = (e_lo + e_hi) / 2.0 * st.across[0] + (n_lo + n_hi) / 2.0 * st.across[1]
    half = (np.maximum(e_hi - e_lo, n_hi - n_lo) + QGC_LINE_MARGIN_M) / 2.0
    s = st.spacing
    # QGroundControl lays its lines along sign·across from the box's centre: line k at sign·(-h + k·spacing)
    return np.asarray((centre_across - st.sign * half - st.v[0] + s / 2.0) % s - s / 2.0, float)


def _clear(r: np.ndarray, m0: np.ndarray, m1: np.ndarray, s: float) -> np.ndarray:
    """True where QGroundControl's lines, `r` off ours, cross our outer lines' strips and not
    the rails, and its next lines out miss the polygon (a 0.2 %-of-a-spacing safety each)."""
    safe = 0.002 * s
    return np.asarray((r > -(1.0 - _RAIL) * m0 + safe) & (r < (1.0 - _RAIL) * m1 - safe)
                      & (r < s - m0 - safe) & (r > m1 - s + safe), bool)


def survey_geometry(plan: Plan, pass_index: int, frame: str,
                    flown: frozenset[int] | None = None) -> tuple[np.ndarray, _Strips]:
    """The polygon (lon/lat, open, vertex 0 the origin of QGroundControl's plane `frame`) and the
    lines QGroundControl regenerates a pass from: all of its runs, or those in `flown` (run
    indices: a sortie's).

    The polygon is the ground the pass's lines are flown over, one strip per line, with a rail
    beyond each outer line (`_ring`): each of QGroundControl's lines crosses its own strip's
    two ends, where our runs start and end. The margins to the rails place QGroundControl's
    line grid on our lines: widening one and narrowing the other by t moves the polygon's box,
    and the grid, by t; widening both, or a tail on the first rail, moves it when the box's
    larger side runs across, or along, the lines. They stay between 1 % and 99 % of a spacing,
    and the lines clear of the rails.
    Where no margins put the grid on our lines, it is left as near as they put it."""
    lines = _pass_lines(plan, pass_index, frozenset(range(len(plan.route.runs))) if flown is None else flown)
    origin = lines.points[0]
    for _ in range(3):  # the plane's origin is vertex 0, which depends a little on the bearing measured on it
        tr = tangent_plane(float(origin[1]), float(origin[0]), frame)
        st = _strips(plan, lines, tr)
        e, n = _ring(st, (st.spacing / 2.0, st.spacing / 2.0))[0]
        vertex0 = np.array(tr.transform(e, n, direction="INVERSE"))
        if float(np.abs(vertex0 - origin).max()) < 1e-9:  # within 0.1 mm of this plane's origin: settled
            break
        origin = vertex0
    ring = _ring(st, *_rails(st))
    lon, lat = tr.transform(ring[:, 0], ring[:, 1], direction="INVERSE")
    return np.column_stack([lon, lat]), st


def _rails(st: _Strips) -> tuple[tuple[float, float], float]:
    """The margins to the rails and the first rail's tail that put QGroundControl's grid on our
    lines (`survey_geometry`): a search over a grid of them, then Newton steps on the margins."""
    s = st.spacing
    m0, m1, tail = np.array([s / 2.0]), np.array([s / 2.0]), np.array([0.0])
    if len(st.v) > 1:  # one line: QGroundControl lays it through the box's centre, the middle of its strip
        # margins m ± t move the grid by -t; a wider m, or a tail on the first rail, widen the box,
        # which moves the grid when its larger side runs across, or along, the lines
        lo, hi = _MARGIN_MIN * s, (1.0 - _MARGIN_MIN) * s
        # a box whose larger side runs across the lines starts the grid at its across edge: a rail
        # edge, whatever the margins, when the lines run north-south or east-west; tails that
        # make the along side the larger one free it
        ring = _ring(st, (s / 2.0, s / 2.0))
        a = math.radians(st.angle)
        along_side = float(np.ptp(ring @ st.along)) * max(abs(math.sin(a)), abs(math.cos(a)))
        longer = max(float(np.ptp(ring[:, 0])), float(np.ptp(ring[:, 1])))
        tails = np.concatenate([[0.0, 0.125, 0.25, 0.5, 1.0],
                                max(longer - along_side, 0.0) / s + np.array([0.25, 0.5, 1.0, 1.5, 2.0])]) * s
        m = np.repeat(np.linspace(lo, hi, 25), len(tails))[:, None]
        tail = np.tile(tails, 25)[:, None]
        r0 = _grid_offsets(st, m, m, tail)
        reach = np.minimum(m - lo, hi - m)
        t = np.concatenate([r0 + k * s for k in (-1, 0, 1)] + [np.linspace(-1.0, 1.0, 41)[None, :] * reach], axis=1)
        t = np.where(np.abs(t) <= reach, t, 0.0)
        m0, m1, tail = (m + t).ravel(), (m - t).ravel(), np.broadcast_to(tail, t.shape).ravel()
    r = _grid_offsets(st, m0, m1, tail)
    clear = _clear(r, m0, m1, s)
    # the grid nearest our lines, then the smallest tail and the most even margins
    best = int(np.argmin(np.where(clear, np.abs(r), np.abs(r) + s) + 1e-9 * (np.abs(m0 - m1) + tail)))
    a, b, c = float(m0[best]), float(m1[best]), float(tail[best])
    for _ in range(3 if len(st.v) > 1 else 0):  # Newton steps on t: a tail's corner can make the grid move by a little less than t
        e = float(_grid_offsets(st, np.array(a), np.array(b), np.array(c)))
        slope = (float(_grid_offsets(st, np.array(a + 1e-3), np.array(b - 1e-3), np.array(c))) - e) / 1e-3
        if abs(e) < 1e-6 or abs(slope) < 0.1:
            break
        step = -e / slope
        na, nb = a + step, b - step
        ne = float(_grid_offsets(st, np.array(na), np.array(nb), np.array(c)))
        if not (_MARGIN_MIN * s <= min(na, nb) and max(na, nb) <= (1.0 - _MARGIN_MIN) * s and abs(ne) < abs(e)
                and bool(_clear(np.array(ne), np.array(na), np.array(nb), s))):
            break
        a, b = na, nb
    return (a, b), c


def _alternate(plan: Plan, pass_index: int, flown: frozenset[int]) -> bool:
    """True when our lines (of the runs in `flown`) are flown in QGroundControl's alternate
    order: every second line one way, then the skipped ones on the way back."""
    order: list[int] = []
    for j, r in enumerate(plan.route.runs):
        if j in flown and r.pass_index == pass_index and (not order or order[-1] != r.line):
            order.append(r.line)
    n = len(order)
    if n < 3 or sorted(order) != list(range(min(order), min(order) + n)):
        return False
    k = [x - min(order) for x in order]
    if k[0] != 0:
        k = [n - 1 - x for x in k]
    want = list(range(0, n, 2)) + [i for i in range(n - 1, 0, -1) if i % 2]
    return k == want


def _run_paths(plan: Plan, pass_index: int, flown: frozenset[int]) -> dict[tuple[int, int], np.ndarray]:
    """(line, part) → lon/lat of the waypoints of each run in `flown` from where its camera is
    switched on to where it is switched off (its start, bends, end)."""
    runs = plan.route.runs
    paths: dict[tuple[int, int], list[tuple[float, float]]] = {}
    for w in plan.waypoints:
        r = runs[w.run] if w.run in flown else None
        if r is not None and r.pass_index == pass_index and w.kind in ("line_start", "bend", "line_end"):
            paths.setdefault((r.line, r.part), []).append((w.lon, w.lat))
    return {k: np.array(v) for k, v in paths.items()}


def _cross_point(a0: np.ndarray, a1: np.ndarray, b0: np.ndarray, b1: np.ndarray) -> np.ndarray:
    """Where the line through a0, a1 meets the line through b0, b1 (their mid-point when parallel)."""
    da, db = a1 - a0, b1 - b0
    den = da[0] * db[1] - da[1] * db[0]
    if abs(den) < 1e-9 * float(np.hypot(*da) * np.hypot(*db)):
        return np.asarray((a1 + b0) / 2.0, float)
    t = ((b0[0] - a0[0]) * db[1] - (b0[1] - a0[1]) * db[0]) / den
    return np.asarray(a0 + t * da, float)


def corridor_geometry(plan: Plan, pass_index: int, frame: str,
                      flown: frozenset[int] | None = None) -> tuple[np.ndarray, float, float, int] | None:
    """(polyline lon/lat, corridor width, spacing, entry point) of a Corridor Scan item for a
    corridor's pass (its runs in `flown`, run indices: all when None), on QGroundControl's plane
    `frame`, or None when its strips are not the offsets of one polyline.

    QGroundControl (CorridorScanComplexItem::_rebuildTransectsPhase1) flies ⌈width / spacing⌉
    transects, the polyline offset to the left by width/2 - spacing/2 - k·spacing (k = 0 … ;
    QGCMapPolyline::offsetPolyline, mitred), each through every vertex, every second one
    reversed; `EntryPoint` 1 starts at the right, 2 at the polyline's end. Our strips are the
    centreline offset to a line's ordinate, mitred too, each split into parts at sharp bends
    (each part runs on past the bend). The polyline written is the middle of our strips: per
    part, the mean of the lines' paths (vertex for vertex), the parts joined where their
    middles' end segments meet; the width is the lines' count times their spacing."""
    paths = _run_paths(plan, pass_index, frozenset(range(len(plan.route.runs))) if flown is None else flown)
    lines = sorted({ln for ln, _ in paths})
    parts = sorted({pt for _, pt in paths})
    if any((ln, pt) not in paths for ln in lines for pt in parts):
        return None
    origin = paths[(lines[0], parts[0])][0]
    tr = tangent_plane(float(origin[1]), float(origin[0]), frame)
    en = {k: np.column_stack(tr.transform(v[:, 0], v[:, 1])) for k, v in paths.items()}
    pieces = []  # per part, the middle of the lines' paths, each the way the first line's path of that part runs
    for pt in parts:
        ref = en[(lines[0], pt)]
        same_way = [v if float((v[-1] - v[0]) @ (ref[-1] - ref[0])) > 0 else v[::-1] for v in (en[(ln, pt)] for ln in lines)]
        if len({len(v) for v in same_way}) != 1:
            return None
        pieces.append(np.mean(same_way, axis=0))
    # each line's offset to the left of the first part's middle (by its chord)
    chord = pieces[0][-1] - pieces[0][0]
    left = np.array([-chord[1], chord[0]]) / float(np.hypot(*chord))
    offsets = np.array([float((en[(ln, parts[0])].mean(axis=0) - pieces[0].mean(axis=0)) @ left) for ln in lines])
    # joined in the order the first line flies its parts (each piece runs its way)
    flight = [pieces[parts.index(r.part)] for k, r in enumerate(plan.route.runs)
              if r.pass_index == pass_index and r.line == lines[0] and (flown is None or k in flown)]
    line = [flight[0][:-1]]
    for a, b in zip(flight[:-1], flight[1:], strict=True):
        line += [_cross_point(a[-2], a[-1], b[0], b[1])[None, :], b[1:-1]]
    polyline = np.concatenate([*line, flight[-1][-1:]])
    first = plan.route.runs[next(k for k, r in enumerate(plan.route.runs)
                                 if r.pass_index == pass_index and (flown is None or k in flown))]
    first_path = en[(first.line, first.part)]
    piece = pieces[parts.index(first.part)]
    if float((first_path[-1] - first_path[0]) @ (piece[-1] - piece[0])) < 0:  # the polyline runs the way our first run flies
        polyline, offsets = polyline[::-1], -offsets
    spacing = float(np.median(np.abs(np.diff(offsets)))) if len(lines) > 1 else plan.sensor.spacing_m
    # QGroundControl's first transect is its leftmost (EntryPoint 0); ours starts on the first line flown
    entry = 0 if offsets[lines.index(first.line)] >= offsets.max() - spacing / 2.0 else 1
    lon, lat = tr.transform(polyline[:, 0], polyline[:, 1], direction="INVERSE")
    # QGroundControl flies ⌈width / spacing⌉ transects: a hair under our lines' count times the spacing
    return np.column_stack([lon, lat]), len(lines) * spacing * (1.0 - 1e-9), spacing, entry


#: how far below the top of the layers' span a Structure Scan's StructureHeight is written (so
#: QGroundControl's layer count, ⌈(height − bottom) / layer⌉, cannot round up to one layer more)
_SPAN_SHORT_M = 0.001


@dataclass(frozen=True)
class QgcStructureScan:
    """One Structure Scan item (StructureScanComplexItem): the flight's rings round a structure.

    QGroundControl stores no items for it: it flies what it generates from these settings
    (`appendMissionItems`): the structure polygon offset `standoff_m` outwards (each edge moved
    to its left on its plane, consecutive edges met: `offset_polygon`), an entrance waypoint at
    its vertex 0 at `entrance_m`, the camera turned 90° right of the next waypoint at
    `pitch_deg`, then per layer the vertices from 0 round to 0 again with the distance trigger
    (`trigger_m`, AdjustedFootprintSide) on after the first, layers `layer_m`
    (AdjustedFootprintFrontal) apart from half a layer above `bottom_m`, or below `height_m`
    when `from_top`, ⌈(height − bottom) / layer⌉ of them, then the exit at vertex 0."""

    first: int  # items first..last of Mission.items: the flight's ring passes, one after another
    last: int
    passes: tuple[int, ...]  # in flight order
    polygon: tuple[tuple[float, float], ...]  # (latitude, longitude), open, clockwise seen from above
    standoff_m: float  # DistanceToSurface: the ring's distance from the polygon (`_structure_polygon`)
    layer_m: float
    trigger_m: float
    bottom_m: float  # ScanBottomAlt, above home
    height_m: float  # StructureHeight, above home
    layers: int
    from_top: bool
    entrance_m: float
    pitch_deg: float
    camera: QgcCamera
    camera_shots: int


def offset_polygon(en: np.ndarray, d: float) -> np.ndarray:
    """QGCMapPolygon::offset on its plane: each edge of the open ring `en` (east, north) moved
    `d` to its left (outwards for a clockwise ring), vertex i where the moved edges i − 1 and i
    meet. Offsetting by −d undoes offsetting by d: each moved edge lies on its own line again."""
    a = np.asarray(en, float)
    t = np.roll(a, -1, axis=0) - a
    t = t / np.hypot(t[:, 0], t[:, 1])[:, None]
    left = np.column_stack([-t[:, 1], t[:, 0]])
    p = a + d * left  # a point of each moved edge i, its direction t[i]
    q, u = np.roll(p, 1, axis=0), np.roll(t, 1, axis=0)  # edge i − 1
    den = u[:, 0] * t[:, 1] - u[:, 1] * t[:, 0]
    k = ((p[:, 0] - q[:, 0]) * t[:, 1] - (p[:, 1] - q[:, 1]) * t[:, 0]) / den
    out: np.ndarray = q + k[:, None] * u
    return out


#: the share of the largest inset a ring's chords allow that its structure polygon is inset by
_INSET_SHARE = 0.99


def _inset(en: np.ndarray, standoff: float) -> float | None:
    """How far inside the ring `en` (open, clockwise, on QGroundControl's plane) its structure
    polygon lies: the stand-off, or less where the ring rounds a corner in chords: moving the
    edges in by s shortens an edge of length L between turns φ1, φ2 (right, positive) by
    s·(tan(φ1/2) + tan(φ2/2)), so the inset stays a share (`_INSET_SHARE`) of the least s that
    makes an edge vanish, and every edge of the polygon keeps its direction (QGroundControl's
    offset moves each edge to its left: an edge turned round would move the wrong way). None when
    two edges in a row are parallel (QGroundControl's offset stops there)."""
    t = np.roll(en, -1, axis=0) - en
    length = np.hypot(t[:, 0], t[:, 1])
    u = t / length[:, None]
    prev = np.roll(u, 1, axis=0)
    cross = prev[:, 0] * u[:, 1] - prev[:, 1] * u[:, 0]  # the turn at each vertex: negative to the right
    if np.any(np.abs(cross) < 1e-9):
        return None
    half = np.tan(np.arctan2(-cross, np.sum(prev * u, axis=1)) / 2.0)  # tan(φ/2), φ the right turn at each vertex
    shrink = half + np.roll(half, -1)  # edge i runs from vertex i to i + 1
    limit = np.where(shrink > 0, length / np.where(shrink > 0, shrink, 1.0), np.inf)
    return float(min(standoff, _INSET_SHARE * float(limit.min())))


def _structure_polygon(ring: np.ndarray, standoff: float, frame: str) -> tuple[np.ndarray, float] | None:
    """The structure polygon (lon/lat, open) and the distance to it (DistanceToSurface) whose
    offset on QGroundControl's plane `frame` (at the polygon's vertex 0) is the ring `ring`
    (lon/lat, open, clockwise): the ring's edges moved in by `_inset` (the stand-off, or a
    hair less where the ring's chords round a corner: 14.67 m for 15 m with 5 chords a
    quarter circle, the polygon's corners rounded by the difference). None where `_inset` is."""
    origin, inset = ring[0], None
    for _ in range(3):  # the plane's origin is vertex 0 of the polygon, which depends a little on the plane
        tr = tangent_plane(float(origin[1]), float(origin[0]), frame)
        en = np.column_stack(tr.transform(ring[:, 0], ring[:, 1]))
        inset = _inset(en, standoff)
        if inset is None:
            return None
        poly = offset_polygon(en, -inset)
        lon, lat = tr.transform(poly[:, 0], poly[:, 1], direction="INVERSE")
        vertex0 = np.array([lon[0], lat[0]])
        if float(np.abs(vertex0 - origin).max()) < 1e-9:
            break
        origin = vertex0
    assert inset is not None
    return np.column_stack([lon, lat]), inset


def _qgc_camera(plan: Plan, distance: float, side_m: float, frontal_m: float) -> QgcCamera:
    """CameraCalc's camera at `distance` from the surface, with the overlaps for which
    QGroundControl's footprint × (1 − overlap) gives `side_m` and `frontal_m`."""
    cam = plan.camera.camera
    gsd_cm = distance * cam.sensor_width_mm * 100.0 / (cam.image_width_px * cam.focal_mm)
    landscape = plan.camera.mount == "landscape"
    side_px, front_px = (cam.image_width_px, cam.image_height_px) if landscape else (cam.image_height_px, cam.image_width_px)
    return QgcCamera(cam.sensor_width_mm, cam.sensor_height_mm, cam.image_width_px, cam.image_height_px, cam.focal_mm,
                     landscape, cam.min_cycle_s, gsd_cm, 100.0 * (1.0 - frontal_m / (front_px * gsd_cm / 100.0)),
                     100.0 * (1.0 - side_m / (side_px * gsd_cm / 100.0)))


def _scan_shape(plan: Plan, passes: list[int], flown: frozenset[int], frame: str) -> QgcStructureScan | str:
    """The Structure Scan item (its items not yet placed: first = last = -1) of the flight's ring
    passes `passes` (pass indices), or why they stay plain items."""
    by_index = {p.index: p for p in plan.layout.passes}
    runs = plan.route.runs
    order = [runs[k].pass_index for k in sorted(flown) if runs[k].pass_index in passes]
    order = [p for i, p in enumerate(order) if i == 0 or order[i - 1] != p]
    first = by_index[order[0]]
    ring = first.ring
    assert ring is not None
    why = "the structure scan: "
    if len(order) != len(set(order)):
        return why + "its rings are not flown one after another, as QGroundControl flies its layers"
    if any(by_index[p].ring is not ring for p in order):
        return why + "the passes go round different rings; QGroundControl's item flies one"
    if any(by_index[p].aim != first.aim for p in order) or first.aim.look != "outline":
        return why + "the camera is not turned to the structure at one pitch, as QGroundControl aims it"
    if plan.altitudes.frame == "terrain" or plan.sensor.heights.mode == "follow":
        return why + "its heights follow the terrain; QGroundControl flies the layers above home"
    if plan.vehicle.firmware == "px4" and mav.DO_SET_ROI_WPNEXT_OFFSET not in mav.PX4_MISSION_FRAME_COMMANDS:
        return why + ("QGroundControl aims its camera with DO_SET_ROI_WPNEXT_OFFSET, which PX4 refuses "
                      "(MAV_MISSION_UNSUPPORTED)")
    xy = ring.path
    if float(np.sum(xy[:, 0] * np.roll(xy[:, 1], -1) - np.roll(xy[:, 0], -1) * xy[:, 1])) > 0:
        return why + "its ring is flown anticlockwise; QGroundControl flies a structure's ring clockwise"
    lon, lat = plan.site.planar.lonlat(xy[:, 0], xy[:, 1])
    found = _structure_polygon(np.column_stack([lon, lat]), ring.standoff_m, frame)
    if found is None:
        return why + "two edges in a row of its ring are parallel, where QGroundControl's offset of a polygon stops"
    polygon, distance = found
    station_run = np.asarray(plan.stations.run)
    z = [float(np.mean(plan.stations.alt_rel_m[np.isin(station_run, [k for k in flown if runs[k].pass_index == p])]))
         for p in order]
    steps = np.diff(z)
    layer = float(np.mean(np.abs(steps))) if len(z) > 1 else plan.sensor.spacing_m
    if len(z) > 1 and (float(np.ptp(np.abs(steps))) > 0.01 or not (np.all(steps > 0) or np.all(steps < 0))):
        return why + "its layers are not evenly spaced one way, as QGroundControl lays them"
    trigger = plan.sensor.trigger_distance_m if plan.sensor.trigger_distance_m is not None else plan.sensor.base_m
    camera = _qgc_camera(plan, distance, trigger, layer)
    if not (0.0 <= camera.frontal_overlap < 100.0 and 0.0 <= camera.side_overlap < 100.0):
        return why + (f"its layers {layer:.2f} m and photos {trigger:.2f} m apart need overlaps {camera.frontal_overlap:.0f} "
                      f"and {camera.side_overlap:.0f} % of a square-on photo, outside QGroundControl's 0-100 %")
    bottom = min(z) - layer / 2.0
    shots = int(np.isin(station_run, [k for k in flown if runs[k].pass_index in order]).sum())
    return QgcStructureScan(-1, -1, tuple(order), tuple((float(b), float(a)) for a, b in polygon), distance, layer,
                            trigger, bottom, bottom + len(z) * layer - _SPAN_SHORT_M, len(z), len(z) > 1 and z[1] < z[0],
                            z[0], first.aim.pitch_deg, camera, shots)


@dataclass(frozen=True)
class PassShape:
    """What one pass's complex item is drawn from: a Survey item's polygon and lines
    (`survey_geometry`), or a Corridor Scan item's polyline, width, spacing and entry
    (`corridor_geometry`); and whether its lines are flown in QGroundControl's alternate order."""

    grid: tuple[np.ndarray, _Strips] | None
    corridor: tuple[np.ndarray, float, float, int] | None
    alternate: bool
    scan: QgcStructureScan | None = None  # a ring pass: the Structure Scan item of all the flight's rings


@dataclass(frozen=True)
class SurveyShapes:
    """The complex items of one flight's .plan (`survey_shapes`): each pass's shape by pass
    index (None: the pass stays plain items, for the reason in `plain`)."""

    passes: Mapping[int, PassShape | None]
    plain: tuple[str, ...]
    first_station: int  # the flight's stations, in flight order
    last_station: int


def survey_shapes(plan: Plan, passes: Iterable[int], frame: str,
                  stations: tuple[int, int] | None = None) -> SurveyShapes:
    """Each of `passes`' complex item shape for a flight of stations `stations` (first, last in
    flight order; the whole mission when None), on QGroundControl's plane `frame`.

    An item holds only what its flight flies: QGroundControl regenerates every line of an
    item's polygon when the pilot edits it, so a sortie's item is drawn from the sortie's own
    runs. A pass stays plain items when its flight flies part of a run (an edit would lay the
    whole line, beyond the sortie's battery), when its lines are not evenly spaced (an oblique
    grid's bands flown as one pass, or a sortie's lines with a gap: QGroundControl lays them
    evenly), when its strips are not the offsets of one polyline, or when they are and its camera
    is not straight down (a Corridor Scan's photos are)."""
    runs = plan.route.runs
    station_run = np.asarray(plan.stations.run)
    first, last = (0, len(station_run) - 1) if stations is None else stations
    inside = np.zeros(len(station_run), bool)
    inside[first:last + 1] = True
    partial = set(station_run[~inside].tolist()) & set(station_run[inside].tolist())
    flown = frozenset(int(k) for k in set(station_run[inside].tolist()) - partial)
    framed = {p.index for p in plan.layout.passes if p.frame is not None}
    out: dict[int, PassShape | None] = {}
    plain: list[str] = []
    ringed = sorted({p.index for p in plan.layout.passes if p.ring is not None} & set(passes))
    if ringed:  # the rings round a structure: one Structure Scan item, or plain items all
        cut = sorted({runs[k].pass_index for k in partial} & set(ringed))
        scan = (f"the structure scan: the flight flies part of the ring of pass {cut[0]}, which QGroundControl "
                "would fly whole") if cut else _scan_shape(plan, ringed, flown, frame)
        if isinstance(scan, str):
            plain.append(scan)
        out |= {p: None if isinstance(scan, str) else PassShape(None, None, False, scan) for p in ringed}
    # the passes of the stations shot at several aims a place (`Run.looks`, each look a pass of its own): one
    # waypoint a shot, a gimbal turn between, which no complex item holds
    looking = sorted({ids.parse_station_id(sid).pass_index for sid, k in zip(plan.stations.ids, station_run.tolist())
                      if runs[k].looks} & set(passes)) if any(r.looks for r in runs) else []
    for p in looking:
        out[p] = None
        plain.append(f"pass {p}: its camera is turned at each station through several aims, one photo each")
    for p in sorted(set(passes) - set(ringed) - set(looking)):
        if any(runs[k].pass_index == p for k in partial):
            out[p] = None
            plain.append(f"pass {p}: the flight flies part of a line, which an edit in QGroundControl would lay whole")
            continue
        alternate = _alternate(plan, p, flown)
        if p in framed:
            ring, st = survey_geometry(plan, p, frame, flown)
            even = len(st.v) < 2 or float(np.max(np.abs(np.diff(st.v) - st.spacing))) <= 0.01 * st.spacing
            out[p] = PassShape((ring, st), None, alternate) if even else None
            if not even:
                plain.append(f"pass {p}: its lines are not evenly spaced, as QGroundControl would lay them on an edit")
            continue
        aim = next(q.aim for q in plan.layout.passes if q.index == p)
        if not aim.nadir:
            out[p] = None
            plain.append(f"pass {p}: its camera looks at {aim.pitch_deg:g}°, not straight down as a Corridor Scan "
                         "lays its photos")
            continue
        found = corridor_geometry(plan, p, frame, flown)
        out[p] = None if found is None else PassShape(None, found, alternate)
        if found is None:
            plain.append(f"pass {p}: its strips are not the offsets of one line, as a Corridor Scan lays them")
    return SurveyShapes(MappingProxyType(out), tuple(plain), first, last)


def survey_items(plan: Plan, shapes: SurveyShapes, m: Mission) -> tuple[QgcSurvey | QgcStructureScan, ...]:
    """A Survey item for each of the mission's pass blocks of parallel lines, or a Corridor Scan
    item for a pass of strips, where `shapes` (`survey_shapes`, made for the stations the
    mission flies) has the pass's shape, and one Structure Scan item for the blocks of the
    rings round a structure. Any other pass stays plain items."""
    run_ids = [ids.run_id(r.pass_index, r.line, r.part) for r in plan.route.runs]
    station_run = np.asarray(plan.stations.run)[shapes.first_station:shapes.last_station + 1]
    if plan.altitudes.frame == "terrain":
        mode = DISTANCE_TERRAIN_FRAME
    elif plan.sensor.heights.mode == "follow":
        mode = DISTANCE_CALC_ABOVE_TERRAIN
    else:
        mode = DISTANCE_RELATIVE
    out: list[QgcSurvey | QgcStructureScan] = []
    blocks = survey_blocks(m)
    for p, a, b in blocks:
        polygon: tuple[tuple[float, float], ...] = ()
        polyline: tuple[tuple[float, float], ...] = ()
        width, angle = 0.0, 0.0
        shape = shapes.passes.get(p)
        if shape is None:  # the pass stays plain items
            continue
        if shape.scan is not None:
            if p == shape.scan.passes[0]:  # the item holds the blocks of its passes, which follow one another
                last = [q for q in blocks if q[0] in shape.scan.passes]
                if [q[0] for q in last] != list(shape.scan.passes) or any(
                        m.items[j].tag != "detour" for (_, _, b0), (_, a1, _) in zip(last[:-1], last[1:]) for j in range(b0 + 1, a1)):
                    raise ValueError(f"the structure scan's passes {shape.scan.passes} are not flown one after another here")
                out.append(replace(shape.scan, first=a, last=last[-1][2]))
            continue
        if shape.corridor is not None:
            # strips bend (a corridor's): a Survey item would regenerate straight lines (the road
            # example: 4 for our 12 runs, their ends up to 2.6 km from ours); a Corridor Scan item
            # offsets one polyline instead
            line, width, spacing, entry = shape.corridor
            polyline = tuple((float(lat), float(lon)) for lon, lat in line)
        else:
            assert shape.grid is not None
            ring, fit = shape.grid
            polygon = tuple((float(lat), float(lon)) for lon, lat in ring)
            spacing, angle, entry = fit.spacing, fit.angle, 2 * fit.reverse_points + fit.reverse_lines
        items = m.items[a:b + 1]
        tags = {it.tag.split(":")[0] for it in items}
        runs = [k for k, rid in enumerate(run_ids) if rid in tags]
        shots = int(np.isin(station_run, runs).sum())
        if mode == DISTANCE_RELATIVE:  # the height of the block's first waypoint on a line
            distance = next(it.z for it in items if it.command == mav.NAV_WAYPOINT and ids.pass_of(it.tag) is not None)
        else:
            distance = plan.sensor.heights.nominal_agl_m
        trigger = plan.sensor.trigger_distance_m if plan.sensor.trigger_distance_m is not None else plan.sensor.base_m
        camera = _qgc_camera(plan, distance, spacing, trigger)
        out.append(QgcSurvey(
            first=a, last=b, pass_index=p, polygon=polygon, angle_deg=angle, entry_location=entry,
            fly_alternate=not polyline and shape.alternate, spacing_m=spacing, trigger_m=trigger,
            turnaround_m=plan.sensor.lead_in_m, distance_m=distance, distance_mode=mode, hover=plan.camera.trigger == "hover",
            camera_shots=shots, camera=camera,
            terrain_tolerance_m=plan.altitudes.tolerance_m if mode == DISTANCE_CALC_ABOVE_TERRAIN else 0.0,
            max_climb_ms=plan.vehicle.climb_rate_ms, max_descent_ms=plan.vehicle.descent_rate_ms,
            flight_speed_ms=plan.sensor.speed.speed_ms,
            visual_points=tuple((it.x, it.y) for it in items if it.has_position),
            corridor_polyline=polyline, corridor_width_m=width,
        ))
    return tuple(out)
