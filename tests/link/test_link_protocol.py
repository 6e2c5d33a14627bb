"""The pure mission protocol machines, fed by hand: every decision they make on what arrives and when."""

from __future__ import annotations

import math

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from aerosurvey.link import mission_protocol as mp

POLICY = mp.Policy(timeout=1.0, retries=2, restarts=2, busy_wait=5.0, stall=4.0)


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
    assert up.stats.duplicate_requests == 1
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
    assert sent_items(up.poll(1.25)) == [1]
    assert sent_items(up.poll(2.3)) == [1]
    assert up.poll(3.4) == [mp.Count(3, mp.MISSION)]  # retries (2) used up: restart
    assert up.stats.resends == 2 and up.stats.restarts == 1


def test_vehicle_that_never_answers_fails_after_the_count_retries() -> None:
    up = mp.Uploader(items(3), mp.MISSION, POLICY)
    out = up.start(0.0)
    t = 0.0
    while not up.finished and t < 100:
        t += 0.5
        out += up.poll(t)
    assert out == [mp.Count(3, mp.MISSION)] * 3
    assert up.error == "mission upload failed: no answer to MISSION_COUNT after 2 resend(s), 1 s each"
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
    assert up.poll(1.05) == [mp.Count(3, mp.MISSION)]
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
    assert resent == 3  # at 1, 2 and 3 s: more than `retries` (2), as the vehicle answers each
    assert up.stats.restarts == 1 and POLICY.stall <= t <= POLICY.stall + POLICY.timeout


def test_late_error_followed_by_requests_is_only_noise() -> None:
    up = mp.Uploader(items(3), mp.MISSION, POLICY)
    up.start(0.0)
    up.handle(mp.Request(0), 0.0)
    up.handle(mp.Ack(mp.INVALID_SEQUENCE), 0.05)
    up.handle(mp.Ack(mp.ERROR), 0.1)
    up.handle(mp.Request(1), 0.2)
    assert sent_items(up.poll(1.25)) == [1]  # a plain resend, no restart
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


def test_download_resends_and_fails_naming_the_step() -> None:
    dl = mp.Downloader(mp.FENCE, POLICY)
    dl.start(0.0)
    dl.handle(mp.Count(2, mp.FENCE), 0.0)
    assert dl.poll(1.0) == [mp.Request(0, mp.FENCE)]
    assert dl.poll(2.0) == [mp.Request(0, mp.FENCE)]
    dl.poll(3.0)
    assert dl.error == "fence download failed: no answer to MISSION_REQUEST_INT for item 0 after 2 resend(s), 1 s each"
    with pytest.raises(mp.TransferFailed):
        dl.result()


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


def test_download_error_ack_restarts_only_when_nothing_follows() -> None:
    dl = mp.Downloader(mp.MISSION, POLICY)
    dl.start(0.0)
    dl.handle(mp.Ack(mp.ERROR), 0.1)
    assert dl.poll(1.0) == [mp.RequestList(mp.MISSION)]
    assert dl.stats.restarts == 1
    dl.handle(mp.Count(1), 1.1)
    dl.handle(mp.Ack(mp.ERROR), 1.2)  # late noise
    dl.handle(mp.Item(items(1)[0]), 1.3)
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
            assert not up.done and out == [mp.Count(2, mp.MISSION)] and up.stats.restarts == 1


def test_ack_lost_needs_every_item_asked_for() -> None:
    up = mp.Uploader(items(3), mp.MISSION, POLICY, confirm_by_download=True)
    up.start(0.0)
    up.handle(mp.Request(0), 0.0)
    up.handle(mp.Request(1), 0.0)
    up.handle(mp.Ack(mp.ERROR), 0.1)
    assert up.poll(1.0) == [mp.Count(3, mp.MISSION)]
    assert not up.done and not up.stats.ack_lost
