"""The formulas of docs/planning.md against the worked numbers of the sources."""

import math

import pyproj
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aerosurvey.camera import Camera, get_camera
from aerosurvey.plan import photogrammetry as pg

RICOH = Camera("ricoh", "Ricoh GR", 23.56, 15.60, 4928, 3264, 18.3)


def test_kubad_abad_gsd_is_4_15_cm_at_159_m():
    # 000_d7f809a4ce06ca02.txt: Ricoh GR, 4.78 um, f = 18.3 mm, H = 159 m -> 4.15 cm
    assert RICOH.pixel_pitch_um == pytest.approx(4.78, abs=0.005)
    assert round(pg.gsd_from_height(159.0, RICOH) * 100, 2) == 4.15


def test_database_ricoh_matches_the_paper():
    cam = get_camera("ricoh-gr")
    assert round(pg.gsd_from_height(159.0, cam) * 100, 2) == 4.15


def test_footprint_spacing_and_base_for_80_60():
    h = 159.0
    across, along = pg.footprint(h, RICOH, "landscape")
    gsd = pg.gsd_from_height(h, RICOH)
    # the smaller of N * GSD and sensor size * H / f (Ricoh: 15.60 mm < 3264 * 4.7808 um)
    assert across == pytest.approx(min(4928 * gsd, 23.56 * h / 18.3))
    assert along == pytest.approx(15.60 * h / 18.3)
    assert along < 3264 * gsd
    safety = 1 - pg.SAFETY
    assert pg.line_spacing(across, 0.6) == pytest.approx(0.4 * across * safety)
    assert pg.trigger_distance(along, 0.8) == pytest.approx(0.2 * along * safety)
    pa, pl = pg.footprint(h, RICOH, "portrait")
    assert (pa, pl) == pytest.approx((along, across))


def test_speed_limits_and_reason():
    cam = Camera("c", "c", 23.5, 15.6, 6000, 4000, 16.0, min_cycle_s=2.0, exposure_s=1 / 500)
    gsd = 0.02
    base = 20.0
    lim = pg.survey_speed(15.0, base, gsd, cam, max_blur_px=0.5)
    assert lim.cycle_limit_ms == pytest.approx(10.0)
    assert lim.blur_limit_ms == pytest.approx(0.5 * 0.02 * 500)
    assert lim.speed_ms == pytest.approx(5.0)
    assert lim.reason == "motion blur"
    assert pg.trigger_interval(base, 5.0) == pytest.approx(4.0)


@pytest.mark.parametrize("overlap,count", [(0.0, 1), (0.5, 2), (0.6, 2), (0.75, 4), (0.8, 5), (0.9, 10)])
def test_images_per_point(overlap, count):
    assert pg.images_per_point(overlap) == count


def test_plane_turn_radius():
    # v = 18 m/s, 30 deg bank: R = 324 / (9.80665 * tan 30) = 57.2 m
    assert pg.turn_radius(18.0, 30.0) == pytest.approx(57.22, abs=0.01)


@given(st.floats(1.0, 500.0))
def test_height_gsd_round_trip(h):
    assert pg.height_from_gsd(pg.gsd_from_height(h, RICOH), RICOH) == pytest.approx(h)


@given(st.floats(0.0, 0.94), st.floats(0.0, 0.94))
def test_images_per_point_is_what_the_spacing_gives(side, fwd):
    # k photos of base B = L(1-o) fit in one footprint length L: k*B <= L + eps
    for o in (side, fwd):
        k = pg.images_per_point(o)
        assert k * (1 - o) <= 1 + 1e-9
        assert (k + 1) * (1 - o) > 1 - 1e-9
        assert math.floor(1 / (1 - o) + 1e-9) == k


@settings(max_examples=200, deadline=None)
@given(lat=st.floats(-85, 85), lon=st.floats(-180, 180), bearing=st.floats(0, 360), dist=st.floats(1, 5000))
def test_ardupilot_distance_is_ardupilots_flat_earth(lat: float, lon: float, bearing: float, dist: float) -> None:
    """pg.ardupilot_distance_m against the independent transcription of Location::get_distance
    (tests/ardupilot_location.py, on unrounded degrees), across the antimeridian too."""
    from ardupilot_location import metres_per_ground_metre

    lon2, lat2, _ = pyproj.Geod(ellps="WGS84").fwd(lon, lat, bearing, dist)
    want = metres_per_ground_metre(lat, lon, lat2, lon2, 1.0)
    assert float(pg.ardupilot_distance_m(lon, lat, lon2, lat2)) == pytest.approx(want, rel=1e-9, abs=1e-9)
    # and it differs from the ground's by at most what the docs say (0.67 % north-south at the equator)
    assert abs(want / dist - 1.0) < 0.0068
