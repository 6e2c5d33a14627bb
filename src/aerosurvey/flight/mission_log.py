"""The mission a vehicle was given, as its flight log records it: one reader per log kind.

- DataFlash (ArduPilot): CMD messages (CTot, CNum, CId, Prm1..4, Lat, Lng, Alt, Frame: the
  item as ArduPilot stored it, rebuilt by AP_Mission::mission_cmd_to_mavlink_int). ArduPilot
  writes every item of its mission at each log start and again after each completed upload
  (AP_Logger::Write_EntireMission), and one item each time the mission starts it. A run of
  CMD messages numbered 0, 1, … with one CTot is one mission as the vehicle held it.
- Telemetry log (.tlog): a MISSION_COUNT followed by the MISSION_ITEM_INT (or MISSION_ITEM)
  messages of that transfer, an upload to the vehicle or a download from it, whichever the log
  holds; a transfer that stops short is a partial upload (or download).
- ULog (PX4): PX4 logs no list of its mission items. Its navigator publishes each item as it
  makes it current (navigator_mission_item: sequence, command, latitude and longitude as
  float32 degrees, altitude, frame, and parameters 1-4 of an item without a position), so a
  ULog holds the items flown, not those uploaded; mission_result's seq_total gives the count.

Each reader returns the missions recorded up to the log's first camera event, the last of
them (the one flown) first, and those recorded after it (changed during the flight) in log
order. Items are MAVLink wire items (`mission_protocol.WireItem`): positions in 1e-7 degrees,
a parameter the log does not record NaN, a frame it does not record -1.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aerosurvey.errors import InputError
from aerosurvey.flight.dataflash import DataFlashLog
from aerosurvey.flight.events import _longest_increasing, log_kind, tlog_messages
from aerosurvey.link import mission_protocol as mp
from aerosurvey.mission import mavlink_ids as mav

#: the frame of an item whose log does not record it
NO_FRAME = -1
#: the ULog topic of the items PX4's navigator made current (`from_ulog`'s source)
ULOG_SOURCE = "navigator_mission_item"


@dataclass(frozen=True)
class LoggedMission:
    """One mission as the log records it."""

    at: str  # where the log records it ("12.345 s", "message 1234")
    total: int  # items the vehicle said the mission holds
    items: tuple[mp.WireItem, ...]  # the items recorded, in sequence order

    @property
    def complete(self) -> bool:
        """Every item 0 … total-1 is recorded."""
        return len(self.items) == self.total and all(it.seq == k for k, it in enumerate(self.items))


@dataclass(frozen=True)
class MissionRecord:
    """What a flight log records of the mission its vehicle was given."""

    source: str  # the log messages read (CMD, MISSION_ITEM_INT, navigator_mission_item); "" when none
    autopilot: str  # "ardupilot", "px4", or "" when the log does not say: whose storage rules the items went through
    stored: bool  # the items are as the autopilot stored them (its own log); False: as sent (a telemetry log's upload)
    flown: LoggedMission | None  # the mission recorded last before the first camera event (or the first one recorded)
    later: tuple[LoggedMission, ...]  # missions recorded after the first camera event, in log order
    superseded: int  # missions recorded before the flown one (replaced before the first photo)
    note: str  # what the log records and what it does not


def _group(items: Iterable[mp.WireItem], at: str, total: int) -> LoggedMission:
    """A mission of the items recorded (each sequence number once: the last record of it)."""
    by_seq = {it.seq: it for it in items}
    return LoggedMission(at, max(total, max(by_seq, default=-1) + 1), tuple(by_seq[k] for k in sorted(by_seq)))


def _split_at_first_photo(missions: list[tuple[float, LoggedMission]], first_photo: float) -> \
        tuple[LoggedMission | None, tuple[LoggedMission, ...], int]:
    """(the mission flown, those after the first photo, how many before it were superseded):
    `missions` are (position in the log, mission) in log order."""
    if not missions:
        return None, (), 0
    before = [m for pos, m in missions if pos <= first_photo]
    after = tuple(m for pos, m in missions if pos > first_photo)
    if not before:  # no mission before the first photo: the first one recorded is taken as flown
        return after[0], after[1:], 0
    return before[-1], after, len(before) - 1


def _none(autopilot: str, why: str) -> MissionRecord:
    return MissionRecord("", autopilot, True, None, (), 0, why)


# ---- DataFlash --------------------------------------------------------------------------------------


def from_dataflash(path: Path) -> MissionRecord:
    """The missions of an ArduPilot DataFlash log's CMD messages (see the module's docstring)."""
    with DataFlashLog(path) as log:
        cmd = log.messages("CMD")
        offs = log.message_offsets("CMD")
        rep = log.repeated("CMD")
        cams = [log.message_offsets(name) for name in ("CAM", "TRIG")]
    if not cmd or "CNum" not in cmd or "CId" not in cmd:
        return _none("ardupilot", f"{path.name} has no CMD messages: the log records no mission (ArduPilot writes "
                                      "them with LOG_BITMASK's CMD bit)")
    n = len(offs)
    first_photo = float(min((int(c[0]) for c in cams if len(c)), default=math.inf))
    clock = ("TimeUS", 1e-6) if "TimeUS" in cmd else ("TimeMS", 1e-3) if "TimeMS" in cmd else None

    def col(name: str, default: float) -> np.ndarray:
        return np.asarray(cmd[name], float) if name in cmd else np.full(n, default)

    tot, num, cid = col("CTot", 0), col("CNum", 0), col("CId", 0)
    p = [col(f"Prm{k}", math.nan) for k in range(1, 5)]
    lat, lon, alt = col("Lat", 0.0), col("Lng", 0.0), col("Alt", math.nan)
    frame = col("Frame", NO_FRAME)
    rows = [i for i in range(n) if rep[i] < 0]  # a copied chunk repeats messages byte for byte: each once

    def item(i: int) -> mp.WireItem:
        return mp.WireItem(int(num[i]), int(cid[i]), int(frame[i]), float(p[0][i]), float(p[1][i]), float(p[2][i]),
                           float(p[3][i]), round(float(lat[i]) * 1e7), round(float(lon[i]) * 1e7), float(alt[i]))

    def where(i: int) -> str:
        return f"{float(cmd[clock[0]][i]) * clock[1]:.3f} s" if clock else f"byte {int(offs[i])}"

    # a write of the whole mission: CNum 0, 1, 2 … under one CTot, up to the next CNum 0: the longest run
    # of increasing numbers there. The items the mission starts meanwhile (it starts at arming, while the
    # log's start is still being written) fall between its messages and are left out of it, as is a
    # damaged number; damage that took messages leaves the write fewer than CTot items
    starts = [k for k, i in enumerate(rows) if num[i] == 0]
    writes: list[tuple[float, LoggedMission]] = []
    taken: set[int] = set()
    for s, k0 in enumerate(starts):
        first = rows[k0]
        seg = [i for i in rows[k0:starts[s + 1] if s + 1 < len(starts) else len(rows)]
               if tot[i] == tot[first] and num[i] < max(tot[first], 1)]
        run = [i for i, keep in zip(seg, _longest_increasing(num[seg])) if keep]
        taken.update(run)
        writes.append((float(offs[first]), _group([item(r) for r in run], where(first), int(tot[first]))))
    single = [i for i in rows if i not in taken]
    # the same mission written again (each log start writes it) is one mission
    distinct = [w for q, w in enumerate(writes) if q == 0 or w[1].items != writes[q - 1][1].items]
    note = "CMD messages: the mission ArduPilot held at the log's start and after each upload (home is item 0)"
    if not distinct:  # only the items the mission started: the log began after the last write
        distinct = [(float(offs[single[0]]), _group([item(i) for i in single], where(single[0]), int(tot[single[0]])))]
        note = ("CMD messages of the items the mission started only (no write of the whole mission): items never "
                "started are not recorded")
    flown, later, superseded = _split_at_first_photo(distinct, first_photo)
    return MissionRecord("CMD", "ardupilot", True, flown, later, superseded, note)


# ---- telemetry log ----------------------------------------------------------------------------------


#: MAV_AUTOPILOT numbers of the two autopilots whose storage rules are known, and of a ground station
_AUTOPILOTS = {3: "ardupilot", 12: "px4"}
_AUTOPILOT_INVALID = 8


def _wire(m: Any) -> mp.WireItem:
    """A MISSION_ITEM_INT, or a MISSION_ITEM (float degrees), as a wire item."""
    if m.get_type() == "MISSION_ITEM_INT":
        x, y = int(m.x), int(m.y)
    else:
        x, y = (round(float(v) * 1e7) if math.isfinite(v) else 0 for v in (m.x, m.y))
    return mp.WireItem(int(m.seq), int(m.command), int(m.frame), float(m.param1), float(m.param2), float(m.param3),
                       float(m.param4), x, y, float(m.z), int(m.autocontinue))


def from_tlog(path: Path) -> MissionRecord:
    """The mission transfers of a MAVLink telemetry log (see the module's docstring)."""
    msgs = tlog_messages(path)
    autopilot = next((_AUTOPILOTS.get(int(m.autopilot), "") for m in msgs
                      if m.get_type() == "HEARTBEAT" and int(m.autopilot) != _AUTOPILOT_INVALID), "")
    first_photo = float(next((k for k, m in enumerate(msgs) if m.get_type() == "CAMERA_FEEDBACK"), math.inf))
    transfers: list[tuple[float, int, list[mp.WireItem]]] = []  # (message index, count, items)
    for k, m in enumerate(msgs):
        kind = m.get_type()
        if getattr(m, "mission_type", mp.MISSION) != mp.MISSION:
            continue
        if kind == "MISSION_COUNT":
            transfers.append((float(k), int(m.count), []))
        elif kind in ("MISSION_ITEM_INT", "MISSION_ITEM") and transfers and int(m.seq) < transfers[-1][1]:
            transfers[-1][2].append(_wire(m))
    if not transfers:
        return _none(autopilot, f"{path.name} holds no MISSION_COUNT: the telemetry log records no mission transfer")
    missions = [(pos, _group(items, f"message {int(pos) + 1}", count)) for pos, count, items in transfers]
    partial = sum(not m.complete for _, m in missions)
    flown, later, superseded = _split_at_first_photo(missions, first_photo)
    note = "MISSION_COUNT and MISSION_ITEM(_INT) messages: the mission transfers (uploads and downloads) the log holds"
    if partial:
        note += f"; {partial} of them stop short of their count (a partial upload or download)"
    return MissionRecord("MISSION_ITEM_INT", autopilot, False, flown, later, superseded, note)


# ---- ULog -------------------------------------------------------------------------------------------


def _ulog_items(d: dict[str, np.ndarray]) -> list[tuple[float, mp.WireItem]]:
    """(time, item) of each navigator_mission_item record. An item without a position (frame 2,
    MAV_FRAME_MISSION) holds its parameters 1-4 in time_inside, acceptance_radius, loiter_radius
    and yaw (PX4's mission_item_s shares them in a union) and parameter 7 in altitude; one with a
    position its latitude, longitude and altitude (relative to home when altitude_is_relative),
    and parameters PX4 has changed (yaw in radians, defaults): they are not taken."""
    n = len(d["timestamp"])

    def col(name: str, default: float) -> np.ndarray:
        return np.asarray(d[name], float) if name in d else np.full(n, default)

    seq, cmd = col("sequence_current", -1), col("nav_cmd", -1)
    lat, lon, alt = col("latitude", 0.0), col("longitude", 0.0), col("altitude", math.nan)
    params = [col(name, math.nan) for name in ("time_inside", "acceptance_radius", "loiter_radius", "yaw")]
    rel, frame = col("altitude_is_relative", math.nan), col("frame", math.nan)
    out = []
    for i in range(n):
        f = int(frame[i]) if math.isfinite(frame[i]) else (3 if rel[i] == 1 else 0 if rel[i] == 0 else NO_FRAME)
        if f == mav.FRAME_MISSION:
            p1, p2, p3, p4 = (float(p[i]) for p in params)
            x = y = 0
        else:
            p1 = p2 = p3 = p4 = math.nan
            x, y = (round(float(v) * 1e7) if math.isfinite(v) else 0 for v in (lat[i], lon[i]))
        out.append((float(d["timestamp"][i]), mp.WireItem(int(seq[i]), int(cmd[i]), f, p1, p2, p3, p4, x, y, float(alt[i]))))
    return out


def from_ulog(path: Path) -> MissionRecord:
    """The mission items a PX4 ULog records (see the module's docstring)."""
    from pyulog import ULog

    try:
        u = ULog(str(path), ["navigator_mission_item", "mission_result", "camera_capture"])
    except Exception as exc:  # pyulog raises plain exceptions for files it cannot parse
        raise InputError(f"{path.name}: not a readable ULog ({exc})") from None
    data = {d.name: d.data for d in u.data_list}
    nav = data.get("navigator_mission_item")
    if nav is None or not len(nav["timestamp"]):
        return _none("px4", f"{path.name} has no navigator_mission_item topic: the ULog records no mission item "
                                "(PX4 logs no list of its mission; its navigator logs each item as it flies it)")
    cams = data.get("camera_capture")
    first_photo = float(cams["timestamp"][0]) if cams is not None and len(cams["timestamp"]) else math.inf
    result = data.get("mission_result")
    total = int(np.max(result["seq_total"])) if result is not None and "seq_total" in result else 0
    recs = _ulog_items(nav)
    # older PX4 counts its mission's changes in instance_count: each count is one mission
    counts = np.asarray(nav["instance_count"], int) if "instance_count" in nav else np.zeros(len(recs), int)
    missions = []
    for c in dict.fromkeys(counts.tolist()):
        part = [r for r, k in zip(recs, counts) if k == c]
        missions.append((part[0][0], _group([it for _, it in part], f"{part[0][0] / 1e6:.3f} s", total)))
    flown, later, superseded = _split_at_first_photo(missions, first_photo)
    note = ("navigator_mission_item: the items PX4's navigator made current, not the mission uploaded (items never "
            "reached are not recorded); positions as float32 degrees, the parameters 1-4 of items with a position not "
            "recorded")
    return MissionRecord(ULOG_SOURCE, "px4", True, flown, later, superseded, note)


def read_mission(path: Path) -> MissionRecord:
    """The mission a flight log records, by the log's kind (`events.log_kind`)."""
    return {"dataflash": from_dataflash, "tlog": from_tlog, "ulog": from_ulog}[log_kind(path)](path)
