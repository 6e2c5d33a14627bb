"""The area grid: parallel lines over the area at the fastest (or a fixed) heading, and a
cross-hatch pass at 90°. Its passes carry their frame and line segments, for the route step's
search of the line order and cells.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import shapely
import shapely.ops
from shapely.geometry.base import BaseGeometry

from aerosurvey.errors import InputError
from aerosurvey.plan.bounds import GridBounds, covered, grid_bounds, narrowest
from aerosurvey.plan.flight_time import Kinematics, quick_cost, quick_cost_lower_bounds
from aerosurvey.plan.frame import LineFrame
from aerosurvey.plan.heading import best_heading, candidate_headings
from aerosurvey.plan.layout import Field, Layout
from aerosurvey.plan.lines import (
    LineSegment,
    Outline,
    StripGeometry,
    anchored_offsets,
    build_lines,
    line_bounds,
    strip_offsets,
)
from aerosurvey.plan.passes import Pass
from aerosurvey.plan.progress import Progress, no_progress
from aerosurvey.plan.sensor import Footprint, SensorSolution, nadir_footprint
from aerosurvey.plan.site import Site
from aerosurvey.spec import FlightSpec, MissionSpec

if TYPE_CHECKING:
    from aerosurvey.plan.model import Heights, Plan

#: frames × (edges + rings + zones) a batch of the heading search's bounds may hold (a few MB a numpy array)
BOUND_BATCH_ELEMENTS = 200_000


def strip_geometry(sensor: SensorSolution, beyond: int, k: float, base_k: float) -> StripGeometry:
    """The sensor solution in planning-grid metres (ground metres × the grid scale k; the photo
    base, in the autopilot's metres, × `base_k`, the line heading's `Site.autopilot_scale`).

    Stations stay as close to a zone's margin as the flight past them allows: the line ends
    half a base after its last station (and a plane needs its turn radius there); the
    lead-in before a run is shortened by the route where a zone is in its way."""
    clearance = sensor.base_m / 2.0 + sensor.turn_radius_m + 1.0
    return StripGeometry(sensor.across_m * k, sensor.along_m * k, sensor.spacing_m * k, sensor.base_m * base_k,
                         sensor.side_images_per_point, sensor.forward_images_per_point, beyond, clearance * k)


@dataclass(frozen=True)
class AreaGrid:
    """Parallel lines over the area at the fastest (or a fixed) heading; a cross-hatch pass at 90°."""

    heading_deg: float | None  # None: the heading with the shortest estimated flight time
    cross_hatch: bool
    images_beyond_boundary: int
    coverage_margin_m: float
    # the area may be flown in several passes a heading (pieces of their own heading, a band a
    # pass): not for the oblique pattern, which flies its grid's first pass again with the
    # camera turned (its bands are joined in one pass)
    several_passes: bool = True

    kind: ClassVar[str] = "area"
    title: ClassVar[str] = "area grid"
    area_is_centreline: ClassVar[bool] = False
    nose_turns_camera: ClassVar[bool] = False
    fields: ClassVar[tuple[Field, ...]] = ()  # its heading and cross-hatch are [flight]'s

    @classmethod
    def centreline_sides(cls, spec: MissionSpec) -> tuple[float | None, float | None]:
        return None, None

    @classmethod
    def stands_on(cls, site: Site) -> BaseGeometry | None:
        return None  # its heights are above the area's ground

    @classmethod
    def options(cls, values: Mapping[str, Any], flight: FlightSpec) -> None:
        return None

    @classmethod
    def from_spec(cls, spec: MissionSpec, several_passes: bool = True) -> AreaGrid:
        return cls(spec.flight.heading_deg, spec.flight.cross_hatch, spec.targets.images_beyond_boundary,
                   spec.targets.coverage_margin_m, several_passes=several_passes)

    @classmethod
    def footprint(cls, spec: MissionSpec, heights: Heights) -> Footprint:
        return nadir_footprint(spec, heights)

    @classmethod
    def bounds(cls, spec: MissionSpec, site: Site, sensor: SensorSolution, layout: Layout) -> GridBounds:
        return grid_bounds(covered(site.area, layout.margin_m, site.grid_scale), site.grid_scale, sensor.across_m,
                           sensor.spacing_m, sensor.base_m, sensor.side_images_per_point, 2 if spec.flight.cross_hatch else 1)

    @classmethod
    def parameters(cls, plan: Plan) -> dict[str, Any]:
        return {}

    def layouts(self, site: Site, sensor: SensorSolution, report: Progress) -> Iterator[Layout]:
        """The grids this area may be flown in, the shortest estimated flight first: the one grid at
        the fastest (or the fixed) heading, or the area cut in two pieces at their own headings where
        that flies shorter; then, laid only when asked for, the one grid where the pieces came first,
        the one grid in one band where it was laid in bands across the notches (at the search's
        heading), and the one grid at the next fastest headings the search priced (MAX_OTHER_HEADINGS). The
        planner flies the first that leaves no required ground unseen (`planner.flown_layout`): the
        estimate prices lines, not the ground a line cut short next to a zone leaves to one photo."""
        k = site.grid_scale
        margin = self.coverage_margin_m * k
        covered = shapely.buffer(site.area, margin, quad_segs=4) if margin > 0 else site.area
        whole = self._grid(covered, site, sensor, report)
        laid = [whole]
        chosen = whole.chosen
        # pieces end runs inside the area, at the cut: not where each run must end beyond it
        if (self.several_passes and self.heading_deg is None and not self.cross_hatch and not self.images_beyond_boundary
                and covered.geom_type == "Polygon" and _concave(covered)):
            report("pieces of their own heading", 0.64)
            laid = self._pieces(covered, whole, site, sensor)
            if len(laid) == 2:
                chosen = (f"auto: the area cut in two pieces flown at {laid[0].heading:.1f}° and {laid[1].heading:.1f}° "
                          "(a shorter flight than one heading)")
        report("flight lines and photo stations", 0.66)
        first = self._laid_out(laid, chosen, covered)
        if first is None:
            raise InputError("no flight line fits: the area is smaller than one photo or entirely blocked by exclusion zones")
        yield first
        others = [self._laid_out([whole], f"{whole.chosen}; not cut in two pieces (they leave more ground next to the zones "
                                 "unseen)", covered)] if len(laid) == 2 else []
        if whole.banded:  # the one grid in one band, at its fastest heading
            one = self._grid(covered, site, sensor, no_progress, at_heading=whole.searched, in_bands=False)
            others.append(self._laid_out([one], f"{whole.chosen.split(';')[0]}; not laid in bands (they leave more ground "
                                         "next to the zones unseen)", covered))
        yield from (o for o in others if o is not None)
        for rank, h in enumerate(whole.others[:MAX_OTHER_HEADINGS], start=2):
            other = self._grid(covered, site, sensor, no_progress, at_heading=h)
            why = other.chosen.replace("fixed by the spec", f"auto: the heading with the {_ordinal(rank)} shortest estimated "
                                       "flight time (the faster layouts leave more ground next to the zones unseen)", 1)
            lay = self._laid_out([other], why, covered)
            if lay is not None:
                yield lay

    def _pieces(self, covered: BaseGeometry, whole: _Laid, site: Site, sensor: SensorSolution) -> list[_Laid]:
        """The area cut in two pieces, each at its own heading, where that flies shorter than the one
        grid `whole` (at its own direction's solution) with no more photos; else [whole]."""
        k = site.grid_scale
        speed = sensor.kinematics.speed_ms

        def rough(piece: BaseGeometry) -> float:
            """A piece's time estimate with lines along its narrowest direction (no search)."""
            h = narrowest(piece)[1]
            fr, own = LineFrame(h), sensor.at_heading(h)
            segs = build_lines(fr.geom_to_frame(piece), None, strip_geometry(own, 0, k, site.autopilot_scale(h)))
            return quick_cost(segs, own.lead_in_m * k, own.kinematics, fr) if segs else math.inf

        # the transit between the pieces: at most from one's centre to the other's
        splits = [(rough(a) + rough(b) + a.centroid.distance(b.centroid) / speed, a, b)
                  for a, b in split_candidates(covered, sensor.spacing_m * k / 4.0)]
        # the one grid at the spacing its own direction needs (a camera turned by the heading: laid again for it
        # alone, `planner._under_turned_camera`), not at this solution's, made for the pieces' directions too
        alone = sensor.at_heading(whole.heading)
        best = whole.cost if alone is sensor else self._grid(covered, site, alone, no_progress, at_heading=whole.heading).cost
        laid = [whole]
        # only the splits whose rough estimate beats the one grid are searched (each piece its
        # heading search): the two most promising
        for _, a, b in sorted((t for t in splits if t[0] < whole.cost), key=lambda t: t[0])[:MAX_SPLITS_SEARCHED]:
            la, lb = (self._grid(piece, site, sensor, no_progress) for piece in (a, b))
            turn = abs((la.heading - lb.heading + 90.0) % 180.0 - 90.0)
            cost = la.cost + lb.cost + a.centroid.distance(b.centroid) / speed
            if turn >= PARALLEL_DEG and la.photos + lb.photos <= whole.photos and cost < best * (1.0 - 1e-9):
                best, laid = cost, [la, lb]
        return laid

    def _laid_out(self, laid: list[_Laid], chosen: str, covered: BaseGeometry) -> Layout | None:
        """The Layout of one grid or of two pieces' grids; None where no line fits."""
        passes = [Pass(i, fr, tuple(segs)) for i, (fr, segs) in enumerate((p for la in laid for p in la.passes), start=1)]
        if not any(p.segments for p in passes):
            return None
        return Layout(laid[0].heading, chosen, tuple(passes), covered, self.coverage_margin_m)

    def _grid(self, covered: BaseGeometry, site: Site, sensor: SensorSolution, report: Progress,
              at_heading: float | None = None, in_bands: bool = True) -> _Laid:
        """Parallel lines over `covered` (planning CRS) at the fastest or the fixed heading (the
        spec's, or `at_heading`), in bands across its notches where that flies shorter (`cheapest_cells`;
        not with `in_bands` False). Each heading is priced with its lines laid by its own solution
        (`SensorSolution.at_heading`: with a camera turned by the heading, the spacing its own turn
        needs), and the chosen one laid with `sensor`."""
        k = site.grid_scale
        fixed = self.heading_deg if at_heading is None else at_heading

        scale = functools.cache(site.autopilot_scale)  # a heading's lines are looked up (and keyed) often

        def strips(h: float, s: SensorSolution) -> StripGeometry:
            return strip_geometry(s, self.images_beyond_boundary, k, scale(h))

        laid: dict[tuple[float, StripGeometry], tuple[LineFrame, list[LineSegment]]] = {}

        def lines_for(h: float, s: SensorSolution) -> tuple[LineFrame, list[LineSegment]]:
            # the heading search lays every candidate; lines laid as they were priced are not laid again
            key = (h, strips(h, s))
            if key not in laid:
                fr = LineFrame(h)
                zf = fr.geom_to_frame(site.zones_buffered) if site.zones_buffered is not None else None
                laid[key] = (fr, build_lines(fr.geom_to_frame(covered), zf, key[1]))
            return laid[key]

        def timer(h: float, s: SensorSolution) -> Callable[[list[LineSegment]], float]:
            """quick_cost of runs of heading h flown with solution s (its lead-in and kinematics)."""
            fr = LineFrame(h)
            return lambda segs: quick_cost(segs, s.lead_in_m * k, s.kinematics, fr) if segs else math.inf

        priced: dict[float, float] = {}
        if fixed is None:
            n_cand = len(candidate_headings(covered)) + 10
            tried = 0

            def cost(fr: LineFrame) -> float:
                nonlocal tried
                tried += 1
                report("choosing the heading", 0.05 + 0.6 * min(1.0, tried / n_cand))
                h = fr.heading_deg
                own = sensor.at_heading(h)
                priced[h] = timer(h, own)(lines_for(h, own)[1])
                return priced[h]

            outline = Outline.of(covered, site.zones_buffered)
            plane = sensor.kinematics.vehicle != "copter"  # only the plane's bound asks which lines have one run

            # line_bounds holds (frames, edges) arrays: frames a batch at a time keeps them small
            per_batch = max(1, BOUND_BATCH_ELEMENTS // (len(outline.start) + len(outline.shells) + len(outline.zone_radius)))
            scales = [scale(h) for h in (0.0, 90.0)]

            def bounded_as(h: float) -> tuple[StripGeometry, float, Kinematics]:
                """What a heading's lower bound is computed with: its own solution, with the longest base of any heading
                (the fewest photos); with a camera not turned by the heading, the same for every heading."""
                own = sensor.at_heading(h)
                g = max((strip_geometry(own, self.images_beyond_boundary, k, sc) for sc in scales), key=lambda s: s.base)
                return g, own.lead_in_m * k, own.kinematics

            def bound(frames: list[LineFrame]) -> list[float]:
                out = [0.0] * len(frames)
                alike: dict[tuple[StripGeometry, float, Kinematics], list[int]] = {}
                for i, fr in enumerate(frames):
                    alike.setdefault(bounded_as(fr.heading_deg), []).append(i)
                for (g, lead, kin), at in alike.items():
                    for b in range(0, len(at), per_batch):
                        batch = at[b:b + per_batch]
                        lb = line_bounds(outline, [frames[i] for i in batch], g, single_runs=plane)
                        for i, low in zip(batch, quick_cost_lower_bounds(lb, lead, g.base, kin)):
                            out[i] = float(low)
                return out

            heading, _ = best_heading(covered, cost, bound=bound)
            chosen = "auto: the shortest estimated flight time"
        else:
            heading, chosen = fixed, "fixed by the spec"
        searched = heading
        zones = site.zones_buffered

        banded: dict[tuple[float, StripGeometry, int], tuple[float, list[float], list[list[LineSegment]]]] = {}

        # where to cut and which headings to try, from the outline without its small wiggles
        # (Douglas-Peucker keeps a subset of the vertices: a notch's corners stay where they are)
        simple = shapely.simplify(covered, sensor.spacing_m * k / 4.0, preserve_topology=True)

        def cells_for(h: float, s: SensorSolution, most: int) -> tuple[float, list[float], list[list[LineSegment]]]:
            """Heading h's runs laid with solution s in bands, with at most `most` photos (`cheapest_cells`)."""
            fr, segs = lines_for(h, s)
            g_h = strips(h, s)
            if (h, g_h, most) not in banded:
                zf = fr.geom_to_frame(zones) if zones is not None else None
                cands = cut_candidates(fr.geom_to_frame(simple), g_h.spacing, g_h.base)
                banded[h, g_h, most] = cheapest_cells(fr.geom_to_frame(covered), zf, g_h, segs, timer(h, s), most, cands)
            return banded[h, g_h, most]

        def photos(h: float, s: SensorSolution) -> int:
            return sum(seg.n for seg in lines_for(h, s)[1])

        # bands end runs inside the area, at their cuts: not where each run must end beyond it
        banding = in_bands and _concave(covered) and not self.images_beyond_boundary
        if banding and fixed is None and not self.cross_hatch:
            # cut into bands, a heading along one of the area's own long edges (a notch's side)
            # may fly shorter than the single grid's best heading: the cheapest kept, each priced by its own
            # solution with no more photos than the single grid at its heading (the time estimate flies lines in
            # order, the route searches more, so a layout priced cheaper with more photos may fly longer)
            report("cells across the notches", 0.62)
            most = photos(heading, sensor.at_heading(heading))

            def own_cells(h: float) -> tuple[float, list[float], list[list[LineSegment]]]:
                return cells_for(h, sensor.at_heading(h), most)

            fewer = [h for h in edge_headings(simple) if sum(seg.n for b in own_cells(h)[2] for seg in b) <= most]
            heading = min((heading, *fewer), key=lambda h: (own_cells(h)[0], h != heading, h))
        headings = [heading] + ([(heading + 90.0) % 180.0] if self.cross_hatch else [])
        passes: list[tuple[LineFrame, list[LineSegment]]] = []
        split = 0
        main: list[LineSegment] = []
        for h in headings:
            _, cuts, bands = cells_for(h, sensor, photos(searched, sensor)) if banding else (0.0, [], [lines_for(h, sensor)[1]])
            split = max(split, len(cuts) + 1 if cuts else 0)
            fr = lines_for(h, sensor)[0]
            passes += [(fr, segs) for segs in bands] if self.several_passes else [(fr, joined(bands))]
            main = main or joined(bands)
        if split:
            each = ", a pass each" if self.several_passes else ""
            chosen += f"; lines laid in {split} bands across the notches{each} (a shorter flight than one grid)"
        # the other headings priced, fastest first (where the search chose a notch's edge, the grid's best too)
        others = [h for c, h in sorted((c, h) for h, c in priced.items()) if h != heading and math.isfinite(c)]
        return _Laid(heading, chosen, passes, timer(heading, sensor)(main),
                     sum(s.n for _, segs in passes for s in segs), others, split > 0, searched)


@dataclass(frozen=True)
class _Laid:
    """One area's (or piece's) lines: its heading, why, its passes' frames and runs, the time
    estimate of its main pass and its photos."""

    heading: float
    chosen: str
    passes: list[tuple[LineFrame, list[LineSegment]]]
    cost: float
    photos: int
    others: list[float]  # the other headings the search priced, fastest first (none at a fixed heading)
    banded: bool  # laid in bands across the notches
    searched: float  # the heading of the search (or the fixed one), before a notch's edge may take its place


def _ordinal(n: int) -> str:
    return f"{n}{'nd' if n == 2 else 'rd' if n == 3 else 'th'}"


def _concave(area: BaseGeometry) -> bool:
    return bool(area.area < shapely.convex_hull(area).area * (1.0 - 1e-9))


#: two pieces' headings at least this far apart: nearer, their lines could lie side by side
#: farther apart than the spacing (bands lay those, `cell_lines`)
PARALLEL_DEG = 3.0
#: headings other than the fastest laid as layouts of their own, when the faster leave ground unseen
MAX_OTHER_HEADINGS = 4
#: reflex vertices whose cuts `split_candidates` tries: the most marked ones
MAX_SPLIT_VERTICES = 3
#: splits whose pieces get a heading search of their own: the ones roughly estimated fastest
MAX_SPLITS_SEARCHED = 2


def split_candidates(area: shapely.Polygon, tol: float) -> list[tuple[shapely.Polygon, shapely.Polygon]]:
    """Ways to cut the area in two at a reflex vertex of its outline simplified by `tol` (a
    detailed outline's small wiggles are no notches): at the MAX_SPLIT_VERTICES most marked
    (the turn's sine times the shorter of its two edges), along either edge at the vertex
    carried on into the area, or along the bisector of its angle, each to where it first meets
    the simplified outline again and 2·tol on, so that it crosses the area's own outline; only
    cuts that leave two polygons, each a hundredth of the area or more."""
    simple = shapely.simplify(area, tol, preserve_topology=True)
    if simple.geom_type != "Polygon":
        return []
    xy = np.asarray(shapely.orient_polygons(simple).exterior.coords)[:-1]
    d_in, d_out = xy - np.roll(xy, 1, axis=0), np.roll(xy, -1, axis=0) - xy
    turn = d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0]  # counter-clockwise exterior: a right turn is reflex
    ln_in, ln_out = np.hypot(*d_in.T), np.hypot(*d_out.T)
    with np.errstate(invalid="ignore", divide="ignore"):
        marked = np.where((turn < 0) & (ln_in > 0) & (ln_out > 0), -turn / (ln_in * ln_out) * np.minimum(ln_in, ln_out), 0.0)
    reach = 2.0 * float(np.hypot(*(np.ptp(xy, axis=0))))
    out: list[tuple[shapely.Polygon, shapely.Polygon]] = []
    for i in np.argsort(-marked, kind="stable")[:MAX_SPLIT_VERTICES].tolist():
        if marked[i] <= tol:
            break
        u_in, u_out = d_in[i] / ln_in[i], d_out[i] / ln_out[i]
        for u in (u_in, -u_out, u_in - u_out):
            u = u / np.hypot(*u)
            p = xy[i]
            hit = shapely.intersection(shapely.LineString([p + u * 1e-6 * reach, p + u * reach]), simple.exterior)
            pts = shapely.get_coordinates(hit)
            if not len(pts):
                continue
            q = pts[np.argmin(np.hypot(*(pts - p).T))]
            cut = shapely.LineString([p - u * (2.0 * tol + 1e-6 * reach), q + u * (2.0 * tol + 1e-6 * reach)])
            pieces = [g for g in shapely.get_parts(shapely.ops.split(area, cut)) if g.geom_type == "Polygon"]
            if len(pieces) == 2 and min(g.area for g in pieces) >= area.area / 100.0:
                out.append((pieces[0], pieces[1]))
    return out


#: the area's edge directions tried as headings of a banded layout: the longest ones
MAX_EDGE_HEADINGS = 6


def edge_headings(area: BaseGeometry) -> list[float]:
    """The directions (degrees, 0-180) of the area's longest boundary edges, holes' too, the
    MAX_EDGE_HEADINGS longest distinct ones (a notch's sides are no edges of the hull)."""
    rings = shapely.get_rings(shapely.get_parts(area))
    xy, ring_of = shapely.get_coordinates(rings, return_index=True)
    start = np.flatnonzero(ring_of[1:] == ring_of[:-1])
    d = xy[start + 1] - xy[start]
    length = np.hypot(d[:, 0], d[:, 1])
    out: list[float] = []
    for i in np.argsort(-length, kind="stable").tolist():
        h = round(float(np.degrees(np.arctan2(d[i, 0], d[i, 1])) % 180.0), 6)
        if length[i] > 0 and h not in out:
            out.append(h)
        if len(out) == MAX_EDGE_HEADINGS:
            break
    return out


#: cuts between cells tried: the ordinates where the area's width jumps most
MAX_CUTS = 6


def cut_candidates(area_f: BaseGeometry, spacing: float, base: float) -> list[float]:
    """Ordinates (line frame) where a band of cells may be cut: the area's reflex vertices (where
    a notch or a hole begins or ends, so the lines' lengths jump), those whose width jumps most
    first (the area's length along the lines a quarter spacing below against above), at most
    MAX_CUTS, each at least half a spacing from the others and from the area's lowest and
    highest ordinate, and a jump of a base or more."""
    _, vmin, _, vmax = area_f.bounds
    vs: list[float] = []
    for poly in shapely.get_parts(area_f):
        for ring in (poly.exterior, *poly.interiors):
            xy = np.asarray(ring.coords)[:-1]
            if len(xy) < 3:
                continue
            ccw = shapely.LinearRing(xy).is_ccw
            d_in, d_out = xy - np.roll(xy, 1, axis=0), np.roll(xy, -1, axis=0) - xy
            turn = d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0]
            # the area lies left of a counter-clockwise exterior and of a clockwise hole
            left = ccw if ring is poly.exterior else not ccw
            vs += xy[(turn < 0) if left else (turn > 0), 1].tolist()
    q = spacing / 2.0
    cand = np.unique(np.asarray(vs, float))  # exact: a cut a hair off a notch's corner leaves a sliver of the wider side
    cand = cand[(cand > vmin + q) & (cand < vmax - q)]
    if not len(cand):
        return []
    minx, _, maxx, _ = area_f.bounds
    w = spacing / 4.0
    below = shapely.area(shapely.intersection(area_f, shapely.box(minx - 1.0, cand - w, maxx + 1.0, cand))) / w
    above = shapely.area(shapely.intersection(area_f, shapely.box(minx - 1.0, cand, maxx + 1.0, cand + w))) / w
    jump = np.abs(above - below)
    kept: list[float] = []
    for i in np.argsort(-jump, kind="stable").tolist():
        if jump[i] < base or len(kept) == MAX_CUTS:
            break
        if all(abs(cand[i] - c) >= q for c in kept):
            kept.append(float(cand[i]))
    return kept


def cell_lines(area_f: BaseGeometry, zones_f: BaseGeometry | None, g: StripGeometry,
               cuts: list[float], direction: int = 1) -> list[list[LineSegment]]:
    """The area cut across the lines at the ordinates `cuts` into bands, each band laid with its
    own lines (`build_lines`: every point of a band in k_side strips of its lines, k_fwd photos
    each, so every point of the area is): the runs of each band, in the order laid (a pass
    each: its lines evenly spaced, as QGroundControl's Survey item regenerates a pass). Runs
    end at the cuts, inside the area: not for the images-beyond-the-boundary rule.

    Bands are laid one after another, upwards (`direction` 1) or downwards (−1): a band's lines
    centred on it (`strip_offsets`) when its first line then lies within a spacing of the last
    band's last line, else at the spacing from that line on (`anchored_offsets`), so that no two
    neighbouring lines lie farther apart than the spacing (the asked side overlap holds between
    bands too). No bands ([]) where a band cannot be laid so."""
    minx, vmin, maxx, vmax = area_f.bounds
    edges = [vmin, *sorted(cuts), vmax]
    spans = list(zip(edges[:-1], edges[1:]))[::direction]
    reach = g.across / 2.0 - (g.side_per_point - 1) * g.spacing  # the k-th line from a band's edge
    out: list[list[LineSegment]] = []
    last: float | None = None
    for lo, hi in spans:
        band = shapely.clip_by_rect(area_f, minx - 1.0, lo, maxx + 1.0, hi)
        if band.is_empty or band.area <= 0:
            continue
        _, blo, _, bhi = band.bounds
        vs = strip_offsets(blo, bhi, g.across, g.spacing, g.side_per_point)
        near = vs[0] if direction > 0 else vs[-1]
        if last is not None and abs(near - last) > g.spacing * (1.0 + 1e-9):
            first = min(last + g.spacing, blo + reach) if direction > 0 else max(last - g.spacing, bhi - reach)
            anchored = anchored_offsets(blo, bhi, first, direction, g)
            if anchored is None:
                return []
            vs = anchored
        last = float(vs[-1] if direction > 0 else vs[0])
        segs = build_lines(band, zones_f, g, vs=vs)
        if segs:
            out.append(segs)
    return out


def joined(bands: list[list[LineSegment]]) -> list[LineSegment]:
    """The bands' runs as one pass's, lines numbered by ordinate (the time estimate's order)."""
    laid = [(s.v, b, s.line, s) for b, segs in enumerate(bands) for s in segs]
    index: dict[tuple[int, int], int] = {}
    for _, b, line, _ in sorted(laid, key=lambda t: t[:3]):
        index.setdefault((b, line), len(index))
    return [LineSegment(index[(b, line)], s.part, s.v, s.x0, s.n, s.base)
            for _, b, line, s in sorted(laid, key=lambda t: (index[(t[1], t[2])], t[3].part))]


def cheapest_cells(area_f: BaseGeometry, zones_f: BaseGeometry | None, g: StripGeometry, grid: list[LineSegment],
                   cost: Callable[[list[LineSegment]], float], most_photos: int,
                   cands: list[float]) -> tuple[float, list[float], list[list[LineSegment]]]:
    """(time, cuts, bands' runs): the single grid's runs `grid` (one band), or the area cut into
    bands across the lines (`cell_lines`) where that costs less time with `most_photos` photos or
    fewer: cuts added one at a time, the one saving most first, while one saves any (a line
    crossing a notch photographs the ground on both sides of it at the length of the longer; a
    band each lays them at their own lengths). `cands`: the cuts to try (`cut_candidates`)."""
    cands = list(cands)
    best_cost = cost(grid) if grid else math.inf
    cuts: list[float] = []
    best = [grid]
    while cands:
        tried = [(c, cell_lines(area_f, zones_f, g, [*cuts, c], d)) for c in cands for d in (1, -1)]
        priced = [(cost(joined(bands)) if bands and sum(s.n for b in bands for s in b) <= most_photos else math.inf,
                   c, bands) for c, bands in tried]
        value, c, bands = min(priced, key=lambda t: (t[0], t[1]))
        if not value < best_cost * (1.0 - 1e-9):
            break
        best_cost, best = value, bands
        cuts.append(c)
        cands.remove(c)
    return best_cost, sorted(cuts), best


__all__ = ["AreaGrid", "cell_lines", "cheapest_cells", "cut_candidates", "joined", "split_candidates", "strip_geometry"]
