"""Oblique blocks: random areas planned as a double grid or in five directions, judged from the
exported `.waypoints` files with a tilted-camera model written here (no planner code).

The photos are where ArduPilot takes them (tests/independent_coverage.py replays the distance
trigger); each photo's camera attitude is the last DO_MOUNT_CONTROL before its run's camera-on
(pitch below the horizon, yaw relative to the nose) and the vehicle's heading along its leg.
Its footprint is where the rays through the image's corners meet flat ground, worked out here
with the camera's axes (forward, right, down) rather than rotation matrices. Every sampled point
of the area must be seen by ⌊1/(1−side)⌋·⌊1/(1−forward)⌋ photos of every pass, as an area grid
promises at nadir.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as hs

import independent_coverage as ic
import independent_legs as il
from aerosurvey.inputs import plan_from_files
from aerosurvey.outputs import write_outputs
from aerosurvey.spec import load_spec

EXAMPLES = int(os.environ.get("AEROSURVEY_OBLIQUE_EXAMPLES", "6"))
DO_MOUNT_CONTROL, DO_SET_CAM_TRIGG_DIST = 205, 206
ORIGIN = (15.3, 49.5)
LOCAL = il.Local(*ORIGIN)


def trapezoid(x: float, y: float, h: float, bearing_deg: float, pitch_deg: float, tan_x: float, tan_y: float) -> shapely.Polygon:
    """Flat-ground footprint of a camera `h` above (x, y) looking towards `bearing_deg`, `pitch_deg`
    (−90 down); tan_x, tan_y: the tangents of half the field of view across and along the image."""
    b = math.radians(bearing_deg)
    t = math.radians(90.0 + pitch_deg)  # off the vertical
    fwd = np.array([math.sin(b), math.cos(b)])
    right = np.array([math.cos(b), -math.sin(b)])
    pts = []
    for u, v in ((1, 1), (-1, 1), (-1, -1), (1, -1)):
        down = math.cos(t) - v * tan_y * math.sin(t)
        horizontal = (math.sin(t) + v * tan_y * math.cos(t)) * fwd + u * tan_x * right
        assert down > 0, "a corner ray above the horizon"
        pts.append(np.array([x, y]) + horizontal * h / down)
    return shapely.Polygon(pts)


def judge(out: Path, area_local: shapely.Geometry) -> tuple[dict[int, int], list[str]]:
    """(the fewest photos of each pass seeing a sampled point of the area, problems)."""
    manifest = json.loads((out / "manifest.json").read_text())
    cam = manifest["camera"]
    (sw, sh), f = cam["sensor_mm"], cam["focal_mm"]
    tan_x, tan_y = (sw / 2 / f, sh / 2 / f) if cam["mount"] == "landscape" else (sh / 2 / f, sw / 2 / f)
    files = sorted(out.glob("sortie-*.waypoints")) or [out / "mission.waypoints"]
    polys, passes = [], []
    stations = manifest["stations"]
    k = 0
    problems = []
    for path in files:
        home, rows = ic.read_wpl(path)
        photos = ic.replay_triggers(rows, LOCAL.fwd, None, home[2])
        mounts, pitch, yaw = [], -90.0, 0.0  # the camera's attitude at each camera-on, in order
        for r in rows:
            if int(r[3]) == DO_MOUNT_CONTROL:
                pitch, yaw = r[4], r[6]
            elif int(r[3]) == DO_SET_CAM_TRIGG_DIST and r[4] > 0:
                mounts.append((pitch, yaw))
        for i in range(len(photos.x)):
            p, y = mounts[photos.run[i]]
            heading = 90.0 - math.degrees(photos.heading[i])  # compass bearing of the flight
            polys.append(trapezoid(photos.x[i], photos.y[i], photos.agl[i], heading + y, p, tan_x, tan_y))
            passes.append(int(stations[k]["id"].split("-")[0][1:]) if k < len(stations) else -1)
            k += 1
    if k != len(stations):
        problems.append(f"ArduPilot takes {k} photos, the manifest lists {len(stations)}")
    gx, gy = ic.grid_inside(area_local, 50)
    fewest = {}
    for pas in sorted(set(passes)):
        tree = shapely.STRtree([g for g, q in zip(polys, passes) if q == pas])
        counts = np.bincount(tree.query(shapely.points(gx, gy), predicate="within")[0], minlength=len(gx))
        fewest[pas] = int(counts.min())
    return fewest, problems


def _plan(folder: Path, area_local: shapely.Geometry, scheme: str, pitch: float, heading: float) -> Path:
    ll = shapely.transform(area_local, lambda a: np.column_stack(LOCAL.inv.transform(a[:, 0], a[:, 1])))
    (folder / "area.geojson").write_text(shapely.to_geojson(ll))
    (folder / "spec.toml").write_text(f"""
[mission]
name = "oblique"
[area]
file = "area.geojson"
[pattern]
kind = "oblique"
scheme = "{scheme}"
pitch_deg = {pitch}
[camera]
model = "sony-a6000-16mm"
trigger = "distance"
[targets]
height_m = 60
forward_overlap = 0.75
side_overlap = 0.6
[vehicle]
type = "copter"
cruise_speed_ms = 8.0
[flight]
heading = {heading}
""")
    out = folder / "out"
    loaded = load_spec(folder / "spec.toml")
    write_outputs(plan_from_files(loaded), loaded, out)
    return out


@pytest.mark.slow
@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
          phases=[Phase.explicit, Phase.reuse, Phase.generate])
@given(w=hs.floats(60, 300), h=hs.floats(60, 300), notch=hs.booleans(), scheme=hs.sampled_from(["double-grid", "five-direction"]),
       pitch=hs.sampled_from([-35.0, -45.0, -60.0]), heading=hs.floats(0, 179))
def test_every_pass_sees_the_area_with_the_asked_overlaps(tmp_path_factory: pytest.TempPathFactory, w: float, h: float,
                                                          notch: bool, scheme: str, pitch: float, heading: float) -> None:
    area = shapely.box(0, 0, w, h)
    if notch:
        area = shapely.difference(area, shapely.box(w / 3, h / 2, 2 * w / 3, h + 1))
    folder = tmp_path_factory.mktemp("oblique")
    out = _plan(folder, area, scheme, pitch, heading)
    fewest, problems = judge(out, area)
    want = 2 * 4  # ⌊1/(1 − 0.6)⌋ strips × ⌊1/(1 − 0.75)⌋ photos
    assert not problems, problems
    assert len(fewest) == (2 if scheme == "double-grid" else 5)
    assert all(n >= want for n in fewest.values()), f"fewest photos a pass sees a point with: {fewest} (files in {folder})"


def test_the_gimbal_items_carry_each_pass_attitude(tmp_path: Path) -> None:
    out = _plan(tmp_path, shapely.box(0, 0, 150, 120), "five-direction", -45.0, 0.0)
    _, rows = ic.read_wpl(out / "mission.waypoints")
    seen = {(round(r[4]), round(r[6]) % 360) for r in rows if int(r[3]) == DO_MOUNT_CONTROL}
    # the nadir pass flies first with the mount as it starts (straight down); the obliques then
    # look along the lines and at 90°, 180°, 270° from them (yaw relative to the nose)
    assert {p for p, _ in seen} <= {-90, -45}
    assert {y for p, y in seen if p == -45} == {0, 90, 180, 270}


def test_a_pitch_whose_image_reaches_the_horizon_is_refused(tmp_path: Path) -> None:
    from aerosurvey.errors import InputError

    with pytest.raises(InputError, match=r"pattern.pitch_deg = -30 .* allowed with this camera and mount: -32 or lower"):
        _plan(tmp_path, shapely.box(0, 0, 100, 100), "double-grid", -30.0, 0.0)


def test_the_far_edge_gsd_is_a_limit_the_plan_keeps(tmp_path: Path) -> None:
    """At 60 m and −45° the far edge of the a6000's image lies at 60·tan(45° + 26.0°) on flat
    ground, 174 m out along the ray's 184 m: its GSD there (≈ 4.6 cm at the image's middle, more
    at the corners) is over a 4 cm limit, and the refusal names the height that keeps it."""
    from aerosurvey.errors import InputError

    out = _plan(tmp_path, shapely.box(0, 0, 100, 100), "double-grid", -45.0, 0.0)
    far = json.loads((out / "manifest.json").read_text())
    spec = tmp_path / "spec.toml"
    spec.write_text(spec.read_text().replace('pitch_deg = -45.0', 'pitch_deg = -45.0\nmax_far_gsd_cm = 4.0'))
    with pytest.raises(InputError, match=r"pattern.max_far_gsd_cm = 4: .* fly at most [0-9.]+ m high"):
        loaded = load_spec(spec)
        write_outputs(plan_from_files(loaded), loaded, tmp_path / "again")
    assert far["stations"]
