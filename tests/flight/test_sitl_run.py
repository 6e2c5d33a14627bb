"""`sitl fly`'s work without a SITL binary: the sortie routes from the manifest, and the fly loop
driven through a stand-in for the process harness (the real one is tested in tests/test_sitl.py)."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from aerosurvey import manifest as mf
from aerosurvey.cli import main
from aerosurvey.errors import InputError
from aerosurvey.flight import sitl_run
from aerosurvey.link import sitl as harness
from conftest import make_spec


@pytest.fixture(scope="module")
def split_plan(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("split")
    spec = make_spec(tmp, {"flight": {"heading": 0.0}, "battery": {"usable_min": 6.0}})
    out = tmp / "plan"
    assert CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)]).exit_code == 0
    return out


def test_sortie_routes_follow_the_manifest(split_plan):
    raw = json.loads((split_plan / "manifest.json").read_text())
    routes = sitl_run.sortie_routes(mf.read_manifest(split_plan), split_plan)
    assert [r.name for r in routes] == [s["id"] for s in raw["sorties"]] and len(routes) >= 2
    flat = [p for r in routes for p in r.stations]
    assert flat == [(s["lat"], s["lon"]) for s in raw["stations"]]  # every station flown once, in order
    for r, s in zip(routes, raw["sorties"]):
        assert r.mission_file == split_plan / s["files"][0] and r.estimated_s == s["time_s"] and len(r.stations) == s["photos"]
        first = next(i for i, st in enumerate(raw["stations"]) if st["id"] == s["first_station"])
        lines = [st["line"] for st in raw["stations"][first: first + s["photos"]]]
        # runs: consecutive stations of one line, covering the sortie without gaps
        assert r.runs[0][0] == 0 and r.runs[-1][1] == len(r.stations) - 1
        assert all(b + 1 == c for (_, b), (c, _) in zip(r.runs, r.runs[1:]))
        for a, b in r.runs:
            assert len(set(lines[a:b + 1])) == 1
        assert len(r.runs) == len(dict.fromkeys(lines))


def test_missing_sortie_file_is_bad_input(split_plan, tmp_path):
    import shutil

    copy = tmp_path / "plan"
    shutil.copytree(split_plan, copy)
    (copy / "sortie-02.plan").unlink()
    with pytest.raises(InputError, match="sortie-02.plan is missing"):
        sitl_run.sortie_routes(mf.read_manifest(copy), copy)


class _FakeVehicle:
    started: list[str] = []
    folders: list[Path] = []

    def __init__(self, binary, vehicle, home, speedup, defaults, work, boot_timeout, heading_deg=0.0):
        self.work = work
        _FakeVehicle.folders.append(work)

    def start(self) -> None:
        _FakeVehicle.started.append("start")
        (self.work / "logs").mkdir(parents=True)
        (self.work / "logs" / "00000001.BIN").write_bytes(b"log")

    def stop(self) -> None:
        _FakeVehicle.started.append("stop")


def _stand_in(monkeypatch, fake_fly) -> list[bool]:
    """The harness replaced: SITL by `_FakeVehicle`, a flight by `fake_fly`; whether each sortie was
    prepared with a mount, in order."""
    monkeypatch.setattr(harness, "SitlVehicle", _FakeVehicle)
    mounts: list[bool] = []
    monkeypatch.setattr(harness, "prepare", lambda sv, mount, wind: mounts.append(mount))
    monkeypatch.setattr(harness, "fly", fake_fly)
    return mounts


def test_fly_loop_flies_every_sortie_and_writes_the_report(split_plan, tmp_path, monkeypatch):
    doc = mf.read_manifest(split_plan)
    routes = {r.name: r for r in sitl_run.sortie_routes(doc, split_plan)}

    def fake_fly(sv, mission, name, est, last_item, timeout_factor, upload, rtl_after_photos=None, wind=None):
        assert rtl_after_photos is None
        f = harness.Flight(name)
        for lat, lon in routes[name].stations:  # every planned photo, exactly where planned
            f.triggers.append((lat, lon, 100.0))
            f.trigger_track_index.append(len(f.track))
            f.track.append((len(f.track) * 1000, lat, lon, 100.0))
        f.armed_ms, f.disarmed_ms, f.completed = 1, 1 + round(est * 1000), True
        return f

    mounts = _stand_in(monkeypatch, fake_fly)
    temp = tmp_path / "temp"
    temp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(temp))
    settings = sitl_run.SitlSettings("copter", Path("/bin/true"), (), 10.0, 3.0)
    seen = []
    rows = sitl_run.fly_sorties(doc, split_plan, settings, tmp_path / "report", seen.append)
    assert [r["sortie"] for r in rows] == list(routes) == [r["sortie"] for r in seen]
    assert all(r["completed"] and r["triggers_match"] and r["max_trigger_offset_m"] == 0.0 for r in rows)
    assert all(r["time_ratio"] == 1.0 for r in rows)
    assert _FakeVehicle.started == ["start", "stop"] * len(routes)
    # a nadir plan sets the gimbal straight down at every flight's first run: SITL flies it with a mount and its aim
    # is judged; the stand-in's log has no picture, so no aim is known and none passes
    assert mounts == [True] * len(routes)
    assert all(r["mount_pitch_deg"] == [] and r["max_aim_error_deg"] is None and r["aim_ok"] is False for r in rows)
    report = json.loads((tmp_path / "report" / "sitl_report.json").read_text())
    assert [r["photos_planned"] for r in report["sorties"]] == [len(r.stations) for r in routes.values()]
    assert sorted(p.name for p in (tmp_path / "report").glob("*.BIN")) == sorted(f"{n}.BIN" for n in routes)
    assert len(_FakeVehicle.folders) == len(routes) and all(f.parent == temp for f in _FakeVehicle.folders)
    assert list(temp.iterdir()) == []  # SITL's work folders removed


def test_a_flight_cut_short_flies_its_first_sortie_only(split_plan, tmp_path, monkeypatch):
    """--rtl-after N: the first sortie flies, the harness is asked to switch to RTL after photo N,
    and the row says the sortie was cut; a sortie with fewer photos than N was not cut."""
    doc = mf.read_manifest(split_plan)
    first = sitl_run.sortie_routes(doc, split_plan)[0]
    asked = []

    def fake_fly(sv, mission, name, est, last_item, timeout_factor, upload, rtl_after_photos=None, wind=None):
        asked.append((name, rtl_after_photos))
        f = harness.Flight(name)
        for lat, lon in first.stations[:rtl_after_photos]:
            f.triggers.append((lat, lon, 100.0))
            f.trigger_track_index.append(len(f.track))
            f.track.append((len(f.track) * 1000, lat, lon, 100.0))
        f.armed_ms, f.disarmed_ms = 1, len(f.track) * 1000
        f.cut_ms = f.track[-1][0] if rtl_after_photos <= len(first.stations) else None
        return f

    monkeypatch.setattr(harness, "SitlVehicle", _FakeVehicle)
    monkeypatch.setattr(harness, "prepare", lambda sv, mount, wind: None)
    monkeypatch.setattr(harness, "fly", fake_fly)
    rows = sitl_run.fly_sorties(doc, split_plan, sitl_run.SitlSettings("copter", Path("/bin/true"), (), 10.0, 3.0,
                                                                     rtl_after_photos=7), tmp_path / "report")
    assert asked == [(first.name, 7)] and len(rows) == 1
    assert rows[0]["rtl_after_photos"] == 7 and rows[0]["triggers_flown"] == 7 and not rows[0]["completed"]
    rows = sitl_run.fly_sorties(doc, split_plan, sitl_run.SitlSettings("copter", Path("/bin/true"), (), 10.0, 3.0,
                                                                     rtl_after_photos=10_000), tmp_path / "again")
    assert rows[0]["rtl_after_photos"] is None


def test_only_the_sorties_asked_fly_and_an_unknown_one_is_bad_input(split_plan, tmp_path, monkeypatch):
    doc = mf.read_manifest(split_plan)
    routes = sitl_run.sortie_routes(doc, split_plan)
    flown = []

    def fake_fly(sv, mission, name, est, last_item, timeout_factor, upload, rtl_after_photos=None, wind=None):
        flown.append(name)
        return harness.Flight(name)

    monkeypatch.setattr(harness, "SitlVehicle", _FakeVehicle)
    monkeypatch.setattr(harness, "prepare", lambda sv, mount, wind: None)
    monkeypatch.setattr(harness, "fly", fake_fly)
    settings = sitl_run.SitlSettings("copter", Path("/bin/true"), (), 10.0, 3.0)
    rows = sitl_run.fly_sorties(doc, split_plan, settings, tmp_path / "report", only=(routes[1].name,))
    assert flown == [routes[1].name] == [r["sortie"] for r in rows]
    with pytest.raises(InputError, match=rf"sorties S99: not sorties of .* \(it has {', '.join(r.name for r in routes)}\)"):
        sitl_run.fly_sorties(doc, split_plan, settings, tmp_path / "again", only=("S99", routes[0].name))


def test_sitl_fly_without_a_manifest_is_one_line(tmp_path):
    res = CliRunner().invoke(main, ["sitl", "fly", str(tmp_path)])
    assert res.exit_code == 2 and res.output.count("\n") == 1
    assert "has no manifest.json: give the folder `aerosurvey plan` wrote" in res.output


def test_the_survey_parameters_add_a_mount_only_when_asked():
    copter = dict(harness.survey_params("copter", mount=False))
    assert copter["CAM1_TYPE"] == 1 and copter["AUTO_OPTIONS"] == 3 and "MNT1_TYPE" not in copter
    assert "THR_FAILSAFE" not in copter  # a PLANE: line
    mounted = dict(harness.survey_params("copter", mount=True))
    assert mounted["MNT1_TYPE"] == 1 and {mounted[f"SERVO{n}_FUNCTION"] for n in (9, 10, 11)} == {6, 7, 8}
    plane = dict(harness.survey_params("plane", mount=True))
    assert plane["THR_FAILSAFE"] == 0 and plane["MNT1_TYPE"] == 1 and "AUTO_OPTIONS" not in plane


#: the harness's servo mount (sitl/aerosurvey-sitl.parm) as the log's PARM messages record it: tilt on output 9, pan
#: on 10, roll on 11, each driven over 1100 to 1900 µs across its MNT1_ limits
HARNESS_MOUNT = {"SERVO9_FUNCTION": 7.0, "SERVO10_FUNCTION": 6.0, "SERVO11_FUNCTION": 8.0,
                 **{f"SERVO{c}_{k}": v for c in (9, 10, 11) for k, v in (("MIN", 1100.0), ("MAX", 1900.0), ("REVERSED", 0.0))},
                 "MNT1_PITCH_MIN": -135.0, "MNT1_PITCH_MAX": 45.0, "MNT1_ROLL_MIN": -30.0, "MNT1_ROLL_MAX": 30.0,
                 "MNT1_YAW_MIN": -180.0, "MNT1_YAW_MAX": 180.0}


def _sight(vehicle: tuple[float, float, float], pan: float, roll: float, tilt: float) -> np.ndarray:
    """The camera's line of sight (north, east, down), by scipy: the vehicle's attitude (roll, pitch, yaw;
    intrinsic yaw-pitch-roll, "ZYX") turned by the servos, pan, roll, tilt (intrinsic "ZXY")."""
    from scipy.spatial.transform import Rotation

    r, p, y = vehicle
    sight: np.ndarray = (Rotation.from_euler("ZYX", [y, p, r], degrees=True)
                         * Rotation.from_euler("ZXY", [pan, roll, tilt], degrees=True)).apply([1.0, 0.0, 0.0])
    return sight


def _pitch(sight: np.ndarray) -> float:
    """A line of sight's pitch against the horizon (degrees)."""
    return float(np.degrees(np.arcsin(-sight[2] / np.linalg.norm(sight))))


def _sight_pitch(vehicle: tuple[float, float, float], pan: float, roll: float, tilt: float) -> float:
    """The camera's pitch against the horizon (`_sight`)."""
    return _pitch(_sight(vehicle, pan, roll, tilt))


def _degrees(pwm: int, least: float, most: float) -> float:
    return least + (pwm - 1100) / 800.0 * (most - least)


def test_the_camera_pitch_at_each_picture_turns_the_servo_outputs_by_the_vehicle_attitude(tmp_path):
    """Pictures of ArduCopter 4.7 SITL flights (CAM, MNT, RCOU and ATT as logged; tilt, pan, roll on
    outputs 9, 10, 11): each servo's angle is read from its output through the log's parameters, the
    camera's line of sight at each output is the vehicle's attitude logged in the same loop (ATT) turned
    by them, pan, roll, tilt, and its line of sight at a picture is interpolated between the outputs either side.
    MNT's Euler angles are not read: at a nadir hover (the vehicle 0.39° nose up, the tilt at -90.45°) MNT
    logged Roll 179.9, Pitch -89.61, YawB 180 (ArduPilot's yaw-pitch-roll decoding of the servo angles,
    past -90 the other solution), which read pan-roll-tilt looks up, +89.2°."""
    from dfwriter import mount_log

    log = tmp_path / "m.BIN"
    # (time_s, vehicle roll, pitch, yaw) per picture, and the MNT, RCOU and ATT messages logged before and after it
    cams = [(0.5, 0.0, 0.0, 0.0), (116.87, 0.06, 0.39, 359.60), (144.199797, 0.08, 6.54, 269.86), (150.0, 13.0, -20.0, 45.0)]
    mnts = [(116.84, 179.935, -89.610, 180.0), (144.199797, 179.910, -83.452, -180.0), (149.95, -13.0, -70.0, 0.0)]
    pwm = [(116.82, {9: 1298, 10: 1500, 11: 1500}, cams[1][1:]), (116.92, {9: 1298, 10: 1500, 11: 1500}, cams[1][1:]),
           # braking at a line end, pitching up 12°/s: 6.54° nose up at the picture, 60 % of the way between two outputs
           (144.139821, {9: 1275, 10: 1500, 11: 1500}, (0.08, 5.82, 269.86)),
           (144.239781, {9: 1270, 10: 1500, 11: 1500}, (0.08, 7.02, 269.86)),
           # panned 90° right (1700 µs), rolled and tilted: the picture half way between two outputs
           (149.95, {9: 1400, 10: 1700, 11: 1300}, cams[3][1:]), (150.05, {9: 1420, 10: 1700, 11: 1260}, cams[3][1:])]
    log.write_bytes(mount_log(cams, mnts, pwm, HARNESS_MOUNT))
    got = sitl_run.mount_pitch_at_photos(log)
    assert got[0] is None  # before the mount's first message
    # the nadir hover: the tilt servo at -90.45° under a vehicle 0.39° nose up looks 0.08° off straight down
    assert got[1] == pytest.approx(_sight_pitch(cams[1][1:], 0.0, 0.0, _degrees(1298, -135.0, 45.0)), abs=0.01)
    assert got[1] == pytest.approx(-89.92, abs=0.01)  # what the flight's report read
    assert _sight_pitch(cams[1][1:], 180.0, 179.935, -89.610) == pytest.approx(89.21, abs=0.01)  # MNT read pan-roll-tilt
    # the tilt, -95.62° under 5.82° nose up and 100 ms later -96.75° under 7.02°, holds the camera within 0.3° of
    # straight down
    at_outputs = [_sight(att, 0.0, 0.0, _degrees(pw[9], -135.0, 45.0)) for _, pw, att in pwm[2:4]]
    share = (cams[2][0] - pwm[2][0]) / (pwm[3][0] - pwm[2][0])
    assert got[2] == pytest.approx(_pitch(at_outputs[0] + share * (at_outputs[1] - at_outputs[0])), abs=0.01)
    assert got[2] == pytest.approx(-89.75, abs=0.01)  # what the flight's report read
    at_outputs = [_sight(att, 90.0, _degrees(pw[11], -30.0, 30.0), _degrees(pw[9], -135.0, 45.0)) for _, pw, att in pwm[4:]]
    assert got[3] == pytest.approx(_pitch(at_outputs[0] + at_outputs[1]), abs=0.01)


def test_a_camera_held_through_a_gap_in_the_log_reads_as_held(tmp_path):
    """ArduPilot SITL at speedup 20 drops log messages when its writer falls behind (RCOU and ATT 300-400 ms apart
    in a quiet run, longer on a busy machine): a copter braking at a line end, level for 0.5 s and then pitching up
    30°/s, its tilt servo holding the camera straight down (-90° less its pitch), the outputs between t = 0 and 1 s
    lost and the picture at 0.8 s. The camera reads straight down; its tilt interpolated under the picture's own
    attitude would read 3° off (the interpolated tilt -102°, the vehicle 9° nose up), past the 2° a flight's aim is
    allowed: a SITL flight was failed so (4.29° at the last photo of a resumed sortie, 124 of 124 photos within 0.41 m)."""
    from dfwriter import mount_log

    log = tmp_path / "m.BIN"

    def pitch(t: float) -> float:
        return max(0.0, t - 0.5) * 30.0

    def tilt_pwm(t: float) -> int:
        return round(1100 + (-90.0 - pitch(t) + 135.0) / 180.0 * 800.0)

    outputs = [(t, {9: tilt_pwm(t), 10: 1500, 11: 1500}, (0.0, pitch(t), 0.0)) for t in (0.0, 1.0, 1.1)]
    log.write_bytes(mount_log([(0.8, 0.0, pitch(0.8), 0.0)], [(0.0, 0.0, -90.0, 0.0)], outputs, HARNESS_MOUNT))
    assert sitl_run.mount_pitch_at_photos(log) == [pytest.approx(-90.0, abs=0.15)]  # a 1 µs output step is 0.225°
    tilt = np.interp(0.8, [0.0, 1.0], [_degrees(tilt_pwm(0.0), -135.0, 45.0), _degrees(tilt_pwm(1.0), -135.0, 45.0)])
    assert _sight_pitch((0.0, pitch(0.8), 0.0), 0.0, 0.0, float(tilt)) == pytest.approx(-87.0, abs=0.1)  # 3° past straight down


def test_a_servo_at_its_stop_reads_where_it_stopped(tmp_path):
    """ArduPilot's own tilt limit (MNT1_PITCH_MIN -90) in the same 5 m/s of wind: at the line end the
    vehicle 6.61° nose up, the tilt servo stopped at -90 (1100 µs), so the camera looked 6.6° off
    straight down, as read (the harness's mount now tilts to -135: sitl/aerosurvey-sitl.parm)."""
    from dfwriter import mount_log

    log = tmp_path / "m.BIN"
    params = {**HARNESS_MOUNT, "MNT1_PITCH_MIN": -90.0, "MNT1_PITCH_MAX": 20.0}
    log.write_bytes(mount_log([(144.20, 0.08, 6.61, 269.85)], [(144.14, 0.0, -89.98, 0.0)],
                              [(144.14, {9: 1100, 10: 1500, 11: 1500}, (0.08, 6.61, 269.85))], params))
    assert sitl_run.mount_pitch_at_photos(log) == [pytest.approx(-83.39, abs=0.01)]


def test_the_aim_is_not_known_without_the_servos_outputs_or_the_parameters_that_map_them(tmp_path):
    """No RCOU, no vehicle attitude logged with the outputs (ATT), no PARM, no tilt servo among the outputs, a
    limit of the tilt or of the roll servo missing, a servo on an output RCOU does not log, or no MNT: every picture's
    aim is unknown (None), which fails the flight's aim
    (`aim_error_deg`), never a guess. A mount without a roll or pan servo holds that axis at 0°."""
    from dfwriter import mount_log

    cams, mnts = [(1.0, 0.0, 10.0, 0.0)], [(0.9, 0.0, -90.0, 0.0)]
    pwm = [(0.9, {9: 1300, 10: 1500, 11: 1200}, (0.0, 10.0, 0.0))]  # tilt -90°, pan 0°, roll -22.5°
    no_tilt = {**HARNESS_MOUNT, "SERVO9_FUNCTION": 0.0}
    no_limit = {k: v for k, v in HARNESS_MOUNT.items() if k != "MNT1_PITCH_MIN"}
    no_roll_limit = {k: v for k, v in HARNESS_MOUNT.items() if k != "MNT1_ROLL_MAX"}
    # the roll servo on output 15, which RCOU does not log (C1 … C14): its angle, and so the aim, is not known
    roll_unlogged = {**HARNESS_MOUNT, "SERVO11_FUNCTION": 0.0, "SERVO15_FUNCTION": 8.0, "SERVO15_MIN": 1100.0,
                     "SERVO15_MAX": 1900.0}
    log = tmp_path / "m.BIN"
    no_attitude = [(0.9, pwm[0][1], None)]
    for mounts, outputs, params in ((mnts, [], HARNESS_MOUNT), (mnts, no_attitude, HARNESS_MOUNT), (mnts, pwm, {}), (mnts, pwm, no_tilt),
                                    (mnts, pwm, no_limit), (mnts, pwm, no_roll_limit), (mnts, pwm, roll_unlogged),
                                    ([], pwm, HARNESS_MOUNT)):
        log.write_bytes(mount_log(cams, mounts, outputs, params))
        assert sitl_run.mount_pitch_at_photos(log) == [None]
    log.write_bytes(mount_log(cams, mnts, pwm, HARNESS_MOUNT))
    assert sitl_run.mount_pitch_at_photos(log) == [pytest.approx(_sight_pitch((0.0, 10.0, 0.0), 0.0, -22.5, -90.0), abs=0.01)]
    # no roll servo: the camera is not rolled; under a vehicle 10° nose up a tilt of -90° looks 80° down
    log.write_bytes(mount_log(cams, mnts, pwm, {**HARNESS_MOUNT, "SERVO11_FUNCTION": 0.0}))
    assert sitl_run.mount_pitch_at_photos(log) == [pytest.approx(-80.0, abs=0.01)]
    # a reversed servo runs from its maximum angle at SERVOn_MIN: 1300 µs is then 0° of tilt, not -90°: the camera
    # looks ahead, 10° up with the vehicle's nose
    log.write_bytes(mount_log(cams, mnts, pwm, {**HARNESS_MOUNT, "SERVO9_REVERSED": 1.0, "SERVO11_FUNCTION": 0.0}))
    assert sitl_run.mount_pitch_at_photos(log) == [pytest.approx(10.0, abs=0.01)]


@settings(max_examples=60, deadline=None)
@given(vehicle=st.tuples(st.floats(-35.0, 35.0), st.floats(-35.0, 35.0), st.floats(0.0, 360.0)),
       outputs=st.tuples(st.integers(1100, 1900), st.integers(1100, 1900), st.integers(1100, 1900)),
       near_nadir=st.booleans())
def test_the_camera_pitch_is_the_servo_chain_at_any_attitude(tmp_path_factory, vehicle, outputs, near_nadir):
    """Any vehicle attitude and any servo outputs, the tilt often at or next to straight down (1290
    to 1310 µs: -92.25° to -87.75°, 1300 µs exactly -90°): the reading is scipy's pan-roll-tilt chain of
    the servo angles within 0.01°."""
    from dfwriter import mount_log

    tilt, pan, roll = outputs
    if near_nadir:
        tilt = 1290 + tilt % 21
    log = tmp_path_factory.mktemp("chain") / "m.BIN"
    log.write_bytes(mount_log([(1.0, *vehicle)], [(0.9, 0.0, 0.0, 0.0)], [(1.0, {9: tilt, 10: pan, 11: roll}, vehicle)], HARNESS_MOUNT))
    want = _sight_pitch(vehicle, _degrees(pan, -180.0, 180.0), _degrees(roll, -30.0, 30.0), _degrees(tilt, -135.0, 45.0))
    assert sitl_run.mount_pitch_at_photos(log) == [pytest.approx(want, abs=0.01)]


def test_the_flown_aim_is_judged_against_the_plan():
    """The largest pitch difference from the planned, picture by picture; unknown (None) when a
    picture has no mount reading."""
    assert sitl_run.aim_error_deg([-44.0, -46.5, -45.2], (-45.0, -45.0, -45.0)) == 1.5
    assert sitl_run.aim_error_deg([-90.0, -42.9], (-90.0, -45.0)) == 2.1
    assert sitl_run.aim_error_deg([None, -45.0], (-45.0, -45.0)) is None
    assert sitl_run.aim_error_deg([], (-45.0,)) is None


def test_a_camera_intervalometer_plan_is_judged_on_neither_photos_nor_aim(tmp_path, monkeypatch):
    """camera.trigger = "camera": SITL takes no picture, so there is no photo whose aim the log gives;
    the row says neither was judged, and the flight is not failed for it (it is for its gimbal otherwise)."""
    spec = make_spec(tmp_path, {"flight": {"heading": 0.0}, "camera": {"trigger": "camera", "interval_s": 2.0}})
    plan = tmp_path / "plan"
    assert CliRunner().invoke(main, ["plan", str(spec), "-o", str(plan)]).exit_code == 0
    doc = mf.read_manifest(plan)

    def fake_fly(sv, mission, name, est, last_item, timeout_factor, upload, rtl_after_photos=None, wind=None):
        f = harness.Flight(name)
        f.track.append((0, 0.0, 0.0, 100.0))
        f.armed_ms, f.disarmed_ms, f.completed = 1, 1 + round(est * 1000), True
        return f

    mounts = _stand_in(monkeypatch, fake_fly)
    rows = sitl_run.fly_sorties(doc, plan, sitl_run.SitlSettings("copter", Path("/bin/true"), (), 10.0, 3.0),
                                tmp_path / "report", lambda row: None)
    assert mounts and all(mounts)  # the gimbal set straight down: flown with the mount, but no picture to judge
    assert rows and all(r["triggers_match"] is None and "aim_ok" not in r and "mount_pitch_deg" not in r for r in rows)


@pytest.mark.parametrize("to", [(0.001, 0.0), (0.0, 0.001), (-0.0008, -0.0012), (0.0005, -0.002)])
def test_a_plane_is_launched_towards_its_first_place_after_the_take_off(to):
    """ArduPlane climbs out along the heading it is launched on; the plan's climb-out heads for the first place
    after the take-off (the speed item has none): the harness launches the SITL plane there (pyproj's bearing)."""
    from pyproj import Geod

    from aerosurvey.mission import mavlink_ids as mav
    from aerosurvey.mission.items import Mission, MissionItem

    home = (49.4, 15.0, 0.0)
    dlat, dlon = to
    items = (MissionItem(mav.NAV_TAKEOFF, x=home[0], y=home[1], z=100.0), MissionItem(mav.DO_CHANGE_SPEED, mav.FRAME_MISSION),
             MissionItem(mav.NAV_WAYPOINT, x=home[0] + dlat, y=home[1] + dlon, z=100.0),
             MissionItem(mav.NAV_WAYPOINT, x=home[0], y=home[1] + 0.01, z=100.0))
    bearing = Geod(ellps="WGS84").inv(home[1], home[0], home[1] + dlon, home[0] + dlat)[0] % 360.0
    got = harness.launch_heading_deg(Mission("plane", "ardupilot", home, items, 16.0, 12.5))
    assert abs((got - bearing + 180.0) % 360.0 - 180.0) < 0.5
    assert harness.launch_heading_deg(Mission("plane", "ardupilot", home, items[:2], 16.0, 12.5)) == 0.0


class _Track:
    """A SITL vehicle's link that replays a plane's positions
    (time ms, metres north of home, height above home) at 15.0 E, the last item reached after the second."""

    def __init__(self, points):
        from pymavlink.dialects.v20 import ardupilotmega as mavlink

        self.vehicle, self.home, self.speedup = "plane", (49.4, 15.0, 0.0), 20.0
        self.messages = [mavlink.MAVLink_global_position_int_message(ms, int(round((49.4 + north / 111_195.0) * 1e7)),
                                                                     int(15.0e7), 0, int(alt * 1000), 0, 0, 0, 0)
                         for ms, north, alt in points]
        self.messages.insert(2, mavlink.MAVLink_mission_current_message(5))  # after the take-off and the way out
        self.conn = self

    def start_mission(self, params):
        pass

    def check_running(self, when):
        raise AssertionError(f"the flight did not end {when}")

    def recv_match(self, blocking, timeout):
        return self.messages.pop(0) if self.messages else None


@pytest.mark.parametrize("lands", [True, False])
def test_a_landing_plane_is_over_at_its_touchdown_and_one_ending_in_rtl_over_home(lands):
    """The estimate of a sortie that lands ends at the touchdown; of one that ends in RTL, back over home."""
    from aerosurvey.mission import mavlink_ids as mav
    from aerosurvey.mission.items import Mission, MissionItem

    end = MissionItem(mav.NAV_LAND, x=49.4, y=15.0) if lands else MissionItem(mav.NAV_RETURN_TO_LAUNCH)
    items = (MissionItem(mav.NAV_TAKEOFF, x=49.4, y=15.0, z=100.0), MissionItem(mav.NAV_WAYPOINT, x=49.41, y=15.0, z=100.0),
             MissionItem(mav.DO_LAND_START, mav.FRAME_MISSION), MissionItem(mav.NAV_WAYPOINT, x=49.404, y=15.0, z=30.0), end)
    mission = Mission("plane", "ardupilot", (49.4, 15.0, 0.0), items, 16.0, 12.5)
    points = [(0, 0.0, 0.0), (10_000, 400.0, 30.0), (40_000, 149.0, 11.0), (50_000, 75.0, 5.0), (60_000, 5.0, 0.4), (61_000, 0.0, 0.0)]
    flight = harness.fly(_Track(points), mission, "S01", 600.0, 5, 3.0, lambda m: "uploaded")
    assert flight.completed
    assert flight.disarmed_ms == (60_000 if lands else 40_000)


def test_a_new_aim_commanded_as_the_picture_is_taken_does_not_leak_into_it(tmp_path):
    """A smart oblique in ArduCopter SITL (outputs as logged): the mount is turned to the next aim by the
    DO_MOUNT_CONTROL after each photo, so the output logged after the picture is already the next aim's,
    tilted 30° or panned 90° on. A picture whose camera turned by more than 10° between the outputs either
    side reads the output before it (interpolated, the nadir would read -73.6°; the next oblique, panned 90°, would
    keep its pitch but look 45° off its bearing)."""
    from dfwriter import mount_log

    log = tmp_path / "m.BIN"
    cams = [(126.894222, 0.1, 0.2, 179.8), (128.896754, 0.2, 0.0, 179.8)]
    mnts = [(126.85, 179.9, -89.8, 180.0), (128.85, -0.2, -60.0, 0.0)]
    pwm = [(126.839244, {9: 1299, 10: 1500, 11: 1500}, cams[0][1:]), (126.939204, {9: 1432, 10: 1500, 11: 1498}, cams[0][1:]),
           (128.839277, {9: 1433, 10: 1500, 11: 1497}, cams[1][1:]), (128.939237, {9: 1434, 10: 1700, 11: 1500}, cams[1][1:])]
    log.write_bytes(mount_log(cams, mnts, pwm, HARNESS_MOUNT))
    got = sitl_run.mount_pitch_at_photos(log)
    at_outputs = [_sight_pitch(att, _degrees(pw[10], -180.0, 180.0), _degrees(pw[11], -30.0, 30.0), _degrees(pw[9], -135.0, 45.0))
                  for _, pw, att in pwm]
    assert got == [pytest.approx(at_outputs[0], abs=0.01), pytest.approx(at_outputs[2], abs=0.01)]
    assert got[0] == pytest.approx(-89.9, abs=0.3) and got[1] == pytest.approx(-60.0, abs=0.3)
