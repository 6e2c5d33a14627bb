"""An orbit's rings written as one QGroundControl Structure Scan item, judged by QGroundControl's
own generator (tests/independent_qgc.py, ported from StructureScanComplexItem.cc and
QGCMapPolygon.cc; it shares no code with the writer).

QGroundControl stores no items for a Structure Scan: it flies what it generates from the
item's settings. So what it would fly is compared with the rings of `mission.waypoints` (the
same mission as plain items): per layer, each vertex of its flight polygon within 1 m of ours
(vertex for vertex, from the ring's first station) and of our path, each of our waypoints within
1 m of its ring; the same layer count, each layer's height within 0.1 m; its trigger distance
ours, the photos ArduPilot's distance trigger takes on its items (tests/independent_coverage.py)
within one a layer of those it takes on ours (its own CameraShots estimate is shown); the
gimbal pitch ours, the camera turned 90° to the right of the flight as ours. Our reader
(`loads_plan`) reads the item as the items QGroundControl uploads.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from tests.plan.test_orbit import L_SHAPE, TO_XY, _box, _plan

import independent_coverage as ic
import independent_qgc as iq
from aerosurvey.mission.formats.qgc_plan import loads_plan

GIMBAL_PITCHYAW, ROI = 1000, 195


def _scan_item(out: Path) -> tuple[dict, list[dict]]:
    doc = json.loads((out / "mission.plan").read_text())
    assert iq.plan_problems(doc) == []
    items = doc["mission"]["items"]
    scans = [it for it in items if it["type"] == "ComplexItem" and it["complexItemType"] == "StructureScan"]
    assert len(scans) == 1, [it.get("complexItemType") for it in items]
    return scans[0], items


def _our_rings(rows: list[list[float]]) -> list[np.ndarray]:
    """Each layer's flown path (x, y, z; TO_XY metres, z above home) from `mission.waypoints`: the
    waypoint the camera is switched on after (the first station) to the one it is switched off
    after (the end)."""
    rings, path, last_wp = [], None, None
    for r in rows:
        if int(r[3]) == ic.NAV_WAYPOINT:
            last_wp = (*TO_XY.transform(r[9], r[8]), r[10])
            if path is not None:
                path.append(last_wp)
        elif int(r[3]) == ic.DO_SET_CAM_TRIGG_DIST and r[4] > 0:
            path = [last_wp]
        elif int(r[3]) == ic.DO_SET_CAM_TRIGG_DIST and path is not None:
            rings.append(np.array(path))
            path = None
    return rings


def _judge(out: Path) -> dict:
    item, _ = _scan_item(out)
    qgc = iq.regenerate_structure_scan(item, "ellipsoid")  # `--qgc survey`: QGroundControl 5.1 and later
    home, rows = ic.read_wpl(out / "mission.waypoints")
    ours = _our_rings(rows)
    ring = np.array([TO_XY.transform(lon, lat) for lat, lon in qgc.ring])
    closed = shapely.LinearRing(ring)
    vertex, to_ours, to_qgc = 0.0, 0.0, 0.0
    for path in ours:
        flown = path[:-1, :2]  # the first station and the bends: the ring's vertices from its start
        if len(flown) > 1 and np.hypot(*(flown[-1] - flown[0])) < 0.01:
            flown = flown[:-1]  # a ring flown round to its first station: a bend there again before its end
        assert len(flown) <= len(ring)
        vertex = max(vertex, float(np.hypot(*(flown - ring[:len(flown)]).T).max()))
        to_ours = max(to_ours, float(shapely.distance(shapely.points(ring), shapely.LineString(path[:, :2])).max()))
        to_qgc = max(to_qgc, float(shapely.distance(shapely.points(flown), closed).max()))
    trigger = [r[4] for r in rows if int(r[3]) == ic.DO_SET_CAM_TRIGG_DIST and r[4] > 0]
    # ours: the gimbal held square to each side (an earth-frame yaw), a region of interest at each corner
    mount = [r[4] for r in rows if int(r[3]) == GIMBAL_PITCHYAW]
    corners = sum(int(r[3]) == ROI for r in rows)
    photos = len(ic.replay_triggers(rows, TO_XY, None, home[2]).x)
    # the photos ArduPilot's distance trigger takes on QGroundControl's items (from the home, at the speed set before them)
    speed = [r for r in rows if int(r[3]) == ic.DO_CHANGE_SPEED][:1]
    theirs = [[0, 0, 3, c, p1, p2, p3, p4, x, y, z, 1] for c, p1, p2, p3, p4, x, y, z in qgc.items]
    qgc_photos = len(ic.replay_triggers(speed + theirs, TO_XY, None, home[2]).x)
    return {"layers": (len(qgc.layers), len(ours)),
            "height_m": max(abs(a - float(np.mean(p[:, 2]))) for a, p in zip(qgc.layers, ours)) if qgc.layers else math.inf,
            "vertex_m": vertex, "qgc_from_ours_m": to_ours, "ours_from_qgc_m": to_qgc,
            "trigger": (qgc.trigger_m, set(trigger)), "shots": (qgc.camera_shots, qgc_photos, photos),
            "mount": (float(item["GimbalPitch"]), set(mount), corners), "item": item, "qgc": qgc}


def _check(j: dict) -> None:
    layers, ours = j["layers"]
    assert layers == ours, j["layers"]
    assert j["height_m"] <= 0.1, j["height_m"]
    assert j["vertex_m"] <= 1.0 and j["qgc_from_ours_m"] <= 1.0 and j["ours_from_qgc_m"] <= 1.0, j
    qgc_trigger, ours_trigger = j["trigger"]
    assert len(ours_trigger) == 1 and next(iter(ours_trigger)) == pytest.approx(qgc_trigger, abs=1e-9), j["trigger"]
    _, qgc_photos, photos = j["shots"]
    assert abs(qgc_photos - photos) <= layers, j["shots"]
    # ours at the item's pitch, square to the walls as QGroundControl's ROI offset (90° right of the next waypoint)
    # is on the sides; round a corner ours looks at the corner, QGroundControl's square to each chord
    pitch, mounts, corners = j["mount"]
    assert mounts == {pitch} and corners >= 3 * layers, j["mount"]


@pytest.mark.parametrize(("name", "footprint", "top", "standoff", "extra"), [
    ("box tower", _box(20.0, 28.0), 30.0, 15.0, {}),
    ("box tower from the top", _box(20.0, 28.0), 30.0, 15.0, {"start": "top"}),
    ("L-shaped building", L_SHAPE, 20.0, 12.0, {"launch": (10.0, -60.0)}),
])
def test_qgroundcontrol_regenerates_our_rings(tmp_path: Path, name: str, footprint: shapely.Polygon, top: float,
                                              standoff: float, extra: dict) -> None:
    out, m = _plan(tmp_path, footprint, top, standoff, **extra)
    j = _judge(out)
    print(name, {k: v for k, v in j.items() if k not in ("item", "qgc")})
    _check(j)
    assert j["item"]["StartFromTop"] is (extra.get("start") == "top")
    assert j["layers"][0] == m["pattern"]["parameters"]["layers"]
    # the structure polygon is the footprint, its corners rounded by the hair the ring's chords take off the stand-off
    poly = shapely.Polygon([TO_XY.transform(lon, lat) for lat, lon in j["item"]["polygon"]])
    assert poly.is_valid and poly.hausdorff_distance(footprint) < 0.5, poly.hausdorff_distance(footprint)
    assert standoff - 0.5 < j["item"]["CameraCalc"]["DistanceToSurface"] <= standoff


def test_our_reader_reads_what_qgroundcontrol_uploads(tmp_path: Path) -> None:
    out, _ = _plan(tmp_path, L_SHAPE, 20.0, 12.0, launch=(10.0, -60.0))
    item, items = _scan_item(out)
    at = items.index(item)
    mission = loads_plan((out / "mission.plan").read_text(), "mission.plan")
    want = iq.regenerate_structure_scan(item, "ellipsoid").items
    got = [(it.command, it.param1, it.param2, it.param3, it.param4, it.x, it.y, it.z) for it in mission.items[at:at + len(want)]]
    assert len(got) == len(want)
    for g, w in zip(got, want):
        assert g[0] == w[0], (g, w)
        np.testing.assert_allclose(g[1:5], w[1:5], atol=1e-9)
        np.testing.assert_allclose(g[5:7], w[5:7], atol=1e-8)  # degrees: 1 mm
        assert g[7] == pytest.approx(w[7], abs=1e-6)
    # the items after the scan are ours again
    assert [it.command for it in mission.items[at + len(want):]] == [it["command"] for it in items[at + 1:]]


def test_a_px4_orbit_is_written_as_the_items_px4_takes(tmp_path: Path) -> None:
    """QGroundControl aims a Structure Scan's camera with DO_SET_ROI_WPNEXT_OFFSET (196), which PX4 answers
    MAV_MISSION_UNSUPPORTED: planned for PX4, the rings are plain items in mission.plan (no item to regenerate),
    the same commands as mission.waypoints, none of them 196, and `upload`'s PX4 gate takes them."""
    from aerosurvey.link.upload import check_px4

    out, _ = _plan(tmp_path, L_SHAPE, 20.0, 12.0, launch=(10.0, -60.0), firmware="px4")
    doc = json.loads((out / "mission.plan").read_text())
    assert iq.plan_problems(doc) == []
    items = doc["mission"]["items"]
    assert all(it["type"] == "SimpleItem" for it in items), [it.get("complexItemType") for it in items]
    commands = [it["command"] for it in items]
    assert 196 not in commands and GIMBAL_PITCHYAW in commands and ROI in commands
    _, rows = ic.read_wpl(out / "mission.waypoints")
    assert commands == [int(r[3]) for r in rows]
    check_px4(loads_plan((out / "mission.plan").read_text(), "mission.plan"), "mission.plan", rally=False)
    # planned for ArduPilot, the same rings are QGroundControl's Structure Scan item
    (tmp_path / "ardupilot").mkdir()
    _scan_item(_plan(tmp_path / "ardupilot", L_SHAPE, 20.0, 12.0, launch=(10.0, -60.0))[0])


@pytest.mark.parametrize(("key", "value", "words"), [
    ("version", 2, "field 'version' = 2 is not allowed: 3"),
    ("Layers", 7, "field 'Layers' = 7 is not allowed: QGroundControl recounts it as"),
    ("polygon", [[49.4, 15.0], [49.4, 15.001]], "has 2 vertices"),
    ("StartFromTop", 1, "field 'StartFromTop' = 1 is not allowed: true or false"),
    ("GimbalPitch", "down", "field 'GimbalPitch' = 'down' is not allowed: a number"),
    ("EntranceAltitude", None, "field 'EntranceAltitude'"),
])
def test_a_damaged_structure_scan_is_refused_naming_the_field(tmp_path: Path, key: str, value: object, words: str) -> None:
    from aerosurvey.errors import InputError

    out, _ = _plan(tmp_path, _box(20.0, 20.0), 20.0, 15.0)
    doc = json.loads((out / "mission.plan").read_text())
    item = next(it for it in doc["mission"]["items"] if it.get("complexItemType") == "StructureScan")
    if value is None:
        del item[key]
    else:
        item[key] = value
    with pytest.raises(InputError, match=words):
        loads_plan(json.dumps(doc), "damaged.plan")


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(w=st.floats(6.0, 40.0), d=st.floats(6.0, 40.0), turn=st.floats(0.0, 90.0), top=st.floats(6.0, 40.0),
       standoff=st.floats(6.0, 60.0), start=st.sampled_from(["bottom", "top"]))
def test_random_footprints_and_standoffs(tmp_path_factory, w: float, d: float, turn: float, top: float, standoff: float,
                                         start: str) -> None:
    out, _ = _plan(tmp_path_factory.mktemp("scan"), _box(w, d, turn), top, standoff, max_gsd_cm=None, start=start)
    _check(_judge(out))
