"""A corridor's ground around its centreline, and the centreline derived from a corridor polygon.

`corridor_polygon` is the ground a given distance left and right of a centreline: what a
corridor plan photographs.

`derive_centreline` turns a corridor drawn as a polygon (a road's outline, a river's banks) into
the centreline the corridor pattern flies along, and the widths each side of it that make the
corridor round that line cover the polygon. Each part of a MultiPolygon gets its own centreline;
holes are filled (ground that needs no photos, flown over as an area's holes are).

1. The boundary is sampled every DENSIFY_SHARE of the polygon's typical half-width (its area
   over its perimeter; at most MAX_SAMPLES samples) and the Voronoi edges of the samples (qhull,
   through scipy) that lie inside the polygon kept: an approximation of its medial axis, a graph
   of the points with two boundary samples or more nearest.
2. Its spurs are pruned: each subtree off the axis whose inscribed circles all lie within
   SPUR_SHARE times the inscribed radius at its root of the root (an outline's corner: a square
   end's, a mitred bend's outer one; a bump of a wiggly edge; the spur pruning of the medial-axis
   literature, by the radius at the root). The longest path of what is left (the graph's diameter,
   found by two shortest-path searches from scipy, exact on a tree) is the main line, each end
   carried on into what was pruned there while one way on stays as wide (`_widest_on`).
3. The line is simplified within SIMPLIFY_SHARE of its median inscribed radius (Douglas-Peucker),
   extended straight at each end over the ground that lies beyond it, and turned to run
   eastwards (northwards when its ends lie due north of one another).
4. A polygon with a branch (a Y) has no single centreline: a point of the medial axis whose
   inscribed circle, at least half as wide as the corridor there, lies wholly beyond the
   corridor's own inscribed width from the line is refused with its numbers.
5. The widths: the farthest boundary sample from the line on its left and on its right. The
   corridor round the line with those widths is checked to cover the polygon (grown by what
   sticks out, if the samples missed any), and one shorter than MIN_ASPECT times its width refused.

Pure: plain shapely geometry in a planar CRS in, plain data out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.errors import InputError

#: the boundary is sampled every this share of the polygon's typical half-width (area / perimeter)
DENSIFY_SHARE = 0.2
#: at most this many boundary samples (the Voronoi diagram's memory and time): a longer outline
#: is sampled more coarsely, and refused when that is coarser than half its typical half-width
MAX_SAMPLES = 200_000
#: a spur of the medial axis (a piece hanging off one of its vertices) whose inscribed circles all
#: lie within this many times that vertex's inscribed radius of it is pruned: an outline's corner
#: (a square end's reaches √2 radii, a mitred bend's outer one 1/cos(turn / 2): 1.56 at 100°, 2 at
#: 120°) or a bump of a wiggly edge, not an arm; an end loses about a radius with it (as much as
#: SPUR_SHARE − 1 radii lies within the circle), which `_widest_on` gives back
SPUR_SHARE = 2.0
#: a main path's end is carried on into the spurs pruned off it while the corridor keeps this share
#: of its width there
END_WIDTH_SHARE = 0.95
#: a branch is judged against the main path's widest inscribed circle within this many of its
#: points either side (about 2.5 corridor widths: the boundary is sampled every DENSIFY_SHARE of a half-width)
BRANCH_WINDOW = 25
#: the main path is simplified within this share of its median inscribed radius
SIMPLIFY_SHARE = 0.1
#: a corridor polygon at least this many times longer than wide
MIN_ASPECT = 2.0
#: the round outside of a bend in `corridor_polygon`: its arc drawn as this many chords
FAN_STEPS = 32
#: `corridor_polygon`'s vertices on a grid this fine (CRS units: a micrometre in a metric CRS)
GRID_SIZE = 1e-6


@dataclass(frozen=True)
class DerivedCentreline:
    """The centreline of a corridor polygon (a LineString, a MultiLineString for several parts,
    in the polygon's CRS), the widths left and right of it that cover the polygon (looking along
    it; CRS units), and the simplification tolerance used (CRS units)."""

    centreline: BaseGeometry
    left: float
    right: float
    tolerance: float


def derive_centreline(polygon: BaseGeometry, unit: float, where: str) -> DerivedCentreline:
    """The centreline of each part of `polygon` (planar CRS, `unit` CRS units per metre) and the
    widths that cover it. `where` names the input in messages (InputError)."""
    # holes filled: ground that needs no photos, which the corridor flies over (as an area's holes)
    parts = shapely.polygons(shapely.get_exterior_ring(shapely.get_parts(polygon)))
    lines: list[np.ndarray] = []
    tolerances = []
    left = right = 0.0
    for i, part in enumerate(parts, start=1):
        name = f"{where} (polygon {i} of {len(parts)})" if len(parts) > 1 else where
        xy, tol = _part_centreline(part, unit, name)
        xy, part_left, part_right = _covering(part, xy, *_sides(xy, _boundary_samples(part, _spacing(part))), unit, name)
        length = float(np.sum(np.hypot(*np.diff(xy, axis=0).T)))
        width = part_left + part_right
        if length < MIN_ASPECT * width:
            raise InputError(f"{name}: the corridor polygon is {length / unit:,.0f} m long and {width / unit:,.0f} m wide round its "
                             f"derived centreline (length/width {length / width:.2f}); a corridor polygon must be at least "
                             f"{MIN_ASPECT:g} times longer than wide: plan it as an area (pattern.kind = 'area') or give its "
                             "centreline as a line")
        lines.append(xy)
        tolerances.append(tol)
        left, right = max(left, part_left), max(right, part_right)
    line = shapely.linestrings(lines[0]) if len(lines) == 1 else shapely.multilinestrings([shapely.linestrings(xy) for xy in lines])
    return DerivedCentreline(line, left, right, max(tolerances))


def _spacing(part: BaseGeometry) -> float:
    """How far apart the boundary is sampled: DENSIFY_SHARE of the typical half-width, or as
    MAX_SAMPLES allows."""
    return max(DENSIFY_SHARE * float(part.area) / float(part.length), float(part.length) / MAX_SAMPLES)


def _boundary_samples(part: BaseGeometry, spacing: float) -> np.ndarray:
    """Points on the polygon's rings at most `spacing` apart, each once."""
    xy: np.ndarray = np.unique(shapely.get_coordinates(shapely.segmentize(part, spacing)), axis=0)
    return xy


def _part_centreline(part: BaseGeometry, unit: float, where: str) -> tuple[np.ndarray, float]:
    """One polygon's centreline, not yet widened (steps 1 to 4 of the module's description), and
    the simplification tolerance."""
    half = part.area / part.length
    spacing = _spacing(part)
    if spacing > 0.5 * half:
        raise InputError(f"{where}: the corridor polygon's outline is {part.length / unit / 1000:,.1f} km long for a typical "
                         f"half-width of {half / unit:,.1f} m: too long and narrow to derive its centreline from "
                         f"{MAX_SAMPLES:,} boundary samples; give the centreline as a line with pattern.width_m")
    samples = _boundary_samples(part, spacing)
    nodes, a, b = _medial_axis(part, samples)
    if not len(a):
        raise InputError(f"{where}: no medial axis found inside the corridor polygon; give its centreline as a line")
    node_radius = np.zeros(len(nodes))  # the inscribed radius at each vertex of the axis
    on_edges = np.unique(np.r_[a, b])
    node_radius[on_edges] = shapely.distance(shapely.points(nodes[on_edges]), shapely.boundary(part))
    path, axis = _main_axis(nodes, node_radius, a, b)
    if len(path) < 2:  # a disc's or a square's medial axis: a point, or spurs from one into its corners
        raise InputError(f"{where}: the corridor polygon is about as wide as it is long (its medial axis is a point): "
                         f"a corridor polygon must be at least {MIN_ASPECT:g} times longer than wide; plan it as an area "
                         "(pattern.kind = 'area')")
    xy, radius = nodes[path], node_radius[path]
    typical = float(np.median(radius))
    tol = SIMPLIFY_SHARE * typical
    line = _extended(_simplified(xy, tol), xy, samples, 2.0 * typical, tol)
    d = line[-1] - line[0]
    if d[0] < 0 or (d[0] == 0 and d[1] < 0):  # eastwards, or northwards
        line = line[::-1]
    _refuse_branches(nodes[axis], node_radius[axis], line, xy, radius, unit, where)
    return line, tol


def _simplified(xy: np.ndarray, tol: float) -> np.ndarray:
    """The polyline simplified within `tol` (Douglas-Peucker: a subset of its points, ends kept)."""
    simple: np.ndarray = np.asarray(shapely.get_coordinates(shapely.simplify(shapely.linestrings(xy), tol)), float)
    return simple


def _medial_axis(part: BaseGeometry, samples: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The Voronoi vertices of the boundary samples (qhull's, through scipy) and the Voronoi
    edges between them that lie inside the polygon, as pairs of vertex indices. An edge is kept
    only if both its ends lie as near its two samples as any (to a thousandth): qhull merges the
    vertices of samples on one circle (a straight corridor sampled alike on both sides), and a
    merged vertex has carried edges 150 m along a corridor."""
    from scipy.spatial import KDTree, Voronoi

    centre = samples.mean(axis=0)
    vor = Voronoi(samples - centre)
    nodes = vor.vertices + centre
    finite = np.array([r[0] >= 0 and r[1] >= 0 for r in vor.ridge_vertices], bool)
    ridges = np.array([r for r, ok in zip(vor.ridge_vertices, finite) if ok], dtype=np.int64).reshape(-1, 2)
    shapely.prepare(part)
    inside = shapely.contains_properly(part, shapely.linestrings(nodes[ridges]))
    ridges, pair = ridges[inside], samples[vor.ridge_points[finite][inside]]  # each edge's two samples
    ends = nodes[ridges]  # (edge, end, xy)
    nearest = KDTree(samples).query(ends.reshape(-1, 2))[0].reshape(-1, 2)
    own = np.hypot(*(ends[:, :, None, :] - pair[:, None, :, :]).transpose(3, 0, 1, 2))  # (edge, end, sample)
    ridges = ridges[np.all(own <= 1.001 * nearest[:, :, None], axis=(1, 2))]
    return nodes, ridges[:, 0], ridges[:, 1]


def _main_axis(nodes: np.ndarray, radius: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The vertex indices of the main path of the medial axis (edges `a`-`b`, inscribed `radius`
    at each vertex), and which vertices belong to the axis it runs along: the component with the
    longest edges in all (spurs and all: the branch test judges them), its spurs pruned (`_spurs`),
    and the longest path of what is left (exact on a tree: the farthest vertex from any vertex is
    an end of it), each end carried on into the spurs pruned there (`_widest_on`)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import breadth_first_order, connected_components, dijkstra

    def graph(a: np.ndarray, b: np.ndarray) -> coo_matrix:
        length = np.hypot(*(nodes[b] - nodes[a]).T)
        return coo_matrix((np.r_[length, length], (np.r_[a, b], np.r_[b, a])), shape=(len(nodes), len(nodes))).tocsr()

    axis = graph(a, b)
    _, label = connected_components(axis, directed=False)
    main = int(np.argmax(np.bincount(label[a], weights=np.hypot(*(nodes[b] - nodes[a]).T))))
    root = int(np.argmax(np.where(label == main, radius, -1.0)))  # the widest point: on the axis, not a spur
    order, parent = breadth_first_order(axis, root, directed=False)
    child = order[1:]
    spur = _spurs(nodes, radius, order, parent)
    kept = child[~spur[child]]
    pruned = graph(kept, parent[kept])
    far = dijkstra(pruned, directed=False, indices=root)
    first = int(np.argmax(np.where(np.isfinite(far), far, -1.0)))
    far, before = dijkstra(pruned, directed=False, indices=first, return_predecessors=True)
    last = int(np.argmax(np.where(np.isfinite(far), far, -1.0)))
    path = [last]
    while path[-1] != first:
        path.append(int(before[path[-1]]))
    on_axis = np.zeros(len(nodes), bool)
    on_axis[order] = True  # the component searched from the root
    return np.array([*_widest_on(first, radius, parent, spur)[::-1], *path[::-1], *_widest_on(last, radius, parent, spur)]), on_axis


def _widest_on(end: int, radius: np.ndarray, parent: np.ndarray, spur: np.ndarray) -> list[int]:
    """The vertices on from a main path's `end` into the spurs pruned off it, as long as one way
    on keeps END_WIDTH_SHARE of the corridor's width at the end: on to a round end's centre, to the
    fork of a square end's two corners (pruning takes up to SPUR_SHARE − 1 radii off an end)."""
    out = [end]
    while True:
        child = np.flatnonzero(spur & (parent == out[-1]))
        wide = child[radius[child] >= END_WIDTH_SHARE * radius[end]]
        if len(wide) != 1:
            return out[1:]
        out.append(int(wide[0]))


def _spurs(nodes: np.ndarray, radius: np.ndarray, order: np.ndarray, parent: np.ndarray) -> np.ndarray:
    """Which vertices of a tree (visited in breadth-first `order` from its root, each vertex's
    `parent`) are cut off with the spur they head: those whose own inscribed circle and all of their
    descendants' lie within SPUR_SHARE times their parent's inscribed radius of it (the spur pruning
    of the medial-axis literature, judged by the radius at the spur's root). No spur reaches
    further along the tree than SPUR_SHARE times the widest radius: each vertex is checked against
    its ancestors that near it, all at once, a step up at a time."""
    child = order[1:]
    step = np.zeros(len(nodes))
    step[child] = np.hypot(*(nodes[child] - nodes[parent[child]]).T)
    reach = SPUR_SHARE * float(radius[order].max())
    # how far each vertex's descendants reach along the tree, their radius added: leaves first
    extent = radius.astype(float).tolist()
    for v, up in zip(order[:0:-1].tolist(), parent[order[:0:-1]].tolist()):
        extent[up] = max(extent[up], step[v] + extent[v])
    # a vertex whose circle lies beyond SPUR_SHARE radii of an ancestor: the ancestor's child on
    # the way to it heads no spur
    beyond = np.zeros(len(nodes), bool)
    at, below, up, walked = child, child, parent[child], step[child]
    while len(at):
        far = np.hypot(*(nodes[at] - nodes[up]).T) + radius[at] > SPUR_SHARE * radius[up]
        beyond[below[far]] = True
        on = (parent[up] >= 0) & (walked + step[up] <= reach)
        at, below, up, walked = at[on], up[on], parent[up[on]], walked[on] + step[up[on]]
    spur = np.zeros(len(nodes), bool)
    spur[child] = (np.asarray(extent)[child] + step[child] <= reach) & ~beyond[child]
    return spur


def _refuse_branches(nodes: np.ndarray, node_radius: np.ndarray, line: np.ndarray, path: np.ndarray, radius: np.ndarray,
                     unit: float, where: str) -> None:
    """Refuse a polygon whose medial axis has a point whose inscribed circle, at least half as
    wide as the corridor's next to it on the main path, lies wholly beyond that width from the
    centreline `line`: a branch as wide as the corridor, not a corner."""
    pts = shapely.points(nodes)
    from scipy.ndimage import maximum_filter1d

    # the corridor's inscribed radius along the main path: the widest within BRANCH_WINDOW path
    # points (a narrow spot of a wiggly outline makes no branch of what is beside it)
    wide = maximum_filter1d(radius, size=2 * BRANCH_WINDOW + 1, mode="nearest")
    which, nearest = shapely.STRtree(shapely.points(path)).query_nearest(pts, all_matches=False)
    near = np.empty(len(pts))
    near[which] = wide[nearest]
    centreline = shapely.linestrings(line)
    off = shapely.distance(centreline, pts)
    branch = (node_radius >= 0.5 * near) & (off - node_radius >= near)
    if not branch.any():
        return
    k = int(np.argmax(np.where(branch, off, -1.0)))
    at = float(shapely.line_locate_point(centreline, pts[k]))
    raise InputError(f"{where}: the corridor polygon branches: its medial axis reaches {off[k] / unit:,.0f} m off the main "
                     f"centreline ({centreline.length / unit:,.0f} m long, {2 * near[k] / unit:,.0f} m wide there), "
                     f"{at / unit:,.0f} m along it, into an arm as wide as the corridor; a corridor polygon must have one "
                     "centreline: give the centrelines as lines (a MultiLineString) with pattern.width_m, or one polygon "
                     "per arm that do not touch")


def _extended(line: np.ndarray, path: np.ndarray, samples: np.ndarray, reach: float, tol: float) -> np.ndarray:
    """The simplified `line` continued straight at each end as far as the boundary samples nearest
    that end reach beyond it, in the direction of the medial `path`'s last `reach` there (a chord:
    the last segment of a wiggly outline's axis may point anywhere): a new end point, the old one
    left out when it lies within `tol` of the new last segment."""
    simple = shapely.linestrings(line)
    at = shapely.line_locate_point(simple, shapely.points(samples))
    length = float(simple.length)  # GEOS's: what it gives a point projected past the end
    raw = shapely.linestrings(path)
    back = min(reach, float(raw.length) / 2.0)
    out = [p for p in line]
    for first, inner_at, nearest in ((True, back, at <= 0.0), (False, float(raw.length) - back, at >= length)):
        end = out[0] if first else out[-1]
        inner = np.asarray(shapely.get_coordinates(shapely.line_interpolate_point(raw, inner_at)), float)[0]
        d = (end - inner) / math.hypot(*(end - inner))
        beyond = float(((samples[nearest] - end) @ d).max()) if nearest.any() else 0.0
        if beyond <= 0.0:
            continue
        new, before = end + d * beyond, (out[1] if first else out[-2])
        drop = shapely.distance(shapely.Point(end), shapely.LineString([new, before])) <= tol
        if first:
            out = [new, *out[1:]] if drop else [new, *out]
        else:
            out = [*out[:-1], new] if drop else [*out, new]
    extended: np.ndarray = np.array(out)
    return extended


def _sides(xy: np.ndarray, samples: np.ndarray) -> tuple[float, float]:
    """The farthest sample from the line on its left and on its right (looking along it)."""
    line = shapely.linestrings(xy)
    pts = shapely.points(samples)
    at = shapely.line_locate_point(line, pts)
    off = shapely.distance(line, pts)
    arc = np.r_[0.0, np.cumsum(np.hypot(*np.diff(xy, axis=0).T))]
    seg = np.clip(np.searchsorted(arc, at, side="right") - 1, 0, len(xy) - 2)
    u = xy[seg + 1] - xy[seg]
    rel = samples - xy[seg]
    left = u[:, 0] * rel[:, 1] - u[:, 1] * rel[:, 0] > 0
    return float(off[left].max(initial=0.0)), float(off[~left].max(initial=0.0))


def _covering(part: BaseGeometry, xy: np.ndarray, left: float, right: float, unit: float,
              where: str) -> tuple[np.ndarray, float, float]:
    """The line and `left` and `right`, the widths and both ends grown by as far as the polygon
    reaches out of the corridor they make (nothing, unless the boundary between two samples
    bulges out of it); a millionth of the polygon's area may stay out (rounding slivers). Up to
    twelve rounds: a sliver inside a bend between short segments shrinks by about half a round
    (a wiggly outline's 1.3 m² took seven)."""
    for _ in range(12):
        band = corridor_polygon(shapely.linestrings(xy), left, right)
        out = shapely.difference(part, band)
        if out.area <= 1e-6 * part.area:
            return xy, left, right
        # twice as far as the farthest vertex out (a sliver in the inside corner of a bend reaches
        # further from the band between its vertices), and the sag of a fan's chords at the bends
        # (its arc is FAN_STEPS chords of at most π/FAN_STEPS each, within the circle)
        sag = max(left, right) * (1.0 / math.cos(math.pi / (2 * FAN_STEPS)) - 1.0)
        grow = 2.0 * float(np.max(shapely.distance(band, shapely.points(shapely.get_coordinates(out))))) + sag
        left, right = left + grow, right + grow
        xy = xy.copy()
        for end, inner in ((0, 1), (-1, -2)):
            d = xy[end] - xy[inner]
            xy[end] = xy[end] + d / math.hypot(*d) * grow
    raise InputError(f"{where}: the corridor round the centreline derived from the polygon still leaves {out.area / unit**2:,.1f} m² "
                     "of it out after twelve widenings; give the centreline as a line (LineString) with pattern.width_m")


def corridor_polygon(centreline: BaseGeometry, left: float, right: float) -> BaseGeometry:
    """The ground `left` to the left and `right` to the right of a centreline (looking along it),
    ending square at its ends, with round corners outside its bends: a rectangle along each
    segment and a fan outside each bend, united. (GEOS's one-sided buffer drops ground where a
    centreline winds back close to itself.)"""
    parts: list[BaseGeometry] = []
    for piece in shapely.get_parts(centreline):
        xy = np.asarray(shapely.get_coordinates(piece), float)
        d = np.diff(xy, axis=0)
        keep = np.hypot(d[:, 0], d[:, 1]) > 0
        xy = np.vstack([xy[:1], xy[1:][keep]])
        d = d[keep]
        if not len(d):
            continue
        u = d / np.hypot(d[:, 0], d[:, 1])[:, None]
        n = np.column_stack([-u[:, 1], u[:, 0]])  # to the left
        a, b = xy[:-1], xy[1:]
        rings = np.stack([a + n * left, b + n * left, b - n * right, a - n * right], axis=1)
        parts += shapely.polygons(rings).tolist()
        for k in range(1, len(xy) - 1):
            turn = u[k - 1, 0] * u[k, 1] - u[k - 1, 1] * u[k, 0]  # > 0: turning left, the outside is on the right
            r, n0, n1 = (right, -n[k - 1], -n[k]) if turn > 0 else (left, n[k - 1], n[k])
            if r <= 0:
                continue
            t0, t1 = math.atan2(n0[1], n0[0]), math.atan2(n1[1], n1[0])
            sweep = (t1 - t0 + math.pi) % (2 * math.pi) - math.pi
            t = t0 + sweep * np.linspace(0.0, 1.0, FAN_STEPS + 1)
            parts.append(shapely.Polygon(np.vstack([xy[k], xy[k] + r * np.column_stack([np.cos(t), np.sin(t)])])))
    # on a grid of GRID_SIZE: each fan's first and last arc points are the rectangles' corners computed
    # another way, a few 1e-14 apart, and GEOS's union without a grid has dropped a whole part over them
    return shapely.normalize(shapely.union_all(parts, grid_size=GRID_SIZE))
