"""Terrain from a DEM window (`plan.inputs.DemGrid`): sampling in the planning CRS, the lowest
clearance along straight segments, area statistics, and the waypoint thinning used by the
`follow` height mode.

The loader (`aerosurvey.inputs`) reads the window round where the plan flies; nothing here opens a
file. The window is held in compressed tiles (`DemGrid`); the last CACHE_TILES tiles unpacked are
kept, and every reader of many points groups them by tile, so each tile is unpacked once per call.
The lowest clearance along segments bounds the ground by the window's block height ranges
(`DemGrid.blocks`) first, and reads cells only where those bounds cannot decide.
Heights are metres above the DEM's vertical datum, float32 as most DEMs hold them.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
import pyproj
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.area import Planar, transformer
from aerosurvey.errors import InputError
from aerosurvey.plan.inputs import TILE, DemGrid

#: a segment is transformed into the DEM's cells exactly at points this far apart (planning metres) and taken
#: straight in between (the curvature of a map projection over 200 m is far under a millimetre)
CHUNK_M = 200.0
#: pieces of segments (between rows and columns of cell centres) worked on at once (about 0.5 kB each)
BATCH = 10_000
#: the last CACHE_TILES tiles unpacked are kept (1 MB float32 each)
CACHE_TILES = 4
#: the blocks' height ranges bound the bilinear ground (float64 sums of float32 cells) to within rounding: widened by this
BOUND_SLACK_M = 1e-6


@dataclass(frozen=True)
class _Chunks:
    """Segments cut into chunks straight in the DEM's cells (`Dem._chunks`): chunk k is the fraction f0[k]..f1[k] of
    segment seg[k] (in order; `first`: each segment's first chunk), from cell (u0, v0) to (u1, v1), starting at planning
    (x, y)."""

    seg: np.ndarray
    first: np.ndarray
    f0: np.ndarray
    f1: np.ndarray
    u0: np.ndarray
    v0: np.ndarray
    u1: np.ndarray
    v1: np.ndarray
    x: np.ndarray
    y: np.ndarray


class Dem:
    """A DEM window for sampling in the planning CRS."""

    def __init__(self, grid: DemGrid, planar: Planar):
        from affine import Affine  # with rasterio, only when there is a DEM: most plans have none

        self.grid = grid
        self.name = grid.name
        self.crs = pyproj.CRS.from_wkt(grid.crs_wkt)
        self.to_dem = transformer(planar.crs.srs, self.crs.srs)
        self.window = Affine(*grid.transform)
        c0, r0 = grid.offset
        self.full = self.window * Affine.translation(-c0, -r0)
        self._tiles: OrderedDict[tuple[int, int], np.ndarray] = OrderedDict()

    def _tile(self, tj: int, ti: int) -> np.ndarray:
        """Tile (row tj, column ti) of the window, from the cache or unpacked (the least recently used one dropped)."""
        tile = self._tiles.get((tj, ti))
        if tile is None:
            tile = self.grid.tile(tj, ti)
            self._tiles[(tj, ti)] = tile
            if len(self._tiles) > CACHE_TILES:
                self._tiles.popitem(last=False)
        else:
            self._tiles.move_to_end((tj, ti))
        return tile

    def _values(self, j: np.ndarray, i: np.ndarray) -> np.ndarray:
        """The heights of window cells (rows j, columns i), float64, each tile read once."""
        out = np.empty(len(j))
        across = -(-self.grid.shape[1] // TILE)
        key = (j // TILE) * across + i // TILE
        order = np.argsort(key, kind="stable")
        keys = key[order]
        starts = np.flatnonzero(np.r_[True, keys[1:] != keys[:-1]])
        for s, e in zip(starts.tolist(), np.r_[starts[1:], len(keys)].tolist()):
            tj, ti = divmod(int(keys[s]), across)
            sel = order[s:e]
            out[sel] = self._tile(tj, ti)[j[sel] - tj * TILE, i[sel] - ti * TILE]
        return out

    def _cells(self, x: np.ndarray, y: np.ndarray, what: str, clip: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Planning-CRS points as (column, row) in the window read, continuous, 0 at the first cell's
        centre; an error names points off the DEM or beyond the window. A point in the DEM's outer half
        cell (beyond its outermost centres) is moved onto them, where the ground is the same, unless not
        `clip` (the ends of a straight piece of a leg: moving one would bend the piece)."""
        x = np.atleast_1d(np.asarray(x, float))
        y = np.atleast_1d(np.asarray(y, float))
        dx, dy = self.to_dem.transform(x, y)
        inv = ~self.full
        dx, dy = np.asarray(dx), np.asarray(dy)
        cols = inv.a * dx + inv.b * dy + inv.c - 0.5
        rows = inv.d * dx + inv.e * dy + inv.f - 0.5
        n_rows, n_cols = self.grid.full_shape
        outside = (cols < -0.5) | (rows < -0.5) | (cols > n_cols - 0.5) | (rows > n_rows - 0.5)
        if outside.any():
            i = int(np.flatnonzero(outside)[0])
            raise InputError(
                f"terrain.dem {self.name!r} does not cover the {what}: {int(outside.sum())} point(s) off the DEM, "
                f"first at planning x {x[i]:.1f}, y {y[i]:.1f}"
            )
        n_win_rows, n_win_cols = self.grid.shape
        c0, r0 = self.grid.offset
        cc, rr = np.clip(cols, 0, n_cols - 1) - c0, np.clip(rows, 0, n_rows - 1) - r0
        bad = (cc < 0) | (rr < 0) | (cc > n_win_cols - 1) | (rr > n_win_rows - 1)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(
                f"terrain.dem {self.name!r}: the {what} reach beyond the part of the DEM read around the area "
                f"({int(bad.sum())} point(s), first at planning x {x[i]:.1f}, y {y[i]:.1f})"
            )
        return (cc, rr) if clip else (cols - c0, rows - r0)

    def _corners(self, i0: np.ndarray, j0: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The heights at the four cell centres round (i0, j0)..(i0 + 1, j0 + 1), clipped to the window."""
        rows, cols = self.grid.shape
        i0 = np.clip(i0, 0, cols - 1)
        j0 = np.clip(j0, 0, rows - 1)
        i1 = np.minimum(i0 + 1, cols - 1)
        j1 = np.minimum(j0 + 1, rows - 1)
        z = self._values(np.concatenate([j0, j0, j1, j1]), np.concatenate([i0, i1, i0, i1])).reshape(4, -1)
        return z[0], z[1], z[2], z[3]

    def _nodata(self, z: np.ndarray, x: np.ndarray, y: np.ndarray, what: str) -> None:
        bad = ~np.isfinite(z)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(
                f"terrain.dem {self.name!r} has nodata under the {what}: {int(bad.sum())} point(s), "
                f"first at planning x {x[i]:.1f}, y {y[i]:.1f}"
            )

    def sample(self, x: np.ndarray, y: np.ndarray, what: str) -> np.ndarray:
        """Bilinear heights at planning-CRS points (between the four nearest cell centres); an error
        names points off the DEM or on nodata."""
        x = np.atleast_1d(np.asarray(x, float))
        y = np.atleast_1d(np.asarray(y, float))
        cc, rr = self._cells(x, y, what)
        i0 = np.floor(cc).astype(int)
        j0 = np.floor(rr).astype(int)
        z00, z01, z10, z11 = self._corners(i0, j0)
        fx, fy = cc - np.clip(i0, 0, None), rr - np.clip(j0, 0, None)
        z: np.ndarray = z00 * (1 - fx) * (1 - fy) + z01 * fx * (1 - fy) + z10 * (1 - fx) * fy + z11 * fx * fy
        self._nodata(z, x, y, what)
        return z

    def _chunks(self, a: np.ndarray, b: np.ndarray, what: str) -> _Chunks:
        """Segments from `a` to `b` ((n, 2) planning CRS) cut into chunks of at most CHUNK_M, their ends in the cells."""
        n = np.maximum(1, np.ceil(np.hypot(*(b - a).T) / CHUNK_M)).astype(np.int64)
        first = np.cumsum(n) - n
        seg = np.repeat(np.arange(len(a)), n)
        f0 = (np.arange(int(n.sum())) - np.repeat(first, n)) / n[seg]
        f1 = f0 + 1.0 / n[seg]
        ends = np.concatenate([f0, f1])
        sx = np.concatenate([seg, seg])
        px, py = a[sx, 0] + ends * (b - a)[sx, 0], a[sx, 1] + ends * (b - a)[sx, 1]
        cc, rr = self._cells(px, py, what, clip=False)
        m = len(f0)
        return _Chunks(seg, first, f0, f1, cc[:m], rr[:m], cc[m:], rr[m:], px[:m], py[:m])

    def _chunk_bounds(self, ch: _Chunks, ceiling: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of each chunk's lowest margin under `ceiling`, from the blocks' height ranges (no tile unpacked): the
        lower ceiling of its two ends less the highest height of the blocks its ground is read from (the cells round it),
        and that ceiling less their lowest height (a bound of the margin at that end)."""
        k0, k1 = ceiling[ch.seg, 0], ceiling[ch.seg, 1]
        top = np.minimum(k0 + ch.f0 * (k1 - k0), k0 + ch.f1 * (k1 - k0))
        cells = [np.floor(np.minimum(p0, p1)).astype(np.int64) for p0, p1 in ((ch.v0, ch.v1), (ch.u0, ch.u1))]
        cells += [np.floor(np.maximum(p0, p1)).astype(np.int64) + 1 for p0, p1 in ((ch.v0, ch.v1), (ch.u0, ch.u1))]
        lo, hi = self.grid.block_range(cells[0], cells[2], cells[1], cells[3])
        return top - hi - BOUND_SLACK_M, top - lo + BOUND_SLACK_M

    def margin_bounds(self, a: np.ndarray, b: np.ndarray, ceiling: np.ndarray,
                      what: str) -> tuple[np.ndarray, np.ndarray]:
        """A lower and an upper bound of each segment's lowest margin as `lowest_along` finds it (same arguments), from
        the blocks' height ranges (`DemGrid.blocks`): no tile unpacked."""
        a, b, ceiling = (np.asarray(v, float).reshape(-1, 2) for v in (a, b, ceiling))
        ch = self._chunks(a, b, what)
        lo, hi = self._chunk_bounds(ch, ceiling)
        return np.minimum.reduceat(lo, ch.first), np.minimum.reduceat(hi, ch.first)

    def lowest_along(self, a: np.ndarray, b: np.ndarray, ceiling: np.ndarray,
                     what: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For straight segments from `a` to `b` ((n, 2) planning CRS) under a ceiling running straight
        from ceiling[:, 0] at `a` to ceiling[:, 1] at `b` (heights in the DEM's datum): along each, the
        lowest of ceiling − ground, the fraction of the segment where it is, and the ground there.

        Exact for the surface `sample` reads: between two rows and two columns of cell centres the
        ground is bilinear, so along a straight line it is a quadratic; the lowest margin lies where
        the segment crosses a row or column of cell centres, at an end, or where the quadratic's slope
        equals the ceiling's. The segment is taken straight in the DEM's cells between points
        transformed exactly every CHUNK_M planning metres. A chunk whose margin is surely above another
        chunk's of its segment (`_chunk_bounds`) cannot hold the lowest: its cells are not read."""
        a, b, ceiling = (np.asarray(v, float).reshape(-1, 2) for v in (a, b, ceiling))
        ch = self._chunks(a, b, what)
        lo, hi = self._chunk_bounds(ch, ceiling)
        read = np.flatnonzero(lo <= np.minimum.reduceat(hi, ch.first)[ch.seg])
        m = len(ch.seg)
        margin = np.full(m, np.inf)
        where = np.zeros(m)
        ground = np.zeros(m)
        # chunks in batches of about BATCH pieces, tile by tile: memory stays bounded whatever the legs' length, and
        # each batch reads few tiles
        across = -(-self.grid.shape[1] // TILE)
        u0, v0, u1, v1 = ch.u0[read], ch.v0[read], ch.u1[read], ch.v1[read]
        tiles = np.floor(np.clip(v0, 0, None) / TILE) * across + np.floor(np.clip(u0, 0, None) / TILE)
        by_tile = np.argsort(tiles, kind="stable")
        pieces = (np.abs(u1 - u0) + np.abs(v1 - v0) + 2)[by_tile]
        batch = np.searchsorted(np.cumsum(pieces), np.arange(1, 2 + int(pieces.sum()) // BATCH) * BATCH)
        for lo_at, hi_at in zip(np.r_[0, batch], np.r_[batch, len(read)]):
            if hi_at > lo_at:
                sl = read[by_tile[int(lo_at):int(hi_at)]]
                margin[sl], where[sl], ground[sl] = self._lowest_on_chunks(
                    ch.u0[sl], ch.v0[sl], ch.u1[sl], ch.v1[sl], ceiling[ch.seg[sl]], ch.f0[sl], ch.f1[sl], ch.x[sl],
                    ch.y[sl], what)
        # the lowest chunk of each segment (each has one read: the chunk of its lowest upper bound)
        order = np.lexsort((margin, ch.seg))
        first = order[ch.first]
        return margin[first], where[first], ground[first]

    def _lowest_on_chunks(self, u0: np.ndarray, v0: np.ndarray, u1: np.ndarray, v1: np.ndarray, ceiling: np.ndarray,
                          f0: np.ndarray, f1: np.ndarray, px: np.ndarray, py: np.ndarray,
                          what: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """`lowest_along` on straight chunks in cell space (fractions f0..f1 of their segments, the
        segment's ceiling at its ends): the lowest margin of each chunk, its fraction, the ground there."""
        m = len(u0)
        ts = [np.zeros(m), np.ones(m)]
        ids = [np.arange(m), np.arange(m)]
        for p0, p1 in ((u0, u1), (v0, v1)):  # where the chunk crosses a column (row) of cell centres
            first = np.floor(np.minimum(p0, p1)) + 1
            count = np.maximum(0, np.ceil(np.maximum(p0, p1)) - first).astype(np.int64)
            c = np.repeat(np.arange(m), count)
            k = first[c] + np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
            ts.append((k - p0[c]) / (p1 - p0)[c])
            ids.append(c)
        t = np.concatenate(ts)
        chunk = np.concatenate(ids)
        order = np.lexsort((t, chunk))
        t, chunk = t[order], chunk[order]
        pair = np.flatnonzero(chunk[:-1] == chunk[1:])
        c, ta, tb = chunk[pair], t[pair], t[pair + 1]
        du, dv = (u1 - u0)[c], (v1 - v0)[c]
        tm = 0.5 * (ta + tb)
        rows, cols = self.grid.shape

        def at(tt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            """The piece's place in the cells at tt, in the DEM's outer half cell moved onto its outermost centres (its
            ground there: pieces end at every row and column of centres, so a piece there lies wholly beyond them)."""
            return np.clip(u0[c] + tt * du, 0, cols - 1), np.clip(v0[c] + tt * dv, 0, rows - 1)

        um, vm = at(tm)
        i0, j0 = np.floor(um).astype(np.int64), np.floor(vm).astype(np.int64)
        z00, z01, z10, z11 = self._corners(i0, j0)

        def ground_at(tt: np.ndarray) -> np.ndarray:
            u, v = at(tt)
            fx, fy = u - i0, v - j0
            g: np.ndarray = z00 * (1 - fx) * (1 - fy) + z01 * fx * (1 - fy) + z10 * (1 - fx) * fy + z11 * fx * fy
            return g

        ga, gm, gb = ground_at(ta), ground_at(tm), ground_at(tb)
        self._nodata(gm, px[c], py[c], what)
        # on s in [0, 1] from ta to tb: ground ga + q1 s + q2 s²; ceiling ka + dk s
        q2 = 2.0 * (ga + gb - 2.0 * gm)
        q1 = gb - ga - q2
        fa, fb = f0[c] + ta * (f1 - f0)[c], f0[c] + tb * (f1 - f0)[c]
        ka = ceiling[c, 0] + fa * (ceiling[c, 1] - ceiling[c, 0])
        dk = (fb - fa) * (ceiling[c, 1] - ceiling[c, 0])
        with np.errstate(divide="ignore", invalid="ignore"):
            s_in = np.where(q2 < 0, np.clip((dk - q1) / (2.0 * q2), 0.0, 1.0), 0.0)
        cand_s = np.stack([np.zeros(len(c)), np.ones(len(c)), s_in])
        cand_g = ga + q1 * cand_s + q2 * cand_s * cand_s
        cand_m = ka + dk * cand_s - cand_g
        best = np.argmin(cand_m, axis=0)
        col = np.arange(len(c))
        margin, s, g = cand_m[best, col], cand_s[best, col], cand_g[best, col]
        frac = fa + s * (fb - fa)
        # the lowest piece of each chunk
        order = np.lexsort((margin, c))
        lowest = order[np.searchsorted(c[order], np.arange(m))]
        return margin[lowest], frac[lowest], g[lowest]

    def range_over(self, geom_plan: BaseGeometry, what: str) -> tuple[float, float]:
        """Lowest and highest DEM cell under a polygon (planning CRS); nodata there is an error."""
        import rasterio.features  # (~0.3 s with GDAL and attrs) only when there is a DEM
        import rasterio.windows

        t = self.to_dem
        g = shapely.transform(geom_plan, lambda xy: np.column_stack(t.transform(xy[:, 0], xy[:, 1])))
        left, b, r, tp = g.bounds
        dl, db, dr, dt = self.grid.full_bounds
        if left < dl or r > dr or b < db or tp > dt:
            raise InputError(
                f"terrain.dem {self.name!r} does not cover the {what}: the {what} spans "
                f"x {left:.1f}..{r:.1f}, y {b:.1f}..{tp:.1f} in the DEM's CRS, the DEM "
                f"x {dl:.1f}..{dr:.1f}, y {db:.1f}..{dt:.1f}"
            )
        n_rows, n_cols = self.grid.full_shape
        win = rasterio.windows.from_bounds(left, b, r, tp, transform=self.full).round_offsets().round_lengths()
        win = rasterio.windows.Window(win.col_off, win.row_off, win.width + 1, win.height + 1).intersection(
            rasterio.windows.Window(0, 0, n_cols, n_rows))
        c0, r0 = self.grid.offset
        rs, cs = int(win.row_off) - r0, int(win.col_off) - c0
        rows, cols = int(win.height), int(win.width)
        if rs < 0 or cs < 0 or rs + rows > self.grid.shape[0] or cs + cols > self.grid.shape[1]:
            raise InputError(f"terrain.dem {self.name!r}: the {what} reaches beyond the part of the DEM read around it")
        lo, hi, cells, nodata = math.inf, -math.inf, 0, 0
        for tj in range(rs // TILE, (rs + rows - 1) // TILE + 1):
            for ti in range(cs // TILE, (cs + cols - 1) // TILE + 1):
                # the part of this tile in the polygon's bounds, and its cells the polygon touches
                j0, j1 = max(rs, tj * TILE), min(rs + rows, (tj + 1) * TILE)
                i0, i1 = max(cs, ti * TILE), min(cs + cols, (ti + 1) * TILE)
                part = self._tile(tj, ti)[j0 - tj * TILE: j1 - tj * TILE, i0 - ti * TILE: i1 - ti * TILE]
                inside = rasterio.features.geometry_mask(
                    [g], out_shape=part.shape, invert=True, all_touched=True,
                    transform=rasterio.windows.transform(rasterio.windows.Window(i0 + c0, j0 + r0, i1 - i0, j1 - j0), self.full))
                vals = part[inside]
                finite = np.isfinite(vals)
                nodata += int((~finite).sum())
                cells += int(finite.sum())
                if finite.any():
                    lo, hi = min(lo, float(vals[finite].min())), max(hi, float(vals[finite].max()))
        if nodata:
            raise InputError(f"terrain.dem {self.name!r} has {nodata} nodata cell(s) under the {what}")
        if cells == 0:
            raise InputError(f"terrain.dem {self.name!r}: no DEM cell under the {what}")
        return lo, hi


def thin_profile(s: np.ndarray, alt: np.ndarray, tolerance: float) -> np.ndarray:
    """Indices of the profile points to keep as waypoints so that straight climbs and
    descents between them stay within `tolerance` of every wanted altitude.

    Greedy: from each kept point, go as far as the straight line still fits.
    """
    n = len(s)
    if n <= 2:
        return np.arange(n)
    keep = [0]
    i = 0
    while i < n - 1:
        j = i + 1
        while j + 1 < n:
            cand = j + 1
            seg = slice(i, cand + 1)
            frac = (s[seg] - s[i]) / (s[cand] - s[i])
            line = alt[i] + frac * (alt[cand] - alt[i])
            if np.max(np.abs(line - alt[seg])) > tolerance:
                break
            j = cand
        keep.append(j)
        i = j
    return np.asarray(keep)
