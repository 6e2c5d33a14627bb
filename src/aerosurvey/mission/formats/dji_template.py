"""Which template a DJI WPML `template.kml` holds for a flight: a mapping template where one
expresses the flight, else the waypoint template (with why).

DJI's WPML reference (DJI Cloud API documentation, DJI WPML, template.kml: "Template common
elements", "Mapping Aerial Template Element", "Waypoint Segment Flight Template Element",
"Coordinate Parameter Info", "Overlap Rate Information") defines `mapping2d` (an area: a
polygon, a route direction, a margin, overlaps, one height) and `mappingStrip` (a strip along a
line: the line, the extent left and right of it, overlaps, one height). DJI Pilot 2 lays its
own lines from these only when the pilot edits the route; until then the aircraft flies
`waylines.wpml`, which is always our route (mission/formats/wpml.py).

A template expresses the flight when DJI Pilot 2 would lay the same kind of flight from it:
`template_choice` says which, from the flight program and the plan, or why none does
(docs/clients/dji.md lists the conditions). The conditions are checked in the order below;
the first that fails is the reason given.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import shapely
from pyproj import Geod

from aerosurvey.mission.formats import DJI_TEMPLATES
from aerosurvey.mission.formats.qgc_survey import corridor_geometry
from aerosurvey.mission.program import FlightProgram, Gimbal, Roi
from aerosurvey.plan.model import Plan
from aerosurvey.plan.passes import NADIR_PITCH_DEG

_GEOD = Geod(ellps="WGS84")


@dataclass(frozen=True)
class MappingTemplate:
    """What template.kml says of a flight written as a mapping2d or mappingStrip template."""

    kind: str  # "mapping2d" or "mappingStrip"
    coordinates: tuple[tuple[float, float], ...]  # lon, lat: the area's ring (closed) or the strip's line
    direction_deg: int  # wpml:direction: the compass bearing the first line is flown along, 0..359
    margin_m: int  # wpml:margin: the survey area grown by this much (targets.coverage_margin_m)
    overlap_h: int  # wpml:orthoCameraOverlapH: forward overlap, percent, as flown (1 − base / footprint along)
    overlap_w: int  # wpml:orthoCameraOverlapW: side overlap, percent, as flown (1 − spacing / footprint across)
    shoot_type: str  # wpml:shootType: "distance" or "time"
    height_m: float  # wpml:height and wpml:ellipsoidHeight: the lines' height above the take-off point
    shoot_height_m: float  # wpml:globalShootHeight: height above the ground the footprints were computed at
    extend_m: int = 0  # mappingStrip: wpml:leftExtend and wpml:rightExtend, the corridor's half width
    include_centre: bool = False  # mappingStrip: a line flies on the strip's middle (an odd count of lines)
    single_line: bool = False  # mappingStrip: one line
    length_m: float = 0.0  # mappingStrip: wpml:cuttingDistance, the whole line (the strip is not cut)


def _bearing(lon0: float, lat0: float, lon1: float, lat1: float) -> float:
    return float(_GEOD.inv(lon0, lat0, lon1, lat1)[0]) % 360.0


def _first_line(p: FlightProgram) -> tuple[int, int] | None:
    """Indices of the first run's first and last waypoints on its line (camera on), or None."""
    starts = [i for i, w in enumerate(p.waypoints) if w.kind == "line_start"]
    if not starts:
        return None
    a = starts[0]
    b = next(i for i in range(a, len(p.waypoints)) if p.waypoints[i].kind == "line_end")
    return a, b


def _why_not(plan: Plan, p: FlightProgram, whole: bool) -> str | None:
    """Why no mapping template expresses the flight, or None: the conditions common to both (one
    pass of nadir photos: parallel lines in a frame for mapping2d, strips for mappingStrip)."""
    passes = [p for p in plan.layout.passes if not p.empty]
    if len(passes) != 1:
        headings = sorted({round(p.frame.heading_deg) % 180 for p in passes if p.frame is not None})
        at = f" at {', '.join(f'{h}°' for h in headings)}" if headings else ""
        return (f"{len(passes)} passes{at} (cross-hatch, bands across notches, pieces at their own headings, "
                f"lines along the zones or corridor parts; {plan.layout.heading_chosen}): a mapping template holds one")
    if not whole:
        return "this sortie flies part of the pass: a mapping template covers the whole area"
    if plan.site.zones is not None:
        return "exclusion zones: a mapping template holds none, DJI Pilot 2 would lay lines across them"
    if p.altitude_frame != "relative" or plan.sensor.heights.mode not in ("none", "fixed"):
        return (f"terrain.mode = {plan.sensor.heights.mode!r}: the lines change height, a mapping template holds one "
                "height above the take-off point")
    if plan.camera.trigger not in ("distance", "time"):
        return (f"camera.trigger = {plan.camera.trigger!r}: a mapping template photographs by distance or by time "
                "(wpml:shootType)")
    if p.fixed_yaw_deg is not None:
        return "flight.fixed_yaw_deg: a mapping template's fixed heading (wpml:mappingHeadingParam) is the M3E's only"
    if any(isinstance(a, Roi) or isinstance(a, Gimbal) and a.pitch_deg != NADIR_PITCH_DEG for w in p.waypoints for a in w.actions):
        return "the camera is tilted: a mapping template photographs straight down"
    if _first_line(p) is None:
        return "no photo run"
    on_line = {w.alt_m for w in p.waypoints if w.run >= 0}
    if len(on_line) != 1:
        return "the runs fly at several heights: a mapping template holds one"
    return None


def template_choice(plan: Plan, p: FlightProgram, whole: bool, asked: str = DJI_TEMPLATES[0]) -> MappingTemplate | str:
    """The mapping template that expresses flight `p` of `plan` (`whole`: it flies every station
    of the plan), or why the waypoint template is written instead; `asked` "waypoint" always
    gives the waypoint template."""
    if asked == "waypoint":
        return "the waypoint template was asked for (dji = waypoint)"
    why = _why_not(plan, p, whole)
    if why is not None:
        return why
    line = _first_line(p)
    assert line is not None
    a, b = (p.waypoints[i] for i in line)
    flown = MappingTemplate(
        "mapping2d", (),
        direction_deg=round(_bearing(a.lon, a.lat, b.lon, b.lat)) % 360,
        margin_m=round(plan.layout.margin_m),
        overlap_h=round(100.0 * (1.0 - plan.sensor.base_m / plan.sensor.along_m)),
        overlap_w=round(100.0 * (1.0 - plan.sensor.spacing_m / plan.sensor.across_m)),
        shoot_type=plan.camera.trigger,
        height_m=a.alt_m,
        shoot_height_m=round(plan.sensor.heights.spacing_agl_m, 2),
    )
    if plan.layout.passes[0].frame is not None:  # parallel lines over the area: its outline
        area = plan.site.area_wgs84
        if not isinstance(area, shapely.Polygon) or len(area.interiors):
            return "the area is several polygons or has holes: a mapping template holds one outline"
        ring = shapely.get_coordinates(area.exterior)
        return replace(flown, coordinates=tuple((float(x), float(y)) for x, y in ring))
    found = corridor_geometry(plan, plan.layout.passes[0].index, "ellipsoid")  # a metric plane at the polyline's start
    if found is None:
        return "the corridor's strips are not the offsets of one line: a strip template lays them so"
    polyline = found[0]
    lines = len({r.line for r in plan.route.runs})
    assert plan.site.sides_m is not None  # the spec's widths, or those derived from a corridor polygon
    length = float(np.sum(_GEOD.line_lengths(polyline[:, 0], polyline[:, 1])))
    return replace(flown, kind="mappingStrip", coordinates=tuple((float(x), float(y)) for x, y in polyline),
                   extend_m=round(sum(plan.site.sides_m) / 2.0),
                   include_centre=lines % 2 == 1, single_line=lines == 1, length_m=float(math.ceil(length)))
