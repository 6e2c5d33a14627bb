"""Upload and verify over a simulated lossy link (simulated clock, real MAVLink bytes, fake vehicle).

The property: whatever the link drops, duplicates or reorders, `upload_mission` either
returns and the vehicle then holds exactly the plan (checked from the vehicle's own store,
not from our download), or it raises LinkError. It never reports a partial upload.
"""

from __future__ import annotations

import math
import re
import struct

import pytest
from fake_vehicle import Faults, SimLink, VehicleModel, survey_mission
from hypothesis import given, settings
from hypothesis import strategies as st

from aerosurvey.link import mission_protocol as mp
from aerosurvey.link.connection import LinkError
from aerosurvey.link.upload import VerificationFailed, upload_mission
from aerosurvey.mission.items import Mission

POLICY = mp.Policy(timeout=0.1, retries=6, restarts=6, busy_wait=0.5)


def f32(v: float) -> float:
    return struct.unpack("<f", struct.pack("<f", v))[0]


def plan_rows(m: Mission) -> list[tuple]:
    """The plan as the vehicle should store it verbatim, computed here without aerosurvey's codec."""
    lat, lon, alt = m.home
    rows = [(16, 0, (0.0, 0.0, 0.0, 0.0), round(lat * 1e7), round(lon * 1e7), f32(alt))]
    for it in m.items:
        params = tuple(math.nan if math.isnan(p) else f32(p) for p in it.params)
        rows.append((it.command, it.frame, params, round(it.x * 1e7), round(it.y * 1e7), f32(it.z)))
    return rows


def stored_rows(model: VehicleModel) -> list[tuple]:
    return [(s.command, s.frame, s.params, s.x, s.y, s.z) for s in model.stored[0]]


def same_rows(a: list[tuple], b: list[tuple]) -> bool:
    def norm(r: tuple) -> tuple:
        return (r[0], r[1], tuple("nan" if math.isnan(p) else p for p in r[2]), r[3], r[4], r[5])

    return [norm(r) for r in a] == [norm(r) for r in b]


@pytest.mark.parametrize("seed", range(6))
def test_lossy_duplicating_reordering_link_still_uploads_and_verifies(seed: int) -> None:
    m = survey_mission(60, fence=True, seed=seed)
    model = VehicleModel(request_resend=0.3, upload_timeout=3.0)
    link = SimLink(model, Faults(drop=0.15, dup=0.1, reorder=0.1, seed=seed))
    report = upload_mission(link, m, POLICY)
    assert report.mission.verified and report.fence is not None and report.fence.verified
    assert same_rows(stored_rows(model), plan_rows(m))
    assert len(model.stored[1]) == 4 + 3  # the exclusion ring's closing vertex is not sent
    assert report.mission.stats.resends > 0  # the faults did bite


@settings(max_examples=40, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**31), n=st.integers(0, 40), drop=st.floats(0.0, 0.4), dup=st.floats(0.0, 0.3),
       reorder=st.floats(0.0, 0.3), legacy=st.booleans())
def test_success_always_means_the_vehicle_holds_the_plan(seed: int, n: int, drop: float, dup: float, reorder: float,
                                                         legacy: bool) -> None:
    m = survey_mission(n, seed=seed)
    model = VehicleModel(legacy_requests=legacy, request_resend=0.2, upload_timeout=1.5)
    link = SimLink(model, Faults(drop=drop, dup=dup, reorder=reorder, seed=seed))
    try:
        upload_mission(link, m, mp.Policy(timeout=0.1, retries=3, restarts=2, busy_wait=0.2))
    except LinkError:
        return
    assert same_rows(stored_rows(model), plan_rows(m))


def test_vehicle_that_accepts_early_is_never_reported_as_uploaded() -> None:
    m = survey_mission(20)
    model = VehicleModel(early_accept_after=10)
    with pytest.raises(LinkError) as exc:
        upload_mission(SimLink(model), m, POLICY)
    held = len(model.stored[0])
    assert held < len(m.items) + 1
    assert f"the vehicle holds {held} of 26 mission items (it says so when asked after the failure" in str(exc.value)
    assert str(exc.value).endswith(": do not fly it")


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_vehicle_that_dies_mid_upload_is_reported_holding_what_it_confirmed(seed: int) -> None:
    """It asks for item 350 of 704 and says nothing more, not even a count: at least 350 of 704, never 0."""
    m = survey_mission(698, seed=seed)
    model = VehicleModel(silent_after_request=350)
    with pytest.raises(LinkError) as exc:
        upload_mission(SimLink(model, Faults(drop=0.1, seed=seed)), m, POLICY)
    assert len(model.stored[0]) == 350
    said = re.search(r"the vehicle holds at least (\d+) of 704 mission items \(it confirmed them in order, and answered "
                     r"no count after the failure\)", str(exc.value))
    assert said is not None, str(exc.value)
    assert 340 <= int(said.group(1)) <= 350  # its requests for the last few may be lost: a lower bound, never above
    assert exc.value.exit_code == 1


def test_a_vehicle_that_refuses_an_item_is_asked_what_it_holds() -> None:
    """ArduPilot writes each item in place as it comes: refusing item 350 it keeps the 350 before it, and says so."""
    m = survey_mission(698)
    model = VehicleModel(storage="ardupilot", fail_item=350)
    with pytest.raises(LinkError) as exc:
        upload_mission(SimLink(model), m, POLICY)
    assert len(model.stored[0]) == 350
    assert "the vehicle holds 350 of 704 mission items (it says so when asked after the failure; it confirmed the " \
           "first 350 as the plan's): do not fly it" in str(exc.value)


def test_no_space_right_after_boot_then_success() -> None:
    m = survey_mission(10)
    model = VehicleModel(no_space_first=2)
    link = SimLink(model)
    report = upload_mission(link, m, POLICY)
    assert report.mission.stats.error_acks == [mp.NO_SPACE, mp.NO_SPACE]
    assert report.mission.stats.restarts == 2
    assert link.t >= 2 * POLICY.busy_wait
    assert same_rows(stored_rows(model), plan_rows(m))


def test_no_space_that_stays_fails_with_the_reason() -> None:
    model = VehicleModel(capacity=5)
    with pytest.raises(LinkError, match="MAV_MISSION_NO_SPACE for 16 items 7 time"):
        upload_mission(SimLink(model), survey_mission(10), POLICY)
    assert model.stored[0] == []


def test_vehicle_cancelling_mid_upload_leads_to_a_restart() -> None:
    m = survey_mission(30)
    model = VehicleModel(request_resend=10.0, upload_timeout=0.15)
    # packet 10 is the vehicle's request for item 4: it waits for an item, gives up before our
    # resend is due and cancels; we restart the transaction and get through
    link = SimLink(model, drop_packets=frozenset({10}))
    report = upload_mission(link, m, mp.Policy(timeout=0.2, retries=3, restarts=2, min_timeout=0.2))
    acks = report.mission.stats.error_acks  # then ERROR for our resent items: it no longer receives
    assert acks[0] == mp.OPERATION_CANCELLED and set(acks) <= {mp.OPERATION_CANCELLED, mp.ERROR}
    assert report.mission.stats.restarts == 1 and model.log["got MISSION_COUNT"] == 2
    assert same_rows(stored_rows(model), plan_rows(m))


def test_px4_plan_has_no_home_item() -> None:
    m = survey_mission(5, firmware="px4")
    model = VehicleModel()
    upload_mission(SimLink(model), m, POLICY)
    assert same_rows(stored_rows(model), plan_rows(m)[1:])


def test_changed_item_is_caught_through_the_lossy_link() -> None:
    m = survey_mission(40)
    model = VehicleModel(alter={17: {"y": 150061234}})
    with pytest.raises(VerificationFailed) as exc:
        upload_mission(SimLink(model, Faults(drop=0.1, dup=0.05, seed=2)), m, POLICY)
    assert [(x.seq, x.field, x.actual) for x in exc.value.mismatches] == [(17, "y (longitude·1e7)", 150061234)]


def test_lost_final_ack_is_settled_by_the_read_back_not_by_sending_everything_again() -> None:
    m = survey_mission(5)
    n = len(m.items) + 1
    final_ack = 2 * n + 2  # packets: COUNT, then a request and an item per seq, then the ACK
    model = VehicleModel()
    report = upload_mission(SimLink(model, drop_packets=frozenset({final_ack})), m, POLICY)
    assert report.mission.stats.ack_lost and report.mission.stats.restarts == 0
    assert report.mission.verified and model.log["got MISSION_COUNT"] == 1
    assert mp.ERROR in report.mission.stats.error_acks  # our resent last item, after the vehicle had finished


def test_lost_final_ack_without_verification_sends_everything_again() -> None:
    m = survey_mission(5)
    final_ack = 2 * (len(m.items) + 1) + 2
    model = VehicleModel()
    report = upload_mission(SimLink(model, drop_packets=frozenset({final_ack})), m, POLICY, verify=False)
    assert not report.mission.stats.ack_lost and report.mission.stats.restarts == 1
    assert model.log["got MISSION_COUNT"] == 2 and model.completed_uploads == 2


def test_failed_last_item_whose_error_ack_is_lost_is_caught_by_the_read_back() -> None:
    m = survey_mission(5)
    n = len(m.items) + 1
    model = VehicleModel(fail_item=n - 1)
    with pytest.raises(VerificationFailed) as exc:
        upload_mission(SimLink(model, drop_packets=frozenset({2 * n + 2})), m, POLICY)
    assert str(exc.value.mismatches[0]) == f"mission: the vehicle has {n - 1} items, the plan {n}"
    assert str(exc.value) == (f"verification failed: the vehicle holds {n - 1} of {n} mission items: do not fly it "
                              "(its final MISSION_ACK never came; the read-back shows it)")
    assert exc.value.exit_code == 1


def test_vehicle_silent_before_the_last_item_holds_698_of_699_and_is_not_to_be_flown() -> None:
    m = survey_mission(693)
    n = len(m.items) + 1
    assert n == 699
    model = VehicleModel(silent_after_request=n - 1)  # asks for item 698, then nothing more
    with pytest.raises(LinkError) as exc:
        upload_mission(SimLink(model), m, POLICY)
    assert len(model.stored[0]) == 698
    assert str(exc.value).startswith("the vehicle holds 698 of 699 mission items: do not fly it (it asked for every item "
                                     "but never acknowledged the last one, and the read-back failed: mission download "
                                     "failed: no answer to MISSION_REQUEST_LIST")
    assert "not verified" not in str(exc.value) and exc.value.exit_code == 1


def test_read_back_of_an_acknowledged_upload_that_fails_says_not_verified() -> None:
    m = survey_mission(5)
    model = VehicleModel()
    link = SimLink(model)
    n = len(m.items) + 1
    link.drop_packets = frozenset(range(2 * n + 3, 10_000))  # everything after the vehicle's ACCEPTED
    with pytest.raises(LinkError, match=r"^upload acknowledged by the vehicle but not verified: mission download failed"):
        upload_mission(link, m, POLICY)
    assert model.completed_uploads == 1


def test_home_item_is_compared_when_the_vehicle_is_not_ardupilot() -> None:
    model = VehicleModel(alter={0: {"z": 10.0}})
    with pytest.raises(VerificationFailed) as exc:
        upload_mission(SimLink(model), survey_mission(3), POLICY)
    assert [(x.seq, x.field, x.actual) for x in exc.value.mismatches] == [(0, "z", 10.0)]


@pytest.mark.parametrize("px4", [False, True])
def test_defaults_over_a_30_percent_lossy_link_verify_every_seeded_run(px4: bool) -> None:
    """The command's defaults (`Policy()`), 20 seeded runs of a 120-item mission at 30 % loss each way (with
    duplicates, and for ArduPilot reordering too: PX4 ends a download when a request arrives out of order, which
    a radio link never does): every run ends verified and the vehicle's own store holds the plan."""
    verified = 0
    for seed in range(20):
        m = survey_mission(114, seed=seed, firmware="px4" if px4 else "ardupilot")
        model = VehicleModel(px4=px4, request_resend=1.0, upload_timeout=8.0)
        link = SimLink(model, Faults(drop=0.3, dup=0.05, reorder=0.0 if px4 else 0.05, seed=seed))
        report = upload_mission(link, m, mp.Policy())
        verified += report.mission.verified
        rows = plan_rows(m)
        assert same_rows(stored_rows(model), rows[1:] if px4 else rows)
    assert verified == 20


def test_px4_answers_are_expected_not_failures() -> None:
    """PX4 drops the items of a resent window it did not ask for without a word, answers a repeat of the last item
    with ACCEPTED, and asks again every 250 ms; none of it is an error."""
    m = survey_mission(40, firmware="px4", fence=True)
    model = VehicleModel(px4=True)
    link = SimLink(model, Faults(drop=0.2, seed=4))
    report = upload_mission(link, m, mp.Policy())
    assert report.mission.verified and report.fence is not None and report.fence.verified
    assert model.log.get("item dropped", 0) > 0 and not report.mission.stats.error_acks
    assert report.mission.stats.restarts == 0
