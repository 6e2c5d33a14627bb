"""The smart oblique: random areas planned with `[pattern] kind = "smart-oblique"`, judged from the
exported `.waypoints` files read here as ArduPilot flies them (no planner code): the copter stops at
each station (NAV_WAYPOINT with a hold) and takes five photos there (DO_DIGICAM_CONTROL), each after
a DO_MOUNT_CONTROL of its own: nadir, then four obliques at the asked pitch looking along the lines
and at 90°, 180° and 270° from them. Each look's photos (footprints by test_oblique's tilted-camera
model) see every sampled point of the area as an area grid promises at nadir, and neighbouring
photos of one look overlap as asked. The DJI export holds one placemark a station with one action
group (gimbalRotate, hover, takePhoto five times); a plane and a trigger other than hover are refused.
"""

from __future__ import annotations

import json
import math
import re
import zipfile
from pathlib import Path

import pytest
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as hs
from lxml import etree
from test_oblique import LOCAL, Shot, _fewest, look, neighbour_overlaps, trapezoid, write_area

import independent_coverage as ic
from aerosurvey.errors import InputError
from aerosurvey.inputs import plan_from_files
from aerosurvey.outputs import write_outputs
from aerosurvey.plan.flight_time import GIMBAL_SLEW_S, Kinematics, hover_time, look_hold_s
from aerosurvey.spec import load_spec

NAV_WAYPOINT, DO_DIGICAM_CONTROL, DO_MOUNT_CONTROL = 16, 203, 205
SETTLE_S = 1.0
WPML = "{http://www.dji.com/wpmz/1.0.2}"


def _spec(folder: Path, area_local: shapely.Geometry, pitch: float, heading: float, **extra: str) -> Path:
    vehicle = extra.get("vehicle", "copter")
    (folder / "spec.toml").write_text(write_area(folder, area_local) + f"""
[pattern]
kind = "smart-oblique"
pitch_deg = {pitch}
[camera]
model = "{extra.get('camera', 'sony-a6000-16mm')}"
trigger = "{extra.get('trigger', 'hover')}"
settle_s = {SETTLE_S}
[targets]
height_m = 60
forward_overlap = 0.75
side_overlap = 0.6
[vehicle]
type = "{vehicle}"
cruise_speed_ms = {18.0 if vehicle == 'plane' else 8.0}
[flight]
heading = {heading}
""")
    return folder / "spec.toml"


def _plan(folder: Path, *args: float, **extra: str) -> Path:
    loaded = load_spec(_spec(folder, *args, **extra))
    out = folder / "out"
    write_outputs(plan_from_files(loaded), loaded, out)
    return out


def _bearing(a: tuple[float, float], b: tuple[float, float]) -> float:
    return math.degrees(math.atan2(b[0] - a[0], b[1] - a[1])) % 360.0


def _off(a: float, b: float) -> float:
    d = (a - b) % 360.0
    return min(d, 360.0 - d)


def photos(out: Path) -> tuple[list[Shot], list[dict], list[str]]:
    """(every photo of the files in `out` as ArduPilot takes them, with the waypoint it is taken at:
    its place, hold and the gimbal commands since the photo before; problems)."""
    manifest = json.loads((out / "manifest.json").read_text())
    cam = manifest["camera"]
    (sw, sh), f = cam["sensor_mm"], cam["focal_mm"]
    tan_x, tan_y = (sw / 2 / f, sh / 2 / f) if cam["mount"] == "landscape" else (sh / 2 / f, sw / 2 / f)
    stations = manifest["stations"]
    run_of = {r: k for k, r in enumerate(dict.fromkeys(s["line"] for s in stations))}
    files = sorted(out.glob("sortie-*.waypoints")) or [out / "mission.waypoints"]
    found: list[Shot] = []
    where: list[dict] = []
    for path in files:
        home, rows = ic.read_wpl(path)
        here = before = None
        hold = heading = math.nan
        mounts: list[tuple[float, float]] = []
        for r in rows:
            cmd = int(r[3])
            if cmd == NAV_WAYPOINT:
                xy = tuple(float(v) for v in LOCAL.fwd.transform(r[9], r[8]))
                if here is not None and math.dist(xy, here) > 0.01:
                    before, heading = here, _bearing(here, xy)
                here, hold, agl = xy, r[4], r[10]
            elif cmd == DO_MOUNT_CONTROL:
                mounts.append((r[4], r[6]))
            elif cmd == DO_DIGICAM_CONTROL:
                assert here is not None and before is not None
                k = len(found)
                sid = stations[k]["id"] if k < len(stations) else "P0-L000-S0000"
                pitch, yaw = mounts[-1] if mounts else (math.nan, math.nan)
                found.append(Shot(here[0], here[1], heading, None if pitch == -90 else (heading + yaw) % 360.0, pitch,
                                  run_of.get(stations[k]["line"], -1) if k < len(stations) else -1,
                                  int(re.match(r"P(\d+)-", sid)[1]),
                                  trapezoid(here[0], here[1], agl, heading + yaw, pitch, tan_x, tan_y)))
                where.append({"place": here, "hold": hold, "mounts": len(mounts), "pitch": pitch, "yaw": yaw})
                mounts = []
    problems = [] if len(found) == len(stations) else [f"ArduPilot takes {len(found)} photos, the manifest lists {len(stations)}"]
    return found, where, problems


@pytest.mark.slow
@settings(max_examples=4, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(w=hs.floats(60, 240), h=hs.floats(60, 240), notch=hs.booleans(), pitch=hs.sampled_from([-35.0, -45.0, -60.0]),
       heading=hs.floats(0, 179))
def test_five_photos_a_station_each_look_sees_the_area_with_the_asked_overlaps(
        tmp_path_factory: pytest.TempPathFactory, w: float, h: float, notch: bool, pitch: float, heading: float) -> None:
    area = shapely.box(0, 0, w, h)
    if notch:
        area = shapely.difference(area, shapely.box(w / 3, h / 2, 2 * w / 3, h + 1))
    folder = tmp_path_factory.mktemp("smart")
    found, where, problems = photos(_plan(folder, area, pitch, heading))
    assert not problems, problems
    assert len(found) % 5 == 0 and found
    for k in range(0, len(found), 5):
        shots, at = found[k:k + 5], where[k:k + 5]
        # one place, five photos, each after a gimbal command of its own; nothing else shot there
        assert all(math.dist(a["place"], at[0]["place"]) < 0.01 for a in at), at
        assert k + 5 == len(found) or math.dist(where[k + 5]["place"], at[0]["place"]) > 1.0
        assert all(a["mounts"] == 1 for a in at[1:]), at
        assert at[0]["mounts"] <= 1 and math.isfinite(at[0]["pitch"]), "a station's first photo with no gimbal command"
        # held still: the first for the settle time, the others longer (the gimbal turns)
        assert at[0]["hold"] >= SETTLE_S and all(a["hold"] > SETTLE_S for a in at[1:]), at
        assert shots[0].pitch == -90 and all(abs(s.pitch - pitch) < 1e-6 for s in shots[1:]), shots
        first = shots[1].look_deg
        assert first is not None and min(_off(first, heading), _off(first, heading + 180.0)) < 0.5, (first, heading)
        for i, s in enumerate(shots[1:]):
            assert s.look_deg is not None and _off(s.look_deg, first + 90.0 * i) < 0.5, shots
    fewest = _fewest(found, area, look)
    assert len(fewest) == 5, fewest
    assert all(n >= 2 * 4 for n in fewest.values()), f"fewest photos a look sees a point with: {fewest} (files in {folder})"
    o = neighbour_overlaps(found, area)
    assert o["side"] and o["forward"]
    assert min(o["side"]) >= 0.6 - 0.005 and min(o["side_area"]) >= 0.6 - 0.005, (min(o["side"]), folder)
    assert min(o["forward"]) >= 0.75 - 0.005 and min(o["forward_area"]) >= 0.75 - 0.005, (min(o["forward"]), folder)


def test_the_dji_export_has_one_waypoint_and_one_action_group_a_station(tmp_path: Path) -> None:
    out = _plan(tmp_path, shapely.box(0, 0, 120, 90), -45.0, 30.0, camera="dji-mavic-3-enterprise")
    manifest = json.loads((out / "manifest.json").read_text())
    with zipfile.ZipFile(out / "mission.kmz") as z:
        doc = etree.fromstring(z.read("wpmz/waylines.wpml"))
    shooting = [pm for pm in doc.iter("{http://www.opengis.net/kml/2.2}Placemark")
                if any(a.text == "takePhoto" for a in pm.iter(f"{WPML}actionActuatorFunc"))]
    assert len(shooting) * 5 == len(manifest["stations"])
    for pm in shooting:
        groups = list(pm.iter(f"{WPML}actionGroup"))
        assert len(groups) == 1
        funcs = [a.text for a in groups[0].iter(f"{WPML}actionActuatorFunc")]
        assert funcs.count("takePhoto") == 5 and funcs.count("hover") == 5
        # a gimbal turn before each photo but the station's first (set as the station before it ended, or at the run's start)
        turns = [i for i, fn in enumerate(funcs) if fn == "gimbalRotate"]
        shots = [i for i, fn in enumerate(funcs) if fn == "takePhoto"]
        assert all(any(a < t < b for t in turns) for a, b in zip(shots, shots[1:])), funcs
        pitches = [float(p.text) for p in groups[0].iter(f"{WPML}gimbalPitchRotateAngle")]
        assert sorted(set(round(p) for p in pitches)) in ([-90, -45], [-45])


@pytest.mark.parametrize(("extra", "key"), [({"vehicle": "plane", "trigger": "distance"}, "vehicle.type"),
                                                 ({"trigger": "distance"}, "camera.trigger")])
def test_a_plane_and_a_trigger_in_flight_are_refused_in_one_line(tmp_path: Path, extra: dict[str, str], key: str) -> None:
    with pytest.raises(InputError) as e:
        plan_from_files(load_spec(_spec(tmp_path, shapely.box(0, 0, 120, 90), -45.0, 30.0, **extra)))
    text = str(e.value)
    assert "\n" not in text and key in text and "smart-oblique" in text, text


def test_sorties_end_on_a_stations_last_look_within_the_item_limit(tmp_path: Path) -> None:
    """A battery of a few minutes: every sortie file shoots whole stations (five photos a place, the
    first straight down) and holds no more items than ArduPilot's 650."""
    spec = _spec(tmp_path, shapely.box(0, 0, 240, 200), -45.0, 30.0)
    spec.write_text(spec.read_text() + "[battery]\nusable_min = 6\nreserve = 0.2\n")
    loaded = load_spec(spec)
    out = tmp_path / "out"
    write_outputs(plan_from_files(loaded), loaded, out)
    files = sorted(out.glob("sortie-*.waypoints"))
    assert len(files) > 1
    found, where, problems = photos(out)
    assert not problems, problems
    for path in files:
        _, rows = ic.read_wpl(path)
        assert len(rows) <= 650, (path.name, len(rows))
        assert sum(int(r[3]) == DO_DIGICAM_CONTROL for r in rows) % 5 == 0, path.name
    for k in range(0, len(found), 5):
        assert found[k].pitch == -90 and all(math.dist(a["place"], where[k]["place"]) < 0.01 for a in where[k:k + 5])
    # the manifest's passes: one for each look, with the aim its stations have
    manifest = json.loads((out / "manifest.json").read_text())
    passes = {p["pass"]: p for p in manifest["pattern"]["passes"]}
    assert sorted(passes) == [1, 2, 3, 4, 5]
    for s in manifest["stations"]:
        p = passes[int(re.match(r"P(\d+)-", s["id"])[1])]
        assert s["pitch_deg"] == pytest.approx(p["pitch_deg"])
        assert p["look_deg"] is None if p["pitch_deg"] == -90 else _off(s["camera_yaw_deg"], p["look_deg"]) < 1.0, (s, p)


@settings(max_examples=30, deadline=None)
@given(places=hs.integers(1, 400), runs=hs.integers(1, 20), base=hs.floats(5.0, 80.0), hold=hs.floats(0.0, 5.0),
       settle=hs.floats(0.0, 5.0), cycle=hs.floats(0.1, 5.0), speed=hs.floats(3.0, 15.0))
def test_each_further_look_adds_its_hold(places: int, runs: int, base: float, hold: float, settle: float, cycle: float,
                                         speed: float) -> None:
    """Five aims at a place against one: the same stops, and four more holds a place, each the settling and the
    gimbal's turn or the camera's cycle, whichever is longer (the flight program's waypoint hold)."""
    k = Kinematics("copter", speed, 2.5, 0.0)
    look = look_hold_s(settle, cycle)
    assert look >= cycle and look >= settle + GIMBAL_SLEW_S and look in (cycle, settle + GIMBAL_SLEW_S)
    one = hover_time(places, min(runs, places), base, 0.0, hold, k)
    five = hover_time(5 * places, min(runs, places), base, 0.0, hold, k, 5, look)
    assert five - one == pytest.approx(4 * places * look, rel=1e-9, abs=1e-9)
