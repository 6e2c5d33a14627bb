"""An area cut into blocks a crew flies in a day: straight cuts along and across the flight lines.

The area in a planning CRS (metres), the lines' grid bearing, the limit a block keeps and the
overlaps in; the blocks out. In a frame turned so that the lines run along x, the area's bounding
rectangle is cut, again and again, across its longer side, until every block keeps the limit: where
a slab of the cell thin enough keeps it, the cut leaves the thickest slab that does below it (found
by bisection to CUT_PRECISION of the side), else it halves the area in the cell; at most `max_m2` (`--max-ha`), or planned within N
sorties (`--max-sorties`: each candidate block planned as `campaign plan` plans it, the
template's battery model splitting its sorties). A cut along the lines (y = c) keeps every line
whole in its block, a cut across them (x = c) shortens the lines, and each block's lines stay
parallel to its long sides, so each keeps its own efficient grid.

What the cuts guarantee against needlessly small blocks: a cell is cut only when it does not
keep the limit, so the blocks of a cell that was cut (a block and its sibling's blocks: the
block's cut path less its last digit, written as the blocks file's `cut`) merged would break the
limit; and the part below a cut is as thick as keeps the limit (a slab a CUT_PRECISION of the side
thicker would not), so a strip of a long area is cut into blocks each as large as the limit allows
but its last, where halving left blocks of about half to all of it.

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
from collections.abc import Callable
from dataclasses import dataclass, replace

import shapely
import shapely.affinity
from shapely.geometry.base import BaseGeometry

from aerosurvey.campaign.blocks import Block
from aerosurvey.errors import InputError
from aerosurvey.spec import MissionSpec

#: bisection steps for the place of a cut (the area halved to 2^-40 of the cell's width)
_STEPS = 40
#: the largest slab below a cut that keeps the limit is found to this share of the cell's side (each step a
#: `fits` call: with --max-sorties, a plan)
CUT_PRECISION = 0.005


def split_area(area: BaseGeometry, heading_deg: float, max_m2: float, overlap_across_m: float,
               overlap_along_m: float) -> list[BaseGeometry]:
    """The blocks (polygons, in the area's CRS) of `area` for lines at grid bearing `heading_deg`,
    each at most `max_m2` with its overlaps; see the module's doc. An InputError when `max_m2` is
    too small for the overlaps (a block would be mostly overlap)."""
    cut = cut_area(area, heading_deg, lambda piece: bool(piece.area <= max_m2), overlap_across_m, overlap_along_m,
                   f"--max-ha {max_m2 / 1e4:g}")
    return [b for b, _ in cut]


def cut_area(area: BaseGeometry, heading_deg: float, fits: Callable[[BaseGeometry], bool], overlap_across_m: float,
             overlap_along_m: float, limit: str) -> list[tuple[BaseGeometry, str]]:
    """The blocks of `area` (see the module's doc), each with its cut path: the cell is halved until `fits`
    (given the cell's piece of the area with its overlaps, in the area's CRS) says the piece fits. The
    path is a "0" or "1" per halving (the lower or upper half: "" the whole area), so the blocks
    whose path starts with a block's path less its last digit are the cell that did not fit before
    its last cut. `limit` names the limit in the InputError of a cell that does not fit and has no
    room left for a cut (a block would be mostly overlap)."""
    turn = 90.0 - heading_deg  # the lines' direction as a mathematical angle: turned by -turn they run along x
    origin = area.centroid
    turned = shapely.affinity.rotate(area, -turn, origin=origin)
    half = (overlap_along_m / 2, overlap_across_m / 2)

    def back(g: BaseGeometry) -> BaseGeometry:
        return shapely.affinity.rotate(g, turn, origin=origin)

    cells: list[tuple[tuple[float, float, float, float], str]] = []
    todo = [(turned.bounds, "")]
    while todo:
        cell, path = todo.pop()
        piece = shapely.intersection(turned, _grown(cell, half))
        if piece.is_empty:
            continue
        if fits(back(piece)):
            cells.append((cell, path))
            continue
        x0, y0, x1, y1 = cell
        room_x, room_y = x1 - x0 > 4 * half[0], y1 - y0 > 4 * half[1]  # a cut there leaves more than overlap
        if not (room_x or room_y):
            raise InputError(f"{limit} is too small: blocks that small would be mostly the overlap at their "
                             f"cuts ({2 * half[1]:.0f} m across the lines, {2 * half[0]:.0f} m along them); allowed: a limit "
                             f"blocks of a few times {4 * half[0] * 4 * half[1] / 1e4:.2f} ha or more meet")
        # cut the longer side (a cut along the lines when the cell is taller), or the one with room for a cut
        along = room_y and ((y1 - y0) >= (x1 - x0) or not room_x)
        lower, upper = _largest_below(turned, cell, along, half, lambda c: fits(back(c))) or _halves(turned, cell, along)
        todo += [(upper, path + "1"), (lower, path + "0")]
    blocks = []
    for cell, path in cells:
        piece = shapely.intersection(turned, _grown(cell, half))
        blocks += [(back(p), path) for p in shapely.get_parts(piece) if p.geom_type == "Polygon" and p.area > 0]
    return blocks


def _grown(cell: tuple[float, float, float, float], half: tuple[float, float]) -> BaseGeometry:
    x0, y0, x1, y1 = cell
    return shapely.box(x0 - half[0], y0 - half[1], x1 + half[0], y1 + half[1])


def _largest_below(turned: BaseGeometry, cell: tuple[float, float, float, float], along: bool,
                   half: tuple[float, float], fits: Callable[[BaseGeometry], bool]) -> list[tuple[float, float, float, float]] | None:
    """The cell cut at y = c (`along` the lines) or x = c where the part below is the thickest that keeps the limit
    (`fits`, given that part's piece of the area with its overlaps), each part wider than the overlap; None when
    the thinnest such part does not keep it (the caller halves the cell)."""
    x0, y0, x1, y1 = cell
    lo, hi = (y0, y1) if along else (x0, x1)
    margin = 2 * (half[1] if along else half[0])

    def below(c: float) -> tuple[float, float, float, float]:
        return (x0, y0, x1, c) if along else (x0, y0, c, y1)

    def keeps(c: float) -> bool:
        return bool(fits(shapely.intersection(turned, _grown(below(c), half))))

    good, bad = lo + margin, hi - margin
    if not keeps(good):
        return None
    if keeps(bad):
        good = bad
    while bad - good > CUT_PRECISION * (hi - lo):
        c = (good + bad) / 2
        good, bad = (c, bad) if keeps(c) else (good, c)
    upper = (x0, good, x1, y1) if along else (good, y0, x1, y1)
    return [below(good), upper]


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


@dataclass(frozen=True)
class MaxSorties:
    """`campaign split --max-sorties`: each block plans within `sorties` sorties of the template (its TOML
    text, and the folder its paths are taken from) with the block's heading."""

    sorties: int
    template: str
    base: str


def blocks_of_area(area_wgs84: BaseGeometry, spec: MissionSpec, heading_deg: float | None, max_ha: float | None = None,
                   max_sorties: MaxSorties | None = None) -> tuple[list[BaseGeometry], list[float], list[str]]:
    """The blocks of an area (WGS84) for the spec's camera, height and overlaps, each one's true
    heading (degrees) and its cut path (`cut_area`): `heading_deg` (a true bearing), the spec's
    flight.heading, else along the area's length. Each block is at most `max_ha` (with its overlaps),
    or plans within `max_sorties`' sorties (planned as `campaign plan` plans it, its heading given). The
    overlaps are at the nominal height (spec.targets; over higher ground the footprint shrinks, and so
    does the overlap on the ground); the cuts are straight in the planning CRS."""
    from aerosurvey.area import planning_crs

    planar = planning_crs(spec.crs, area_wgs84)
    area = planar.forward(area_wgs84)
    c = area.centroid
    true = heading_deg if heading_deg is not None else spec.flight.heading_deg
    grid = float(planar.grid_bearing(true, c.x, c.y)) if true is not None else long_side_bearing(area)
    across, along = cut_overlaps_m(spec)
    lon, lat = planar.lonlat(c.x, c.y)
    scale = planar.scale_factor(float(lon), float(lat))

    def heading_of(g: BaseGeometry) -> float:
        p = g.centroid
        return round(float(planar.true_bearing(grid, p.x, p.y)) % 180.0, 4)

    if max_sorties is not None:
        if spec.battery is None:
            raise InputError("--max-sorties needs the template's [battery] table: the sorties are split by its battery model")
        fits = _within_sorties(max_sorties, planar.inverse, heading_of)
        limit = f"--max-sorties {max_sorties.sorties}"
    elif max_ha is not None:
        max_m2 = max_ha * 1e4 * scale**2
        fits, limit = (lambda piece: bool(piece.area <= max_m2)), f"--max-ha {max_ha:g}"
    else:
        raise InputError("campaign split needs --max-ha or --max-sorties: the size of a block")
    blocks = cut_area(area, grid, fits, across * scale, along * scale, limit)
    return [planar.inverse(b) for b, _ in blocks], [heading_of(b) for b, _ in blocks], [path for _, path in blocks]


def _within_sorties(limit: MaxSorties, to_wgs84: Callable[[BaseGeometry], BaseGeometry],
                    heading_of: Callable[[BaseGeometry], float]) -> Callable[[BaseGeometry], bool]:
    """Whether each polygon of a piece (planning CRS) plans within the limit's sorties."""
    from pathlib import Path

    from aerosurvey.campaign.job import block_spec
    from aerosurvey.inputs import plan_from_files

    def fits(piece: BaseGeometry) -> bool:
        for part in shapely.get_parts(piece):
            if part.geom_type != "Polygon" or part.area <= 0:
                continue
            block = Block("piece", shapely.to_wkb(to_wgs84(part)), (("heading", heading_of(part)),))
            plan = plan_from_files(block_spec(limit.template, Path(limit.base), block, "EPSG:4326"))
            if len(plan.sorties) > limit.sorties:  # with a [battery] table, one sortie or more
                return False
        return True

    return fits


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
