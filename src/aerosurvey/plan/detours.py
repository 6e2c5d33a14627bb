"""Detours around exclusion zones: the shortest way round on a visibility graph of the zones'
corners (`Detours`), lead-ins stopped short of a zone's margin, and a plane's climb out from the
launch point.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.plan.passes import Run

if TYPE_CHECKING:
    from aerosurvey.plan.flight_time import PlaneTakeoff


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
    plane's straight climb (`climb` long, towards the first of those waypoints) ends past that
    waypoint and that overshoot, or the way back to it, meets a zone, a first waypoint where the
    climb ends, in the clear direction nearest the way to `first`. ValueError when no direction is
    clear."""
    way = detours.path(home, first)
    towards = way[0] if way else first  # the take-off's leg: the plane climbs straight along it
    d = math.dist(home, towards)
    if climb <= d or detours.blocked is None:
        return way
    bearing = math.atan2(towards[1] - home[1], towards[0] - home[0])
    ahead = (home[0] + climb * math.cos(bearing), home[1] + climb * math.sin(bearing))
    if detours.clear(home, ahead) and detours.clear(ahead, towards):
        return way  # it climbs past the first waypoint and turns back to it, all clear of the zones
    for turn in sorted(np.radians(np.arange(-180.0, 180.0, 5.0)).tolist(), key=abs):
        end = (home[0] + climb * math.cos(bearing + turn), home[1] + climb * math.sin(bearing + turn))
        if detours.clear(home, end):
            return [end, *detours.path(end, first)]
    raise ValueError("a plane taking off there climbs into an exclusion zone whichever way it heads")


def approach_way(home: tuple[float, float], lead: tuple[float, float], first: tuple[float, float], climb: float,
                 takeoff: PlaneTakeoff, detours: Detours) -> list[tuple[float, float]]:
    """Waypoints from the launch point to a line's lead-in `lead` (its first station `first`): `climb_out_path`, and
    where a plane could meet the lead-in heading more than 90° off the line, first to a point `takeoff.setback` behind
    it on the line's extension, so that it turns onto the line there and flies on along it. It could where the way's
    last leg comes from ahead of the lead-in; and where that leg is the take-off's (`takeoff.climb_out` along it),
    longer than the climb-out and from ahead, shorter and from behind (climbing past the lead-in, the plane turns
    back to it, heading away), or within `takeoff.doubt` of it either way. Met heading away, ArduPlane SITL turned round at the
    lead-in and passed the first station 68 m off the line (8 m/s from 270°), where its camera started, a base early.
    Not where the line's extension is blocked by a zone, nor with no lead-in or setback (a copter's: 0)."""
    way = climb_out_path(home, lead, climb, detours)
    length, setback = math.dist(lead, first), takeoff.setback
    if setback <= 0.0 or length <= 0.0:
        return way
    ux, uy = (first[0] - lead[0]) / length, (first[1] - lead[1]) / length
    before = way[-1] if way else home
    towards = (lead[0] - before[0]) * ux + (lead[1] - before[1]) * uy
    if not way:  # the take-off's leg
        leg = math.dist(home, lead)
        out = takeoff.climb_out(math.degrees(math.atan2(lead[1] - home[1], lead[0] - home[0])))
        if abs(leg - out) <= takeoff.doubt:
            towards = -1.0  # either way
        elif leg < out:
            towards = -towards  # climbed past the lead-in, it turns back to it
    if towards >= 0.0:
        return way
    behind = (lead[0] - ux * setback, lead[1] - uy * setback)
    if not detours.clear(behind, lead):
        return way
    return [*climb_out_path(home, behind, climb, detours), behind]
