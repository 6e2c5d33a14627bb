"""`Dem.lowest_along` against an independent sampler: the test's own bilinear surface on its own
array (heights at cell centres, straight between the four nearest), sampled densely along each
segment. The documented semantics: the lowest of ceiling − ground along the segment, exactly."""

from __future__ import annotations

import numpy as np
import pyproj
from hypothesis import given, settings
from hypothesis import strategies as st

from aerosurvey.plan.inputs import DemGrid
from aerosurvey.plan.terrain import Dem
from aerosurvey.reproject import planar

CELL = 5.0
WEST, NORTH = 500_000.0, 5_472_000.0
ROWS, COLS = 60, 80


def _grid(heights: np.ndarray) -> DemGrid:
    rows, cols = heights.shape
    return DemGrid.of_array("test.tif", heights, (CELL, 0.0, WEST, 0.0, -CELL, NORTH), pyproj.CRS.from_epsg(32633).to_wkt(),
                            (0, 0), (rows, cols), (WEST, NORTH - rows * CELL, WEST + cols * CELL, NORTH))


def _bilinear(h: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The test's own sampler: cell centres at WEST + (i + 0.5)·CELL, NORTH − (j + 0.5)·CELL."""
    u = (x - WEST) / CELL - 0.5
    v = (NORTH - y) / CELL - 0.5
    i = np.clip(np.floor(u).astype(int), 0, h.shape[1] - 2)
    j = np.clip(np.floor(v).astype(int), 0, h.shape[0] - 2)
    fu, fv = u - i, v - j
    return (h[j, i] * (1 - fu) * (1 - fv) + h[j, i + 1] * fu * (1 - fv)
            + h[j + 1, i] * (1 - fu) * fv + h[j + 1, i + 1] * fu * fv)


def _ridges(draw: st.DrawFn) -> np.ndarray:
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    h = np.full((ROWS, COLS), 300.0) + rng.normal(0.0, 0.5, (ROWS, COLS))
    for _ in range(draw(st.integers(1, 4))):  # narrow ridges: a row, a column or a diagonal of high cells
        kind = draw(st.sampled_from(["row", "col", "diag"]))
        k = draw(st.integers(2, 50))
        top = draw(st.floats(5.0, 80.0))
        if kind == "row":
            h[k, :] += top
        elif kind == "col":
            h[:, k] += top
        else:
            idx = np.arange(min(ROWS, COLS) - k)
            h[idx, idx + k] += top
    return h.astype(np.float32).astype(np.float64)  # as a DEM holds them


@st.composite
def cases(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    h = _ridges(draw)
    n = draw(st.integers(1, 6))
    xs = [draw(st.floats(WEST + 3.0, WEST + COLS * CELL - 3.0)) for _ in range(2 * n)]
    ys = [draw(st.floats(NORTH - ROWS * CELL + 3.0, NORTH - 3.0)) for _ in range(2 * n)]
    a = np.column_stack([xs[:n], ys[:n]])
    b = np.column_stack([xs[n:], ys[n:]])
    ceiling = np.array([[draw(st.floats(300.0, 420.0)), draw(st.floats(300.0, 420.0))] for _ in range(n)])
    return h, a, b, ceiling


@settings(max_examples=60, deadline=None)
@given(cases())
def test_the_lowest_margin_along_segments_is_the_dense_samplers(case) -> None:
    h, a, b, ceiling = case
    dem = Dem(_grid(h), planar("EPSG:32633"))
    margin, frac, ground = dem.lowest_along(a, b, ceiling, "test legs")
    for s in range(len(a)):
        t = np.linspace(0.0, 1.0, 20_001)
        x = a[s, 0] + t * (b[s, 0] - a[s, 0])
        y = a[s, 1] + t * (b[s, 1] - a[s, 1])
        dense = ceiling[s, 0] + t * (ceiling[s, 1] - ceiling[s, 0]) - _bilinear(h, x, y)
        length = float(np.hypot(*(b[s] - a[s])))
        # between two dense samples the margin changes by at most its steepest slope times the step
        slack = 2.0 * (np.abs(np.diff(dense)).max() + 1e-9)
        assert margin[s] <= dense.min() + 1e-6
        assert margin[s] >= dense.min() - slack
        # where it says the lowest is, the test's surface has that margin
        xf, yf = a[s, 0] + frac[s] * (b[s, 0] - a[s, 0]), a[s, 1] + frac[s] * (b[s, 1] - a[s, 1])
        g = float(_bilinear(h, np.array([xf]), np.array([yf]))[0])
        assert abs(ground[s] - g) < 1e-6
        assert abs(ceiling[s, 0] + frac[s] * (ceiling[s, 1] - ceiling[s, 0]) - g - margin[s]) < 1e-6
        assert 0.0 <= frac[s] <= 1.0 and length >= 0.0


def test_a_one_cell_ridge_between_two_samples_a_cell_apart_is_found() -> None:
    """Samples a cell apart either side of a one-cell ridge read half its height; the exact minimum reads all of it."""
    h = np.full((ROWS, COLS), 300.0)
    h[:, 40] = 350.0  # column 40: x = WEST + 202.5
    dem = Dem(_grid(h), planar("EPSG:32633"))
    a = np.array([[WEST + 100.0, NORTH - 150.0]])
    b = np.array([[WEST + 300.0, NORTH - 150.0]])
    margin, frac, ground = dem.lowest_along(a, b, np.array([[340.0, 340.0]]), "a leg")
    assert ground[0] == 350.0 and margin[0] == -10.0
    assert abs(a[0, 0] + frac[0] * 200.0 - (WEST + 202.5)) < 1e-9
    # a sampler a cell apart straddling the ridge misses it: the leg looks clear
    xs = np.arange(WEST + 100.0, WEST + 300.0 + 1e-9, CELL)
    assert (340.0 - _bilinear(h, xs, np.full(len(xs), NORTH - 150.0))).min() > 0


def test_a_large_window_is_held_compressed_and_unpacked_a_tile_at_a_time() -> None:
    """A 6,000 × 6,000 window (144 MB as float32) of a plane z = 300 + x/100 − y/50 made a tile at a time: bilinear
    heights on a plane are the plane, across tile edges too; the window is held in far fewer bytes, and sampling and
    the clearance along legs across all of it use far less memory than the window."""
    import tracemalloc

    from aerosurvey.plan.inputs import TILE
    from aerosurvey.plan.terrain import CACHE_TILES

    n = 6_000
    made: list[tuple[int, int]] = []

    def plane(row: int, col: int, rows: int, cols: int) -> np.ndarray:
        assert rows <= TILE and cols <= TILE
        made.append((row, col))
        x = WEST + (np.arange(col, col + cols) + 0.5) * CELL
        y = NORTH - (np.arange(row, row + rows) + 0.5) * CELL
        return (300.0 + x[None, :] / 100.0 - (y[:, None] - NORTH) / 50.0).astype(np.float32)

    grid = DemGrid.read_tiles("big.tif", (n, n), plane, (CELL, 0.0, WEST, 0.0, -CELL, NORTH),
                              pyproj.CRS.from_epsg(32633).to_wkt(), (0, 0), (n, n),
                              (WEST, NORTH - n * CELL, WEST + n * CELL, NORTH))
    assert len(made) == len(set(made)) == 12 * 12
    assert sum(len(t) for t in grid.tiles.values()) < 0.5 * n * n * 4
    dem = Dem(grid, planar("EPSG:32633"))
    rng = np.random.default_rng(3)
    x = WEST + rng.uniform(10.0, n * CELL - 10.0, 5000)
    y = NORTH - rng.uniform(10.0, n * CELL - 10.0, 5000)
    tracemalloc.start()
    z = dem.sample(x, y, "points")
    # legs across the whole window, under a ceiling 10 m over the plane at their ends
    a = np.column_stack([np.full(40, WEST + 7.0), NORTH - np.linspace(7.0, n * CELL - 7.0, 40)])
    b = np.column_stack([np.full(40, WEST + n * CELL - 7.0), NORTH - np.linspace(n * CELL - 7.0, 7.0, 40)])
    top = np.column_stack([300.0 + a[:, 0] / 100.0 - (a[:, 1] - NORTH) / 50.0,
                           300.0 + b[:, 0] / 100.0 - (b[:, 1] - NORTH) / 50.0]) + 10.0
    margin, _, _ = dem.lowest_along(a, b, top, "legs")
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    # float32 cells: the plane to a few centimetres
    assert np.abs(z - (300.0 + x / 100.0 - (y - NORTH) / 50.0)).max() < 0.05
    assert np.abs(margin - 10.0).max() < 0.05
    assert len(dem._tiles) <= CACHE_TILES
    assert peak < 32e6, peak  # the window is 144 MB
