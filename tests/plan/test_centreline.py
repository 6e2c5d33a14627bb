"""The centreline derived from a corridor polygon (plan/centreline.py), judged against the line the
polygon was built from and a band rebuilt here from the derived line and widths alone.

- Random bent corridors: a random polyline buffered (round, square or flat ends; round or mitred
  bends). The derived line lies within its stated simplification tolerance plus half the
  half-width of the polyline continued over the polygon's ends (a medial axis cuts the inside
  corner of a sharp bend by up to about a third of the half-width); the band the derived widths
  make covers the polygon; with round bends no side is wider than the half-width plus the
  tolerance and a third of the half-width (the line's own shift at a sharp bend).
- Wiggly edges (the outline moved by noise of a tenth of the half-width): one centreline still,
  close to the polyline, the band covering the polygon.
- A Y or a T (three arms as wide as the corridor, round or flat at their ends) is refused in one line naming the input, the branch's
  numbers and what is allowed; so is a blob (shorter than twice its width), with its numbers.
"""

from __future__ import annotations

import math
import os

import numpy as np
import pytest
import shapely
from hypothesis import event, example, given, settings
from hypothesis import strategies as hs

from aerosurvey.errors import InputError
from aerosurvey.plan.centreline import derive_centreline

#: examples per property test (more: AEROSURVEY_CENTRELINE_EXAMPLES=500)
EXAMPLES = int(os.environ.get("AEROSURVEY_CENTRELINE_EXAMPLES", "60"))


def band(line: shapely.Geometry, left: float, right: float) -> shapely.Geometry:
    """The ground `left` to the left and `right` to the right of each segment (rectangles), and a
    disc at each bend as wide as the side outside it: rebuilt here, sharing no code with the planner."""
    parts = []
    for piece in shapely.get_parts(line):
        xy = shapely.get_coordinates(piece)
        u = np.diff(xy, axis=0)
        u = u / np.hypot(*u.T)[:, None]
        for (a, b), d in zip(zip(xy[:-1], xy[1:]), u):
            n = np.array([-d[1], d[0]])  # to the left
            parts.append(shapely.Polygon([a + n * left, b + n * left, b - n * right, a - n * right]))
        for k in range(1, len(xy) - 1):
            turns_left = u[k - 1, 0] * u[k, 1] - u[k - 1, 1] * u[k, 0] > 0
            parts.append(shapely.Point(xy[k]).buffer(right if turns_left else left, 64))
    return shapely.union_all(parts)


def uncovered(polygon: shapely.Geometry, line: shapely.Geometry, left: float, right: float) -> float:
    """The area of the polygon outside the band (square metres). The overlay snaps to a micrometre
    grid: GEOS's floating overlay of a band whose edges lie on the polygon's to 1e-14 once gave back
    the whole polygon (a straight corridor, CI); snap rounding is robust there."""
    return float(shapely.difference(polygon, band(line, left, right), grid_size=1e-6).area)


@hs.composite
def polylines(draw: hs.DrawFn) -> np.ndarray:
    """1–4 segments, 300–900 m each, turning up to 100° at a bend."""
    heading = draw(hs.floats(0, 2 * math.pi))
    pts = [np.zeros(2)]
    for _ in range(draw(hs.integers(1, 4))):
        length = draw(hs.floats(300, 900))
        pts.append(pts[-1] + length * np.array([math.sin(heading), math.cos(heading)]))
        heading += math.radians(draw(hs.floats(-100, 100)))
    return np.array(pts)


def continued(xy: np.ndarray, by: float) -> shapely.LineString:
    """The polyline continued straight by `by` at both ends."""
    out = xy.copy()
    for end, inner in ((0, 1), (-1, -2)):
        d = xy[end] - xy[inner]
        out[end] = xy[end] + d / np.hypot(*d) * by
    return shapely.LineString(out)


def _simple_corridor(poly: shapely.Geometry) -> bool:
    """A polyline's buffer that does not touch itself (one ring, no hole)."""
    return poly.geom_type == "Polygon" and not len(poly.interiors)


@settings(max_examples=EXAMPLES, deadline=None)
@given(xy=polylines(), half=hs.floats(15, 80), cap=hs.sampled_from(["round", "square", "flat"]),
       join=hs.sampled_from(["round", "mitre"]))
# sharp bends onto legs two widths long: the wider inside of the bend is no reason to cut an end
# back, nor the outer corner's spur an arm
@example(xy=np.array([[0, 0], [0, 300], [0, 600], [299.81724811, 610.46984901]]), half=79.0, cap="round", join="round")
@example(xy=np.array([[0, 0], [0, 300], [298.35656861, 268.64146102]]), half=76.0, cap="round", join="round")
# a spiral's last end a few metres beside its first: an end cut back by a radius left its cap
# nearer the first leg than its own (widths of 203 m for 80, and a band that missed 92 m²)
@example(xy=np.array([[0, 0], [0, 466], [734.66793324, 718.96645601], [884.00652226, 161.62725424],
                      [168.73872903, 99.04943095]]), half=80.0, cap="square", join="mitre")
@example(xy=np.array([[0, 0], [0, 598], [740.19252529, 649.75930352], [891.64106834, 154.39343993],
                      [55.91720866, 51.77945278]]), half=22.0, cap="round", join="round")
# a straight one sampled alike on both sides: qhull merged the vertices of samples on one circle,
# carrying a Voronoi edge 150 m along the corridor (refused as a branch)
@example(xy=np.array([[0, 0], [286.22573448290814, -89.86005185687225]]), half=31.52145178224162, cap="round", join="round")
def test_a_bent_corridor_gives_back_its_line_and_a_covering_band(xy: np.ndarray, half: float, cap: str, join: str) -> None:
    poly = shapely.LineString(xy).buffer(half, cap_style=cap, join_style=join)
    if not _simple_corridor(poly):
        event("skipped: the buffer touches itself")
        return
    length = shapely.LineString(xy).length + (2 * half if cap != "flat" else 0.0)
    if length < 1.9 * 2 * half:  # shorter than twice its width: refused
        with pytest.raises(InputError, match="longer than wide"):
            derive_centreline(poly, 1.0, "area.file 'road.geojson'")
        event("refused: shorter than twice its width")
        return
    if length < 2.6 * 2 * half:  # the derived width may be wider by the tolerance: either
        event("skipped: about twice as long as wide")
        return
    event(f"derived: {len(xy) - 1} segment(s)")
    d = derive_centreline(poly, 1.0, "area.file 'road.geojson'")
    assert d.centreline.geom_type == "LineString"
    original = continued(xy, half if cap != "flat" else 0.0)
    off = shapely.hausdorff_distance(d.centreline, original, densify=0.02)
    assert off <= d.tolerance + 0.5 * half, (off, d.tolerance, half)
    assert uncovered(poly, d.centreline, d.left, d.right) <= 1e-6 * poly.area
    if join == "round":
        assert max(d.left, d.right) <= half + d.tolerance + 0.35 * half, (d.left, d.right, half, d.tolerance)


@settings(max_examples=max(EXAMPLES // 2, 10), deadline=None)
@given(xy=polylines(), half=hs.floats(25, 80), seed=hs.integers(0, 2**31))
# a noisy round end: its spurs, pruned one circle round two at a time, looked wider than they are
@example(xy=np.array([[0, 0], [366.8813493762429, 235.57180535850893]]), half=25.0, seed=0)
# a sliver inside a bend between short segments of the derived line, covered in the seventh round
@example(xy=np.array([[0.0, 0.0], [171.94448454001753, -245.83550239187926], [19.208335169343485, -572.9328406192319]]), half=60.0, seed=2)
def test_wiggly_edges_still_give_one_centreline(xy: np.ndarray, half: float, seed: int) -> None:
    smooth = shapely.LineString(xy).buffer(half, quad_segs=16)
    # legs at least a half-width apart: the noise (a tenth of the half-width a coordinate) moving
    # the outlines of two legs closer than that would join them into a loop round a hole, a
    # ring (its hole filled, a blob) and no corridor
    if not _simple_corridor(shapely.LineString(xy).buffer(1.5 * half)):
        event("skipped: two legs less than a half-width apart")
        return
    ring = shapely.get_coordinates(shapely.segmentize(smooth.exterior, half / 5))
    ring = ring + np.random.default_rng(seed).normal(0.0, 0.1 * half, ring.shape)
    ring[-1] = ring[0]
    poly = shapely.make_valid(shapely.Polygon(ring))
    poly = max(shapely.get_parts(poly), key=lambda p: p.area)  # noise may pinch off a sliver
    d = derive_centreline(poly, 1.0, "area.file 'river.gpkg'")
    assert shapely.hausdorff_distance(d.centreline, continued(xy, half), densify=0.02) <= d.tolerance + 0.6 * half
    assert uncovered(poly, d.centreline, d.left, d.right) <= 1e-6 * poly.area


@settings(max_examples=max(EXAMPLES // 3, 10), deadline=None)
@given(arm=hs.floats(300, 900), half=hs.floats(15, 60), turn=hs.floats(math.radians(50), math.radians(180)),
       heading=hs.floats(0, 2 * math.pi), cap=hs.sampled_from(["round", "flat"]))
def test_a_y_is_refused_in_one_line_with_its_numbers(arm: float, half: float, turn: float, heading: float, cap: str) -> None:
    """Three arms from a fork (a T at a turn of 180°), round or flat at their ends."""
    fork = np.zeros(2)

    def to(bearing: float) -> np.ndarray:
        return fork + arm * np.array([math.sin(bearing), math.cos(bearing)])

    y = shapely.union_all([shapely.LineString([fork, to(heading + b)]).buffer(half, cap_style=cap)
                           for b in (0.0, math.pi - turn / 2, math.pi + turn / 2)])
    with pytest.raises(InputError) as exc:
        derive_centreline(y, 1.0, "area.file 'junction.geojson'")
    message = str(exc.value)
    assert "\n" not in message
    assert message.startswith("area.file 'junction.geojson': the corridor polygon branches")
    assert "one centreline" in message and "MultiLineString" in message


@pytest.mark.parametrize("blob", [shapely.Point(0, 0).buffer(100), shapely.box(0, 0, 150, 100),
                                  shapely.affinity.scale(shapely.Point(0, 0).buffer(100), 1.8, 1.0)])
def test_a_blob_is_refused_with_its_numbers(blob: shapely.Geometry) -> None:
    with pytest.raises(InputError, match=r"^area.file 'field.kml': the corridor polygon is .*(longer than wide)") as exc:
        derive_centreline(blob, 1.0, "area.file 'field.kml'")
    assert "\n" not in str(exc.value)
    assert "pattern.kind = 'area'" in str(exc.value)


def test_a_straight_corridor_runs_eastwards_with_its_sides_measured_in_metres() -> None:
    """A 1 km by 100 m strip in a CRS of 2 units a metre: the line along its middle from west to
    east, 50 m each side; left is north."""
    strip = shapely.box(0, 0, 2000, 160)  # 1 km by 80 m
    strip = shapely.union_all([strip, shapely.box(0, 160, 2000, 200)])  # 100 m
    d = derive_centreline(strip, 2.0, "area.file 'strip.geojson'")
    xy = shapely.get_coordinates(d.centreline)
    assert np.allclose(xy[[0, -1]], [[0, 100], [2000, 100]], atol=0.5)
    assert d.left == pytest.approx(100, abs=0.5) and d.right == pytest.approx(100, abs=0.5)
    north_heavy = shapely.union_all([strip, shapely.box(500, 200, 1500, 260)])  # a lay-by on the north side
    d = derive_centreline(north_heavy, 2.0, "area.file 'strip.geojson'")
    assert d.left > d.right


def test_each_part_of_a_multipolygon_gets_its_centreline() -> None:
    parts = shapely.MultiPolygon([shapely.box(0, 0, 1000, 100), shapely.box(0, 500, 100, 2000)])
    d = derive_centreline(parts, 1.0, "area.file 'two.geojson'")
    assert d.centreline.geom_type == "MultiLineString" and len(d.centreline.geoms) == 2
    assert uncovered(parts, d.centreline, d.left, d.right) <= 1e-6 * parts.area


def test_holes_are_flown_over() -> None:
    """A road with a traffic island: the line runs down the middle as without it."""
    road = shapely.box(0, 0, 1000, 100).difference(shapely.box(400, 40, 600, 60))
    d = derive_centreline(road, 1.0, "area.file 'road.geojson'")
    assert np.allclose(shapely.get_coordinates(d.centreline), [[0, 50], [1000, 50]], atol=0.5)
    assert d.left == pytest.approx(50, abs=0.5) and d.right == pytest.approx(50, abs=0.5)
