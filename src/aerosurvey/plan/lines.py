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
    `per_point` strips or more (a strip covers ±across/2 around its line)."""
    half = across / 2.0
    need = vmax - vmin - across + 2.0 * (per_point - 1) * spacing
    n = max(per_point, math.ceil(need / spacing - _EPS) + 1, 1)
    probe = np.linspace(vmin, vmax, 257)
    while True:
        mid = (vmin + vmax) / 2.0
        vs = mid + spacing * (np.arange(n) - (n - 1) / 2.0)
        counts = (np.abs(probe[:, None] - vs[None, :]) <= half + _EPS).sum(axis=1)
        if counts.min() >= per_point:
            return vs
        n += 1


def band_intervals(area_f: BaseGeometry, vs: np.ndarray, half_width: float) -> list[list[tuple[float, float]]]:
    """For each line ordinate, the merged x-intervals where its strip (±half_width) meets the area."""
    minx, _, maxx, _ = area_f.bounds
    # clipping by a rectangle is 3x faster than a general intersection (measured: 149 strips of a
    # 1,000 ha area with holes, 7 ms against 21 ms) and gives the same pieces
    inter = np.array([shapely.clip_by_rect(area_f, minx - 1.0, v - half_width, maxx + 1.0, v + half_width) for v in vs.tolist()])
    parts, idx = shapely.get_parts(inter, return_index=True)
    out: list[list[tuple[float, float]]] = [[] for _ in vs]
    if len(parts):
        keep = ~shapely.is_empty(parts) & (shapely.area(parts) > 0)
        b = shapely.bounds(parts[keep])
        for i, (x0, x1) in zip(idx[keep], b[:, [0, 2]]):
            out[i].append((float(x0), float(x1)))
    return [_merge(iv) for iv in out]


def _merge(intervals: list[tuple[float, float]], gap: float = 0.0) -> list[tuple[float, float]]:
    merged: list[tuple[float, float]] = []
    for a, b in sorted(intervals):
        if merged and a <= merged[-1][1] + gap:
            merged[-1] = (merged[-1][0], max(merged[-1][1], b))
        else:
            merged.append((a, b))
    return merged


def station_span(a: float, b: float, along: float, base: float, per_point: int, beyond: int) -> tuple[float, float]:
    """First and last station abscissa needed to photograph [a, b].

    Forward coverage needs the first station at a + L/2 − (k−1)·B or before (k photos
    per point); the boundary rule needs `beyond` stations strictly before a.
    """
    reach = along / 2.0 - (per_point - 1) * base
    start = min(a + reach, a - beyond * base)
    end = max(b - reach, b + beyond * base)
    return start, end


def segments_for_line(line: int, v: float, intervals: list[tuple[float, float]], along: float,
                      base: float, per_point: int, beyond: int, merge_gap: float) -> list[LineSegment]:
    """Photo runs on one line: each interval extended, runs closer than `merge_gap` joined."""
    spans = [station_span(a, b, along, base, per_point, beyond) for a, b in intervals]
    spans = _merge(spans, gap=merge_gap)
    segs = []
    for part, (s, e) in enumerate(spans):
        n = max(per_point, math.ceil((e - s) / base - _EPS) + 1)
        mid = (s + e) / 2.0
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
    ends = np.array([[s.x0 - clearance - 1.0, s.v, s.x1 + clearance + 1.0, s.v] for s in segs])
    # only runs whose box meets the zones' box can meet a zone: the heading search cuts dozens of
    # layouts, and most runs lie far from every zone
    zx0, zy0, zx1, zy1 = zones_f.bounds
    near = np.flatnonzero((ends[:, 1] >= zy0) & (ends[:, 1] <= zy1) & (ends[:, 2] >= zx0) & (ends[:, 0] <= zx1))
    hits: list[BaseGeometry | None] = [None] * len(segs)
    if len(near):
        for i, hit in zip(near.tolist(), shapely.intersection(shapely.linestrings(ends[near].reshape(-1, 2, 2)), zones_f)):
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


def build_lines(area_f: BaseGeometry, zones_f: BaseGeometry | None, g: StripGeometry) -> list[LineSegment]:
    """All photo runs of one pass over the area (in the line frame)."""
    _, vmin, _, vmax = area_f.bounds
    vs = strip_offsets(vmin, vmax, g.across, g.spacing, g.side_per_point)
    intervals = band_intervals(area_f, vs, g.across / 2.0)
    segs: list[LineSegment] = []
    for i, (v, iv) in enumerate(zip(vs, intervals)):
        if iv:
            segs.extend(segments_for_line(i, float(v), iv, g.along, g.base, g.fwd_per_point, g.beyond, merge_gap=g.along))
    segs = cut_by_zones(segs, zones_f, g.clearance)
    lines_used = sorted({s.line for s in segs})
    index = {old: new for new, old in enumerate(lines_used)}
    return [s if index[s.line] == s.line else LineSegment(index[s.line], s.part, s.v, s.x0, s.n, s.base) for s in segs]
