"""The site: the area and the exclusion zones in the planning CRS, the grid scale, and the
terrain under the area. The pipeline's first look at the inputs.

Boundaries exported from a cadastre or a GIS may have thousands of vertices closer together
than anything a photo resolves. Before any other step they are simplified to a tolerance
derived from the plan (`simplify_tolerance_m`), and only ever outwards: the area and each
zone become a simpler polygon that covers the original and lies within the tolerance of it,
so the ground to photograph may only grow and the zones may only grow. The vertex counts
before and after go into the manifest (`Simplification`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.area import Planar, check_area_of_use, planning_crs
from aerosurvey.errors import InputError
from aerosurvey.plan import photogrammetry as pg
from aerosurvey.plan.centreline import corridor_polygon, derive_centreline
from aerosurvey.plan.inputs import PlanInputs
from aerosurvey.spec import MissionSpec

if TYPE_CHECKING:
    from aerosurvey.plan.terrain import Dem


#: the simplification tolerance: this share of the photo footprint's shorter side at the
#: target height (1 m for a 100 m footprint), and at most this share of the exclusion margin
SIMPLIFY_SHARE_OF_FOOTPRINT = 0.01
SIMPLIFY_SHARE_OF_MARGIN = 0.1
#: one plan lays every length with the grid scale at the area's centroid: the scale anywhere
#: over the area may differ from it by this share at most (UTM's own spread across a zone's
#: width at the equator, 0.9996 to 1.0010; 1 m over a 1 km line)
MAX_GRID_SCALE_SPREAD = 0.001


@dataclass(frozen=True)
class Simplification:
    """How the boundaries were simplified: the tolerance (ground metres) and the vertex counts
    of the area and of the zones before and after."""

    tolerance_m: float
    area_vertices: tuple[int, int]
    zone_vertices: tuple[int, int]


@dataclass(frozen=True, eq=False)
class Site:
    planar: Planar
    area_wgs84: BaseGeometry
    exclusions_wgs84: tuple[BaseGeometry, ...]
    area: BaseGeometry  # planning CRS, normalised
    zones: BaseGeometry | None  # the exclusion zones, united
    zones_buffered: BaseGeometry | None  # with the margin: nothing may fly inside
    grid_scale: float  # planning-CRS metres per ground metre at the area's centroid
    dem: Dem | None
    ground: tuple[float, float] | None  # lowest and highest DEM cell under the area (a terrain mode with a DEM)
    simplification: Simplification
    centreline: BaseGeometry | None  # a corridor's centreline (planning CRS); its area is the corridor
    margin_m: float  # flight.exclusion_margin_m: how far from the zones every leg keeps (ground metres)
    sides_m: tuple[float, float] | None  # a corridor's ground left and right of its centreline (ground metres)
    warnings: tuple[str, ...]  # what the site step decided that the user should see (a derived centreline)
    min_clearance_m: float = 20.0  # terrain.min_clearance_m: how high above the DEM every leg keeps (mission/clearance.py)
    structure: BaseGeometry | None = None  # [structure]'s footprint (planning CRS), a polygon

    def autopilot_scale(self, heading_deg: float) -> float:
        """Planning-grid metres per metre of ArduPilot's distance along a line heading (a grid
        bearing), at the area's centroid: a kilometre of the line there, measured as the
        autopilot measures it (`photogrammetry.ardupilot_distance_m`). Stations laid the photo
        base times this apart are where its distance trigger fires: the ground's metres and the
        autopilot's differ by up to 0.7 % with the direction and the latitude (`grid_scale`
        turns ground metres into grid metres)."""
        return float(self._autopilot_scales(np.array([heading_deg]))[0])

    def autopilot_stretch(self) -> float:
        """The most ground metres one metre of ArduPilot's distance spans at the area, in any
        direction (every degree of heading): a photo base measured in the autopilot's metres
        is at most this many times longer on the ground, whichever way a line runs."""
        return float(self._autopilot_scales(np.arange(0.0, 180.0, 1.0)).max()) / self.grid_scale

    def _autopilot_scales(self, headings_deg: np.ndarray) -> np.ndarray:
        c = self.area.centroid
        half = 500.0 * self.grid_scale
        h = np.radians(headings_deg)
        dx, dy = half * np.sin(h), half * np.cos(h)
        lon, lat = self.planar.lonlat(np.concatenate([c.x - dx, c.x + dx]), np.concatenate([c.y - dy, c.y + dy]))
        n = len(h)
        return np.asarray(2.0 * half / pg.ardupilot_distance_m(lon[:n], lat[:n], lon[n:], lat[n:]), float)


def simplify_tolerance_m(spec: MissionSpec, height_agl_m: float) -> float:
    """How far (ground metres) a simplified boundary may lie outside the given one: a share of
    the photo footprint at the target height (`sensor.target_height`), and of the exclusion
    margin when there is one."""
    across, along = pg.footprint(height_agl_m, spec.camera.camera, spec.camera.mount)
    tol = SIMPLIFY_SHARE_OF_FOOTPRINT * min(float(across), float(along))
    margin = spec.flight.exclusion_margin_m
    return min(tol, SIMPLIFY_SHARE_OF_MARGIN * margin) if margin > 0 else tol


def check_scale_spread(planar: Planar, area: BaseGeometry, k: float) -> None:
    """Refuse an area over which the planning CRS's scale strays from `k` (its value at the
    centroid) by more than MAX_GRID_SCALE_SPREAD, measured at the corners of the area's convex
    hull (a conformal projection's scale is furthest from the centre's on its rim)."""
    hull = shapely.get_coordinates(shapely.convex_hull(area))
    lon, lat = planar.lonlat(hull[:, 0], hull[:, 1])
    scales = planar.scale_factors(lon, lat)
    worst = float(np.max(np.abs(scales / k - 1.0)))
    if worst <= MAX_GRID_SCALE_SPREAD:
        return
    parts = len(shapely.get_parts(area))
    x0, y0, x1, y1 = area.bounds
    what = f"its {parts} parts span" if parts > 1 else "it spans"
    raise InputError(
        f"area: {what} {math.hypot(x1 - x0, y1 - y0) / k / 1000:,.0f} km, over which the planning CRS {planar.name} scales "
        f"ground lengths by {float(scales.min()):.5f} to {float(scales.max()):.5f} against {k:.5f} at the centre "
        f"({100 * worst:.2f} %, more than the {100 * MAX_GRID_SCALE_SPREAD:g} % one plan allows): plan each part or block "
        "as its own mission, or give mission.crs a projection centred on the area", key="mission.crs")


def grown_simplification(geom: BaseGeometry, tolerance: float) -> BaseGeometry:
    """A polygon with fewer vertices that covers `geom` and lies within `tolerance` of it, or
    `geom` itself when that removes no vertex (or, never seen, when the result would not cover it).

    Douglas-Peucker at s = tolerance/6 (topology-preserving where the plain one crosses an
    edge or drops a ring) keeps a subset of the vertices, every removed one within s of the
    segment that replaces it; GEOS may then drop a ring's first vertex when it lies within s
    of its neighbours' new segment, which leaves the vertices around it within 2 s. Each piece
    of the original between two kept vertices lies in the 2s-wide stadium around the segment
    that replaces it, and so does everything between the two: original and simplified differ
    by at most 2 s. Grown by 2 s with mitred corners (cut at twice that, beyond the 2s-disc
    about the corner), the simplified polygon covers the original and lies within 2 s + 4 s
    of it. Time and memory are linear in the vertices (GEOS's simplifier, buffer and
    an indexed `covers` that checks the result)."""
    s = tolerance / 6.0
    simple = shapely.simplify(geom, s, preserve_topology=False)
    if not (shapely.is_valid(simple) and _rings(simple) == _rings(geom)):
        # plain Douglas-Peucker (20x faster: 40 ms against 0.7 s on 400,000 vertices) made a
        # crossing or dropped a ring: GEOS's topology-preserving variant never does
        simple = shapely.simplify(geom, s, preserve_topology=True)
    if shapely.get_num_coordinates(simple) >= shapely.get_num_coordinates(geom):
        return geom
    grown = shapely.normalize(shapely.buffer(simple, 2.0 * s, join_style="mitre", mitre_limit=2.0))
    fewer = shapely.get_num_coordinates(grown) < shapely.get_num_coordinates(geom)
    return grown if fewer and shapely.covers(grown, geom) else geom


def _rings(geom: BaseGeometry) -> int:
    return len(shapely.get_rings(shapely.get_parts(geom)))


def _places(spec: MissionSpec, inputs: PlanInputs) -> list[tuple[str, BaseGeometry]]:
    """The area, the exclusion zones, the launch and rally points, each with its name in the spec."""
    out: list[tuple[str, BaseGeometry]] = [("area", inputs.area_wgs84)]
    out += [(f"exclusion zone {p.name}", z) for p, z in zip(spec.area.exclusions, inputs.exclusions_wgs84)]
    if spec.area.launch is not None:
        out.append(("area.launch", shapely.Point(spec.area.launch)))
    if spec.battery is not None:
        out += [(f"battery.launch_points[{i}]", shapely.Point(p)) for i, p in enumerate(spec.battery.launch_points)]
    out += [(f"flight.rally_points[{i}]", shapely.Point(p)) for i, p in enumerate(spec.flight.rally_points)]
    return out


def prepare_site(spec: MissionSpec, inputs: PlanInputs, height_agl_m: float) -> Site:
    """Project the inputs; refuse zones that leave nothing to survey. `height_agl_m` is the
    target height (`sensor.target_height`), which sets how far outlines may be simplified."""
    planar = planning_crs(spec.crs, inputs.area_wgs84)
    if spec.crs != "auto":  # "auto" is the UTM zone of the area's centre
        check_area_of_use(planar.crs, "mission.crs", _places(spec, inputs))
    c = inputs.area_wgs84.centroid
    k = planar.scale_factor(c.x, c.y)
    tol = simplify_tolerance_m(spec, height_agl_m) * k
    centreline = sides = None
    warnings: tuple[str, ...] = ()
    from aerosurvey.plan.pattern import kind_of  # the registry's patterns are laid on a Site

    pattern = kind_of(spec.pattern.kind)
    if pattern.area_is_centreline:
        given = planar.forward(inputs.area_wgs84)
        line, sides, warnings = _corridor_centreline(spec, pattern.centreline_sides(spec), given, k)
        # the corridor round a simpler centreline (within `tol` of the given one), each side wider
        # by the tolerance: it covers the corridor round the given centreline
        centreline = shapely.simplify(shapely.line_merge(line), tol, preserve_topology=False)
        area = corridor_polygon(centreline, sides[0] * k + tol, sides[1] * k + tol)
        area_wgs84 = planar.inverse(area)
    else:
        given = planar.forward(inputs.area_wgs84)
        area = grown_simplification(given, tol)  # normalised when simplified
        area_wgs84 = inputs.area_wgs84 if area is given else planar.inverse(area)
        if area is given:  # normalised once it is the one planned (a copy: +19 MB on 400,000 vertices)
            area = shapely.normalize(area)
    given_zones = [planar.forward(e) for e in inputs.exclusions_wgs84]
    simple_zones = [grown_simplification(z, tol) for z in given_zones]
    excl = tuple(e if z is g else planar.inverse(z)
                 for e, z, g in zip(inputs.exclusions_wgs84, simple_zones, given_zones))
    zones = shapely.union_all(simple_zones) if simple_zones else None
    vertices = shapely.get_num_coordinates
    simplification = Simplification(
        tol / k, (int(vertices(given)), int(vertices(centreline if centreline is not None else area))),
        (int(np.sum(vertices(given_zones))), int(np.sum(vertices(simple_zones)))))
    margin = spec.flight.exclusion_margin_m
    check_scale_spread(planar, area, k)
    zones_buf = shapely.buffer(zones, margin) if zones is not None else None
    if zones_buf is not None:
        remaining = shapely.difference(area, zones_buf)
        if remaining.area < 0.01 * area.area:
            raise InputError(
                f"the exclusion zones (with the {margin:g} m margin, flight.exclusion_margin_m) cover "
                f"{100 * (1 - remaining.area / area.area):.1f} % of the area: nothing is left to survey",
                key="area.exclusions",
            )
    dem = None
    ground = None
    if inputs.dem is not None:
        from aerosurvey.plan.terrain import Dem  # rasterio loads only for plans with a DEM

        dem = Dem(inputs.dem, planar)
        if spec.terrain.mode != "none":
            ground = dem.range_over(area, "area")
    return Site(planar, area_wgs84, excl, area, zones, zones_buf, k, dem, ground, simplification, centreline,
                spec.flight.exclusion_margin_m, sides, warnings, spec.terrain.min_clearance_m,
                planar.forward(inputs.structure_wgs84) if inputs.structure_wgs84 is not None else None)


def _corridor_centreline(spec: MissionSpec, asked: tuple[float | None, float | None], given: BaseGeometry,
                         k: float) -> tuple[BaseGeometry, tuple[float, float], tuple[str, ...]]:
    """A corridor's centreline (planning CRS), its ground left and right of it (ground metres) and
    what to tell the user: the line given, or the one derived from a corridor polygon
    (plan/centreline.py) with the spec's widths or, without them, the widths that cover the polygon."""
    left, right = asked
    where = f"area.file {str(spec.area.file)!r}" if spec.area.file is not None else "area.wkt"
    if given.geom_type not in ("Polygon", "MultiPolygon"):
        if left is None or right is None:
            raise InputError(f"{where} holds a centreline: [pattern] kind = 'corridor' needs width_m (centred on it) or "
                             "left_m and right_m for a line (only a corridor polygon's widths are derived)", key="pattern.width_m")
        return given, (left, right), ()
    derived = derive_centreline(given, k, where)
    length_km = derived.centreline.length / k / 1000.0
    tolerance = f"simplified within {derived.tolerance / k:.1f} m"
    if left is None or right is None:
        sides = (derived.left / k, derived.right / k)
        return derived.centreline, sides, (
            f"centreline derived from the corridor polygon: {length_km:,.2f} km ({tolerance}), {sides[0]:.1f} m to its "
            f"left and {sides[1]:.1f} m to its right cover the polygon",)
    band = corridor_polygon(derived.centreline, left * k, right * k)
    share = shapely.intersection(given, band).area / given.area
    return derived.centreline, (left, right), (
        f"centreline derived from the corridor polygon: {length_km:,.2f} km ({tolerance}); the corridor the spec gives "
        f"({left:g} m left, {right:g} m right) holds {100 * share:.1f} % of the polygon, "
        f"{derived.left / k:.1f} m left and {derived.right / k:.1f} m right would hold all of it",)
