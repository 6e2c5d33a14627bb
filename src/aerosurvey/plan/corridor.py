"""The corridor pattern: strips along a centreline (a road, a river, a pipeline, a power line).

A corridor is the ground `left_m` to the left and `right_m` to the right of its centreline
(`Site.centreline` and `Site.sides_m`, the area is that ground; the site step derives both from
a corridor polygon when area.file holds one, plan/centreline.py). Its strips are the centreline offset sideways
to the ordinates an area grid's lines would have across the same width (`strip_offsets`: every
point in ⌊1/(1−side)⌋ strips), or one strip down the middle when one footprint spans the width.
Each strip bends where the centreline does, with mitred corners, so the outside of a bend is
flown to its corner; it runs on past both ends of the centreline as far as the forward overlap
and the images-beyond-the-boundary rule ask (`station_span`, as for an area grid's line ends).
A bend sharper than SPLIT_BEND_DEG splits the strips, each running on past it as past an end; a
sharp bend the centreline turns in several short steps (as one derived from a corridor polygon
does) is made one corner first (`_sharp_corners`).

Photo stations are where the autopilot takes the photos (plan/polyline.py: along a strip that
bends, as ArduPilot's distance trigger fires).

Each piece of the centreline is a pass; its strips are flown in order, back and forth. Next to
an exclusion zone (and its margin, and the clearance a turn needs) stations are left out and
the strip is cut, as an area grid's lines are. Around the bends the coverage step checks the
footprints exactly (`Layout.check_exactly`): there the straight-line rule does not prove it.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.errors import InputError, bad_value
from aerosurvey.plan.bounds import GridBounds, covered, grid_bounds
from aerosurvey.plan.layout import Field, Layout
from aerosurvey.plan.lines import station_span, strip_offsets
from aerosurvey.plan.passes import Pass, Strip
from aerosurvey.plan.photogrammetry import TRIGGER_CHECK_HZ, ardupilot_distance_m
from aerosurvey.plan.polyline import arc_lengths, extend, stations_along, strips_clear_of
from aerosurvey.plan.progress import Progress
from aerosurvey.plan.sensor import Footprint, SensorSolution, nadir_footprint
from aerosurvey.plan.site import Site
from aerosurvey.spec import FlightSpec, MissionSpec

if TYPE_CHECKING:
    from aerosurvey.plan.model import Heights, Plan

#: a bend sharper than this (the change of direction) splits the strips there: each side's strip
#: runs on past the bend as past an end (the images-beyond-the-boundary rule and the forward
#: overlap), so the outside of the bend is photographed as a line's end is; gentler bends are
#: flown through with the camera on
SPLIT_BEND_DEG = 40.0
#: an offset strip's corner may reach this many offsets out from the centreline's bend (GEOS's
#: mitre limit): sharper bends are bevelled, and the exact coverage check around them says what that leaves
MITRE_LIMIT = 5.0


@dataclass(frozen=True)
class CorridorOptions:
    """[pattern] kind = "corridor": the ground left and right of the centreline, looking along it
    (metres; None: derived from the corridor polygon given instead of a centreline, plan/centreline.py)."""

    left_m: float | None
    right_m: float | None


@dataclass(frozen=True)
class Corridor:
    """Strips along the site's centreline, over its ground each side of it (`Site.sides_m`: the
    spec's widths, or those derived from a corridor polygon)."""

    images_beyond_boundary: int
    coverage_margin_m: float

    kind: ClassVar[str] = "corridor"
    title: ClassVar[str] = "corridor along a centreline"
    area_is_centreline: ClassVar[bool] = True
    nose_turns_camera: ClassVar[bool] = False
    fields: ClassVar[tuple[Field, ...]] = (
        Field("width_m", "Corridor width (m)", "number", None, lo=0.0, hi=20000.0, lo_open=True,
              hint="Ground photographed across the corridor, centred on the centreline"),
        Field("left_m", "or left of the line (m)", "number", None, lo=0.0, hi=10000.0),
        Field("right_m", "and right of it (m)", "number", None, lo=0.0, hi=10000.0),
    )

    @classmethod
    def centreline_sides(cls, spec: MissionSpec) -> tuple[float | None, float | None]:
        o = spec.pattern.options
        assert isinstance(o, CorridorOptions), o  # the spec made it from this kind's fields
        return o.left_m, o.right_m

    @classmethod
    def stands_on(cls, site: Site) -> BaseGeometry | None:
        return None  # its heights are above the area's ground

    @classmethod
    def options(cls, values: Mapping[str, Any], flight: FlightSpec) -> CorridorOptions:
        width, left, right = values["width_m"], values["left_m"], values["right_m"]
        if width is not None and (left is not None or right is not None):
            raise InputError("[pattern] corridor takes either width_m or left_m and right_m, not both")
        if (left is None) != (right is None):
            raise InputError("[pattern] corridor takes width_m (centred on the centreline) or both left_m and right_m, "
                             "or none of them for a corridor polygon (its widths derived)")
        if width is not None:
            left = right = width / 2.0
        if left is not None and right is not None and left + right <= 0:
            raise bad_value("pattern.left_m + pattern.right_m", left + right, "a corridor wider than 0 m")
        if flight.cross_hatch:
            raise InputError("flight.cross_hatch is for area grids: a corridor is flown along its centreline")
        return CorridorOptions(left, right)

    @classmethod
    def from_spec(cls, spec: MissionSpec) -> Corridor:
        return cls(spec.targets.images_beyond_boundary, spec.targets.coverage_margin_m)

    @classmethod
    def footprint(cls, spec: MissionSpec, heights: Heights) -> Footprint:
        return nadir_footprint(spec, heights)

    @classmethod
    def bounds(cls, spec: MissionSpec, site: Site, sensor: SensorSolution, layout: Layout) -> GridBounds:
        """Strips follow the centreline: the count across its width (left + right, grown by the
        coverage margin), not across its outline's (a bent corridor's is wide); one strip down
        the middle of a corridor one footprint spans."""
        width = None if site.sides_m is None else sum(site.sides_m) + 2.0 * layout.margin_m
        return grid_bounds(covered(site.area, layout.margin_m, site.grid_scale), site.grid_scale, sensor.across_m,
                           sensor.spacing_m, sensor.base_m, sensor.side_images_per_point, 1, width, one_strip_when_narrow=True)

    @classmethod
    def parameters(cls, plan: Plan) -> dict[str, Any]:
        """The widths flown: the spec's, or those derived from a corridor polygon."""
        if plan.site.sides_m is None:
            return {}
        return {"left_m": round(plan.site.sides_m[0], 3), "right_m": round(plan.site.sides_m[1], 3)}

    def layouts(self, site: Site, sensor: SensorSolution, report: Progress) -> Iterator[Layout]:
        """The strips along the centreline: one layout."""
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
                stretches = _split_at_sharp_bends(_sharp_corners(np.asarray(shapely.get_coordinates(piece), float),
                                                                 max(left, right)))
                for j, stretch in enumerate(stretches):
                    path = _offset(shapely.LineString(stretch), v)
                    arc = arc_lengths(path)
                    # at a sharp bend the corridor's outside reaches its width past the bend (a round corner)
                    a = -max(left, right) if j > 0 else 0.0
                    b = float(arc[-1]) + (max(left, right) if j < len(stretches) - 1 else 0.0)
                    # the strip enters the corridor at a and leaves it at b
                    first, last = station_span(a, b, a, b, along, base, sensor.forward_images_per_point,
                                               self.images_beyond_boundary)
                    ext = extend(path, -first, last - float(arc[-1]) + 2.0 * base)
                    at = stations_along(ext, autopilot_m, sensor.base_m, last - first, sensor.trigger_distance_m,
                                   sensor.speed.speed_ms / TRIGGER_CHECK_HZ)
                    strips += strips_clear_of(line, len([s for s in strips if s.line == line]), numbered, ext, at,
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
        yield Layout(heading, "along the corridor's centreline", tuple(passes), site.area, self.coverage_margin_m, exact)


def strip_ordinates(left: float, right: float, across: float, spacing: float, per_point: int) -> np.ndarray:
    """The strips' offsets from the centreline (positive: to its left) over a corridor `left` and
    `right` of it: one down the middle when a footprint `across` wide spans it, else the area
    grid's rule across the width (`strip_offsets`: every point in `per_point` strips)."""
    if left + right <= across:
        return np.array([(left - right) / 2.0])
    return strip_offsets(-right, left, across, spacing, per_point)


def _turns_deg(xy: np.ndarray) -> np.ndarray:
    """The change of direction at each inner vertex of the polyline, degrees (positive: to the right)."""
    d = np.diff(xy, axis=0)
    bearing = np.arctan2(d[:, 0], d[:, 1])
    return np.degrees((np.diff(bearing) + np.pi) % (2 * np.pi) - np.pi)


def _sharp_corners(xy: np.ndarray, short: float) -> np.ndarray:
    """The polyline with each sharp bend rounded over segments shorter than `short` made one corner
    again: a run of inner vertices joined by such segments whose turns add up to more than
    SPLIT_BEND_DEG is replaced by the point where the segments before and after it meet (a
    centreline derived from a corridor polygon turns a sharp bend in a few short steps, each under
    SPLIT_BEND_DEG, and the strips were then flown round it mitred, leaving the outside of the bend
    to one photo). Only a bend turning one way by less than 180° is rounded so: a run that turns both
    ways, or loops, is the centreline's own shape and is kept, as is a run whose segments meet farther
    than `short` from it (a hairpin)."""
    seg = np.hypot(*np.diff(xy, axis=0).T)
    turns = _turns_deg(xy)
    out = [xy[0]]
    i = 1
    while i < len(xy) - 1:
        j = i
        while j + 1 < len(xy) - 1 and seg[j] < short:
            j += 1  # vertices i..j joined by short segments
        run = turns[i - 1:j]  # the turns at vertices i..j
        rounded = j > i and SPLIT_BEND_DEG < abs(run.sum()) < 180.0 and (np.all(run > 0) or np.all(run < 0))
        corner = _meeting_point(xy[i - 1], xy[i], xy[j], xy[j + 1]) if rounded else None
        if corner is not None and np.hypot(*(corner - xy[i])) < short and np.hypot(*(corner - xy[j])) < short:
            out.append(corner)
        else:
            out.extend(xy[i:j + 1])
        i = j + 1
    out.append(xy[-1])
    return np.asarray(out)


def _meeting_point(a0: np.ndarray, a1: np.ndarray, b0: np.ndarray, b1: np.ndarray) -> np.ndarray | None:
    """Where the line through a0, a1 meets the line through b0, b1 (None when they are parallel)."""
    da, db = a1 - a0, b1 - b0
    det = da[0] * db[1] - da[1] * db[0]
    if abs(det) < 1e-12 * np.hypot(*da) * np.hypot(*db):
        return None
    s = float(((b0[0] - a0[0]) * db[1] - (b0[1] - a0[1]) * db[0]) / det)
    return np.asarray(a0 + s * da, float)


def _split_at_sharp_bends(xy: np.ndarray) -> list[np.ndarray]:
    """The polyline cut at each vertex where its direction turns by more than SPLIT_BEND_DEG."""
    cuts = (np.flatnonzero(np.abs(_turns_deg(xy)) > SPLIT_BEND_DEG) + 1).tolist()
    return [xy[a:b + 1] for a, b in zip([0, *cuts], [*cuts, len(xy) - 1])]


def _offset(line: BaseGeometry, v: float) -> np.ndarray:
    """The centreline moved `v` to its left (negative: right), corners mitred, as (m, 2) points
    in the centreline's direction; where a tight bend splits it, its longest part."""
    if v == 0:
        return np.asarray(shapely.get_coordinates(line), float)
    moved = shapely.line_merge(shapely.offset_curve(line, v, join_style="mitre", mitre_limit=MITRE_LIMIT))
    parts = shapely.get_parts(moved)
    return np.asarray(shapely.get_coordinates(max(parts, key=lambda p: p.length)), float)


