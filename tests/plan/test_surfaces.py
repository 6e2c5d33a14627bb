"""The capture model on a structure's faces, judged by a ray caster written here.

The caster (tests/independent_faces.py) shares nothing with plan/capture.py or
plan/surfaces.py. Pairs whose segment grazes the prism are left out of the comparison:
marching cannot tell them. The GSD on a face is the inverse of the image's Jacobian on the
face's plane (finite differences of the projection).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from shapely import affinity

from aerosurvey.plan.capture import Attitudes, Optics, Photos
from aerosurvey.plan.surfaces import Structure, Terrace, face_coverage, face_gsd, face_points, seen
from independent_faces import bench_caster, bench_samples, caster, project, section

OPTICS = Optics(width_mm=13.2, height_mm=8.7984, focal_mm=8.8, pixel_mm=0.0024, width_px=5500, height_px=3666)
SENSOR = (OPTICS.width_mm, OPTICS.height_mm, OPTICS.focal_mm)  # the caster's: image width and height, focal length (mm)


@st.composite
def structures(draw) -> Structure:
    w1, d1 = draw(st.floats(8.0, 60.0)), draw(st.floats(8.0, 60.0))
    shape = shapely.box(0, 0, w1, d1)
    if draw(st.booleans()):  # an L: a second block on one corner
        w2, d2 = draw(st.floats(5.0, 40.0)), draw(st.floats(5.0, 40.0))
        shape = shapely.union(shape, shapely.box(w1 - min(w1, w2) / 2, d1 - 1.0, w1 - min(w1, w2) / 2 + w2, d1 + d2))
    shape = affinity.rotate(shape, draw(st.floats(0.0, 360.0)), origin=(0, 0))
    top = draw(st.floats(4.0, 60.0))
    return Structure(shapely.Polygon(shapely.get_coordinates(shape.exterior)), 0.0, top)


@settings(max_examples=12, deadline=None)
@given(s=structures(), standoff=st.floats(8.0, 40.0), count=st.integers(4, 10), seed=st.integers(0, 2**31 - 1))
def test_the_faces_a_photo_sees_are_the_ray_casters(s: Structure, standoff: float, count: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    ring = s.footprint.buffer(standoff, join_style="mitre").exterior
    pts = face_points(s, max(s.top_m, math.sqrt(s.footprint.area)) / 6.0)
    cams = []
    for _ in range(count):  # round the structure, each camera aimed near a face point
        at = ring.interpolate(float(rng.uniform(0.0, 1.0)), normalized=True)
        z = float(rng.uniform(0.5, s.top_m + 30.0))
        m = int(rng.integers(len(pts)))
        d = np.array([pts.x[m] - at.x, pts.y[m] - at.y, pts.z[m] - z])
        yaw = math.degrees(math.atan2(d[0], d[1])) + float(rng.uniform(-15, 15))
        pitch = math.degrees(math.atan2(d[2], math.hypot(d[0], d[1]))) + float(rng.uniform(-10, 10))
        cams.append((at.x, at.y, z, yaw % 360.0, min(max(pitch, -89.0), 30.0)))
    c = np.array(cams)
    photos = Photos(c[:, 0], c[:, 1], c[:, 2], Attitudes(c[:, 3], c[:, 4], np.zeros(len(c))))
    ours = seen(photos, OPTICS, s, pts)
    p = np.column_stack([pts.x, pts.y, pts.z])
    theirs, graze = caster(s.footprint, s.base_m, s.top_m, SENSOR, cams, p, pts.normal)
    differ = (ours != theirs) & ~graze
    assert not differ.any(), f"{int(differ.sum())} pairs differ, e.g. {np.argwhere(differ)[:3].tolist()}"
    assume((theirs & ~graze).any())
    # the GSD on the face, where seen
    i, j = np.nonzero(ours)
    g = face_gsd(photos, OPTICS, pts, i, j)
    for k in rng.choice(len(i), size=min(len(i), 40), replace=False):
        rel = c[i[k], :3] - p[j[k]]
        if rel @ pts.normal[j[k]] > 0.2 * np.linalg.norm(rel):  # a pixel and the derivative agree short of grazing
            assert g[k] == pytest.approx(_jacobian_gsd(cams[i[k]], p[j[k]], pts.normal[j[k]]), rel=2e-3)


def _jacobian_gsd(cam: tuple, p: np.ndarray, n: np.ndarray) -> float:
    """The larger side of a pixel on the face's plane: the columns of the inverse Jacobian of the
    projection (pixels a metre along two in-plane axes)."""
    c = np.array(cam[:3])
    e1 = np.cross(n, [0.0, 0.0, 1.0]) if abs(n[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    h = 1e-4
    u0, v0, _ = project(SENSOR, c, cam[3], cam[4], p)
    cols = []
    for e in (e1, e2):
        u, v, _ = project(SENSOR, c, cam[3], cam[4], p + h * e)
        cols.append([(u - u0) / h / OPTICS.pixel_mm, -(v - v0) / h / OPTICS.pixel_mm])
    inv = np.linalg.inv(np.array(cols).T)  # metres in the plane (e1, e2) a pixel along the image's columns and rows
    return float(max(np.linalg.norm(inv[:, 0]), np.linalg.norm(inv[:, 1])))


@settings(max_examples=30, deadline=None)
@given(s=structures(), spacing=st.floats(1.0, 15.0))
def test_face_points_stand_for_the_faces_whole_area(s: Structure, spacing: float) -> None:
    pts = face_points(s, spacing)
    walls = s.footprint.exterior.length * (s.top_m - s.base_m)
    assert pts.area_m2[pts.normal[:, 2] == 0].sum() == pytest.approx(walls, rel=1e-9)
    assert pts.area_m2[pts.normal[:, 2] == 1].sum() == pytest.approx(s.footprint.area, rel=1e-9)
    # every wall point on its wall, every roof point inside the footprint at the top
    on_wall = pts.normal[:, 2] == 0
    assert np.all(shapely.distance(s.footprint.exterior, shapely.points(pts.x[on_wall], pts.y[on_wall])) < 1e-6)
    assert np.all(shapely.contains_xy(s.footprint.buffer(1e-9), pts.x[~on_wall], pts.y[~on_wall]))
    # the normals point out of the structure
    out = shapely.points(pts.x[on_wall] + pts.normal[on_wall, 0] * 0.01, pts.y[on_wall] + pts.normal[on_wall, 1] * 0.01)
    assert not shapely.contains(s.footprint, out).any()


def test_one_wing_of_an_l_hides_the_other_ones_inner_wall() -> None:
    """An L (a 40 × 10 m wing along x, a 10 × 30 m wing up from its east end), 20 m high: from the
    far west, low, the east wing's west wall (x = 30, facing west) is behind nothing; from the south
    west, low, the south wing hides the part of it near the ground; from high above the south
    wing, looking down across its roof, the roof hides that part too."""
    s = Structure(shapely.Polygon([(0, 0), (40, 0), (40, 40), (30, 40), (30, 10), (0, 10)]), 0.0, 20.0)
    pts = face_points(s, 1.0)
    inner = (np.abs(pts.x - 30) < 1e-9) & (pts.normal[:, 0] < -0.5) & (pts.z < 6) & (pts.y > 10) & (pts.y < 12)
    assert inner.sum() > 10

    def look(x: float, y: float, z: float, at: tuple[float, float, float]) -> np.ndarray:
        d = np.subtract(at, (x, y, z))
        yaw, pitch = math.degrees(math.atan2(d[0], d[1])), math.degrees(math.atan2(d[2], math.hypot(d[0], d[1])))
        ph = Photos(np.array([x]), np.array([y]), np.array([z]), Attitudes(np.array([yaw]), np.array([pitch]), np.zeros(1)))
        return seen(ph, OPTICS, s, pts)[0]

    assert look(-60.0, 13.0, 4.0, (30.0, 13.0, 4.0))[inner].all()
    assert not look(-20.0, -40.0, 4.0, (30.0, 13.0, 4.0))[inner].any()  # through the south wing's walls
    assert not look(10.0, -3.0, 60.0, (30.0, 13.0, 4.0))[inner].any()  # through its roof
    assert look(10.0, 30.0, 60.0, (30.0, 13.0, 4.0))[inner].all()  # from above the open corner


def test_a_tower_seen_from_one_side_is_half_covered() -> None:
    """A square tower photographed from the south only: its north wall and nothing of it is seen."""
    s = Structure(shapely.box(-5, -5, 5, 5), 0.0, 30.0)
    pts = face_points(s, 1.0)
    xs = np.linspace(-15, 15, 7)
    photos = Photos(np.repeat(xs, 3), np.full(21, -40.0), np.tile([5.0, 15.0, 25.0], 7),
                    Attitudes(np.zeros(21), np.zeros(21), np.zeros(21)))
    cov = face_coverage(photos, OPTICS, s, pts)
    north = pts.normal[:, 1] > 0.5
    south = pts.normal[:, 1] < -0.5
    assert (cov.images[north] == 0).all() and (cov.images[south] >= 2).all()
    assert np.isinf(cov.finest_gsd_m[north]).all()
    # 40 m from the wall at pitch 0: 40·p/f on the face
    assert cov.finest_gsd_m[south].min() == pytest.approx(35.0 * 0.0024 / 8.8, rel=0.05)


def test_a_camera_inside_the_structure_is_refused() -> None:
    s = Structure(shapely.box(-5, -5, 5, 5), 0.0, 30.0)
    photos = Photos(np.zeros(1), np.zeros(1), np.array([10.0]), Attitudes(np.zeros(1), np.zeros(1), np.zeros(1)))
    with pytest.raises(ValueError, match="inside the structure"):
        seen(photos, OPTICS, s, face_points(s, 5.0))


def test_the_forward_overlap_on_a_wall_is_the_footprint_less_the_base() -> None:
    """A row of level photos 40 m off a 200 m wall, 10 m apart: each sees 60 m of it (13.2 / 8.8 of
    the distance), two neighbours share 50 m of that: 83 %, the row's first pair (cut by the wall's
    end) all of the first's."""
    s = Structure(shapely.box(0, 0, 200, 2), 0.0, 30.0)
    xs = np.arange(20.0, 181.0, 10.0)
    n = len(xs)
    photos = Photos(xs, np.full(n, -40.0), np.full(n, 15.0), Attitudes(np.zeros(n), np.zeros(n), np.zeros(n)))
    cov = face_coverage(photos, OPTICS, s, face_points(s, 1.0), run=np.zeros(n, int))
    assert len(cov.forward_overlap) == n - 1
    assert cov.forward_overlap.min() == pytest.approx(50.0 / 60.0, abs=0.02)
    assert cov.forward_overlap[0] == pytest.approx(1.0, abs=0.02)
    # another run's photos are no forward neighbours
    split = face_coverage(photos, OPTICS, s, face_points(s, 1.0), run=(xs > 100).astype(int))
    assert len(split.forward_overlap) == n - 2


@settings(max_examples=12, deadline=None)
@given(angle=st.floats(30.0, 90.0), height=st.floats(4.0, 25.0), benches=st.integers(1, 3), berm=st.floats(0.0, 8.0),
       turn=st.floats(0.0, 360.0), length=st.floats(15.0, 80.0), count=st.integers(4, 10), seed=st.integers(0, 2**31 - 1))
def test_the_bench_faces_a_photo_sees_are_the_ray_casters(angle: float, height: float, benches: int, berm: float, turn: float,
                                                          length: float, count: int, seed: int) -> None:
    """Cameras in front of and above random benches, each aimed near a face point, some low enough
    for the lower crests to hide the upper faces."""
    rng = np.random.default_rng(seed)
    t = math.radians(turn)
    a, b = np.array([0.0, 0.0]), np.array([math.sin(t), math.cos(t)]) * length
    s = Terrace((0.0, 0.0), (float(b[0]), float(b[1])), 0.0, angle, height, benches, berm)
    pts = s.points(max(height, length) / 6.0)
    solid = section(0.0, angle, height, benches, berm)
    along = (b - a) / length
    front = -np.array([along[1], -along[0]])
    cams = []
    for _ in range(count):
        low = rng.uniform() < 0.5  # below the first crest, near: an upper face behind it
        xy = a + along * float(rng.uniform(-0.3, 1.3)) * length + front * float(rng.uniform(2.0, 12.0 if low else 40.0))
        z = float(rng.uniform(0.5, height) if low else rng.uniform(0.5, benches * height + 30.0))
        upper = np.flatnonzero(pts.face == benches - 1)
        m = int(rng.choice(upper)) if low else int(rng.integers(len(pts)))
        d = np.array([pts.x[m] - xy[0], pts.y[m] - xy[1], pts.z[m] - z])
        yaw = math.degrees(math.atan2(d[0], d[1])) + float(rng.uniform(-15, 15))
        pitch = math.degrees(math.atan2(d[2], math.hypot(d[0], d[1]))) + float(rng.uniform(-10, 10))
        cams.append((float(xy[0]), float(xy[1]), z, yaw % 360.0, min(max(pitch, -89.0), 70.0)))  # looking up at a face too
    c = np.array(cams)
    photos = Photos(c[:, 0], c[:, 1], c[:, 2], Attitudes(c[:, 3], c[:, 4], np.zeros(len(c))))
    ours = seen(photos, OPTICS, s, pts)
    p = np.column_stack([pts.x, pts.y, pts.z])
    theirs, graze = bench_caster(a, b, solid, SENSOR, cams, p, pts.normal)
    differ = (ours != theirs) & ~graze
    assert not differ.any(), f"{int(differ.sum())} pairs differ, e.g. {np.argwhere(differ)[:3].tolist()}"
    assume((theirs & ~graze).any())
    # the samples' area is the faces' and the caster's samples lie on the same planes
    ref, nrm, area = bench_samples(a, b, 0.0, angle, height, benches, berm, max(height, length) / 6.0)
    assert pts.area_m2.sum() == pytest.approx(area.sum(), rel=1e-9) and np.allclose(pts.normal, nrm[0], atol=1e-12)
    # the GSD on the face, where seen
    i, j = np.nonzero(ours)
    g = face_gsd(photos, OPTICS, pts, i, j)
    for k in rng.choice(len(i), size=min(len(i), 40), replace=False):
        rel = c[i[k], :3] - p[j[k]]
        if rel @ pts.normal[j[k]] > 0.2 * np.linalg.norm(rel):
            assert g[k] == pytest.approx(_jacobian_gsd(cams[i[k]], p[j[k]], pts.normal[j[k]]), rel=2e-3)


def test_a_camera_inside_the_benches_is_refused() -> None:
    s = Terrace((0.0, 0.0), (0.0, 50.0), 0.0, 60.0, 10.0, 2, 5.0)  # faces rise to the east
    photos = Photos(np.array([8.0]), np.array([20.0]), np.array([5.0]), Attitudes(np.zeros(1), np.zeros(1), np.zeros(1)))
    with pytest.raises(ValueError, match="inside"):
        seen(photos, OPTICS, s, s.points(5.0))
