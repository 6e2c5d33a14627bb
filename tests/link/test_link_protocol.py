"""The pure mission protocol machines, fed by hand: every decision they make on what arrives and when."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from aerosurvey.link import mission_protocol as mp

POLICY = mp.Policy(timeout=1.0, retries=2, restarts=2, busy_wait=5.0, stall=4.0, min_timeout=1.0)  # a fixed 1 s timer


def items(n: int, mtype: int = mp.MISSION) -> list[mp.WireItem]:
    return [mp.WireItem(i, 16, 3, x=494000000 + i, y=150000000, z=50.0 + i, mission_type=mtype) for i in range(n)]


def sent_items(out: list[mp.Message]) -> list[int]:
    return [m.item.seq for m in out if isinstance(m, mp.Item)]


def test_constants_match_pymavlink() -> None:
    for code, name in mp.RESULT_NAMES.items():
        assert getattr(mavlink2, name) == code
    assert len(mp.RESULT_NAMES) == mavlink2.MAV_MISSION_RESULT_ENUM_END
    assert (mp.MISSION, mp.FENCE, mp.RALLY) == (mavlink2.MAV_MISSION_TYPE_MISSION, mavlink2.MAV_MISSION_TYPE_FENCE,
                                                mavlink2.MAV_MISSION_TYPE_RALLY)


def test_clean_upload_answers_each_request_and_ends_on_accepted() -> None:
    up = mp.Uploader(items(3), mp.MISSION, POLICY)
    assert up.start(0.0) == [mp.Count(3, mp.MISSION)]
    for seq in range(3):
        assert sent_items(up.handle(mp.Request(seq), 0.1 * seq)) == [seq]
    assert not up.done
    up.handle(mp.Ack(mp.ACCEPTED), 0.5)
    assert up.done and up.error is None
    assert up.stats.resends == 0 and up.stats.restarts == 0


def test_duplicate_out_of_order_and_legacy_requests_get_the_item_asked_for() -> None:
    up = mp.Uploader(items(4), mp.MISSION, POLICY)
    up.start(0.0)
    assert sent_items(up.handle(mp.Request(0), 0.0)) == [0]
    assert sent_items(up.handle(mp.Request(2, legacy=True), 0.0)) == [2]
    assert sent_items(up.handle(mp.Request(0), 0.0)) == [0]
    assert sent_items(up.handle(mp.Request(1), 0.0)) == [1]
    assert sent_items(up.handle(mp.Request(3), 0.0)) == [3]
    assert up.stats.duplicate_requests == 2  # 0 and 1, asked for after 2: repeats
    assert up.handle(mp.Request(4), 0.0) == []  # outside the mission: ignored
    assert up.handle(mp.Request(1, mission_type=mp.FENCE), 0.0) == []  # another transfer's request
    up.handle(mp.Ack(mp.ACCEPTED), 0.0)
    assert up.done


def test_accepted_before_every_item_was_requested_is_not_success() -> None:
    up = mp.Uploader(items(5), mp.MISSION, POLICY)
    up.start(0.0)
    for seq in range(3):
        up.handle(mp.Request(seq), 0.0)
    up.handle(mp.Ack(mp.ACCEPTED), 0.0)
    assert not up.done
    # the vehicle stopped; the machine resends, then restarts, then gives up: never done
    t = 0.0
    for _ in range(100):
        t += 1.01
        up.poll(t)
        if up.finished:
            break
    assert up.error is not None and not up.done
    assert up.stats.restarts == 1 and "no answer to MISSION_COUNT" in up.error  # the silent vehicle after the restart


def test_timeout_resends_the_last_item_then_restarts_the_transaction() -> None:
    up = mp.Uploader(items(3), mp.MISSION, POLICY)
    up.start(0.0)
    up.handle(mp.Request(0), 0.0)
    up.handle(mp.Request(1), 0.2)
    assert up.poll(1.0) == []
    assert sent_items(up.poll(1.25)) == [1, 2]  # the item asked for and the one after it
    assert sent_items(up.poll(2.3)) == [1, 2]
    assert up.poll(3.4) == [mp.Count(3, mp.MISSION)]  # silent for timeout x (retries + 1): restart
    assert up.stats.resends == 2 and up.stats.restarts == 1


def test_vehicle_that_never_answers_fails_after_the_count_retries() -> None:
    up = mp.Uploader(items(3), mp.MISSION, POLICY)
    out = up.start(0.0)
    t = 0.0
    while not up.finished and t < 100:
        t += 0.5
        out += up.poll(t)
    assert out == [mp.Count(3, mp.MISSION)] * 3
    assert up.error == "mission upload failed: no answer to MISSION_COUNT for 3.0 s (2 resend(s) in all)"
    assert t == pytest.approx(3.0)


def test_busy_waits_then_restarts_and_gives_up_when_it_stays() -> None:
    up = mp.Uploader(items(2), mp.MISSION, POLICY)
    up.start(0.0)
    assert up.handle(mp.Ack(mp.NO_SPACE), 0.1) == []
    assert up.poll(5.0) == []
    assert up.poll(5.2) == [mp.Count(2, mp.MISSION)]
    up.handle(mp.Ack(mp.NO_SPACE), 5.3)
    assert up.poll(10.4) == [mp.Count(2, mp.MISSION)]
    up.handle(mp.Ack(mp.NO_SPACE), 10.5)
    assert up.error is not None and "MAV_MISSION_NO_SPACE for 2 items 3 time(s)" in up.error


def test_no_space_after_the_vehicle_accepted_the_count_is_stale() -> None:
    up = mp.Uploader(items(2), mp.MISSION, POLICY)
    up.start(0.0)
    up.handle(mp.Request(0), 0.0)
    up.handle(mp.Ack(mp.NO_SPACE), 0.0)
    assert sent_items(up.handle(mp.Request(1), 0.0)) == [1]
    up.handle(mp.Ack(mp.ACCEPTED), 0.0)
    assert up.done


@pytest.mark.parametrize("code", [mp.OPERATION_CANCELLED, mp.ERROR])
def test_cancelled_or_error_without_further_requests_restarts(code: int) -> None:
    up = mp.Uploader(items(3), mp.MISSION, POLICY)
    up.start(0.0)
    up.handle(mp.Request(0), 0.0)
    up.handle(mp.Ack(code), 0.1)
    assert sent_items(up.poll(1.05)) == [0, 1]  # resent while the answer is younger than one timeout
    assert up.poll(2.05) == [mp.Count(3, mp.MISSION)]
    assert up.stats.restarts == 1 and up.stats.error_acks == [code]


def test_invalid_sequence_answers_keep_the_upload_alive_until_the_stall_limit() -> None:
    up = mp.Uploader(items(3), mp.MISSION, POLICY)
    up.start(0.0)
    up.handle(mp.Request(0), 0.0)
    t, resent = 0.0, 0
    while not up.finished and t < 60:  # our resends of item 0 are each answered INVALID_SEQUENCE
        t += 0.05
        out = up.poll(t)
        resent += len(sent_items(out))
        if sent_items(out):
            up.handle(mp.Ack(mp.INVALID_SEQUENCE), t + 0.01)
        if not up.finished and out == [mp.Count(3, mp.MISSION)]:
            break
    assert up.stats.resends == 3  # at 1, 2 and 3 s: more than `retries` (2), as the vehicle answers each
    assert up.stats.restarts == 1 and POLICY.stall <= t <= POLICY.stall + POLICY.timeout


def test_late_error_followed_by_requests_is_only_noise() -> None:
    up = mp.Uploader(items(3), mp.MISSION, POLICY)
    up.start(0.0)
    up.handle(mp.Request(0), 0.0)
    up.handle(mp.Ack(mp.INVALID_SEQUENCE), 0.05)
    up.handle(mp.Ack(mp.ERROR), 0.1)
    up.handle(mp.Request(1), 0.2)
    assert sent_items(up.poll(1.25)) == [1, 2]  # a plain resend, no restart
    up.handle(mp.Request(2), 1.3)
    up.handle(mp.Ack(mp.ACCEPTED), 1.3)
    assert up.done and up.stats.restarts == 0


def test_a_vehicle_that_only_repeats_requests_cannot_loop_forever() -> None:
    up = mp.Uploader(items(3), mp.MISSION, POLICY)
    up.start(0.0)
    up.handle(mp.Request(0), 0.0)
    t = 0.0
    while not up.finished and t < 60:
        t += 0.1
        up.handle(mp.Request(0), t)
        up.poll(t)
    assert up.error is not None and "asked for nothing new after item 0 of 3 for 4." in up.error
    assert 3 * POLICY.stall <= t < 3 * (POLICY.stall + POLICY.timeout)  # checked at resend times


def test_rejected_item_fails_naming_it() -> None:
    up = mp.Uploader(items(3), mp.MISSION, POLICY)
    up.start(0.0)
    up.handle(mp.Request(0), 0.0)
    up.handle(mp.Request(1), 0.0)
    up.handle(mp.Ack(mp.INVALID_PARAM7), 0.0)
    assert up.error == "mission upload rejected by the vehicle at item 1: MAV_MISSION_INVALID_PARAM7"


def test_empty_upload_is_done_on_accepted() -> None:
    up = mp.Uploader([], mp.FENCE, POLICY)
    assert up.start(0.0) == [mp.Count(0, mp.FENCE)]
    up.handle(mp.Ack(mp.ACCEPTED, mp.MISSION), 0.0)
    assert not up.done  # another mission type's ack
    up.handle(mp.Ack(mp.ACCEPTED, mp.FENCE), 0.0)
    assert up.done


def test_uploader_refuses_misnumbered_items() -> None:
    with pytest.raises(ValueError):
        mp.Uploader([mp.WireItem(1, 16, 3)], mp.MISSION, POLICY)
    with pytest.raises(ValueError):
        mp.Policy(timeout=math.inf)


def test_download_requests_each_item_ignores_duplicates_and_acks() -> None:
    dl = mp.Downloader(mp.MISSION, POLICY)
    assert dl.start(0.0) == [mp.RequestList(mp.MISSION)]
    assert dl.handle(mp.Count(3), 0.0) == [mp.Request(0, mp.MISSION)]
    src = items(3)
    assert dl.handle(mp.Count(3), 0.0) == []  # duplicated count
    assert dl.handle(mp.Item(src[2]), 0.0) == []  # not asked for yet
    assert dl.handle(mp.Item(src[0]), 0.0) == [mp.Request(1, mp.MISSION)]
    assert dl.handle(mp.Item(src[0]), 0.0) == []  # duplicate
    assert dl.handle(mp.Item(src[1]), 0.0) == [mp.Request(2, mp.MISSION)]
    assert dl.handle(mp.Item(src[2]), 0.0) == [mp.Ack(mp.ACCEPTED, mp.MISSION)]
    assert dl.result() == src


def test_download_resends_then_restarts_and_goes_on_from_the_first_missing_item() -> None:
    dl = mp.Downloader(mp.FENCE, POLICY)
    src = items(3, mp.FENCE)
    dl.start(0.0)
    dl.handle(mp.Count(3, mp.FENCE), 0.0)
    assert dl.handle(mp.Item(src[0]), 0.1) == [mp.Request(1, mp.FENCE)]
    assert dl.poll(1.1) == [mp.Request(1, mp.FENCE)]
    assert dl.poll(2.1) == [mp.Request(1, mp.FENCE)]
    assert dl.poll(3.1) == [mp.RequestList(mp.FENCE)]  # retries (2) used up: restart, like an upload
    assert dl.stats.restarts == 1 and dl.stats.resends == 2 and dl.error is None
    assert dl.handle(mp.Count(3, mp.FENCE), 3.2) == [mp.Request(1, mp.FENCE)]  # same count: item 0 is kept
    dl.handle(mp.Item(src[1]), 3.3)
    assert dl.handle(mp.Item(src[2]), 3.4) == [mp.Ack(mp.ACCEPTED, mp.FENCE)]
    assert dl.result() == src


def test_download_gives_up_after_restarts_in_a_row_without_a_new_item_naming_the_step() -> None:
    dl = mp.Downloader(mp.FENCE, POLICY)
    out = dl.start(0.0)
    out += dl.handle(mp.Count(2, mp.FENCE), 0.0)
    t = 0.0
    while not dl.finished and t < 100:
        t += 0.5
        out += dl.poll(t)
    # Request(0) and 2 resends, then per restart (2 allowed) MISSION_REQUEST_LIST and 2 resends of it
    assert out.count(mp.Request(0, mp.FENCE)) == 3 and out.count(mp.RequestList(mp.FENCE)) == 1 + 3 * 2
    assert dl.error == ("fence download failed: no answer to MISSION_REQUEST_LIST for 3.0 s (6 resend(s) in all); gave up after "
                        "2 restart(s) in a row that brought no new item (0 of 2 items read)")
    assert t == pytest.approx(3 * (POLICY.retries + 1) * POLICY.timeout)
    with pytest.raises(mp.TransferFailed):
        dl.result()


def test_download_restarts_as_often_as_each_brings_a_new_item() -> None:
    n = 3 * (POLICY.restarts + 1)
    src = items(n)
    dl = mp.Downloader(mp.MISSION, POLICY)
    out = dl.start(0.0)
    t = 0.0
    while not dl.finished and t < 1000:  # the vehicle answers the count and one item per transaction, then is silent
        t += 0.25
        for m in out:
            if isinstance(m, mp.RequestList):
                out = dl.handle(mp.Count(n), t)
                break
        else:
            asked = [m.seq for m in out if isinstance(m, mp.Request)]
            out = dl.handle(mp.Item(src[asked[0]]), t) if asked and dl.progress[0] < dl.stats.restarts + 1 else []
        out += dl.poll(t)
    assert dl.done and dl.result() == src
    assert dl.stats.restarts == n - 1 > POLICY.restarts


def test_download_starts_again_from_item_0_when_the_count_changes() -> None:
    dl = mp.Downloader(mp.MISSION, POLICY)
    dl.start(0.0)
    dl.handle(mp.Count(3), 0.0)
    dl.handle(mp.Item(items(3)[0]), 0.0)
    dl.handle(mp.Ack(mp.ERROR), 0.1)
    assert dl.poll(1.0) == [mp.Request(1, mp.MISSION)]  # resent while the error is younger than one timeout
    assert dl.poll(2.0) == [mp.RequestList(mp.MISSION)]
    assert dl.handle(mp.Count(2), 2.1) == [mp.Request(0, mp.MISSION)]
    assert dl.progress == (0, 2) and dl.count == 2


def test_download_waits_while_the_vehicle_is_busy_receiving() -> None:
    dl = mp.Downloader(mp.MISSION, POLICY)
    dl.start(0.0)
    dl.handle(mp.Ack(mp.DENIED), 0.1)
    assert dl.poll(1.2) == [] and dl.handle(mp.Count(2), 1.3) == []  # waiting: a late count is ignored
    assert dl.poll(5.2) == [mp.RequestList(mp.MISSION)]
    dl.handle(mp.Ack(mp.DENIED), 5.3)
    assert dl.poll(10.4) == [mp.RequestList(mp.MISSION)]
    dl.handle(mp.Ack(mp.DENIED), 10.5)
    assert dl.error == "mission download failed: the vehicle answered MAV_MISSION_DENIED 3 time(s); it is busy with another transfer"


def test_upload_denied_waits_then_gives_up() -> None:
    up = mp.Uploader(items(2), mp.MISSION, POLICY)
    up.start(0.0)
    up.handle(mp.Ack(mp.DENIED), 0.1)
    assert up.poll(5.2) == [mp.Count(2, mp.MISSION)]
    up.handle(mp.Ack(mp.DENIED), 5.3)
    up.poll(10.4)
    up.handle(mp.Ack(mp.DENIED), 10.5)
    assert up.error is not None and "MAV_MISSION_DENIED for 2 items 3 time(s); another ground station" in up.error


def test_download_busy_counts_only_restarts_without_a_new_item() -> None:
    dl = mp.Downloader(mp.MISSION, POLICY)
    src = items(4)
    dl.start(0.0)
    t = 0.0
    for k in range(4):  # DENIED after each item: 4 restarts in all, none of them idle
        dl.handle(mp.Count(4), t)
        dl.handle(mp.Item(src[k]), t)
        if k < 3:
            dl.handle(mp.Ack(mp.DENIED), t)
            t += POLICY.busy_wait
            assert dl.poll(t) == [mp.RequestList(mp.MISSION)]
    assert dl.done and dl.stats.restarts == 3 > POLICY.restarts


def test_download_error_ack_restarts_only_when_nothing_follows() -> None:
    dl = mp.Downloader(mp.MISSION, POLICY)
    dl.start(0.0)
    dl.handle(mp.Ack(mp.ERROR), 0.1)
    assert dl.poll(1.0) == [mp.RequestList(mp.MISSION)] and dl.stats.restarts == 0  # a resend
    assert dl.poll(2.0) == [mp.RequestList(mp.MISSION)] and dl.stats.restarts == 1
    dl.handle(mp.Count(1), 2.1)
    dl.handle(mp.Ack(mp.ERROR), 2.2)  # late noise
    dl.handle(mp.Item(items(1)[0]), 2.3)
    assert dl.done and dl.stats.restarts == 1


def test_empty_download() -> None:
    dl = mp.Downloader(mp.MISSION, POLICY)
    dl.start(0.0)
    assert dl.handle(mp.Count(0), 0.0) == [mp.Ack(mp.ACCEPTED, mp.MISSION)]
    assert dl.result() == []


def test_all_items_asked_then_silence_ends_as_ack_lost_only_when_a_read_back_follows() -> None:
    for confirm in (True, False):
        up = mp.Uploader(items(2), mp.MISSION, POLICY, confirm_by_download=confirm)
        up.start(0.0)
        up.handle(mp.Request(0), 0.0)
        up.handle(mp.Request(1), 0.0)
        assert sent_items(up.poll(1.0)) == [1]
        up.handle(mp.Ack(mp.ERROR), 1.01)  # the vehicle is no longer receiving
        out = up.poll(2.0)
        if confirm:
            assert up.done and up.stats.ack_lost and out == []
        else:
            assert not up.done and sent_items(out) == [1]  # resent while the error is younger than one timeout
            assert up.poll(3.0) == [mp.Count(2, mp.MISSION)] and up.stats.restarts == 1


def test_ack_lost_needs_every_item_sent() -> None:
    up = mp.Uploader(items(6), mp.MISSION, POLICY, confirm_by_download=True)
    up.start(0.0)
    up.handle(mp.Request(0), 0.0)
    up.handle(mp.Request(1), 0.0)
    up.handle(mp.Ack(mp.ERROR), 0.1)
    assert sent_items(up.poll(1.0)) == [1, 2]
    assert up.poll(2.0) == [mp.Count(6, mp.MISSION)]
    assert not up.done and not up.stats.ack_lost


def test_policy_limit_is_setup_plus_a_share_per_item() -> None:
    p = mp.Policy()
    assert p.setup == 4 * (3.0 + 6 * 1.0 + 1.0 + 10.0)
    assert p.limit(701) == p.setup + 701 * 5.0
    assert mp.Policy(timeout=2.0).per_item == 10.0 and mp.Policy(item_time=1.5).per_item == 1.5
    with pytest.raises(ValueError):
        mp.Policy(item_time=0.0)


def test_upload_to_a_vehicle_that_answers_just_often_enough_ends_at_the_limit() -> None:
    # a new request every 2.5 s trips neither the retries (3 s) nor the stall rule (4 s)
    policy = mp.Policy(timeout=1.0, retries=2, restarts=0, busy_wait=0.0, stall=4.0, item_time=1.0)
    up = mp.Uploader(items(20), mp.MISSION, policy)
    up.start(0.0)
    t, seq = 0.0, 0
    while not up.finished:
        t = min(up.deadline, 2.5 * (seq + 1))
        if t == 2.5 * (seq + 1):
            up.handle(mp.Request(seq), t)
            seq += 1
        up.poll(t)
    assert t == policy.limit(20) == 28.0 and seq == 11
    assert up.error == ("mission upload failed: not finished within 28 s, the limit for 20 item(s) (8 s + 1 s per item); "
                        "the link is too poor or the vehicle too slow")


def test_download_from_a_vehicle_that_answers_just_often_enough_ends_at_the_limit() -> None:
    # each item comes 1.4 s after its request: within the 2 resends (0.5 s apart) that would restart
    policy = mp.Policy(timeout=0.5, retries=2, restarts=0, busy_wait=0.0, stall=2.0, item_time=1.0)
    src = items(20)
    dl = mp.Downloader(mp.MISSION, policy, expected=20)
    out = dl.start(0.0)
    out += dl.handle(mp.Count(20), 0.0)
    asked_at, t = 0.0, 0.0
    while not dl.finished:
        t = min(dl.deadline, asked_at + 1.4)
        if t == asked_at + 1.4:
            out = dl.handle(mp.Item(src[dl.progress[0]]), t)
            asked_at = t
        dl.poll(t)
    assert t == policy.limit(20) == 24.0 and dl.progress == (17, 20)
    assert dl.error is not None and dl.error.startswith("mission download failed: not finished within 24 s, the limit for 20 item(s)")


_SEQ = st.integers(0, 8)
_VEHICLE_SAYS = st.one_of(
    st.builds(mp.Count, st.integers(0, 8)), st.builds(mp.Request, _SEQ),
    st.builds(lambda seq: mp.Item(mp.WireItem(seq, 16, 3)), _SEQ), st.builds(mp.Ack, st.integers(0, 15)))


@settings(max_examples=300, deadline=None, derandomize=True)
@given(upload=st.booleans(), n=st.integers(0, 6), confirm=st.booleans(),
       events=st.lists(st.tuples(st.floats(0.0, 2.0), _VEHICLE_SAYS), max_size=200))
def test_whatever_the_vehicle_says_a_transfer_ends_within_its_limit(upload: bool, n: int, confirm: bool,
                                                                     events: list[tuple[float, mp.Message]]) -> None:
    policy = mp.Policy(timeout=0.5, retries=2, restarts=2, busy_wait=1.0, stall=2.0, item_time=1.0)
    machine: mp.Uploader | mp.Downloader = (mp.Uploader(items(n), mp.MISSION, policy, confirm) if upload
                                            else mp.Downloader(mp.MISSION, policy, expected=n))
    machine.start(0.0)
    t, last_count, finished_at = 0.0, None, math.inf
    for gap, msg in [*events, (math.inf, None)]:
        t += gap
        for _ in range(10_000):  # bounded here too: a machine that never ends fails the test, not the run
            if machine.finished or machine.deadline > t:
                break
            finished_at = machine.deadline  # the machine is polled at each of its deadlines
            machine.poll(finished_at)
        if machine.finished or msg is None:
            break
        last_count = msg.count if isinstance(msg, mp.Count) else last_count
        machine.handle(msg, t)
        machine.poll(t)
        finished_at = t
    assert machine.finished and finished_at <= policy.limit(n)
    if isinstance(machine, mp.Downloader) and machine.done:
        assert len(machine.result()) == last_count == machine.count
    if isinstance(machine, mp.Uploader) and machine.done and not machine.stats.ack_lost:
        assert machine.confirmed == n


def rfc6298(samples: list[float], g: float) -> float:
    """RFC 6298 section 2, written out here: the timer after these round trips (no bounds)."""
    srtt, rttvar = samples[0], samples[0] / 2
    for r in samples[1:]:
        rttvar = (1 - 1 / 4) * rttvar + 1 / 4 * abs(srtt - r)
        srtt = (1 - 1 / 8) * srtt + 1 / 8 * r
    return srtt + max(g, 4 * rttvar)


@settings(max_examples=100, deadline=None, derandomize=True)
@given(st.lists(st.floats(0.0, 2.0), min_size=1, max_size=30))
def test_resend_timer_follows_rfc_6298_within_its_bounds(samples: list[float]) -> None:
    policy = mp.Policy(timeout=1.0, min_timeout=0.01)
    timer = mp.ResendTimer(policy)
    assert timer.value(0) == mp.FIRST_TIMEOUT  # before any round trip
    for r in samples:
        timer.measured(r)
    expected = min(1.0, max(0.01, rfc6298(samples, 0.01)))
    assert timer.value(0) == pytest.approx(expected)
    waits = [timer.value(k) for k in range(20)]
    assert waits[: mp.FLAT_RESENDS + 1] == [waits[0]] * (mp.FLAT_RESENDS + 1)
    ceiling = min(1.0, max(4 * waits[0], 0.25))  # four timers, at least the protocol's 250 ms, at most the timeout
    assert all(b == min(ceiling, 2 * a) for a, b in zip(waits[mp.FLAT_RESENDS:], waits[mp.FLAT_RESENDS + 1:]))
    assert max(waits) == pytest.approx(ceiling) and waits[-1] == pytest.approx(ceiling)


def test_upload_measures_round_trips_only_on_items_sent_once() -> None:
    policy = mp.Policy(timeout=1.0, min_timeout=0.01)
    up = mp.Uploader(items(6), mp.MISSION, policy)
    up.start(0.0)
    up.handle(mp.Request(0), 0.05)  # MISSION_COUNT answered after 50 ms
    up.handle(mp.Request(1), 0.10)  # item 0 after 50 ms
    assert up.timer.samples == 2 and up.timer.srtt == pytest.approx(0.05)
    assert up.deadline == pytest.approx(0.10 + max(0.01, 0.05 + 4 * up.timer.rttvar))
    t = up.deadline
    assert sent_items(up.poll(t)) == [1, 2]  # the request for 2 is late: 1 and the one after it
    up.handle(mp.Request(2), t + 0.001)  # answered, but which copy? Karn: no round trip taken
    assert up.timer.samples == 2
    t = up.deadline
    assert sent_items(up.poll(t)) == [2, 3]
    assert sent_items(up.poll(up.deadline)) == [2, 3, 4]  # its requests for 3 and 4 may both be lost
    up.handle(mp.Request(3), up.deadline + 5.0)  # long after the last copy: the vehicle's own re-request, maybe
    assert up.timer.samples == 2 and up.timer.srtt == pytest.approx(0.05)
    up.handle(mp.Request(3), up.deadline + 6.0)  # its re-request of the item we sent: a copy, then answered
    t = up.deadline - 0.5
    up.handle(mp.Request(4), t)
    assert up.timer.samples == 2  # Karn: the copy answered, or the one before
    up.handle(mp.Request(5), t + 0.02)  # item 4 sent once, answered after 20 ms
    assert up.timer.samples == 3 and up.timer.srtt == pytest.approx(0.875 * 0.05 + 0.125 * 0.02)


def test_download_measures_a_request_answered_long_after_its_last_copy() -> None:
    """The vehicle sends an item only when asked: an answer a whole timer after the last copy proves the round
    trip is at least that long, and the timer follows a link that got slower."""
    down = mp.Downloader(mp.MISSION, mp.Policy(timeout=1.0, min_timeout=0.01))
    down.start(0.0)
    down.handle(mp.Count(3), 0.05)
    t = down.deadline
    assert down.poll(t) == [mp.Request(0)]
    down.handle(mp.Item(items(3)[0]), t + 0.6)
    assert down.timer.samples == 2 and down.timer.srtt == pytest.approx(0.875 * 0.05 + 0.125 * 0.6)


def test_upload_window_reaches_the_item_the_vehicle_wants_when_its_requests_are_lost() -> None:
    """A vehicle (as ArduPilot) that stored items 1 and 2 from a resent window, whose requests for 2 and 3 were
    lost: it wants 3, which the next window carries; every other item is answered INVALID_SEQUENCE and is harmless."""
    up = mp.Uploader(items(8), mp.MISSION, mp.Policy(timeout=1.0, min_timeout=0.01))
    up.start(0.0)
    up.handle(mp.Request(0), 0.01)
    up.handle(mp.Request(1), 0.02)
    wants = 1
    for _ in range(4):
        out = up.poll(up.deadline)
        for seq in sent_items(out):
            if seq == wants:
                wants += 1  # stored; its request for the next one is lost
            else:
                up.handle(mp.Ack(mp.INVALID_SEQUENCE), up.deadline)
        if wants > 3:
            break
    assert wants > 3 and not up.finished
    assert all(len(sent_items([m])) == 1 for m in out) and len(sent_items(out)) <= mp.RESEND_WINDOW


def test_accepted_after_a_window_that_carried_the_last_item_is_success() -> None:
    up = mp.Uploader(items(3), mp.MISSION, mp.Policy(timeout=1.0, min_timeout=0.01))
    up.start(0.0)
    up.handle(mp.Request(0), 0.01)
    up.handle(mp.Request(1), 0.02)
    assert sent_items(up.poll(up.deadline)) == [1, 2]  # its request for 2 was lost
    up.handle(mp.Ack(mp.ACCEPTED), up.deadline)
    assert up.done and up.confirmed == 3


def test_download_without_resume_asks_again_from_item_0() -> None:
    """PX4 answers only the next item of its transfer or the one before: after a restart, item 0 first."""
    src = items(3)
    dl = mp.Downloader(mp.MISSION, POLICY, resume=False)
    dl.start(0.0)
    dl.handle(mp.Count(3), 0.0)
    dl.handle(mp.Item(src[0]), 0.1)
    dl.handle(mp.Item(src[1]), 0.2)
    dl.handle(mp.Ack(mp.ERROR), 0.3)
    dl.poll(1.2)
    assert dl.poll(2.2) == [mp.RequestList(mp.MISSION)]
    assert dl.handle(mp.Count(3), 2.3) == [mp.Request(0, mp.MISSION)]
    assert dl.progress == (2, 3)  # what it holds is kept; the requests start over


def test_a_window_that_carried_the_last_items_then_error_leaves_it_to_the_read_back() -> None:
    """The vehicle's requests for 3 and 4 were lost, a window carried 3 and 4, it took them and its ACCEPTED was lost:
    our next resends get ERROR (it no longer receives). Sending everything again would cost a whole upload; the
    read-back decides instead (and would catch a vehicle that holds less)."""
    up = mp.Uploader(items(5), mp.MISSION, POLICY, confirm_by_download=True)
    up.start(0.0)
    for seq in range(3):
        up.handle(mp.Request(seq), 0.0)
    assert sent_items(up.poll(1.0)) == [2, 3]
    assert sent_items(up.poll(2.0)) == [2, 3, 4]
    up.handle(mp.Ack(mp.ERROR), 3.0)
    assert up.poll(3.0) == [] and up.done and up.stats.ack_lost and up.confirmed == 2
