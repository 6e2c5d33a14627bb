"""The rules measure photos by the planner's own formulas: GSD and footprint from the
manifest's camera section equal aerosurvey.plan.photogrammetry's for every camera."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from aerosurvey.camera import database
from aerosurvey.errors import InputError
from aerosurvey.inputs import plan_from_files
from aerosurvey.plan import photogrammetry as pg
from aerosurvey.rules.footprints import ViewCamera, footprints, forward_overlaps
from aerosurvey.rules.load import plan_documents
from aerosurvey.rules.planview import PlanView
from aerosurvey.spec import load_spec
from conftest import make_spec

CAMERAS = sorted(database())
MOUNTS = ("landscape", "portrait")


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    """(spec, plan) of a small block."""
    spec = load_spec(make_spec(tmp_path_factory.mktemp("fp")))
    return spec, plan_from_files(spec)


def _view(planned, cam_id: str, mount: str) -> PlanView:
    """The rules' view of the plan flown with another camera: its manifest written by the manifest writer."""
    spec, plan = planned
    camera = dataclasses.replace(plan.camera, camera=database()[cam_id], mount=mount)
    manifest, features = plan_documents(dataclasses.replace(plan, camera=camera), spec)
    view = PlanView.from_documents(json.loads(json.dumps(manifest)), features, "test")
    # heights over the whole range a survey flies, not only this plan's one height
    return dataclasses.replace(view, agl=np.linspace(15.0, 500.0, len(view.x)))


@pytest.mark.parametrize("mount", MOUNTS)
@pytest.mark.parametrize("cam_id", CAMERAS)
def test_rules_footprint_is_the_planners(planned, cam_id, mount):
    view = _view(planned, cam_id, mount)
    plan = planned[1]
    cam = database()[cam_id]
    across, along = pg.footprint(view.agl, cam, mount)
    fp = footprints(view)
    k = plan.site.grid_scale
    # the manifest rounds the grid scale to 1e-9; the planner's rule and the old sensor-size
    # rule differ by up to 0.3 % (DJI Zenmuse P1: 5460 px x 4.38 um = 23.93 mm, sensor 24 mm)
    np.testing.assert_allclose(fp.across, np.asarray(across) * k, rtol=2e-9)
    np.testing.assert_allclose(fp.along, np.asarray(along) * k, rtol=2e-9)
    np.testing.assert_array_equal(ViewCamera.of(view).gsd_m(view.agl, view.pitch_deg), pg.gsd_from_height(view.agl, cam))


@pytest.mark.parametrize("mount", MOUNTS)
@pytest.mark.parametrize("cam_id", CAMERAS)
def test_plain_number_formulas_equal_the_camera_ones(cam_id, mount):
    cam = database()[cam_id]
    heights = np.linspace(5.0, 800.0, 97)
    args = (cam.sensor_width_mm, cam.sensor_height_mm, cam.image_width_px, cam.image_height_px, cam.focal_mm, mount)
    for h in (heights, 87.3):
        np.testing.assert_array_equal(pg.footprint_m(h, *args), pg.footprint(h, cam, mount))
        np.testing.assert_array_equal(pg.gsd_m(h, pg.pixel_pitch_mm(cam.sensor_width_mm, cam.image_width_px), cam.focal_mm),
                                      pg.gsd_from_height(h, cam))


def test_footprint_takes_the_smaller_of_pixels_and_published_sensor():
    # 8192 x 5460 px on a "35.9 x 24 mm" sensor: 5460 px x 4.382 um = 23.93 mm across the short side
    across, along = pg.footprint_m(100.0, 35.9, 24.0, 8192, 5460, 35.0, "landscape")
    assert across == pytest.approx(35.9 * 100.0 / 35.0)
    assert along == pytest.approx(5460 * 35.9 / 8192 * 100.0 / 35.0)
    assert along < 24.0 * 100.0 / 35.0
    assert pg.footprint_m(100.0, 35.9, 24.0, 8192, 5460, 35.0, "portrait") == (along, across)
    with pytest.raises(ValueError, match="mount"):
        pg.footprint_m(100.0, 35.9, 24.0, 8192, 5460, 35.0, "sideways")


def test_unknown_mount_in_a_manifest_is_an_input_error(planned):
    view = _view(planned, "sony-a6000-16mm", "landscape")
    view.manifest["camera"]["mount"] = "Portrait"
    with pytest.raises(InputError, match="camera.mount = 'Portrait'"):
        footprints(view)


def test_level_photos_count_for_no_ground_point(planned):
    """Photos whose image reaches the horizon (every third turned level, pitch 0) have no ground
    footprint: the rules' footprints drop them by index, every count is the count of the others'
    nadir rectangles (made here from the station, the heading and the planner's footprint size),
    and the overlaps are measured among the others only."""
    spec, plan = planned
    manifest, features = plan_documents(plan, spec)
    nadir = PlanView.from_documents(json.loads(json.dumps(manifest)), features, "test")
    level = np.arange(len(nadir.x)) % 3 == 1
    view = dataclasses.replace(nadir, pitch_deg=np.where(level, 0.0, nadir.pitch_deg))
    fp = footprints(view)
    np.testing.assert_array_equal(fp.station, np.flatnonzero(~level))
    k = plan.site.grid_scale
    across, along = (np.asarray(a, float) * k for a in pg.footprint(view.agl, spec.camera.camera, spec.camera.mount))
    rng = np.random.default_rng(7)
    px = rng.uniform(view.x.min(), view.x.max(), 300)
    py = rng.uniform(view.y.min(), view.y.max(), 300)
    # each point in the frame of each photo's image: across (right) and along (its top) the heading
    h = np.radians(np.asarray(view.camera_yaw_deg, float))[:, None]
    dx, dy = px[None, :] - np.asarray(view.x)[:, None], py[None, :] - np.asarray(view.y)[:, None]
    inside = ((np.abs(dx * np.cos(h) - dy * np.sin(h)) < across[:, None] / 2 - 1e-6)
              & (np.abs(dx * np.sin(h) + dy * np.cos(h)) < along[:, None] / 2 - 1e-6))
    edge = ((np.abs(np.abs(dx * np.cos(h) - dy * np.sin(h)) - across[:, None] / 2) < 1e-3)
            | (np.abs(np.abs(dx * np.sin(h) + dy * np.cos(h)) - along[:, None] / 2) < 1e-3)).any(axis=0)
    want = inside[~level].sum(axis=0)
    np.testing.assert_array_equal(fp.count_at(px, py)[~edge], want[~edge])
    assert (want < inside.sum(axis=0)).any()  # some points lost a level photo
    overlaps = dict(forward_overlaps(view, fp))
    assert overlaps and all(np.isfinite(v) for v in overlaps.values())
    # two photos a base apart either side of a level one: 1 − 2·base / along
    assert min(overlaps.values()) == pytest.approx(1 - 2 * plan.sensor.base_m * k / along.min(), abs=0.01)
