"""The grid's lower bounds (plan/bounds.py): the minimum width against a sweep of directions,
the strip bound against the lines laid at every heading of a convex area."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from scipy.spatial import ConvexHull

from aerosurvey.plan.bounds import grid_bounds, minimum_width, narrowest
from aerosurvey.plan.frame import LineFrame
from aerosurvey.plan.lines import strip_offsets


def _convex(seed: int, size: float) -> shapely.Polygon:
    rng = np.random.default_rng(seed)
    return shapely.convex_hull(shapely.MultiPoint(rng.uniform(-size, size, (10, 2)) * [1.0, rng.uniform(0.1, 1.0)]))


def _width_at(poly: shapely.Polygon, deg: float) -> float:
    xy = np.asarray(poly.exterior.coords)
    t = math.radians(deg)
    p = xy @ np.array([math.cos(t), math.sin(t)])
    return float(p.max() - p.min())


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), size=st.floats(50, 2000))
def test_minimum_width_is_the_narrowest_of_all_directions(seed, size):
    poly = _convex(seed, size)
    sweep = min(_width_at(poly, d) for d in np.arange(0.0, 180.0, 0.05))
    w = minimum_width(poly)
    assert w <= sweep + 1e-9 * size
    # a 0.05° sweep misses the narrowest direction by at most that much: cos-like error, tiny
    assert w >= sweep - size * 2 * math.radians(0.05)


def test_minimum_width_of_a_rectangle_is_its_short_side():
    rect = shapely.affinity.rotate(shapely.box(0, 0, 300, 120), 33.0)
    assert math.isclose(minimum_width(rect), 120.0, rel_tol=1e-9)
    assert minimum_width(shapely.LineString([(0, 0), (5, 5)])) == 0.0


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10_000), size=st.floats(50, 2000))
def test_the_narrowest_heading_measures_the_minimum_width(seed, size):
    """Across lines at the narrowest heading (compass degrees) the area is its minimum width wide."""
    poly = _convex(seed, size)
    w, h = narrowest(poly)
    _, vmin, _, vmax = LineFrame(h).geom_to_frame(poly).bounds
    assert math.isclose(vmax - vmin, w, rel_tol=1e-9, abs_tol=1e-9 * size)
    assert math.isclose(w, minimum_width(poly), rel_tol=1e-12)


def _widths_by_brute_force(points: np.ndarray) -> np.ndarray:
    """The width across each edge of the points' convex hull (Qhull's, through scipy): every hull vertex's distance from
    every edge's line, the largest."""
    xy = points[ConvexHull(points).vertices]
    d = np.roll(xy, -1, axis=0) - xy
    normal = np.column_stack([-d[:, 1], d[:, 0]]) / np.hypot(d[:, 0], d[:, 1])[:, None]
    proj = xy @ normal.T
    return proj.max(axis=0) - proj.min(axis=0)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(3, 1500), size=st.floats(1.0, 5000.0), flat=st.floats(0.001, 1.0),
       noise=st.sampled_from([0.0, 1e-3, 0.05]), turn=st.floats(0, 360), repeat=st.booleans())
def test_the_minimum_width_of_a_many_sided_hull_is_the_narrowest_across_its_edges(seed, n, size, flat, noise, turn,
                                                                                    repeat):
    """Round, flat and jagged hulls of up to 1,500 vertices (points on an ellipse, some collinear or repeated): the
    width is the least over the hull's edges of the farthest vertex from each, the hull Qhull's (GEOS's can keep a
    vertex it turns right at on slivers), the vertex found here by trying every one."""
    rng = np.random.default_rng(seed)
    a = np.sort(rng.uniform(0, 2 * np.pi, n))
    r = 1.0 + noise * rng.uniform(-1, 1, n)
    pts = np.column_stack([size * r * np.cos(a), flat * size * r * np.sin(a)])
    if repeat:  # repeated vertices and points along the hull's edges
        pts = np.vstack([pts, pts[: n // 3], (pts[:-1:5] + pts[1::5]) / 2])
    geom = shapely.affinity.rotate(shapely.MultiPoint(pts), turn, origin=(0, 0))
    want = float(_widths_by_brute_force(shapely.get_coordinates(geom)).min())
    w, h = narrowest(geom)
    assert w == pytest.approx(want, rel=1e-9, abs=1e-9 * size)
    _, vmin, _, vmax = LineFrame(h).geom_to_frame(geom).bounds
    assert vmax - vmin == pytest.approx(w, rel=1e-9, abs=1e-9 * size)


def test_a_round_area_of_a_hundred_thousand_vertices_has_its_width():
    """An ellipse of 100,000 vertices (semi-axes 3 km and 1 km, turned 20°): 2 km wide across its major axis. Trying
    every vertex against every edge would hold 10^10 distances (80 GB)."""
    a = np.linspace(0, 2 * np.pi, 100_000, endpoint=False)
    ellipse = shapely.affinity.rotate(shapely.Polygon(np.column_stack([3000 * np.cos(a), 1000 * np.sin(a)])), 20.0,
                                      origin=(0, 0))
    w, h = narrowest(ellipse)
    assert w == pytest.approx(2000.0, abs=1e-3)  # the inscribed polygon: under 2b by b(1 - cos(π/n)) ≈ 5e-7 m
    assert min(abs(h - 70.0), abs(h - 250.0)) < 0.01  # along the major axis: 20° from east, compass 70°


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10_000), size=st.floats(80, 1500), heading=st.floats(0, 180), k=st.integers(1, 3),
       ratio=st.floats(1.05, 1.9))
@example(seed=3, size=908.0, heading=0.0, k=3, ratio=1.875)  # narrower than a strip by 0.7 m: k lines would nearly coincide
def test_no_heading_lays_fewer_lines_than_the_strip_bound(seed, size, heading, k, ratio):
    poly = _convex(seed, size)
    spacing = 40.0
    across = spacing * (k + ratio - 1.0)  # k strips per point: across between k and k+1 spacings
    bound = grid_bounds(poly, 1.0, across, spacing, 10.0, k, 1)
    _, vmin, _, vmax = LineFrame(heading).geom_to_frame(poly).bounds
    assert len(strip_offsets(vmin, vmax, across, spacing, k)) >= bound.strips
    # lines along a hull edge (the narrowest width is across one of them) reach the bound
    d = np.diff(np.asarray(poly.exterior.coords), axis=0)
    along_edges = [LineFrame(math.degrees(math.atan2(dx, dy)) % 180.0).geom_to_frame(poly).bounds for dx, dy in d]
    assert min(len(strip_offsets(b[1], b[3], across, spacing, k)) for b in along_edges) == bound.strips
    assert bound.photos == math.ceil(poly.area / (10.0 * spacing) - 1e-9)


@settings(max_examples=60, deadline=None)
@given(width=st.floats(1.0, 3000.0), ratio=st.floats(1.01, 5.0), spacing=st.floats(5.0, 200.0), lo=st.floats(-1e4, 1e4))
def test_strip_offsets_put_every_point_in_k_strips_at_the_spacing_or_closer(width, ratio, spacing, lo):
    k = max(1, math.floor(ratio + 1e-9))
    across = spacing * ratio
    vs = strip_offsets(lo, lo + width, across, spacing, k)
    gaps = np.diff(vs)
    assert (gaps <= spacing * (1 + 1e-9)).all() and (gaps > 0).all()
    probe = np.linspace(lo, lo + width, 2001)
    assert (np.abs(probe[:, None] - vs[None, :]) <= across / 2 + 1e-6).sum(axis=1).min() >= k
    # as few lines as the strip bound of a band that wide
    band = shapely.box(0.0, lo, 1e5, lo + width)  # its minimum width is `width`
    assert len(vs) == grid_bounds(band, 1.0, across, spacing, 1.0, k, 1).strips


def test_a_corridors_strip_bound_is_across_its_width_not_its_outline(tmp_path):
    """A bent corridor's outline is wide; its strips follow the centreline, so its bound counts
    the strips across left + right, and the plan of the road example flies no fewer."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    repo = Path(__file__).resolve().parents[2]
    subprocess.run([sys.executable, "-m", "aerosurvey.cli", "plan", str(repo / "missions" / "road-corridor.toml"),
                    "-o", str(tmp_path / "o")], check=True, capture_output=True)
    m = json.loads((tmp_path / "o" / "manifest.json").read_text())
    bound = m["derived"]["bounds"]
    flown = len({line["line"] for line in m["lines"]})
    p = m["pattern"]["parameters"]
    k, a, s = m["derived"]["side_images_per_point"], m["derived"]["footprint_across_m"], m["derived"]["line_spacing_m"]
    width = p["left_m"] + p["right_m"] + 2 * m["targets"]["coverage_margin_m"]
    assert width >= a  # the example is wider than one footprint
    assert bound["strips"] == _fewest_lines(width, a, s, k)
    assert bound["strips"] <= flown


def _fewest_lines(width: float, across: float, spacing: float, k: int) -> int:
    """The fewest lines `spacing` apart whose strips (±across/2) put every point of [0, width] in
    k of them, found by trying counts and offsets on sampled points (not by the bound's formula)."""
    pts = np.linspace(0.0, width, 2001)
    for n in range(1, 1000):
        for first in np.linspace(-across / 2.0, across / 2.0, 241):  # the first line within half a strip of 0
            lines = first + spacing * np.arange(n)
            if ((np.abs(pts[:, None] - lines[None, :]) <= across / 2.0 + 1e-6).sum(axis=1) >= k).all():
                return n
    raise AssertionError("no count of lines covers the width")


def test_a_corridor_one_footprint_spans_is_bound_by_one_strip(tmp_path):
    """A corridor narrower than a footprint is one strip down the middle (its guarantee): the
    bound is one strip and at most the photos flown (was: a bound of 2 strips over a plan of 1)."""
    import json

    from click.testing import CliRunner
    from tests.conftest import write_geojson

    from aerosurvey.cli import main

    write_geojson(tmp_path / "line.geojson", [[15.0, 49.4], [15.01, 49.4], [15.02, 49.405]], "LineString")
    spec = tmp_path / "spec.toml"
    spec.write_text('[mission]\nname = "narrow"\n[area]\nfile = "line.geojson"\n[pattern]\nkind = "corridor"\nwidth_m = 40\n'
                    '[camera]\nmodel = "sony-a6000-16mm"\n[targets]\ngsd_cm = 2.5\nforward_overlap = 0.75\nside_overlap = 0.6\n'
                    '[vehicle]\ntype = "copter"\ncruise_speed_ms = 10.0\n')
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(tmp_path / "o")])
    assert res.exit_code in (0, 1), res.output
    m = json.loads((tmp_path / "o" / "manifest.json").read_text())
    assert m["derived"]["footprint_across_m"] > 40
    flown_lines = len({line["line"] for line in m["lines"]})
    assert flown_lines == 1
    assert m["derived"]["bounds"]["strips"] == 1
    assert m["derived"]["bounds"]["photos"] <= len(m["stations"])


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(width=st.floats(20.0, 200.0), bend=st.floats(0.0, 60.0), gsd=st.sampled_from([1.5, 2.0, 2.5]))
@example(width=80.0, bend=35.0, gsd=2.5)
def test_a_narrow_bent_corridor_polygon_is_never_below_its_bound(tmp_path_factory, width, bend, gsd):
    """Corridor polygons (a bent centreline grown by half the width, flat ends), from narrower than
    a footprint (the issue's 80 m wide bent corridor: one strip down the middle) to a few strips
    wide: the plan flies at least the bound's strips and photos."""
    import json

    import pyproj
    from click.testing import CliRunner
    from tests.conftest import write_geojson

    from aerosurvey.cli import main

    tmp = tmp_path_factory.mktemp("corridor")
    b = math.radians(bend)
    line = shapely.LineString([(0.0, 0.0), (600.0, 0.0), (600.0 + 600.0 * math.cos(b), 600.0 * math.sin(b))])
    poly = shapely.buffer(line, width / 2.0, cap_style="flat", join_style="mitre")
    back = pyproj.Transformer.from_crs("+proj=aeqd +lat_0=49.4 +lon_0=15.0 +datum=WGS84", "EPSG:4326", always_xy=True)
    lon, lat = back.transform(*np.asarray(poly.exterior.coords).T)
    write_geojson(tmp / "corridor.geojson", [[[float(a), float(c)] for a, c in zip(lon, lat)]])
    spec = tmp / "spec.toml"
    spec.write_text('[mission]\nname = "narrow"\n[area]\nfile = "corridor.geojson"\n[pattern]\nkind = "corridor"\n'
                    f'[camera]\nmodel = "sony-a6000-16mm"\n[targets]\ngsd_cm = {gsd}\nforward_overlap = 0.75\nside_overlap = 0.6\n'
                    '[vehicle]\ntype = "copter"\ncruise_speed_ms = 10.0\n')
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(tmp / "o")])
    assert res.exit_code in (0, 1), res.output
    m = json.loads((tmp / "o" / "manifest.json").read_text())
    bound = m["derived"]["bounds"]
    flown = len({ln["line"] for ln in m["lines"]})
    assert flown >= bound["strips"], (flown, bound, m["derived"]["footprint_across_m"])
    assert len(m["stations"]) >= bound["photos"], (len(m["stations"]), bound)
