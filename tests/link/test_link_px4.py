"""`aerosurvey upload` of a PX4 mission end to end: through MAVSDK's mission_raw plugin (the
`mavsdk` package's own C++ library) to the fake vehicle set up as PX4 on loopback.

The fake answers as PX4's MavlinkMissionManager: HEARTBEAT autopilot MAV_AUTOPILOT_PX4, its
dataman room per mission type, the commands and frames it takes (MAV_MISSION_UNSUPPORTED(_FRAME)
otherwise), what it keeps of each item and the _INT frames it answers with. What the vehicle
stores is checked against the plan's own numbers, not through aerosurvey's wire code.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import pytest
from click.testing import CliRunner
from fake_vehicle import FakeVehicle, Faults, VehicleModel, survey_mission

from aerosurvey.cli import main
from aerosurvey.errors import InputError
from aerosurvey.link.connection import LinkError, open_link
from aerosurvey.link.px4 import MavsdkTransfers, mavsdk_url
from aerosurvey.link.upload import upload_plan
from aerosurvey.mission import mavlink_ids as mav
from aerosurvey.mission.formats.qgc_plan import dumps_plan
from aerosurvey.mission.items import Mission, MissionItem

RALLY = ((49.4012, 15.0013, 80.5), (49.4023, 15.0031, 82.25))


def px4_mission(n: int = 10, **changes: object) -> Mission:
    m = survey_mission(n, firmware="px4", fence=True)
    return dataclasses.replace(m, **{"rally": RALLY, **changes})


def write(tmp_path: Path, m: Mission) -> Path:
    plan = tmp_path / "survey.plan"
    plan.write_text(dumps_plan(m))
    return plan


def run(plan: Path, url: str, *args: str):
    return CliRunner().invoke(main, ["upload", str(plan), "--connect", url, *args])


def mission_messages(model: VehicleModel) -> int:
    return sum(v for k, v in model.log.items() if k.startswith("got MISSION_"))


@pytest.mark.parametrize("transport", ["udp", "tcp"])
def test_a_px4_mission_with_fence_and_rally_goes_through_mavsdk_and_is_verified(tmp_path: Path, transport: str) -> None:
    m = px4_mission()
    model = VehicleModel(px4=True, home=m.home)
    with FakeVehicle(model, transport) as fv:
        res = run(write(tmp_path, m), fv.url, "--rally", "--autopilot", "px4")
    assert res.exit_code == 0, res.output
    lines = res.output.splitlines()
    assert "transfers: through MAVSDK's mission_raw plugin" in lines
    assert lines[-1] == ("verified: 15 mission items, 7 fence vertices and 2 rally points read back and compared as PX4 "
                         "stores items (fields it does not keep are not compared); all match")
    # the vehicle holds the plan: no home item for PX4, the plan's items from seq 0
    assert [s.command for s in model.stored[0]] == [it.command for it in m.items]
    assert [(s.x, s.y) for s in model.stored[0]] == [(round(it.x * 1e7), round(it.y * 1e7)) for it in m.items]
    assert all(math.isclose(s.z, it.z, abs_tol=1e-4) for s, it in zip(model.stored[0], m.items))
    vertices = [p for poly in m.fence_inclusion + m.fence_exclusion for p in (poly[:-1] if poly[0] == poly[-1] else poly)]
    assert [(s.x, s.y) for s in model.stored[1]] == [(round(a * 1e7), round(b * 1e7)) for a, b in vertices]
    assert [(s.command, s.x, s.y, s.z) for s in model.stored[2]] == [
        (5100, round(lat * 1e7), round(lon * 1e7), alt) for lat, lon, alt in RALLY]
    assert model.completed_uploads == 3


def test_what_px4_drops_or_rewrites_is_modelled_and_what_it_stores_wrongly_is_named(tmp_path: Path) -> None:
    """PX4 keeps no pass radius (param3) nor takeoff pitch, gives a yaw of -90° back as 270° and answers
    in the _INT frames: still 'all match'. A field it stores otherwise is named, exit 1."""
    lat, lon = 49.4, 15.0
    items = (MissionItem(mav.NAV_TAKEOFF, mav.FRAME_GLOBAL_RELATIVE_ALT, 15.0, 0, 0, math.nan, lat, lon, 60.0),
             MissionItem(mav.NAV_WAYPOINT, mav.FRAME_GLOBAL_RELATIVE_ALT, 2.0, 3.0, 5.0, -90.0, lat + 0.001, lon, 60.0),
             MissionItem(mav.DO_SET_CAM_TRIGG_DIST, mav.FRAME_MISSION, 21.37, 0, 1, 0),
             MissionItem(mav.NAV_WAYPOINT, mav.FRAME_GLOBAL, 0, 0, 0, 725.0, lat + 0.002, lon, 460.0),
             MissionItem(mav.NAV_RETURN_TO_LAUNCH, mav.FRAME_MISSION))
    m = Mission("copter", "px4", (lat, lon, 400.0), items, 10.0, 5.0)
    model = VehicleModel(px4=True, home=m.home, params={"MPC_XY_CRUISE": 5.0})  # no DO_CHANGE_SPEED: it flies that
    with FakeVehicle(model, "udp") as fv:
        res = run(write(tmp_path, m), fv.url)
    assert res.exit_code == 0, res.output
    assert res.output.splitlines()[-1].endswith("all match")
    assert model.stored[0][1].params[2] == 0.0 and model.stored[0][0].params[0] == 0.0  # dropped by the vehicle

    model = VehicleModel(px4=True, home=m.home, alter={3: {"z": 470.0}}, params={"MPC_XY_CRUISE": 5.0})
    with FakeVehicle(model, "udp") as fv:
        res = run(write(tmp_path, m), fv.url)
    assert res.exit_code == 1, res.output
    assert "  differs: mission item 3 (NAV_WAYPOINT) z: planned 460, vehicle has 470" in res.output


def test_what_px4_would_refuse_is_refused_before_anything_is_sent(tmp_path: Path) -> None:
    m = px4_mission(4)
    cases = {
        "terrain": (dataclasses.replace(m, items=(dataclasses.replace(m.items[0], frame=mav.FRAME_GLOBAL_TERRAIN_ALT),
                                                  *m.items[1:])), (),
                    "survey.plan: mission item 0 (NAV_TAKEOFF, frame 10) is not one PX4 takes (it answers "
                    "MAV_MISSION_UNSUPPORTED_FRAME; PX4 has no terrain frame: plan it with relative altitudes)"),
        "yaw": (dataclasses.replace(m, items=(*m.items[:2], MissionItem(mav.CONDITION_YAW, mav.FRAME_MISSION, 90.0),
                                              *m.items[2:])), (),
                "survey.plan: mission item 2 (CONDITION_YAW, frame 2) is not one PX4 takes (it answers MAV_MISSION_UNSUPPORTED)"),
        "items": (px4_mission(1996), (), "survey.plan has 2001 mission items but PX4 stores at most 2000: plan it with "
                                         "smaller sorties"),
        "rally": (dataclasses.replace(m, rally=RALLY * 17), ("--rally",),
                  "survey.plan has 34 rally points but PX4 stores at most 32: plan it with smaller sorties"),
    }
    for name, (mission, extra, words) in cases.items():
        model = VehicleModel(px4=True, home=mission.home)
        with FakeVehicle(model, "udp") as fv:
            res = run(write(tmp_path, mission), fv.url, *extra)
        assert res.exit_code == 3, (name, res.output)
        assert res.output.strip().splitlines()[-1] == f"Error: {words}", name
        assert mission_messages(model) == 0, name


def test_the_other_checks_hold_for_px4_too(tmp_path: Path) -> None:
    """Vehicle type, other autopilot and --autopilot: refused before anything is sent."""
    plane = px4_mission(4, vehicle="plane")
    model = VehicleModel(px4=True, home=plane.home)  # a PX4 multicopter (MAV_TYPE 2)
    with FakeVehicle(model, "udp") as fv:
        res = run(write(tmp_path, plane), fv.url)
    assert res.exit_code == 3 and "is a plane mission but the vehicle reports MAV_TYPE 2 (a copter)" in res.output
    assert mission_messages(model) == 0

    m = px4_mission(4)
    model = VehicleModel(storage="ardupilot", home=m.home)
    with FakeVehicle(model, "udp") as fv:
        res = run(write(tmp_path, m), fv.url)
    assert res.exit_code == 3, res.output
    assert res.output.strip().endswith("the plan is for px4 but the vehicle reports ArduPilot: plan the mission for "
                                       "ardupilot and upload that")
    assert mission_messages(model) == 0

    res = run(write(tmp_path, m), "udpout:127.0.0.1:9", "--autopilot", "ardupilot")
    assert res.exit_code == 2
    assert "--autopilot ardupilot: survey.plan is a mission for px4" in res.output

    res = run(write(tmp_path, m), "udpbcast:127.0.0.1:9")  # pymavlink opens it, MAVSDK does not: said before anything
    assert res.exit_code == 2
    assert "a PX4 upload goes through MAVSDK, which opens udpin:, udpout:, tcp:, tcpin: and serial devices" in res.output


def test_what_the_vehicle_refuses_during_a_mavsdk_upload_is_an_error_that_says_do_not_fly(tmp_path: Path) -> None:
    """Past the checks: the vehicle's own answers (no room, an item it does not take) reach the pilot."""
    m = px4_mission(30)  # 35 items: within PX4's 2000, beyond this vehicle's 20
    model = VehicleModel(px4=True, home=m.home, capacity=20)
    with FakeVehicle(model, "udp") as fv:
        res = run(write(tmp_path, m), fv.url)
    assert res.exit_code == 1, res.output
    assert "MAV_MISSION_NO_SPACE" in res.output and "do not fly it" in res.output
    assert model.stored[0] == []

    yaw = dataclasses.replace(m, items=(*m.items[:2], MissionItem(mav.CONDITION_YAW, mav.FRAME_MISSION, 90.0), *m.items[2:]))
    model = VehicleModel(px4=True, home=m.home)
    with FakeVehicle(model, "udp") as fv:
        with open_link(fv.url, 2.0) as link:
            vehicle = link.vehicle
        assert vehicle is not None
        with MavsdkTransfers(fv.url, vehicle, 0.2, 2.0) as transfers, pytest.raises(LinkError) as exc:
            upload_plan(transfers, yaw)  # check_px4 skipped on purpose
    assert "MAV_MISSION_UNSUPPORTED" in str(exc.value) and "do not fly it" in str(exc.value)
    assert model.log.get("ack MAV_MISSION_UNSUPPORTED") == 1 and model.stored[0] == []


def test_a_vehicle_that_accepts_before_the_last_item_is_never_reported_as_uploaded() -> None:
    m = px4_mission(10)
    model = VehicleModel(px4=True, home=m.home, early_accept_after=8)  # a faulty vehicle: ACCEPTED after item 7
    with FakeVehicle(model, "udp") as fv:
        with open_link(fv.url, 2.0) as link:
            vehicle = link.vehicle
        assert vehicle is not None
        with MavsdkTransfers(fv.url, vehicle, 0.2, 2.0) as transfers, pytest.raises(LinkError) as exc:
            upload_plan(transfers, m)
    # MAVSDK takes the early ACCEPTED as a broken protocol (PROTOCOL_ERROR); each restart meets it again
    assert str(exc.value) == ("mission upload through MAVSDK failed: the vehicle answered MAV_MISSION_ERROR, or an ACK came "
                              "that MAVSDK did not expect (after 3 restart(s)); the vehicle's mission is incomplete or "
                              "unchanged: do not fly it")
    assert model.log["got MISSION_COUNT"] == 4


def test_a_lost_final_ack_is_settled_by_the_read_back(tmp_path: Path) -> None:
    """MAVSDK does not send the last item again when the vehicle's final MISSION_ACK is lost (it waits for a
    request PX4 never sends once it holds everything) and ends in TIMEOUT; the read-back proves the upload.
    Without a read-back (--no-verify) the same timeout is a failure."""
    m = px4_mission(10)
    model = VehicleModel(px4=True, home=m.home, lose_final_acks=1)
    with FakeVehicle(model, "udp") as fv:
        res = run(write(tmp_path, m), fv.url, "--timeout", "0.1", "--rally")
    assert res.exit_code == 0, res.output
    assert model.log["final ack lost"] == 1
    assert ("mission: 15 items uploaded" in res.output and "MAVSDK timed out waiting for the vehicle's final MISSION_ACK, "
            "the read-back below proves the upload" in res.output)
    assert res.output.splitlines()[-1].endswith("all match")

    model = VehicleModel(px4=True, home=m.home, lose_final_acks=1)
    with FakeVehicle(model, "udp") as fv:
        res = run(write(tmp_path, m), fv.url, "--timeout", "0.1", "--no-verify")
    assert res.exit_code == 1, res.output
    assert "mission upload through MAVSDK failed: the vehicle stopped answering" in res.output
    assert "do not fly it" in res.output


@pytest.mark.parametrize("seed", [1, 2])
def test_mavsdk_resends_through_a_lossy_link(tmp_path: Path, seed: int) -> None:
    m = px4_mission(30)
    model = VehicleModel(px4=True, home=m.home)
    with FakeVehicle(model, "udp", Faults(drop=0.03, dup=0.03, seed=seed)) as fv:
        res = run(write(tmp_path, m), fv.url, "--rally")
    assert res.exit_code == 0, res.output
    assert [(s.x, s.y) for s in model.stored[0]] == [(round(it.x * 1e7), round(it.y * 1e7)) for it in m.items]
    assert len(model.stored[2]) == len(RALLY)


def test_rally_points_go_to_ardupilot_through_our_protocol_in_whole_metres(tmp_path: Path) -> None:
    """ArduPilot keeps a rally point's altitude as int16 metres: 82.25 comes back as 82, and that is a match."""
    m = dataclasses.replace(survey_mission(6, fence=True), rally=RALLY)
    model = VehicleModel(storage="ardupilot", home=m.home)
    with FakeVehicle(model, "udp") as fv:
        res = run(write(tmp_path, m), fv.url, "--rally")
    assert res.exit_code == 0, res.output
    assert "rally: 2 points uploaded" in res.output and "and 2 rally points read back" in res.output
    assert [(s.x, s.y, s.z) for s in model.stored[2]] == [(round(a * 1e7), round(b * 1e7), float(int(z))) for a, b, z in RALLY]
    assert "transfers:" not in res.output  # our own protocol: resends are counted
    assert "0 resend(s)" in res.output


def test_mavsdk_urls() -> None:
    assert mavsdk_url("udpin:0.0.0.0:14550") == "udpin://0.0.0.0:14550"
    assert mavsdk_url("udp:0.0.0.0:14550") == "udpin://0.0.0.0:14550"
    assert mavsdk_url("udpout:127.0.0.1:14580") == "udpout://127.0.0.1:14580"
    assert mavsdk_url("tcp:127.0.0.1:5760") == "tcpout://127.0.0.1:5760"
    assert mavsdk_url("/dev/ttyACM0") == "serial:///dev/ttyACM0:115200"
    assert mavsdk_url("/dev/ttyUSB0,57600") == "serial:///dev/ttyUSB0:57600"
    with pytest.raises(InputError, match="MAVSDK"):
        mavsdk_url("mcast:")


def test_a_planned_px4_plane_landing_is_one_px4_takes(tmp_path: Path) -> None:
    """The landing sequence's DO_LAND_START goes to PX4 in MAV_FRAME_MISSION (the frame PX4's mission
    rules take it in); every item of the planned mission passes the PX4 check."""
    from aerosurvey.inputs import plan_from_files
    from aerosurvey.link.upload import check_px4
    from aerosurvey.mission.builder import build_mission
    from aerosurvey.spec import load_spec
    from conftest import make_spec

    spec = make_spec(tmp_path, {"vehicle": {"type": "plane", "firmware": "px4", "cruise_speed_ms": 18.0},
                                "flight": {"end": "land", "wind_from_deg": 270.0}})
    m = build_mission(plan_from_files(load_spec(spec)))
    land = [it for it in m.items if it.command == mav.DO_LAND_START]
    assert land and all(it.frame == mav.FRAME_MISSION for it in land)
    check_px4(m, "mission.plan", rally=True)


def _longest_leg(m: Mission) -> tuple[float, int, int]:
    """(metres, seq, seq) of the longest leg between consecutive places, as PX4 v1.13 measures it
    (haversine on 6,371 km; its items numbered from 0, positions at 1e-7 degrees)."""
    places = [(k, round(it.x * 1e7) / 1e7, round(it.y * 1e7) / 1e7) for k, it in enumerate(m.items)
              if it.command in (16, 21, 22)]

    def hav(a: tuple[int, float, float], b: tuple[int, float, float]) -> float:
        p1, p2 = math.radians(a[1]), math.radians(b[1])
        h = math.sin((p2 - p1) / 2) ** 2 + math.cos(p1) * math.cos(p2) * math.sin(math.radians(b[2] - a[2]) / 2) ** 2
        return 2 * 6_371_000.0 * math.asin(math.sqrt(h))

    return max((hav(a, b), a[0], b[0]) for a, b in zip(places, places[1:]))


@pytest.mark.parametrize("params,said", [
    ({"MIS_DIST_WPS": 900.0, "MIS_DIST_1WP": 900.0}, "within the vehicle's MIS_DIST_WPS = 900 m"),
    ({"MIS_DIST_1WP": 10000.0}, "the vehicle has no MIS_DIST_WPS (PX4 v1.14 and later do not limit legs)"),
    ({"MIS_DIST_WPS": 0.0, "MIS_DIST_1WP": 900.0}, "the vehicle's MIS_DIST_WPS = 0 does not limit legs"),
])
def test_the_legs_are_compared_with_the_vehicles_mis_dist_wps(tmp_path: Path, params: dict, said: str) -> None:
    """PX4 v1.13 and earlier (MIS_DIST_WPS 900 m by default) take the mission, v1.14 and later have
    no such parameter and do not answer for it; the report says which and how long the longest leg is."""
    m = px4_mission(6)
    d, a, b = _longest_leg(m)
    model = VehicleModel(px4=True, home=m.home, params=params)
    with FakeVehicle(model, "udp") as fv:
        res = run(write(tmp_path, m), fv.url, "--timeout", "0.2", "--retries", "4")
    assert res.exit_code == 0, res.output
    assert f"legs: the longest, items {a} to {b}, is {d:,.0f} m; {said}" in res.output or \
        f"legs: the longest, items {a} to {b}, is {d:,.0f} m, {said}" in res.output
    assert len(model.stored[0]) == len(m.items)


def test_a_leg_longer_than_the_vehicles_mis_dist_wps_is_refused_before_anything_is_sent(tmp_path: Path) -> None:
    m = px4_mission(6)
    d, a, b = _longest_leg(m)
    assert 400.0 < d < 900.0
    model = VehicleModel(px4=True, home=m.home, params={"MIS_DIST_WPS": 400.0, "MIS_DIST_1WP": 900.0})
    with FakeVehicle(model, "udp") as fv:
        res = run(write(tmp_path, m), fv.url)
    assert res.exit_code == 3, res.output
    assert res.output.strip().splitlines()[-1] == (
        f"Error: survey.plan: mission items {a} and {b} lie {d:,.0f} m apart but the vehicle's MIS_DIST_WPS = 400 m "
        "(PX4 refuses such a mission at arming): plan it again with vehicle.max_leg_m = 400, or raise MIS_DIST_WPS "
        "(or give --accept leg-length)")
    assert mission_messages(model) == 0 and model.log.get("got PARAM_REQUEST_READ MIS_DIST_WPS")
    with FakeVehicle(model, "udp") as fv:
        res = run(write(tmp_path, m), fv.url, "--accept", "leg-length")
    assert res.exit_code == 0, res.output
    assert (f"leg-length: ACCEPTED by the pilot (--accept leg-length): mission items {a} and {b} lie {d:,.0f} m apart"
            in res.output)


def test_a_vehicle_that_answers_no_parameter_request_is_refused_naming_the_first_setting_needed(tmp_path: Path) -> None:
    """Nothing known of its settings: the first check the mission needs refuses (the camera: it takes photos)."""
    m = px4_mission(6)
    model = VehicleModel(px4=True, home=m.home, answer_params=False)
    with FakeVehicle(model, "udp") as fv:
        res = run(write(tmp_path, m), fv.url, "--timeout", "0.2", "--retries", "4")
    assert res.exit_code == 3, res.output
    assert res.output.strip().splitlines()[-1] == (
        "Error: survey.plan: TRIG_MODE not known: the vehicle answered no parameter request but the mission takes photos "
        "with 1 item(s) (DO_SET_CAM_TRIGG_DIST): set TRIG_MODE = 4 (or give --accept camera)")
    assert mission_messages(model) == 0


def test_px4s_integer_parameters_are_read_from_their_bytes() -> None:
    """PX4 sends an INT32 parameter's bytes in PARAM_VALUE's float (TRIG_MODE 4 arrives as 5.6e-45)."""
    model = VehicleModel(px4=True, params={"TRIG_MODE": 4, "MPC_XY_CRUISE": 10.0, "MIS_DIST_1WP": -1})
    with FakeVehicle(model, "udp") as fv, open_link(fv.url, 5.0) as link:
        got = link.read_params(("TRIG_MODE", "MPC_XY_CRUISE", "MIS_DIST_1WP", "NO_SUCH_PARAM"), 1.0)
    assert got == {"TRIG_MODE": 4.0, "MPC_XY_CRUISE": 10.0, "MIS_DIST_1WP": -1.0}
