"""The corridor pattern: strips along a centreline (a road, a river, a pipeline, a power line).

A corridor is the ground `left_m` to the left and `right_m` to the right of its centreline
(`Site.centreline` and `Site.sides_m`, the area is that ground; the site step derives both from
a corridor polygon when area.file holds one, plan/centreline.py). Its strips are the centreline offset sideways
to the ordinates an area grid's lines would have across the same width (`strip_offsets`: every
point in ⌊1/(1−side)⌋ strips), or one strip down the middle when one footprint spans the width.
Each strip bends where the centreline does, with mitred corners, so the outside of a bend is
flown to its corner; it runs on past both ends of the centreline as far as the forward overlap
and the images-beyond-the-boundary rule ask (`station_span`, as for an area grid's line ends).

Photo stations are where the autopilot takes the photos: with distance triggering, ArduPilot
takes one at the first 50 Hz check that lies the trigger distance or more from the last photo,
in a straight line (AP_Camera_Backend::update, Location::get_distance), so on a straight
stretch they are a base apart and through a bend a whole number of check steps further along
the strip, until the chord reaches the trigger distance. With time triggering they are a base
apart along the strip. All these lengths are ArduPilot's metres (`ardupilot_distance_m`), which
differ from the ground's by up to 0.7 % with the direction and the latitude.

Each piece of the centreline is a pass; its strips are flown in order, back and forth. Next to
an exclusion zone (and its margin, and the clearance a turn needs) stations are left out and
the strip is cut, as an area grid's lines are. Around the bends the coverage step checks the
footprints exactly (`Layout.check_exactly`): there the straight-line rule does not prove it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.errors import InputError
from aerosurvey.plan.layout import Layout
from aerosurvey.plan.lines import station_span, strip_offsets
from aerosurvey.plan.photogrammetry import TRIGGER_CHECK_HZ, ardupilot_distance_m
from aerosurvey.plan.progress import Progress
from aerosurvey.plan.route import Pass, Strip
from aerosurvey.plan.sensor import SensorSolution
from aerosurvey.plan.site import Site
from aerosurvey.spec import MissionSpec

#: a bend sharper than this (the change of direction) splits the strips there: each side's strip
#: runs on past the bend as past an end (the images-beyond-the-boundary rule and the forward
#: overlap), so the outside of the bend is photographed as a line's end is; gentler bends are
#: flown through with the camera on
SPLIT_BEND_DEG = 40.0
#: an offset strip's corner may reach this many offsets out from the centreline's bend (GEOS's
#: mitre limit): sharper bends are bevelled, and the exact coverage check around them says what that leaves
MITRE_LIMIT = 5.0


@dataclass(frozen=True)
class Corridor:
    """Strips along the site's centreline, over its ground each side of it (`Site.sides_m`: the
    spec's widths, or those derived from a corridor polygon)."""

    images_beyond_boundary: int
    coverage_margin_m: float

    @classmethod
    def from_spec(cls, spec: MissionSpec) -> Corridor:
        return cls(spec.targets.images_beyond_boundary, spec.targets.coverage_margin_m)

    def layout(self, site: Site, sensor: SensorSolution, report: Progress) -> Layout:
        if site.centreline is None or site.sides_m is None:
            raise InputError("pattern.kind = 'corridor' needs area.file to hold the centreline (a LineString) or the corridor polygon")
        k = site.grid_scale
        grow = site.simplification.tolerance_m * k + self.coverage_margin_m * k
        left, right = site.sides_m[0] * k + grow, site.sides_m[1] * k + grow
        across, along = sensor.across_m * k, sensor.along_m * k
        base = sensor.base_m * k
        offsets = strip_ordinates(left, right, across, sensor.spacing_m * k, sensor.side_images_per_point)

        def autopilot_m(a: np.ndarray, b: np.ndarray) -> np.ndarray:
            """ArduPilot's distance between the points a and b (planning CRS, (n, 2) each)."""
            lon, lat = site.planar.lonlat(np.r_[a[:, 0], b[:, 0]], np.r_[a[:, 1], b[:, 1]])
            n = len(a)
            return np.asarray(ardupilot_distance_m(lon[:n], lat[:n], lon[n:], lat[n:]), float)

        clearance = (sensor.base_m / 2.0 + sensor.turn_radius_m + 1.0) * k
        pieces = shapely.get_parts(shapely.line_merge(site.centreline))
        passes = []
        for i, piece in enumerate(pieces, start=1):
            report("strips along the corridor", 0.05 + 0.6 * i / len(pieces))
            strips: list[Strip] = []
            for line, v in enumerate(offsets.tolist()):
                numbered = 0  # stations of the line so far, for ids
                stretches = _split_at_sharp_bends(np.asarray(shapely.get_coordinates(piece), float))
                for j, stretch in enumerate(stretches):
                    path = _offset(shapely.LineString(stretch), v)
                    arc = _arc(path)
                    # at a sharp bend the corridor's outside reaches its width past the bend (a round corner)
                    a = -max(left, right) if j > 0 else 0.0
                    b = float(arc[-1]) + (max(left, right) if j < len(stretches) - 1 else 0.0)
                    # the strip enters the corridor at a and leaves it at b
                    first, last = station_span(a, b, a, b, along, base, sensor.forward_images_per_point,
                                               self.images_beyond_boundary)
                    ext = _extend(path, -first, last - float(arc[-1]) + 2.0 * base)
                    at = _stations(ext, autopilot_m, sensor.base_m, last - first, sensor.trigger_distance_m,
                                   sensor.speed.speed_ms / TRIGGER_CHECK_HZ)
                    strips += _cut(line, len([s for s in strips if s.line == line]), numbered, ext, at,
                                   site.zones_buffered, clearance)
                    numbered += len(at)
            if strips:
                passes.append(Pass(i, strips=tuple(strips)))
        if not passes:
            raise InputError("no strip fits: the corridor is shorter than one photo or entirely blocked by exclusion zones")
        bends = shapely.points(np.concatenate([shapely.get_coordinates(p)[1:-1] for p in pieces]).reshape(-1, 2))
        reach = max(across, along) + base + max(left, right)
        exact = shapely.union_all(shapely.buffer(bends, reach, quad_segs=4)) if len(bends) else None
        start = shapely.get_coordinates(pieces[0])[:2]
        heading = math.degrees(math.atan2(*(start[1] - start[0]))) % 360.0
        return Layout(heading, "along the corridor's centreline", tuple(passes), site.area, self.coverage_margin_m, exact)


def strip_ordinates(left: float, right: float, across: float, spacing: float, per_point: int) -> np.ndarray:
    """The strips' offsets from the centreline (positive: to its left) over a corridor `left` and
    `right` of it: one down the middle when a footprint `across` wide spans it, else the area
    grid's rule across the width (`strip_offsets`: every point in `per_point` strips)."""
    if left + right <= across:
        return np.array([(left - right) / 2.0])
    return strip_offsets(-right, left, across, spacing, per_point)


def _split_at_sharp_bends(xy: np.ndarray) -> list[np.ndarray]:
    """The polyline cut at each vertex where its direction turns by more than SPLIT_BEND_DEG."""
    d = np.diff(xy, axis=0)
    bearing = np.arctan2(d[:, 0], d[:, 1])
    turn = np.degrees(np.abs((np.diff(bearing) + np.pi) % (2 * np.pi) - np.pi))
    cuts = (np.flatnonzero(turn > SPLIT_BEND_DEG) + 1).tolist()
    return [xy[a:b + 1] for a, b in zip([0, *cuts], [*cuts, len(xy) - 1])]


def _offset(line: BaseGeometry, v: float) -> np.ndarray:
    """The centreline moved `v` to its left (negative: right), corners mitred, as (m, 2) points
    in the centreline's direction; where a tight bend splits it, its longest part."""
    if v == 0:
        return np.asarray(shapely.get_coordinates(line), float)
    moved = shapely.line_merge(shapely.offset_curve(line, v, join_style="mitre", mitre_limit=MITRE_LIMIT))
    parts = shapely.get_parts(moved)
    return np.asarray(shapely.get_coordinates(max(parts, key=lambda p: p.length)), float)


def _arc(path: np.ndarray) -> np.ndarray:
    """The distance along the polyline of each of its points."""
    arc: np.ndarray = np.r_[0.0, np.cumsum(np.hypot(*np.diff(path, axis=0).T))]
    return arc


def _extend(path: np.ndarray, before: float, after: float) -> np.ndarray:
    """The polyline continued straight `before` back from its start and `after` on from its end."""
    d0 = (path[1] - path[0]) / np.hypot(*(path[1] - path[0]))
    d1 = (path[-1] - path[-2]) / np.hypot(*(path[-1] - path[-2]))
    return np.vstack([path[0] - d0 * max(before, 0.0), path[1:-1], path[-1] + d1 * max(after, 0.0)])


def _at(path: np.ndarray, arc: np.ndarray, s: np.ndarray) -> np.ndarray:
    """The points at distances `s` along the polyline."""
    return np.column_stack([np.interp(s, arc, path[:, 0]), np.interp(s, arc, path[:, 1])])


def _stations(path: np.ndarray, autopilot_m: Callable[[np.ndarray, np.ndarray], np.ndarray], base: float, span: float,
              chord: float | None, step: float) -> np.ndarray:
    """Distances along `path` (grid metres) of the stations from its start until `span` is
    reached. The autopilot measures in its own metres (`autopilot_m(a, b)`: between the points
    a and b, (n, 2) each): `base`, `chord` (the trigger distance) and `step` (between its 50 Hz
    checks) are in them. A base apart along the strip; with a distance trigger through a bend,
    at the first check whose straight distance from the last station reaches `chord`."""
    arc = _arc(path)
    own = np.r_[0.0, np.cumsum(autopilot_m(path[:-1], path[1:]))]  # the autopilot's metres along the strip
    inner = own[1:-1]
    out = [0.0]
    end = float(np.interp(span, arc, own))
    while out[-1] < end - 1e-6:
        s = out[-1]
        nxt = s + base
        if chord is not None and np.any((inner > s) & (inner < nxt + base)):
            # a bend within reach: ArduPilot's straight-line distance from s, check by check
            cand = s + step * np.arange(1, int(math.ceil(2.0 * base / step)) + 2)
            here = _at(path, own, np.array([s]))
            far = autopilot_m(np.repeat(here, len(cand), axis=0), _at(path, own, cand)) >= chord
            nxt = float(cand[int(np.argmax(far))]) if far.any() else float(cand[-1])
        out.append(nxt)
    at: np.ndarray = np.interp(np.asarray(out), own, arc)
    return at


def _cut(line: int, part0: int, index0: int, path: np.ndarray, at: np.ndarray, zones: BaseGeometry | None,
         clearance: float) -> list[Strip]:
    """The strips of one stretch of a line: its stations at distances `at` along `path`, without
    those within `clearance` of a zone's margin, cut where that leaves a gap or where the way
    between two stations meets a margin; their parts numbered from `part0`, stations from `index0`."""
    arc = _arc(path)
    xy = _at(path, arc, at)
    n = len(at)
    keep = np.ones(n, bool)
    joined = np.ones(max(n - 1, 0), bool)  # whether the way from station j to j + 1 is flown with the camera on
    if zones is not None:
        keep = shapely.distance(zones, shapely.points(xy)) > clearance
        ways = [np.vstack([xy[j], path[(arc > at[j]) & (arc < at[j + 1])], xy[j + 1]]) for j in range(n - 1)]
        if ways:
            lines = shapely.linestrings(np.vstack(ways), indices=np.repeat(np.arange(len(ways)), [len(w) for w in ways]))
            joined = ~shapely.intersects(zones, lines)
    runs: list[tuple[int, int]] = []
    j = 0
    while j < n:
        if not keep[j]:
            j += 1
            continue
        e = j
        while e + 1 < n and keep[e + 1] and joined[e]:
            e += 1
        runs.append((j, e))
        j = e + 1
    heading = _headings(path, arc, at)
    out = []
    for part, (a, b) in enumerate(runs):
        inner = (arc > at[a]) & (arc < at[b])
        bends = path[inner]
        after = np.searchsorted(at[a:b + 1], arc[inner], side="right") - 1
        out.append(Strip(line, part0 + part, np.vstack([xy[a], bends, xy[b]]), xy[a:b + 1].copy(), index0 + np.arange(a, b + 1),
                         heading[a:b + 1].copy(), after.astype(np.int64)))
    return out


def _headings(path: np.ndarray, arc: np.ndarray, at: np.ndarray) -> np.ndarray:
    """The compass bearing of the polyline's segment under each distance (the next one at a corner)."""
    seg = np.clip(np.searchsorted(arc, at, side="right") - 1, 0, len(path) - 2)
    d = path[seg + 1] - path[seg]
    bearing: np.ndarray = np.degrees(np.arctan2(d[:, 0], d[:, 1])) % 360.0
    return bearing
