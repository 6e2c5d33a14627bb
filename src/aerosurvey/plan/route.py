"""Route: the order lines are flown in, turnarounds and lead-ins; `build_route` joins the passes
and inserts the detours around exclusion zones.

Input is a list of passes (a heading and its photo runs); output is the ordered list of
waypoints in the planning CRS with the photo runs attached, as plain data. The types are in
passes.py, the flight-time model the candidate orders are compared by in flight_time.py, the
detours in detours.py.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from aerosurvey.plan.detours import Detours, approach_way, clip_lead_in
from aerosurvey.plan.flight_time import Kinematics, PlaneTakeoff, line_orders, path_time, plane_way_out
from aerosurvey.plan.frame import LineFrame
from aerosurvey.plan.lines import LineSegment
from aerosurvey.plan.passes import Pass, Route, Run, Strip, Waypoint
from aerosurvey.plan.progress import Progress, no_progress


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
                        (lead_x[i], lead_y[i]), (end_x[i], end_y[i]), aim=p.aim, rise_m=p.rise_m, looks=p.looks))
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


def _unit(bearing_deg: float) -> tuple[float, float]:
    h = math.radians(bearing_deg)
    return math.sin(h), math.cos(h)


def _strip_run(p: Pass, s: Strip, direction: int, lead_in: float, half_base: float) -> Run:
    """A strip flown one way: its stations, bends and headings in flight order, the lead-in
    `lead_in` before the first station along its direction there, the end `half_base` past the last."""
    n = len(s.stations)
    rise = None if s.rise_m is None else np.asarray(s.rise_m, float)
    if direction > 0:
        xy, idx, heads = s.stations, s.station_index, np.asarray(s.heading_deg, float)
        bends, after = s.path[1:-1], s.bend_after
    else:
        xy, idx, heads = s.stations[::-1], s.station_index[::-1], (np.asarray(s.heading_deg, float)[::-1] + 180.0) % 360.0
        bends, after = s.path[1:-1][::-1], (n - 2 - s.bend_after)[::-1]
        rise = None if rise is None else rise[::-1]
    first, last = xy[0], xy[-1]
    # a ring flown round to its first station goes on round it to its end, as it began: a bend at the last station.
    # So does the last piece of a ring the zones cut, which ends where the first began (else its end went on straight
    # past the ring's corner, the camera held on the side's look: 2.8° off at a photo taken 0.5 m past the station)
    start = p.strips[0]
    round_again = n > 1 and (math.dist(first, last) < 1e-6 if p.ring is not None else
                                 p.one_way and s is not start and math.dist(start.stations[0], last) < 1e-6)
    if round_again:
        bends, after = np.vstack([np.reshape(bends, (-1, 2)), last]), np.append(after, n - 1)
    ux, uy = _unit(float(heads[0]))
    vx, vy = _unit(float(start.heading_deg[0])) if round_again else _unit(float(heads[-1]))
    return Run(p.index, s.line, s.part, direction, float(heads[0]), np.array(xy, float), np.array(idx),
               (float(first[0] - ux * lead_in), float(first[1] - uy * lead_in)),
               (float(last[0] + vx * half_base), float(last[1] + vy * half_base)),
               np.array(bends, float).reshape(-1, 2), np.array(after, np.int64), np.array(heads),
               p.aim, p.rise_m, p.looks, None if rise is None else rise.copy())


def strip_runs(p: Pass, lead_in: float, base: float, start_near: tuple[float, float] | None) -> list[Run]:
    """A pass of strips flown in their order, back and forth: each line the other way from the
    one before (its parts in order along that way), the first line the way whose first station
    is nearer `start_near`; a `one_way` pass's strips each their own way. Each run's lead-in is
    `lead_in` long and it ends half of `base` past its last station, or as the pass's own
    (`Pass.lead_in_m`, `Pass.end_m`) where it has them."""
    lead_in = lead_in if p.lead_in_m is None else p.lead_in_m
    end = base / 2.0 if p.end_m is None else p.end_m
    by_line: dict[int, list[Strip]] = {}
    for s in p.strips:
        by_line.setdefault(s.line, []).append(s)
    lines = [sorted(v, key=lambda s: s.part) for _, v in sorted(by_line.items())]
    first = 1
    if start_near is not None and not p.one_way:
        a, b = lines[0][0].stations[0], lines[0][-1].stations[-1]
        first = 1 if math.dist(start_near, (a[0], a[1])) <= math.dist(start_near, (b[0], b[1])) else -1
    runs: list[Run] = []
    for k, parts in enumerate(lines):
        d = first if k % 2 == 0 or p.one_way else -first
        runs.extend(_strip_run(p, s, d, lead_in, end) for s in (parts if d > 0 else parts[::-1]))
    return runs


def _way_time(a: tuple[float, float], b: tuple[float, float], k: Kinematics) -> float:
    """A straight way from a to b at k's speed, in the wind: its length times its slowness (1 in still air)."""
    d = math.dist(a, b)
    return 0.0 if d <= 0.0 else d * k.slowness(math.degrees(math.atan2(b[1] - a[1], b[0] - a[0]))) / k.speed_ms


@dataclass(frozen=True, eq=False)
class Transits:
    """The ways from the launch point to the flight's first pass and home from its last (`routing.plan_route`),
    flown with `kin` (the transits' speed in the wind, `Kinematics.cruising`). A plane climbs and descends while it
    flies them (`estimates.estimate`): its way out is the sorties' (`detours.approach_way` round `detours`, its climb
    `climb_out` long at the take-off pitch, in planning-grid metres, `grid_scale` of them a metre), flown as
    `flight_time.plane_way_out` flies it (its take-off, `flight_time.PlaneTakeoff`: the climb to `climb_m` at
    `climb_rate_ms` and the air speed `takeoff_speed_ms`), and its way home takes at least its descent time."""

    kin: Kinematics
    home_from: Callable[[tuple[float, float]], tuple[float, float]]  # where the way home ends, of a flight from there
    climb_m: float = 0.0  # a plane's climb to the survey height (0: a copter's is vertical, flown apart)
    climb_rate_ms: float = 1.0
    takeoff_speed_ms: float = 0.0
    descent_s: float = 0.0
    climb_out: float = 0.0
    grid_scale: float = 1.0
    detours: Detours = field(default_factory=lambda: Detours(None, 0.0))

    def out_s(self, home: tuple[float, float], lead: tuple[float, float], first: tuple[float, float]) -> float:
        """The way from `home` to a line's lead-in `lead` (its first station `first`)."""
        if self.climb_m <= 0.0:
            return _way_time(home, lead, self.kin)
        takeoff = PlaneTakeoff(self.kin, self.climb_m, self.climb_rate_ms, self.takeoff_speed_ms, self.grid_scale)
        way = approach_way(home, lead, first, self.climb_out, takeoff, self.detours)
        climb, after = plane_way_out(np.array([home, *way, lead]) / self.grid_scale, self.climb_m, self.climb_rate_ms,
                                     self.takeoff_speed_ms, self.kin)  # in metres, its climb-out's
        return climb + after

    def home_s(self, last: tuple[float, float], flight_start: tuple[float, float]) -> float:
        return max(_way_time(last, self.home_from(flight_start), self.kin), self.descent_s)


def order_pass(p: Pass, lead_in: float, k: Kinematics, spacing: float,
               start_near: tuple[float, float] | None, pinned: bool = False, transits: Transits | None = None,
               flight_start: tuple[float, float] | None = None, last: bool = False) -> tuple[list[Run], str]:
    """The fastest way through a pass: every line across the whole area (camera off over
    notches and holes) or cell by cell where the lines split, each from its best corner; the way
    there from `start_near` included (from the launch point, where `flight_start`, the flight's first
    place, is None, as `transits` flies it) and, for the flight's `last` pass, the way home (`transits`).
    `pinned`: `start_near` is where the pilot chose the pass to start (`flight.pass_start`): of
    the candidates, those whose first run starts nearest to it, and of them the fastest.

    Returns the runs and which of the two was chosen. Candidates are timed from their runs'
    ends alone (`_run_ends`); only the chosen one's runs are made.
    """
    n_lines = 1 + max(s.line for s in p.segments)
    best: tuple[float, float, list[Leg], str] | None = None

    def consider(legs: list[Leg], how: str) -> None:
        nonlocal best
        ends = _run_ends(p, legs, lead_in)
        cost = path_time(ends, k)
        first, end = (float(ends[0, 0]), float(ends[0, 1])), (float(ends[-1, 0]), float(ends[-1, 1]))
        away = 0.0
        if start_near is not None:
            if pinned:
                away = round(math.dist(start_near, first), 3)
            elif flight_start is None and transits is not None:
                cost += transits.out_s(start_near, first, (float(ends[1, 0]), float(ends[1, 1])))
            else:
                cost += _way_time(start_near, first, k)
        if last and transits is not None:
            cost += transits.home_s(end, flight_start or first)
        # a later candidate wins by a microsecond a second or more: orders that tie up to the
        # rounding of the runs' ends (a millimetre) keep the first, whichever way the rounding falls
        if best is None or away < best[0] or (away == best[0] and cost < best[1] * (1.0 - 1e-6) - 1e-9):
            best = (away, cost, legs, how)

    for order in line_orders(n_lines, spacing, k.turn_radius_m, k.vehicle):
        for reverse in (False, True):
            o = order[::-1] if reverse else order
            for first_dir in (1, -1):
                consider(_legs_of_pass(p, o, first_dir), "lines across the whole area")
    todo = cells(p.segments)
    if len(todo) > 1:
        consider(_cells_route(p, todo, lead_in, start_near), f"{len(todo)} cells flown one after another")
    assert best is not None
    return _build_runs(p, best[2], lead_in, _offsets(p)), best[3]


def build_route(passes: list[Pass], lead_in: float, k: Kinematics, spacing_by_pass: list[float],
                start_near: tuple[float, float] | None, detours: Detours, report: Progress = no_progress,
                base: float = 0.0, starts: Mapping[int, tuple[float, float]] | None = None,
                transits: Transits | None = None) -> Route:
    """Order every pass, join them, and insert detours wherever a leg would enter a zone
    (`report` hears how many of the legs that need one have theirs). `starts`: by pass index,
    the place the pilot chose a pass to start at (its first run starts at the line end nearest
    to it); the others start where they are fastest from the place before them, with the ways from
    and back to the launch point (`transits`) where they are the first and the last (an area grid's)."""
    runs: list[Run] = []
    how: list[str] = []
    here = start_near
    last = max((i for i, p in enumerate(passes) if not p.empty), default=-1)
    for i, (p, spacing) in enumerate(zip(passes, spacing_by_pass)):
        if p.empty:
            continue
        pin = (starts or {}).get(p.index)
        if p.frame is not None:
            pr, chosen = order_pass(p, lead_in, k, spacing, pin or here, pin is not None, transits,
                                    runs[0].lead_in_xy if runs else None, i == last)
        else:
            pr = strip_runs(p, lead_in, base, pin or here)
            chosen = "strips in order, each its own way" if p.one_way else "strips in order, back and forth"
        if pin is not None:
            chosen += ", from the start chosen (flight.pass_start)"
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
