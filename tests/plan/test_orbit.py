"""The orbit pattern (structure scan), judged from the exported mission alone.

A box tower and an L-shaped building are planned end to end through the command line. From
`mission.waypoints` (parsed here; the distance trigger replayed by tests/independent_coverage.py)
each photo's place, height and aim are rebuilt: the direction of flight at the photo turned by
the mount's yaw (DO_MOUNT_CONTROL, relative to the nose: a copter faces along its track), at the
mount's pitch. The ray caster of tests/independent_faces.py (shared by nothing in src/) samples
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
MOUNT_CONTROL, RTL = 205, 20
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
    pattern = {"kind": "orbit", "standoff_m": standoff, **{k: v for k, v in extra.items() if k != "launch"}}
    structure = {"file": "structure.geojson", "top_m": top, **({"max_gsd_cm": max_gsd_cm} if max_gsd_cm else {})}
    over: dict = {"pattern": pattern, "structure": structure, "camera": {"model": CAMERA, "trigger": "distance"}}
    if "launch" in extra:
        over["area"] = {"file": "area.geojson", "launch": _lonlat(np.array([extra["launch"]]))[0]}
    out = tmp / "out"
    code, text = _run("plan", make_spec(tmp, over), "-o", out)
    assert code == 0, text
    return out, json.loads((out / "manifest.json").read_text())


def _photos(out: Path) -> tuple[list[tuple[float, float, float, float, float]], list[list[float]], tuple]:
    """The photos (x, y, z, yaw, pitch) from the .waypoints, the rows, the home."""
    home, rows = ic.read_wpl(out / "mission.waypoints")
    photos = ic.replay_triggers(rows, TO_XY, None, home[2])
    # the mount's last setting before each trigger-on block
    mount, aims = None, []
    for r in rows:
        if int(r[3]) == MOUNT_CONTROL:
            mount = (r[4], r[6])  # pitch, yaw (relative to the nose)
        elif int(r[3]) == ic.DO_SET_CAM_TRIGG_DIST and r[4] > 0:
            assert mount is not None, "photos with the mount where the last flight left it"
            aims.append(mount)
    cams = []
    for x, y, z, h, run in zip(photos.x, photos.y, photos.agl, photos.heading, photos.run):
        pitch, yaw = aims[run]
        cams.append((float(x), float(y), float(z), (90.0 - math.degrees(h) + yaw) % 360.0, pitch))
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
    return {"short_m2": float(area[counts < min_images].sum()), "short_sure_m2": float(area[sure < min_images].sum()),
            "area_m2": float(area.sum()), "min_images": int(counts.min()), "nearest_leg_m": nearest, "photos": len(cams),
            "heights": sorted({round(c[2], 1) for c in cams})}


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
    # layers: ceil(height / spacing), one pass each, bottom first
    spacing = m["pattern"]["passes"][0]["line_spacing_m"]
    layers = math.ceil(top / spacing)
    assert m["pattern"]["parameters"]["layers"] == layers == len(m["pattern"]["passes"])
    assert len(j["heights"]) == layers and j["heights"] == sorted(j["heights"])


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
