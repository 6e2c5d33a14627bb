"""Battery split: cut the route into sorties that each fit one battery.

A sortie is a contiguous range of photo stations in flight order. It takes off at a
launch point, climbs, flies to the lead-in of its first station, photographs its
stations (starting mid-line when the previous sortie ended there, with a new lead-in),
flies back and lands. No station is skipped and none is photographed twice.

The endurance model: horizontal flight time from the route's time model (copter
acceleration and corner stops, plane turns) multiplied by a wind allowance
1 / (1 − (w/v)²) (a round trip against and with a steady wind w), plus climb and
descent at their rates; energy = time × power when the battery is given in Wh.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from aerosurvey.errors import InputError
from aerosurvey.plan.model import Heights, RouteWaypoint, Stations
from aerosurvey.plan.route import Detours, Kinematics, Run, climb_out_path, clip_approach, descent_time, path_time
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
    wind_factor: float
    max_items: int

    def cost(self, horizontal_s: float, vertical_s: float) -> float:
        """Battery used, in the budget's unit."""
        if self.usable_j is not None:
            return horizontal_s * self.wind_factor * (self.cruise_w or 0.0) + vertical_s * (self.climb_w or 0.0)
        return horizontal_s * self.wind_factor + vertical_s

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
    horizontal_s: float  # still air; the battery use includes the wind allowance
    vertical_s: float
    distance_m: float
    battery_used: float  # fraction of the usable battery (reserve excluded)
    items: int


def wind_factor(wind_ms: float, speed_ms: float) -> float:
    """Time allowance of a round trip against and with a steady wind: 1 / (1 − (w/v)²); w < v."""
    if not 0.0 <= wind_ms < speed_ms:
        raise ValueError(f"wind {wind_ms:g} m/s must be below the speed {speed_ms:g} m/s")
    return 1.0 / (1.0 - (wind_ms / speed_ms) ** 2)


class Splitter:
    """Builds and costs candidate sorties over a planned route."""

    def __init__(self, plan: FlightPath, sites: tuple[LaunchSite, ...], budget: Budget, kin: Kinematics, detours: Detours,
                 fixed_launch: int | None):
        self.plan = plan
        self.sites = sites
        self.budget = budget
        self.kin = kin
        self.detours = detours
        self.fixed_launch = fixed_launch
        st = plan.stations
        self.run_of = st.run
        self.n = len(st.ids)
        self.run_start = np.searchsorted(st.run, np.arange(len(plan.runs)))
        self.run_end = np.searchsorted(st.run, np.arange(len(plan.runs)), side="right") - 1
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
        self._evaluated: dict[tuple[int, int], tuple[float, int, float, float, float, list[SortieWaypoint], int]] = {}
        self._run_wps: dict[tuple[int, int, int], list[SortieWaypoint]] = {}
        self._detour_wps: dict[int, list[SortieWaypoint]] = {}

    def _run_waypoints(self, r: int, a: int, b: int) -> list[SortieWaypoint]:
        """Waypoints flying stations a..b (global indices) of run r; made once for each (the
        budget bisection asks for the same runs again and again: 4,101 times for 550 distinct
        sorties of the Obrataň example, 65 of the split's 227 ms)."""
        key = (r, a, b)
        if key not in self._run_wps:
            self._run_wps[key] = self._make_run_waypoints(r, a, b)
        return self._run_wps[key]

    def _detour_waypoints(self, r: int) -> list[SortieWaypoint]:
        """The detour into run r, as sortie waypoints (made once a run)."""
        if r not in self._detour_wps:
            self._detour_wps[r] = [SortieWaypoint(w.x, w.y, w.alt_m, w.kind, w.run, "") for w in self.detours_before.get(r, [])]
        return self._detour_wps[r]

    def _make_run_waypoints(self, r: int, a: int, b: int) -> list[SortieWaypoint]:
        plan = self.plan
        st = plan.stations
        if a == self.run_start[r] and b == self.run_end[r]:
            return [SortieWaypoint(w.x, w.y, w.alt_m, w.kind, w.run, w.station) for w in self.by_run[r]]
        ux, uy = self._direction(r)
        lead, half = plan.lead_in_m * plan.grid_scale, plan.base_m * plan.grid_scale / 2.0
        alt_a = float(st.alt_rel_m[a]) if plan.altitude_frame == "relative" else float(plan.heights.nominal_agl_m)
        alt_b = float(st.alt_rel_m[b]) if plan.altitude_frame == "relative" else float(plan.heights.nominal_agl_m)
        # a sortie resuming mid-line approaches its first station anew (shortened where a zone is in the way)
        lx, ly = clip_approach((float(st.x[a]), float(st.y[a])), (st.x[a] - ux * lead, st.y[a] - uy * lead), self.detours)
        out = [SortieWaypoint(lx, ly, alt_a, "lead_in", r, ""),
               SortieWaypoint(float(st.x[a]), float(st.y[a]), alt_a, "line_start", r, st.ids[a])]
        for w in self.by_run[r]:
            if w.kind == "terrain" and a < self.station_index[w.station] < b:
                out.append(SortieWaypoint(w.x, w.y, w.alt_m, "terrain", r, w.station))
        if plan.heights.mode == "follow" and b > a:
            out.append(SortieWaypoint(float(st.x[b]), float(st.y[b]), alt_b, "terrain", r, st.ids[b]))
        out.append(SortieWaypoint(st.x[b] + ux * half, st.y[b] + uy * half, alt_b, "line_end", r, ""))
        return out

    def _direction(self, r: int) -> tuple[float, float]:
        h = math.radians(self.plan.runs[r].heading_deg)
        return math.sin(h), math.cos(h)

    def waypoints(self, a: int, b: int) -> list[SortieWaypoint]:
        out: list[SortieWaypoint] = []
        r0, r1 = int(self.run_of[a]), int(self.run_of[b])
        for r in range(r0, r1 + 1):
            if r > r0:
                out.extend(self._detour_waypoints(r))
            lo = max(a, int(self.run_start[r]))
            hi = min(b, int(self.run_end[r]))
            out.extend(self._run_waypoints(r, lo, hi))
        return out

    def _items(self, wps: list[SortieWaypoint]) -> int:
        per_trigger = 0 if self.plan.trigger == "camera" else 2
        runs = sum(1 for w in wps if w.kind == "line_start")
        return 3 + len(wps) + per_trigger * runs

    def evaluate(self, a: int, b: int) -> tuple[float, int, float, float, float, list[SortieWaypoint], int]:
        """(battery used, launch index, horizontal s, vertical s, distance m, waypoints, items).

        Memoised: the budget bisection asks for the same (first, last) stations again (550
        distinct of 890 calls for the Obrataň example)."""
        key = (a, b)
        if key not in self._evaluated:
            self._evaluated[key] = self._evaluate(a, b)
        return self._evaluated[key]

    def _evaluate(self, a: int, b: int) -> tuple[float, int, float, float, float, list[SortieWaypoint], int]:
        survey = self.waypoints(a, b)
        pts = np.asarray([(w.x, w.y) for w in survey])
        climb = max(w.alt_m for w in survey) if self.plan.altitude_frame == "relative" else self.plan.heights.nominal_agl_m
        candidates = [self.fixed_launch] if self.fixed_launch is not None else range(len(self.sites))
        best: tuple[float, int, float, float, float, list[SortieWaypoint]] | None = None
        first, last = (survey[0].x, survey[0].y), (survey[-1].x, survey[-1].y)
        for li in candidates:
            s = self.sites[li]
            home = (s.x, s.y)
            alt_shift = self.plan.home_ground_m - s.ground_m
            end = self.plan.ends[li]
            out_via, back_via = climb_out_path(home, first, self.plan.climb, self.detours), self.detours.path(last, end)
            out_leg = [home, *out_via]
            back_leg = [*back_via, *([end] if end != home else []), home]
            poly = np.vstack([np.asarray(out_leg), pts, np.asarray(back_leg)]) / self.plan.grid_scale
            horiz = path_time(poly, self.kin)
            v = self.plan.vehicle
            h = max(climb + alt_shift, 1.0)
            vert = h / v.climb_rate_ms + descent_time(h, v.descent_rate_ms, v.type)
            if v.type == "plane":  # climb and descent overlap the transits out and back
                t_out = path_time(np.asarray([*out_leg, first]) / self.plan.grid_scale, self.kin)
                t_back = path_time(np.asarray([last, *back_leg]) / self.plan.grid_scale, self.kin)
                vert = max(0.0, h / v.climb_rate_ms - t_out) + max(0.0, descent_time(h, v.descent_rate_ms, v.type) - t_back)
            dist = float(np.hypot(*np.diff(poly, axis=0).T).sum())
            used = self.budget.cost(horiz, vert)
            if best is None or used < best[0]:
                # the way from the launch point and back home goes round the zones as the costing did
                wps = ([SortieWaypoint(x, y, survey[0].alt_m, "transit", -1, "") for x, y in out_via] + survey
                       + [SortieWaypoint(x, y, survey[-1].alt_m, "transit", -1, "") for x, y in back_via])
                best = (used, li, horiz, vert, dist, wps)
        assert best is not None
        return (*best, self._items(best[5]))

    def fits(self, a: int, b: int, budget: float) -> bool:
        used, *_, items = self.evaluate(a, b)
        return used <= budget and items <= self.budget.max_items

    def greedy(self, budget: float) -> list[tuple[int, int]]:
        """Sorties as long as `budget` allows, by binary search for each sortie's last station."""
        out = []
        a = 0
        while a < self.n:
            if not self.fits(a, a, budget):
                return []
            lo, hi = a, self.n - 1
            if self.fits(a, hi, budget):
                lo = hi
            else:
                while hi - lo > 1:
                    mid = (lo + hi) // 2
                    if self.fits(a, mid, budget):
                        lo = mid
                    else:
                        hi = mid
            out.append((a, lo))
            a = lo + 1
        return out


def split(plan: FlightPath, sites: tuple[LaunchSite, ...], budget: Budget, kin: Kinematics, detours: Detours,
          fixed_launch: int | None) -> list[Sortie]:
    """Fewest sorties, then as balanced as they can be."""
    sp = Splitter(plan, sites, budget, kin, detours, fixed_launch)
    used, li, horiz, vert, dist, wps, items = sp.evaluate(0, 0)
    if used > budget.usable or items > budget.max_items:
        unit = "Wh" if budget.usable_j is not None else "min"
        scale = 3600.0 if budget.usable_j is not None else 60.0
        raise InputError(
            f"battery too small: one battery gives {budget.usable / scale:.1f} {unit} after the reserve, but taking off, "
            f"flying to the first station, photographing it and coming back takes {used / scale:.1f} {unit} "
            f"({horiz / 60:.1f} min level flight, {vert / 60:.1f} min climb and descent)"
        )
    first = sp.greedy(budget.usable)
    if not first:
        raise InputError("battery too small: a station farther out cannot be reached and photographed on one battery "
                         "from any launch point; add a launch point nearer to the area")
    n = len(first)
    total = sum(sp.evaluate(a, b)[0] for a, b in first)
    lo, hi = total / n, budget.usable
    best = first
    for _ in range(12):
        mid = (lo + hi) / 2
        trial = sp.greedy(mid)
        if trial and len(trial) == n:
            best, hi = trial, mid
        else:
            lo = mid
    sorties = []
    for k, (a, b) in enumerate(best, start=1):
        used, li, horiz, vert, dist, wps, items = sp.evaluate(a, b)
        sorties.append(Sortie(k, a, b, li, tuple(wps), horiz, vert, dist, used / budget.usable, items))
    return sorties
