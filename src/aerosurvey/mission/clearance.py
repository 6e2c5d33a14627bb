"""Terrain clearance under every leg of every flight, as the autopilot flies it, against the DEM.

The legs are the airspace check's (airspace/legs.py: the final gate's legs rebuilt from the flight
program, with their heights and altitude frames): take-off, climb-out, every waypoint leg (lines,
lead-ins, turns, terrain and bend waypoints, transits, detours), the approach, the landing or the
return (RTL) and a plane's circle over the launch point.

Heights along a leg run straight from its start to its end in the end's frame, as ArduPilot flies
them (the start converted into that frame where the two differ):

- "relative" (above the launch point): the altitude is interpolated along the leg (a copter's
  S-curve flies the straight 3-D line; a plane's glide slope too, and below 20 m it climbs at once,
  which only raises it), so the height above the terrain is that altitude less the DEM's ground;
- "terrain" (above the terrain): the autopilot adds its terrain database's height under the
  vehicle to the interpolated height above terrain, so the clearance runs straight between the
  two ends (this assumes the autopilot's terrain data is the DEM; ArduPilot's own database is
  SRTM on a 100 m grid by default, TERRAIN_SPACING, and sees no ridge narrower than that).

The ground is the DEM's bilinear surface between cell centres (`Dem.sample`), and the lowest
clearance along a leg is found exactly on it (`Dem.lowest_along`), at the DEM's own resolution.
The report holds each flight's lowest clearance and every leg under its minimum, so the DEM's
cells are read only under the legs that may be either: the others are told apart by bounds from
the DEM's block height ranges (`Dem.margin_bounds`, `_may_matter`), which read no cell.

A RTL leg holds the lowest of the heights RTL may fly at. A plane turns at its turn radius from
each waypoint towards the next, then flies straight to it (when the next lies inside that
circle, the arc through it), checked chord by chord. The legs to and from the ground (a plane's
take-off climb and landing glide) must stay above the terrain; the minimum clearance holds for
every other leg. A copter's vertical take-off and descents are not checked: they rise from and
come down to the ground under them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.airspace.check import leg_geometries, leg_pieces, limit_in_frame
from aerosurvey.airspace.legs import Leg3, flight_legs
from aerosurvey.airspace.model import Limit
from aerosurvey.area import Planar
from aerosurvey.mission.program import FlightProgram
from aerosurvey.plan.terrain import Dem

#: legs that leave or reach the ground: they must stay above the terrain (the minimum clearance holds for every other leg)
GROUND_LEGS = ("takeoff", "climb-out", "land", "descent", "rtl-descent")
#: heights are written to the centimetre: a clearance this far under the minimum is rounding
TOLERANCE_M = 0.01
#: a plane's turn arc is flown as chords whose sagitta is at most this (ground metres)
ARC_SAGITTA_M = 0.25
#: the legs named in a refusal (the rest are counted)
NAMED = 3
#: the clearance record's version (manifest "clearance"): a change of its fields bumps it
VERSION = 1


@dataclass(frozen=True)
class Lowest:
    """The lowest clearance of a leg: where along it, the terrain there and the height flown."""

    flight: str  # "mission", "sortie-01", …
    seq: int  # the point the leg flies to
    what: str  # the leg's waypoint tag, or takeoff, climb-out, approach, land, rtl, …
    along_m: float  # ground metres from the leg's start
    lon: float
    lat: float
    ground_m: float  # the DEM's height there
    amsl_m: float  # the height flown there, in the DEM's datum
    clearance_m: float

    def text(self) -> str:
        return (f"{self.flight}: the leg to point {self.seq} ({self.what}) passes {self.clearance_m:.1f} m above the terrain "
                f"{self.along_m:.0f} m along it (terrain {self.ground_m:.1f} m, flown at {self.amsl_m:.1f} m, "
                f"lon {self.lon:.6f}, lat {self.lat:.6f})")

    def record(self) -> dict[str, Any]:
        return {"flight": self.flight, "seq": self.seq, "what": self.what, "along_m": round(self.along_m, 1),
                "lon": round(self.lon, 8), "lat": round(self.lat, 8), "ground_m": round(self.ground_m, 2),
                "amsl_m": round(self.amsl_m, 2), "clearance_m": round(self.clearance_m, 2)}


@dataclass(frozen=True)
class ClearanceReport:
    min_clearance_m: float
    dem: str  # the DEM's file name
    # per flight (in the programs' order) its lowest clearance off the take-off and landing legs (on them when it has no
    # other); a flight with no leg checked is left out
    lowest: tuple[Lowest, ...]
    below: tuple[Lowest, ...]  # every leg whose lowest clearance is under the minimum, in flight order

    def refusal(self) -> str | None:
        if not self.below:
            return None
        more = f" (and {len(self.below) - NAMED} more leg(s))" if len(self.below) > NAMED else ""
        return (f"terrain clearance under {self.min_clearance_m:g} m (terrain.min_clearance_m; under the terrain on a "
                "take-off climb or a landing glide): "
                + "; ".join(b.text() for b in self.below[:NAMED]) + more)

    def rule_record(self) -> dict[str, Any]:
        """The planner's terrain-clearance rule, as the manifest records rule results."""
        worst = min(self.lowest, key=lambda w: w.clearance_m, default=None)
        measured = "no leg checked" if worst is None else f"{worst.clearance_m:.1f} m (lowest, {worst.flight})"
        from aerosurvey.plan.coverage import PLANNER_PROFILE

        return {"profile": PLANNER_PROFILE, "rule": "terrain-clearance", "status": "fail" if self.below else "pass",
                "severity": "error",
                "statement": "every leg of every flight stays at least terrain.min_clearance_m above the DEM",
                "measured": measured, "required": f">= {self.min_clearance_m:g} m",
                "evidence": [w.text() for w in self.lowest],
                "where": [{"flight": b.flight, "seq": b.seq, "lon": round(b.lon, 8), "lat": round(b.lat, 8)}
                          for b in self.below[:50]],
                "source": "aerosurvey planner (mission/clearance.py)"}

    def manifest_record(self) -> dict[str, Any]:
        return {"version": VERSION, "dem": self.dem, "min_clearance_m": self.min_clearance_m,
                "flights": [w.record() for w in self.lowest], "below": [b.record() for b in self.below]}


@dataclass
class _Pieces:
    """Straight pieces of legs under a straight ceiling (the height flown less the minimum clearance, in the DEM's datum)."""

    a: list[tuple[float, float]]
    b: list[tuple[float, float]]
    ceiling: list[tuple[float, float]]
    leg: list[int]
    along: list[tuple[float, float]]  # ground metres from the leg's start at the piece's ends


def terrain_clearance(programs: Mapping[str, FlightProgram], dem: Dem, planar: Planar, grid_scale: float,
                      min_clearance_m: float, rtl_loiter: float, turn_radius: float) -> ClearanceReport:
    """The lowest clearance of every flight of `programs` (file stem → program) over `dem`, and every leg under
    `min_clearance_m`; `rtl_loiter` is a plane's circle after RTL, `turn_radius` its turns' (grid metres)."""
    lowest: list[Lowest] = []
    below: list[Lowest] = []
    for stem, program in programs.items():
        legs = flight_legs(program, stem, planar, rtl_loiter, grid_scale)
        per_leg = _legs_lowest(program, legs, dem, planar, grid_scale, min_clearance_m, turn_radius)
        airborne = [w for w in per_leg if w.what not in GROUND_LEGS] or per_leg
        if airborne:
            lowest.append(min(airborne, key=lambda w: w.clearance_m))
            below += [w for w in per_leg if w.clearance_m < (0.0 if w.what in GROUND_LEGS else min_clearance_m) - TOLERANCE_M]
    return ClearanceReport(min_clearance_m, dem.name, tuple(lowest), tuple(below))


def _legs_lowest(program: FlightProgram, legs: list[Leg3], dem: Dem, planar: Planar, k: float, m: float,
                 turn_radius: float) -> list[Lowest]:
    """Each checked leg's lowest clearance."""
    home = program.home[2]
    # the ground under the starts of the legs that change altitude frame (`_start_in_end_frame`); the others' is not read
    starts = np.array([leg.leg.start for leg in legs], float).reshape(-1, 2)
    ground0 = np.full(len(legs), np.nan)
    change = [i for i, leg in enumerate(legs) if leg.frames[0] != leg.frames[1]]
    if change:
        ground0[change] = dem.sample(starts[change, 0], starts[change, 1], f"{legs[0].leg.flight}'s legs")
    straight = _Pieces([], [], [], [], [])
    level: list[tuple[int, float, float, int]] = []  # terrain-frame legs: (leg, along, height above terrain, x-y index)
    level_xy: list[tuple[float, float]] = []
    prev_dir: np.ndarray | None = None  # the heading (unit vector) at the end of the leg before
    for i, leg3 in enumerate(legs):
        (x0, y0), (x1, y1) = leg3.leg.start, leg3.leg.end
        d = math.hypot(x1 - x0, y1 - y0)
        a0, a1 = _start_in_end_frame(leg3, float(ground0[i]), home), leg3.alt_end[0]
        frame = leg3.frames[1]
        if frame == "terrain":  # the clearance runs straight between the ends
            level += [(i, 0.0, a0, len(level_xy)), (i, d / k, a1, len(level_xy) + 1)]
            level_xy += [(x0, y0), (x1, y1)]
            if d > 0:
                prev_dir = np.array([x1 - x0, y1 - y0]) / d
        else:
            ground_leg = leg3.leg.what in GROUND_LEGS
            if ground_leg and d == 0:
                continue  # straight up from, or down to, the ground it stands on
            need = 0.0 if ground_leg else m
            path = np.array([leg3.leg.start, leg3.leg.end], float)
            if program.vehicle == "plane" and prev_dir is not None and d > 0 and not ground_leg:
                path = turn_path(path[0], path[1], prev_dir, turn_radius, ARC_SAGITTA_M * k)
            _add(straight, i, path, k, home + a0 - need, home + a1 - need)
            last = path[-1] - path[-2]
            if float(np.hypot(*last)) > 0:
                prev_dir = last / float(np.hypot(*last))
    out: dict[int, Lowest] = {}
    what = f"{legs[0].leg.flight}'s legs" if legs else "legs"
    if straight.a:
        a, b, ceiling = np.array(straight.a), np.array(straight.b), np.array(straight.ceiling)
        read = _may_matter(dem.margin_bounds(a, b, ceiling, what), [legs[i].leg.what for i in straight.leg],
                           [(legs[i].leg.what, agl) for i, _, agl, _ in level], m)
        a, b, ceiling = a[read], b[read], ceiling[read]
        margin, frac, ground = dem.lowest_along(a, b, ceiling, what)
        x, y = a[:, 0] + frac * (b - a)[:, 0], a[:, 1] + frac * (b - a)[:, 1]
        lon, lat = planar.lonlat(x, y)
        along = np.array(straight.along)[read]
        for j in np.argsort(margin, kind="stable"):
            i = straight.leg[read[j]]
            if i not in out:
                s = float(along[j, 0] + frac[j] * (along[j, 1] - along[j, 0]))
                flown = float(margin[j] + ground[j] + (0.0 if legs[i].leg.what in GROUND_LEGS else m))
                out[i] = _lowest(legs[i], s, float(lon[j]), float(lat[j]), float(ground[j]), flown)
    if level:
        xy = np.array(level_xy, float)
        g = dem.sample(xy[:, 0], xy[:, 1], what)
        lon, lat = planar.lonlat(xy[:, 0], xy[:, 1])
        for i, s, agl, p in sorted(level, key=lambda t: t[2]):
            if i not in out or agl < out[i].clearance_m:
                out[i] = _lowest(legs[i], s, float(lon[p]), float(lat[p]), float(g[p]), float(g[p]) + agl)
    return [out[i] for i in sorted(out)]


def _may_matter(bounds: tuple[np.ndarray, np.ndarray], whats: list[str], level: list[tuple[str, float]],
                m: float) -> np.ndarray:
    """The pieces (indices) whose lowest clearance the report may hold, from bounds of their lowest margins under the
    ceiling (the clearance less the piece's minimum: `whats`, their legs' tags) and the clearances of the terrain-frame
    legs (`level`: their tags and clearances): a piece that may pass under its minimum (a margin under 0), or that may
    be its flight's lowest: `terrain_clearance` takes that off the ground legs when the flight has another, and a piece
    whose clearance is surely above another's cannot be it. The others' ground is not read."""
    lo, hi = bounds
    ground = np.array([w in GROUND_LEGS for w in whats])
    need = np.where(ground, 0.0, m)
    # the legs the flight's lowest is taken from: off the ground legs, when the flight has another
    off_ground = not ground.all() or any(w not in GROUND_LEGS for w, _ in level)
    counted = ~ground if off_ground else np.ones(len(whats), bool)
    surely = min(float(np.min(hi + need, where=counted, initial=np.inf)),
                 min((agl for w, agl in level if not off_ground or w not in GROUND_LEGS), default=np.inf))
    return np.flatnonzero((lo < 0) | (counted & (lo + need <= surely)))


def _start_in_end_frame(leg3: Leg3, ground_start: float, home: float) -> float:
    """The leg's (lowest) start height in its end's frame: the autopilot flies the leg in that frame, the
    start converted into it at the ground under it (`home`: the launch point's ground, the DEM's datum)."""
    a0 = leg3.alt_start[0]
    start_frame, frame = leg3.frames
    if start_frame != frame:
        a0 += (ground_start - home) if frame == "relative" else (home - ground_start)
    return a0


@dataclass(frozen=True)
class ProfileZone:
    """A zone the profile shows where the route crosses its outline: a drawn or spec exclusion zone (from the ground,
    no ceiling) or an official zone with its height band (airspace/model.py; a limit None: the surface, no ceiling)."""

    name: str
    kind: str  # "exclusion" or "official"
    outline: BaseGeometry  # planning CRS
    band: str  # the band as the zone states it, for the label
    lower: Limit | None = None
    upper: Limit | None = None


@dataclass(frozen=True)
class ZoneBand:
    """The route inside a zone's outline from `distance_m[0]` to `distance_m[-1]` (distance flown) and the zone's
    band there above mean sea level, as the airspace check converts its limits (`limit_in_frame`: an AGL limit over
    the DEM's ground, a WGS84 height as the widest span of sea-level heights it can be); `upper_m` None: no ceiling."""

    name: str
    kind: str
    band: str
    distance_m: tuple[float, ...]
    lower_m: tuple[float, ...]
    upper_m: tuple[float, ...] | None

    def record(self) -> dict[str, Any]:
        return {"name": self.name, "kind": self.kind, "band": self.band, "distance_m": [round(v, 1) for v in self.distance_m],
                "lower_m": [round(v, 2) for v in self.lower_m],
                "upper_m": None if self.upper_m is None else [round(v, 2) for v in self.upper_m]}


@dataclass(frozen=True)
class Profile:
    """The route of one flight over the terrain, leg after leg as `terrain_clearance` models it (turns
    drawn straight): the ground distance flown, the height flown above mean sea level (the DEM's
    datum) and the DEM's ground under it, at most about `samples` points and every leg's ends; the
    zones' height bands where the route crosses their outlines."""

    distance_m: tuple[float, ...]
    amsl_m: tuple[float, ...]
    ground_m: tuple[float, ...]
    checked: tuple[bool, ...]  # the minimum clearance holds there (not on the legs to and from the ground)
    min_clearance_m: float
    bands: tuple[ZoneBand, ...] = ()

    def record(self) -> dict[str, Any]:
        return {"distance_m": [round(v, 1) for v in self.distance_m], "amsl_m": [round(v, 2) for v in self.amsl_m],
                "ground_m": [round(v, 2) for v in self.ground_m], "checked": list(self.checked),
                "min_clearance_m": self.min_clearance_m, "bands": [b.record() for b in self.bands]}


def terrain_profile(program: FlightProgram, flight: str, dem: Dem, planar: Planar, grid_scale: float,
                    min_clearance_m: float, rtl_loiter: float, samples: int = 1500,
                    zones: Sequence[ProfileZone] = ()) -> Profile:
    """`program`'s route over `dem` for a profile drawing (the page's): the same legs and heights as the check, and
    the bands of the `zones` whose outlines it crosses."""
    legs = flight_legs(program, flight, planar, rtl_loiter, grid_scale)
    home = program.home[2]
    lengths = [math.dist(leg3.leg.start, leg3.leg.end) / grid_scale for leg3 in legs]
    step = max(sum(lengths) / max(samples, 1), 1e-9)
    xs: list[np.ndarray] = []
    ys: list[np.ndarray] = []
    along: list[np.ndarray] = []
    heights: list[tuple[np.ndarray, str, float]] = []  # per leg: its points' fractions, its frame, its end's height
    run = 0.0
    for leg3, d in zip(legs, lengths, strict=True):
        t = np.linspace(0.0, 1.0, max(2, math.ceil(d / step) + 1))
        (x0, y0), (x1, y1) = leg3.leg.start, leg3.leg.end
        xs.append(x0 + t * (x1 - x0))
        ys.append(y0 + t * (y1 - y0))
        along.append(run + t * d)
        run += d
        heights.append((t, leg3.frames[1], leg3.alt_end[0]))
    if not legs:
        return Profile((), (), (), (), min_clearance_m)
    x, y = np.concatenate(xs), np.concatenate(ys)
    ground = dem.sample(x, y, f"{flight}'s route")
    amsl: list[np.ndarray] = []
    checked: list[bool] = []
    at = 0
    for leg3, (t, frame, a1) in zip(legs, heights, strict=True):
        g = ground[at:at + len(t)]
        a0 = _start_in_end_frame(leg3, float(g[0]), home)
        h = a0 + t * (a1 - a0)
        amsl.append(g + h if frame == "terrain" else home + h)
        checked += [leg3.leg.what not in GROUND_LEGS and leg3.leg.start != leg3.leg.end] * len(t)
        at += len(t)
    distance = np.concatenate(along)
    bands = _zone_bands(legs, lengths, zones, distance, ground)
    return Profile(tuple(map(float, distance)), tuple(map(float, np.concatenate(amsl))),
                   tuple(map(float, ground)), tuple(checked), min_clearance_m, bands)


def _zone_bands(legs: Sequence[Leg3], lengths: Sequence[float], zones: Sequence[ProfileZone], distance: np.ndarray,
                ground: np.ndarray) -> tuple[ZoneBand, ...]:
    """Each stretch of the route inside a zone's outline (the airspace check's pieces of the legs, joined where one
    leg's piece runs on into the next's), with the zone's band over the profile's ground there."""
    if not zones:
        return ()
    geoms = leg_geometries(legs)
    outlines = np.asarray([z.outline for z in zones], dtype=object)
    leg_i, zone_i = shapely.STRtree(outlines).query(geoms, predicate="intersects")
    starts = np.concatenate([[0.0], np.cumsum(lengths)])
    stretches: dict[int, list[tuple[float, float]]] = {}
    for (li, zi), parts in leg_pieces(geoms, outlines, leg_i, zone_i).items():
        stretches.setdefault(zi, []).extend((starts[li] + t0 * lengths[li], starts[li] + t1 * lengths[li]) for t0, t1 in parts)
    bands = []
    for zi in sorted(stretches):
        z = zones[zi]
        for a, b in _joined(stretches[zi]):
            inside = distance[(distance > a) & (distance < b)]
            d = np.unique(np.concatenate([[a], inside, [b]]))
            g = np.interp(d, distance, ground)
            base = np.zeros(len(d))
            lower = g if z.lower is None else limit_in_frame(z.lower, g, base, no_dem=False, upper=False)
            upper = None if z.upper is None else limit_in_frame(z.upper, g, base, no_dem=False, upper=True)
            bands.append(ZoneBand(z.name, z.kind, z.band, tuple(map(float, d)), tuple(map(float, lower)),
                                  None if upper is None else tuple(map(float, upper))))
    return tuple(sorted(bands, key=lambda band: band.distance_m[0]))


def _joined(spans: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Distance spans joined where they touch or overlap; spans of no length (a vertical leg, an outline touched) left out."""
    out: list[tuple[float, float]] = []
    for a, b in sorted(spans):
        if out and a <= out[-1][1] + 1e-6:
            out[-1] = (out[-1][0], max(out[-1][1], b))
        else:
            out.append((a, b))
    return [(a, b) for a, b in out if b - a > 1e-6]


def _lowest(leg3: Leg3, along_m: float, lon: float, lat: float, ground: float, amsl: float) -> Lowest:
    return Lowest(leg3.leg.flight, leg3.leg.seq, leg3.leg.what, along_m, lon, lat, ground, amsl, amsl - ground)


def turn_path(p0: np.ndarray, p1: np.ndarray, direction: np.ndarray, radius: float, sagitta: float) -> np.ndarray:
    """The path a plane flies from p0, heading along the unit vector `direction`, to p1: a turn of `radius` towards p1
    until it heads for p1, then straight (when p1 lies inside that circle, the circular arc leaving p0 along
    `direction` through p1); the turn as chords whose sagitta is at most `sagitta`."""
    c = p1 - p0
    side = float(direction[0] * c[1] - direction[1] * c[0])  # > 0: p1 to the left
    ahead = float(direction @ c)
    if radius <= 0 or (abs(side) < 1e-9 * max(1.0, float(np.hypot(*c))) and ahead >= 0):
        return np.stack([p0, p1])
    turn = 1.0 if side >= 0 else -1.0  # counter-clockwise to the left
    normal = np.array([-direction[1], direction[0]]) * turn
    centre = p0 + radius * normal
    to_end = p1 - centre
    d = float(np.hypot(*to_end))
    if d <= radius:  # the circle through p0 (tangent to `direction`) and p1
        radius = float(c @ c) / (2.0 * float(c @ normal))
        centre = p0 + radius * normal
        a_end = math.atan2(*(p1 - centre)[::-1])
    else:  # where the tangent from p1 touches the circle
        a_end = math.atan2(to_end[1], to_end[0]) - turn * math.acos(radius / d)
    a0 = math.atan2(*(p0 - centre)[::-1])
    sweep = ((a_end - a0) * turn) % (2 * math.pi)
    step = 2.0 * math.acos(1.0 - sagitta / radius) if sagitta < radius else math.pi / 2
    ang = a0 + turn * sweep * np.linspace(0.0, 1.0, max(1, math.ceil(sweep / step)) + 1)
    arc = centre + radius * np.column_stack([np.cos(ang), np.sin(ang)])
    arc[0] = p0
    return np.vstack([arc, p1[None, :]]) if d > radius else np.vstack([arc[:-1], p1[None, :]])


def _add(pieces: _Pieces, leg: int, path: np.ndarray, k: float, k0: float, k1: float) -> None:
    """Leg `leg` flown through `path` (its heights running straight with the distance flown) under a ceiling from k0
    to k1, as straight pieces."""
    cum = np.r_[0.0, np.cumsum(np.hypot(*np.diff(path, axis=0).T))]
    f = cum / cum[-1] if cum[-1] > 0 else np.linspace(0.0, 1.0, len(path))
    for j in range(len(path) - 1):
        pieces.a.append((float(path[j, 0]), float(path[j, 1])))
        pieces.b.append((float(path[j + 1, 0]), float(path[j + 1, 1])))
        pieces.ceiling.append((k0 + f[j] * (k1 - k0), k0 + f[j + 1] * (k1 - k0)))
        pieces.leg.append(leg)
        pieces.along.append((float(cum[j] / k), float(cum[j + 1] / k)))
