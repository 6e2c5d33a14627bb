"""The MAVLink mission protocol as pure state machines: no sockets, no clock of their own.

A machine is told what arrived (`handle`) and what time it is (`poll`); it answers with
the messages to send next. Keeping time and I/O outside makes every retry, restart and
stale-packet decision testable with a simulated clock and a lossy simulated link.

Upload (ground station side): MISSION_COUNT → the vehicle asks for each item with
MISSION_REQUEST_INT (or legacy MISSION_REQUEST) → we answer MISSION_ITEM_INT → the vehicle
ends with MISSION_ACK. Download: MISSION_REQUEST_LIST → MISSION_COUNT → MISSION_REQUEST_INT
per item → MISSION_ITEM_INT → we end with MISSION_ACK.

Both sides follow the same rules: a step is resent after `Policy.timeout`, `Policy.retries`
unanswered resends in a row restart the transaction, restarts are bounded, and every
transfer ends within `Policy.limit(n)` seconds whatever the vehicle does.

Numbers follow MAVLink common.xml (MAV_MISSION_RESULT, MAV_MISSION_TYPE); they are plain
integers here so this module stays free of pymavlink.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

# MAV_MISSION_TYPE
MISSION = 0
FENCE = 1
RALLY = 2

# MAV_MISSION_RESULT
ACCEPTED = 0
ERROR = 1
UNSUPPORTED_FRAME = 2
UNSUPPORTED = 3
NO_SPACE = 4
INVALID = 5
INVALID_PARAM1 = 6
INVALID_PARAM7 = 12
INVALID_SEQUENCE = 13
DENIED = 14
OPERATION_CANCELLED = 15

RESULT_NAMES = {
    0: "MAV_MISSION_ACCEPTED", 1: "MAV_MISSION_ERROR", 2: "MAV_MISSION_UNSUPPORTED_FRAME",
    3: "MAV_MISSION_UNSUPPORTED", 4: "MAV_MISSION_NO_SPACE", 5: "MAV_MISSION_INVALID",
    6: "MAV_MISSION_INVALID_PARAM1", 7: "MAV_MISSION_INVALID_PARAM2", 8: "MAV_MISSION_INVALID_PARAM3",
    9: "MAV_MISSION_INVALID_PARAM4", 10: "MAV_MISSION_INVALID_PARAM5_X", 11: "MAV_MISSION_INVALID_PARAM6_Y",
    12: "MAV_MISSION_INVALID_PARAM7", 13: "MAV_MISSION_INVALID_SEQUENCE", 14: "MAV_MISSION_DENIED",
    15: "MAV_MISSION_OPERATION_CANCELLED",
}
TYPE_NAMES = {MISSION: "mission", FENCE: "fence", RALLY: "rally"}

# Answers that mean "the vehicle may have lost or already finished this transaction". ArduPilot
# (MissionItemProtocol.cpp) sends ERROR for an item that arrives when it is not receiving (e.g. a
# duplicate of the last item after its ACK) and OPERATION_CANCELLED when its own upload timer
# expired. Neither alone proves the transfer failed (it may be a late copy), so the machine waits
# one step timeout for a request and restarts the transaction when none comes.
# INVALID_SEQUENCE is different: ArduPilot sends it for a duplicated or late item while it keeps
# receiving and re-requesting the item it wants (also when our resend crosses its lost request),
# so it is counted but needs no action; a vehicle that answers it and never asks again is caught
# by the stall rule, which restarts the transaction.
_SUSPECT = frozenset({ERROR, OPERATION_CANCELLED})


def result_name(code: int) -> str:
    return RESULT_NAMES.get(code, f"MAV_MISSION_RESULT {code}")


@dataclass(frozen=True)
class WireItem:
    """The content of one MISSION_ITEM_INT: x/y are int32 degrees·1e7, z and params float32."""

    seq: int
    command: int
    frame: int
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    x: int = 0
    y: int = 0
    z: float = 0.0
    autocontinue: int = 1
    current: int = 0
    mission_type: int = MISSION


@dataclass(frozen=True)
class Count:
    """MISSION_COUNT."""

    count: int
    mission_type: int = MISSION


@dataclass(frozen=True)
class RequestList:
    """MISSION_REQUEST_LIST."""

    mission_type: int = MISSION


@dataclass(frozen=True)
class Request:
    """MISSION_REQUEST_INT, or the legacy MISSION_REQUEST when `legacy` (same meaning)."""

    seq: int
    mission_type: int = MISSION
    legacy: bool = False


@dataclass(frozen=True)
class Item:
    """MISSION_ITEM_INT (a legacy MISSION_ITEM is converted to this form by the codec)."""

    item: WireItem


@dataclass(frozen=True)
class Ack:
    """MISSION_ACK with a MAV_MISSION_RESULT."""

    result: int
    mission_type: int = MISSION


Message = Count | RequestList | Request | Item | Ack


@dataclass(frozen=True)
class Policy:
    """How long to wait and how often to try again; all bounded so a transfer always ends.

    `timeout`: seconds without an answer before a step is resent. `retries`: resends in a row
    that the vehicle does not answer at all before the transaction is restarted (or, for an
    upload's first step, given up). `stall`: seconds an upload may go without the vehicle
    asking for a new item while it still answers (it may be re-requesting at its own pace:
    ArduPilot asks again after 1 s and cancels after 8 s) before it is restarted. `restarts`:
    an upload's whole-transaction restarts (each sends every item again); a download keeps the
    items it has and may restart any number of times as long as each restart follows a new
    item, but no more than `restarts` times in a row without one. `busy_wait`: pause before
    restarting after MAV_MISSION_NO_SPACE (ArduPilot sends it right after boot) or
    MAV_MISSION_DENIED (the vehicle is still busy with another transfer), so that 3 restarts
    span ArduPilot's 8 s upload timeout. `item_time`: the average seconds per item a whole
    transfer may take (None: the larger of 5 s and 5 timeouts); see `limit`.
    """

    timeout: float = 1.0
    retries: int = 5
    restarts: int = 3
    busy_wait: float = 3.0
    stall: float = 10.0
    item_time: float | None = None

    def __post_init__(self) -> None:
        if not (self.timeout > 0 and math.isfinite(self.timeout)):
            raise ValueError(f"timeout must be a positive number of seconds, got {self.timeout!r}")
        if self.retries < 0 or self.restarts < 0 or self.busy_wait < 0 or not self.stall > 0:
            raise ValueError("retries, restarts and busy_wait must not be negative, stall must be positive")
        if self.item_time is not None and not (self.item_time > 0 and math.isfinite(self.item_time)):
            raise ValueError(f"item_time must be a positive number of seconds, got {self.item_time!r}")

    @property
    def per_item(self) -> float:
        """Average seconds per item a transfer may take: `item_time`, by default max(5 s, 5 timeouts)."""
        return self.item_time if self.item_time is not None else max(5.0, 5.0 * self.timeout)

    @property
    def setup(self) -> float:
        """The part of `limit` that does not grow with the items: each allowed restart may wait
        `busy_wait`, go `retries` + 1 timeouts unanswered and stall for `stall`."""
        return (self.restarts + 1) * (self.busy_wait + (self.retries + 1) * self.timeout + self.stall)

    def limit(self, n: int) -> float:
        """Seconds a transfer of `n` items may take in all: `setup` + n × `per_item`.

        The machines fail a transfer that has not ended by then, whatever the vehicle does
        (one that answers just often enough never to trip the other rules included); the
        resend, retry and restart rules decide long before it on any link that is merely lossy.
        """
        return self.setup + n * self.per_item


@dataclass
class Stats:
    """What happened on the way; reported so a flaky link is visible even when it succeeds."""

    sent: int = 0
    resends: int = 0
    restarts: int = 0
    duplicate_requests: int = 0
    ignored: int = 0
    error_acks: list[int] = field(default_factory=list)
    ack_lost: bool = False  # an upload ended without the vehicle's ACCEPTED (see Uploader)
    confirmed: int = 0  # upload: items the vehicle confirmed in the last attempt (see Uploader.confirmed)


class TransferFailed(Exception):
    """The transfer ended without success; the message says which step and why."""


class _Machine:
    """Shared bookkeeping: state, deadlines and outcome of one transfer."""

    kind = "transfer"

    @property
    def what(self) -> str:
        """E.g. "fence upload": the start of every error message."""
        return f"{TYPE_NAMES.get(self.mission_type, self.mission_type)} {self.kind}"

    def __init__(self, mission_type: int, policy: Policy) -> None:
        self.mission_type = mission_type
        self.policy = policy
        self.stats = Stats()
        self.done = False
        self.error: str | None = None
        self._step_deadline = math.inf  # when the current step is resent (or the wait ends)
        self._started = 0.0
        self._end = math.inf  # `_started` + `policy.limit(n)`: the transfer fails then

    @property
    def finished(self) -> bool:
        return self.done or self.error is not None

    @property
    def deadline(self) -> float:
        """When `poll` has something to do next, if nothing arrives before."""
        return math.inf if self.finished else min(self._step_deadline, self._end)

    @property
    def progress(self) -> tuple[int, int]:
        """(items done, items in all) so far, for a progress display."""
        return (0, 0)

    def _limit(self, n: int) -> None:
        self._end = self._started + self.policy.limit(n)

    def _over_time(self, now: float, n: int) -> bool:
        if now < self._end:
            return False
        p = self.policy
        self._fail(f"{self.what} failed: not finished within {p.limit(n):g} s, the limit for {n} item(s) "
                   f"({p.setup:g} s + {p.per_item:g} s per item); the link is too poor or the vehicle too slow")
        return True

    def _fail(self, message: str) -> list[Message]:
        self.error = message
        return []

    def _out(self, msgs: list[Message]) -> list[Message]:
        self.stats.sent += len(msgs)
        return msgs

    def _ours(self, msg: Message) -> bool:
        if self.finished or isinstance(msg, RequestList) or msg_type(msg) != self.mission_type:
            self.stats.ignored += 1
            return False
        return True


def msg_type(msg: Message) -> int:
    return msg.item.mission_type if isinstance(msg, Item) else msg.mission_type


class Uploader(_Machine):
    """Ground-station side of an upload of `items` (seq 0…n-1, in order) of one mission type.

    Success needs a MISSION_ACK(ACCEPTED) after the vehicle has asked for every item of the
    current attempt; an ACCEPTED before that is stale (from an earlier transaction) and is
    ignored, so a partial upload is never reported as done.

    One exception, only with `confirm_by_download`: the vehicle asked for every item, then
    stopped answering or answered our resent last item with ERROR or OPERATION_CANCELLED (it
    is no longer receiving: its ACCEPTED was lost, or it failed on the last item). The machine
    then ends with `stats.ack_lost` set instead of sending all items again, and the caller
    must read the mission back and compare it before calling it uploaded.
    """

    kind = "upload"

    def __init__(self, items: Sequence[WireItem], mission_type: int, policy: Policy,
                 confirm_by_download: bool = False) -> None:
        super().__init__(mission_type, policy)
        self.confirm_by_download = confirm_by_download
        for i, it in enumerate(items):
            if it.seq != i or it.mission_type != mission_type:
                raise ValueError(f"item {i} has seq {it.seq} and mission type {it.mission_type}; "
                                 f"expected seq {i} and mission type {mission_type}")
        self.items = tuple(items)
        self._phase = "idle"
        self._requested: set[int] = set()
        self._last_seq = -1
        self._step_tries = 0
        self._last_progress = 0.0
        self._suspect: int | None = None

    @property
    def confirmed(self) -> int:
        """Items the vehicle has confirmed in this attempt: asking for item k confirms items 0…k-1
        (it stores them in order), its ACCEPTED all of them. Kept in `stats.confirmed`."""
        return self.stats.confirmed

    @property
    def progress(self) -> tuple[int, int]:
        return (self.confirmed, len(self.items))

    def start(self, now: float) -> list[Message]:
        self.stats.restarts = -1
        self._started = now
        self._limit(len(self.items))
        return self._restart(now)

    def _restart(self, now: float) -> list[Message]:
        self.stats.restarts += 1
        self._phase = "count"
        self._requested.clear()
        self.stats.confirmed = 0
        self._last_seq = -1
        self._step_tries = 0
        self._suspect = None
        self._last_progress = now
        self._step_deadline = now + self.policy.timeout
        return self._out([Count(len(self.items), self.mission_type)])

    def _restart_or_fail(self, now: float, why: str) -> list[Message]:
        if self.stats.restarts >= self.policy.restarts:
            return self._fail(f"{self.what} failed: {why}; gave up after {self.stats.restarts} restart(s) of the transaction")
        return self._restart(now)

    def handle(self, msg: Message, now: float) -> list[Message]:
        if not self._ours(msg):
            return []
        if isinstance(msg, Request):
            return self._on_request(msg.seq, now)
        if isinstance(msg, Ack):
            return self._on_ack(msg.result, now)
        self.stats.ignored += 1
        return []

    def _on_request(self, seq: int, now: float) -> list[Message]:
        if self._phase not in ("count", "items") or not 0 <= seq < len(self.items):
            self.stats.ignored += 1
            return []
        self._phase = "items"
        self._suspect = None
        self._step_tries = 0
        if seq in self._requested:
            # answered again, but the step timer keeps running: a vehicle that keeps asking for
            # items we already sent (ours get lost) must still end in a restart, not a loop
            self.stats.duplicate_requests += 1
        else:
            self._requested.add(seq)
            self.stats.confirmed = max(self.stats.confirmed, seq)
            self._last_progress = now
            self._step_deadline = now + self.policy.timeout
        self._last_seq = seq
        return self._out([Item(self.items[seq])])

    def _on_ack(self, result: int, now: float) -> list[Message]:
        if result == ACCEPTED:
            complete = len(self._requested) == len(self.items)
            if (self._phase == "items" and complete) or (self._phase == "count" and not self.items):
                self.done = True
                self.stats.confirmed = len(self.items)
            else:
                self.stats.ignored += 1
            return []
        self.stats.error_acks.append(result)
        if result in (NO_SPACE, DENIED) and self._phase != "items":
            if self._phase != "count":
                self.stats.ignored += 1
                return []
            if self.stats.restarts >= self.policy.restarts:
                why = ("it has no room for them or it has not finished booting" if result == NO_SPACE else
                       "another ground station may be uploading, or the vehicle refuses changes")
                return self._fail(f"{self.what} failed: the vehicle answered {result_name(result)} for "
                                  f"{len(self.items)} items {self.stats.restarts + 1} time(s); {why}")
            self._phase = "wait"
            self._step_deadline = now + self.policy.busy_wait
            return []
        if result == NO_SPACE:
            # the vehicle has already accepted this attempt's count: a stale answer
            self.stats.ignored += 1
            return []
        if result in _SUSPECT:
            # before the first request a resent MISSION_COUNT is already a restart
            if self._phase == "items":
                self._suspect = result
            return []
        if result == INVALID_SEQUENCE:
            self._step_tries = 0  # the vehicle is still in the transfer and will ask again
            return []
        where = f" at item {self._last_seq}" if self._last_seq >= 0 else ""
        return self._fail(f"{self.what} rejected by the vehicle{where}: {result_name(result)}")

    def poll(self, now: float) -> list[Message]:
        if self.finished or now < self.deadline or self._over_time(now, len(self.items)):
            return []
        if self._phase == "wait":
            return self._restart(now)
        stalled = now - self._last_progress >= self.policy.stall
        self._step_tries += 1
        all_asked = self._phase == "items" and len(self._requested) == len(self.items)
        if all_asked and self.confirm_by_download and (
                self._suspect is not None or stalled or self._step_tries > self.policy.retries):
            self.stats.ack_lost = True
            self.done = True
            return []
        if self._suspect is not None:
            return self._restart_or_fail(now, f"the vehicle answered {result_name(self._suspect)} and stopped asking for items")
        if self._phase == "count":
            if self._step_tries > self.policy.retries:
                return self._fail(f"{self.what} failed: no answer to MISSION_COUNT after {self.policy.retries} "
                                  f"resend(s), {self.policy.timeout:g} s each")
            self.stats.resends += 1
            self._step_deadline = now + self.policy.timeout
            return self._out([Count(len(self.items), self.mission_type)])
        if stalled:
            return self._restart_or_fail(now, f"the vehicle asked for nothing new after item {self._last_seq} of "
                                              f"{len(self.items)} for {now - self._last_progress:.1f} s")
        if self._step_tries > self.policy.retries:
            return self._restart_or_fail(now, f"no answer after item {self._last_seq} of {len(self.items)} "
                                              f"to {self.policy.retries} resend(s), {self.policy.timeout:g} s each")
        self.stats.resends += 1
        self._step_deadline = now + self.policy.timeout
        return self._out([Item(self.items[self._last_seq])])


class Downloader(_Machine):
    """Ground-station side of a download: asks for every item in order, then acknowledges.

    It restarts like the Uploader: when `retries` resends of one step (MISSION_REQUEST_LIST or
    the request for the next item) go unanswered, or the vehicle answers with an error and
    nothing follows within one timeout, the transaction starts again with MISSION_REQUEST_LIST.
    Unlike an upload it keeps what it has: when the vehicle reports the same count again the
    requests go on from the first missing item (a different count starts from item 0). Any
    number of restarts may follow new items; `policy.restarts` in a row without a new item end
    the download. `expected` (the number of items uploaded) sizes the time limit; without it
    the vehicle's count does.
    """

    kind = "download"

    def __init__(self, mission_type: int, policy: Policy, expected: int | None = None) -> None:
        super().__init__(mission_type, policy)
        self.expected = expected
        self.count: int | None = None  # the vehicle's count, once it has said it
        self.items: list[WireItem | None] = []
        self._phase = "idle"
        self._next = 0
        self._step_tries = 0
        self._suspect: int | None = None
        self._mark = 0  # the most items held at any restart: a restart that adds none to it is idle
        self._idle_restarts = 0

    @property
    def progress(self) -> tuple[int, int]:
        return (self._next, self.count or 0)

    def result(self) -> list[WireItem]:
        if not self.done:
            raise TransferFailed(self.error or f"{self.what} has not finished")
        return [it for it in self.items if it is not None]

    def start(self, now: float) -> list[Message]:
        self.stats.restarts = -1
        self._started = now
        self._limit(self.expected or 0)
        return self._restart(now)

    def _restart(self, now: float) -> list[Message]:
        self.stats.restarts += 1
        self._phase = "count"
        self._step_tries = 0
        self._suspect = None
        self._step_deadline = now + self.policy.timeout
        return self._out([RequestList(self.mission_type)])

    def _may_restart(self) -> bool:
        """Count a restart against the budget unless items came in since the last one."""
        if self._next > self._mark:
            self._idle_restarts = 0
            self._mark = self._next
        else:
            self._idle_restarts += 1
        return self._idle_restarts <= self.policy.restarts

    def _restart_or_fail(self, now: float, why: str) -> list[Message]:
        if not self._may_restart():
            return self._fail(f"{self.what} failed: {why}; gave up after {self.policy.restarts} restart(s) in a row "
                              f"that brought no new item ({self._next} of {self.count if self.count is not None else '?'} "
                              "items read)")
        return self._restart(now)

    def _request_next(self, now: float) -> list[Message]:
        self._step_tries = 0
        self._suspect = None
        self._step_deadline = now + self.policy.timeout
        return self._out([Request(self._next, self.mission_type)])

    def handle(self, msg: Message, now: float) -> list[Message]:
        if not self._ours(msg):
            return []
        if isinstance(msg, Count) and self._phase == "count":
            if msg.count != self.count:  # first answer, or the vehicle's mission changed: from item 0
                self.count = msg.count
                self.items = [None] * msg.count
                self._next = 0
                if self.expected is None:
                    self._limit(msg.count)
            self._phase = "items"
            if self._next == msg.count:
                return self._finish()
            return self._request_next(now)
        if isinstance(msg, Item) and self._phase == "items" and msg.item.seq == self._next:
            self.items[self._next] = msg.item
            self._next += 1
            if self._next == len(self.items):
                return self._finish()
            return self._request_next(now)
        if isinstance(msg, Ack) and msg.result == DENIED and self._phase in ("count", "items"):
            # the vehicle is still receiving an upload (a late copy of our MISSION_COUNT can
            # start one): wait for it to give that up, then start again
            self.stats.error_acks.append(msg.result)
            if not self._may_restart():
                return self._fail(f"{self.what} failed: the vehicle answered MAV_MISSION_DENIED {self._idle_restarts} "
                                  "time(s); it is busy with another transfer")
            self._phase = "wait"
            self._step_deadline = now + self.policy.busy_wait
            return []
        if isinstance(msg, Ack) and msg.result != ACCEPTED and self._phase in ("count", "items"):
            # may be a late answer to an earlier transfer: act on it only if nothing follows
            self.stats.error_acks.append(msg.result)
            self._suspect = msg.result
            return []
        self.stats.ignored += 1
        return []

    def _finish(self) -> list[Message]:
        self.done = True
        return self._out([Ack(ACCEPTED, self.mission_type)])

    def poll(self, now: float) -> list[Message]:
        if self.finished or now < self.deadline:
            return []
        if self._over_time(now, self.expected if self.expected is not None else self.count or 0):
            return []
        if self._phase == "wait":
            return self._restart(now)
        if self._suspect is not None:
            return self._restart_or_fail(now, f"the vehicle answered {result_name(self._suspect)}")
        self._step_tries += 1
        if self._step_tries > self.policy.retries:
            step = "MISSION_REQUEST_LIST" if self._phase == "count" else f"MISSION_REQUEST_INT for item {self._next}"
            return self._restart_or_fail(now, f"no answer to {step} after {self.policy.retries} resend(s), "
                                              f"{self.policy.timeout:g} s each")
        self.stats.resends += 1
        self._step_deadline = now + self.policy.timeout
        if self._phase == "count":
            return self._out([RequestList(self.mission_type)])
        return self._out([Request(self._next, self.mission_type)])
