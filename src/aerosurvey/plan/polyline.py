"""Photo strips along polylines: where the stations of a strip that bends lie, and how a strip
is cut next to the zones. Any pattern whose strips are polylines (a corridor's offsets of its
centreline, rings around a structure, lanes along a facade) lays its stations with these.

Photo stations are where the autopilot takes the photos: with distance triggering, ArduPilot
takes one at the first 50 Hz check that lies the trigger distance or more from the last photo,
in a straight line (AP_Camera_Backend::update, Location::get_distance), so on a straight
stretch they are a base apart and through a bend a whole number of check steps further along
the strip, until the chord reaches the trigger distance. With time triggering they are a base
apart along the strip. All these lengths are ArduPilot's metres (`ardupilot_distance_m`), which
differ from the ground's by up to 0.7 % with the direction and the latitude.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.plan.passes import Strip
from aerosurvey.plan.photogrammetry import ardupilot_distance_m

if TYPE_CHECKING:
    from aerosurvey.area import Planar


def autopilot_distance(planar: Planar) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """`stations_along`'s `autopilot_m` for places in a planning CRS: ArduPilot's distance between
    the points a and b ((n, 2) each)."""
    def autopilot_m(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        lon, lat = planar.lonlat(np.r_[a[:, 0], b[:, 0]], np.r_[a[:, 1], b[:, 1]])
        return np.asarray(ardupilot_distance_m(lon[:len(a)], lat[:len(a)], lon[len(a):], lat[len(a):]), float)

    return autopilot_m


def arc_lengths(path: np.ndarray) -> np.ndarray:
    """The distance along the polyline of each of its points."""
    arc: np.ndarray = np.r_[0.0, np.cumsum(np.hypot(*np.diff(path, axis=0).T))]
    return arc


def extend(path: np.ndarray, before: float, after: float) -> np.ndarray:
    """The polyline continued straight `before` back from its start and `after` on from its end."""
    d0 = (path[1] - path[0]) / np.hypot(*(path[1] - path[0]))
    d1 = (path[-1] - path[-2]) / np.hypot(*(path[-1] - path[-2]))
    return np.vstack([path[0] - d0 * max(before, 0.0), path[1:-1], path[-1] + d1 * max(after, 0.0)])


def point_at(path: np.ndarray, arc: np.ndarray, s: np.ndarray) -> np.ndarray:
    """The points at distances `s` along the polyline."""
    return np.column_stack([np.interp(s, arc, path[:, 0]), np.interp(s, arc, path[:, 1])])


def stations_along(path: np.ndarray, autopilot_m: Callable[[np.ndarray, np.ndarray], np.ndarray], base: float, span: float,
              chord: float | None, step: float) -> np.ndarray:
    """Distances along `path` (grid metres) of the stations from its start until `span` is
    reached. The autopilot measures in its own metres (`autopilot_m(a, b)`: between the points
    a and b, (n, 2) each): `base`, `chord` (the trigger distance) and `step` (between its 50 Hz
    checks) are in them. A base apart along the strip; with a distance trigger through a bend,
    at the first check whose straight distance from the last station reaches `chord`."""
    arc = arc_lengths(path)
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
            here = point_at(path, own, np.array([s]))
            far = autopilot_m(np.repeat(here, len(cand), axis=0), point_at(path, own, cand)) >= chord
            nxt = float(cand[int(np.argmax(far))]) if far.any() else float(cand[-1])
        out.append(nxt)
    at: np.ndarray = np.interp(np.asarray(out), own, arc)
    return at


def strips_clear_of(line: int, part0: int, index0: int, path: np.ndarray, at: np.ndarray, zones: BaseGeometry | None,
         clearance: float) -> list[Strip]:
    """The strips of one stretch of a line: its stations at distances `at` along `path`, without
    those within `clearance` of a zone's margin, cut where that leaves a gap or where the way
    between two stations meets a margin; their parts numbered from `part0`, stations from `index0`."""
    arc = arc_lengths(path)
    xy = point_at(path, arc, at)
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
    heading = headings_along(path, arc, at)
    out = []
    for part, (a, b) in enumerate(runs):
        inner = (arc > at[a]) & (arc < at[b])
        bends = path[inner]
        after = np.searchsorted(at[a:b + 1], arc[inner], side="right") - 1
        out.append(Strip(line, part0 + part, np.vstack([xy[a], bends, xy[b]]), xy[a:b + 1].copy(), index0 + np.arange(a, b + 1),
                         heading[a:b + 1].copy(), after.astype(np.int64)))
    return out


def headings_along(path: np.ndarray, arc: np.ndarray, at: np.ndarray) -> np.ndarray:
    """The compass bearing of the polyline's segment under each distance (the next one at a corner)."""
    seg = np.clip(np.searchsorted(arc, at, side="right") - 1, 0, len(path) - 2)
    d = path[seg + 1] - path[seg]
    bearing: np.ndarray = np.degrees(np.arctan2(d[:, 0], d[:, 1])) % 360.0
    return bearing
