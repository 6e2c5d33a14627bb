"""`sitl fly`'s work without a SITL binary: the sortie routes from the manifest, and the fly loop
driven through a stand-in for the process harness (the real one is tested in tests/test_sitl.py)."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

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

    def fake_fly(sv, mission, name, est, last_item, timeout_factor, upload, rtl_after_photos=None):
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
    # a nadir plan only sets the gimbal straight down at its first run: SITL flies it without a mount and its aim
    # is not judged (sitl/README.md: at -90 degrees the mount's logged angles are not read reliably)
    assert mounts == [False] * len(routes)
    assert all("mount_pitch_deg" not in r and "aim_ok" not in r for r in rows)
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

    def fake_fly(sv, mission, name, est, last_item, timeout_factor, upload, rtl_after_photos=None):
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

    def fake_fly(sv, mission, name, est, last_item, timeout_factor, upload, rtl_after_photos=None):
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


def test_the_camera_pitch_at_each_picture_turns_the_servo_angles_by_the_vehicle_attitude(tmp_path):
    """A servo mount logs its angles relative to the body, driven pan, then roll, then tilt: a
    vehicle pitched 20° nose down with the servo at -25° looks 45° down; rolled 10° with the
    servo rolled back -10°, still 45°; panned 90° (looking to the right) while pitched 20° nose
    down, the lean is taken off the roll servo and the camera still looks 45° down (turned in
    yaw-pitch-roll order it would read -41.6°)."""
    from dfwriter import mount_log
    from scipy.spatial.transform import Rotation

    log = tmp_path / "m.BIN"
    # (time_s, vehicle roll, pitch, yaw) per picture; (time_s, roll, pitch, yaw_body) per mount message
    cams = [(0.5, 0.0, 0.0, 90.0), (2.0, 0.0, -20.0, 270.0), (3.0, 10.0, -20.0, 45.0), (4.0, 3.0, -7.0, 10.0),
            (5.0, 0.0, -20.0, 30.0), (6.0, 0.0, 15.0, 200.0)]
    mnts = [(1.0, 0.0, -45.0, 0.0), (2.0, 0.0, -25.0, 0.0), (2.9, -10.0, -25.0, 0.0), (3.5, 5.0, -30.0, 12.0),
            (4.5, 20.0, -45.0, 90.0), (5.5, 15.0, -45.0, -90.0)]
    log.write_bytes(mount_log(cams, mnts))
    got = sitl_run.mount_pitch_at_photos(log)
    assert got[0] is None  # before the mount's first message
    assert got[1] == pytest.approx(-45.0, abs=0.01)
    assert got[4] == pytest.approx(-45.0, abs=0.01) and got[5] == pytest.approx(-45.0, abs=0.01)
    # scipy's intrinsic rotations: the body yaw-pitch-roll ("ZYX"), the mount pan-roll-tilt ("ZXY")
    expected = [(Rotation.from_euler("ZYX", [c[3], c[2], c[1]], degrees=True)
                 * Rotation.from_euler("ZXY", [m[3], m[1], m[2]], degrees=True)).apply([1.0, 0.0, 0.0])
                for c, m in zip(cams[1:], mnts[1:])]
    assert got[1:] == pytest.approx([float(np.degrees(np.arcsin(-v[2]))) for v in expected], abs=0.01)
    wrong = (Rotation.from_euler("ZYX", [30.0, -20.0, 0.0], degrees=True)
             * Rotation.from_euler("ZYX", [90.0, -45.0, 20.0], degrees=True)).apply([1.0, 0.0, 0.0])
    assert float(np.degrees(np.arcsin(-wrong[2]))) == pytest.approx(-41.64, abs=0.01)  # the yaw-pitch-roll reading


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

    def fake_fly(sv, mission, name, est, last_item, timeout_factor, upload, rtl_after_photos=None):
        f = harness.Flight(name)
        f.track.append((0, 0.0, 0.0, 100.0))
        f.armed_ms, f.disarmed_ms, f.completed = 1, 1 + round(est * 1000), True
        return f

    mounts = _stand_in(monkeypatch, fake_fly)
    rows = sitl_run.fly_sorties(doc, plan, sitl_run.SitlSettings("copter", Path("/bin/true"), (), 10.0, 3.0),
                                tmp_path / "report", lambda row: None)
    assert mounts and not any(mounts)  # straight down only: flown without a mount (sitl/README.md)
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

    def start_mission(self):
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
