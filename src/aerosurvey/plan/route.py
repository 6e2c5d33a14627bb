"""Route: the order lines are flown in, turnarounds, lead-ins, detours around exclusion
zones, and the flight-time model.

Input is a list of passes (a heading and its photo runs); output is the ordered list of
waypoints in the planning CRS with the photo runs attached, as plain data.
"""

from __future__ import annotations

import bisect
import heapq
import math
from dataclasses import dataclass, field, replace

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.plan.frame import LineFrame
from aerosurvey.plan.lines import LineBounds, LineSegment
from aerosurvey.plan.progress import Progress, no_progress


@dataclass(frozen=True, eq=False)
class Strip:
    """A photo strip in world geometry (planning CRS), in line order: the polyline the camera
    flies along from its first station to its last, and the stations on it. A corridor's strips
    bend where its centreline does."""

    line: int  # index of the strip in its pass
    part: int  # index of the piece of the line (cut by exclusion zones)
    path: np.ndarray  # (m ≥ 2, 2): the first station, the bends, the last station
    stations: np.ndarray  # (n, 2)
    station_index: np.ndarray  # (n,) index of each station along its line, for ids
    heading_deg: np.ndarray  # (n,) the strip's direction at each station (compass bearing), in line order
    bend_after: np.ndarray  # (m − 2,) for each bend, the station (index into `stations`) it follows


@dataclass(frozen=True, eq=False)
class Pass:
    """A group of strips flown one after another, with the camera held at one attitude, and the
    hint the route step needs to order them.

    An area grid's pass is parallel lines in a frame (`frame` and `segments`): the route searches
    the line order and cells. Any other pattern gives `strips`, flown in their order, back and
    forth (each line the other way from the one before)."""

    index: int  # 1 for the main pass, 2 for the cross-hatch, …
    frame: LineFrame | None = None
    segments: tuple[LineSegment, ...] = ()
    strips: tuple[Strip, ...] = ()
    pitch_deg: float = -90.0  # the camera's pitch (gimbal convention: −90 straight down)
    look_deg: float | None = None  # the bearing the camera looks to; None: along the flight

    @property
    def empty(self) -> bool:
        return not self.segments and not self.strips


@dataclass(frozen=True, eq=False)
class Run:
    """One photo run as flown: stations in flight order, in the planning CRS."""

    pass_index: int
    line: int
    part: int
    direction: int  # +1 along the line (the frame's +x, a strip's order), −1 against it
    heading_deg: float  # direction of flight at the first station (compass bearing)
    station_xy: np.ndarray  # (n, 2), flight order
    station_index: np.ndarray  # index of each station along its line (by +x), for ids
    lead_in_xy: tuple[float, float]
    end_xy: tuple[float, float]  # past the last station by half a photo base
    bends_xy: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))  # (k, 2) flight order
    bend_after: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # the station (flight order) each follows
    station_heading_deg: np.ndarray | None = None  # (n,) where the run bends; None: heading_deg throughout
    pitch_deg: float = -90.0
    look_deg: float | None = None  # the camera's bearing; None: along the flight

    def headings(self) -> np.ndarray:
        """The direction of flight at each station."""
        if self.station_heading_deg is not None:
            return self.station_heading_deg
        return np.full(len(self.station_xy), self.heading_deg)


@dataclass(frozen=True)
class Waypoint:
    x: float
    y: float
    kind: str  # lead_in, line_start, bend, line_end, detour
    run: int  # index into Route.runs, −1 for detours


@dataclass(frozen=True)
class Route:
    runs: tuple[Run, ...]
    waypoints: tuple[Waypoint, ...]
    strategy: tuple[str, ...]  # per pass: lines across the area, or cells


@dataclass(frozen=True)
class Kinematics:
    """What the time model needs of the vehicle."""

    vehicle: str
    speed_ms: float
    accel_ms2: float
    turn_radius_m: float
    jerk_ms3: float = 1.0  # copters: ArduCopter's WPNAV_JERK default


def _grid(p: Pass) -> LineFrame:
    """The frame of an area grid's pass."""
    assert p.frame is not None, "an area grid's pass has a frame"
    return p.frame


def _offsets(p: Pass) -> dict[tuple[int, int], int]:
    """Index of each segment's first station along its line (by +x), for stable station ids."""
    by_line: dict[int, list[LineSegment]] = {}
    for s in p.segments:
        by_line.setdefault(s.line, []).append(s)
    out = {}
    for line, segs in by_line.items():
        n = 0
        for s in sorted(segs, key=lambda s: s.x0):
            out[(line, s.part)] = n
            n += s.n
    return out


#: A run as ordered: its segment and its direction (+1 along the frame's +x, −1 against it).
Leg = tuple[LineSegment, int]


def _leg_stations(legs: list[Leg]) -> tuple[np.ndarray, np.ndarray]:
    """Per station of every leg, in flight order: the leg it belongs to and its index along its
    segment (j of x0 + j·B)."""
    n = np.array([s.n for s, _ in legs], np.int64)
    back = np.array([d < 0 for _, d in legs], bool)
    leg = np.repeat(np.arange(len(legs)), n)
    start = np.cumsum(n) - n
    j = np.arange(int(n.sum()), dtype=np.int64) - start[leg]
    j = np.where(back[leg], n[leg] - 1 - j, j)  # backwards: from the last station to the first
    return leg, j


def _leg_arrays(legs: list[Leg]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    x0, n, base, v = (np.array(a, float) for a in zip(*((s.x0, s.n, s.base, s.v) for s, _ in legs)))
    return x0, n, base, v, np.array([d for _, d in legs], np.int64)


def _run_ends(p: Pass, legs: list[Leg], lead_in: float) -> np.ndarray:
    """(3·len(legs), 2): the lead-in, the first station and the end of every run the legs make
    (`_build_runs`), in flight order, without making the runs: the same operations on the same
    values, element by element, so the same numbers."""
    if not legs:
        return np.zeros((0, 2))
    x0, n, base, v, d = _leg_arrays(legs)
    first = x0 + base * np.where(d > 0, 0.0, n - 1.0)
    last = x0 + base * np.where(d > 0, n - 1.0, 0.0)
    u = np.column_stack([first - d * lead_in, first, last + d * base / 2.0]).ravel()
    X, Y = _grid(p).from_frame(u, np.repeat(v, 3))
    return np.column_stack([X, Y])


def _build_runs(p: Pass, legs: list[Leg], lead_in: float, offsets: dict[tuple[int, int], int]) -> list[Run]:
    """The runs of the legs, in flight order: each line's stations (x0 + j·B) in the planning
    CRS, its lead-in `lead_in` before the first and its end half a base after the last (those
    two by `_run_ends`, as the candidate orders were costed). Every leg's stations are turned out
    of the line frame in one numpy step."""
    if not legs:
        return []
    fr = _grid(p)
    leg, j = _leg_stations(legs)
    x0, _, base, v, _ = _leg_arrays(legs)
    X, Y = fr.from_frame(x0[leg] + base[leg] * j, v[leg])
    xy = np.column_stack([X, Y])
    first_at = np.searchsorted(leg, np.arange(len(legs)))
    last_at = np.searchsorted(leg, np.arange(len(legs)), side="right") - 1
    idx = np.array([offsets[(s.line, s.part)] for s, _ in legs], np.int64)[leg] + j
    ends = _run_ends(p, legs, lead_in).reshape(-1, 3, 2)
    lead_x, lead_y = ends[:, 0, 0].tolist(), ends[:, 0, 1].tolist()
    end_x, end_y = ends[:, 2, 0].tolist(), ends[:, 2, 1].tolist()
    runs = []
    for i, ((s, direction), a, b) in enumerate(zip(legs, first_at.tolist(), last_at.tolist())):
        heading = (fr.heading_deg + (0.0 if direction > 0 else 180.0)) % 360.0
        runs.append(Run(p.index, s.line, s.part, direction, heading, xy[a:b + 1].copy(), idx[a:b + 1].copy(),
                        (lead_x[i], lead_y[i]), (end_x[i], end_y[i]), pitch_deg=p.pitch_deg, look_deg=p.look_deg))
    return runs


def _legs_of_pass(p: Pass, order: list[int], first_dir: int) -> list[Leg]:
    """Every line in `order`, alternating direction, all runs of a line in one pass."""
    by_line: dict[int, list[LineSegment]] = {}
    for s in p.segments:
        by_line.setdefault(s.line, []).append(s)
    legs: list[Leg] = []
    for k, line in enumerate(order):
        direction = first_dir if k % 2 == 0 else -first_dir
        legs.extend((s, direction) for s in sorted(by_line[line], key=lambda s: s.x0, reverse=direction < 0))
    return legs


def cells(segments: tuple[LineSegment, ...]) -> list[list[LineSegment]]:
    """Boustrophedon cells: chains of segments on consecutive lines that overlap along x
    one-to-one. Where a line splits (a notch, a hole, a zone) a new cell starts."""
    by_line: dict[int, list[LineSegment]] = {}
    for s in segments:
        by_line.setdefault(s.line, []).append(s)
    lines = sorted(by_line)

    def touching(a: LineSegment, bs: list[LineSegment]) -> list[LineSegment]:
        return [b for b in bs if b.x0 <= a.x1 + a.base and a.x0 <= b.x1 + b.base]

    cell_of: dict[tuple[int, int], int] = {}
    out: list[list[LineSegment]] = []
    for i, line in enumerate(lines):
        prev = by_line.get(line - 1, []) if i > 0 and lines[i - 1] == line - 1 else []
        for s in sorted(by_line[line], key=lambda s: s.x0):
            up = touching(s, prev)
            if len(up) == 1 and len(touching(up[0], by_line[line])) == 1:
                c = cell_of[(up[0].line, up[0].part)]
                out[c].append(s)
            else:
                c = len(out)
                out.append([s])
            cell_of[(s.line, s.part)] = c
    return out


def _cell_legs(cell: list[LineSegment], reverse: bool, first_dir: int) -> list[Leg]:
    segs = cell[::-1] if reverse else cell
    return [(s, first_dir if k % 2 == 0 else -first_dir) for k, s in enumerate(segs)]


def _cell_ends(p: Pass, cell: list[LineSegment], lead_in: float, reverse: bool,
               first_dir: int) -> tuple[tuple[float, float], tuple[float, float]]:
    """Where a cell flown this way starts (its first lead-in) and ends, without building it."""
    segs = cell[::-1] if reverse else cell
    a, b = segs[0], segs[-1]
    last_dir = first_dir if (len(segs) - 1) % 2 == 0 else -first_dir
    u0 = (a.x0 if first_dir > 0 else a.x1) - first_dir * lead_in
    u1 = (b.x1 if last_dir > 0 else b.x0) + last_dir * b.base / 2.0
    X, Y = _grid(p).from_frame(np.array([u0, u1]), np.array([a.v, b.v]))
    return (float(X[0]), float(Y[0])), (float(X[1]), float(Y[1]))


def _cells_route(p: Pass, todo: list[list[LineSegment]], lead_in: float,
                 start_near: tuple[float, float] | None) -> list[Leg]:
    """Fly cell after cell, each as its own boustrophedon, always to the nearest next cell corner."""
    todo = list(todo)
    ends = [{(rv, fd): _cell_ends(p, c, lead_in, rv, fd) for rv in (False, True) for fd in (1, -1)} for c in todo]
    here = start_near
    legs: list[Leg] = []
    while todo:
        best = None
        for ci in range(len(todo)):
            for (rv, fd), (start, _) in ends[ci].items():
                d = 0.0 if here is None else math.dist(here, start)
                if best is None or d < best[0] - 1e-9:
                    best = (d, ci, rv, fd)
        assert best is not None
        _, ci, rv, fd = best
        legs.extend(_cell_legs(todo[ci], rv, fd))
        here = ends[ci][(rv, fd)][1]
        todo.pop(ci)
        ends.pop(ci)
    return legs


def line_orders(n_lines: int, spacing: float, turn_radius: float, vehicle: str) -> list[list[int]]:
    """Candidate line orders: plain boustrophedon, and for planes whose turn diameter is
    larger than the spacing, interleaved skip-line orders (0, k, 1, k+1, …) so that most
    turns are at least 2R wide."""
    orders = [list(range(n_lines))]
    if vehicle == "plane" and spacing < 2.0 * turn_radius and n_lines > 2:
        kmax = min(n_lines - 1, math.ceil(2.0 * turn_radius / spacing) + 1)
        for k in range(2, kmax + 1):
            order: list[int] = []
            for block in range(0, n_lines, 2 * k):
                lo = list(range(block, min(block + k, n_lines)))
                hi = list(range(block + k, min(block + 2 * k, n_lines)))
                for i in range(max(len(lo), len(hi))):
                    if i < len(lo):
                        order.append(lo[i])
                    if i < len(hi):
                        order.append(hi[i])
            orders.append(order)
    return orders


def plane_turn_length(lateral: float, radius: float) -> float:
    """Path length of a 180° turn between parallel lines `lateral` apart.

    At least 2R apart: two quarter circles and a straight. Closer: an omega (bulb) turn
    of total angle π + 4α with cos α = (2R + d) / 4R.
    """
    d = abs(lateral)
    if d >= 2 * radius:
        return math.pi * radius + (d - 2 * radius)
    alpha = math.acos(min(1.0, (2 * radius + d) / (4 * radius)))
    return radius * (math.pi + 4 * alpha)


def plane_turn_lengths(lateral: np.ndarray, radius: float) -> np.ndarray:
    """`plane_turn_length` of many non-negative distances at once (numpy's arccos may differ
    from math.acos by an ulp: for bounds, not for the route's own times)."""
    d = np.asarray(lateral, float)
    bulb = radius * (math.pi + 4.0 * np.arccos(np.minimum(1.0, (2.0 * radius + d) / (4.0 * radius))))
    out: np.ndarray = np.where(d >= 2.0 * radius, math.pi * radius + (d - 2.0 * radius), bulb)
    return out


#: A copter stops at a corner sharper than this (degrees) and flies on through a gentler one
CORNER_DEG = 30.0


def _straight_time(d: float, k: Kinematics) -> float:
    """Copter from rest to rest over d metres: top speed v, acceleration a, jerk J.

    With jerk-limited (S-curve) acceleration each of the two speed changes costs
    (v/a + a/J)/2 more than cruising the same distance, so t = d/v + v/a + a/J.
    """
    v, a, j = k.speed_ms, k.accel_ms2, k.jerk_ms3
    if d <= 0:
        return 0.0
    ramp = a / j if j > 0 else 0.0
    if d >= v * (v / a + ramp):
        return d / v + v / a + ramp
    return 2.0 * math.sqrt(d / a) + ramp


def hover_time(stations: int, runs: int, base: float, hold_s: float, k: Kinematics) -> float:
    """What hover-and-capture adds to a copter's time over runs flown straight through: at each of
    `stations` photos it stops (braking and accelerating again over the `base` between two
    stations of a run, `_straight_time` against cruising it) and rests `hold_s`."""
    stops = max(stations - runs, 0)
    return stations * hold_s + stops * (_straight_time(base, k) - base / k.speed_ms)


#: path_time drops segments this short or shorter (planning-grid units / grid scale)
KEPT = 1e-9


def path_time(points: np.ndarray, k: Kinematics) -> float:
    """Flight time along a polyline.

    Copter: it stops at every corner sharper than CORNER_DEG and flies straight runs
    with the acceleration model. Plane: constant speed; a reversal between two lines is
    flown as the turn of :func:`plane_turn_length` instead of the straight connection.
    """
    if len(points) < 2:
        return 0.0
    if k.vehicle == "copter":  # the battery split times sorties in parts by the same CopterTime
        timer = CopterTime(k)
        timer.feed(kept_segments(points))
        return timer.time()
    seg = np.diff(points, axis=0)
    lengths = np.hypot(seg[:, 0], seg[:, 1])
    keep = lengths > KEPT
    seg, lengths = seg[keep], lengths[keep]
    if len(lengths) == 0:
        return 0.0
    ang = np.degrees(np.arctan2(seg[:, 1], seg[:, 0]))
    turn = np.abs((np.diff(ang) + 180.0) % 360.0 - 180.0)
    total_len = float(lengths.sum())
    i = 0
    while i < len(turn) - 1:
        if turn[i] + turn[i + 1] > 150.0:  # a reversal: corner, short leg, corner
            u = seg[i] / lengths[i]
            lateral = abs(u[0] * seg[i + 1][1] - u[1] * seg[i + 1][0])
            total_len += plane_turn_length(lateral, k.turn_radius_m) - lengths[i + 1]
            i += 2
        else:
            i += 1
    return total_len / k.speed_ms


#: The segments path_time keeps of a polyline: (lengths, directions in degrees), planning-grid units / grid scale
Segments = tuple[list[float], list[float]]


def all_segments(points: np.ndarray) -> Segments:
    """Every segment's length and direction (degrees) of a polyline, the dropped ones too, as
    `kept_segments` measures them (elementwise: the same floats whichever polyline a segment is part of)."""
    d = (points[1:] - points[:-1]).T
    return np.hypot(d[0], d[1]).tolist(), np.degrees(np.arctan2(d[1], d[0])).tolist()


def kept_segments(points: np.ndarray) -> Segments:
    """The segments path_time keeps of a polyline (already divided by the grid scale), by
    the same numpy operations on the same values (np.diff is this subtraction): elementwise, so a
    segment's length and direction are the same floats whichever polyline it is part of."""
    d = (points[1:] - points[:-1]).T
    dx, dy = d[0], d[1]
    lengths = np.hypot(dx, dy)
    keep = lengths > KEPT
    if not keep.all():
        dx, dy, lengths = dx[keep], dy[keep], lengths[keep]
    return lengths.tolist(), np.degrees(np.arctan2(dy, dx)).tolist()


class RouteSegments:
    """The kept segments of the whole runs and the detours between them, in flight order, with
    path_time's corners, each segment's length flown straight since the last corner (`running`)
    and, at each corner, the time of the straight stretch it ends (`closed`)."""

    __slots__ = ("lengths", "angles", "corners", "running", "closed", "kept_before")

    def __init__(self, points: np.ndarray, kin: Kinematics):
        self.lengths, self.angles = kept_segments(points)
        seg = np.diff(points, axis=0)
        # kept_before[i]: how many kept segments come before segment i (from point i to point i + 1)
        self.kept_before: list[int] = np.concatenate([[0], np.cumsum(np.hypot(seg[:, 0], seg[:, 1]) > KEPT)]).tolist()
        turn = np.abs((np.diff(np.asarray(self.angles)) + 180.0) % 360.0 - 180.0)
        self.corners: list[int] = (np.flatnonzero(turn > CORNER_DEG) + 1).tolist()
        self.running: list[float] = []
        self.closed: dict[int, float] = {}
        at_corner = set(self.corners)
        for k, length in enumerate(self.lengths):
            if k in at_corner:
                self.closed[k] = _straight_time(self.running[-1], kin)
            self.running.append(length if k == 0 or k in at_corner else self.running[-1] + length)


class CopterTime:
    """path_time of a copter (path_time is made by it): it stops at every corner sharper than
    CORNER_DEG and times each straight stretch by _straight_time. Fed in parts, so that
    the stretches between corners of the whole runs are timed once for all sorties (`route`)."""

    __slots__ = ("kin", "total", "run", "last")

    def __init__(self, kin: Kinematics, total: float = 0.0, run: float | None = None, last: float = 0.0):
        self.kin = kin
        self.total = total  # the stretches ended so far
        self.run = run  # flown straight since the last corner (None before the first kept segment)
        self.last = last  # direction of the last kept segment

    def feed(self, segs: Segments) -> None:
        # the state in locals while the loop runs (the same operations in the same order; measured on
        # a 57-line boustrophedon's 170 segments: 82-88 -> 75-79 µs, /tmp/p2/feedt.py)
        total, run, last, kin, corner = self.total, self.run, self.last, self.kin, CORNER_DEG
        for length, ang in zip(*segs):
            if run is None:
                run = length
            elif abs((ang - last + 180.0) % 360.0 - 180.0) > corner:
                total += _straight_time(run, kin)
                run = length
            else:
                run += length
            last = ang
        self.total, self.run, self.last = total, run, last

    def route(self, rs: RouteSegments, k0: int, k1: int) -> None:
        """Feed the route's kept segments k0..k1-1: the first as any other, then one by one up to
        the first corner, the stretches between corners by their times, the last by its length."""
        if k0 >= k1:
            return
        self.feed(([rs.lengths[k0]], [rs.angles[k0]]))
        assert self.run is not None
        ci, cj = bisect.bisect_right(rs.corners, k0), bisect.bisect_left(rs.corners, k1)
        for k in range(k0 + 1, rs.corners[ci] if ci < cj else k1):
            self.run += rs.lengths[k]
        if ci < cj:
            self.total += _straight_time(self.run, self.kin)
            for c in rs.corners[ci + 1:cj]:
                self.total += rs.closed[c]
            self.run = rs.running[k1 - 1]
        self.last = rs.angles[k1 - 1]

    def time(self) -> float:
        return 0.0 if self.run is None else self.total + _straight_time(self.run, self.kin)



#: A copter lands its last metres slowly (ArduCopter: below LAND_ALT_LOW = 10 m at LAND_SPEED = 0.5 m/s).
LAND_SLOW_ALT_M, LAND_SLOW_SPEED_MS = 10.0, 0.5


def descent_time(alt_m: float, rate_ms: float, vehicle: str) -> float:
    """Time from the survey height to the ground: descent rate, then a copter's slow final metres."""
    if vehicle != "copter":
        return alt_m / rate_ms
    slow = min(alt_m, LAND_SLOW_ALT_M)
    return (alt_m - slow) / rate_ms + slow / LAND_SLOW_SPEED_MS


def quick_cost(segments: list[LineSegment], lead_in: float, k: Kinematics) -> float:
    """Estimated time of a boustrophedon over the segments, in their own line frame.

    Used to compare headings: it needs only the run ends (time is the same in any frame).
    """
    by_line: dict[int, list[LineSegment]] = {}
    for s in segments:
        by_line.setdefault(s.line, []).append(s)
    pts: list[tuple[float, float]] = []
    for i, line in enumerate(sorted(by_line)):
        segs = sorted(by_line[line], key=lambda s: s.x0)
        d = 1 if i % 2 == 0 else -1
        if d < 0:
            segs.reverse()
        for s in segs:
            first, last = (s.x0, s.x1) if d > 0 else (s.x1, s.x0)
            pts.extend([(first - d * lead_in, s.v), (first, s.v), (last + d * s.base / 2.0, s.v)])
    return path_time(np.asarray(pts), k)


def _least_gain(d: np.ndarray, k: Kinematics) -> tuple[np.ndarray, float]:
    """Per run length d: the least G(x) = t(x) − x/v of a copter's straight run
    (`_straight_time`) over every x ≥ d; and the least over every x > 0. G is v/a + a/J from
    D = v(v/a + a/J) on and 2√(x/a) + a/J − x/v (concave) below D, so the least is at d, just
    below D, or past D."""
    v, a, j = k.speed_ms, k.accel_ms2, k.jerk_ms3
    ramp = a / j if j > 0 else 0.0
    big, top = v * (v / a + ramp), v / a + ramp
    below_big = min(2.0 * math.sqrt(big / a) + ramp - big / v, top)
    here = 2.0 * np.sqrt(np.maximum(d, 0.0) / a) + ramp - np.maximum(d, 0.0) / v
    return np.where(d >= big, top, np.minimum(here, below_big)), min(ramp, below_big)


def _connector_ahead(lb: LineBounds, i: np.ndarray, j: np.ndarray, lead_in: float,
                     base: float) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """How far the connector from sure line i to sure line j (flown the other way) runs ahead,
    along line i's direction of flight, as (least, most), line i flown to the right (+x: from its
    last station + base/2 to line j's last station + lead_in) and to the left (from its first
    station − base/2 to line j's first station − lead_in)."""
    right = (lb.last_lo[j] + lead_in - lb.last_hi[i] - base / 2.0, lb.last_hi[j] + lead_in - lb.last_lo[i] - base / 2.0)
    left = (lb.first_lo[i] - base / 2.0 - lb.first_hi[j] + lead_in, lb.first_hi[i] - base / 2.0 - lb.first_lo[j] + lead_in)
    return right, left


def connector_stops(lb: LineBounds, i: np.ndarray, j: np.ndarray, lead_in: float, base: float) -> np.ndarray:
    """Per pair of sure lines (i, j) of a heading: is a copter surely stopped at both corners of
    the connector from line i to line j (each turn sharper than CORNER_DEG), whichever way the two
    lines are flown (see quick_cost_lower_bounds)?"""
    dv = lb.v[j] - lb.v[i]
    cot = 1.0 / math.tan(math.radians(CORNER_DEG)) * (1.0 - 1e-6)
    stops = np.ones(len(i), bool)
    for lo, hi in _connector_ahead(lb, i, j, lead_in, base):
        stops &= (hi < dv * cot) & (lo > -dv * cot)
    return stops


def quick_cost_lower_bounds(lb: LineBounds, lead_in: float, base: float, k: Kinematics) -> np.ndarray:
    """Per heading of `lb`: a proven lower bound of `quick_cost(build_lines(...), lead_in, k)`.

    The path quick_cost times is, line after line (those with runs, by ordinate), the line's
    part P (lead-in, stations, half a base past the last run, all on the line, backwards
    between runs that overlap) and a connector to the next line, at least Δv long. For a line
    sure to exist, P runs from before its first station to past its last one: it is at least
    λ = extent + lead_in + base/2 long.

    Copter (t = d/v + G(d) per stop-to-stop run, G ≥ least_gain): every leg is along the line
    but the connectors, so a stop within P is a reversal (two corners of 180°: ≥ 3 runs, G ≥ 3m,
    m = least_gain(0)); otherwise P lies in one run of length ≥ λ. A connector's two corners
    add up to 180°, so at least one is a stop: either both are (the connector is a run of
    its own: Δv/v + least_gain(Δv)), or it turns by ≤ 30° into a line, so it is at least 2Δv
    long. Where both corners are surely sharper than 30°, whichever way the two lines are flown,
    the connector is a run of its own: it runs from line i's end (its last station + base/2 flown
    to the right, its first − base/2 to the left: a line's runs lie apart, so its last run ends
    at its outermost station) to line j's lead-in (its last station + lead_in, its first −
    lead_in), and the bounds of those stations bound how far it runs ahead along line i (a
    corner is sharper than 30° when that is below Δv·cot 30° out of line i and above −Δv·cot 30°
    into line j; the segments before and after it run along the lines). Runs of different lines
    and those connector runs are distinct, hence the sum.
    Between two sure lines with unsure ones between them there is at least one connector and
    they add up to the ordinate difference; each connector has G ≥ m or the extra length ≥ Δv.

    Plane (length/v, where path_time replaces the middle leg of a reversal, a leg whose two
    corners add up to more than 150°, by the turn `plane_turn_length` over its lateral offset,
    never shorter than that offset; it pairs corners from the first on, skipping the corner
    after a pair). A connector's offset is Δv (the leg before it runs along the line), so it
    counts at least Δv. A connector that surely turns by at most 150° out of the line before
    it ("gentle", from the bounds of both lines' ends, either way they are flown) is surely
    replaced by the turn over Δv: its first corner is skipped only when paired with the 0°
    corner before it. Its second corner is then skipped, so the lead-in after it (lead_in > 0)
    is not replaced. A sure line with gentle connectors in and out (or only surely empty lines
    beyond it) thus keeps its first lead-in and its last run: with no reversal within (a line
    of one run has none) nothing of it is replaced, λ; else its first reversal replaces the
    leg before it and the lead-in after it by the turn over 0 each: at least
    lead_in + base/2 + 2·turn(0).
    """
    frames = int(lb.heading.max()) + 1 if len(lb.heading) else 0
    exists = np.flatnonzero(lb.exists)
    hid, v, speed = lb.heading, lb.v, k.speed_ms
    lam = lb.extent[exists] + lead_in + base / 2.0
    i, j = exists[:-1], exists[1:]
    pair = hid[i] == hid[j]  # consecutive sure lines of one heading
    i, j = i[pair], j[pair]
    dv = v[j] - v[i]
    # with only surely empty lines between them, the connector joins them
    unknown = np.cumsum(~lb.exists & ~lb.absent)
    joined = unknown[j] == unknown[i]

    def per_heading(at: np.ndarray, values: np.ndarray) -> np.ndarray:
        return np.bincount(hid[at], weights=values, minlength=frames).astype(float)  # float when empty too

    if k.vehicle == "copter":
        gain, m = _least_gain(np.concatenate([lam, dv[joined]]), k)
        same = hid[1:] == hid[:-1]
        gap = float(np.min(np.diff(v)[same])) if same.any() else 0.0  # no two lines of a heading are closer
        total = per_heading(exists, lam / speed + np.minimum(gain[:len(lam)], 3.0 * m))
        # a joined connector whose corners are surely both sharper than 30°, whichever way the two
        # lines are flown, is a run of its own (see the docstring)
        stops = connector_stops(lb, i, j, lead_in, base)
        own = dv[joined] / speed + gain[len(lam):]
        total += per_heading(i[joined], np.where(stops[joined], own, np.minimum(own, 2.0 * dv[joined] / speed)))
        total += per_heading(i[~joined], dv[~joined] / speed + min(m, gap / speed))
        return total * (1.0 - 1e-7)
    # plane: connectors that surely turn by at most 150° out of the line before them, whichever
    # way that line is flown (see the docstring)
    cot30 = math.sqrt(3.0) * (1.0 - 1e-6)
    (ahead_right, _), (ahead_left, _) = _connector_ahead(lb, i, j, lead_in, base)
    gentle = joined & (ahead_right >= -dv * cot30) & (ahead_left >= -dv * cot30) & (lead_in > 1e-6)
    # each heading's first and last sure line: are all lines before (after) it surely empty?
    start = np.flatnonzero(np.r_[True, hid[1:] != hid[:-1]])
    end = np.r_[start[1:], len(hid)] - 1
    before_start = np.where(start > 0, unknown[np.maximum(start - 1, 0)], 0)[hid[exists]]
    known_before = unknown[exists] == before_start
    known_after = unknown[exists] == unknown[end][hid[exists]]
    # a sure line's connectors in and out, where it has them
    first = np.r_[True, hid[exists[1:]] != hid[exists[:-1]]] if len(exists) else np.zeros(0, bool)  # no sure line: none
    last = np.r_[first[1:], True] if len(exists) else np.zeros(0, bool)
    into, out = np.zeros(len(exists), bool), np.zeros(len(exists), bool)
    into[~first] = gentle
    out[~last] = gentle
    as_laid = (np.where(first, known_before, into) & np.where(last, known_after, out) & (lead_in > 1e-6))
    short = lead_in + base / 2.0 + 2.0 * plane_turn_length(0.0, k.turn_radius_m)
    length = per_heading(exists[as_laid], np.where(lb.single[exists], lam, np.minimum(lam, short))[as_laid])
    length += per_heading(i, np.where(gentle, plane_turn_lengths(dv, k.turn_radius_m), dv))
    return length / speed * (1.0 - 1e-7)


def _unit(bearing_deg: float) -> tuple[float, float]:
    h = math.radians(bearing_deg)
    return math.sin(h), math.cos(h)


def _strip_run(p: Pass, s: Strip, direction: int, lead_in: float, half_base: float) -> Run:
    """A strip flown one way: its stations, bends and headings in flight order, the lead-in
    `lead_in` before the first station along its direction there, the end `half_base` past the last."""
    n = len(s.stations)
    if direction > 0:
        xy, idx, heads = s.stations, s.station_index, np.asarray(s.heading_deg, float)
        bends, after = s.path[1:-1], s.bend_after
    else:
        xy, idx, heads = s.stations[::-1], s.station_index[::-1], (np.asarray(s.heading_deg, float)[::-1] + 180.0) % 360.0
        bends, after = s.path[1:-1][::-1], (n - 2 - s.bend_after)[::-1]
    ux, uy = _unit(float(heads[0]))
    vx, vy = _unit(float(heads[-1]))
    first, last = xy[0], xy[-1]
    return Run(p.index, s.line, s.part, direction, float(heads[0]), np.array(xy, float), np.array(idx),
               (float(first[0] - ux * lead_in), float(first[1] - uy * lead_in)),
               (float(last[0] + vx * half_base), float(last[1] + vy * half_base)),
               np.array(bends, float).reshape(-1, 2), np.array(after, np.int64), np.array(heads),
               p.pitch_deg, p.look_deg)


def strip_runs(p: Pass, lead_in: float, base: float, start_near: tuple[float, float] | None) -> list[Run]:
    """A pass of strips flown in their order, back and forth: each line the other way from the
    one before (its parts in order along that way), the first line the way whose first station
    is nearer `start_near`."""
    by_line: dict[int, list[Strip]] = {}
    for s in p.strips:
        by_line.setdefault(s.line, []).append(s)
    lines = [sorted(v, key=lambda s: s.part) for _, v in sorted(by_line.items())]
    first = 1
    if start_near is not None:
        a, b = lines[0][0].stations[0], lines[0][-1].stations[-1]
        first = 1 if math.dist(start_near, (a[0], a[1])) <= math.dist(start_near, (b[0], b[1])) else -1
    runs: list[Run] = []
    for k, parts in enumerate(lines):
        d = first if k % 2 == 0 else -first
        runs.extend(_strip_run(p, s, d, lead_in, base / 2.0) for s in (parts if d > 0 else parts[::-1]))
    return runs


def order_pass(p: Pass, lead_in: float, k: Kinematics, spacing: float,
               start_near: tuple[float, float] | None) -> tuple[list[Run], str]:
    """The fastest way through a pass: every line across the whole area (camera off over
    notches and holes) or cell by cell where the lines split, each from its best corner.

    Returns the runs and which of the two was chosen. Candidates are timed from their runs'
    ends alone (`_run_ends`); only the chosen one's runs are made.
    """
    n_lines = 1 + max(s.line for s in p.segments)
    best: tuple[float, list[Leg], str] | None = None

    def consider(legs: list[Leg], how: str) -> None:
        nonlocal best
        ends = _run_ends(p, legs, lead_in)
        cost = path_time(ends, k)
        if start_near is not None:
            cost += math.dist(start_near, (float(ends[0, 0]), float(ends[0, 1]))) / k.speed_ms
        if best is None or cost < best[0] - 1e-9:
            best = (cost, legs, how)

    for order in line_orders(n_lines, spacing, k.turn_radius_m, k.vehicle):
        for reverse in (False, True):
            o = order[::-1] if reverse else order
            for first_dir in (1, -1):
                consider(_legs_of_pass(p, o, first_dir), "lines across the whole area")
    todo = cells(p.segments)
    if len(todo) > 1:
        consider(_cells_route(p, todo, lead_in, start_near), f"{len(todo)} cells flown one after another")
    assert best is not None
    return _build_runs(p, best[1], lead_in, _offsets(p)), best[2]


class Detours:
    """Shortest detours around exclusion zones on a visibility graph of their corners.

    A detour looks among the corners of the zones (margins merged where they touch) that the
    straight leg crosses first, and adds the zones its way then crosses until it crosses none:
    with 200 small zones over an area, one search over every corner checked each leg against
    all of them (profiled: 200 zones, 49 ha, over 10 minutes in `way_round`).
    """

    def __init__(self, zones: BaseGeometry | None, margin: float):
        self.blocked = None
        self._groups: list[list[tuple[float, float]]] = []  # the corners of each part of the outline flown round
        if zones is None or zones.is_empty:
            return
        # fly around a slightly larger outline than the one that must not be crossed
        # eight segments a quarter circle: GEOS rounds the segment count of a corner down, so two
        # (one chord across up to 90°) let legs cut up to 29 % of the margin at a zone's corners
        self.blocked = shapely.buffer(zones, margin, quad_segs=8)
        around = shapely.get_parts(shapely.buffer(zones, margin + max(1.0, 0.02 * margin) + 1.0, quad_segs=2, join_style="mitre"))
        shapely.prepare(self.blocked)
        for poly in around:
            group: list[tuple[float, float]] = []
            for ring in [poly.exterior, *poly.interiors]:
                group.extend(map(tuple, np.asarray(ring.coords)[:-1]))
            self._groups.append(group)
        # each margin's part lies within one part of the outline flown round
        self._parts = shapely.get_parts(self.blocked)
        owner_part, owner = shapely.STRtree(around).query(shapely.point_on_surface(self._parts), predicate="within")
        self._group_of_part = np.zeros(len(self._parts), np.int64)
        self._group_of_part[owner_part] = owner
        self._part_tree = shapely.STRtree(self._parts)

    def clear(self, a: tuple[float, float], b: tuple[float, float]) -> bool:
        if self.blocked is None:
            return True
        return not shapely.intersects(self.blocked, shapely.LineString([a, b]))

    def clear_legs(self, points: np.ndarray) -> np.ndarray:
        """`clear` of every leg of a polyline ((n, 2) points: n − 1 legs), in one GEOS call."""
        legs = max(len(points) - 1, 0)
        if self.blocked is None or not legs:
            return np.ones(legs, bool)
        pts = np.asarray(points, float)
        return ~self._hits(pts[:-1], pts[1:])

    def _hits(self, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
        """Whether each leg starts[k] → ends[k] ((m, 2) arrays) meets the zones' margins: one GEOS call."""
        hit: np.ndarray = shapely.intersects(self.blocked, shapely.linestrings(np.stack([starts, ends], axis=1)))
        return hit

    def path(self, a: tuple[float, float], b: tuple[float, float]) -> list[tuple[float, float]]:
        """Intermediate points of the shortest way from a to b that stays out of the zones."""
        return [] if self.clear(a, b) else self.way_round(a, b)

    def crossing(self, starts: np.ndarray, b: tuple[float, float]) -> list[bool]:
        """Whether the leg from each of the (n, 2) points `starts` to b crosses the zones' margins
        (not `clear`), in one GEOS call."""
        if self.blocked is None or not len(starts):
            return [False] * len(starts)
        crossed: list[bool] = self._hits(starts, np.broadcast_to(np.asarray(b, float), starts.shape)).tolist()
        return crossed

    def _groups_crossed(self, points: list[tuple[float, float]]) -> set[int]:
        """The outline parts whose margins the polyline through `points` enters."""
        legs = shapely.linestrings(np.stack([np.asarray(points[:-1], float), np.asarray(points[1:], float)], axis=1))
        _, parts = self._part_tree.query(legs, predicate="intersects")
        return set(self._group_of_part[parts].tolist())

    def way_round(self, a: tuple[float, float], b: tuple[float, float]) -> list[tuple[float, float]]:
        """`path` of a leg already known to cross the zones: the search on the corners of the
        zones crossed, more of them while its way crosses others (all of them if that fails)."""
        chosen = self._groups_crossed([a, b])
        while True:
            groups = sorted(chosen)
            walls = shapely.multipolygons(self._parts[np.isin(self._group_of_part, groups)])
            shapely.prepare(walls)
            out = self._search([a, b, *(pt for g in groups for pt in self._groups[g])], walls)
            if out is None:
                if len(chosen) == len(self._groups):
                    raise ValueError("no way around the exclusion zones between two waypoints")
                chosen = set(range(len(self._groups)))
                continue
            more = self._groups_crossed([a, *out, b]) - chosen
            if not more:
                return out
            chosen |= more

    def _search(self, nodes: list[tuple[float, float]], walls: BaseGeometry) -> list[tuple[float, float]] | None:
        """The shortest way from nodes[0] to nodes[1] through the others whose legs clear `walls`, some of the
        zones' margins (None: no way). A*: nodes in order of their way from nodes[0] plus the straight line on to
        nodes[1] (never longer than the way on), so the first time nodes[1] comes it comes by its shortest way."""
        goal = nodes[1]
        dist = {0: 0.0}
        prev: dict[int, int] = {}
        heap = [(math.dist(nodes[0], goal), 0.0, 0)]
        done = set()
        while heap:
            _, d, i = heapq.heappop(heap)
            if i in done:
                continue
            done.add(i)
            if i == 1:
                break
            # the legs that would shorten the way to a node, checked against the zones in one call
            better = [(j, nd) for j in range(1, len(nodes)) if j not in done
                      for nd in (d + math.dist(nodes[i], nodes[j]),) if nd < dist.get(j, math.inf)]
            if not better:
                continue
            ends = np.array([nodes[j] for j, _ in better], float)
            legs = shapely.linestrings(np.stack([np.broadcast_to(nodes[i], ends.shape), ends], axis=1))
            for (j, nd), hit in zip(better, shapely.intersects(walls, legs).tolist()):
                if not hit:
                    dist[j] = nd
                    prev[j] = i
                    heapq.heappush(heap, (nd + math.dist(nodes[j], goal), nd, j))
        if 1 not in prev:
            return None
        out = []
        j = prev[1]
        while j != 0:
            out.append(nodes[j])
            j = prev[j]
        return out[::-1]


def clip_approach(first: tuple[float, float], lead: tuple[float, float], detours: Detours,
                  gap_m: float = 1.0) -> tuple[float, float]:
    """The lead-in point moved towards `first` so that the approach stops `gap_m` short of a zone's margin."""
    if detours.blocked is None:
        return lead
    # GEOS answers an empty intersection for an approach whose box misses the margins' box: most
    # lead-ins lie far from every zone, and this is asked for each run of every candidate heading
    zx0, zy0, zx1, zy1 = detours.blocked.bounds
    if (max(first[0], lead[0]) < zx0 or min(first[0], lead[0]) > zx1
            or max(first[1], lead[1]) < zy0 or min(first[1], lead[1]) > zy1):
        return lead
    approach = shapely.LineString([first, lead])
    hit = shapely.intersection(approach, detours.blocked)
    if hit.is_empty:
        return lead
    d = shapely.line_locate_point(approach, shapely.get_point(shapely.shortest_line(shapely.Point(first), hit), 1))
    keep = max(0.0, float(d) - gap_m)
    length = math.dist(first, lead)
    t = keep / length if length > 0 else 0.0
    return (first[0] + (lead[0] - first[0]) * t, first[1] + (lead[1] - first[1]) * t)


def clip_lead_in(run: Run, detours: Detours, gap_m: float = 1.0) -> Run:
    """The run with its lead-in shortened to stop `gap_m` short of a zone's margin in its way."""
    first = (float(run.station_xy[0, 0]), float(run.station_xy[0, 1]))
    lead = clip_approach(first, run.lead_in_xy, detours, gap_m)
    return run if lead == run.lead_in_xy else replace(run, lead_in_xy=lead)


def climb_out_path(home: tuple[float, float], first: tuple[float, float], climb: float,
                   detours: Detours) -> list[tuple[float, float]]:
    """Waypoints from the launch point to `first`: the detours round the zones, and when a
    plane's straight climb (`climb` long) ends past `first` and that overshoot meets a zone, a
    first waypoint where the climb ends, in the clear direction nearest the way to `first`.
    ValueError when no direction is clear."""
    d = math.dist(home, first)
    if climb <= d or detours.blocked is None:
        return detours.path(home, first)
    bearing = math.atan2(first[1] - home[1], first[0] - home[0])
    ahead = (home[0] + climb * math.cos(bearing), home[1] + climb * math.sin(bearing))
    if detours.clear(home, ahead) and detours.clear(ahead, first):
        return []  # it climbs past the first waypoint and turns back to it, all clear of the zones
    for turn in sorted(np.radians(np.arange(-180.0, 180.0, 5.0)).tolist(), key=abs):
        end = (home[0] + climb * math.cos(bearing + turn), home[1] + climb * math.sin(bearing + turn))
        if detours.clear(home, end):
            return [end, *detours.path(end, first)]
    raise ValueError("a plane taking off there climbs into an exclusion zone whichever way it heads")


def build_route(passes: list[Pass], lead_in: float, k: Kinematics, spacing_by_pass: list[float],
                start_near: tuple[float, float] | None, detours: Detours, report: Progress = no_progress,
                base: float = 0.0) -> Route:
    """Order every pass, join them, and insert detours wherever a leg would enter a zone
    (`report` hears how many of the legs that need one have theirs)."""
    runs: list[Run] = []
    how: list[str] = []
    here = start_near
    for p, spacing in zip(passes, spacing_by_pass):
        if p.empty:
            continue
        if p.frame is not None:
            pr, chosen = order_pass(p, lead_in, k, spacing, here)
        else:
            pr, chosen = strip_runs(p, lead_in, base, here), "strips in order, back and forth"
        runs.extend(pr)
        how.append(chosen)
        here = pr[-1].end_xy
    runs = [clip_lead_in(r, detours) for r in runs]
    stops = [(i, kind, pt) for i, r in enumerate(runs)
             for kind, pt in (("lead_in", r.lead_in_xy), ("line_start", (float(r.station_xy[0, 0]), float(r.station_xy[0, 1]))),
                              *(("bend", (float(x), float(y))) for x, y in r.bends_xy), ("line_end", r.end_xy))]
    # which legs cross a zone's margin, in one call: only those look for a way round
    clear = detours.clear_legs(np.array([pt for _, _, pt in stops], float).reshape(-1, 2)).tolist()
    wps: list[Waypoint] = []
    crossing, found = clear.count(False), 0
    for m, (i, kind, pt) in enumerate(stops):
        if m and not clear[m - 1]:
            report("detours round the exclusion zones", found / crossing)
            found += 1
            for d in detours.way_round(stops[m - 1][2], pt):
                wps.append(Waypoint(d[0], d[1], "detour", -1))
        wps.append(Waypoint(pt[0], pt[1], kind, i))
    return Route(tuple(runs), tuple(wps), tuple(how))
