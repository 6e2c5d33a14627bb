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
    """The test's own sampler: cell centres at WEST + (i + 0.5)·CELL, NORTH − (j + 0.5)·CELL; in the outer half cell
    (beyond the outermost centres) the outer row's or column's height, as a raster holds its edge, not extrapolated."""
    u = np.clip((x - WEST) / CELL - 0.5, 0.0, h.shape[1] - 1)
    v = np.clip((NORTH - y) / CELL - 0.5, 0.0, h.shape[0] - 1)
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
    # anywhere on the DEM, the outer half cell (beyond the outermost centres, 2.5 m) included
    xs = [draw(st.floats(WEST + 0.01, WEST + COLS * CELL - 0.01)) for _ in range(2 * n)]
    ys = [draw(st.floats(NORTH - ROWS * CELL + 0.01, NORTH - 0.01)) for _ in range(2 * n)]
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


def test_in_the_outer_half_cell_the_edge_height_is_held() -> None:
    """Beyond the outermost cell centres the ground is the edge cell's (a raster's edge, not a slope carried on): a leg
    starting a metre from the corner over a 50 m corner spike reads the spike's height there, not more."""
    h = np.full((ROWS, COLS), 300.0)
    h[0, 0] = 350.0
    dem = Dem(_grid(h), planar("EPSG:32633"))
    margin, frac, ground = dem.lowest_along(np.array([[WEST + 1.0, NORTH - 1.0]]), np.array([[WEST + 100.0, NORTH - 1.0]]),
                                            np.array([[340.0, 340.0]]), "a leg")
    assert frac[0] <= 1.5 / 99.0 and ground[0] == 350.0 and margin[0] == -10.0


def test_a_leg_from_the_outer_half_cell_over_a_ridge_reads_the_ridge() -> None:
    """A leg starting 0.05 m inside the DEM's west edge (half a cell beyond the outermost centres) and crossing a 300 m
    ridge two columns in: its lowest margin is over the ridge. (The chunk's end was once moved to the outermost centre,
    which slid the ground under the ceiling by up to half a cell: 350.0 read for 339.53.)"""
    h = np.zeros((4, 6))
    h[:, 2] = 300.0  # centres at x = WEST + 12.5
    dem = Dem(_grid(h), planar("EPSG:32633"))
    a, b = np.array([[WEST + 0.05, NORTH - 7.5]]), np.array([[WEST + 22.5, NORTH - 7.5]])
    margin, frac, ground = dem.lowest_along(a, b, np.array([[1000.0, 350.0]]), "a leg")
    at = (12.5 - 0.05) / 22.45  # the ridge's fraction of the leg
    assert ground[0] == 300.0 and abs(frac[0] - at) < 1e-9
    assert abs(margin[0] - (1000.0 - 650.0 * at - 300.0)) < 1e-6


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
    assert sum(len(group) for t in grid.tiles.values() for group in t) < 0.5 * n * n * 4
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


def _dense_margin(h: np.ndarray, a: np.ndarray, b: np.ndarray, ceiling: np.ndarray) -> tuple[float, float]:
    """The lowest margin under the ceiling along a segment by the test's own sampler (20,001 points), and how far the
    true lowest may lie under it (twice the largest change between two samples)."""
    t = np.linspace(0.0, 1.0, 20_001)
    dense = ceiling[0] + t * (ceiling[1] - ceiling[0]) - _bilinear(h, a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]))
    return float(dense.min()), 2.0 * float(np.abs(np.diff(dense)).max() + 1e-9)


@st.composite
def hills_with_spikes(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Gentle hills over a 2 km window (400 × 400 cells: 7 × 7 blocks; the blocks' ranges then bound the ground within
    a metre or two), one to three cells or short ridges raised anywhere, and long segments (up to ~2.8 km: many chunks,
    many blocks) under ceilings from under the hills to far above, each a ground leg (no minimum) or not; some run
    over a spike."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    n_cells = 400
    yy, xx = np.mgrid[0:n_cells, 0:n_cells]
    h = 300.0 + 4.0 * np.sin(xx / 150.0 + rng.uniform(0, 6)) * np.cos(yy / 170.0) + rng.normal(0.0, 0.05, xx.shape)
    spikes = []
    for _ in range(draw(st.integers(1, 3))):
        r, c, length = draw(st.integers(0, n_cells - 1)), draw(st.integers(0, n_cells - 1)), draw(st.integers(1, 4))
        h[r, c:c + length] += draw(st.floats(5.0, 90.0))
        spikes.append((WEST + (c + 0.5) * CELL, NORTH - (r + 0.5) * CELL))
    n = draw(st.integers(2, 10))
    side = n_cells * CELL
    pts = [[draw(st.floats(WEST + 3.0, WEST + side - 3.0)), draw(st.floats(NORTH - side + 3.0, NORTH - 3.0))]
           for _ in range(2 * n)]
    for k, (x, y) in enumerate(spikes[:draw(st.integers(0, min(len(spikes), n)))]):  # segments over spikes (n at most)
        pts[k], pts[n + k] = [max(WEST + 3.0, x - 700.0), y + k], [min(WEST + side - 3.0, x + 700.0), y - k]
    a, b = np.array(pts[:n]), np.array(pts[n:])
    ceiling = np.array([[draw(st.floats(300.0, 400.0)), draw(st.floats(300.0, 400.0))] for _ in range(n)])
    ground_leg = np.array([draw(st.booleans()) for _ in range(n)])
    return h.astype(np.float32).astype(np.float64), a, b, ceiling, ground_leg


@settings(max_examples=40, deadline=None)
@given(hills_with_spikes())
def test_the_pruned_search_finds_every_leg_under_its_minimum_and_the_flights_lowest(case) -> None:
    """The chunks and legs whose cells are not read (their bounds from the blocks' height ranges clear another's) hide
    nothing: along every segment the lowest margin is the dense sampler's, its bounds hold it, every segment under its
    minimum is read, and so is the flight's lowest (off the ground legs when it has another)."""
    from aerosurvey.mission.clearance import GROUND_LEGS, _may_matter

    h, a, b, ceiling, ground_leg = case
    dem = Dem(DemGrid.of_array("test.tif", h, (CELL, 0.0, WEST, 0.0, -CELL, NORTH), pyproj.CRS.from_epsg(32633).to_wkt(),
                                (0, 0), h.shape, (WEST, NORTH - h.shape[0] * CELL, WEST + h.shape[1] * CELL, NORTH)),
              planar("EPSG:32633"))
    m = 20.0
    dense = [_dense_margin(h, a[s], b[s], ceiling[s]) for s in range(len(a))]
    margin, _, _ = dem.lowest_along(a, b, ceiling, "test legs")
    lo, hi = dem.margin_bounds(a, b, ceiling, "test legs")
    for s, (d, slack) in enumerate(dense):
        assert d - slack <= margin[s] <= d + 1e-6
        assert lo[s] <= margin[s] + 1e-6 and hi[s] >= margin[s] - 1e-6
    whats = [GROUND_LEGS[0] if g else "line" for g in ground_leg]
    read = set(_may_matter((lo, hi), whats, [], m).tolist())
    assert {s for s, (d, slack) in enumerate(dense) if d < -slack} <= read
    counted = [s for s in range(len(a)) if not ground_leg[s]] or list(range(len(a)))
    clearance = {s: dense[s][0] + (0.0 if ground_leg[s] else m) for s in counted}
    lowest = min(clearance.values())
    assert min(clearance[s] for s in read if s in clearance) <= lowest + max(slack for _, slack in dense)
