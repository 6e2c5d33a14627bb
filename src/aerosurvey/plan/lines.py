"""Flight lines for one heading: strip offsets, the stretch each line must photograph,
and the photo stations with their extensions beyond the boundary.

Everything works in a LineFrame (lines along +x). Coverage rules, for a footprint
W (across) × L (along), spacing S and photo base B:
- every point of the area lies in at least ⌊1/(1−side)⌋ strips, at the outer edges too
  (extra lines where needed);
- every point a strip sees lies in at least ⌊1/(1−forward)⌋ of that strip's photos, and
  at least `beyond` photo centres lie outside the area where a line crosses the boundary.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.plan.frame import LineFrame, to_frames
from aerosurvey.plan.photogrammetry import FloatOrArray

_EPS = 1e-6


@dataclass(frozen=True)
class LineSegment:
    """A run of photo stations on one line, in the line frame.

    Stations are at x0 + j·B for j = 0 … n−1 and all lie at ordinate `v`.
    """

    line: int  # index of the line in its pass (by ordinate)
    part: int  # index of the run on that line (by abscissa)
    v: float
    x0: float
    n: int
    base: float

    @property
    def x1(self) -> float:
        return self.x0 + (self.n - 1) * self.base

    def xs(self) -> np.ndarray:
        return self.x0 + self.base * np.arange(self.n)


def strip_offsets(vmin: float, vmax: float, across: float, spacing: float, per_point: int) -> np.ndarray:
    """Line ordinates, centred on the area, so that every v in [vmin, vmax] lies in
    `per_point` strips or more (a strip covers ±across/2 around its line).

    A range narrower than a strip lies in all of k = `per_point` strips whose lines are
    (across − width)/(k − 1) apart or closer: where that asks fewer lines than the spacing does,
    k lines are laid that close (more side overlap than asked, fewer lines)."""
    half = across / 2.0
    n = _spaced_count(vmax - vmin, across, spacing, per_point)
    close = _narrow_spacing(vmax - vmin, across, spacing, per_point, n)
    if close is not None:
        return (vmin + vmax) / 2.0 + close * (np.arange(per_point) - (per_point - 1) / 2.0)
    probe = np.linspace(vmin, vmax, 257)
    reach = half + _EPS
    # a probe lies in the strips of the lines within `reach` only: those are in a window of
    # `width` lines from two below the first line at or above probe − reach (every line outside
    # it is half a spacing or more beyond reach), so comparing the window's lines alone counts
    # the same (measured: 168 lines, 430 µs for all of them, 60 µs for the windows; with 60 lines
    # or fewer, the same time)
    width = math.ceil(2.0 * reach / spacing) + 5
    while True:
        mid = (vmin + vmax) / 2.0
        vs = mid + spacing * (np.arange(n) - (n - 1) / 2.0)
        if n > max(width, 64):
            first = np.clip(np.searchsorted(vs, probe - reach) - 2, 0, n - width)
            near = vs[first[:, None] + np.arange(width)]
        else:
            near = vs[None, :]
        counts = (np.abs(probe[:, None] - near) <= reach).sum(axis=1)
        if counts.min() >= per_point:
            return vs
        n += 1


#: lines laid closer than this share of the spacing would take the same photos twice (to the centimetre): a
#: range that asks them so close gets the spacing's lines instead
_NARROW_MIN = 0.01


def _spaced_count(width: float, across: float, spacing: float, per_point: int) -> int:
    """How many lines `spacing` apart put a range `width` wide in `per_point` strips (n lines see
    `per_point` times a band of across + (n − 2·per_point + 1)·spacing)."""
    need = width - across + 2.0 * (per_point - 1) * spacing
    return max(per_point, math.ceil(need / spacing - _EPS) + 1, 1)


def strip_count(width: float, across: float, spacing: float, per_point: int) -> int:
    """How many lines `strip_offsets` lays across a range `width` wide: `per_point` closer lines where
    `_narrow_spacing` allows them, else the spacing's lines (the strip bound of `bounds.grid_bounds`)."""
    n = _spaced_count(width, across, spacing, per_point)
    return per_point if _narrow_spacing(width, across, spacing, per_point, n) is not None else n


def _narrow_spacing(width: float, across: float, spacing: float, per_point: int, n: int) -> float | None:
    """The spacing of `per_point` lines putting a range `width` wide in all their strips, when
    the range is narrower than a strip and the spacing would lay more lines (else None): the
    farthest line from a point then lies (width + (k − 1)·s)/2 ≤ across/2 from it. None too
    when that is under `_NARROW_MIN` of the spacing: a range almost a strip wide would have its
    lines on top of one another (the same stations twice)."""
    if per_point < 2 or n <= per_point or width >= across * (1.0 - 1e-6):
        return None
    close = min(spacing, (across - width) / (per_point - 1)) * (1.0 - 1e-6)
    return close if close >= _NARROW_MIN * spacing else None


def strip_offsets_many(vmins: np.ndarray, vmaxs: np.ndarray, across: float, spacing: float,
                       per_point: int) -> list[np.ndarray]:
    """`strip_offsets(vmin, vmax, across, spacing, per_point)` of every pair, checked together.

    The lines and probes are those `strip_offsets` makes (the same operations, element by
    element). Which lines lie within reach of a probe follows from where the probe falls
    between them, (p − mid)/spacing + (n − 1)/2 ± reach/spacing: the lines' indices between
    those two numbers. That is what comparing every line gives unless one of the two numbers
    lies within η of a whole number, η = 64 ε M / spacing (M: the largest magnitude of the
    ordinates, probes and lines; ε: the double's relative precision) bounding every rounding
    of either computation by a wide margin; such a pair, and any pair short of strips with its
    first count of lines, is left to `strip_offsets` itself. Measured: 16 headings of the
    1,000 ha case, 1.0 ms one by one, 0.1 ms so."""
    lo, hi = np.asarray(vmins, float), np.asarray(vmaxs, float)
    if not len(lo):
        return []
    half = across / 2.0
    need = hi - lo - across + 2.0 * (per_point - 1) * spacing
    n = np.maximum(np.maximum(per_point, np.ceil(need / spacing - _EPS) + 1), 1)
    with np.errstate(invalid="ignore", over="ignore"):
        ok = np.isfinite(n) & (n < 1e6)
    n = np.where(ok, n, 1).astype(np.int64)
    mid = (lo + hi) / 2.0
    c = (n - 1) / 2.0
    step = (hi - lo) / 256  # np.linspace(vmin, vmax, 257), row by row
    probe = np.arange(257.0)[:, None] * step + lo
    probe[-1] = hi
    reach = half + _EPS
    with np.errstate(invalid="ignore"):
        t = (probe - mid) / spacing + c
        a, b = t - reach / spacing, t + reach / spacing
        big = np.maximum(np.maximum(np.abs(lo), np.abs(hi)), np.abs(mid) + spacing * (n + 2.0)) + reach
        eta = 64.0 * np.finfo(float).eps * big / spacing
        sure = ((np.abs(a - np.round(a)) > eta) & (np.abs(b - np.round(b)) > eta)).all(axis=0)
        count = np.minimum(np.floor(b), n - 1) - np.maximum(np.ceil(a), 0) + 1
        enough = (count.min(axis=0) >= per_point) & ((step != 0) | (hi == lo))  # linspace's zero-step branch aside
        narrow = (per_point > 1) & (n > per_point) & (hi - lo < across * (1.0 - 1e-6))  # _narrow_spacing's: left to strip_offsets
    out = []
    for f, (k, m, done) in enumerate(zip(n.tolist(), mid.tolist(), (ok & sure & enough & ~narrow).tolist())):
        out.append(m + spacing * (np.arange(k) - (k - 1) / 2.0) if done
                   else strip_offsets(float(lo[f]), float(hi[f]), across, spacing, per_point))
    return out


def line_slabs(vs: np.ndarray, g: StripGeometry) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) ordinates of the ground each line must photograph: the points whose
    `side_per_point` nearest lines it is among. Lines are S apart, so that is within k·S/2 of an
    inner line, and as far as its strip reaches (across/2) on the outer side of the first and
    last k lines (no line lies beyond them). Every point of the area lies in k strips
    (`strip_offsets`), so its k nearest lines all see it: k·S/2 ≤ across/2, and each of those
    lines photographs it, k·k_fwd photos in all; the rest of a strip is not flown for."""
    k, n = g.side_per_point, len(vs)
    half = g.across / 2.0
    inner = min(half, k * g.spacing / 2.0)
    i = np.arange(n)
    return vs - np.where(i < k, half, inner), vs + np.where(i >= n - k, half, inner)


def band_intervals(area_f: BaseGeometry, low: np.ndarray, high: np.ndarray) -> list[list[tuple[float, float]]]:
    """For each band [low[i], high[i]] across the lines, the merged x-intervals where it meets the area."""
    minx, _, maxx, _ = area_f.bounds
    # clipping by a rectangle is 3x faster than a general intersection (measured: 149 strips of a
    # 1,000 ha area with holes, 7 ms against 21 ms) and gives the same pieces. shapely's ufunc
    # clips by every strip in one call (its wrapper takes one rectangle a call): the same GEOS
    # clip per strip, without the per-call overhead (measured: 75 strips, 1.1 ms against 0.4 ms)
    try:
        inter = shapely.lib.clip_by_rect(area_f, np.double(minx - 1.0), low, np.double(maxx + 1.0), high)
    except shapely.errors.GEOSException:
        # GEOS's rectangle clip can build a ring of three points from a near-degenerate piece (seen:
        # a corridor's band at 65° N); the general intersection makes the same pieces without it
        inter = shapely.intersection(area_f, shapely.box(minx - 1.0, low, maxx + 1.0, high))
    parts, idx = shapely.get_parts(inter, return_index=True)
    out: list[list[tuple[float, float]]] = [[] for _ in low]
    if len(parts):
        keep = ~shapely.is_empty(parts) & (shapely.area(parts) > 0)
        b = shapely.bounds(parts[keep])
        for i, x0, x1 in zip(idx[keep].tolist(), b[:, 0].tolist(), b[:, 2].tolist()):
            out[i].append((x0, x1))
    return [_merge(iv) if len(iv) > 1 else iv for iv in out]


def _merge(intervals: list[tuple[float, float]], gap: float = 0.0) -> list[tuple[float, float]]:
    merged: list[tuple[float, float]] = []
    for a, b in sorted(intervals):
        if merged and a <= merged[-1][1] + gap:
            merged[-1] = (merged[-1][0], max(merged[-1][1], b))
        else:
            merged.append((a, b))
    return merged


#: A station counted beyond the boundary lies this fraction of a base or more outside it (the
#: photos flown land within centimetres of the stations; this keeps rounding off the count)
BEYOND_MARGIN = 0.05


def line_crossings(area_f: BaseGeometry, vs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(line index, x) of every point where a line y = vs[i] meets the area's boundary, sorted
    by line then x (an edge along a line gives its ends). `vs` ascending."""
    rings = shapely.get_rings(shapely.get_parts(area_f))
    xy, ring_of = shapely.get_coordinates(rings, return_index=True)
    start = np.flatnonzero(ring_of[1:] == ring_of[:-1])  # consecutive points of one ring make an edge
    (x0, y0), (x1, y1) = xy[start].T, xy[start + 1].T
    first = np.searchsorted(vs, np.minimum(y0, y1), "left")
    last = np.searchsorted(vs, np.maximum(y0, y1), "right")
    edge, line = _ranges(first, last)
    dy = (y1 - y0)[edge]
    t = np.divide(vs[line] - y0[edge], dy, out=np.zeros(len(edge)), where=dy != 0)
    x = x0[edge] + t * (x1 - x0)[edge]
    order = np.lexsort((x, line))
    return line[order], x[order]


def station_span(a: FloatOrArray, b: FloatOrArray, enter: FloatOrArray, leave: FloatOrArray, along: float, base: float,
                 per_point: int, beyond: int) -> tuple[FloatOrArray, FloatOrArray]:
    """First and last station abscissa needed to photograph each [a, b] (numbers or arrays).

    Forward coverage needs the first station at a + L/2 − (k−1)·B or before (k photos
    per point). The boundary rule counts photos on the line itself: where the line enters the
    area at `enter` (+inf: it does not within [a, b]), `beyond` stations lie before it, so the
    first at enter − (beyond − 1)·B, less BEYOND_MARGIN of a base, or before; the same after
    `leave` at the other end.
    """
    reach = along / 2.0 - (per_point - 1) * base
    if not beyond:
        return a + reach, b - reach
    out = (beyond - 1 + BEYOND_MARGIN) * base
    return np.minimum(a + reach, enter - out), np.maximum(b - reach, leave + out)


def interval_crossings(intervals: list[tuple[float, float]], xs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(enter, leave) per interval: the first and last of a line's sorted crossings `xs` within
    it (+inf and −inf where the line itself does not meet the area there)."""
    ab = np.asarray(intervals, float).reshape(-1, 2)
    tol = 1e-9 * (1.0 + np.abs(ab).max(initial=0.0))
    i0 = np.searchsorted(xs, ab[:, 0] - tol, "left")
    i1 = np.searchsorted(xs, ab[:, 1] + tol, "right")
    met = i1 > i0
    xs_ = np.r_[xs, 0.0]
    return np.where(met, xs_[i0], np.inf), np.where(met, xs_[np.maximum(i1 - 1, 0)], -np.inf)


def segments_for_line(line: int, v: float, intervals: list[tuple[float, float]], along: float,
                      base: float, per_point: int, beyond: int, merge_gap: float,
                      crossings: np.ndarray | None = None) -> list[LineSegment]:
    """Photo runs on one line: each interval extended, runs closer than `merge_gap` joined.
    `crossings`: the sorted x where the line meets the area's boundary (needed with `beyond`)."""
    ab = np.asarray(intervals, float).reshape(-1, 2)
    enter, leave = interval_crossings(intervals, np.zeros(0) if crossings is None else crossings)
    s, e = station_span(ab[:, 0], ab[:, 1], enter, leave, along, base, per_point, beyond)
    spans = _merge(list(zip(s.tolist(), e.tolist())), gap=merge_gap)
    segs = []
    for part, (s0, e0) in enumerate(spans):
        n = max(per_point, math.ceil((e0 - s0) / base - _EPS) + 1)
        mid = (s0 + e0) / 2.0
        segs.append(LineSegment(line=line, part=part, v=v, x0=mid - (n - 1) * base / 2.0, n=n, base=base))
    return segs


def cut_by_zones(segs: list[LineSegment], zones_f: BaseGeometry | None, clearance: float) -> list[LineSegment]:
    """Remove stations whose flight along the line (±clearance) would enter a zone.

    `zones_f` are the exclusion zones, already buffered by the safety margin, in the line
    frame. Stations that remain keep their places, so runs on both sides stay aligned.
    """
    if zones_f is None or zones_f.is_empty or not segs:
        return segs
    out: list[LineSegment] = []
    # only runs whose box meets the zones' box can meet a zone: the heading search cuts dozens of
    # layouts, and most runs lie far from every zone (first by ordinate: most fail that already,
    # so only the runs of a few lines have their ends worked out)
    zx0, zy0, zx1, zy1 = zones_f.bounds
    ends = [(i, s.x0 - clearance - 1.0, s.v, s.x1 + clearance + 1.0) for i, s in enumerate(segs) if zy0 <= s.v <= zy1]
    near = [(i, a, v, b) for i, a, v, b in ends if b >= zx0 and a <= zx1]
    hits: list[BaseGeometry | None] = [None] * len(segs)
    if near:
        lines = shapely.linestrings(np.array([(a, v, b, v) for _, a, v, b in near], float).reshape(-1, 2, 2))
        for (i, *_), hit in zip(near, shapely.intersection(lines, zones_f)):
            hits[i] = None if hit.is_empty else hit
    for seg, hit in zip(segs, hits):
        if hit is None:
            out.append(seg)
            continue
        xs = seg.xs()
        blocked = np.zeros(len(xs), bool)
        for piece in shapely.get_parts(hit):
            px0, _, px1, _ = piece.bounds
            blocked |= (xs >= px0 - clearance) & (xs <= px1 + clearance)
        part = len(out)
        for i0, i1 in _runs(~blocked):
            out.append(LineSegment(seg.line, part, seg.v, float(xs[i0]), i1 - i0, seg.base))
            part += 1
    renum: list[LineSegment] = []
    counts: dict[int, int] = {}
    for s in sorted(out, key=lambda s: (s.line, s.x0)):
        k = counts.get(s.line, 0)
        counts[s.line] = k + 1
        renum.append(s if s.part == k else LineSegment(s.line, k, s.v, s.x0, s.n, s.base))
    return renum


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) index pairs of the True runs of a boolean array."""
    padded = np.concatenate([[False], mask, [False]]).astype(np.int8)
    d = np.diff(padded)
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist()))


@dataclass(frozen=True)
class StripGeometry:
    """How photo runs are laid on one pass, in planning-grid metres (ground metres × grid scale)."""

    across: float  # footprint across the line
    along: float  # footprint along the line
    spacing: float  # between lines
    base: float  # between stations
    side_per_point: int  # strips every point must lie in
    fwd_per_point: int  # photos of a strip every point must lie in
    beyond: int  # stations beyond the boundary where a line crosses it
    clearance: float  # flight along the line before/after a station that must stay out of zones


def _lone_runs(intervals: list[list[tuple[float, float]]], enter: np.ndarray, leave: np.ndarray,
               g: StripGeometry) -> dict[int, tuple[float, int]]:
    """(x0, n) of the one run of every line with one interval, as `segments_for_line` lays it
    (the same operations, on arrays: most lines have one interval, and the heading search lays
    dozens of passes; measured: 75 lines, 0.6 ms one by one, 0.1 ms so). `enter`, `leave`:
    each line's first and last crossing of the boundary (±inf: none)."""
    lines = [i for i, iv in enumerate(intervals) if len(iv) == 1]
    if not lines:
        return {}
    ab = np.array([intervals[i][0] for i in lines])
    s, e = station_span(ab[:, 0], ab[:, 1], enter[lines], leave[lines], g.along, g.base, g.fwd_per_point, g.beyond)
    n = np.maximum(g.fwd_per_point, np.ceil((e - s) / g.base - _EPS).astype(np.int64) + 1)
    x0 = (s + e) / 2.0 - (n - 1) * g.base / 2.0
    return dict(zip(lines, zip(x0.tolist(), n.tolist())))


def anchored_offsets(vmin: float, vmax: float, first: float, direction: int, g: StripGeometry) -> np.ndarray | None:
    """Line ordinates `first` + direction·j·S, j = 0 … n − 1 (ascending), as few as put every v in
    [vmin, vmax] in `side_per_point` strips: a band's lines continuing a neighbouring band's at
    the spacing (the asked side overlap between them). `first` lies within the k-th strip's
    reach of the band's near edge, so the near edge is covered; lines are added at the far end
    until the k-th from the last reaches the far edge (None if those lines leave a point in fewer
    than k strips: the near edge out of reach, or lines too far apart)."""
    k = g.side_per_point
    reach = g.across / 2.0 + _EPS
    far = vmax - reach - first if direction > 0 else first - vmin - reach  # how far the k-th last line must go
    n = max(k, k + math.ceil(far / g.spacing - 1e-9))
    vs = np.sort(first + direction * g.spacing * np.arange(n))
    probe = np.linspace(vmin, vmax, 257)
    # a probe's strips are those of the lines within reach: a window of lines round where it falls
    lo, hi = np.searchsorted(vs, probe - reach, "left"), np.searchsorted(vs, probe + reach, "right")
    return vs if ((hi - lo) >= k).all() else None


def build_lines(area_f: BaseGeometry, zones_f: BaseGeometry | None, g: StripGeometry,
                vs: np.ndarray | None = None) -> list[LineSegment]:
    """All photo runs of one pass over the area (in the line frame). `vs`: the line ordinates
    (ascending, S apart or closer, every point of `area_f` in k_side strips), when not
    `strip_offsets` of the area's bounds."""
    _, vmin, _, vmax = area_f.bounds
    if vs is None:
        vs = strip_offsets(vmin, vmax, g.across, g.spacing, g.side_per_point)
    intervals = band_intervals(area_f, *line_slabs(vs, g))
    owner, xs = line_crossings(area_f, vs) if g.beyond else (np.zeros(0, np.int64), np.zeros(0))
    enter, leave = np.full(len(vs), np.inf), np.full(len(vs), -np.inf)
    np.minimum.at(enter, owner, xs)
    np.maximum.at(leave, owner, xs)
    lone = _lone_runs(intervals, enter, leave, g)
    bounds = np.searchsorted(owner, np.arange(len(vs) + 1))
    segs: list[LineSegment] = []
    for i, (v, iv) in enumerate(zip(vs.tolist(), intervals)):
        if i in lone:
            x0, n = lone[i]
            segs.append(LineSegment(line=i, part=0, v=v, x0=x0, n=n, base=g.base))
        elif iv:
            segs.extend(segments_for_line(i, v, iv, g.along, g.base, g.fwd_per_point, g.beyond, merge_gap=g.along,
                                          crossings=xs[bounds[i]:bounds[i + 1]]))
    segs = cut_by_zones(segs, zones_f, g.clearance)
    lines_used = sorted({s.line for s in segs})
    index = {old: new for new, old in enumerate(lines_used)}
    return [s if index[s.line] == s.line else LineSegment(index[s.line], s.part, s.v, s.x0, s.n, s.base) for s in segs]


@dataclass(frozen=True)
class LineBounds:
    """What `build_lines` is sure of for some headings, found without clipping a single strip.

    Arrays are per line ordinate of `strip_offsets` (the lines `build_lines` may lay), in the
    line frame, heading after heading (`heading` says whose line each is). Where `exists` is
    False the line may or may not get a run and nothing else is claimed (unless `absent` says
    that it surely has none). Where it is True the line surely keeps at least one station
    after the zone cut, and its first and last stations (by x) lie in [first_lo, first_hi] and
    [last_lo, last_hi], at least `extent` apart. `single` says that the line surely has
    exactly one run.
    """

    heading: np.ndarray  # index of the line's heading in the headings asked for
    v: np.ndarray
    exists: np.ndarray
    absent: np.ndarray  # bool: surely no run (the closed strip does not meet the area)
    extent: np.ndarray
    single: np.ndarray
    first_lo: np.ndarray
    first_hi: np.ndarray
    last_lo: np.ndarray
    last_hi: np.ndarray


@dataclass(frozen=True, eq=False)
class Outline:
    """The area's and the zones' vertices, and what about them does not change with the heading
    (`line_bounds` turns the vertices into each heading's line frame)."""

    xy: np.ndarray  # (N, 2) every vertex of every ring of the area, rings closed, as get_coordinates gives them
    start: np.ndarray  # index in xy of each edge's first vertex (the second is the next one)
    ring_of_edge: np.ndarray
    shells: np.ndarray  # bool per ring: a polygon's exterior (each polygon's rings in a row, exterior first)
    convex: np.ndarray  # bool per polygon: its exterior turns one way only
    shell_vertex: np.ndarray  # bool per vertex: on an exterior (the bounds are the exteriors')
    zone_centre: np.ndarray  # (M, 2) the centre of each zone polygon's bounding box
    zone_radius: np.ndarray  # (M,) the largest distance of its vertices from that centre
    radius: float  # largest distance of a vertex from the origin (no frame coordinate is larger)

    @classmethod
    def of(cls, area: BaseGeometry, zones: BaseGeometry | None) -> Outline:
        polys = shapely.get_parts(area)
        rings, poly_of_ring = shapely.get_rings(polys, return_index=True)
        xy, ring_of = shapely.get_coordinates(rings, return_index=True)
        same = ring_of[1:] == ring_of[:-1]  # consecutive points of one ring make an edge
        start = np.flatnonzero(same)
        shells = np.r_[True, poly_of_ring[1:] != poly_of_ring[:-1]] if len(rings) else np.zeros(0, bool)
        ring_xy = np.split(xy, np.flatnonzero(np.diff(ring_of)) + 1) if len(xy) else []
        convex = np.array([_convex(ring_xy[r]) for r in np.flatnonzero(shells).tolist()], bool)
        centre, zone_radius = np.zeros((0, 2)), np.zeros(0)
        if zones is not None and not zones.is_empty:
            parts = shapely.get_parts(zones)
            b = shapely.bounds(parts)
            centre = (b[:, :2] + b[:, 2:]) / 2.0
            zxy, part = shapely.get_coordinates(parts, return_index=True)
            zone_radius = np.zeros(len(parts))
            np.maximum.at(zone_radius, part, np.hypot(*(zxy - centre[part]).T))
        radius = float(np.max(np.hypot(xy[:, 0], xy[:, 1]))) if len(xy) else 0.0
        return cls(xy, start, ring_of[start], shells, convex, shells[ring_of], centre, zone_radius, radius)


def _ranges(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every (owner, index) with lo[owner] <= index < hi[owner]."""
    counts = np.maximum(hi - lo, 0)
    owner = np.repeat(np.arange(len(lo)), counts)
    return owner, np.arange(int(counts.sum())) + np.repeat(lo - (np.cumsum(counts) - counts), counts)


def _convex(ring_xy: np.ndarray) -> bool:
    """The closed ring turns one way only (collinear points allowed, to a relative 1e-9 of
    the edges' lengths: a pocket that flat is far shallower than a photo's footprint)."""
    d = np.diff(ring_xy, axis=0)
    d = d[np.hypot(d[:, 0], d[:, 1]) > 0]
    if len(d) < 3:
        return False
    nxt = np.roll(d, -1, axis=0)
    cross = d[:, 0] * nxt[:, 1] - d[:, 1] * nxt[:, 0]
    tol = 1e-9 * np.hypot(d[:, 0], d[:, 1]) * np.hypot(nxt[:, 0], nxt[:, 1])
    return bool(np.all(cross >= -tol) or np.all(cross <= tol))


def line_bounds(outline: Outline, frames: list[LineFrame], g: StripGeometry, single_runs: bool = True) -> LineBounds:
    """Sure facts about the runs `build_lines(area_f, zones_f, g)` lays for each frame, from
    the area's edges, where area_f and zones_f are the outline's area and zones in the frame.
    Every frame's lines are bounded at once (one numpy step for all of them: the heading search
    bounds dozens). Without `single_runs` it claims no line has surely one run (the copter's
    bound needs where lines end, not that: measured, 23 headings of the 1,000 ha case with two
    holes, 1.5-2.7 -> 1.4-1.5 ms).

    Why they hold (`build_lines` step by step, h = across/2, B = base, tol covers rounding):
    - the lines are `strip_offsets` of the same bounds, so the same ordinates;
    - a point of the area's boundary strictly inside a line's slab (`line_slabs`: within
      min(h, k_side·S/2) of the line at least, within h at most) is the limit of interior points
      of area ∩ slab, so it lies within the bounds of a piece of positive area, i.e. within
      the line's merged band intervals; the x-range of the area's vertices and edge crossings
      in the slightly narrowed min(h, k_side·S/2) strip is therefore inside the intervals' hull
      [a, b], and that of the closed strip (h) contains it;
    - `station_span` stretches every interval [a', b'] to [s, e] with a' + c_lo ≤ s ≤ a' + c and
      b' − c ≤ e ≤ b' − c_lo, c = L/2 − (k−1)B, c_lo = min(c, −(beyond − 1 + BEYOND_MARGIN)·B)
      (c without `beyond`): the line's own crossings lie in [a', b'], and with `beyond` the
      first station lies `beyond` − 1 + BEYOND_MARGIN bases before the line's first crossing of
      the boundary or earlier (the last as far after its last); merging only joins spans;
      a run of n = max(k, ⌈(e − s)/B − ε⌉ + 1) stations
      centred on its span [s, e] starts at s + εB/2 or before and ends at e − εB/2 or after,
      and at most max(B, (k−1)B)/2 + max(0, c) beyond; and has n ≥ k stations;
    - the zone cut removes only stations within `clearance` of the zones' pieces on the line,
      so only stations within `clearance` of the x-range of the zones' circles (about their
      centres, through their farthest vertices) that the line crosses; when that window lies
      strictly between the line's first and last stations, both stay and the cut changes
      neither end (it may split the run);
    - a strip meets a convex polygon (no hole within the strip's y-range) in one convex piece:
      one interval, one run (when no zone is near the line).
    """
    # the same arithmetic as LineFrame.geom_to_frame, so the same bounds and line ordinates
    fx, fy = to_frames(frames, outline.xy[:, 0], outline.xy[:, 1])
    shell_y = fy[:, outline.shell_vertex]
    per_frame = strip_offsets_many(shell_y.min(axis=1), shell_y.max(axis=1), g.across, g.spacing, g.side_per_point)
    counts = np.array([len(vs) for vs in per_frame])
    offset = np.cumsum(counts) - counts
    n = int(counts.sum())
    hid = np.repeat(np.arange(len(frames)), counts)
    vs = np.concatenate(per_frame)
    v0 = np.array([vs[0] for vs in per_frame])
    # the lines' spacing per frame (strip_offsets lays a narrow range's lines closer)
    sp = np.array([vs[1] - vs[0] if len(vs) > 1 else g.spacing for vs in per_frame])[:, None]
    half = g.across / 2.0
    tol = 1e-7 * (1.0 + outline.radius) + 1e-6 * (g.base + g.across + g.clearance)
    s0 = outline.start
    x0, y0, x1, y1 = fx[:, s0], fy[:, s0], fx[:, s0 + 1], fy[:, s0 + 1]
    ylo, yhi = np.minimum(y0, y1), np.maximum(y0, y1)

    # the x-range of the area's vertices within each narrowed strip (inner hull) and each
    # closed strip widened by tol (outer hull), and of its edges' crossings of the
    # strips' sides. Which lines a vertex or an edge meets comes from the lines' even spacing;
    # rounding may add one whose side is a hair away, which only moves a point a hair off the
    # narrowed strip (still well inside the strip) or adds to the outer hull.
    narrow = min(half, g.side_per_point * g.spacing / 2.0) * (1.0 - 1e-6)  # line_slabs: every line's reaches that far
    widths = (narrow, half + tol)
    xmin, xmax = np.full(len(widths) * n, np.inf), np.full(len(widths) * n, -np.inf)
    n_of = counts[:, None]
    strips, xs = [], []
    for k, w in enumerate(widths):
        for sign in (-1.0, 1.0):  # crossings of the strips' lower and upper sides
            first = np.maximum(np.ceil((ylo - sign * w - v0[:, None]) / sp), 0)
            last = np.minimum(np.floor((yhi - sign * w - v0[:, None]) / sp), n_of - 1)
            sloped = (y1 != y0).ravel()
            owner, line = _ranges(np.where(sloped, first.ravel(), 0).astype(np.int64),
                                  np.where(sloped, last.ravel() + 1, 0).astype(np.int64))
            h = owner // len(s0)
            at = vs[offset[h] + line] + sign * w
            ex0, ey0, ex1, ey1 = (a.ravel()[owner] for a in (x0, y0, x1, y1))
            t = np.clip((at - ey0) / (ey1 - ey0), 0.0, 1.0)
            strips.append(k * n + offset[h] + line)
            xs.append(ex0 + t * (ex1 - ex0))
        # vertices (the outer strip's widened by another tol: a crossing of its side that rounding
        # misses is then near a vertex it takes in)
        wv = w + tol if k else w
        first = np.maximum(np.ceil((y0 - wv - v0[:, None]) / sp), 0)
        last = np.minimum(np.floor((y0 + wv - v0[:, None]) / sp), n_of - 1)
        owner, line = _ranges(first.ravel().astype(np.int64), last.ravel().astype(np.int64) + 1)
        strips.append(k * n + offset[owner // len(s0)] + line)
        xs.append(x0.ravel()[owner])
    strip, x = np.concatenate(strips), np.concatenate(xs)
    np.minimum.at(xmin, strip, x)
    np.maximum.at(xmax, strip, x)
    a_in, b_in = xmin[:n], xmax[:n]
    a_out, b_out = xmin[n:] - tol, xmax[n:] + tol
    met = np.isfinite(a_in) & (b_in - a_in > 2.0 * tol)
    a_in, b_in = a_in + tol, b_in - tol

    k, base = g.fwd_per_point, g.base
    c = g.along / 2.0 - (k - 1) * base  # station_span: the latest start after a (and end before b)
    c_lo = min(c, -(g.beyond - 1 + BEYOND_MARGIN) * base) if g.beyond else c  # the earliest (the line enters at a)
    lo, hi = a_in + c, b_in - c
    if g.beyond:
        # the line's own crossings of the edges that surely cross it (ends more than tol either
        # side): the line enters the area at the first of them or before and leaves at the last
        # or after, and station_span puts `beyond` stations before and after those
        first = np.maximum(np.floor((ylo + tol - v0[:, None]) / sp) + 1, 0)
        last = np.minimum(np.ceil((yhi - tol - v0[:, None]) / sp) - 1, n_of - 1)
        owner, line = _ranges(first.ravel().astype(np.int64), last.ravel().astype(np.int64) + 1)
        at = offset[owner // len(s0)] + line
        ex0, ey0, ex1, ey1 = (a.ravel()[owner] for a in (x0, y0, x1, y1))
        cross = ex0 + (vs[at] - ey0) / (ey1 - ey0) * (ex1 - ex0)
        line_in, line_out = np.full(n, np.inf), np.full(n, -np.inf)
        np.minimum.at(line_in, at, cross)
        np.maximum.at(line_out, at, cross)
        out = (g.beyond - 1 + BEYOND_MARGIN) * base
        lo = np.where(met, np.minimum(lo, line_in + tol - out), lo)
        hi = np.where(met, np.maximum(hi, line_out - tol + out), hi)
    slack = max(base, (k - 1) * base) / 2.0 + max(0.0, c) + tol
    exists = met.copy()
    extent = np.where(met, np.maximum(hi - lo, (k - 1) * base) - tol, 0.0)

    # one run: the strip meets one polygon, convex, none of whose holes reaches into the strip
    single = np.zeros(n, bool)
    if single_runs:
        # every ring has edges, in ring order: each ring's lowest and highest edge end per frame
        first_edge = np.flatnonzero(np.r_[True, np.diff(outline.ring_of_edge) != 0])
        ring_lo = np.minimum.reduceat(ylo, first_edge, axis=1)[hid]  # (lines, rings)
        ring_hi = np.maximum.reduceat(yhi, first_edge, axis=1)[hid]
        reach = (ring_lo <= (vs + half + tol)[:, None]) & (ring_hi >= (vs - half - tol)[:, None])
        polys_met = reach[:, outline.shells]  # one exterior per polygon, in polygon order
        single = (met & (polys_met.sum(axis=1) == 1) & (polys_met & outline.convex).any(axis=1)
                  & ~reach[:, ~outline.shells].any(axis=1))

    if len(outline.zone_radius):
        # each zone lies within its circle about its centre, in every frame
        zx, zy = to_frames(frames, outline.zone_centre[:, 0], outline.zone_centre[:, 1])
        r = outline.zone_radius + tol
        near = np.abs(vs[:, None] - zy[hid]) <= r
        touched = near.any(axis=1)
        w0 = np.where(near, zx[hid] - r, np.inf).min(axis=1, initial=np.inf) - g.clearance
        w1 = np.where(near, zx[hid] + r, -np.inf).max(axis=1, initial=-np.inf) + g.clearance
        kept = ~touched | ((w0 > lo + tol) & (w1 < hi - tol))
        exists &= kept
        single &= ~touched
        extent = np.where(exists, extent, 0.0)
    absent = ~np.isfinite(a_out)
    return LineBounds(hid, vs, exists, absent, extent, single & exists, a_out + c_lo - slack, lo + tol, hi - tol,
                      b_out - c_lo + slack)
