"""`aerosurvey upload` reads the vehicle's settings a mission depends on and refuses, in one line
naming the parameter, its value and what the mission needs, what would fly other than planned;
`--accept NAME` overrides exactly that one check, and the report says so. A plan that fails an
error-severity rule uploads only when every such rule is named.

Against the fake vehicle answering PARAM_REQUEST_READ as ArduPilot (a value cast to the float)
and PX4 (an integer's bytes in the float) do; every check refuses with the parameter set wrong and
passes with it corrected. The expected lines are written out here from the test's own figures.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

import pytest
from click.testing import CliRunner
from fake_vehicle import FakeVehicle, VehicleModel, survey_mission
from test_link_checks import home_of, planned_folder, refused

from aerosurvey.cli import main
from aerosurvey.mission import mavlink_ids as mav
from aerosurvey.mission.formats.qgc_plan import dumps_plan, loads_plan
from aerosurvey.mission.items import Mission

if TYPE_CHECKING:
    from aerosurvey.link.px4_sitl import Px4Vehicle
    from aerosurvey.link.sitl import SitlVehicle


def upload(plan: Path, model: VehicleModel, *options: str):
    with FakeVehicle(model, "udp") as fv:
        return CliRunner().invoke(main, ["upload", str(plan), "--connect", fv.url, *options])


def mission_messages(model: VehicleModel) -> int:
    return sum(v for k, v in model.log.items() if k.startswith("got MISSION_"))


def uploaded(plan: Path, model: VehicleModel, *options: str) -> list[str]:
    res = upload(plan, model, *options)
    assert res.exit_code == 0, res.output
    assert len(model.stored[0]) > 0
    return res.output.splitlines()


def write(tmp_path: Path, m: Mission) -> Path:
    plan = tmp_path / "survey.plan"
    plan.write_text(dumps_plan(m))
    return plan


def in_terrain_frame(m: Mission) -> Mission:
    return dataclasses.replace(m, items=tuple(dataclasses.replace(it, frame=mav.FRAME_GLOBAL_TERRAIN_ALT)
                                              if it.frame == mav.FRAME_GLOBAL_RELATIVE_ALT else it for it in m.items))


def test_terrain_frame_without_terrain_data_is_refused_and_passes_with_it(tmp_path: Path) -> None:
    m = in_terrain_frame(survey_mission(4))
    plan = write(tmp_path, m)
    n = sum(1 for it in m.items if it.frame == mav.FRAME_GLOBAL_TERRAIN_ALT)
    assert n == 5
    off = VehicleModel(storage="ardupilot", home=m.home, params={"TERRAIN_ENABLE": 0})
    assert refused(plan, off) == (
        f"Error: survey.plan: TERRAIN_ENABLE = 0 but the mission flies {n} item(s) in the terrain frame: ArduPilot without "
        "terrain data flies them as heights above home; set TERRAIN_ENABLE = 1 (with terrain data on its SD card or from "
        "the ground station), or plan it with relative altitudes (or give --accept terrain)")
    assert off.log["got PARAM_REQUEST_READ TERRAIN_ENABLE"] >= 1
    lines = uploaded(plan, VehicleModel(storage="ardupilot", home=m.home, params={"TERRAIN_ENABLE": 1}))
    assert f"terrain: TERRAIN_ENABLE = 1 for {n} item(s) in the terrain frame" in lines
    # a build without terrain has no TERRAIN_ENABLE at all
    assert refused(plan, VehicleModel(storage="ardupilot", home=m.home, params={"TERRAIN_ENABLE": None})).startswith(
        f"Error: survey.plan: the vehicle has no TERRAIN_ENABLE but the mission flies {n} item(s) in the terrain frame")
    # the pilot overrides this one check, and the report says so
    lines = uploaded(plan, VehicleModel(storage="ardupilot", home=m.home, params={"TERRAIN_ENABLE": 0}),
                     "--accept", "terrain")
    assert any(line.startswith("terrain: ACCEPTED by the pilot (--accept terrain): TERRAIN_ENABLE = 0 but") for line in lines)


def test_accept_overrides_exactly_the_check_it_names(tmp_path: Path) -> None:
    m = in_terrain_frame(survey_mission(4))
    plan = write(tmp_path, m)
    both = {"TERRAIN_ENABLE": 0, "CAM1_TYPE": 0}
    # the terrain accepted, the camera still refuses
    assert refused(plan, VehicleModel(storage="ardupilot", home=m.home, params=both), "--accept", "terrain") == (
        "Error: survey.plan: CAM1_TYPE = 0 (no camera) but the mission takes photos with 1 item(s) "
        "(DO_SET_CAM_TRIGG_DIST): no photo would be taken; set CAM1_TYPE to the camera's trigger (1 servo, 2 relay, "
        "5 MAVLink …) and reboot (or give --accept camera)")
    lines = uploaded(plan, VehicleModel(storage="ardupilot", home=m.home, params=both), "--accept", "terrain",
                     "--accept", "camera")
    assert sum("ACCEPTED by the pilot" in line for line in lines) == 2
    # a name that is no check and no rule of the plan is bad input
    res = upload(plan, VehicleModel(storage="ardupilot", home=m.home), "--accept", "terrian")
    assert res.exit_code == 2
    assert "--accept 'terrian' is not a check of upload nor a rule of the plan: the checks are terrain, camera, " \
           "rtl-altitude, speed, battery-failsafe, leg-length" in res.output


@pytest.mark.parametrize("px4", [False, True])
def test_a_camera_mission_without_a_camera_is_refused(tmp_path: Path, px4: bool) -> None:
    m = survey_mission(4, firmware="px4" if px4 else "ardupilot")
    plan = write(tmp_path, m)
    kw = {"px4": True} if px4 else {"storage": "ardupilot"}
    wrong, right = ({"TRIG_MODE": 0}, {"TRIG_MODE": 4}) if px4 else ({"CAM1_TYPE": 0}, {"CAM1_TYPE": 2})
    line = refused(plan, VehicleModel(home=m.home, params=wrong, **kw))
    if px4:
        assert line == ("Error: survey.plan: TRIG_MODE = 0 (the camera trigger is disabled) but the mission takes photos "
                        "with 1 item(s) (DO_SET_CAM_TRIGG_DIST): set TRIG_MODE = 4 and reboot (or give --accept camera)")
        # a time-based trigger never hears the mission's distance
        assert "TRIG_MODE = 1 (not by distance on command" in refused(
            plan, VehicleModel(home=m.home, params={"TRIG_MODE": 1}, **kw))
    else:
        assert line.startswith("Error: survey.plan: CAM1_TYPE = 0 (no camera) but the mission takes photos with 1 item(s)")
    lines = uploaded(plan, VehicleModel(home=m.home, params=right, **kw))
    said = "TRIG_MODE = 4, TRIG_INTERFACE = 3" if px4 else "CAM1_TYPE = 2"
    assert f"camera: {said}, and the mission takes photos with 1 item(s) (DO_SET_CAM_TRIGG_DIST)" in lines


def test_a_speed_limit_below_the_commanded_speed_is_refused(tmp_path: Path) -> None:
    m = survey_mission(4, firmware="px4")  # DO_CHANGE_SPEED 12.5 m/s
    plan = write(tmp_path, m)
    assert refused(plan, VehicleModel(px4=True, home=m.home, params={"MPC_XY_VEL_MAX": 12.0})) == (
        "Error: survey.plan: MPC_XY_VEL_MAX = 12 m/s but the mission commands 12.5 m/s (DO_CHANGE_SPEED): the vehicle "
        "would fly slower and the photos' timing, blur and the flight time would change; raise MPC_XY_VEL_MAX to at "
        "least 12.5 (or give --accept speed)")
    lines = uploaded(plan, VehicleModel(px4=True, home=m.home, params={"MPC_XY_VEL_MAX": 12.5}))
    assert "speed: the mission commands 12.5 m/s, within MPC_XY_VEL_MAX = 12.5 m/s" in lines


def test_a_plane_whose_airspeed_limit_is_below_the_mission_is_refused(tmp_path: Path) -> None:
    m = survey_mission(4, vehicle="plane")
    speed = next(it for it in m.items if it.command == mav.DO_CHANGE_SPEED)
    m = dataclasses.replace(m, items=tuple(dataclasses.replace(it, param1=0.0, param2=18.0) if it is speed else it
                                           for it in m.items))  # an airspeed, as aerosurvey writes it for planes
    plan = write(tmp_path, m)
    model = VehicleModel(storage="ardupilot", plane=True, home=m.home, params={"AIRSPEED_MAX": 17.0})
    assert refused(plan, model).startswith("Error: survey.plan: AIRSPEED_MAX = 17 m/s but the mission commands 18 m/s")
    # ArduPlane before 4.5 calls it ARSPD_FBW_MAX
    old = VehicleModel(storage="ardupilot", plane=True, home=m.home, params={"AIRSPEED_MAX": None, "ARSPD_FBW_MAX": 22.0})
    assert "speed: the mission commands 18 m/s, within ARSPD_FBW_MAX = 22 m/s" in uploaded(plan, old)


def test_a_default_speed_other_than_the_planned_one_is_refused_when_the_mission_commands_none(tmp_path: Path) -> None:
    m = survey_mission(4)
    m = dataclasses.replace(m, items=tuple(it for it in m.items if it.command != mav.DO_CHANGE_SPEED))
    plan = write(tmp_path, m)  # a copter plan flown at its hover speed, 5 m/s
    assert refused(plan, VehicleModel(storage="ardupilot", home=m.home, params={"WPNAV_SPEED": 1000.0})) == (
        "Error: survey.plan: WPNAV_SPEED = 1000 (10 m/s) but the mission commands no speed and was planned at 5 m/s "
        "(photo spacing and flight time follow it): set WPNAV_SPEED to it (or give --accept speed)")
    assert "speed: WPNAV_SPEED = 500 (5 m/s), the planned 5 m/s (no DO_CHANGE_SPEED)" in uploaded(
        plan, VehicleModel(storage="ardupilot", home=m.home, params={"WPNAV_SPEED": 500.0}))


@pytest.fixture(scope="module")
def plan_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A copter plan folder made by `aerosurvey plan`, its battery keeping 25 % in reserve."""
    return planned_folder(tmp_path_factory.mktemp("settings"), {"battery": {"usable_min": 60.0, "reserve": 0.25}})


def copy_folder(src: Path, dst: Path, change=None) -> Path:
    """The plan folder's manifest (changed by `change`, a function of its JSON) and mission.plan, in `dst`."""
    dst.mkdir()
    doc = json.loads((src / "manifest.json").read_text())
    if change is not None:
        change(doc)
    (dst / "manifest.json").write_text(json.dumps(doc))
    (dst / "mission.plan").write_bytes((src / "mission.plan").read_bytes())
    return dst / "mission.plan"


def test_an_ardupilot_battery_failsafe_below_the_plans_reserve_is_refused(plan_folder: Path, tmp_path: Path) -> None:
    plan = copy_folder(plan_folder, tmp_path / "plan")
    model = VehicleModel(storage="ardupilot", home=home_of(plan), params={"BATT_LOW_MAH": 500.0, "BATT_CAPACITY": 5000.0})
    assert refused(plan, model) == (
        "Error: mission.plan: BATT_LOW_MAH = 500 of BATT_CAPACITY = 5000 mAh (10%) but the plan keeps 25% in reserve: "
        "the failsafe would act only after the reserve is spent; raise BATT_LOW_MAH to at least 1250 "
        "(or give --accept battery-failsafe)")
    lines = uploaded(plan, VehicleModel(storage="ardupilot", home=home_of(plan),
                                        params={"BATT_LOW_MAH": 1250.0, "BATT_CAPACITY": 5000.0}))
    assert "battery-failsafe: BATT_LOW_MAH = 1250 of BATT_CAPACITY = 5000 mAh (25%), at or above the plan's 25% reserve" \
        in lines
    lines = uploaded(plan, VehicleModel(storage="ardupilot", home=home_of(plan), params={"BATT_LOW_MAH": 0.0}))
    assert ("battery-failsafe: BATT_FS_LOW_ACT = 2, BATT_LOW_MAH = 0, BATT_CAPACITY = 3300: by voltage only, which cannot "
            "be compared with the plan's 25% reserve") in lines
    assert refused(plan, VehicleModel(storage="ardupilot", home=home_of(plan), params={"BATT_FS_LOW_ACT": 0})) == (
        "Error: mission.plan: BATT_FS_LOW_ACT = 0 (no action): nothing brings the vehicle back on a low battery; the plan "
        "keeps 25% in reserve: set a battery failsafe (or give --accept battery-failsafe)")


def test_a_px4_battery_failsafe_below_the_plans_reserve_is_refused(tmp_path: Path) -> None:
    plan = planned_folder(tmp_path, {"battery": {"usable_min": 60.0, "reserve": 0.2}, "vehicle": {"firmware": "px4"}}) \
        / "mission.plan"
    model = VehicleModel(px4=True, home=home_of(plan), params={"BAT_CRIT_THR": 0.07})
    assert refused(plan, model) == (
        "Error: mission.plan: BAT_CRIT_THR = 0.07 (7%, COM_LOW_BAT_ACT = 3) but the plan keeps 20% in reserve: the "
        "failsafe would act only after the reserve is spent; raise BAT_CRIT_THR to at least 0.2 "
        "(or give --accept battery-failsafe)")
    lines = uploaded(plan, VehicleModel(px4=True, home=home_of(plan), params={"BAT_CRIT_THR": 0.2}))
    assert "battery-failsafe: BAT_CRIT_THR = 0.2 (20%, COM_LOW_BAT_ACT = 3), at or above the plan's 20% reserve" in lines


def _hill(doc: dict) -> None:
    """The manifest's DEM figures of a plan whose highest ground lies 70 m above the launch point."""
    doc["home"]["ground_amsl_m"] = 400.0
    doc["derived"]["terrain"]["ground_max_m"] = 470.0


def test_an_rtl_altitude_into_the_ground_under_the_plan_is_refused(plan_folder: Path, tmp_path: Path) -> None:
    """The manifest's DEM figures: the highest ground 70 m above the launch point."""
    plan = copy_folder(plan_folder, tmp_path / "plan", _hill)
    model = VehicleModel(storage="ardupilot", home=home_of(plan), params={"RTL_ALT": 6000})
    assert refused(plan, model) == (
        "Error: mission.plan: RTL_ALT = 6000 (60 m) but the plan's ground rises 70 m above the launch point, and a return "
        "at 60 m clears it by less than 30 m: set RTL_ALT to fit, or plan again (or give --accept rtl-altitude)")
    lines = uploaded(plan, VehicleModel(storage="ardupilot", home=home_of(plan), params={"RTL_ALT": 10000}))
    line = next(x for x in lines if x.startswith("rtl-altitude:"))
    assert line.startswith("rtl-altitude: RTL_ALT = 10000 (100 m): clears the highest ground under the plan (70 m above "
                           "the launch point) by 30 m")
    assert "no official zone file in the plan" in line
    # without DEM figures the ground is not checked, and the line says so
    flat = copy_folder(plan_folder, tmp_path / "flat")
    lines = uploaded(flat, VehicleModel(storage="ardupilot", home=home_of(flat)))
    assert any("the ground on the way home not checked (no DEM figures in the manifest)" in x for x in lines)


def test_an_rtl_altitude_above_the_return_the_zones_were_checked_at_is_refused(plan_folder: Path, tmp_path: Path) -> None:
    def zones(doc: dict) -> None:
        doc["airspace"] = {"version": 1, "files": [], "authorisations": [], "window": None, "zones_read": 1,
                           "zones": [{"file": "zones.json", "format": "ED-269", "identifier": "LKR1", "name": "Airport",
                                      "restriction": "PROHIBITED", "lower": {"m": 120.0, "reference": "AMSL"},
                                      "upper": None, "verdict": "neither", "reason": "below the band", "message": "",
                                      "legs": []}],
                           "notes": []}

    plan = copy_folder(plan_folder, tmp_path / "plan", zones)
    m = loads_plan(plan.read_text())
    rtl = next(k for k, it in enumerate(m.items) if it.command == mav.NAV_RETURN_TO_LAUNCH)
    back = [it for it in m.items[:rtl] if it.has_position][-1].z
    above = int((back + 20) * 100)
    res = upload(plan, VehicleModel(storage="ardupilot", home=m.home, params={"RTL_ALT": above}))
    assert res.exit_code == 3, res.output
    assert res.output.strip() == (
        f"Error: mission.plan: RTL_ALT = {above} ({above / 100:g} m) but the plan's return was checked at {back:g} m "
        f"against 1 official zone(s) near the flights (Airport), and the vehicle climbs to {above / 100:g} m first: set "
        "RTL_ALT to fit, or plan again (or give --accept rtl-altitude)")
    lines = uploaded(plan, VehicleModel(storage="ardupilot", home=m.home, params={"RTL_ALT": int(back * 100)}))
    assert any(f"at or below the {back:g} m the plan's return was checked at against the official zones" in x for x in lines)


def test_a_plan_that_fails_a_rule_uploads_only_when_the_pilot_names_it(plan_folder: Path, tmp_path: Path) -> None:
    def fail(doc: dict) -> None:
        doc["rules"][0]["status"] = "fail"

    doc = json.loads((plan_folder / "manifest.json").read_text())
    assert doc["rules"], "the plan records its rules"
    rule = doc["rules"][0]["rule"]
    plan = copy_folder(plan_folder, tmp_path / "plan", fail)
    model = VehicleModel(storage="ardupilot", home=home_of(plan))
    assert refused(plan, model) == (
        f"Error: mission.plan: the plan fails 1 error-severity rule(s) ({rule}): `aerosurvey plan` wrote it for inspection "
        f"only (`aerosurvey check` shows the evidence); upload it only by naming each: --accept {rule}")
    assert model.log.get("got PARAM_REQUEST_READ TERRAIN_ENABLE") is None  # refused before the link was opened
    lines = uploaded(plan, model, "--accept", rule)
    assert f"rules: 1 error-severity rule(s) fail, ACCEPTED by the pilot (--accept {rule})" in lines
    # the plan as written passes its rules: nothing to accept
    lines = uploaded(plan_folder / "mission.plan", VehicleModel(storage="ardupilot", home=home_of(plan)))
    assert f"rules: {len(doc['rules'])} evaluated, none fails at error level" in lines


def test_the_documented_table_is_the_table_read() -> None:
    """docs/upload.md lists every parameter of SETTINGS with its autopilot and check, and no other."""
    from aerosurvey.link.vehicle_settings import SETTINGS

    text = (Path(__file__).resolve().parents[2] / "docs" / "upload.md").read_text()
    rows = [line.split("|")[1:5] for line in text.splitlines() if line.startswith("| `") and line.count("|") == 7]
    documented = {(name.strip().strip("`"), who.strip(), check.strip().strip("`")) for name, who, _, check in rows}
    read = {(s.name, {"ardupilot": "ArduPilot", "px4": "PX4"}[s.firmware], s.check) for s in SETTINGS}
    assert documented == read


@contextmanager
def ardupilot_copter_sitl(tmp_path: Path, home: tuple[float, float, float]) -> Iterator[SitlVehicle]:
    """ArduCopter SITL at `home` (skipped with the reason when no binary is found), stopped at the end."""
    from aerosurvey.errors import InputError
    from aerosurvey.link.sitl import SitlVehicle, default_params, find_binary

    try:
        binary = find_binary("copter", None)
    except InputError as exc:
        pytest.skip(str(exc))
    work = tmp_path / "sitl"
    work.mkdir()
    sv = SitlVehicle(binary, "copter", home, 1.0, list(default_params("copter")), work)
    try:
        sv.start()
        yield sv
    finally:
        sv.stop()


def held_mission_count(sv: SitlVehicle) -> int:
    """MISSION_COUNT as the SITL answers MISSION_REQUEST_LIST on the harness's link (ArduPilot: 0 before it has
    a home, then home counts as one), the transfer then ended with MISSION_ACK. Asked again every second: PX4's
    ground station link streams at 50 Hz, and an answer behind a full socket buffer is lost."""
    for _ in range(10):
        sv.conn.mav.mission_request_list_send(sv.conn.target_system, sv.conn.target_component)
        m = sv.conn.recv_match(type="MISSION_COUNT", blocking=True, timeout=1.0)
        if m is not None:
            sv.conn.mav.mission_ack_send(sv.conn.target_system, sv.conn.target_component, 0)  # MAV_MISSION_ACCEPTED
            return int(m.count)
    raise AssertionError("the SITL did not answer MISSION_REQUEST_LIST in 10 s")


def sitl_upload(plan: Path, sv: SitlVehicle):
    """`aerosurvey upload` to the SITL's second MAVLink port, the launch distance not compared."""
    return CliRunner().invoke(main, ["upload", str(plan), "--connect", sv.upload_url, "--launch-distance", "off"])


@pytest.mark.sitl
def test_ardupilot_sitl_without_terrain_data_refuses_a_terrain_frame_mission_and_takes_it_with(tmp_path: Path) -> None:
    """ArduCopter SITL: TERRAIN_ENABLE = 0 refuses the terrain-frame mission (nothing sent), 1 takes it and
    verifies it. The checks read the SITL's own parameters on its second MAVLink port (TCP 5762)."""
    m = in_terrain_frame(survey_mission(4))
    plan = write(tmp_path, m)
    right = {"TERRAIN_ENABLE": 1, "CAM1_TYPE": 1, "BATT_FS_LOW_ACT": 2}
    wrong = (("TERRAIN_ENABLE", 0, "TERRAIN_ENABLE = 0 but the mission flies 5 item(s) in the terrain frame"),)
    with ardupilot_copter_sitl(tmp_path, m.home) as sv:
        lines = refused_then_taken(sv, plan, right, wrong)
    assert "terrain: TERRAIN_ENABLE = 1 for 5 item(s) in the terrain frame" in lines
    assert any(line.startswith("verified: 10 mission items read back") for line in lines)


@pytest.mark.sitl
def test_ardupilot_sitl_refuses_each_setting_set_wrong_and_takes_the_mission_with_it_corrected(tmp_path: Path) -> None:
    """ArduCopter SITL, one boot: the camera (CAM1_TYPE = 0), the mission speed (a mission commanding no speed
    flown at WPNAV_SPEED 10 m/s for its planned 5) and the battery failsafe (BATT_FS_LOW_ACT = 0) each refuse
    the upload with nothing sent, naming the parameter and its value as SITL answers it; each set right, the
    mission uploads and verifies. The SITL's own parameters, read on its second MAVLink port (TCP 5762)."""
    m = survey_mission(4)
    m = dataclasses.replace(m, items=tuple(it for it in m.items if it.command != mav.DO_CHANGE_SPEED))  # planned at 5 m/s
    plan = write(tmp_path, m)
    right = {"CAM1_TYPE": 1, "WPNAV_SPEED": 500, "BATT_MONITOR": 4, "BATT_FS_LOW_ACT": 2}
    wrong = (("CAM1_TYPE", 0, "CAM1_TYPE = 0 (no camera) but the mission takes photos"),
             ("WPNAV_SPEED", 1000, "WPNAV_SPEED = 1000 (10 m/s) but the mission commands no speed and was planned at 5 m/s"),
             ("BATT_FS_LOW_ACT", 0, "BATT_FS_LOW_ACT = 0 (no action): nothing brings the vehicle back on a low battery"))
    with ardupilot_copter_sitl(tmp_path, m.home) as sv:
        lines = refused_then_taken(sv, plan, right, wrong)
    assert any(line.startswith("camera: CAM1_TYPE = 1") for line in lines), lines
    assert "speed: WPNAV_SPEED = 500 (5 m/s), the planned 5 m/s (no DO_CHANGE_SPEED)" in lines


@pytest.mark.sitl
def test_ardupilot_sitl_refuses_an_rtl_altitude_into_the_ground_and_takes_the_mission_with_it_raised(
        plan_folder: Path, tmp_path: Path) -> None:
    """ArduCopter SITL, the plan folder `aerosurvey plan` wrote, its manifest's ground rising 70 m above the
    launch point: RTL_ALT = 6000 (60 m, as SITL answers it in cm) refuses the upload, naming RTL_ALT, its value
    and the 100 m the return needs (70 m of ground and 30 m of clearance), with nothing sent; RTL_ALT = 10000
    takes the mission and verifies it. The plan's 25 % reserve: BATT_LOW_MAH 500 of 5000 mAh refuses, 1250 passes."""
    plan = copy_folder(plan_folder, tmp_path / "plan", _hill)
    m = loads_plan(plan.read_text())
    right = {"CAM1_TYPE": 1, "WPNAV_SPEED": round(m.hover_speed * 100), "BATT_MONITOR": 4, "BATT_FS_LOW_ACT": 2,
             "BATT_CAPACITY": 5000, "BATT_LOW_MAH": 1250,  # the plan keeps 25 % in reserve
             "RTL_ALT": 10000}
    wrong = (("RTL_ALT", 6000, "RTL_ALT = 6000 (60 m) but the plan's ground rises 70 m above the launch point, and a "
                               "return at 60 m clears it by less than 30 m: set RTL_ALT to fit, or plan again (or give "
                               "--accept rtl-altitude)"),
             ("BATT_LOW_MAH", 500, "BATT_LOW_MAH = 500 of BATT_CAPACITY = 5000 mAh (10%) but the plan keeps 25% in "
                                   "reserve: the failsafe would act only after the reserve is spent; raise BATT_LOW_MAH "
                                   "to at least 1250 (or give --accept battery-failsafe)"))
    with ardupilot_copter_sitl(tmp_path, m.home) as sv:
        lines = refused_then_taken(sv, plan, right, wrong)
    assert any(line.startswith("rtl-altitude: RTL_ALT = 10000 (100 m): clears the highest ground under the plan "
                               "(70 m above the launch point) by 30 m") for line in lines), lines
    assert "battery-failsafe: BATT_LOW_MAH = 1250 of BATT_CAPACITY = 5000 mAh (25%), at or above the plan's 25% " \
           "reserve" in lines


@contextmanager
def px4_sitl(tmp_path: Path, home: tuple[float, float, float]) -> Iterator[Px4Vehicle]:
    """PX4 SIH SITL at `home` with the harness's survey parameters (skipped with the reason when no binary is
    found), stopped at the end."""
    from aerosurvey.errors import InputError
    from aerosurvey.link.px4_sitl import PARAMS_FILE, Px4Vehicle, find_px4
    from aerosurvey.link.sitl import survey_params

    try:
        binary = find_px4(None)
    except InputError as exc:
        pytest.skip(str(exc))
    work = tmp_path / "px4"
    work.mkdir()
    sv = Px4Vehicle(binary, home, 1.0, survey_params("copter", False, PARAMS_FILE), work)
    try:
        sv.start()
        yield sv
    finally:
        sv.stop()


def refused_then_taken(sv: SitlVehicle, plan: Path, right: dict[str, float],
                       wrong: Sequence[tuple[str, float, str]]) -> list[str]:
    """With every parameter of `right` set, each (name, value, line) of `wrong` set in turn refuses the upload of
    `plan` with the one line starting `line`, the mission the vehicle holds unchanged, and is set right again;
    then the upload goes through and is verified. Its output's lines."""
    for name, value in right.items():
        sv.set_param(name, value)
    held = held_mission_count(sv)
    for name, value, said in wrong:
        sv.set_param(name, value)
        res = sitl_upload(plan, sv)
        assert res.exit_code == 3, res.output
        assert res.output.strip().startswith(f"Error: {plan.name}: {said}"), res.output
        assert len(res.output.strip().splitlines()) == 1, res.output
        # nothing sent (ArduPilot's count goes from 0 to 1, its home, when it gets a position)
        assert held_mission_count(sv) <= max(held, 1)
        sv.set_param(name, right[name])
    res = sitl_upload(plan, sv)
    assert res.exit_code == 0, res.output
    lines = res.output.splitlines()
    assert any(line.startswith("verified: ") for line in lines), lines
    sent = next(line for line in lines if line.startswith("mission: ")).split()[1]
    assert held_mission_count(sv) == int(sent), lines
    return lines


@pytest.mark.sitl
def test_px4_sitl_refuses_each_setting_set_wrong_and_takes_the_mission_with_it_corrected(tmp_path: Path) -> None:
    """PX4 SIH SITL, one boot, its parameters set over MAVLink (integers' bytes in the float, as PX4 takes them)
    and read by the upload's checks on its API link: the camera (TRIG_MODE 0, and 1: by time), the speed limit
    (MPC_XY_VEL_MAX below the mission's DO_CHANGE_SPEED), the battery failsafe (COM_LOW_BAT_ACT 0, BAT_CRIT_THR
    below the plan's 20 % reserve) and the RTL altitude (RTL_RETURN_ALT 60 m under a manifest whose ground rises
    70 m above the launch point) each refuse the upload of the plan folder's mission with nothing sent; each set
    right, it uploads and verifies. A mission commanding no speed is refused at MPC_XY_CRUISE 10 m/s for its
    planned 5 and taken at 5. This PX4 (v1.14 and later) has no MIS_DIST_WPS: the report says so."""
    (tmp_path / "planned").mkdir()
    folder = planned_folder(tmp_path / "planned", {"battery": {"usable_min": 60.0, "reserve": 0.2},
                                                    "vehicle": {"firmware": "px4"}})
    plan = copy_folder(folder, tmp_path / "plan", _hill)
    m = loads_plan(plan.read_text())
    speed = max(it.param2 for it in m.items if it.command == mav.DO_CHANGE_SPEED)
    slow = dataclasses.replace(survey_mission(4, firmware="px4"), items=tuple(
        it for it in survey_mission(4, firmware="px4").items if it.command != mav.DO_CHANGE_SPEED))  # planned at 5 m/s
    (tmp_path / "slow").mkdir()
    slow_plan = write(tmp_path / "slow", slow)
    right = {"TRIG_MODE": 4, "MPC_XY_VEL_MAX": max(12.0, speed), "MPC_XY_CRUISE": 5.0, "COM_LOW_BAT_ACT": 3,
             "BAT_CRIT_THR": 0.2, "RTL_RETURN_ALT": 100.0}
    wrong = (("TRIG_MODE", 0, "TRIG_MODE = 0 (the camera trigger is disabled) but the mission takes photos"),
             ("TRIG_MODE", 1, "TRIG_MODE = 1 (not by distance on command: the mission's DO_SET_CAM_TRIGG_DIST would "
                              "not switch it) but the mission takes photos"),
             ("MPC_XY_VEL_MAX", speed - 1.0, f"MPC_XY_VEL_MAX = {speed - 1.0:g} m/s but the mission commands {speed:g} "
                                             "m/s (DO_CHANGE_SPEED)"),
             ("COM_LOW_BAT_ACT", 0, "COM_LOW_BAT_ACT = 0 (a warning only): nothing brings the vehicle back on a low "
                                    "battery; the plan keeps 20% in reserve: set it to 3 (or give --accept "
                                    "battery-failsafe)"),
             ("BAT_CRIT_THR", 0.07, "BAT_CRIT_THR = 0.07 (7%, COM_LOW_BAT_ACT = 3) but the plan keeps 20% in reserve: "
                                    "the failsafe would act only after the reserve is spent; raise BAT_CRIT_THR to at "
                                    "least 0.2 (or give --accept battery-failsafe)"),
             ("RTL_RETURN_ALT", 60.0, "RTL_RETURN_ALT = 60 m but the plan's ground rises 70 m above the launch point, "
                                      "and a return at 60 m clears it by less than 30 m: set RTL_RETURN_ALT to fit, or "
                                      "plan again (or give --accept rtl-altitude)"))
    with px4_sitl(tmp_path, m.home) as sv:
        lines = refused_then_taken(sv, plan, right, wrong)
        assert any(line.startswith("camera: TRIG_MODE = 4, TRIG_INTERFACE = 3, and the mission takes photos")
                   for line in lines), lines
        assert f"speed: the mission commands {speed:g} m/s, within MPC_XY_VEL_MAX = {max(12.0, speed):g} m/s" in lines
        assert "battery-failsafe: BAT_CRIT_THR = 0.2 (20%, COM_LOW_BAT_ACT = 3), at or above the plan's 20% reserve" \
            in lines
        assert any(line.startswith("rtl-altitude: RTL_RETURN_ALT = 100 m: clears the highest ground under the plan "
                                   "(70 m above the launch point) by 30 m") for line in lines), lines
        legs = [line for line in lines if line.startswith("legs: ")]
        assert len(legs) == 1 and legs[0].endswith("; the vehicle has no MIS_DIST_WPS (PX4 v1.14 and later do not "
                                                   "limit legs)"), lines
        lines = refused_then_taken(sv, slow_plan, right, (
            ("MPC_XY_CRUISE", 10.0, "MPC_XY_CRUISE = 10 m/s but the mission commands no speed and was planned at 5 m/s"),))
        assert "speed: MPC_XY_CRUISE = 5 m/s, the planned 5 m/s (no DO_CHANGE_SPEED)" in lines


def test_a_generic_autopilot_is_not_asked_for_parameters_and_the_report_says_so(tmp_path: Path) -> None:
    m = survey_mission(4)
    model = VehicleModel(home=m.home)  # neither ArduPilot nor PX4: MAV_AUTOPILOT_GENERIC
    lines = uploaded(write(tmp_path, m), model)
    assert "settings: not read (the vehicle reports generic, whose parameter names are not known)" in lines
    assert not any(k.startswith("got PARAM_REQUEST_READ") for k in model.log)


@pytest.mark.parametrize(("param_type", "fmt", "value"), [(6, "<i", 4), (6, "<i", -1), (5, "<I", 3_000_000_000),
                                                          (2, "<b", -7), (1, "<B", 200)])
def test_a_px4_integer_parameter_is_set_with_its_bytes_in_the_float(param_type: int, fmt: str, value: int) -> None:
    """PARAM_SET to PX4 carries an integer's own bytes in the float (MAVLink's bytewise encoding: PX4 copies
    them), and the value read back is the integer; ArduPilot and PX4's floats carry the value itself."""
    import struct

    from aerosurvey.link.connection import param_value, param_wire_value

    wire = param_wire_value(value, param_type, 12)
    assert struct.pack("<f", wire)[:struct.calcsize(fmt)] == struct.pack(fmt, value)  # the integer's own bytes first
    assert param_value(wire, param_type, 12) == value
    assert param_wire_value(value, param_type, 3) == value  # ArduPilot
    assert param_wire_value(0.07, 9, 12) == 0.07  # MAV_PARAM_TYPE_REAL32
