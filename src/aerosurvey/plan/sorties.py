"""Battery split: cut the route into sorties that each fit one battery.

A sortie is a contiguous range of photo stations in flight order. It takes off at a
launch point, climbs, flies to the lead-in of its first station, photographs its
stations (starting mid-line when the previous sortie ended there, with a new lead-in),
flies back and lands. No station is skipped and none is photographed twice.

The endurance model: horizontal flight time from the route's time model (copter
acceleration and corner stops, plane turns), each leg at its ground speed in the wind
(`Kinematics.ground_speed`: the wind triangle), plus climb and descent at their rates;
energy = time × power when the battery is given in Wh. Each sortie also records what the
same stations from the same launch point take in still air: the share of its battery the
wind takes is the difference.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, replace
from itertools import accumulate

import numpy as np

from aerosurvey.errors import InputError
from aerosurvey.plan.detours import Detours, approach_way, clip_approach
from aerosurvey.plan.flight_time import (
    KEPT,
    Climbs,
    CopterTime,
    Kinematics,
    PlaneTakeoff,
    RouteSegments,
    Segments,
    all_segments,
    descent_time,
    hover_time,
    kept_segments,
    lanes_in_place,
    path_time,
    plane_transit_time,
)
from aerosurvey.plan.landing import way_home
from aerosurvey.plan.model import Heights, RouteWaypoint, Stations
from aerosurvey.plan.passes import Run
from aerosurvey.plan.progress import Progress, no_progress
from aerosurvey.spec import VehicleSpec


@dataclass(frozen=True, eq=False)
class FlightPath:
    """What the battery split needs of a planned route: stations, runs and waypoints in
    flight order, and how altitudes and triggers work along them."""

    stations: Stations
    runs: tuple[Run, ...]
    waypoints: tuple[RouteWaypoint, ...]
    lead_in_m: float
    base_m: float
    grid_scale: float
    altitude_frame: str
    heights: Heights
    home_ground_m: float  # ground under the plan's home (relative altitudes are above it)
    trigger: str
    vehicle: VehicleSpec
    ends: tuple[tuple[float, float], ...]  # per launch site: where the way home ends (a landing plane's approach, else the site)
    climb: float = 0.0  # planning-grid metres a plane climbs straight ahead after take-off
    hover_s: float | None = None  # hover-and-capture: seconds at rest at each station
    hover_look_s: float = 0.0  # hover-and-capture: the hold of each further aim at a place
    aims: int = 1  # station rows at each place (`passes.aims_per_place`): a sortie ends after a place's last


@dataclass(frozen=True)
class LaunchSite:
    x: float
    y: float
    lon: float
    lat: float
    ground_m: float


@dataclass(frozen=True)
class Budget:
    """What one battery allows, in seconds (minutes given) or joules (Wh given)."""

    usable_s: float | None
    usable_j: float | None
    cruise_w: float | None
    climb_w: float | None
    max_items: int
    reserve: float | None = None  # the share of the battery kept back (battery.reserve); None: no battery given
    #: battery.wind_ms's allowance for a wind of unknown direction: horizontal flight costs this many times more
    allowance: float = 1.0

    def cost(self, horizontal_s: float, vertical_s: float) -> float:
        """Battery used, in the budget's unit."""
        if self.usable_j is not None:
            return horizontal_s * self.allowance * (self.cruise_w or 0.0) + vertical_s * (self.climb_w or 0.0)
        return horizontal_s * self.allowance + vertical_s

    @property
    def usable(self) -> float:
        return self.usable_j if self.usable_j is not None else (self.usable_s or 0.0)


@dataclass(frozen=True)
class SortieWaypoint:
    x: float
    y: float
    alt_m: float
    kind: str
    run: int
    station: str


@dataclass(frozen=True)
class Sortie:
    index: int
    first: int  # station index (flight order), inclusive
    last: int
    launch: int  # index into the launch sites
    waypoints: tuple[SortieWaypoint, ...]
    horizontal_s: float  # in the planned wind (still air without one)
    vertical_s: float
    distance_m: float
    battery_used: float  # fraction of the usable battery (reserve excluded)
    items: int
    still_air_s: float  # the same flight's time in still air (horizontal and vertical)
    still_air_used: float  # its fraction of the usable battery in still air: battery_used less it is what the wind takes


#: A sortie waypoint's fields (x, y, alt_m, kind, run, station); SortieWaypoints are made for the chosen sorties only
_Wp = tuple[float, float, float, str, int, str]
_XY = tuple[float, float]
#: CopterTime's state (`CopterTime.state`)
_State = tuple[float, float, float, tuple[float, float] | None]
class _Piece:
    """Stations lo..hi of one run as a sortie flies them (made once for each)."""

    __slots__ = ("wps", "first", "last", "alt_max", "starts")

    def __init__(self, wps: list[_Wp]):
        self.wps = wps
        self.first: _XY = (wps[0][0], wps[0][1])
        self.last: _XY = (wps[-1][0], wps[-1][1])
        self.alt_max = max(w[2] for w in wps)
        self.starts = sum(1 for w in wps if w[3] == "line_start")


class _Ends:
    """What the last pieces of one run share, from its first station to each station b before its
    last (as `_make_run_waypoints` lays them), with the ways home after them to one launch site:
    the lead-in, the chain of points every such piece starts with (lead-in, first station, the
    run's terrain waypoints: a piece has those before b) and its kept-segment measures, and the
    points after the way home round the zones (the end, the site). And for every b at once, by
    the same elementwise numpy operations on the same values as `kept_segments` (k = b − the
    run's first station, n of them): `own` holds the segments from the chain's last point b's
    piece has to b (follow mode) or its line end (k), from b to its line end (n + k), and from
    the line end straight to the first point of `after` (2n + k; unless `round_home[k]`: the
    straight way home crosses a zone)."""

    __slots__ = ("lead", "chain", "chain_segments", "terrain_at", "highest", "after", "straight_home", "own",
                 "round_home", "line_ends")

    def __init__(self, lead: _XY, chain: list[_XY], chain_segments: Segments, terrain_at: list[float],
                 highest: list[float], after: list[_XY], straight_home: Segments, own: Segments, round_home: list[bool],
                 line_ends: list[_XY]):
        self.lead = lead
        self.chain = chain
        self.chain_segments = chain_segments  # every segment, dropped ones too (`all_segments`)
        self.terrain_at = terrain_at  # where each waypoint of the chain lies: its station index (a bend: half past it)
        self.highest = highest  # per chain terrain waypoints kept: the highest altitude of the chain so far
        self.after = after
        self.straight_home = straight_home  # the segments of `after`
        self.own = own  # every segment, dropped ones too
        self.round_home = round_home
        self.line_ends = line_ends  # the line end after each b (k = b - the run's first station)


#: A last piece ending before its run's last station: (waypoints, highest altitude, way home, segments from its lead-in to the site)
_Last = tuple[int, float, list[_XY], Segments]


def _kept(lengths: list[float], angles: list[float]) -> Segments:
    """The segments path_time keeps of these (`kept_segments`' test)."""
    keep = [length > KEPT for length in lengths]
    if all(keep):
        return lengths, angles
    return [x for x, y in zip(lengths, keep) if y], [x for x, y in zip(angles, keep) if y]


#: a sortie is costed from this many launch sites at most, the nearest to its first and last stations
NEAREST_SITES = 6


class Splitter:
    """Builds and costs candidate sorties over a planned route.

    A sortie's survey is a piece of its first run (from its first station), the detours and whole
    runs after it, and a piece of its last run (to its last station). The budget bisection costs
    hundreds of sorties that share these parts (550 for the Obrataň example), so each piece is made
    once, the way from a launch point through the first piece into the route (the head) and out of
    the route through the last piece home (the tail) are measured once, and a copter's time along
    the whole runs between is summed from stretches timed once (RouteSegments). A copter's last
    pieces ending mid-run are not made: what they share per run (`_Ends`) is, and per last station
    only the few segments of its own (`_last`). The sums are
    flight_time.path_time's, term by term in the same order, so the costs are the floats timing each
    sortie's whole polyline gives (tests/test_sorties_exact.py compares them)."""

    def __init__(self, plan: FlightPath, sites: tuple[LaunchSite, ...], budget: Budget, kin: Kinematics, detours: Detours,
                 fixed_launch: int | None):
        self.plan = plan
        self.sites = sites
        self.budget = budget
        self.kin = kin
        self.detours = detours
        self.fixed_launch = fixed_launch
        st = plan.stations
        self.run_of: list[int] = st.run.tolist()
        self.station_x: list[float] = st.x.tolist()
        self.station_y: list[float] = st.y.tolist()
        self.station_alt: list[float] = st.alt_rel_m.tolist()
        # a lane flown up or down: its climbs and descents, and the level way to it flown from rest to rest
        self.rises, self.arrivals = lanes_in_place(st.x, st.y, st.alt_rel_m, st.run, plan.grid_scale)
        self.n = len(st.ids)
        self.run_start: list[int] = np.searchsorted(st.run, np.arange(len(plan.runs))).tolist()
        self.run_end: list[int] = (np.searchsorted(st.run, np.arange(len(plan.runs)), side="right") - 1).tolist()
        # the original waypoints of each run, and the detours leading into it
        self.by_run: dict[int, list[RouteWaypoint]] = {}
        self.detours_before: dict[int, list[RouteWaypoint]] = {}
        pending: list[RouteWaypoint] = []
        for w in plan.waypoints:
            if w.kind == "detour":
                pending.append(w)
                continue
            if w.kind == "lead_in":
                self.detours_before[w.run] = pending
                pending = []
            self.by_run.setdefault(w.run, []).append(w)
        self.station_index = {sid: i for i, sid in enumerate(st.ids)}
        self.site_xy = np.array([(s.x, s.y) for s in sites], float).reshape(-1, 2)
        # each run's waypoints between its ends, by where they lie: a terrain waypoint at its
        # station's index, a bend half a station after the station it follows
        self.inner: dict[int, list[tuple[float, RouteWaypoint]]] = {}
        for r, wps in self.by_run.items():
            bends = iter(plan.runs[r].bend_after.tolist())
            self.inner[r] = [(self.station_index[w.station] if w.kind == "terrain" else self.run_start[r] + next(bends) + 0.5, w)
                             for w in wps if w.kind in ("terrain", "bend")]
        self.heading = np.radians(st.heading_deg)
        # every run's detour in and whole waypoints in flight order; where each run's detour and waypoints begin
        self.route_wps: list[_Wp] = []
        self.detour_at: list[int] = []
        self.run_at: list[int] = []
        for r in range(len(plan.runs)):
            self.detour_at.append(len(self.route_wps))
            self.route_wps.extend((w.x, w.y, w.alt_m, w.kind, w.run, "") for w in self.detours_before.get(r, []))
            self.run_at.append(len(self.route_wps))
            self.route_wps.extend((w.x, w.y, w.alt_m, w.kind, w.run, w.station) for w in self.by_run.get(r, []))
        self.route_alts = [w[2] for w in self.route_wps]
        self.route_starts: list[int] = np.cumsum([0, *(w[3] == "line_start" for w in self.route_wps)]).tolist()
        self._route_segments: RouteSegments | None = None
        self._pieces: dict[tuple[int, int, int], _Piece] = {}
        self._out: dict[tuple[int, int], list[_XY]] = {}
        self._back: dict[tuple[int, int], list[_XY]] = {}
        self._heads: dict[tuple[int, int, bool], _State] = {}
        self._routed: dict[tuple[tuple[int, int, bool], int], _State] = {}
        self._tails: dict[tuple[int, int, int], Segments] = {}
        self._ends_of: dict[tuple[int, int], _Ends] = {}
        self._lasts: dict[tuple[int, int], _Last] = {}
        self._junctions: dict[tuple[int, int, int], Segments] = {}
        self._before_last: dict[tuple[int, int, int], _State] = {}
        self._highest_in: dict[tuple[int, int], list[float]] = {}
        self._costs: dict[tuple[int, int], tuple[float, int, float, float, int]] = {}

    def _piece(self, r: int, a: int, b: int) -> _Piece:
        """Stations a..b (global indices) of run r."""
        key = (r, a, b)
        if key not in self._pieces:
            self._pieces[key] = _Piece(self._make_run_waypoints(r, a, b))
        return self._pieces[key]

    def _make_run_waypoints(self, r: int, a: int, b: int) -> list[_Wp]:
        plan = self.plan
        st = plan.stations
        if a == self.run_start[r] and b == self.run_end[r]:
            return [(w.x, w.y, w.alt_m, w.kind, w.run, w.station) for w in self.by_run[r]]
        ux, uy = self._direction(a)
        vx, vy = self._direction(b)
        lead, half = plan.lead_in_m * plan.grid_scale, plan.base_m * plan.grid_scale / 2.0
        alt_a = float(st.alt_rel_m[a]) if plan.altitude_frame == "relative" else float(plan.heights.nominal_agl_m)
        alt_b = float(st.alt_rel_m[b]) if plan.altitude_frame == "relative" else float(plan.heights.nominal_agl_m)
        # a sortie resuming mid-line approaches its first station anew (shortened where a zone is in the way)
        lx, ly = clip_approach((float(st.x[a]), float(st.y[a])), (st.x[a] - ux * lead, st.y[a] - uy * lead), self.detours)
        out: list[_Wp] = [(lx, ly, alt_a, "lead_in", r, ""), (float(st.x[a]), float(st.y[a]), alt_a, "line_start", r, st.ids[a])]
        for at, w in self.inner[r]:
            if a < at < b:
                out.append((w.x, w.y, w.alt_m, w.kind, r, w.station))
        if plan.heights.mode == "follow" and b > a:
            out.append((float(st.x[b]), float(st.y[b]), alt_b, "terrain", r, st.ids[b]))
        out.append((st.x[b] + vx * half, st.y[b] + vy * half, alt_b, "line_end", r, ""))
        return out

    def _direction(self, i: int) -> tuple[float, float]:
        """The direction of flight at station i (a unit vector)."""
        h = float(self.heading[i])
        return math.sin(h), math.cos(h)

    def _parts(self, a: int, b: int) -> tuple[_Piece, int, int, _Piece]:
        """Stations a..b: the piece of the first run, the route's waypoints [i, j) after it (detours
        and whole runs) and the piece of the last run (the first piece again, j = i, within one run)."""
        r0, r1 = self.run_of[a], self.run_of[b]
        if r0 == r1:
            p = self._piece(r0, a, b)
            return p, 0, 0, p
        return (self._piece(r0, a, self.run_end[r0]), self.detour_at[r0 + 1], self.run_at[r1],
                self._piece(r1, self.run_start[r1], b))

    def waypoints(self, a: int, b: int) -> list[_Wp]:
        """The survey waypoints of stations a..b in flight order."""
        p0, i, j, p1 = self._parts(a, b)
        return p0.wps if p1 is p0 else [*p0.wps, *self.route_wps[i:j], *p1.wps]

    def _ways(self, li: int, first: _Piece, last: _Piece) -> tuple[list[_XY], list[_XY]]:
        """The points between launch site li and the first piece, and between the last piece and the
        site's end (round the zones)."""
        kb = (li, id(last))  # pieces live as long as the splitter
        if kb not in self._back:
            self._back[kb] = self.detours.path(last.last, self.plan.ends[li])
        return self._way_out(li, first), self._back[kb]

    def _way_out(self, li: int, first: _Piece) -> list[_XY]:
        """The points between launch site li and the first piece (round the zones; a plane's onto its line,
        `approach_way`)."""
        ko = (li, id(first))
        if ko not in self._out:
            home = (self.sites[li].x, self.sites[li].y)
            station = (first.wps[1][0], first.wps[1][1])
            plan, v = self.plan, self.plan.vehicle
            takeoff = PlaneTakeoff(self.kin, plan.heights.max_agl_m, v.climb_rate_ms, v.cruise_speed_ms, plan.grid_scale)
            self._out[ko] = approach_way(home, first.first, station, plan.climb, takeoff, self.detours)
        return self._out[ko]

    def _leg_out(self, li: int, first: _Piece) -> list[_XY]:
        """The polyline out: the site and the way out."""
        return [(self.sites[li].x, self.sites[li].y), *self._way_out(li, first)]

    def _legs(self, li: int, p0: _Piece, p1: _Piece) -> tuple[list[_XY], list[_XY], list[_XY], list[_XY]]:
        """(way out, way home, polyline out: the site and the way out, polyline home: the way home, the end, the site)."""
        out_via, back_via = self._ways(li, p0, p1)
        home, end = (self.sites[li].x, self.sites[li].y), self.plan.ends[li]
        return out_via, back_via, [home, *out_via], way_home(back_via, end, home)

    def _points(self, li: int, a: int, b: int) -> np.ndarray:
        """The sortie's polyline from launch site li, divided by the grid scale (as the old costing made it)."""
        p0, i, j, p1 = self._parts(a, b)
        _, _, out_leg, back_leg = self._legs(li, p0, p1)
        pts = np.asarray([(w[0], w[1]) for w in self.waypoints(a, b)])
        return np.vstack([np.asarray(out_leg), pts, np.asarray(back_leg)]) / self.plan.grid_scale

    def _copter_time(self, li: int, p0: _Piece, i: int, j: int, tail: Segments) -> float:
        """flight_time.path_time of the sortie's polyline: the head (site, way out, first piece, into the
        route), the route's whole runs, and the kept segments of the tail after them.

        CopterTime is a fold over the polyline's kept segments, so its state after a part is kept
        and the rest fed from it: after the head (the same for every sortie with this head) and
        after the route's runs up to a run (every sortie of that head ending in that run)."""
        t = CopterTime(self.kin, *self._routed_state(li, p0, i, j))
        t.feed(tail)
        return t.time()

    def _into_state(self, li: int, p0: _Piece, i: int, j: int, r: int) -> _State:
        """CopterTime's state after the head, the route's whole runs and the segment into run r's
        last pieces (every sortie of this head ending mid-run r), found once."""
        key = (li, id(p0), r)
        if key not in self._before_last:
            t = CopterTime(self.kin, *self._routed_state(li, p0, i, j))
            t.feed(self._into(li, p0, i, j, r))
            self._before_last[key] = t.state()
        return self._before_last[key]

    def _routed_state(self, li: int, p0: _Piece, i: int, j: int) -> _State:
        """CopterTime's state after the head and the route's waypoints [i, j)."""
        kh = (li, id(p0), i < j)
        state = self._heads.get(kh)
        if state is None:  # the sum from the start: the same for every sortie with this head
            into = [(self.route_wps[i][0], self.route_wps[i][1])] if i < j else []
            h = CopterTime(self.kin)
            h.feed(kept_segments(np.asarray([*self._leg_out(li, p0), *((w[0], w[1]) for w in p0.wps), *into])
                                 / self.plan.grid_scale))
            state = self._heads[kh] = h.state()
        if i < j:
            routed = self._routed.get((kh, j))
            if routed is None:  # every sortie of this head ending in the run at j
                t = CopterTime(self.kin, *state)
                rs = self._route()
                t.route(rs, rs.kept_before[i], rs.kept_before[j - 1])
                routed = self._routed[(kh, j)] = t.state()
            state = routed
        return state

    def _tail(self, li: int, p0: _Piece, i: int, j: int, p1: _Piece) -> Segments:
        """The kept segments after the route's whole runs: within one run the way home from the
        piece's end; else out of the route's last waypoint (or straight from the first piece where
        no whole run or detour lies between), the last piece and the way home."""
        kt = (li, id(p1), -1 if i < j else id(p0))
        if kt not in self._tails:
            _, _, _, back_leg = self._legs(li, p0, p1)
            if p1 is p0:
                tail = [p0.last, *back_leg]
            else:
                tail = [self._into_last(p0, i, j), *((w[0], w[1]) for w in p1.wps), *back_leg]
            self._tails[kt] = kept_segments(np.asarray(tail) / self.plan.grid_scale)
        return self._tails[kt]

    def _into(self, li: int, p0: _Piece, i: int, j: int, r: int) -> Segments:
        """The kept segment into run r's last pieces (to site li): from the route's waypoint before
        it, or from the first piece's end where no whole run or detour lies between; measured once."""
        key = (li, r, -1 if i < j else id(p0))
        if key not in self._junctions:
            ends = np.asarray([self._into_last(p0, i, j), self._ends(li, r).lead], float)
            self._junctions[key] = kept_segments(ends / self.plan.grid_scale)
        return self._junctions[key]

    def _into_last(self, p0: _Piece, i: int, j: int) -> _XY:
        """Where the way into the last run starts: the route's waypoint before it, or the first piece's end."""
        return (self.route_wps[j - 1][0], self.route_wps[j - 1][1]) if i < j else p0.last

    def _ends(self, li: int, r: int) -> _Ends:
        """What run r's last pieces and ways home to site li share (`_Ends`), made once."""
        if (li, r) not in self._ends_of:
            plan, st, gs = self.plan, self.plan.stations, self.plan.grid_scale
            a, e = self.run_start[r], self.run_end[r]
            lead, start, _ = self._piece(r, a, a).wps  # as every piece from a lays them
            terr = [w for at_, w in self.inner[r] if at_ > a]
            at = [at_ for at_, _ in self.inner[r] if at_ > a]
            assert at == sorted(at), "a run's terrain waypoints follow its stations"
            chain = [(lead[0], lead[1]), (start[0], start[1]), *((w.x, w.y) for w in terr)]
            home, end = (self.sites[li].x, self.sites[li].y), plan.ends[li]
            after = way_home([], end, home)
            # every b's own segments (see _Ends): the points as _make_run_waypoints makes them
            bs = np.arange(a, e)
            q = (np.asarray(chain, float) / gs)[np.searchsorted(np.asarray(at, np.int64), bs) + 1]
            ux, uy = np.sin(self.heading[a:e]), np.cos(self.heading[a:e])
            half = plan.base_m * plan.grid_scale / 2.0
            ex, ey = st.x[a:e] + ux * half, st.y[a:e] + uy * half
            sx, sy, exg, eyg = st.x[a:e] / gs, st.y[a:e] / gs, ex / gs, ey / gs
            follow = (bs > a) & (plan.heights.mode == "follow")
            nx, ny = after[0][0] / gs, after[0][1] / gs
            dx = np.concatenate([np.where(follow, sx, exg) - q[:, 0], exg - sx, nx - exg])
            dy = np.concatenate([np.where(follow, sy, eyg) - q[:, 1], eyg - sy, ny - eyg])
            self._ends_of[(li, r)] = _Ends(
                chain[0], chain, all_segments(np.asarray(chain, float) / gs), at,
                list(accumulate([lead[2], *(w.alt_m for w in terr)], max)), after, all_segments(np.asarray(after, float) / gs),
                (np.hypot(dx, dy).tolist(), np.degrees(np.arctan2(dy, dx)).tolist()),
                self.detours.crossing(np.column_stack([ex, ey]), end), list(zip(ex.tolist(), ey.tolist())))
        return self._ends_of[(li, r)]

    def _last(self, li: int, r: int, b: int) -> _Last:
        """The last piece of run r from its first station to b (before its last one), made once."""
        if (li, b) in self._lasts:
            return self._lasts[(li, b)]
        plan = self.plan
        ends = self._ends(li, r)
        m = bisect.bisect_left(ends.terrain_at, b)  # the piece has the terrain waypoints before b
        follow = plan.heights.mode == "follow" and b > self.run_start[r]
        k, n = b - self.run_start[r], len(ends.round_home)
        back: list[_XY] = []
        if ends.round_home[k]:
            line_end = ends.line_ends[k]
            back = self.detours.way_round(line_end, plan.ends[li])
            own = [ends.chain[m + 1], *([(self.station_x[b], self.station_y[b])] if follow else []), line_end, back[0]]
            lengths, angles = all_segments(np.asarray(own, float) / plan.grid_scale)
            rest = all_segments(np.asarray([*back, *ends.after], float) / plan.grid_scale)
        else:
            at = [k, n + k, 2 * n + k] if follow else [k, 2 * n + k]
            lengths, angles = [ends.own[0][x] for x in at], [ends.own[1][x] for x in at]
            rest = ends.straight_home
        alt = self.station_alt[b] if plan.altitude_frame == "relative" else float(plan.heights.nominal_agl_m)
        chain = ends.chain_segments
        last = self._lasts[(li, b)] = (3 + m + follow, max(ends.highest[m], alt), back,
                                       _kept(chain[0][:m + 1] + lengths + rest[0], chain[1][:m + 1] + angles + rest[1]))
        return last

    def _highest(self, i: int, j: int) -> list[float]:
        """The highest of the route's waypoints [i, j) (none if empty), found once for each range."""
        if (i, j) not in self._highest_in:
            self._highest_in[(i, j)] = [max(self.route_alts[i:j])] if i < j else []
        return self._highest_in[(i, j)]

    def _route(self) -> RouteSegments:
        if self._route_segments is None:
            xy = np.asarray([(w[0], w[1]) for w in self.route_wps]).reshape(-1, 2)
            self._route_segments = RouteSegments(xy / self.plan.grid_scale, self.kin)
        return self._route_segments

    def cost(self, a: int, b: int) -> tuple[float, int, float, float, int]:
        """(battery used, launch index, horizontal s, vertical s, items) of the sortie of stations a..b.

        Memoised: the budget bisection asks for the same (first, last) stations again (550 distinct
        of 890 calls for the Obrataň example)."""
        key = (a, b)
        if key not in self._costs:
            self._costs[key] = self._cost(a, b)
        return self._costs[key]

    def _cost(self, a: int, b: int) -> tuple[float, int, float, float, int]:
        r0, r1 = self.run_of[a], self.run_of[b]
        # a copter's sortie ending mid-run: its last piece and way home from the run's table (_Ends)
        by_ends = self.kin.vehicle == "copter" and r0 != r1 and b < self.run_end[r1]
        if by_ends:
            p0, i, j, p1 = self._piece(r0, a, self.run_end[r0]), self.detour_at[r0 + 1], self.run_at[r1], None
            n1, alt1, _, _ = self._last(self.fixed_launch or 0, r1, b)
            starts1 = 1
        else:
            p0, i, j, p1 = self._parts(a, b)
            n1, starts1, alt1 = len(p1.wps), p1.starts, p1.alt_max
        one = p1 is p0
        n_survey = len(p0.wps) if one else len(p0.wps) + (j - i) + n1
        starts = p0.starts if one else p0.starts + (self.route_starts[j] - self.route_starts[i]) + starts1
        if self.plan.altitude_frame != "relative":
            climb = self.plan.heights.nominal_agl_m
        elif one:
            climb = p0.alt_max
        else:  # the highest survey waypoint: max() over them all is the first of the highest, as here
            climb = max(p0.alt_max, *self._highest(i, j), alt1)
        per_trigger = 0 if self.plan.trigger in ("camera", "hover") else 2
        # hover-and-capture: a waypoint and a shot at every station (at most, where a waypoint is one already), and with
        # several aims at a place the gimbal turned after each shot but a run's last
        rows = b - a + 1
        shots = 2 * rows + (rows - (r1 - r0 + 1) if self.plan.aims > 1 else 0) if self.plan.trigger == "hover" else 0
        candidates = [self.fixed_launch] if self.fixed_launch is not None else self._nearest_sites(a, b)
        best: tuple[float, int, float, float, int] | None = None
        v = self.plan.vehicle
        gs = self.plan.grid_scale
        # a plane's survey is timed apart from its ways out and home (`plane_transit_time`)
        survey = None if p1 is None or v.type != "plane" else np.asarray([(w[0], w[1]) for w in self.waypoints(a, b)]) / gs
        for li in candidates:
            out_via = self._way_out(li, p0)
            h = max(climb + (self.plan.home_ground_m - self.sites[li].ground_m), 1.0)
            vert = h / v.climb_rate_ms + descent_time(h, v.descent_rate_ms, v.type)
            if p1 is None:
                _, _, back_via, segs = self._last(li, r1, b)
                t = CopterTime(self.kin, *self._into_state(li, p0, i, j, r1))
                t.feed(segs)
                horiz = t.time()
            elif survey is None:
                _, back_via, _, _ = self._legs(li, p0, p1)
                horiz = self._copter_time(li, p0, i, j, self._tail(li, p0, i, j, p1))
            else:  # a plane climbs and descends while it flies out and home
                _, back_via, out_leg, back_leg = self._legs(li, p0, p1)
                lands = self.plan.ends[li] != (self.sites[li].x, self.sites[li].y)  # through a landing's approach
                t_out, t_back, t_climb, t_descent = plane_transit_time(np.asarray([*out_leg, p0.first]) / gs,
                                                                       np.asarray([p1.last, *back_leg]) / gs, h,
                                                                       v.climb_rate_ms, v.cruise_speed_ms,
                                                                       v.descent_rate_ms, self.kin,
                                                                       v.landing_speed_ms if lands else None)
                horiz, vert = path_time(survey, self.kin) + t_out + t_back, t_climb + t_descent
            if self.plan.hover_s is not None:
                horiz += hover_time(b - a + 1, r1 - r0 + 1, self.plan.base_m, self.plan.lead_in_m, self.plan.hover_s, self.kin,
                                    self.plan.aims, self.plan.hover_look_s, self.rises[a + 1:b + 1],
                                    Climbs(v.climb_rate_ms, v.descent_rate_ms), self.arrivals[a + 1:b + 1])
            used = self.budget.cost(horiz, vert)
            if best is None or used < best[0]:
                best = (used, li, horiz, vert, 3 + len(out_via) + n_survey + len(back_via) + per_trigger * starts + shots)
        assert best is not None
        return best

    def _nearest_sites(self, a: int, b: int) -> list[int]:
        """The launch sites a sortie of stations a..b is costed from: the NEAREST_SITES with the
        shortest straight way to station a and back from station b (a farther site only adds
        transit; with 110 sites along a 220 km corridor, costing every one took 20 s of 28)."""
        if len(self.sites) <= NEAREST_SITES:
            return list(range(len(self.sites)))
        d = (np.hypot(self.site_xy[:, 0] - self.station_x[a], self.site_xy[:, 1] - self.station_y[a])
             + np.hypot(self.site_xy[:, 0] - self.station_x[b], self.site_xy[:, 1] - self.station_y[b]))
        return sorted(np.argsort(d, kind="stable")[:NEAREST_SITES].tolist())

    def evaluate(self, a: int, b: int) -> tuple[float, int, float, float, float, list[SortieWaypoint], int]:
        """(battery used, launch index, horizontal s, vertical s, distance m, waypoints, items)."""
        used, li, horiz, vert, items = self.cost(a, b)
        p0, _, _, p1 = self._parts(a, b)
        out_via, back_via, _, _ = self._legs(li, p0, p1)
        dist = float(np.hypot(*np.diff(self._points(li, a, b), axis=0).T).sum())
        survey = self.waypoints(a, b)
        # the way from the launch point and back home goes round the zones as the costing did
        wps = ([SortieWaypoint(x, y, survey[0][2], "transit", -1, "") for x, y in out_via]
               + [SortieWaypoint(*w) for w in survey]
               + [SortieWaypoint(x, y, survey[-1][2], "transit", -1, "") for x, y in back_via])
        return used, li, horiz, vert, dist, wps, items

    def fits(self, a: int, b: int, budget: float) -> bool:
        used, *_, items = self.cost(a, b)
        return used <= budget and items <= self.budget.max_items

    def greedy(self, budget: float, most: int | None = None, start: int = 0) -> list[tuple[int, int]]:
        """Sorties over the stations from `start` as long as `budget` allows, by binary search for
        each sortie's last station; none when a station does not fit alone, or when more than
        `most` sorties would be needed (the search stops there: the budget bisection needs to know
        no more)."""
        out: list[tuple[int, int]] = []
        k = self.plan.aims  # a sortie ends with a place's last row: the places' numbers are searched

        def last_row(place: int) -> int:
            return min(place * k + k - 1, self.n - 1)

        a = start
        while a < self.n:
            if most is not None and len(out) == most:
                return []
            if not self.fits(a, last_row(a // k), budget):
                return []
            lo, hi = a // k, (self.n - 1) // k
            if self.fits(a, last_row(hi), budget):
                lo = hi
            else:
                while hi - lo > 1:
                    mid = (lo + hi) // 2
                    if self.fits(a, last_row(mid), budget):
                        lo = mid
                    else:
                        hi = mid
            out.append((a, last_row(lo)))
            a = last_row(lo) + 1
        return out


def split(plan: FlightPath, sites: tuple[LaunchSite, ...], budget: Budget, kin: Kinematics, detours: Detours,
          fixed_launch: int | None, start: int = 0, report: Progress = no_progress) -> list[Sortie]:
    """Fewest sorties over the stations from `start` (0: the whole route; later: the rest of a
    flight cut short), then as balanced as they can be (`report` hears of each balancing round)."""
    sp = Splitter(plan, sites, budget, kin, detours, fixed_launch)
    used, li, horiz, vert, items = sp.cost(start, start)
    if used > budget.usable or items > budget.max_items:
        unit = "Wh" if budget.usable_j is not None else "min"
        scale = 3600.0 if budget.usable_j is not None else 60.0
        raise InputError(
            f"battery too small: one battery gives {budget.usable / scale:.1f} {unit} after the reserve, but taking off, "
            f"flying to the first station, photographing it and coming back takes {used / scale:.1f} {unit} "
            f"({horiz / 60:.1f} min level flight, {vert / 60:.1f} min climb and descent)"
        )
    first = sp.greedy(budget.usable, start=start)
    if not first:
        raise InputError("battery too small: a station farther out cannot be reached and photographed on one battery "
                         "from any launch point; add a launch point nearer to the area")
    n = len(first)
    total = sum(sp.cost(a, b)[0] for a, b in first)
    lo, hi = total / n, budget.usable
    best = first
    for rounds in range(12 if math.isfinite(hi) else 0):
        report("battery sorties: balancing", rounds / 12)
        mid = (lo + hi) / 2
        trial = sp.greedy(mid, n, start)  # more than n sorties fail the trial as none do
        if trial:
            best, hi = trial, mid
        else:
            lo = mid
    sorties = []
    calm: dict[int, Splitter] = {}  # per launch point: the sorties flown from it in still air
    for k, (a, b) in enumerate(best, start=1):
        used, li, horiz, vert, dist, wps, items = sp.evaluate(a, b)
        if kin.calm and budget.allowance == 1.0:
            still_used, still_h, still_v = used, horiz, vert
        else:  # the same stations from the same launch point in still air, without an allowance
            if li not in calm:
                calm[li] = Splitter(plan, sites, replace(budget, allowance=1.0), replace(kin, wind_x=0.0, wind_y=0.0),
                                    detours, li)
            still_used, _, still_h, still_v, _ = calm[li].cost(a, b)
        sorties.append(Sortie(k, a, b, li, tuple(wps), horiz, vert, dist, used / budget.usable, items,
                              still_h + still_v, still_used / budget.usable))
    return sorties
