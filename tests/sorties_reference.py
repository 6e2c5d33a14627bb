"""The battery split's sortie costs as computed before the incremental costing (commit 5cd63bf):
every candidate sortie's waypoints built and its whole polyline timed by route.path_time.
Kept verbatim as the reference the new Splitter must match bit for bit (tests/test_sorties_exact.py)."""

from __future__ import annotations

import math

import numpy as np

from aerosurvey.errors import InputError
from aerosurvey.plan.model import RouteWaypoint
from aerosurvey.plan.route import Detours, Kinematics, climb_out_path, clip_approach, descent_time, path_time
from aerosurvey.plan.sorties import Budget, FlightPath, LaunchSite, Sortie, SortieWaypoint


class ReferenceSplitter:
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


def reference_split(plan: FlightPath, sites: tuple[LaunchSite, ...], budget: Budget, kin: Kinematics, detours: Detours,
          fixed_launch: int | None) -> list[Sortie]:
    """Fewest sorties, then as balanced as they can be."""
    sp = ReferenceSplitter(plan, sites, budget, kin, detours, fixed_launch)
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
