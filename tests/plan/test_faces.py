"""The facade and faces patterns, judged from the exported mission alone.

The examples of a long wall and a quarry of three benches (missions/long-wall.toml,
missions/quarry-3-benches.toml) are planned end to end through the command line. From
`mission.waypoints` each photo's place, height and aim are rebuilt as tests/plan/test_orbit.py
does (the distance trigger replayed by tests/independent_coverage.py; the mount's pitch and yaw
relative to the nose from DO_MOUNT_CONTROL). The solid is built here from the spec's numbers as a
section polygon (tests/independent_faces.py, shared by nothing in src/), its faces sampled on the
caster's own grid, each sample counted for the photos that see it with a GSD on the face at most
`max_gsd_cm`. Judged:

- every face sample is seen by at least `min_images` such photos (grazing samples counted only
  if seen, as in the orbit's test);
- every leg of the flight (launch, every waypoint in order at its height, then the landing flown
  level to the launch point and down) keeps at least `standoff_m − 2 m` from the solid, in 3-D;
- the planner's own structure-faces rule passes, and fails when a face is out of every photo.

Hypothesis property tests do the same for random walls, bench geometries and stand-offs.
"""

from __future__ import annotations

import json
import math
import tomllib
import zipfile
from pathlib import Path

import numpy as np
import pyproj
import pytest
import tomli_w
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from lxml import etree
from tests.conftest import make_spec, write_geojson
from tests.plan.test_orbit import CAMERA, MOUNT_CONTROL, TO_XY, _face_gsd, _lonlat, _photos

import independent_coverage as ic
from aerosurvey.camera import get_camera
from aerosurvey.cli import main
from aerosurvey.plan.capture import Optics, Photos
from aerosurvey.plan.surfaces import Terrace, check_faces, faces_rule
from independent_faces import bench_caster, bench_samples, distance_to_benches, section
from independent_motion import stop_to_stop_time

ALLOWANCE_M = 2.0
LAND, RTL = 21, 20


def _plan(tmp: Path, toe: np.ndarray, pattern: dict, min_images: int = 2, max_gsd_cm: float | None = None,
          code: int = 0, **over: dict) -> tuple[Path, dict]:
    write_geojson(tmp / "line.geojson", _lonlat(toe), "LineString")
    pattern = {**pattern, "min_images": min_images, **({"max_gsd_cm": max_gsd_cm} if max_gsd_cm else {})}
    # lanes flown up and down the wall shoot at rest at every station
    trigger = "hover" if pattern.get("lanes") == "vertical" else "distance"
    over = {**over, "camera": {"model": CAMERA, "trigger": trigger, **over.get("camera", {})}}
    spec = make_spec(tmp, {"pattern": pattern, **over})
    text = spec.read_text().replace('file = "area.geojson"', 'file = "line.geojson"')
    spec.write_text(text)
    out = tmp / "out"
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)])
    assert res.exit_code == code, res.output
    return out, json.loads((out / "manifest.json").read_text())


def _geometry(pattern: dict) -> tuple[float, float, float, int, float]:
    """(base, angle, height, benches, berm) of a facade or faces [pattern]."""
    if pattern["kind"] == "facade":
        base = pattern.get("base_m", 0.0)
        return base, 90.0, pattern["top_m"] - base, 1, 0.0
    return 0.0, pattern["face_angle_deg"], pattern["face_height_m"], pattern.get("benches", 1), pattern.get("berm_m", 0.0)


def _hover_photos(out: Path) -> tuple[list[tuple[float, float, float, float, float]], list[list[float]], tuple]:
    """The photos (x, y, z, yaw, pitch) of a hover-and-capture mission from the .waypoints: one at each
    NAV_WAYPOINT a DO_DIGICAM_CONTROL follows, at its place and height, the camera at the last
    DO_MOUNT_CONTROL's pitch and its yaw from the nose; the nose faces along the last leg that moved
    the copter level (ArduCopter holds its yaw on a leg straight up or down), as the rows, the home."""
    home, rows = ic.read_wpl(out / "mission.waypoints")
    cams, mount, here, nose = [], None, None, None
    for i, r in enumerate(rows[1:], start=1):
        cmd = int(r[3])
        if cmd == ic.NAV_WAYPOINT:
            there = np.array([*TO_XY.transform(r[9], r[8]), r[10]])
            if here is not None and math.hypot(*(there[:2] - here[:2])) > 0.05:
                nose = math.degrees(math.atan2(*(there[:2] - here[:2])))
            here = there
            if i + 1 < len(rows) and int(rows[i + 1][3]) == DIGICAM:
                assert mount is not None and nose is not None, "a photo with the mount or the nose unknown"
                cams.append((float(here[0]), float(here[1]), float(here[2]), (nose + mount[1]) % 360.0, mount[0]))
        elif cmd == MOUNT_CONTROL:
            mount = (r[4], r[6])  # pitch, yaw relative to the nose
    return cams, rows, home


#: MAV_CMD_DO_DIGICAM_CONTROL: one photo
DIGICAM = 203


def _judge(out: Path, toe: np.ndarray, pattern: dict, cell: float, min_images: int = 2, max_gsd_m: float = math.inf) -> dict:
    cams, rows, home = (_hover_photos if pattern.get("lanes") == "vertical" else _photos)(out)
    a, b = (toe[0], toe[1]) if pattern.get("side", "right") == "right" else (toe[1], toe[0])
    base, angle, height, benches, berm = _geometry(pattern)
    solid = section(base, angle, height, benches, berm)
    cam = get_camera(CAMERA)
    sensor = (cam.sensor_width_mm, cam.sensor_height_mm, cam.focal_mm)
    pixel = cam.sensor_width_mm / cam.image_width_px
    pts, nrm, area = bench_samples(a, b, base, angle, height, benches, berm, cell)
    vis, graze = bench_caster(a, b, solid, sensor, cams, pts, nrm, samples=300)
    gsd = np.full(vis.shape, np.inf)
    for i, j in zip(*np.nonzero(vis)):
        gsd[i, j] = _face_gsd(sensor, pixel, cams[i], pts[j], nrm[j])
    fine = vis & (gsd <= max_gsd_m)
    counts = fine.sum(axis=0)
    # the legs in 3-D: launch → every waypoint at its height → level to the launch point → down
    hx, hy = TO_XY.transform(home[0], home[1])
    xyz = [np.array([hx, hy, 0.0])]
    for r in rows:
        if int(r[3]) == ic.NAV_WAYPOINT:
            x, y = TO_XY.transform(r[9], r[8])
            xyz.append(np.array([x, y, r[10]]))
    assert int(rows[-1][3]) in (LAND, RTL), rows[-1]
    xyz += [np.array([hx, hy, xyz[-1][2]]), xyz[0]]
    along = [p + (q - p) * f[:, None] for p, q in zip(xyz[:-1], xyz[1:])
             for f in [np.linspace(0.0, 1.0, max(2, int(np.linalg.norm(q - p) / 0.25) + 2))]]
    nearest = float(distance_to_benches(a, b, solid, np.vstack(along)).min())
    seen_gsd = np.where(vis, gsd, np.inf).min(axis=0)
    return {"short_m2": float(area[counts < min_images].sum()), "area_m2": float(area.sum()), "photos": len(cams),
            "fewest": int(counts.min()), "worst_gsd_cm": float(seen_gsd.max() * 100), "nearest_leg_m": nearest,
            "grazing_short": int(((fine & ~graze).sum(axis=0) < min_images).sum())}


def _planned_photos(out: Path) -> int:
    return sum(1 for f in json.loads((out / "plan.geojson").read_text())["features"] if f["properties"]["role"] == "station")


def _rule(manifest: dict) -> dict:
    return next(r for r in manifest["rules"] if r["rule"] == "structure-faces")


WALL = np.array([[-90.0, -20.0], [90.0, 10.0]])  # 182 m
REPO = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize(("name", "example"), [("a long wall", "long-wall"), ("a quarry of three benches", "quarry-3-benches")])
def test_the_examples_faces_are_covered_by_the_exported_mission_and_kept_off(tmp_path: Path, name: str, example: str) -> None:
    spec = tomllib.loads((REPO / "missions" / f"{example}.toml").read_text())
    pattern = spec["pattern"]
    coords = json.loads((REPO / "missions" / spec["area"]["file"]).read_text())["features"][0]["geometry"]["coordinates"]
    toe = np.column_stack(TO_XY.transform(*np.array(coords).T))
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["plan", str(REPO / "missions" / f"{example}.toml"), "-o", str(out)])
    assert res.exit_code == 0, res.output
    m = json.loads((out / "manifest.json").read_text())
    assert _rule(m)["status"] == "pass", _rule(m)
    max_gsd_cm = pattern["max_gsd_cm"]
    j = _judge(out, toe, pattern, 2.5, max_gsd_m=max_gsd_cm / 100)
    print(name, j, m["pattern"]["parameters"])
    assert j["short_m2"] == 0.0 and j["fewest"] >= pattern["min_images"], j
    assert j["photos"] == _planned_photos(out), j  # every planned station is a photo the trigger takes
    assert j["worst_gsd_cm"] <= max_gsd_cm, j
    assert j["nearest_leg_m"] >= pattern["standoff_m"] - ALLOWANCE_M, j
    # lanes: per face, ceil(slope length / spacing), one pass each
    spacing = m["pattern"]["passes"][0]["line_spacing_m"]
    _, angle, height, benches, _ = _geometry(pattern)
    lanes = benches * math.ceil(height / math.sin(math.radians(angle)) / spacing - 1e-9)
    assert m["pattern"]["parameters"]["lanes"] == lanes == len(m["pattern"]["passes"])


#: plan.geojson's reason for a photo with no ground footprint (docs/planning.md, "Facade")
NO_FOOTPRINT = "none: the image reaches the horizon"


@pytest.mark.parametrize(("pitch", "ground"), [(None, False), (0.0, False), (-45.0, True)])
def test_a_square_facade_writes_its_photos_points_not_ground_footprints_and_check_runs(tmp_path: Path, pitch: float | None,
                                                                                    ground: bool) -> None:
    """The long wall's default is square to the wall: the camera level. Its photos reach the
    horizon: plan.geojson gives each a feature of role "no-footprint", the photo's point and the
    reason, no ground polygon (each role stays of one geometry type); at -45°
    every corner is more than 5° below the horizon (half the vertical angle is about 27°) and
    each photo has its ground polygon. `check` runs on both."""
    spec = tomllib.loads((REPO / "missions" / "long-wall.toml").read_text())
    coords = json.loads((REPO / "missions" / spec["area"]["file"]).read_text())["features"][0]["geometry"]["coordinates"]
    toe = np.column_stack(TO_XY.transform(*np.array(coords).T))
    pattern = {k: v for k, v in spec["pattern"].items() if k not in ("min_images", "max_gsd_cm")}
    out, m = _plan(tmp_path, toe, {**pattern, **({} if pitch is None else {"pitch_deg": pitch})})
    assert m["pattern"]["parameters"]["pitch_deg"] == (-45.0 if ground else 0.0)
    feats = json.loads((out / "plan.geojson").read_text())["features"]
    stations = {f["id"]: f["geometry"]["coordinates"] for f in feats if f["properties"]["role"] == "station"}
    footprints = {f["properties"]["station"]: f for f in feats if f["properties"]["role"] in ("footprint", "no-footprint")}
    assert stations and footprints.keys() == stations.keys() and len(footprints) == len(stations)
    for sid, f in footprints.items():
        assert f["id"] == f["properties"]["id"] == f"{sid}-fp"
        assert f["properties"]["role"] == ("footprint" if ground else "no-footprint"), f
        if ground:
            assert f["geometry"]["type"] == "Polygon" and "footprint" not in f["properties"], f
            ring = np.array(f["geometry"]["coordinates"][0])
            assert len(ring) == 5 and np.isfinite(ring).all()
        else:
            assert f["geometry"] == {"type": "Point", "coordinates": stations[sid]}, f
            assert f["properties"]["footprint"].startswith(NO_FOOTPRINT), f
    res = CliRunner().invoke(main, ["check", str(out)])
    assert res.exit_code == 0, res.output
    assert "faces" in res.output


def test_a_face_no_photo_sees_fails_the_rule() -> None:
    """Photos turned away from the faces: the rule fails, naming the whole area short."""
    t = Terrace((0.0, 0.0), (50.0, 0.0), 0.0, 70.0, 10.0, 2, 5.0)  # faces rise to the south
    n = 20
    photos = Photos.looking(np.linspace(-10, 60, n), np.full(n, 15.0), np.full(n, 8.0), np.zeros(n), np.full(n, -30.0))
    optics = Optics.of(get_camera(CAMERA), "landscape")
    c = check_faces(t, 0.0, photos, [f"S{i}" for i in range(n)], np.zeros(n, np.intp), optics, 1.0, 2, None)
    rule = faces_rule(c, "plan")
    assert rule["status"] == "fail" and "no photo sees" in str(rule["measured"]), rule
    assert c.short_m2 == pytest.approx(2 * 50.0 * 10.0 / math.sin(math.radians(70.0))), rule


def test_too_few_photos_a_point_fails_the_rule(tmp_path: Path) -> None:
    out, m = _plan(tmp_path, WALL, {"kind": "facade", "standoff_m": 12.0, "top_m": 10.0}, min_images=40, code=1)
    rule = _rule(m)
    assert rule["status"] == "fail" and float(rule["measured"].split(" m² of ")[0]) > 0, rule


@pytest.mark.parametrize(("pattern", "words"), [
    ({"kind": "facade", "standoff_m": 12.0}, "pattern.top_m = None is not allowed"),
    ({"kind": "facade", "standoff_m": 12.0, "top_m": 5.0, "base_m": 6.0}, "pattern.top_m = 5.0 is not allowed"),
    ({"kind": "faces", "benches": 2.5}, "pattern.benches = 2.5 is not allowed"),
    ({"kind": "faces", "face_angle_deg": 95.0}, "pattern.face_angle_deg"),
    ({"kind": "faces", "pitch_deg": -89.0}, "pattern.pitch_deg = -89 is not allowed"),
    ({"kind": "facade", "top_m": 20.0, "standoff_m": 1.0}, "pattern.standoff_m"),
    # at 8 m the image reaches 4.2 m below the level camera: a lowest lane at 12 m sees the wall from 7.8 m up
    ({"kind": "facade", "top_m": 18.0, "standoff_m": 8.0, "min_height_m": 12.0},
     "pattern.min_height_m = 12: the lowest lane raised to it sees the face only from 7.7[0-9] m up its slope, not its "
     "foot; allowed: at most 4.2[0-9] m"),
    ({"kind": "facade", "top_m": 18.0, "min_height_m": -1.0}, "pattern.min_height_m"),
])
def test_bad_settings_are_refused_in_one_line_naming_them(tmp_path: Path, pattern: dict, words: str) -> None:
    with pytest.raises(AssertionError, match=words) as e:
        _plan(tmp_path, WALL, pattern)
    assert len(str(e.value).split("\n")[0]) > 0


def test_a_bent_toe_line_is_refused(tmp_path: Path) -> None:
    with pytest.raises(AssertionError, match="one straight line of 2 points"):
        _plan(tmp_path, np.array([[-50.0, 0.0], [0.0, 10.0], [50.0, 0.0]]), {"kind": "facade", "top_m": 20.0})


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(length=st.floats(20.0, 120.0), turn=st.floats(0.0, 180.0), top=st.floats(4.0, 40.0), standoff=st.floats(6.0, 25.0),
       side=st.sampled_from(["left", "right"]))
def test_random_walls(tmp_path_factory, length: float, turn: float, top: float, standoff: float, side: str) -> None:
    tmp = tmp_path_factory.mktemp("wall")
    t = math.radians(turn)
    toe = np.array([[-math.sin(t), -math.cos(t)], [math.sin(t), math.cos(t)]]) * length / 2
    pattern = {"kind": "facade", "standoff_m": standoff, "top_m": top, "side": side}
    out, m = _plan(tmp, toe, pattern)
    assert _rule(m)["status"] == "pass", _rule(m)
    j = _judge(out, toe, pattern, math.sqrt(length * top / 150.0))
    assert j["short_m2"] == 0.0 and j["photos"] == _planned_photos(out), j
    assert j["nearest_leg_m"] >= standoff - ALLOWANCE_M, j
    assert min(s["alt_rel_m"] for s in m["stations"]) >= LEAST_HEIGHT_M - 0.01


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(length=st.floats(30.0, 100.0), turn=st.floats(0.0, 180.0), angle=st.floats(35.0, 90.0), height=st.floats(5.0, 20.0),
       benches=st.integers(1, 3), berm=st.floats(0.0, 12.0), standoff=st.floats(8.0, 25.0))
def test_random_benches(tmp_path_factory, length: float, turn: float, angle: float, height: float, benches: int,
                        berm: float, standoff: float) -> None:
    tmp = tmp_path_factory.mktemp("benches")
    t = math.radians(turn)
    toe = np.array([[-math.sin(t), -math.cos(t)], [math.sin(t), math.cos(t)]]) * length / 2
    pattern = {"kind": "faces", "standoff_m": standoff, "face_angle_deg": angle, "face_height_m": height,
               "benches": benches, "berm_m": berm}
    out, m = _plan(tmp, toe, pattern)
    assert _rule(m)["status"] == "pass", _rule(m)
    j = _judge(out, toe, pattern, math.sqrt(length * height * benches / math.sin(math.radians(angle)) / 150.0))
    assert j["short_m2"] == 0.0 and j["photos"] == _planned_photos(out), j
    assert j["nearest_leg_m"] >= standoff - ALLOWANCE_M, j
    assert min(s["alt_rel_m"] for s in m["stations"]) >= LEAST_HEIGHT_M - 0.01


#: the lowest lane's height above the toe line's ground by default (docs/mission-spec.md, pattern.min_height_m)
LEAST_HEIGHT_M = 2.0


@pytest.mark.parametrize(("pattern", "least"), [
    ({"kind": "facade", "standoff_m": 10.0, "top_m": 18.0}, LEAST_HEIGHT_M),  # a low wall: its lowest lane laid at 1.8 m
    ({"kind": "facade", "standoff_m": 10.0, "top_m": 18.0, "min_height_m": 4.0}, 4.0),
    # a steep low first bench close in: its lowest lane laid at 2.03 m
    ({"kind": "faces", "standoff_m": 8.0, "face_angle_deg": 85.0, "face_height_m": 8.0, "benches": 2, "berm_m": 4.0,
      "min_height_m": 3.0}, 3.0),
])
def test_the_lowest_lane_is_raised_to_the_least_height_and_still_sees_the_foot(tmp_path: Path, pattern: dict,
                                                                               least: float) -> None:
    """A lane laid below `min_height_m` above the toe line's ground flies at it, the rest where they were; from
    the exported mission every face sample (the foot's too) is still seen by two photos, no leg nearer than the
    allowance."""
    toe = np.array([[-35.0, 0.0], [35.0, 0.0]])
    (tmp_path / "low").mkdir()
    _, low = _plan(tmp_path / "low", toe, {**pattern, "min_height_m": 0.0})
    laid = sorted({s["alt_rel_m"] for s in low["stations"]})
    assert laid[0] < least  # the lowest lane would be laid lower
    out, m = _plan(tmp_path, toe, pattern)
    flown = sorted({s["alt_rel_m"] for s in m["stations"]})
    assert flown[0] == pytest.approx(least, abs=0.01) and flown[1:] == laid[1:], (laid, flown)
    assert _rule(m)["status"] == "pass", _rule(m)
    _, angle, height, benches, _ = _geometry(pattern)
    j = _judge(out, toe, pattern, math.sqrt(70.0 * height * benches / math.sin(math.radians(angle)) / 150.0))
    assert j["short_m2"] == 0.0 and j["fewest"] >= 2 and j["photos"] == _planned_photos(out), j
    assert j["nearest_leg_m"] >= pattern["standoff_m"] - ALLOWANCE_M, j


def test_the_exports_turn_the_camera_to_the_faces(tmp_path: Path) -> None:
    """mission.plan: plain items (no Corridor Scan: its photos are nadir), a DO_MOUNT_CONTROL per
    lane; mission.kmz: on every lane waypoint the aircraft faces the wall (a DJI gimbal yaws a few
    degrees only), the gimbal pitched as the plan's; the bearing square to the toe line, on the
    side the wall rises, both found here from the toe line's coordinates."""
    toe = WALL
    out, m = _plan(tmp_path, toe, {"kind": "facade", "standoff_m": 12.0, "top_m": 20.0, "side": "left"})
    pitch = m["pattern"]["parameters"]["pitch_deg"]
    items = json.loads((out / "mission.plan").read_text())["mission"]["items"]
    assert all(i["type"] == "SimpleItem" for i in items)
    mounts = [i["params"] for i in items if i["command"] == 205]
    assert len(mounts) == m["pattern"]["parameters"]["lanes"] and all(p[0] == pitch for p in mounts)
    assert sorted({abs(p[2]) for p in mounts}) == [90.0]
    # the wall rises left of the line: the camera looks 90° left of its true bearing (pyproj.Geod)
    lon, lat = _lonlat_arrays(toe)
    geod = pyproj.Geod(ellps="WGS84")
    along = geod.inv(lon[0], lat[0], lon[1], lat[1])[0]
    want = (along - 90.0) % 360.0
    with zipfile.ZipFile(out / "mission.kmz") as z:
        doc = etree.fromstring(z.read("wpmz/waylines.wpml"))
    ns = {"k": "http://www.opengis.net/kml/2.2", "wpml": "http://www.dji.com/wpmz/1.0.2"}
    angles = [float(e.text) for e in doc.iterfind(".//wpml:waypointHeadingAngle", ns)]
    assert len(angles) == 3 * m["pattern"]["parameters"]["lanes"]  # lead-in, first station, line end
    assert all(abs((a - want + 180.0) % 360.0 - 180.0) < 0.1 for a in angles), (angles[:3], want)
    pitches = {float(e.text) for e in doc.iterfind(".//wpml:gimbalPitchRotateAngle", ns)}
    assert pitches == {pitch}  # the flight program sets the lanes' aim at the first run: no nadir group before it


def _lonlat_arrays(xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    lonlat = np.array(_lonlat(xy))
    return lonlat[:, 0], lonlat[:, 1]


def _kmz_heights(out: Path) -> list[float]:
    """Each waypoint's height in mission.kmz's waylines (wpml:executeHeight), in order."""
    with zipfile.ZipFile(out / "mission.kmz") as z:
        doc = etree.fromstring(z.read("wpmz/waylines.wpml"))
    return [float(e.text) for e in doc.iterfind(".//wpml:executeHeight", {"wpml": "http://www.dji.com/wpmz/1.0.2"})]


def _judge_vertical(out: Path, toe: np.ndarray, pattern: dict, m: dict, cell: float, max_gsd_cm: float | None = None) -> dict:
    """A wall flown in vertical lanes, from the exported files: coverage, GSD and stand-off from the
    .waypoints' photos at their heights; every lane's photos at one place, one above another; the
    DJI waylines and mission.plan's plain items flying the same heights as the .waypoints, waypoint
    by waypoint."""
    j = _judge(out, toe, pattern, cell, max_gsd_m=math.inf if max_gsd_cm is None else max_gsd_cm / 100)
    assert j["short_m2"] == 0.0 and j["fewest"] >= 2 and j["photos"] == _planned_photos(out), j
    assert j["nearest_leg_m"] >= pattern["standoff_m"] - ALLOWANCE_M, j
    if max_gsd_cm is not None:
        assert j["worst_gsd_cm"] <= max_gsd_cm, j
    cams, rows, _ = _hover_photos(out)
    places = {(round(c[0], 1), round(c[1], 1)) for c in cams}
    assert len(places) == m["pattern"]["parameters"]["lanes"] == len(m["pattern"]["passes"]), places
    assert len(cams) // len(places) >= 2  # photos one above another at each place
    wpl = [r[10] for r in rows[1:] if int(r[3]) == ic.NAV_WAYPOINT]
    assert _kmz_heights(out) == pytest.approx(wpl, abs=0.01)
    # mission.plan: plain items (no complex item lays stations at heights of their own), the same heights
    items = json.loads((out / "mission.plan").read_text())["mission"]["items"]
    assert all(i["type"] == "SimpleItem" for i in items)
    assert [i["params"][6] for i in items if i["command"] == ic.NAV_WAYPOINT] == pytest.approx(wpl, abs=0.01)
    return j


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(length=st.floats(12.0, 80.0), turn=st.floats(0.0, 180.0), top=st.floats(4.0, 30.0), standoff=st.floats(6.0, 20.0),
       side=st.sampled_from(["left", "right"]), start=st.sampled_from(["bottom", "top"]),
       pitch=st.sampled_from([None, -10.0, -25.0]))
def test_random_walls_in_vertical_lanes(tmp_path_factory, length: float, turn: float, top: float, standoff: float, side: str,
                                        start: str, pitch: float | None) -> None:
    """Walls flown up and down (`pattern.lanes = "vertical"`, the camera level or pitched down), judged
    from the exported mission: every face sample seen by two photos at least, each at most the GSD
    asked (twice a pixel's size square to the wall at the stand-off: the image's corners see it
    slanted), no leg nearer the wall than the stand-off less the allowance, no photo lower than the
    least height."""
    tmp = tmp_path_factory.mktemp("vwall")
    t = math.radians(turn)
    toe = np.array([[-math.sin(t), -math.cos(t)], [math.sin(t), math.cos(t)]]) * length / 2
    cam = get_camera(CAMERA)
    gsd_cm = round(2.0 * standoff * cam.sensor_width_mm / cam.image_width_px / cam.focal_mm * 100.0, 3)
    pattern = {"kind": "facade", "standoff_m": standoff, "top_m": top, "side": side, "start": start, "lanes": "vertical",
               **({} if pitch is None else {"pitch_deg": pitch})}
    out, m = _plan(tmp, toe, pattern, max_gsd_cm=gsd_cm)
    assert _rule(m)["status"] == "pass", _rule(m)
    _judge_vertical(out, toe, pattern, m, math.sqrt(length * top / 120.0), gsd_cm)
    assert min(s["alt_rel_m"] for s in m["stations"]) >= LEAST_HEIGHT_M - 0.01
    assert m["pattern"]["parameters"]["lane_direction"] == "vertical"


def _vertical_long_wall(tmp: Path) -> tuple[Path, dict, np.ndarray, dict]:
    """missions/long-wall.toml with `pattern.lanes = "vertical"` and `camera.trigger = "hover"`, planned
    through the command line: the output folder, the manifest, the toe line (local metres), the spec."""
    spec = tomllib.loads((REPO / "missions" / "long-wall.toml").read_text())
    area = REPO / "missions" / spec["area"]["file"]
    coords = json.loads(area.read_text())["features"][0]["geometry"]["coordinates"]
    spec["area"]["file"] = str(area)
    spec["pattern"]["lanes"] = "vertical"
    spec["camera"]["trigger"] = "hover"
    (tmp / "spec.toml").write_text(tomli_w.dumps(spec))
    res = CliRunner().invoke(main, ["plan", str(tmp / "spec.toml"), "-o", str(tmp / "out")])
    assert res.exit_code == 0, res.output
    m = json.loads((tmp / "out" / "manifest.json").read_text())
    return tmp / "out", m, np.column_stack(TO_XY.transform(*np.array(coords).T)), spec


def test_the_long_wall_in_vertical_lanes(tmp_path: Path) -> None:
    """missions/long-wall.toml flown up and down: covered as asked, judged from the exported files;
    the lanes a spacing apart along the wall (from the photo's width on it), the stations a base
    apart up each (from its height), from the least height at the foot to past the top."""
    out, m, toe, spec = _vertical_long_wall(tmp_path)
    pattern = spec["pattern"]
    assert _rule(m)["status"] == "pass", _rule(m)
    j = _judge_vertical(out, toe, pattern, m, 2.5, pattern["max_gsd_cm"])
    print(j, m["pattern"]["parameters"], m["pattern"]["passes"][0])
    ps = m["pattern"]["passes"][0]
    cams, _, _ = _hover_photos(out)
    xy = np.array(sorted({(round(c[0], 3), round(c[1], 3)) for c in cams}, key=lambda p: p[0]))
    gaps = np.hypot(*np.diff(xy, axis=0).T)
    assert gaps.max() <= ps["line_spacing_m"] + 0.01 and gaps.min() > 0.9 * ps["line_spacing_m"], gaps
    z = np.array(sorted({round(c[2], 2) for c in cams}))
    assert np.diff(z).max() <= ps["photo_base_m"] + 0.01, z
    assert z[0] == pytest.approx(LEAST_HEIGHT_M, abs=0.01) and z[-1] > pattern["top_m"]
    length = float(np.hypot(*(toe[1] - toe[0])))
    assert length < float(np.hypot(*(xy[-1] - xy[0]))) < length + ps["line_spacing_m"] * 3


@pytest.mark.parametrize(("over", "words"), [
    ({"vehicle": {"type": "plane", "cruise_speed_ms": 18.0}}, "camera.trigger = 'hover' is for copters"),
    ({"vehicle": {"type": "plane", "cruise_speed_ms": 18.0}, "camera": {"trigger": "distance"}},
     "pattern.lanes = 'vertical' climbs and descends in front of the wall: vehicle.type = 'plane' cannot; allowed: 'copter'"),
    ({"camera": {"trigger": "distance"}}, "pattern.lanes = 'vertical' shoots at rest at every station .* camera.trigger = "
     "'distance'; allowed: 'hover'"),
    ({"camera": {"trigger": "time"}}, "camera.trigger = 'time'; allowed: 'hover'"),
])
def test_vertical_lanes_refuse_what_cannot_fly_them(tmp_path: Path, over: dict, words: str) -> None:
    with pytest.raises(AssertionError, match=words):
        _plan(tmp_path, WALL, {"kind": "facade", "standoff_m": 12.0, "top_m": 10.0, "lanes": "vertical"}, **over)


@pytest.mark.parametrize(("pattern", "words"), [
    ({"kind": "faces", "lanes": "vertical"}, "lanes"),
    ({"kind": "facade", "top_m": 10.0, "lanes": "diagonal"}, "pattern.lanes"),
    # at 8 m the image reaches 4.2 m below the level camera: a lowest station at 12 m sees the wall from 7.8 m up
    ({"kind": "facade", "top_m": 18.0, "standoff_m": 8.0, "min_height_m": 12.0, "lanes": "vertical"},
     "pattern.min_height_m = 12: the lowest station raised to it sees the wall only from 7.7[0-9] m above its foot; "
     "allowed: at most 4.2[0-9] m"),
])
def test_vertical_lanes_bad_settings_are_refused_in_one_line(tmp_path: Path, pattern: dict, words: str) -> None:
    with pytest.raises(AssertionError, match=words) as e:
        _plan(tmp_path, WALL, pattern)
    assert "Traceback" not in str(e.value), e.value


def test_vertical_lanes_are_timed_as_climbs_holds_and_level_ways_from_rest(tmp_path: Path) -> None:
    """The survey time of a wall flown up and down, rebuilt from mission.waypoints alone by stepping the
    motion (tests/independent_motion.py): the copter comes to rest at every waypoint that holds, and at
    each end of a leg straight up or down, flown at the climb or descent rate asked (WPNAV_ACCEL_Z
    1 m/s², jerk 1 m/s³); the level legs between two rests one straight run; each hold and the
    camera's cycle after it. The plan's estimate agrees within 2 %."""
    climb, descent, speed, accel, jerk = 2.0, 1.0, 5.0, 2.0, 1.0
    out, m = _plan(tmp_path, np.array([[-20.0, 0.0], [20.0, 0.0]]),
                   {"kind": "facade", "standoff_m": 10.0, "top_m": 12.0, "lanes": "vertical"},
                   vehicle={"type": "copter", "cruise_speed_ms": speed, "acceleration_ms2": accel,
                            "climb_rate_ms": climb, "descent_rate_ms": descent})
    assert m["derived"]["speed_ms"] == speed
    _, rows = ic.read_wpl(out / "mission.waypoints")
    wps = [(np.array([*TO_XY.transform(r[9], r[8]), r[10]]), r[4]) for r in rows[2:] if int(r[3]) == ic.NAV_WAYPOINT]
    total, level = 0.0, 0.0
    for (a, _), (b, hold) in zip(wps, wps[1:]):
        dz, dh = b[2] - a[2], math.hypot(*(b[:2] - a[:2]))
        if abs(dz) > 1e-3:
            assert dh < 0.01, (a, b)  # a lane: straight up or down
            total += stop_to_stop_time(level, speed, accel, jerk) if level else 0.0
            total += stop_to_stop_time(abs(dz), climb if dz > 0 else descent, 1.0, jerk)
            level = 0.0
        else:
            level += dh
        if hold > 0:
            total += stop_to_stop_time(level, speed, accel, jerk) if level else 0.0
            total += hold + m["camera"]["min_cycle_s"]
            level = 0.0
    total += stop_to_stop_time(level, speed, accel, jerk) if level else 0.0
    assert sum(1 for _, h in wps if h > 0) == len(m["stations"])
    print(m["estimates"]["survey_time_s"], total)
    assert m["estimates"]["survey_time_s"] == pytest.approx(total, rel=0.02), (m["estimates"], total)
