"""Upload and verify through pymavlink connections to an in-process vehicle on loopback sockets."""

from __future__ import annotations

import math
import socket
import time

import pytest
from fake_vehicle import FakeVehicle, Faults, LossyRelay, VehicleModel, survey_mission

from aerosurvey.errors import InputError
from aerosurvey.link import mission_protocol as mp
from aerosurvey.link.connection import LinkError, open_link
from aerosurvey.link.upload import (
    Refused,
    VerificationFailed,
    ardupilot_stored,
    compare_items,
    fence_wire_items,
    item_to_wire,
    mission_wire_items,
    upload_mission,
)
from aerosurvey.mission import mavlink_ids as mav
from aerosurvey.mission.items import MissionItem

FAST = mp.Policy(timeout=0.1, retries=5, restarts=3, busy_wait=0.3)


def closed_port() -> int:
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


@pytest.mark.parametrize("transport", ["udp", "tcp"])
def test_clean_upload_and_verify(transport: str) -> None:
    m = survey_mission(50, fence=True)
    model = VehicleModel()
    with FakeVehicle(model, transport) as fv, open_link(fv.url, 2.0) as link:
        assert link.vehicle is not None and link.vehicle.system == 1
        # the command's own waits: on a clean link nothing times out, whatever else the machine is doing
        # (FAST's 0.1 s did, once, on this 2-core machine at a load of 12)
        report = upload_mission(link, m, mp.Policy())
    assert report.mission.verified and report.fence is not None and report.fence.verified
    assert report.mission.items == len(m.items) + 1
    assert report.mission.stats.resends == 0 and report.mission.stats.restarts == 0
    assert len(model.stored[0]) == len(m.items) + 1 and len(model.stored[1]) == 7
    assert model.completed_uploads == 2


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_lossy_upload_still_completes_and_verifies(seed: int) -> None:
    m = survey_mission(40, fence=True, seed=seed)
    model = VehicleModel(request_resend=0.1, upload_timeout=0.5)
    with FakeVehicle(model, "udp", Faults(drop=0.1, dup=0.1, reorder=0.1, seed=seed)) as fv:
        with open_link(fv.url, 2.0) as link:
            report = upload_mission(link, m, mp.Policy(timeout=0.05, retries=8, restarts=6, busy_wait=0.3))
    assert report.mission.verified and report.fence is not None and report.fence.verified
    assert report.mission.stats.resends + report.mission.stats.duplicate_requests > 0
    assert [s.x for s in model.stored[0][1:]] == [round(it.x * 1e7) for it in m.items]


def test_through_the_lossy_relay() -> None:
    m = survey_mission(40)
    model = VehicleModel(request_resend=0.1)
    with FakeVehicle(model, "udp") as fv, LossyRelay(fv.port, drop=0.1, seed=5) as relay:
        with open_link(relay.url, 3.0) as link:
            report = upload_mission(link, m, mp.Policy(timeout=0.05, retries=8, restarts=6, busy_wait=0.3))
    assert report.mission.verified
    assert relay.counts["dropped"] > 0


def test_vehicle_storing_a_different_item_fails_naming_seq_field_and_values() -> None:
    m = survey_mission(20)
    model = VehicleModel(alter={7: {"z": 99.5}})
    with FakeVehicle(model, "tcp") as fv, open_link(fv.url, 2.0) as link:
        with pytest.raises(VerificationFailed) as exc:
            upload_mission(link, m, FAST)
    planned_z = m.items[6].z  # seq 7 is the plan's 7th item: seq 0 is home
    assert len(exc.value.mismatches) == 1
    mm = exc.value.mismatches[0]
    assert (mm.seq, mm.field, mm.actual) == (7, "z", 99.5)
    assert mm.expected == pytest.approx(planned_z, abs=1e-4)
    assert f"mission item 7 (NAV_WAYPOINT) z: planned {planned_z:.7g}, vehicle has 99.5;" in str(exc.value)
    assert exc.value.exit_code == 1


def test_vehicle_that_never_answers_times_out() -> None:
    model = VehicleModel(answer_missions=False)
    with FakeVehicle(model, "udp") as fv, open_link(fv.url, 2.0) as link:
        t0 = time.monotonic()
        with pytest.raises(LinkError, match="no answer to MISSION_COUNT for 0.3 s"):
            upload_mission(link, survey_mission(5), mp.Policy(timeout=0.1, retries=2))
        assert time.monotonic() - t0 < 2.0
    assert model.log["got MISSION_COUNT"] == 3
    assert model.stored[0] == []


def test_no_heartbeat_within_the_timeout() -> None:
    with FakeVehicle(VehicleModel(), "udp", heartbeats=False) as fv:
        t0 = time.monotonic()
        with pytest.raises(LinkError, match=r"no heartbeat from a vehicle within 0.4 s"):
            open_link(fv.url, 0.4)
        assert 0.35 < time.monotonic() - t0 < 2.0


def test_no_space_then_success_after_retry() -> None:
    m = survey_mission(10)
    model = VehicleModel(no_space_first=1)
    with FakeVehicle(model, "tcp") as fv, open_link(fv.url, 2.0) as link:
        report = upload_mission(link, m, FAST)
    assert report.mission.stats.error_acks == [mp.NO_SPACE] and report.mission.stats.restarts == 1
    assert report.mission.verified and model.log["got MISSION_COUNT"] == 2


def test_too_many_items_fails_with_what_the_vehicle_said() -> None:
    model = VehicleModel(capacity=8)
    with FakeVehicle(model, "udp") as fv, open_link(fv.url, 2.0) as link:
        with pytest.raises(LinkError) as exc:
            upload_mission(link, survey_mission(10), mp.Policy(timeout=0.1, restarts=1, busy_wait=0.1))
    assert ("MAV_MISSION_NO_SPACE for 16 items 2 time(s); it has no room for them or it has not finished booting "
            "(the vehicle said: Only 8 items are supported); the vehicle holds 0 mission item(s), none confirmed of the "
            "plan's 16 (it says so when asked after the failure): do not fly it") in str(exc.value)


def test_connection_refused_on_a_closed_port() -> None:
    port = closed_port()
    with pytest.raises(LinkError, match=rf"tcp:127.0.0.1:{port}: connection refused"):
        open_link(f"tcp:127.0.0.1:{port}", 1.0)


def test_bad_connection_strings_are_input_errors() -> None:
    with pytest.raises(InputError):
        open_link("tcp:127.0.0.1", 0.5)
    with pytest.raises(InputError, match="is a file"):
        open_link(__file__, 0.5)


def test_vehicle_closing_the_tcp_connection_is_a_clear_error() -> None:
    model = VehicleModel(answer_missions=False)
    fv = FakeVehicle(model, "tcp")
    with fv, open_link(fv.url, 2.0) as link:
        fv.__exit__(None, None, None)
        with pytest.raises(LinkError, match="the vehicle closed the connection"):
            upload_mission(link, survey_mission(3), mp.Policy(timeout=0.1, retries=2))


def test_legacy_requests_and_legacy_items() -> None:
    model = VehicleModel(legacy_requests=True)
    m = survey_mission(12)
    with FakeVehicle(model, "udp") as fv, open_link(fv.url, 2.0) as link:
        report = upload_mission(link, m, FAST)
        assert report.mission.verified
        assert model.log["got MISSION_ITEM_INT"] == len(m.items) + 1


@pytest.mark.parametrize("plane", [False, True])
def test_ardupilot_vehicle_verifies_what_it_keeps(plane: bool) -> None:
    m = survey_mission(15, fence=True, vehicle="plane" if plane else "copter")
    model = VehicleModel(storage="ardupilot", plane=plane, home=(49.41, 15.01, 390.0))
    with FakeVehicle(model, "tcp") as fv, open_link(fv.url, 2.0) as link:
        assert link.vehicle is not None and link.vehicle.autopilot_name == "ArduPilot"
        report = upload_mission(link, m, FAST)
    assert report.mission.verified and "as ArduPilot stores items" in report.compared_as
    assert "item 0 (home) not compared" in report.home_note and "m from the planned home" in report.home_note
    # it dropped the NaN yaw and moved DO_ commands to frame 0: invisible to the check, as it should be
    assert model.stored[0][2].frame == 0 and model.stored[0][1].params[3] == 0.0


def test_ardupilot_vehicle_with_a_changed_position_still_fails() -> None:
    m = survey_mission(15)
    model = VehicleModel(storage="ardupilot", alter={5: {"x": 494123456}})
    with FakeVehicle(model, "udp") as fv, open_link(fv.url, 2.0) as link:
        with pytest.raises(VerificationFailed) as exc:
            upload_mission(link, m, FAST)
    assert [(x.seq, x.field) for x in exc.value.mismatches] == [(5, "x (latitude·1e7)")]


def test_plan_for_the_other_firmware_is_refused_before_upload() -> None:
    model = VehicleModel(storage="ardupilot")
    with FakeVehicle(model, "udp") as fv, open_link(fv.url, 2.0) as link:
        with pytest.raises(Refused, match="plan is for px4 but the vehicle reports ArduPilot"):
            upload_mission(link, survey_mission(3, firmware="px4"), FAST)
    assert "got MISSION_COUNT" not in model.log


def test_wire_items_home_fence_and_float32_rules() -> None:
    m = survey_mission(2, fence=True)
    wire = mission_wire_items(m)
    assert (wire[0].seq, wire[0].command, wire[0].frame, wire[0].z) == (0, 16, 0, 402.5)
    assert wire[0].x == round(m.home[0] * 1e7)
    assert [w.seq for w in wire] == list(range(len(m.items) + 1))
    fence = fence_wire_items(m)
    assert [f.command for f in fence] == [mav.NAV_FENCE_POLYGON_VERTEX_INCLUSION] * 4 + [mav.NAV_FENCE_POLYGON_VERTEX_EXCLUSION] * 3
    assert [f.param1 for f in fence] == [4.0] * 4 + [3.0] * 3
    assert all(f.mission_type == mp.FENCE for f in fence)
    assert compare_items(wire, list(wire)) == []
    nudged = [mp.WireItem(**{**w.__dict__, "z": w.z + 1e-6}) for w in wire]  # below float32 resolution at 80 m
    assert compare_items(wire, nudged) == []
    moved = [mp.WireItem(**{**w.__dict__, "x": w.x + (1 if w.seq == 4 else 0)}) for w in wire]
    assert [(x.seq, x.field) for x in compare_items(wire, moved)] == [(4, "x (latitude·1e7)")]
    assert [str(x) for x in compare_items(wire, wire[:-1])][0] == f"mission: the vehicle has {len(wire) - 1} items, the plan {len(wire)}"


def test_ardupilot_stored_form() -> None:
    wp = mp.WireItem(3, mav.NAV_WAYPOINT, 3, 2.7, 5.0, 0.0, math.nan, 494000000, 150000000, 80.126)
    c = ardupilot_stored(wp, plane=False)
    assert (c.param1, c.param2, c.param4, c.frame, c.x) == (2.0, 0.0, 0.0, 3, 494000000)
    assert c.z == pytest.approx(80.12, abs=1e-5)
    p = ardupilot_stored(wp, plane=True)
    assert (p.param1, p.param2) == (0.0, 5.0)
    speed = mp.WireItem(4, mav.DO_CHANGE_SPEED, 2, 1, 12.5, -1, 7, 5, 6, 7)
    s = ardupilot_stored(speed, plane=False)
    assert (s.frame, s.param1, s.param2, s.param3, s.param4, s.x, s.y, s.z) == (0, 1.0, 12.5, -1.0, 0.0, 0, 0, 0.0)
    unknown = mp.WireItem(5, 31000, 3, 1, 2, 3, 4, 5, 6, 7)
    assert ardupilot_stored(unknown, plane=False) == unknown


def test_the_shooting_command_goes_as_a_plain_integer() -> None:
    """MISSION_ITEM_INT's x is 1e-7 degrees for a position but the parameter itself for
    DO_DIGICAM_CONTROL: ArduPilot takes its x as the shooting command (1 = take a picture;
    10,000,000 is stored as the byte 128 and takes none, as seen in SITL)."""
    shoot = MissionItem(mav.DO_DIGICAM_CONTROL, mav.FRAME_MISSION, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0)
    w = item_to_wire(shoot, 7, "item 7")
    assert (w.x, w.y) == (1, 0)
    wp = item_to_wire(MissionItem(mav.NAV_WAYPOINT, mav.FRAME_GLOBAL_RELATIVE_ALT, 0, 0, 0, 0, 49.5, 15.25, 80.0), 8, "item 8")
    assert (wp.x, wp.y) == (495000000, 152500000)
    # PX4's DO_LAND_START goes in MAV_FRAME_MISSION with its place: still 1e-7 degrees
    land = item_to_wire(MissionItem(mav.DO_LAND_START, mav.FRAME_MISSION, 0, 0, 0, 0, 49.5, 15.25, 0.0), 9, "item 9")
    assert (land.x, land.y) == (495000000, 152500000)
    with pytest.raises(InputError, match="item 7 param5 = 1.5"):
        item_to_wire(MissionItem(mav.DO_DIGICAM_CONTROL, mav.FRAME_MISSION, 0, 0, 0, 0, 1.5, 0, 0), 7, "item 7")


def test_ardupilot_keeps_mount_angles_and_the_shooting_command() -> None:
    mount = mp.WireItem(4, mav.DO_MOUNT_CONTROL, mav.FRAME_MISSION, -45.0, 0.0, 12.5, 0.0, 0, 0, 2.0)
    m = ardupilot_stored(mount, plane=False)
    assert (m.frame, m.param1, m.param2, m.param3, m.param4, m.x, m.y, m.z) == (0, -45.0, 0.0, 12.5, 0.0, 0, 0, 2.0)
    shoot = mp.WireItem(6, mav.DO_DIGICAM_CONTROL, mav.FRAME_MISSION, 0.0, 0.0, -1.0, 0.0, 1, 0, 0.0)
    s = ardupilot_stored(shoot, plane=False)
    assert (s.frame, s.param3, s.x, s.y, s.z) == (0, -1.0, 1, 0, 0.0)


def test_command_parameters_that_are_not_places_go_as_plain_integers() -> None:
    """MISSION_ITEM_INT's x/y are 1e-7 degrees only for a place: PX4's gimbal manager flags (12 =
    roll and pitch locked to the horizon) and ArduPilot's shooting command (1) go as they are."""
    from aerosurvey.link.upload import item_to_wire
    from aerosurvey.mission import mavlink_ids as mav
    from aerosurvey.mission.items import MissionItem

    gimbal = MissionItem(mav.DO_GIMBAL_MANAGER_PITCHYAW, mav.FRAME_MISSION, -45.0, 0.0, float("nan"), float("nan"), 12.0, 0.0, 0.0)
    shoot = MissionItem(mav.DO_DIGICAM_CONTROL, mav.FRAME_MISSION, 0, 0, 0, 0, 1.0, 0.0, 0.0)
    place = MissionItem(mav.NAV_WAYPOINT, mav.FRAME_GLOBAL_RELATIVE_ALT, 0, 0, 0, 0, 49.5, 15.3, 80.0)
    assert item_to_wire(gimbal, 1, "item 1").x == 12
    assert item_to_wire(shoot, 2, "item 2").x == 1
    assert (item_to_wire(place, 3, "item 3").x, item_to_wire(place, 3, "item 3").y) == (495_000_000, 153_000_000)
