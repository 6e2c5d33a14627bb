"""The MAVLink mission protocol as pure state machines: no sockets, no clock of their own.

A machine is told what arrived (`handle`) and what time it is (`poll`); it answers with
the messages to send next. Keeping time and I/O outside makes every retry, restart and
stale-packet decision testable with a simulated clock and a lossy simulated link.

Upload (ground station side): MISSION_COUNT → the vehicle asks for each item with
MISSION_REQUEST_INT (or legacy MISSION_REQUEST) → we answer MISSION_ITEM_INT → the vehicle
ends with MISSION_ACK. Download: MISSION_REQUEST_LIST → MISSION_COUNT → MISSION_REQUEST_INT
per item → MISSION_ITEM_INT → we end with MISSION_ACK.

Both sides follow the same rules: a step is resent when its answer is late by the resend
timer (`ResendTimer`: it adapts to the round trips measured on the link as TCP's
retransmission timer does, RFC 6298), silence from the vehicle for `Policy.silence` restarts
the transaction, restarts are bounded, and every transfer ends within `Policy.limit(n)`
seconds whatever the vehicle does.

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
# expired; PX4 (mavlink_mission.cpp) sends ERROR for a MISSION_COUNT while it is receiving. None
# of them alone proves the transfer failed (it may be a late copy), so the machine keeps resending
# for `Policy.timeout` and restarts the transaction when no request comes by then.
# INVALID_SEQUENCE is different: ArduPilot sends it for a duplicated or late item while it keeps
# receiving and re-requesting the item it wants (also for the item of a resent pair it did not
# want, see Uploader), so it is counted but needs no action; a vehicle that answers it and never
# asks again is caught by the stall rule, which restarts the transaction. PX4 answers neither:
# it drops an item it did not ask for and asks again after 250 ms.
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

    `timeout`: the resend timer's ceiling; below it the timer follows the round trips
    measured (`ResendTimer`), never shorter than `min_timeout`. `retries`: silence from the
    vehicle for `timeout` × (`retries` + 1) seconds (`silence`) restarts the transaction (or,
    for an upload's first step, gives up). `stall`: seconds an upload may go without the vehicle asking for a new item while it
    still answers (it may be re-requesting at its own pace: ArduPilot asks again after 1 s and
    cancels after 8 s) before it is restarted. `restarts`: an upload's whole-transaction
    restarts (each sends every item again); a download keeps the items it has and may restart
    any number of times as long as each restart follows a new item, but no more than
    `restarts` times in a row without one. `busy_wait`: pause before restarting after
    MAV_MISSION_NO_SPACE (ArduPilot sends it right after boot) or MAV_MISSION_DENIED (the
    vehicle is still busy with another transfer), so that 3 restarts span ArduPilot's 8 s
    upload timeout. `item_time`: the average seconds per item a whole transfer may take
    (None: the larger of 5 s and 5 timeouts); see `limit`.
    """

    timeout: float = 1.0
    retries: int = 5
    restarts: int = 3
    busy_wait: float = 3.0
    stall: float = 10.0
    item_time: float | None = None
    min_timeout: float = 0.01

    def __post_init__(self) -> None:
        if not (self.timeout > 0 and math.isfinite(self.timeout)):
            raise ValueError(f"timeout must be a positive number of seconds, got {self.timeout!r}")
        if not 0 < self.min_timeout <= self.timeout:
            raise ValueError(f"min_timeout must be positive and at most timeout ({self.timeout!r}), got {self.min_timeout!r}")
        if self.retries < 0 or self.restarts < 0 or self.busy_wait < 0 or not self.stall > 0:
            raise ValueError("retries, restarts and busy_wait must not be negative, stall must be positive")
        if self.item_time is not None and not (self.item_time > 0 and math.isfinite(self.item_time)):
            raise ValueError(f"item_time must be a positive number of seconds, got {self.item_time!r}")

    @property
    def silence(self) -> float:
        """Seconds without a word from the vehicle that end a step: `timeout` × (`retries` + 1)."""
        return self.timeout * (self.retries + 1)

    @property
    def per_item(self) -> float:
        """Average seconds per item a transfer may take: `item_time`, by default max(5 s, 5 timeouts)."""
        return self.item_time if self.item_time is not None else max(5.0, 5.0 * self.timeout)

    @property
    def setup(self) -> float:
        """The part of `limit` that does not grow with the items: each allowed restart may wait
        `busy_wait`, stay silent for `silence` and stall for `stall`, one timeout more."""
        return (self.restarts + 1) * (self.busy_wait + self.silence + self.timeout + self.stall)

    def limit(self, n: int) -> float:
        """Seconds a transfer of `n` items may take in all: `setup` + n × `per_item`.

        The machines fail a transfer that has not ended by then, whatever the vehicle does
        (one that answers just often enough never to trip the other rules included); the
        resend, silence and restart rules decide long before it on any link that is merely lossy.
        """
        return self.setup + n * self.per_item


#: Resends of one step that wait one timer each before the waits double (see ResendTimer)
FLAT_RESENDS = 3
#: The timer before any round trip was measured: the MAVLink mission protocol's recommended
#: timeout for mission items (within Policy.min_timeout and Policy.timeout)
FIRST_TIMEOUT = 0.25
#: The waits of a step double up to this many times the timer (or up to FIRST_TIMEOUT when that
#: is longer), never beyond Policy.timeout: see ResendTimer
BACKOFF_CEILING = 4.0


class ResendTimer:
    """When to resend: RFC 6298's retransmission timer, fed with the times the machines are given.

    Each round trip measured updates the smoothed round trip SRTT and its variation RTTVAR
    (α = 1/8, β = 1/4); the timer is SRTT + max(G, 4·RTTVAR) with G = `policy.min_timeout`, kept
    between `min_timeout` and `timeout`, and `FIRST_TIMEOUT` before the first measurement (RFC
    6298 starts at 1 s; the mission protocol recommends 250 ms for items, and the vehicle
    answers MISSION_COUNT as fast as an item: at 30 % loss each way the first step then gets
    about ten tries, not six, before `Policy.silence` gives it up). A round
    trip is measured on a step sent once; on a step sent again (Karn's rule: which copy was
    answered is not known) only when the answer came a whole timer or more after the last
    copy, which proves the round trip is at least that long (so a link that got slower is
    followed). Backing off: the first `FLAT_RESENDS` resends of a step wait one timer each (on
    a lossy radio a lost packet is most often just lost: at 30 % loss each way half the
    exchanges fail, and doubling from the first resend costs as much again as the losses), each
    further one twice the one before, up to `BACKOFF_CEILING` timers (or `FIRST_TIMEOUT`, when that
    is longer) and never beyond `timeout`. The ceiling bounds the tail on a lossy link whose
    round trips are short: there one exchange in 30 fails five times in a row at 30 % loss each way,
    and waits doubled to a whole second made those exchanges cost seconds each and left so few
    tries within `Policy.silence` that a transfer restarted (from item 0, for a PX4 read-back).
    A vehicle slower than the timer is still followed: its late answers are measured (below).
    One timer is shared by the transfers on one link.
    """

    def __init__(self, policy: Policy) -> None:
        self.policy = policy
        self.srtt: float | None = None
        self.rttvar = 0.0
        self.samples = 0

    def measured(self, rtt: float) -> None:
        rtt = max(rtt, 0.0)
        if self.srtt is None:
            self.srtt, self.rttvar = rtt, rtt / 2
        else:
            self.rttvar = 0.75 * self.rttvar + 0.25 * abs(self.srtt - rtt)
            self.srtt = 0.875 * self.srtt + 0.125 * rtt
        self.samples += 1

    @property
    def base(self) -> float:
        """The timer of a step's first wait."""
        p = self.policy
        wanted = FIRST_TIMEOUT if self.srtt is None else self.srtt + max(p.min_timeout, 4.0 * self.rttvar)
        return min(p.timeout, max(p.min_timeout, wanted))

    def value(self, resends: int) -> float:
        """The wait after a step's `resends`-th resend (0: after sending it the first time)."""
        base = self.base
        ceiling = min(self.policy.timeout, max(BACKOFF_CEILING * base, FIRST_TIMEOUT))
        return min(ceiling, base * 2.0 ** max(0, resends - FLAT_RESENDS))

    def answered(self, resends: int, first_sent: float, last_sent: float, now: float, late: bool = True) -> None:
        """A step sent 1 + `resends` times (first and last at the times given) was answered `now`;
        `late`: a resent step answered a whole timer after its last copy is measured (not when the
        vehicle also asks on its own timer, see Uploader)."""
        if resends == 0:
            self.measured(now - first_sent)
        elif late and now - last_sent >= self.base:
            self.measured(now - last_sent)


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
    most_confirmed: int = 0  # upload: the most it confirmed in any attempt (an ArduPilot keeps them: it writes in place)


class TransferFailed(Exception):
    """The transfer ended without success; the message says which step and why."""


class _Machine:
    """Shared bookkeeping: state, deadlines, the resend timer and outcome of one transfer."""

    kind = "transfer"
    #: whether a resent step answered long after its last copy is a round trip (ResendTimer.answered)
    measure_late = True

    @property
    def what(self) -> str:
        """E.g. "fence upload": the start of every error message."""
        return f"{TYPE_NAMES.get(self.mission_type, self.mission_type)} {self.kind}"

    def __init__(self, mission_type: int, policy: Policy, timer: ResendTimer | None) -> None:
        self.mission_type = mission_type
        self.policy = policy
        self.timer = timer if timer is not None else ResendTimer(policy)
        self.stats = Stats()
        self.done = False
        self.error: str | None = None
        self._step_deadline = math.inf  # when the current step is resent (or the wait ends)
        self._started = 0.0
        self._end = math.inf  # `_started` + `policy.limit(n)`: the transfer fails then
        self._heard = 0.0  # when the vehicle last said something about this transfer (or the step began)
        self._probe: tuple[int, float, float] | None = None  # (step, first sent, last sent) of the step the timer runs for
        self._resends = 0  # of that step

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

    def _ours(self, msg: Message, now: float) -> bool:
        if self.finished or isinstance(msg, RequestList) or msg_type(msg) != self.mission_type:
            self.stats.ignored += 1
            return False
        self._heard = now
        return True

    def _step(self, step: int, now: float) -> None:
        """A new step is sent: arm the timer and remember it for a round-trip measurement."""
        self._probe = (step, now, now)
        self._resends = 0
        self._step_deadline = now + self.timer.value(0)

    def _answered(self, step: int, now: float) -> None:
        """The answer to `step` came: a round trip for the timer, if it tells one."""
        if self._probe is not None and self._probe[0] == step:
            self.timer.answered(self._resends, self._probe[1], self._probe[2], now, self.measure_late)
        self._probe = None

    def _copied(self, now: float) -> None:
        """The step was sent again at the vehicle's own asking (its re-request timer): the answer that
        follows may answer this copy, so it is timed from it, as after a resend (Karn's rule). Timed from
        the copy before, the vehicle's own timer (ArduPilot: 1 s) would be taken for the round trip."""
        if self._probe is not None:
            self._probe = (self._probe[0], self._probe[1], now)
            self._resends = max(self._resends, 1)

    def _resent(self, now: float) -> None:
        self._resends += 1
        if self._probe is not None:
            self._probe = (self._probe[0], self._probe[1], now)
        self.stats.resends += 1
        self._step_deadline = now + self.timer.value(self._resends)

    def _silent(self, now: float) -> bool:
        return now - self._heard >= self.policy.silence

    def _silence_why(self, now: float, step: str) -> str:
        return f"no answer to {step} for {now - self._heard:.1f} s ({self.stats.resends} resend(s) in all)"


def msg_type(msg: Message) -> int:
    return msg.item.mission_type if isinstance(msg, Item) else msg.mission_type


#: Items an upload resends at most when the vehicle's next request is late (see Uploader)
RESEND_WINDOW = 4


class Uploader(_Machine):
    """Ground-station side of an upload of `items` (seq 0…n-1, in order) of one mission type.

    The vehicle drives the upload with its requests; each is answered with the item asked for.
    When the next request is late by the resend timer, the item the vehicle last asked for is
    sent again, followed by the ones after it up to one past the highest sent so far (at most
    `RESEND_WINDOW` items): if the item was lost the vehicle takes it and then the next; if its
    request for the next one was lost (or for the next two: a resend already sent the next
    one) it takes the one it wants. It answers the others with an error ack (ArduPilot:
    MAV_MISSION_INVALID_SEQUENCE; PX4 drops them without a word), which is expected and changes
    nothing. The vehicle stores only the item it wants, in order, so nothing it stores can be
    out of place.

    Success needs a MISSION_ACK(ACCEPTED) once every item of the current attempt has been sent
    (the last one only after the vehicle asked for the one before it); an ACCEPTED before that
    is stale (from an earlier transaction) and is ignored, so a partial upload is never reported
    as done.

    One exception, only with `confirm_by_download`: every item was sent, and then the vehicle
    stopped answering or answered our resent items with ERROR or OPERATION_CANCELLED (it is no
    longer receiving: its ACCEPTED was lost, or it failed on the last item). A resent window may
    have carried the last items before the vehicle asked for them, so the vehicle may also hold
    less; the read-back that must follow counts and compares every item either way. The machine then
    ends with `stats.ack_lost` set instead of sending all items again, and the caller must read
    the mission back and compare it before calling it uploaded.
    """

    kind = "upload"
    # the vehicle asks again on its own timer (ArduPilot after 1 s, PX4 after 250 ms): a request that
    # comes long after our last copy may answer a copy lost long before, so it tells no round trip
    # (taken for one, a single such request on a 4 ms link set the timer to 0.9 s for dozens of items)
    measure_late = False

    def __init__(self, items: Sequence[WireItem], mission_type: int, policy: Policy,
                 confirm_by_download: bool = False, timer: ResendTimer | None = None) -> None:
        super().__init__(mission_type, policy, timer)
        self.confirm_by_download = confirm_by_download
        for i, it in enumerate(items):
            if it.seq != i or it.mission_type != mission_type:
                raise ValueError(f"item {i} has seq {it.seq} and mission type {it.mission_type}; "
                                 f"expected seq {i} and mission type {mission_type}")
        self.items = tuple(items)
        self._phase = "idle"
        self._asked = -1  # the highest item the vehicle asked for in this attempt
        self._sent_top = -1  # the highest item sent in this attempt
        self._last_progress = 0.0
        self._suspect: tuple[int, float] | None = None  # (error ack, when) that may mean the vehicle left the transfer

    @property
    def confirmed(self) -> int:
        """Items the vehicle has confirmed in this attempt: asking for item k confirms items 0…k-1
        (it stores them in order), its ACCEPTED all of them. Kept in `stats.confirmed`."""
        return self.stats.confirmed

    @property
    def progress(self) -> tuple[int, int]:
        return (self.confirmed, len(self.items))

    @property
    def _all_sent(self) -> bool:
        return self._phase == "items" and self._sent_top == len(self.items) - 1

    def start(self, now: float) -> list[Message]:
        self.stats.restarts = -1
        self._started = now
        self._limit(len(self.items))
        return self._restart(now)

    def _restart(self, now: float) -> list[Message]:
        self.stats.restarts += 1
        self._phase = "count"
        self.stats.confirmed = 0
        self._asked = self._sent_top = -1
        self._suspect = None
        self._last_progress = self._heard = now
        self._step(-1, now)
        return self._out([Count(len(self.items), self.mission_type)])

    def _restart_or_fail(self, now: float, why: str) -> list[Message]:
        if self.stats.restarts >= self.policy.restarts:
            return self._fail(f"{self.what} failed: {why}; gave up after {self.stats.restarts} restart(s) of the transaction")
        return self._restart(now)

    def _send(self, seqs: Sequence[int] | range) -> list[Message]:
        self._sent_top = max(self._sent_top, *seqs)
        return self._out([Item(self.items[s]) for s in seqs])

    def handle(self, msg: Message, now: float) -> list[Message]:
        if not self._ours(msg, now):
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
        if seq <= self._asked:
            # asked again (its re-request timer, or a copy): answered, but the step timer keeps
            # running, so a vehicle that keeps asking for items we already sent still ends in a restart
            self.stats.duplicate_requests += 1
            if seq == self._asked:
                self._copied(now)
            return self._send([seq])
        self._answered(seq - 1, now)
        self._asked = seq
        self.stats.confirmed = seq  # above every seq asked before in this attempt
        self.stats.most_confirmed = max(self.stats.most_confirmed, seq)
        self._last_progress = now
        self._step(seq, now)
        return self._send([seq])

    def _on_ack(self, result: int, now: float) -> list[Message]:
        if result == ACCEPTED:
            if self._all_sent or (self._phase == "count" and not self.items):
                self.done = True
                self.stats.confirmed = self.stats.most_confirmed = len(self.items)
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
            if self._phase == "items" and self._suspect is None:
                self._suspect = (result, now)
            return []
        if result == INVALID_SEQUENCE:
            return []  # the answer to an item the vehicle did not want (see the class): expected
        where = f" at item {self._asked}" if self._asked >= 0 else ""
        return self._fail(f"{self.what} rejected by the vehicle{where}: {result_name(result)}")

    def poll(self, now: float) -> list[Message]:
        if self.finished or now < self.deadline or self._over_time(now, len(self.items)):
            return []
        if self._phase == "wait":
            return self._restart(now)
        stalled = now - self._last_progress >= self.policy.stall
        silent = self._silent(now)
        if self._all_sent and self.confirm_by_download and (self._suspect is not None or stalled or silent):
            self.stats.ack_lost = True
            self.done = True
            return []
        if self._suspect is not None and now - self._suspect[1] >= self.policy.timeout:
            return self._restart_or_fail(now, f"the vehicle answered {result_name(self._suspect[0])} and stopped asking for items")
        if self._phase == "count":
            if silent:
                return self._fail(f"{self.what} failed: {self._silence_why(now, 'MISSION_COUNT')}")
            self._resent(now)
            return self._out([Count(len(self.items), self.mission_type)])
        if stalled:
            return self._restart_or_fail(now, f"the vehicle asked for nothing new after item {self._asked} of "
                                              f"{len(self.items)} for {now - self._last_progress:.1f} s")
        if silent:
            return self._restart_or_fail(now, self._silence_why(now, f"item {self._asked} of {len(self.items)}"))
        self._resent(now)
        return self._send(self._window())

    def _window(self) -> range:
        """The items a late request resends (see the class): from the one last asked for, up to one
        past the highest sent, at most RESEND_WINDOW of them; when that span is longer, every other
        resend sends its top instead (the vehicle may have stored items of earlier windows whose
        requests were lost, and want the one after them), never more than two windows past the
        item last asked for."""
        top = min(len(self.items) - 1, self._sent_top + 1, self._asked + 2 * RESEND_WINDOW - 1)
        if top - self._asked < RESEND_WINDOW or self._resends % 2 == 1:
            return range(self._asked, min(top, self._asked + RESEND_WINDOW - 1) + 1)
        return range(top - RESEND_WINDOW + 1, top + 1)


class Downloader(_Machine):
    """Ground-station side of a download: asks for every item in order, then acknowledges.

    A request whose item is late by the resend timer is sent again. The transaction restarts
    (MISSION_REQUEST_LIST again) when the vehicle says nothing for `policy.silence`, or answers
    with an error and nothing follows within one timer. With `resume` (ArduPilot answers any
    request) it keeps what it has: when the vehicle reports the same count again the requests go
    on from the first missing item (a different count starts from item 0); without it (PX4
    answers only the next item of a transfer, or the one before) every restart asks again from
    item 0. Any number of restarts may follow new items; `policy.restarts` in a row without a
    new item end the download. `expected` (the number of items uploaded) sizes the time limit;
    without it the vehicle's count does.
    """

    kind = "download"

    def __init__(self, mission_type: int, policy: Policy, expected: int | None = None, timer: ResendTimer | None = None,
                 resume: bool = True) -> None:
        super().__init__(mission_type, policy, timer)
        self.expected = expected
        self.resume = resume
        self.count: int | None = None  # the vehicle's count, once it has said it
        self.items: list[WireItem | None] = []
        self._phase = "idle"
        self._next = 0
        self._got = 0  # items held (the first `_got` of them)
        self._suspect: tuple[int, float] | None = None  # (error ack, when): restart if nothing follows
        self._mark = 0  # the most items held at any restart: a restart that adds none to it is idle
        self._idle_restarts = 0

    @property
    def progress(self) -> tuple[int, int]:
        return (self._got, self.count or 0)

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
        self._suspect = None
        self._heard = now
        self._step(-1, now)
        return self._out([RequestList(self.mission_type)])

    def _may_restart(self) -> bool:
        """Count a restart against the budget unless items came in since the last one."""
        if self._got > self._mark:
            self._idle_restarts = 0
            self._mark = self._got
        else:
            self._idle_restarts += 1
        return self._idle_restarts <= self.policy.restarts

    def _restart_or_fail(self, now: float, why: str) -> list[Message]:
        if not self._may_restart():
            return self._fail(f"{self.what} failed: {why}; gave up after {self.policy.restarts} restart(s) in a row "
                              f"that brought no new item ({self._got} of {self.count if self.count is not None else '?'} "
                              "items read)")
        return self._restart(now)

    def _request_next(self, now: float) -> list[Message]:
        self._suspect = None
        self._step(self._next, now)
        return self._out([Request(self._next, self.mission_type)])

    def handle(self, msg: Message, now: float) -> list[Message]:
        if not self._ours(msg, now):
            return []
        if isinstance(msg, Count) and self._phase == "count":
            self._answered(-1, now)
            if msg.count != self.count:  # first answer, or the vehicle's mission changed: from item 0
                self.count = msg.count
                self.items = [None] * msg.count
                self._got = 0
                if self.expected is None:
                    self._limit(msg.count)
            self._next = self._got if self.resume else 0
            self._phase = "items"
            if self._got == msg.count:
                return self._finish()
            return self._request_next(now)
        if isinstance(msg, Item) and self._phase == "items" and msg.item.seq == self._next:
            self._answered(self._next, now)
            self.items[self._next] = msg.item
            self._next += 1
            self._got = max(self._got, self._next)
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
            if self._suspect is None:
                self._suspect = (msg.result, now)
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
        if self._suspect is not None and now - self._suspect[1] >= self.policy.timeout:
            return self._restart_or_fail(now, f"the vehicle answered {result_name(self._suspect[0])}")
        step = "MISSION_REQUEST_LIST" if self._phase == "count" else f"MISSION_REQUEST_INT for item {self._next}"
        if self._silent(now):
            return self._restart_or_fail(now, self._silence_why(now, step))
        self._resent(now)
        if self._phase == "count":
            return self._out([RequestList(self.mission_type)])
        return self._out([Request(self._next, self.mission_type)])
