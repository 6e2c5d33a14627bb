"""An area cut into blocks a crew flies in a day: straight cuts along and across the flight lines.

Pure: the area in a planning CRS (metres), the lines' grid bearing, the largest block and the
overlaps in; the blocks out. In a frame turned so that the lines run along x, the area's bounding
rectangle is halved, again and again, across its longer side at the place that halves the area
in it, until every block is at most `max_m2`: a cut along the lines (y = c) keeps every line
whole in its block, a cut across them (x = c) shortens the lines, and each block's lines stay
parallel to its long sides, so each keeps its own efficient grid.

The overlap at each cut: each block reaches across the cut by half of it, so neighbours share a
band as wide as the overlap. Across a cut along the lines, `overlap_across_m` (the ground two
neighbouring strips of one area share: the footprint across the lines times the side overlap);
across a cut across the lines, `overlap_along_m` (what two consecutive photos share: the
footprint along the lines times the forward overlap). Each block is planned to the guarantee over
its whole polygon, so on the shared band both blocks' photos see every point as often as one
area's would, and their photos share at least what neighbouring strips or photos of one area do.
"""

from __future__ import annotations

import math
from dataclasses import replace

import shapely
import shapely.affinity
from shapely.geometry.base import BaseGeometry

from aerosurvey.campaign.blocks import Block
from aerosurvey.errors import InputError
from aerosurvey.spec import MissionSpec

#: bisection steps for the place of a cut (the area halved to 2^-40 of the cell's width)
_STEPS = 40


def split_area(area: BaseGeometry, heading_deg: float, max_m2: float, overlap_across_m: float,
               overlap_along_m: float) -> list[BaseGeometry]:
    """The blocks (polygons, in the area's CRS) of `area` for lines at grid bearing `heading_deg`,
    each at most `max_m2` with its overlaps; see the module's doc. An InputError when `max_m2` is
    too small for the overlaps (a block would be mostly overlap)."""
    turn = 90.0 - heading_deg  # the lines' direction as a mathematical angle: turned by -turn they run along x
    origin = area.centroid
    turned = shapely.affinity.rotate(area, -turn, origin=origin)
    half = (overlap_along_m / 2, overlap_across_m / 2)
    cells: list[tuple[float, float, float, float]] = []
    todo = [turned.bounds]
    while todo:
        cell = todo.pop()
        piece = shapely.intersection(turned, _grown(cell, half))
        if piece.area <= max_m2:
            if not piece.is_empty:
                cells.append(cell)
            continue
        x0, y0, x1, y1 = cell
        room_x, room_y = x1 - x0 > 4 * half[0], y1 - y0 > 4 * half[1]  # a cut there leaves more than overlap
        if not (room_x or room_y):
            raise InputError(f"--max-ha {max_m2 / 1e4:g} is too small: blocks that small would be mostly the overlap at their "
                             f"cuts ({2 * half[1]:.0f} m across the lines, {2 * half[0]:.0f} m along them); allowed: a few times "
                             f"{4 * half[0] * 4 * half[1] / 1e4:.2f} ha or more")
        # halve the longer side (a cut along the lines when the cell is taller), or the one with room for a cut
        along = room_y and ((y1 - y0) >= (x1 - x0) or not room_x)
        todo += reversed(_halves(turned, cell, along))
    blocks = []
    for cell in cells:
        piece = shapely.intersection(turned, _grown(cell, half))
        blocks += [shapely.affinity.rotate(p, turn, origin=origin) for p in shapely.get_parts(piece)
                   if p.geom_type == "Polygon" and p.area > 0]
    return blocks


def _grown(cell: tuple[float, float, float, float], half: tuple[float, float]) -> BaseGeometry:
    x0, y0, x1, y1 = cell
    return shapely.box(x0 - half[0], y0 - half[1], x1 + half[0], y1 + half[1])


def _halves(turned: BaseGeometry, cell: tuple[float, float, float, float],
            along: bool) -> list[tuple[float, float, float, float]]:
    """The cell cut in two where the area in it is halved: at y = c (`along` the lines) or x = c."""
    x0, y0, x1, y1 = cell
    inside = shapely.intersection(turned, shapely.box(*cell))
    target = inside.area / 2
    lo, hi = (y0, y1) if along else (x0, x1)
    for _ in range(_STEPS):
        c = (lo + hi) / 2
        below = shapely.box(x0, y0, x1, c) if along else shapely.box(x0, y0, c, y1)
        if shapely.intersection(inside, below).area < target:
            lo = c
        else:
            hi = c
    c = (lo + hi) / 2
    if along:
        return [(x0, y0, x1, c), (x0, c, x1, y1)]
    return [(x0, y0, c, y1), (c, y0, x1, y1)]


def long_side_bearing(area: BaseGeometry) -> float:
    """The grid bearing (0..180) of the long side of the area's smallest rotated rectangle: lines along
    the area's length when no heading is given."""
    ring = shapely.oriented_envelope(area).exterior.coords
    (ax, ay), (bx, by), (cx, cy) = ring[0], ring[1], ring[2]
    if math.hypot(bx - ax, by - ay) < math.hypot(cx - bx, cy - by):
        ax, ay, bx, by = bx, by, cx, cy
    return math.degrees(math.atan2(bx - ax, by - ay)) % 180.0


def blocks_of_area(area_wgs84: BaseGeometry, spec: MissionSpec, max_ha: float,
                   heading_deg: float | None) -> tuple[list[BaseGeometry], list[float]]:
    """The blocks of an area (WGS84) for the spec's camera, height and overlaps, and each one's true
    heading (degrees): `heading_deg` (a true bearing), the spec's flight.heading, else along the
    area's length. The overlaps are at the nominal height (spec.targets; over higher ground the
    footprint shrinks, and so does the overlap on the ground); the cuts are straight in the planning CRS."""
    from aerosurvey.area import planning_crs

    planar = planning_crs(spec.crs, area_wgs84)
    area = planar.forward(area_wgs84)
    c = area.centroid
    true = heading_deg if heading_deg is not None else spec.flight.heading_deg
    grid = float(planar.grid_bearing(true, c.x, c.y)) if true is not None else long_side_bearing(area)
    across, along = cut_overlaps_m(spec)
    lon, lat = planar.lonlat(c.x, c.y)
    scale = planar.scale_factor(float(lon), float(lat))
    blocks = split_area(area, grid, max_ha * 1e4 * scale**2, across * scale, along * scale)
    centres = [b.centroid for b in blocks]
    headings = planar.true_bearing(grid, [p.x for p in centres], [p.y for p in centres]) % 180.0
    return [planar.inverse(b) for b in blocks], [round(float(h), 4) for h in headings]


def cut_overlaps_m(spec: MissionSpec) -> tuple[float, float]:
    """The overlap at a cut along the lines and at one across them, ground metres: the footprint across
    the lines times the side overlap, the footprint along them times the forward overlap, at the
    spec's nominal height."""
    from aerosurvey.plan.photogrammetry import footprint, height_from_gsd

    t = spec.targets
    height = t.height_m if t.height_m is not None else height_from_gsd(t.gsd_m or 0.0, spec.camera.camera)
    across, along = footprint(height, spec.camera.camera, spec.camera.mount)
    return float(across) * t.side_overlap, float(along) * t.forward_overlap


def grow_into_neighbours(blocks: list[BaseGeometry], reach: list[float]) -> list[BaseGeometry]:
    """Each block with the part of its neighbours within its `reach` of it: neighbours that abut then
    share a band as wide as their two reaches along their shared edges; nothing grows beyond the
    blocks' union."""
    tree = shapely.STRtree(blocks)
    out = []
    for i, b in enumerate(blocks):
        near = [j for j in tree.query(b, predicate="dwithin", distance=reach[i]) if j != i]
        if not near:
            out.append(b)
            continue
        reached = shapely.intersection(shapely.buffer(b, reach[i], join_style="mitre"),
                                       shapely.union_all([blocks[j] for j in near]))
        out.append(shapely.union(b, reached))
    return out


def overlapping_blocks(blocks: list[Block], crs: str, specs: list[MissionSpec]) -> list[Block]:
    """Blocks (in `crs`) grown into their neighbours by the overlap the guarantee needs: each by half of
    the larger of its spec's two cut overlaps (`cut_overlaps_m`), as the lines may run any way
    across a shared edge, so that abutting neighbours share a band at least that wide."""
    from aerosurvey.area import planning_crs, transformed, transformer

    polys = [shapely.from_wkb(b.wkb) for b in blocks]
    to_wgs = transformer(crs, "EPSG:4326")
    planar = planning_crs(specs[0].crs, shapely.union_all([transformed(to_wgs, p) for p in polys]))
    to_plan, back = transformer(crs, planar.crs.srs), transformer(planar.crs.srs, crs)
    c = shapely.union_all(polys).centroid
    lon, lat = to_wgs.transform(c.x, c.y)
    scale = planar.scale_factor(lon, lat)
    grown = grow_into_neighbours([transformed(to_plan, p) for p in polys], [max(cut_overlaps_m(s)) / 2 * scale for s in specs])
    return [replace(b, wkb=shapely.to_wkb(transformed(back, g))) for b, g in zip(blocks, grown)]
