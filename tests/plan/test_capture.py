"""The capture model against geometry worked out by hand (pinhole, flat or sloping ground).

Expected values are written from the textbook relations (H · size / f at nadir; tan(θ ± β)
for a camera tilted by θ from nadir with half field β; a ray met with a plane), not from the
model's functions."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from aerosurvey.camera import Camera
from aerosurvey.plan.capture import (
    Attitudes,
    Optics,
    Photos,
    bounded_footprint_corners,
    bounded_footprints,
    edge_gsd,
    footprint_corners,
    footprint_polygons,
    ground_points,
    image_points,
    images_seeing,
)

# a sensor whose pixel grid is shorter than the published short side (as the Sony a6000's is not):
# 6000 x 4000 px of 23.5 mm / 6000 = 3.9167 µm; the short side's imaging area is min(15.667, 15.6) = 15.6 mm
CAM = Camera("t", "test", 23.5, 15.6, 6000, 4000, 16.0)
W, H_SENSOR, F = 23.5, 15.6, 16.0


def photos(yaw: float, pitch: float, roll: float = 0.0, z: float = 100.0, x: float = 0.0, y: float = 0.0) -> Photos:
    a = np.array
    return Photos(a([x]), a([y]), a([z]), Attitudes(a([yaw]), a([pitch]), a([roll])))


def test_nadir_is_the_rectangle_of_the_sensor_scaled_by_h_over_f() -> None:
    c = footprint_corners(photos(0.0, -90.0), Optics.of(CAM, "landscape"), 0.0)[0]
    half_across, half_along = W * 100 / F / 2, H_SENSOR * 100 / F / 2  # 73.4375, 48.75
    assert c == pytest.approx(np.array([[half_across, half_along], [-half_across, half_along],
                                        [-half_across, -half_along], [half_across, -half_along]]), abs=1e-9)
    assert shapely.Polygon(c).exterior.is_ccw
    p = footprint_corners(photos(0.0, -90.0), Optics.of(CAM, "portrait"), 0.0)[0]
    assert p.max(axis=0) == pytest.approx([half_along, half_across])


@given(st.floats(0, 360), st.floats(20, 400), st.floats(-1e5, 1e5), st.floats(-1e5, 1e5))
@settings(max_examples=60, deadline=None)
def test_nadir_footprint_turns_with_the_yaw_and_keeps_its_size(yaw: float, z: float, x: float, y: float) -> None:
    c = footprint_corners(photos(yaw, -90.0, z=z, x=x, y=y), Optics.of(CAM, "landscape"), 0.0)[0]
    assert c.mean(axis=0) == pytest.approx([x, y], abs=1e-6)
    top_mid = (c[0] + c[1]) / 2 - [x, y]  # the image's top edge lies ahead, along the yaw
    assert top_mid == pytest.approx(np.array([math.sin(math.radians(yaw)), math.cos(math.radians(yaw))]) * H_SENSOR * z / F / 2,
                                    abs=1e-6)
    assert shapely.Polygon(c).area == pytest.approx(W * H_SENSOR * (z / F) ** 2, rel=1e-9)


@pytest.mark.parametrize("tilt", [10.0, 30.0, 45.0])
def test_a_forward_tilt_gives_the_trapezoid_of_tan_theta_plus_minus_beta(tilt: float) -> None:
    z = 100.0
    c = footprint_corners(photos(0.0, -90.0 + tilt), Optics.of(CAM, "landscape"), 0.0)[0]
    beta = math.atan(H_SENSOR / 2 / F)
    near, far = z * math.tan(math.radians(tilt) - beta), z * math.tan(math.radians(tilt) + beta)
    assert c[:, 1] == pytest.approx([far, far, near, near], abs=1e-9)
    # across: the ray's range to the ground over f, times the half width
    th = math.radians(tilt)
    half_far = (W / 2) * z / (F * math.cos(th) - (H_SENSOR / 2) * math.sin(th))
    half_near = (W / 2) * z / (F * math.cos(th) + (H_SENSOR / 2) * math.sin(th))
    assert c[:, 0] == pytest.approx([half_far, -half_far, -half_near, half_near], abs=1e-9)


def test_roll_tilts_to_the_right_as_pitch_does_forward() -> None:
    rolled = footprint_corners(photos(0.0, -90.0, roll=30.0), Optics.of(CAM, "portrait"), 0.0)[0]
    pitched = footprint_corners(photos(90.0, -60.0), Optics.of(CAM, "landscape"), 0.0)[0]
    # the portrait camera rolled right sees what a landscape camera facing east, tilted 30°, sees
    assert shapely.Polygon(rolled).symmetric_difference(shapely.Polygon(pitched)).area < 1e-6
    assert rolled[:, 0].min() > 0  # wholly to the right (east)


def test_gsd_is_h_p_over_f_at_nadir_and_grows_to_the_far_edge_when_tilted() -> None:
    optics = Optics.of(CAM, "landscape")
    p = W / 6000
    g = edge_gsd(photos(0.0, -90.0), optics, 0.0)
    assert g.near_m == pytest.approx(100 * p / F, rel=1e-6) and g.far_m == pytest.approx(100 * p / F, rel=1e-6)
    t = edge_gsd(photos(0.0, -60.0), optics, 0.0)
    # far edge, the top edge's middle ray at β = atan(h/2f) off the axis, θ + β from the vertical:
    # across, the range over the ray's length in the camera times p; along, d(H tan(θ + β)) for
    # the ray's turn by one pixel, dβ = p cos²β / f
    th, beta = math.radians(30), math.atan(H_SENSOR / 2 / F)
    across = 100 / math.cos(th + beta) * p / math.hypot(F, H_SENSOR / 2)
    along = 100 * p * math.cos(beta) ** 2 / (F * math.cos(th + beta) ** 2)
    assert t.far_m[0] == pytest.approx(max(across, along), rel=1e-3)
    assert t.near_m[0] < g.near_m[0] * 1.2 < t.far_m[0] and t.worst_m[0] >= t.far_m[0]


def test_a_ray_near_the_horizon_is_refused() -> None:
    with pytest.raises(ValueError, match="below it"):
        footprint_corners(photos(0.0, -20.0), Optics.of(CAM, "landscape"), 0.0)


@given(st.floats(0, 360), st.floats(-90.0, 15.0), st.sampled_from(["landscape", "portrait"]), st.floats(5.0, 300.0))
@settings(max_examples=200, deadline=None)
def test_a_photo_has_a_ground_footprint_iff_every_corner_is_5_degrees_below_the_horizon(yaw: float, pitch: float, mount: str,
                                                                                     z: float) -> None:
    """Random pitches across the threshold (about -33.7° for this camera landscape, -41.6° portrait).
    A corner ray in the camera is (x, f, y) (x across, y up the image, f along the axis); pitched
    by p it rises f·sin p + y·cos p over its length √(x² + f² + y²): its elevation. The top
    corners (y = +half the image's height) are the highest."""
    across, along = (W, H_SENSOR) if mount == "landscape" else (H_SENSOR, W)
    p = math.radians(pitch)
    top = math.degrees(math.asin((F * math.sin(p) + along / 2 * math.cos(p)) / math.hypot(across / 2, F, along / 2)))
    assume(abs(top + 5.0) > 1e-6)
    ph = Photos.looking(np.array([10.0, 10.0]), np.array([-3.0, -3.0]), np.array([z, z]), np.array([yaw, yaw]),
                        np.array([pitch, -90.0]))
    optics = Optics.of(CAM, mount)
    assert bounded_footprints(ph, optics).tolist() == [top < -5.0, True]
    if top < -5.0:
        c = footprint_corners(ph, optics, 0.0)[0]
        assert np.isfinite(c).all() and shapely.Polygon(c).area > 0
    else:
        with pytest.raises(ValueError, match="below it"):
            footprint_corners(ph, optics, 0.0)
        assert footprint_corners(ph.take(np.array([1])), optics, 0.0).shape == (1, 4, 2)


@given(st.lists(st.tuples(st.floats(0, 360), st.floats(-90.0, 15.0), st.floats(-30.0, 30.0), st.floats(5.0, 300.0)),
                min_size=0, max_size=12),
       st.sampled_from(["landscape", "portrait"]), st.floats(0.999, 1.001))
@settings(max_examples=100, deadline=None)
def test_bounded_footprint_corners_are_the_footprints_of_the_photos_that_have_one(looks, mount: str, k: float) -> None:
    """Photos looking anywhere from straight down to above the horizon, some with a footprint
    and some without (or none at all): the mask is `bounded_footprints`' and the corners are
    `footprint_corners` of exactly those photos, in their order."""
    yaw, pitch, roll, z = (np.array([t[i] for t in looks], float) for i in range(4))
    ph = Photos(np.arange(len(looks), dtype=float) * 50.0, -np.arange(len(looks), dtype=float), z, Attitudes(yaw, pitch, roll))
    optics = Optics.of(CAM, mount)
    corners, bounded = bounded_footprint_corners(ph, optics, 0.0, k)
    assert bounded.dtype == bool and bounded.tolist() == bounded_footprints(ph, optics).tolist()
    assert corners.shape == (int(bounded.sum()), 4, 2)
    assert np.array_equal(corners, footprint_corners(ph.take(np.flatnonzero(bounded)), optics, 0.0, k))


class Slope:
    """Ground rising 0.2 m a metre to the east."""

    def height(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return 0.2 * np.asarray(x, float)


def test_rays_meet_a_sloping_ground_where_the_plane_says() -> None:
    c = footprint_corners(photos(0.0, -90.0, z=100.0), Optics.of(CAM, "landscape"), Slope())[0]
    # the east corners' ray (s, ±h, -1)·t meets z = 0.2 x: 100 - t = 0.2 s t, t = 100 / (1 + 0.2 s)
    s = W / 2 / F
    t = 100 / (1 + 0.2 * s)
    assert c[0] == pytest.approx([s * t, H_SENSOR / 2 / F * t], abs=1e-3)
    t_west = 100 / (1 - 0.2 * s)
    assert c[1] == pytest.approx([-s * t_west, H_SENSOR / 2 / F * t_west], abs=1e-3)


def test_images_seeing_counts_overlapping_footprints() -> None:
    a = np.array
    ph = Photos(a([0.0, 50.0]), a([0.0, 0.0]), a([100.0, 100.0]), Attitudes.nadir(a([0.0, 0.0])))
    fps = footprint_polygons(ph, Optics.of(CAM, "landscape"), 0.0)
    counts = images_seeing(a([25.0, -60.0, 110.0, 200.0]), a([0.0, 0.0, 0.0, 0.0]), shapely.STRtree(fps))
    assert counts.tolist() == [2, 1, 1, 0]


@given(st.floats(0, 360), st.floats(-89.0, -40.0), st.floats(-20.0, 20.0), st.floats(-0.95, 0.95), st.floats(-0.95, 0.95))
@settings(max_examples=80, deadline=None)
def test_a_ground_point_projects_back_to_the_image_point_whose_ray_met_it(yaw: float, pitch: float, roll: float,
                                                                           u: float, v: float) -> None:
    ph = photos(yaw, pitch, roll, z=120.0, x=1000.0, y=-500.0)
    optics = Optics.of(CAM, "landscape")
    g = ground_points(ph, optics, np.array([[u, v]]), 0.0, grid_scale=0.9996)[0, 0]
    ip = image_points(ph, optics, np.array([g[0]]), np.array([g[1]]), 0.0, grid_scale=0.9996)
    assert ip.seen[0, 0]
    # (u, v) in half sides of the imaging area (23.5 x 15.6 mm) → pixels of 23.5/6000 mm from the
    # top-left corner of the 6000 x 4000 px image, whose centre is the principal point
    pitch_mm = 23.5 / 6000
    assert ip.col[0, 0] == pytest.approx(3000 + u * 23.5 / 2 / pitch_mm, abs=1e-6)
    assert ip.row[0, 0] == pytest.approx(2000 - v * 15.6 / 2 / pitch_mm, abs=1e-6)


def test_a_point_behind_or_beside_the_camera_is_not_seen() -> None:
    ph = photos(0.0, -45.0)
    ip = image_points(ph, Optics.of(CAM, "landscape"), np.array([0.0, 0.0, 500.0]), np.array([-50.0, 100.0, 100.0]), 0.0)
    assert ip.seen[0].tolist() == [False, True, False]
