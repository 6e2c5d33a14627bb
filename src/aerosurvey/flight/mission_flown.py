"""The mission a flight log records against the plan's missions: which one was flown, and how it differs.

Pure: the plan's missions (each sortie's, or the whole mission's, as `aerosurvey plan` wrote
them) and the log's items (`mission_log.MissionRecord`) in, plain data out. Items are compared
by meaning, as the autopilot keeps them: the plan's go through the autopilot's storage rules
(`link.upload.ardupilot_stored`, `px4_stored`: fields it does not keep are not compared), and
so do the log's when it holds them as sent (a telemetry log's upload); then the command must
be the same, a position within POSITION_TOL_M, an altitude within ALT_TOL_M
and the parameters within float32's rounding. The two lists are aligned (difflib on the items
in context, then each stretch that differs item by item: `_stretch`) so that an item added or
left out shows as that item, not as every item after it.

What names the flight: the plan's survey waypoints (items tagged with a line, run or station
id: the lead-ins, line starts, stations and line ends the photos depend on). A log whose
mission holds at least SAME_SHARE of a sortie's survey waypoints (at the same place, whatever
else changed) flew that sortie, changed where its items differ (a mission edited in the
field), as does one that holds the sortie's first items and none after them (an upload that
stopped). One whose photo runs start at the plan's stations (at least SAME_SHARE of them: the
waypoint before each camera-on) flies the plan's stations, part of the plan (a mission
`aerosurvey resume` wrote starts at the first station not photographed). Any other flew
another mission, or an older version of this plan (its photo runs starting elsewhere along the
lines), and is named so with the figures.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from aerosurvey import ids
from aerosurvey.flight.mission_log import ULOG_SOURCE
from aerosurvey.link import mission_protocol as mp
from aerosurvey.link.upload import (
    PLAIN_XY_COMMANDS,
    ardupilot_stored,
    command_name,
    f32,
    home_on_wire,
    mission_wire_items,
    px4_stored,
    same_frame,
)
from aerosurvey.mission import mavlink_ids as mav
from aerosurvey.mission.items import Mission

#: metres between two positions of one item: a float32 degree (how PX4's navigator_mission_item
#: logs positions) is good to 1.7 m at longitude 180°, ArduPilot keeps 1e-7 degrees (1 cm); a
#: survey waypoint moved less than this changes no photo (a station's tolerance is a quarter of
#: the photo base)
POSITION_TOL_M = 2.0
#: metres between two altitudes of one item (ArduPilot keeps whole centimetres)
ALT_TOL_M = 0.1
#: the share of a mission's survey waypoints a log's mission must hold to be that mission
SAME_SHARE = 0.5

#: the verdicts, in log_report.json's mission.verdict
PLAN, CHANGED, OTHER, NOT_RECORDED, NOT_COMPARED = "plan", "changed", "other", "not-recorded", "not-compared"

_WGS84_A, _WGS84_E2 = 6_378_137.0, 0.00669437999014  # semi-major axis (m), first eccentricity squared


@dataclass(frozen=True)
class PlannedMission:
    """One mission file of the plan, as it would go up the link."""

    sortie: str | None  # the sortie it flies; None for the whole mission
    file: str
    items: tuple[mp.WireItem, ...]  # `link.upload.mission_wire_items`: home first for ArduPilot
    tags: tuple[str, ...]  # each item's manifest tag ("home" for home, "" for none)


def planned_mission(sortie: str | None, file: str, mission: Mission) -> PlannedMission:
    """A mission file's items with their tags."""
    tags = (("home",) if home_on_wire(mission) else ()) + tuple(it.tag for it in mission.items)
    return PlannedMission(sortie, file, tuple(mission_wire_items(mission)), tags)


def storage_rules(autopilot: str, plane: bool) -> Callable[[mp.WireItem], mp.WireItem]:
    """What the autopilot keeps of an item (`link.upload`); an unknown autopilot keeps it as it is."""
    if autopilot == "ardupilot":
        return lambda it: ardupilot_stored(it, plane)
    if autopilot == "px4":
        return px4_stored
    return lambda it: it


def _ulog_recorded(stored: Callable[[mp.WireItem], mp.WireItem]) -> Callable[[mp.WireItem], mp.WireItem]:
    """What navigator_mission_item records of a stored item: of one without a position
    (MAV_FRAME_MISSION) no parameters 5 and 6 (a gimbal command's flags): x = y = 0, as the
    reader gives them."""
    def rule(it: mp.WireItem) -> mp.WireItem:
        s = stored(it)
        return replace(s, x=0, y=0) if s.frame == mav.FRAME_MISSION else s
    return rule


def _place(it: mp.WireItem) -> tuple[float, float] | None:
    """(lat, lon) of an item whose x/y are a position, else None."""
    if it.command in PLAIN_XY_COMMANDS or (it.x == 0 and it.y == 0):
        return None
    return it.x * 1e-7, it.y * 1e-7


def _metres_per_degree(lat: float) -> tuple[float, float]:
    """Metres per degree of longitude and of latitude at a latitude, on the WGS84 ellipsoid (its
    radii of curvature there): distances of a few kilometres to a millimetre."""
    s = math.sin(math.radians(lat))
    w = 1.0 - _WGS84_E2 * s * s
    k = math.pi / 180.0
    return _WGS84_A / math.sqrt(w) * math.cos(math.radians(lat)) * k, _WGS84_A * (1.0 - _WGS84_E2) / w ** 1.5 * k


def distance_m(a: tuple[float, float], b: tuple[float, float]) -> float:
    """Metres between two (lat, lon) a few kilometres apart at most."""
    kx, ky = _metres_per_degree((a[0] + b[0]) / 2)
    return math.hypot((b[1] - a[1]) * kx, (b[0] - a[0]) * ky)


def _close(planned: float, logged: float) -> bool:
    """A parameter or altitude of the plan and of the log are one float32 value (NaN in the log: not recorded)."""
    if math.isnan(logged):
        return True
    if math.isnan(planned):
        return False
    return abs(f32(planned) - f32(logged)) <= 1e-6 + 2.0**-22 * max(abs(planned), abs(logged))


def _num(v: float) -> float | None:
    """A float32 value with the 7 digits it holds (102.13, not 102.12999725341797); None for NaN."""
    return None if not math.isfinite(v) else float(f"{v:.7g}")


def _deg(v: float) -> float:
    """Degrees to the 1e-7 a mission item holds."""
    return round(float(v), 7)


def field_differences(e: mp.WireItem, a: mp.WireItem) -> list[dict[str, Any]]:
    """How a logged item `a` differs from the planned `e` (both as the autopilot keeps them): one
    entry per field, {field, planned, logged} (and offset_m for a position); none when they are one."""
    if e.command != a.command:
        return [{"field": "command", "planned": command_name(e.command), "logged": command_name(a.command)}]
    out: list[dict[str, Any]] = []
    if e.frame >= 0 and a.frame >= 0 and same_frame(e.frame) != same_frame(a.frame):
        out.append({"field": "frame", "planned": e.frame, "logged": a.frame})
    for k, (pv, lv) in enumerate(zip((e.param1, e.param2, e.param3, e.param4), (a.param1, a.param2, a.param3, a.param4)), 1):
        if not _close(pv, lv):
            out.append({"field": f"param{k}", "planned": _num(pv), "logged": _num(lv)})
    pe, pa = _place(e), _place(a)
    if pe is not None and pa is not None:
        d = distance_m(pe, pa)
        if d > POSITION_TOL_M:
            out.append({"field": "position", "planned": [_deg(pe[0]), _deg(pe[1])], "logged": [_deg(pa[0]), _deg(pa[1])],
                        "offset_m": round(d, 2)})
    elif pe is not None or pa is not None:
        out.append({"field": "position", "planned": None if pe is None else [_deg(pe[0]), _deg(pe[1])],
                    "logged": None if pa is None else [_deg(pa[0]), _deg(pa[1])]})
    elif (e.x, e.y) != (a.x, a.y):  # the plain integers of a command whose x/y are no position
        out.append({"field": "x, y", "planned": [e.x, e.y], "logged": [a.x, a.y]})
    if pe is not None or pa is not None:
        if not (math.isnan(a.z) or (math.isfinite(e.z) and abs(e.z - a.z) <= ALT_TOL_M)):
            out.append({"field": "altitude", "planned": _num(e.z), "logged": _num(a.z)})
    elif not _close(e.z, a.z):
        out.append({"field": "param7", "planned": _num(e.z), "logged": _num(a.z)})
    return out


@dataclass(frozen=True)
class Difference:
    """One item of the plan and of the log that are not one: left out of the log, added to it, or changed."""

    kind: str  # "missing" (planned, not in the log), "added" (in the log, not planned), "differs"
    planned: int | None  # its sequence number in the plan's mission
    logged: int | None  # its sequence number in the log's
    command: int
    tag: str  # the planned item's manifest tag
    fields: tuple[dict[str, Any], ...] = ()  # for "differs": `field_differences`

    def as_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "planned_item": self.planned, "logged_item": self.logged,
                "command": command_name(self.command), "tag": self.tag, "fields": list(self.fields)}

    def text(self) -> str:
        what = f"{command_name(self.command)}" + (f" {self.tag}" if self.tag else "")
        if self.kind == "missing":
            return f"planned item {self.planned} ({what}) is not in the log's mission"
        if self.kind == "added":
            return f"the log's item {self.logged} ({what}) is not planned"
        parts = []
        for f in self.fields:
            if "offset_m" in f:
                parts.append(f"position {f['offset_m']:.1f} m off")
            else:
                parts.append(f"{f['field']} planned {_show(f['planned'])}, logged {_show(f['logged'])}")
        at = f"item {self.planned}" if self.planned == self.logged else f"planned item {self.planned} (the log's {self.logged})"
        return f"{at} ({what}): " + "; ".join(parts)


def _show(v: Any) -> str:
    if isinstance(v, list):
        return "none" if not v else ", ".join(_show(x) for x in v)
    if isinstance(v, float):
        return f"{v:.7g}"
    return "none" if v is None else str(v)


@dataclass(frozen=True)
class Comparison:
    """A log's mission against one planned mission."""

    planned: PlannedMission
    planned_items: int  # compared (home aside)
    logged_items: int  # recorded and compared (home aside)
    complete: bool  # the log records every item of the vehicle's mission
    same: int  # items that are one by meaning
    differences: tuple[Difference, ...]
    unrecorded: int  # planned items the log does not record (an incomplete record)
    survey_waypoints: int  # the plan's survey waypoints the record can hold
    found: int  # of those, how many the log's mission has at their place
    offset_median_m: float | None  # from each of those to the nearest logged item of its command
    offset_max_m: float | None
    photo_starts: int = 0  # the log's photo runs (the waypoints before each camera-on)
    photo_starts_at_stations: int = 0  # of those, how many start at one of the plan's stations
    #: the log's mission is the plan's first items (survey waypoints among them) and none of the
    #: others: what an upload that stopped leaves (ArduPilot keeps the items it received)
    partial_upload: bool = False
    #: of the log's photo runs, how many start where none of this mission's do (a run it does not fly)
    photo_starts_elsewhere: int = 0

    @property
    def share(self) -> float:
        """Of the plan's survey waypoints the record can hold, the share at their place."""
        return self.found / self.survey_waypoints if self.survey_waypoints else (
            self.same / max(self.planned_items, 1))

    @property
    def log_share(self) -> float:
        """Of the log's photo runs, the share that start at one of the plan's stations."""
        return self.photo_starts_at_stations / self.photo_starts if self.photo_starts else 0.0

    @property
    def of_sortie(self) -> bool:
        """The log's mission photographs this mission's stations: every item as planned, every survey
        waypoint at its place and no photo run of its own (what changed is elsewhere: altitudes, speed,
        take-off, landing), or the mission's first items (an upload that stopped). A mission that flies
        a sortie's runs and more (a resumed mission over two sorties) is not that sortie's: its photos
        are matched to all the plan's stations."""
        return not self.differences or self.partial_upload or (0 < self.survey_waypoints == self.found
                                                               and self.photo_starts_elsewhere == 0)

    @property
    def verdict(self) -> str:
        if not self.differences:
            return PLAN
        return CHANGED if self.share >= SAME_SHARE or self.log_share >= SAME_SHARE else OTHER


def _signature(it: mp.WireItem) -> tuple[Any, ...]:
    """An item without a position as one hashable value (NaN as None; its frame, which says nothing
    without a position, left out: ArduPilot stores 0 for the plan's 2)."""
    def v(x: float) -> float | None:
        return None if math.isnan(x) else f32(x)
    return (it.command, v(it.param1), v(it.param2), v(it.param3), v(it.param4), it.x, it.y, v(it.z))


def _keys(planned: Sequence[mp.WireItem], logged: Sequence[mp.WireItem]) -> tuple[list[Any], list[Any], list[Any], list[Any]]:
    """Alignment keys of the planned and the logged items, plain and in context: items that are
    one by meaning share a plain key. An item with a position is the index of the first planned
    item it is one with (a logged item with none: a key of its own); one without is its
    signature, and in context that after the key of the last item with a position (the camera
    items of every line are alike: after their line's waypoint each is one item, so difflib's
    alignment stays near linear instead of trying every alike item against every other)."""
    places: dict[int, tuple[list[int], np.ndarray]] = {}  # command -> planned items with a place, their (lat, lon)
    for i, it in enumerate(planned):
        p = _place(it)
        if p is not None:
            places.setdefault(it.command, ([], np.empty((0, 2))))[0].append(i)
    for cmd, (idx, _) in places.items():
        places[cmd] = (idx, np.array([_place(planned[i]) for i in idx], float).reshape(-1, 2))

    def first_same(it: mp.WireItem, p: tuple[float, float]) -> int | None:
        idx, ll = places.get(it.command, ([], np.empty((0, 2))))
        if not idx:
            return None
        kx, ky = _metres_per_degree(p[0])
        d = np.hypot((ll[:, 1] - p[1]) * kx, (ll[:, 0] - p[0]) * ky)
        for q in np.flatnonzero(d <= POSITION_TOL_M * 1.01).tolist():
            if not field_differences(planned[idx[q]], it):
                return idx[q]
        return None

    def keys(items: Sequence[mp.WireItem], own: str) -> tuple[list[Any], list[Any]]:
        plain: list[Any] = []
        context: list[Any] = []
        at: Any = None  # the key of the last item with a position
        for i, it in enumerate(items):
            p = _place(it)
            if p is None:
                plain.append(("item", _signature(it)))
                context.append((plain[-1], at))
                continue
            same = first_same(it, p)
            at = ("place", same) if same is not None else (own, i)
            plain.append(at)
            context.append(at)
        return plain, context

    (pp, pc), (lp, lc) = keys(planned, "place"), keys(logged, "logged")
    return pp, lp, pc, lc


#: the most cells (planned × logged items of one stretch that differs) the stretch is aligned item by
#: item in; a larger one (another mission: nothing aligns) pairs its items by command only (difflib)
_MAX_CELLS = 4_000_000


def _stretch(pp: list[Any], lp: list[Any], planned: Sequence[mp.WireItem], logged: Sequence[mp.WireItem]) -> \
        list[tuple[int | None, int | None]]:
    """The items of a stretch that differs, paired: (planned, logged) indexes within it, None on the
    side an item is missing from. The pairing holds the most items one by meaning (plain keys
    equal, 3 points), then of one command at one place (2: an item changed where it was), then of
    one command, the nearer the better (1 to 2: an item moved), in order: a Needleman-Wunsch
    alignment without gap costs, a row at a time (numpy)."""
    n, m = len(pp), len(lp)
    pcmd, lcmd = [it.command for it in planned], [it.command for it in logged]
    if not n or not m or n * m > _MAX_CELLS:
        out: list[tuple[int | None, int | None]] = []
        for op, a0, a1, b0, b1 in difflib.SequenceMatcher(None, pcmd, lcmd, autojunk=False).get_opcodes():
            if op == "equal":
                out += list(zip(range(a0, a1), range(b0, b1)))
            else:
                out += [(i, None) for i in range(a0, a1)] + [(None, j) for j in range(b0, b1)]
        return out
    ids_: dict[Any, int] = {}
    kp = np.array([ids_.setdefault(k, len(ids_)) for k in pp])
    kl = np.array([ids_.setdefault(k, len(ids_)) for k in lp])
    pl, ll = (np.array([_place(it) or (math.nan, math.nan) for it in items], float).reshape(-1, 2) for items in (planned, logged))
    kx = np.array([_metres_per_degree(lat)[0] if math.isfinite(lat) else 0.0 for lat in pl[:, 0]])
    ky = np.array([_metres_per_degree(lat)[1] if math.isfinite(lat) else 0.0 for lat in pl[:, 0]])
    d = np.hypot((ll[None, :, 1] - pl[:, None, 1]) * kx[:, None], (ll[None, :, 0] - pl[:, None, 0]) * ky[:, None])
    here = (np.isnan(pl[:, :1]) & np.isnan(ll[None, :, 0])) | (d <= POSITION_TOL_M)
    same_cmd = np.array(pcmd)[:, None] == np.array(lcmd)[None, :]
    moved = 1.0 + 1.0 / (1.0 + np.nan_to_num(d, nan=np.inf))
    w = np.where(kp[:, None] == kl[None, :], 3.0, np.where(same_cmd, np.where(here, 2.0, moved), -1e9))
    score = np.zeros((n + 1, m + 1))
    for i in range(1, n + 1):
        best = np.maximum(score[i - 1, 1:], score[i - 1, :-1] + w[i - 1])
        score[i, 1:] = np.maximum.accumulate(np.maximum(best, 0))
    pairs: list[tuple[int | None, int | None]] = []
    i, j = n, m
    while i > 0 or j > 0:
        if i > 0 and j > 0 and w[i - 1, j - 1] > 0 and score[i, j] == score[i - 1, j - 1] + w[i - 1, j - 1]:
            pairs.append((i - 1, j - 1))
            i, j = i - 1, j - 1
        elif i > 0 and (j == 0 or score[i, j] == score[i - 1, j]):
            pairs.append((i - 1, None))
            i -= 1
        else:
            pairs.append((None, j - 1))
            j -= 1
    return pairs[::-1]


def _survey(planned: PlannedMission, kept: Sequence[int], logged: Sequence[mp.WireItem], recorded: set[int] | None) -> \
        tuple[int, int, float | None, float | None]:
    """(survey waypoints the record holds a number of (`recorded`: the sequence numbers an
    incomplete record holds; None: all), how many the log's mission has at their place, the
    median and largest distance from them to the nearest logged item of their command)."""
    by_command: dict[int, list[tuple[float, float]]] = {}
    for a in logged:
        q = _place(a)
        if q is not None:
            by_command.setdefault(a.command, []).append(q)
    places = {cmd: np.array(ps, float) for cmd, ps in by_command.items()}
    near: list[float] = []
    for i in kept:
        it, tag = planned.items[i], planned.tags[i]
        p = _place(it)
        if p is None or ids.pass_of(tag) is None or (recorded is not None and it.seq not in recorded):
            continue
        near.append(_nearest_m(p, places.get(it.command, np.empty((0, 2)))))
    found = sum(d <= POSITION_TOL_M for d in near)
    fin = [d for d in near if math.isfinite(d)]
    return len(near), found, (float(np.median(fin)) if fin else None), (max(fin) if fin else None)


def _camera_on(it: mp.WireItem) -> bool:
    """The item starts the camera: a distance or time trigger set, or a picture taken."""
    if it.command in (mav.DO_SET_CAM_TRIGG_DIST, mav.DO_SET_CAM_TRIGG_INTERVAL):
        return it.param1 > 0
    return it.command in (mav.DO_DIGICAM_CONTROL, mav.IMAGE_START_CAPTURE)


def photo_starts(items: Sequence[mp.WireItem]) -> list[tuple[float, float]]:
    """(lat, lon) of the waypoint before each item that starts the camera (each waypoint once)."""
    out: list[tuple[float, float]] = []
    last: tuple[float, float] | None = None
    for it in items:
        if it.command == mav.NAV_WAYPOINT and _place(it) is not None:
            last = _place(it)
        elif _camera_on(it) and last is not None and (not out or out[-1] != last):
            out.append(last)
    return out


def _nearest_m(p: tuple[float, float], places: np.ndarray) -> float:
    """Metres from `p` to the nearest of `places` (rows of lat, lon); infinite when there are none."""
    if not len(places):
        return math.inf
    kx, ky = _metres_per_degree(p[0])
    return float(np.min(np.hypot((places[:, 1] - p[1]) * kx, (places[:, 0] - p[0]) * ky)))


def compare(planned: PlannedMission, logged: Sequence[mp.WireItem], complete: bool,
            stored: Callable[[mp.WireItem], mp.WireItem], skip_home: bool, log_stored: bool = True,
            stations: np.ndarray | None = None) -> Comparison:
    """The log's items (`complete`: every item of the vehicle's mission) against one planned
    mission through the autopilot's storage rules `stored`, the log's too unless `log_stored`
    (they are as the autopilot stored them); with `skip_home`, item 0 of neither (ArduPilot
    keeps its own home there). `stations` (rows of lat, lon): the plan's photo stations, where
    a mission of the plan starts its photo runs."""
    kept = [i for i, it in enumerate(planned.items) if not (skip_home and planned.tags[i] == "home")]
    plan_items = [stored(planned.items[i]) for i in kept]
    log_items = [it if log_stored else stored(it) for it in logged if not (skip_home and it.seq == 0)]
    pp, lp, pc, lc = _keys(plan_items, log_items)
    diffs: list[Difference] = []
    same = unrecorded = 0

    def missing(i: int) -> None:
        nonlocal unrecorded
        e = plan_items[i]
        if complete:
            diffs.append(Difference("missing", e.seq, None, e.command, planned.tags[kept[i]]))
        else:
            unrecorded += 1

    def added(j: int) -> None:
        a = log_items[j]
        diffs.append(Difference("added", None, a.seq, a.command, ""))

    opcodes = difflib.SequenceMatcher(None, pc, lc, autojunk=False).get_opcodes()
    for op, i0, i1, j0, j1 in opcodes:
        if op == "equal":
            same += i1 - i0
            continue
        # an item added or left out changes the context of the items after it up to the next waypoint:
        # the stretch is paired item by item (`_stretch`): one by meaning, changed, left out, added
        for a, b in _stretch(pp[i0:i1], lp[j0:j1], plan_items[i0:i1], log_items[j0:j1]):
            if a is None:
                assert b is not None
                added(j0 + b)
            elif b is None:
                missing(i0 + a)
            else:
                e, g = plan_items[i0 + a], log_items[j0 + b]
                fields = field_differences(e, g)
                if fields:
                    diffs.append(Difference("differs", e.seq, g.seq, e.command, planned.tags[kept[i0 + a]], tuple(fields)))
                else:
                    same += 1
    survey, found, med, top = _survey(planned, kept, log_items, None if complete else {a.seq for a in log_items})
    prefix = opcodes[0][2] if opcodes and opcodes[0][0] == "equal" else 0
    partial = 0 < prefix == same < len(plan_items) and any(ids.pass_of(planned.tags[i]) is not None for i in kept[:prefix])
    starts = photo_starts(log_items)
    at_stations = sum(_nearest_m(p, stations) <= POSITION_TOL_M for p in starts) if stations is not None else 0
    own = np.array(photo_starts(plan_items), float).reshape(-1, 2)
    elsewhere = sum(_nearest_m(p, own) > POSITION_TOL_M for p in starts)
    return Comparison(planned, len(plan_items), len(log_items), complete, same, tuple(diffs), unrecorded, survey, found,
                      med, top, len(starts), at_stations, partial, elsewhere)


@dataclass(frozen=True)
class MissionCheck:
    """What the log's mission says of the flight against the plan: log_report.json's `mission`."""

    verdict: str  # PLAN, CHANGED, OTHER, NOT_RECORDED, NOT_COMPARED
    sortie: str | None  # the sortie whose stations the log's mission photographs (None: the whole mission, or none known)
    source: str  # the log messages read
    note: str  # what the log records; why nothing was compared
    logged_items: int  # items the log records of the mission flown (home included)
    logged_total: int  # items the vehicle said that mission holds
    comparison: Comparison | None  # against the planned mission it is nearest
    #: the missions recorded after the first photo: (where, how each differs from the one before it)
    changes: tuple[tuple[str, tuple[Difference, ...]], ...]
    mission_name: str = ""  # the plan's mission name, for the text

    @property
    def names_sortie(self) -> bool:
        """The log's mission is one of the plan's, whole or changed: `sortie` is the one flown (None: the whole mission)."""
        return self.verdict in (PLAN, CHANGED) and self.comparison is not None and self.comparison.of_sortie

    @property
    def flies_part_of_plan(self) -> bool:
        """The log's mission is none of the plan's but flies part of it (a mission `aerosurvey resume` wrote?)."""
        c = self.comparison
        return self.verdict == CHANGED and c is not None and not c.of_sortie and c.log_share >= SAME_SHARE

    def text(self) -> str:
        """One line: what the vehicle flew."""
        c = self.comparison
        if self.verdict in (NOT_RECORDED, NOT_COMPARED) or c is None:
            return f"mission not compared: {self.note}"
        of = f"sortie {c.planned.sortie} of " if c.planned.sortie else ""
        what = f"{of}{self.mission_name!r} ({c.planned.file})"
        recorded = "" if c.complete else f" (the log records {c.logged_items} of them)"
        if self.verdict == PLAN:
            return f"the vehicle's mission is {what}: {c.planned_items} items as planned{recorded}"
        far = "" if c.offset_median_m is None else (
            f"; the plan's survey waypoints lie a median {c.offset_median_m:.1f} m (max {c.offset_max_m:.1f} m) from the "
            "nearest item of the log's mission")
        partial = f" (the plan's first {c.same} items and none after them: an upload that stopped)" if c.partial_upload else ""
        figures = (f"{c.same} of its {c.planned_items} items as planned{partial}, {len(c.differences)} differ{recorded}; "
                   f"{c.found} of {c.survey_waypoints} survey waypoints at their place{far}")
        every = "its photos are matched to every planned station (--sortie names the sortie whose stations they are)"
        if self.verdict == CHANGED and c.of_sortie:
            return f"the vehicle's mission is {what}, changed: {figures}"
        if self.flies_part_of_plan:
            return (f"the vehicle's mission flies part of the plan: {c.photo_starts_at_stations} of its {c.photo_starts} "
                    "photo runs start at planned stations (a mission `aerosurvey resume` wrote?); its photos are matched to the "
                    "planned stations they lie nearest (--sortie names the sortie whose stations they are); nearest "
                    f"{what}: {figures}")
        if self.verdict == CHANGED:
            return f"the vehicle's mission is {what}, changed, survey waypoints moved: {figures}; {every}"
        return (f"the vehicle flew another mission than {what}, or an older version of it: {figures}; "
                f"{c.photo_starts_at_stations} of its {c.photo_starts} photo runs start at a planned station (a mission "
                f"holding fewer than {SAME_SHARE:.0%} of the plan's survey waypoints, whose photo runs do not mostly start "
                "at planned stations, is another)")

    def lines(self, most: int = 10) -> list[str]:
        """The summary, then each difference (the first `most` of each list)."""
        out = [self.text()]
        diffs = self.comparison.differences if self.comparison is not None and self.verdict != PLAN else ()
        out += [f"  {d.text()}" for d in diffs[:most]]
        if len(diffs) > most:
            out.append(f"  … and {len(diffs) - most} more (log_report.json's mission.differences)")
        for where, changed in self.changes:
            out.append(f"mission changed after the first photo (recorded at {where}): {len(changed)} item(s)")
            out += [f"  {d.text()}" for d in changed[:most]]
        return out

    def as_dict(self) -> dict[str, Any]:
        c = self.comparison
        out: dict[str, Any] = {"verdict": self.verdict, "sortie": self.sortie, "source": self.source or None,
                               "note": self.note, "logged_items": self.logged_items, "logged_total": self.logged_total,
                               "text": self.text()}
        if c is not None:
            out.update({"file": c.planned.file, "planned_items": c.planned_items, "compared_items": c.logged_items,
                        "complete": c.complete, "same_items": c.same, "unrecorded_items": c.unrecorded,
                        "partial_upload": c.partial_upload,
                        "survey_waypoints": c.survey_waypoints, "survey_waypoints_found": c.found,
                        "photo_runs": c.photo_starts, "photo_runs_from_stations": c.photo_starts_at_stations,
                        "offset_median_m": None if c.offset_median_m is None else round(c.offset_median_m, 2),
                        "offset_max_m": None if c.offset_max_m is None else round(c.offset_max_m, 2),
                        "differences": [d.as_dict() for d in c.differences]})
        out["changes"] = [{"at": where, "differences": [d.as_dict() for d in changed]} for where, changed in self.changes]
        return out


def not_compared(verdict: str, source: str, note: str, logged_items: int = 0, logged_total: int = 0) -> MissionCheck:
    """A check that compared nothing: the log records no mission, or the plan folder has no mission file."""
    return MissionCheck(verdict, None, source, note, logged_items, logged_total, None, ())


def recognise(candidates: Sequence[PlannedMission], flown: Sequence[mp.WireItem], complete: bool, total: int,
              later: Sequence[tuple[str, Sequence[mp.WireItem]]], autopilot: str, log_stored: bool, plane: bool, source: str,
              note: str, mission_name: str, stations: np.ndarray | None = None) -> MissionCheck:
    """The planned mission the log's mission (`flown`: its items, as `autopilot` stored them if
    `log_stored`; `complete`: all `total` of them) is, or is nearest: the one whose survey
    waypoints it holds most of (then the most items as planned). `later` are the missions
    recorded after the first photo, each compared with the one before it. Without candidates,
    NOT_COMPARED. `stations`: the plan's (rows of lat, lon), where its photo runs start."""
    stored = storage_rules(autopilot, plane)
    if source == ULOG_SOURCE:
        stored = _ulog_recorded(stored)
    skip_home = autopilot == "ardupilot"
    if not candidates:
        return not_compared(NOT_COMPARED, source, note, len(flown), total)
    found = [compare(p, flown, complete, stored, skip_home, log_stored, stations) for p in candidates]
    best = max(found, key=lambda c: (c.share, c.log_share, c.same, -len(c.differences)))
    changes = []
    before = flown
    for where, items in later:
        prev = PlannedMission(None, "", tuple(before), tuple("home" if it.seq == 0 else "" for it in before))
        c = compare(prev, items, True, lambda it: it if log_stored else stored(it), skip_home, True)
        if c.differences:
            changes.append((where, c.differences))
        before = items
    verdict = best.verdict
    skipped = " Item 0 (home) is not compared: ArduPilot keeps its own home there." if skip_home else ""
    named = verdict != OTHER and best.of_sortie
    return MissionCheck(verdict, best.planned.sortie if named else None, source, note + "." + skipped, len(flown), total,
                        best, tuple(changes), mission_name)


def another_mission(report: dict[str, Any]) -> str | None:
    """Why a log_report.json's flight is of another mission (its `mission.verdict` is OTHER), or None."""
    m = report.get("mission") or {}
    if m.get("verdict") != OTHER:
        return None
    return (f"flight log {report.get('log')!r}: {m.get('text')}; log_report.json's mission lists the items that differ")
