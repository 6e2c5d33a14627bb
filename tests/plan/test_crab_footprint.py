"""A camera fixed to a plane's body (camera.gimbal = "body") in a crosswind: the plane flies its lines
with the nose turned into the wind by the crab angle, and the photos turn with it. Checked here with
footprints computed in the test: each photo the sensor's rectangle on the ground (sensor size × height /
focal length), turned by asin(crosswind / air speed). The side overlap of neighbours on two lines, and the
forward overlap of two photos a base apart on one line, is the share of a photo's ground its neighbour
sees too (in still air 1 − spacing / footprint width, the targets' own definition)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import shapely
from click.testing import CliRunner
from tests.conftest import make_spec

from aerosurvey.cli import main
from aerosurvey.inputs import plan_from_files
from aerosurvey.spec import load_spec

AREA = [[15.0, 49.4], [15.02, 49.4], [15.02, 49.41], [15.0, 49.41], [15.0, 49.4]]
SIDE = 0.6
FORWARD = 0.75


def _spec(tmp_path, gimbal: str | None, wind: dict | None):
    over: dict = {"vehicle": {"type": "plane", "cruise_speed_ms": 18.0}, "targets": {"gsd_cm": 2.5, "side_overlap": SIDE,
                                                                                     "forward_overlap": FORWARD},
                  "flight": {"heading": 90.0}}  # lines east-west (grid), across a wind from the north
    if gimbal is not None:
        over["camera"] = {"gimbal": gimbal}
    if wind is not None:
        over["conditions"] = {"wind": wind}
    return make_spec(tmp_path, over, area=AREA)


def _photo(across: float, along: float, crab_deg: float, x: float, y: float) -> shapely.Polygon:
    """A photo on the ground centred at (x, y), the track along +x, turned by crab_deg about its centre."""
    c = math.radians(crab_deg)
    rect = np.array([(-along / 2, -across / 2), (along / 2, -across / 2), (along / 2, across / 2), (-along / 2, across / 2)])
    return shapely.Polygon(rect @ np.array([[math.cos(c), math.sin(c)], [-math.sin(c), math.cos(c)]]) + (x, y))


def _overlap(a: shapely.Polygon, b: shapely.Polygon) -> float:
    """The share of photo a's ground that photo b sees too (in still air, side by side: 1 − spacing / across)."""
    return float(shapely.intersection(a, b).area / a.area)


def _ground_footprint(plan) -> tuple[float, float]:
    """The sensor's rectangle on the ground at the lowest height above it, landscape: the long side across."""
    cam, h = plan.camera.camera, plan.sensor.heights.spacing_agl_m
    return cam.sensor_width_mm * h / cam.focal_mm, cam.sensor_height_mm * h / cam.focal_mm


def test_a_body_fixed_camera_keeps_its_side_overlap_under_the_crab(tmp_path):
    (tmp_path / "crab").mkdir()
    (tmp_path / "calm").mkdir()
    wind = {"speed_ms": 7.0, "from_deg": 0.0}
    plan = plan_from_files(load_spec(_spec(tmp_path / "crab", None, wind)))  # a plane's camera: body-fixed by default
    still = plan_from_files(load_spec(_spec(tmp_path / "calm", None, None)))
    air = plan.sensor.speed.speed_ms
    # the wind from grid north at the area (within the meridian convergence, a fraction of a degree): across the lines
    crab = math.degrees(math.asin(wind["speed_ms"] / air))
    [p] = [p for p in plan.layout.passes if not p.empty]
    assert plan.crab_deg(p) == pytest.approx(crab, abs=0.5)
    across, along = _ground_footprint(plan)
    here = _photo(across, along, crab, 0.0, 0.0)
    for turned in (crab, -crab):  # the neighbouring line flown back (the nose into the same wind: turned the other way), or the same way
        assert _overlap(here, _photo(across, along, turned, 0.0, plan.sensor.spacing_m)) >= SIDE
        # the still-air spacing under the same crab: the side overlap falls short (so the check above can fail)
        assert _overlap(here, _photo(across, along, turned, 0.0, still.sensor.spacing_m)) < SIDE - 0.05
    # along the line: the next photo, a base on, turned alike
    assert _overlap(here, _photo(across, along, crab, plan.sensor.base_m, 0.0)) >= FORWARD
    assert _overlap(here, _photo(across, along, crab, still.sensor.base_m, 0.0)) < FORWARD - 0.02
    # in still air the measure is the target's own: 1 − spacing / across
    flat = _photo(across, along, 0.0, 0.0, 0.0)
    assert _overlap(flat, _photo(across, along, 0.0, 0.0, still.sensor.spacing_m)) == pytest.approx(SIDE, abs=2e-3)


def test_a_stabilised_camera_and_a_copter_do_not_crab(tmp_path):
    wind = {"speed_ms": 7.0, "from_deg": 0.0}
    (tmp_path / "stab").mkdir()
    (tmp_path / "calm").mkdir()
    stab = plan_from_files(load_spec(_spec(tmp_path / "stab", "stabilised", wind)))
    calm = plan_from_files(load_spec(_spec(tmp_path / "calm", None, None)))
    assert stab.sensor.spacing_m == calm.sensor.spacing_m
    assert all(stab.crab_deg(p) is None for p in stab.layout.passes)


def test_the_manifest_and_summary_give_the_crab(tmp_path):
    spec = _spec(tmp_path, "body", {"speed_ms": 7.0, "from_deg": 0.0})
    out = tmp_path / "out"
    r = CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)])
    assert r.exit_code == 0, r.output
    m = json.loads((out / "manifest.json").read_text())
    assert m["camera"]["gimbal"] == "body"
    [p] = m["pattern"]["passes"]
    assert 20.0 < p["crab_deg"] < 40.0
    assert p["line_spacing_m"] == pytest.approx(m["derived"]["line_spacing_m"])
    assert f"pass 1: {p['crab_deg']:.1f} deg" in r.output


def test_a_bad_gimbal_is_refused_in_one_line(tmp_path):
    r = CliRunner().invoke(main, ["plan", str(_spec(tmp_path, "wobbly", None)), "-o", str(tmp_path / "o")])
    assert r.exit_code == 2
    assert "camera.gimbal" in r.output and "'wobbly'" in r.output and "body, stabilised" in r.output
