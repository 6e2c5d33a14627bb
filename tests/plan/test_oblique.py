"""Oblique blocks: random areas planned as a double grid or in five directions, judged from the
exported `.waypoints` files with a tilted-camera model written here (no planner code).

The photos are where ArduPilot takes them (tests/independent_coverage.py replays the distance
trigger); each photo's camera attitude is the last DO_MOUNT_CONTROL before its run's camera-on
(pitch below the horizon, yaw relative to the nose) and the vehicle's heading along its leg.
Its footprint is where the rays through the image's corners meet flat ground, worked out here
with the camera's axes (forward, right, down) rather than rotation matrices. Every sampled point
of the area must be seen by ⌊1/(1−side)⌋·⌊1/(1−forward)⌋ photos of every pass, as an area grid
promises at nadir, and of every look (the photos of one pass looking one way, what reconstruction
matches), whose neighbours must overlap as asked (by the planner's rectangle, near-edge width by
depth, and by area). A photo with no gimbal command before it is a failure: every flight sets
the camera's aim at its start.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
import shapely
import shapely.affinity
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


@dataclass(frozen=True)
class Shot:
    """A photo as ArduPilot takes it from the exported mission: where, its footprint, its pass (from
    the manifest's station ids, in order), its look (a compass bearing; None straight down) and pitch."""

    x: float
    y: float
    flight_deg: float  # compass bearing of the flight
    look_deg: float | None
    pitch: float
    run: int  # the trigger-on block, counted over the files
    pass_index: int
    footprint: shapely.Polygon


def shots(out: Path) -> tuple[list[Shot], list[str]]:
    """(every photo of the plan in `out`, as its sortie files fly it; problems)."""
    manifest = json.loads((out / "manifest.json").read_text())
    cam = manifest["camera"]
    (sw, sh), f = cam["sensor_mm"], cam["focal_mm"]
    tan_x, tan_y = (sw / 2 / f, sh / 2 / f) if cam["mount"] == "landscape" else (sh / 2 / f, sw / 2 / f)
    files = sorted(out.glob("sortie-*.waypoints")) or [out / "mission.waypoints"]
    stations = manifest["stations"]
    found: list[Shot] = []
    runs = 0
    for path in files:
        home, rows = ic.read_wpl(path)
        photos = ic.replay_triggers(rows, LOCAL.fwd, None, home[2])
        mounts, pitch, yaw = [], math.nan, math.nan  # the camera's attitude at each camera-on, in order
        for r in rows:
            if int(r[3]) == DO_MOUNT_CONTROL:
                pitch, yaw = r[4], r[6]
            elif int(r[3]) == DO_SET_CAM_TRIGG_DIST and r[4] > 0:
                mounts.append((pitch, yaw))
        for i in range(len(photos.x)):
            p, y = mounts[photos.run[i]]
            assert math.isfinite(p), f"{path.name}: a photo with no gimbal command before it"
            heading = (90.0 - math.degrees(photos.heading[i])) % 360.0  # compass bearing of the flight
            k = len(found)
            found.append(Shot(photos.x[i], photos.y[i], heading, None if p == -90 else (heading + y) % 360.0, p,
                              runs + int(photos.run[i]),
                              int(stations[k]["id"].split("-")[0][1:]) if k < len(stations) else -1,
                              trapezoid(photos.x[i], photos.y[i], photos.agl[i], heading + y, p, tan_x, tan_y)))
        runs += len(mounts)
    problems = [] if len(found) == len(stations) else [f"ArduPilot takes {len(found)} photos, the manifest lists {len(stations)}"]
    return found, problems


def _fewest(found: list[Shot], area_local: shapely.Geometry, key) -> dict:
    """The fewest photos of each group (`key`) that see a sampled point of the area."""
    gx, gy = ic.grid_inside(area_local, 50)
    fewest = {}
    for g in sorted({key(s) for s in found}, key=str):
        tree = shapely.STRtree([s.footprint for s in found if key(s) == g])
        counts = np.bincount(tree.query(shapely.points(gx, gy), predicate="within")[0], minlength=len(gx))
        fewest[g] = int(counts.min())
    return fewest


def look(s: Shot) -> tuple[int, float, int | None]:
    """A photo's look group: its pass, pitch and look bearing (to 10°; one group straight down)."""
    return s.pass_index, s.pitch, None if s.look_deg is None else round(s.look_deg / 10.0) * 10 % 360


def rectangle(s: Shot) -> tuple[float, float, np.ndarray, np.ndarray]:
    """The rectangle a photo surely holds, by the planner's definition written here: its trapezoid's
    near-edge width across the image by its depth (near edge to far edge) along it; with the unit
    vectors of the image's across and along directions on the ground."""
    c = np.asarray(s.footprint.exterior.coords)[:4]  # far-right, far-left, near-left, near-right
    near = float(np.hypot(*(c[3] - c[2])))
    right = (c[3] - c[2]) / near
    fwd = np.array([-right[1], right[0]])
    depth = float(((c[0] + c[1]) / 2 - (c[2] + c[3]) / 2) @ fwd)
    return near, depth, right, fwd


def neighbour_overlaps(found: list[Shot], area_local: shapely.Geometry) -> dict[str, list[float]]:
    """For each look group: the overlaps of neighbouring same-look photos, along a run (forward) and
    with the nearest same-look photo on the next line on either side (side), by the planner's
    rectangle (1 − the offset over the rectangle's extent that way) and by area (the footprints'
    intersection over one footprint; sideways with the offset along the line taken out). A side
    pair whose midpoint lies outside the area (two lines across a notch) is left out."""
    out: dict[str, list[float]] = {"forward": [], "forward_area": [], "side": [], "side_area": []}
    for g in {look(s) for s in found}:
        group = [s for s in found if look(s) == g]
        xy = np.array([(s.x, s.y) for s in group])
        b = math.radians(group[0].flight_deg)
        u = np.array([math.sin(b), math.cos(b)])  # along the lines
        n = np.array([u[1], -u[0]])
        near, depth, right, _ = rectangle(group[0])
        along_line = near if abs(float(right @ u)) > 0.5 else depth  # the rectangle's extent along the line
        across_line = depth if along_line == near else near
        a, c = xy @ u, xy @ n
        run = np.array([s.run for s in group])
        for i in range(len(group)):
            j = i + 1
            if j < len(group) and run[j] == run[i]:
                d = abs(a[j] - a[i])
                out["forward"].append(1.0 - d / along_line)
                out["forward_area"].append(group[i].footprint.intersection(group[j].footprint).area / group[i].footprint.area)
            for side in (1.0, -1.0):
                other = np.flatnonzero((run != run[i]) & ((c - c[i]) * side > 1.0) & (np.abs(a - a[i]) < along_line / 2))
                if not len(other):
                    continue
                k = other[np.argmin(np.abs(c[other] - c[i]))]
                if not area_local.contains(shapely.Point(*(xy[i] + xy[k]) / 2)):
                    continue
                out["side"].append(1.0 - abs(c[k] - c[i]) / across_line)
                moved = shapely.affinity.translate(group[k].footprint, *(-(a[k] - a[i]) * u))
                out["side_area"].append(group[i].footprint.intersection(moved).area / group[i].footprint.area)
    return out


def write_area(folder: Path, area_local: shapely.Geometry) -> str:
    """The area (local metres) as `folder`/area.geojson; the spec's [mission] and [area] tables naming it."""
    ll = shapely.transform(area_local, lambda a: np.column_stack(LOCAL.inv.transform(a[:, 0], a[:, 1])))
    (folder / "area.geojson").write_text(shapely.to_geojson(ll))
    return f'[mission]\nname = "{folder.name}"\n[area]\nfile = "area.geojson"\n'


def _plan(folder: Path, area_local: shapely.Geometry, scheme: str, pitch: float, heading: float) -> Path:
    (folder / "spec.toml").write_text(write_area(folder, area_local) + f"""
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
def test_every_pass_and_every_look_sees_the_area_with_the_asked_overlaps(
        tmp_path_factory: pytest.TempPathFactory, w: float, h: float, notch: bool, scheme: str, pitch: float,
        heading: float) -> None:
    """Every pass sees every point of the area 2 × 4 times (⌊1/(1 − 0.6)⌋ strips × ⌊1/(1 − 0.75)⌋
    photos); and so do the photos looking the same way (one pass, one pitch, one look bearing: what
    reconstruction matches), whose neighbours overlap by the asked 60 % sideways and 75 % forward,
    by the rectangle and by area."""
    area = shapely.box(0, 0, w, h)
    if notch:
        area = shapely.difference(area, shapely.box(w / 3, h / 2, 2 * w / 3, h + 1))
    folder = tmp_path_factory.mktemp("looks")
    found, problems = shots(_plan(folder, area, scheme, pitch, heading))
    assert not problems, problems
    passes = _fewest(found, area, lambda s: s.pass_index)
    assert len(passes) == (2 if scheme == "double-grid" else 5)
    assert all(n >= 2 * 4 for n in passes.values()), f"fewest photos a pass sees a point with: {passes} (files in {folder})"
    fewest = _fewest(found, area, look)
    assert len(fewest) == (4 if scheme == "double-grid" else 5), fewest
    assert all(n >= 2 * 4 for n in fewest.values()), f"fewest photos a look sees a point with: {fewest} (files in {folder})"
    o = neighbour_overlaps(found, area)
    assert o["side"] and o["forward"]
    assert min(o["side"]) >= 0.6 - 0.005, (min(o["side"]), folder)
    assert min(o["side_area"]) >= 0.6 - 0.005, (min(o["side_area"]), folder)
    assert min(o["forward"]) >= 0.75 - 0.005, (min(o["forward"]), folder)
    assert min(o["forward_area"]) >= 0.75 - 0.005, (min(o["forward_area"]), folder)


def test_the_gimbal_items_carry_each_pass_attitude(tmp_path: Path) -> None:
    out = _plan(tmp_path, shapely.box(0, 0, 150, 120), "five-direction", -45.0, 0.0)
    _, rows = ic.read_wpl(out / "mission.waypoints")
    seen = {(round(r[4]), round(r[6]) % 360) for r in rows if int(r[3]) == DO_MOUNT_CONTROL}
    # the nadir pass flies first with the mount set straight down (it may be where another flight left
    # it); the obliques then look along the lines and at 90°, 180°, 270° from them (yaw relative to the nose)
    assert {p for p, _ in seen} == {-90, -45} and (-90, 0) in seen
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
