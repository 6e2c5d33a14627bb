"""The orbit pattern (structure scan), judged from the exported mission alone.

A box tower and an L-shaped building are planned end to end through the command line. From
`mission.waypoints` (parsed here; the distance trigger replayed by tests/independent_coverage.py)
each photo's place, height and aim are rebuilt from the mount's setting on the leg it is taken on
(`_photos`: a yaw relative to the nose, a copter facing along its track; a compass bearing; or
a region of interest). The ray caster of tests/independent_faces.py (shared by nothing in src/) samples
the structure's walls and roof on its own grid and counts the photos that see each sample with a
GSD on the face at most [structure] max_gsd_cm, the GSD found here by meeting the rays through
the neighbouring pixels with the face's plane. Judged:

- every face sample is seen by at least `min_images` such photos (samples a ray only grazes at
  an edge, where marching cannot tell, are counted only if it sees them);
- every leg of the flight (the launch point, every waypoint in order, and the return to launch)
  keeps at least `standoff_m − 2 m` (the tracking allowance) from the footprint (shapely);
- the planner's own structure-faces rule passes;
- the layers: ceil((top − base) / spacing) of them, one pass each, flown in the order asked.

A hypothesis property test does the same for random boxes and stand-offs, without a GSD limit
(a wide roof is seen from the highest ring only at a grazing angle: its GSD there is the rule's
to judge, and the rule refuses it, as one case found: a 32 × 36 m roof 6 m high, 16 m off).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pyproj
import pytest
import shapely
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from tests.conftest import make_spec, write_geojson

import independent_coverage as ic
from aerosurvey.camera import get_camera
from aerosurvey.cli import main
from independent_faces import caster, frame, prism_samples

CENTRE = (15.003, 49.40175)  # inside make_spec's area
ALLOWANCE_M = 2.0
MOUNT_CONTROL, RTL, GIMBAL_PITCHYAW, ROI, ROI_NONE = 205, 20, 1000, 195, 197
YAW_LOCK = 16  # GIMBAL_MANAGER_FLAGS
CAMERA = "dji-mavic-3-enterprise"
TO_XY = ic.local_projection(*CENTRE)
TO_LONLAT = pyproj.Transformer.from_crs(TO_XY.target_crs, "EPSG:4326", always_xy=True)


def _run(*args: object) -> tuple[int, str]:
    res = CliRunner().invoke(main, [str(a) for a in args])
    return res.exit_code, res.output


def _lonlat(xy: np.ndarray) -> list[list[float]]:
    lon, lat = TO_LONLAT.transform(xy[:, 0], xy[:, 1])
    return [[float(a), float(b)] for a, b in zip(lon, lat)]


def _box(w: float, d: float, turn_deg: float = 0.0) -> shapely.Polygon:
    return shapely.affinity.rotate(shapely.box(-w / 2, -d / 2, w / 2, d / 2), turn_deg, origin=(0, 0))


L_SHAPE = shapely.Polygon([(-20, -20), (20, -20), (20, -4), (-4, -4), (-4, 20), (-20, 20)])  # 40 × 40 m, wings 16 m


def _plan(tmp: Path, footprint: shapely.Polygon, top: float, standoff: float, max_gsd_cm: float | None = 2.0,
          **extra: object) -> tuple[Path, dict]:
    ring = np.asarray(footprint.exterior.coords)
    write_geojson(tmp / "structure.geojson", [_lonlat(ring)])
    pattern = {"kind": "orbit", "standoff_m": standoff,
               **{k: v for k, v in extra.items() if k not in ("launch", "zone", "firmware")}}
    structure = {"file": "structure.geojson", "top_m": top, **({"max_gsd_cm": max_gsd_cm} if max_gsd_cm else {})}
    over: dict = {"pattern": pattern, "structure": structure, "camera": {"model": CAMERA, "trigger": "distance"}}
    if "firmware" in extra:
        over["vehicle"] = {"firmware": extra["firmware"]}
    if "launch" in extra:
        over["area"] = {"file": "area.geojson", "launch": _lonlat(np.array([extra["launch"]]))[0]}
    if "zone" in extra:
        assert isinstance(extra["zone"], shapely.Polygon)
        write_geojson(tmp / "zone.geojson", [_lonlat(np.asarray(extra["zone"].exterior.coords))])
        over.setdefault("area", {}).update({"exclusions": ["zone.geojson"]})
    out = tmp / "out"
    code, text = _run("plan", make_spec(tmp, over), "-o", out)
    assert code == 0, text
    return out, json.loads((out / "manifest.json").read_text())


def _photos(out: Path) -> tuple[list[tuple[float, float, float, float, float]], list[list[float]], tuple]:
    """The photos (x, y, z, yaw, pitch) from the .waypoints, the rows, the home. Each photo's aim is
    the mount's setting on the leg it is taken on (ArduPilot runs the DO items after a waypoint as
    it leaves it): DO_MOUNT_CONTROL, a yaw relative to the nose (a copter faces along the leg);
    DO_GIMBAL_MANAGER_PITCHYAW with the yaw lock flag, a compass bearing; DO_SET_ROI_LOCATION,
    the camera on that point from wherever the photo is taken."""
    home, rows = ic.read_wpl(out / "mission.waypoints")
    photos = ic.replay_triggers(rows, TO_XY, None, home[2])
    # (start, end, mount on it, the trigger-on block it is flown in); the last waypoint's place
    legs, mount, at, block = [], None, None, -1
    for r in rows:
        cmd = int(r[3])
        if cmd == ic.NAV_WAYPOINT:
            here = np.array(TO_XY.transform(r[9], r[8]))
            if at is not None:
                legs.append((at, here, mount, block))
            at = here
        elif cmd == ic.DO_SET_CAM_TRIGG_DIST and r[4] > 0:
            block += 1
        elif cmd == MOUNT_CONTROL:
            mount = ("nose", r[4], r[6])  # pitch, yaw relative to the nose
        elif cmd == GIMBAL_PITCHYAW:
            assert int(r[8]) & YAW_LOCK, r
            mount = ("bearing", r[4], r[5])
        elif cmd == ROI:
            mount = ("roi", *TO_XY.transform(r[9], r[8]), r[10])
        elif cmd == ROI_NONE:
            mount = None
    starts = np.array([a for a, _, _, _ in legs])
    ends = np.array([b for _, b, _, _ in legs])
    blocks = np.array([k for _, _, _, k in legs])
    cams = []
    for x, y, z, run in zip(photos.x, photos.y, photos.agl, photos.run):
        p = np.array([x, y])
        # the leg of its block the photo lies on
        t = np.clip(np.einsum("ij,ij->i", p - starts, ends - starts) / np.maximum(np.sum((ends - starts) ** 2, 1), 1e-12), 0, 1)
        k = int(np.argmin(np.hypot(*(starts + t[:, None] * (ends - starts) - p).T) + np.where(blocks == run, 0.0, np.inf)))
        a, b, m, _ = legs[k]
        assert m is not None, "photos with the mount where the last flight left it"
        if m[0] == "nose":
            cams.append((float(x), float(y), float(z), (math.degrees(math.atan2(*(b - a))) + m[2]) % 360.0, m[1]))
        elif m[0] == "bearing":
            cams.append((float(x), float(y), float(z), m[2] % 360.0, m[1]))
        else:
            d = np.array(m[1:3]) - p
            pitch = math.degrees(math.atan2(m[3] - z, float(np.hypot(*d))))
            cams.append((float(x), float(y), float(z), math.degrees(math.atan2(d[0], d[1])) % 360.0, pitch))
    return cams, rows, home


def _face_gsd(sensor: tuple, pixel_mm: float, cam: tuple, p: np.ndarray, n: np.ndarray) -> float:
    """The larger side of a pixel at p on its face's plane: the rays through the pixel's neighbours
    met with the plane."""
    c = np.array(cam[:3])
    axis, right, top = frame(cam[3], cam[4])
    rel = p - c
    depth = rel @ axis
    u, v = sensor[2] * (rel @ right) / depth, sensor[2] * (rel @ top) / depth

    def meet(du: float, dv: float) -> np.ndarray:
        ray = sensor[2] * axis + (u + du) * right + (v + dv) * top
        return c + ray * ((p - c) @ n) / (ray @ n)

    return max(float(np.linalg.norm(meet(pixel_mm / 2, 0) - meet(-pixel_mm / 2, 0))),
               float(np.linalg.norm(meet(0, pixel_mm / 2) - meet(0, -pixel_mm / 2))))


def _judge(out: Path, footprint: shapely.Polygon, top: float, cell: float, min_images: int = 2,
           max_gsd_m: float = math.inf) -> dict:
    cams, rows, home = _photos(out)
    cam = get_camera(CAMERA)
    sensor = (cam.sensor_width_mm, cam.sensor_height_mm, cam.focal_mm)  # landscape: the long side level
    pixel = cam.sensor_width_mm / cam.image_width_px
    pts, nrm, area = prism_samples(footprint, 0.0, top, cell)
    vis, graze = caster(footprint, 0.0, top, sensor, cams, pts, nrm, samples=300)
    fine = np.zeros_like(vis)
    for a, b in zip(*np.nonzero(vis)):
        fine[a, b] = _face_gsd(sensor, pixel, cams[a], pts[b], nrm[b]) <= max_gsd_m
    counts = fine.sum(axis=0)
    sure = (fine & ~graze).sum(axis=0)
    # legs: launch → every waypoint → launch (the mission ends with RTL)
    xy = [TO_XY.transform(home[0], home[1])]
    xy += [TO_XY.transform(r[9], r[8]) for r in rows if int(r[3]) == ic.NAV_WAYPOINT]
    if int(rows[-1][3]) == RTL:
        xy.append(xy[0])
    legs = shapely.linestrings(np.stack([np.array(xy[:-1]), np.array(xy[1:])], axis=1))
    nearest = float(shapely.distance(legs, footprint).min())
    # the plan's look: each station's bearing (camera_yaw_deg) to the footprint's nearest point, which is the stand-off
    # away (less a chord's sag round a corner)
    stations = json.loads((out / "manifest.json").read_text())["stations"]
    at = np.array([TO_XY.transform(s["lon"], s["lat"]) for s in stations])
    near = np.array([shapely.ops.nearest_points(footprint, shapely.Point(p))[0].coords[0] for p in at])
    look = np.degrees(np.arctan2(near[:, 0] - at[:, 0], near[:, 1] - at[:, 1]))
    look_off = float(np.abs((np.array([s["camera_yaw_deg"] for s in stations]) - look + 180.0) % 360.0 - 180.0).max())
    # the mission's look at each photo (replayed above) against the look at the nearest point from where it is taken
    taken = np.array([c[:2] for c in cams])
    seen = np.array([shapely.ops.nearest_points(footprint, shapely.Point(p))[0].coords[0] for p in taken])
    look_there = np.degrees(np.arctan2(seen[:, 0] - taken[:, 0], seen[:, 1] - taken[:, 1]))
    aim_off = float(np.abs((np.array([c[3] for c in cams]) - look_there + 180.0) % 360.0 - 180.0).max())
    reach = np.hypot(*(near - at).T)
    return {"look_off_deg": look_off, "aim_off_deg": aim_off, "reach_m": (float(reach.min()), float(reach.max())),
            "short_m2": float(area[counts < min_images].sum()), "short_sure_m2": float(area[sure < min_images].sum()),
            "area_m2": float(area.sum()), "min_images": int(counts.min()), "nearest_leg_m": nearest, "photos": len(cams),
            "heights": sorted({round(c[2], 1) for c in cams})}


def _assert_looks_at_the_nearest_point(j: dict, standoff: float) -> None:
    """Every station looks at the footprint's nearest point (square to a wall, or at a corner), the
    stand-off away (less the chords' 0.25 m sag round a corner), and so does every photo the
    mission takes, from where it is taken."""
    assert j["look_off_deg"] < 0.05, j["look_off_deg"]
    # the mission's: ArduPilot keeps an earth-frame yaw in whole degrees
    assert j["aim_off_deg"] <= 0.5 + 0.05, j["aim_off_deg"]
    least, most = j["reach_m"]
    assert standoff - 0.25 - 0.02 <= least and most <= standoff + 0.02, j["reach_m"]


def _rule(manifest: dict) -> dict:
    return next(r for r in manifest["rules"] if r["rule"] == "structure-faces")


@pytest.mark.parametrize(("name", "footprint", "top", "standoff", "launch"), [
    ("box tower", _box(20.0, 28.0), 30.0, 15.0, None),
    ("L-shaped building", L_SHAPE, 20.0, 12.0, (10.0, -60.0)),  # launched south: the way to the north start goes round
])
def test_the_orbit_covers_the_faces_and_keeps_off_the_structure(tmp_path: Path, name: str, footprint: shapely.Polygon,
                                                                 top: float, standoff: float, launch: tuple | None) -> None:
    out, m = _plan(tmp_path, footprint, top, standoff, **({"launch": launch} if launch else {}))
    assert _rule(m)["status"] == "pass", _rule(m)
    j = _judge(out, footprint, top, 2.5, max_gsd_m=0.02)
    print(name, j)
    assert j["short_m2"] == 0.0, j
    assert j["nearest_leg_m"] >= standoff - ALLOWANCE_M, j
    _assert_looks_at_the_nearest_point(j, standoff)
    # layers: ceil(height / spacing), one pass each, bottom first
    spacing = m["pattern"]["passes"][0]["line_spacing_m"]
    layers = math.ceil(top / spacing)
    assert m["pattern"]["parameters"]["layers"] == layers == len(m["pattern"]["passes"])
    assert len(j["heights"]) == layers and j["heights"] == sorted(j["heights"])


def test_a_ring_cut_by_a_zone_is_joined_round_the_zone_and_the_structure(tmp_path: Path) -> None:
    """A zone 15 m east of a 10 m tower, its 10 m margin across the ring's east side (12 m off): each ring is flown
    in two pieces, and every leg (the joins of the pieces too: a straight one crossed the tower 3 m off its wall)
    keeps the stand-off less the allowance from the footprint and the margin from the zone; every photo looks at the
    footprint's nearest point from where it is taken (the last piece ends round the ring's first chord, as an uncut
    ring does). Flown in ArduCopter SITL: tests/test_sitl.py."""
    tower, zone, margin = _box(10.0, 10.0), shapely.box(20.0, -4.0, 40.0, 4.0), 10.0
    out, m = _plan(tmp_path, tower, 10.0, 12.0, max_gsd_cm=None, zone=zone)
    assert len(m["lines"]) == 2 * len(m["pattern"]["passes"]) == 4
    j = _judge(out, tower, 10.0, 2.5)
    print(j)
    assert j["nearest_leg_m"] >= 12.0 - ALLOWANCE_M, j
    _assert_looks_at_the_nearest_point(j, 12.0)
    home, rows = ic.read_wpl(out / "mission.waypoints")
    xy = np.array([TO_XY.transform(home[0], home[1])] + [TO_XY.transform(r[9], r[8]) for r in rows if int(r[3]) == ic.NAV_WAYPOINT])
    legs = shapely.linestrings(np.stack([xy[:-1], xy[1:]], axis=1))
    assert float(shapely.distance(legs, zone).min()) >= margin - 1e-6


def test_start_top_flies_the_layers_downwards(tmp_path: Path) -> None:
    out, _ = _plan(tmp_path, _box(20.0, 20.0), 30.0, 15.0, start="top")
    cams, _, _ = _photos(out)
    z = [c[2] for c in cams]
    assert z == sorted(z, reverse=True) and len(set(np.round(z, 1))) > 1


def test_a_level_orbit_claims_no_ground_and_sees_the_walls(tmp_path: Path) -> None:
    """pitch_deg = 0: every photo reaches the horizon, so plan.geojson writes its point (role
    "no-footprint", with the reason) and no ground polygon; the walls are covered, judged by the
    independent caster; the roof is not (a level ring does not look down on it): the
    structure-faces rule fails by no more than the roof, and `check` says so (exit 1)."""
    footprint, top = _box(20.0, 20.0), 30.0
    with pytest.raises(AssertionError, match="1 error-severity rule"):
        _plan(tmp_path, footprint, top, 15.0, pitch_deg=0.0)
    out = tmp_path / "out"
    m = json.loads((out / "manifest.json").read_text())
    assert m["pattern"]["parameters"]["pitch_deg"] == 0.0
    assert [r["rule"] for r in m["rules"] if r["status"] == "fail"] == ["structure-faces"]
    assert 0.0 < float(_rule(m)["measured"].split(" m² of ")[0]) <= footprint.area + 1.0, _rule(m)
    roles = [f["properties"] for f in json.loads((out / "plan.geojson").read_text())["features"]]
    points = [p for p in roles if p["role"] == "no-footprint"]
    assert not [p for p in roles if p["role"] == "footprint"]
    assert len(points) == len([p for p in roles if p["role"] == "station"]) > 0
    assert all(p["footprint"].startswith("none: the image reaches the horizon") for p in points)
    cams, _, _ = _photos(out)
    cam = get_camera(CAMERA)
    sensor = (cam.sensor_width_mm, cam.sensor_height_mm, cam.focal_mm)
    pts, nrm, _ = prism_samples(footprint, 0.0, top, 2.5)
    walls = np.abs(nrm[:, 2]) < 0.5
    vis, _ = caster(footprint, 0.0, top, sensor, cams, pts[walls], nrm[walls], samples=300)
    assert vis.sum(axis=0).min() >= 2, vis.sum(axis=0).min()
    code, text = _run("check", out)
    assert code == 1 and "structure-faces" in text, text


def test_an_orbit_without_a_structure_is_refused(tmp_path: Path) -> None:
    code, text = _run("plan", make_spec(tmp_path, {"pattern": {"kind": "orbit"}}), "-o", tmp_path / "out")
    assert code == 2 and "pattern.kind = 'orbit' needs a [structure] table" in text, text
    assert len(text.strip().splitlines()) == 1


@pytest.mark.parametrize(("extra", "words"), [
    ({"pitch_deg": -79.0}, "pattern.pitch_deg = -79 is not allowed"),
    ({"standoff_m": 1.0}, "pattern.standoff_m"),
    ({"start": "middle"}, "pattern.start"),
    ({"launch": (0.0, 14.0)}, "the launch point lies within the stand-off"),
])
def test_bad_orbit_settings_are_refused_naming_them(tmp_path: Path, extra: dict, words: str) -> None:
    with pytest.raises(AssertionError, match=words):
        _plan(tmp_path, _box(20.0, 20.0), 30.0, 15.0, **extra)


def test_a_layer_over_the_height_cap_is_refused_naming_the_station(tmp_path: Path) -> None:
    with pytest.raises(AssertionError, match=r"station P\d+-.*vehicle.max_height_agl_m = 120"):
        _plan(tmp_path, _box(20.0, 20.0), 110.0, 15.0)


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(w=st.floats(6.0, 40.0), d=st.floats(6.0, 40.0), turn=st.floats(0.0, 90.0), top=st.floats(6.0, 40.0),
       standoff=st.floats(6.0, 25.0))
def test_random_boxes_and_standoffs(tmp_path_factory, w: float, d: float, turn: float, top: float, standoff: float) -> None:
    tmp = tmp_path_factory.mktemp("box")
    footprint = _box(w, d, turn)
    out, m = _plan(tmp, footprint, top, standoff, max_gsd_cm=None)
    assert _rule(m)["status"] == "pass", _rule(m)
    j = _judge(out, footprint, top, math.sqrt((footprint.area + footprint.length * top) / 200.0))
    assert j["short_m2"] == 0.0, j
    assert j["nearest_leg_m"] >= standoff - ALLOWANCE_M, j
    _assert_looks_at_the_nearest_point(j, standoff)


def test_a_round_tower_given_by_its_centre_and_radius_is_covered_and_kept_off(tmp_path: Path) -> None:
    """[structure] centre and radius_m instead of a footprint file (a tank, a chimney, a round tower): judged
    against the round tower itself (a 96-sided polygon in the test's own projection, within 5 mm of the circle), not the
    plan's polygon."""
    radius, top, standoff = 9.0, 24.0, 12.0
    structure = {"centre": list(CENTRE), "radius_m": radius, "top_m": top, "max_gsd_cm": 2.0}
    over = {"pattern": {"kind": "orbit", "standoff_m": standoff}, "structure": structure,
            "camera": {"model": CAMERA, "trigger": "distance"}}
    out = tmp_path / "out"
    code, text = _run("plan", make_spec(tmp_path, over), "-o", out)
    assert code == 0, text
    m = json.loads((out / "manifest.json").read_text())
    assert _rule(m)["status"] == "pass", _rule(m)
    tower = shapely.Point(TO_XY.transform(*CENTRE)).buffer(radius, quad_segs=24)
    j = _judge(out, tower, top, 2.5, max_gsd_m=0.02)
    assert j["short_m2"] == 0.0, j
    assert j["nearest_leg_m"] >= standoff - ALLOWANCE_M, j


@pytest.mark.parametrize(("structure", "says"), [
    ({"file": "structure.geojson", "centre": list(CENTRE), "radius_m": 5.0, "top_m": 10.0},
     "gives both structure.file and a circle"),
    ({"centre": list(CENTRE), "top_m": 10.0}, "structure.radius_m is missing"),
    ({"radius_m": 5.0, "top_m": 10.0}, "structure.centre is missing"),
    ({"centre": [15.0], "radius_m": 5.0, "top_m": 10.0}, "structure.centre"),
    ({"centre": list(CENTRE), "radius_m": 0.0, "top_m": 10.0}, "structure.radius_m"),
])
def test_a_round_structure_given_wrongly_is_one_line(tmp_path: Path, structure: dict, says: str) -> None:
    write_geojson(tmp_path / "structure.geojson", [_lonlat(np.asarray(_box(10.0, 10.0).exterior.coords))])
    over = {"pattern": {"kind": "orbit", "standoff_m": 12.0}, "structure": structure,
            "camera": {"model": CAMERA, "trigger": "distance"}}
    code, text = _run("plan", make_spec(tmp_path, over), "-o", tmp_path / "out")
    assert code == 2 and says in text and len(text.strip().splitlines()) == 1, text
