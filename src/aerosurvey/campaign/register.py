"""CAMPAIGN/register.gpkg: the campaign's record, its one writer and its one reader.

Two layers (docs/campaign.md):

- `blocks`: one row per block, its polygon (WGS84) and its status with the plan's summary
  (photos, time, distance, sorties, GSD, rule results) and, for a failed block, why;
- `events`: one row per event in a block's life (no geometry): planned, failed (planning),
  then uploaded, flown, compliance, re-fly, qa, accepted, each with its UTC time and detail.

A block's status is the latest of its events for its current key (`status_of`): a block whose
inputs change gets a new key, and starts again from its new plan. The file is written whole into
a temporary file and renamed into place, each read-modify-write under one lock (`update_register`,
fcntl.flock on CAMPAIGN/register.lock), so no event recorded at the same time is lost. `block_of`
tells whether a plan folder is a block's (CAMPAIGN/blocks/NAME.KEY/): the commands that upload,
check, re-fly and QA a plan record their event for it (`record`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aerosurvey.campaign.job import BLOCKS_DIR, BlockJob, BlockResult
from aerosurvey.errors import InputError

FILE = "register.gpkg"
LOCK = "register.lock"
FORMAT = 1
#: the events of a block's life, in order; "failed" is a planning attempt that ended without a plan
EVENTS = ("failed", "planned", "uploaded", "flown", "compliance", "re-fly", "qa", "accepted")
#: what a block in a status needs next
NEXT = {
    "failed": "planning failed; fix the block or the template and run `campaign plan` again",
    "rules-fail": "an error-level rule fails; change the block's attributes or the template and plan again",
    "planned": "fly it: its mission files are in blocks/{folder}; then `campaign ingest` its logs",
    "uploaded": "fly it; then `campaign ingest` its logs",
    "flown": "check the flight (flown compliance) and QA it with its check points",
    "compliance": "QA it with its check points (`qa accuracy`)",
    "re-fly": "fly the re-fly mission; then `campaign ingest` its logs",
    "qa": "accept it, or fly it again",
    "accepted": "",
}


@dataclass(frozen=True)
class BlockRow:
    """A row of the blocks layer; `wkb` the polygon in WGS84."""

    name: str
    key: str
    folder: str
    status: str
    wkb: bytes
    area_ha: float = 0.0
    photos: int = 0
    time_min: float = 0.0
    distance_km: float = 0.0
    sorties: int = 0
    gsd_cm: float = 0.0
    rules_evaluated: int = 0
    rules_passed: int = 0
    rules_failing: str = ""  # comma-separated rule ids
    message: str = ""


@dataclass(frozen=True)
class Event:
    """A row of the events layer."""

    block: str
    key: str
    event: str
    time: str  # ISO 8601, UTC
    detail: str = ""


_NUMBERS = {"area_ha": "float64", "photos": "int64", "time_min": "float64", "distance_km": "float64", "sorties": "int64",
            "gsd_cm": "float64", "rules_evaluated": "int64", "rules_passed": "int64"}
_TEXTS = ("name", "key", "folder", "status", "rules_failing", "message")
_EVENT_FIELDS = ("block", "key", "event", "time", "detail")


def status_of(planned_status: str, events: Sequence[Event]) -> str:
    """A block's status: the latest of its events after planning (by time, then by EVENTS' order),
    else how its planning ended ("planned", "rules-fail" or "failed")."""
    later = [e for e in events if e.event not in ("failed", "planned")]
    if not later:
        return planned_status
    return max(later, key=lambda e: (e.time, EVENTS.index(e.event))).event


def write_register(campaign: Path, rows: Sequence[BlockRow], events: Sequence[Event]) -> Path:
    """Write CAMPAIGN/register.gpkg whole (a temporary file renamed into place)."""
    import numpy as np
    import pyogrio

    from aerosurvey.fileio import staged_file

    path = campaign / FILE
    with staged_file(path) as tmp:
        geoms = np.array([r.wkb for r in rows], dtype=object)
        fields = [np.array([getattr(r, k) for r in rows], dtype=object) for k in _TEXTS]
        fields += [np.array([getattr(r, k) for r in rows], dtype=t) for k, t in _NUMBERS.items()]
        pyogrio.raw.write(tmp, geoms, fields, [*_TEXTS, *_NUMBERS], layer="blocks", driver="GPKG",
                          geometry_type="MultiPolygon", crs="EPSG:4326", promote_to_multi=True,
                          layer_options={"DESCRIPTION": f"aerosurvey campaign register {FORMAT}"})
        values = [np.array([getattr(e, k) for e in events], dtype=object) for k in _EVENT_FIELDS]
        pyogrio.raw.write(tmp, None, values, list(_EVENT_FIELDS), layer="events", driver="GPKG", geometry_type=None,
                          append=True)
    return path


def read_register(campaign: Path) -> tuple[list[BlockRow], list[Event]]:
    """The blocks and the events of CAMPAIGN/register.gpkg; a one-line InputError when it is missing or not one."""
    import pyogrio

    path = campaign / FILE
    if not path.is_file():
        raise InputError(f"campaign folder {str(campaign)!r} holds no {FILE}: run `aerosurvey campaign plan` into it first")
    try:
        meta, _, wkb, values = pyogrio.raw.read(path, layer="blocks")
        emeta, _, _, evalues = pyogrio.raw.read(path, layer="events", read_geometry=False)
    except Exception as exc:  # GDAL's error types vary between versions
        raise InputError(f"{str(path)!r} cannot be read as a campaign register: {exc}") from None
    cols = dict(zip(meta["fields"], values))
    ecols = dict(zip(emeta["fields"], evalues))
    missing = [k for k in (*_TEXTS, *_NUMBERS) if k not in cols] + [k for k in _EVENT_FIELDS if k not in ecols]
    if missing:
        raise InputError(f"{str(path)!r} is not a campaign register: it has no field {', '.join(missing)}")
    n = len(wkb) if wkb is not None else 0
    rows = []
    for i in range(n):
        row: dict[str, Any] = {k: str(cols[k][i] or "") for k in _TEXTS}
        row |= {k: (float if t == "float64" else int)(cols[k][i]) for k, t in _NUMBERS.items()}
        rows.append(BlockRow(wkb=bytes(wkb[i]), **row))
    events = [Event(*(str(ecols[k][i] or "") for k in _EVENT_FIELDS)) for i in range(len(ecols["block"]))]
    return rows, events


def after_planning(jobs: Sequence[BlockJob], results: Sequence[BlockResult], events: Sequence[Event],
                   now: str) -> tuple[list[BlockRow], list[Event]]:
    """The register after a `campaign plan` run: a row per job (in the jobs' order), and the
    events before it with a "planned" event for each block planned under a key that has none yet
    (a rerun adds none for a block done before) and a "failed" one for each attempt that failed."""
    import shapely

    from aerosurvey.area import transformed, transformer

    events = list(events)
    of_key: dict[str, list[Event]] = {}
    for e in events:
        of_key.setdefault(e.key, []).append(e)
    rows = []
    for job, res in zip(jobs, results):
        new = None
        if res.status == "failed":
            new = Event(job.name, job.key, "failed", now, res.message)
        elif not any(e.event == "planned" for e in of_key.get(job.key, ())):
            failing = ", ".join(res.record["rules"]["failed"]) if res.record else ""
            new = Event(job.name, job.key, "planned", now, f"error-level rules fail: {failing}" if failing else "")
        if new is not None:
            events.append(new)
            of_key.setdefault(job.key, []).append(new)
        geom = shapely.from_wkb(job.block.wkb)
        if job.crs != "EPSG:4326":
            geom = transformed(transformer(job.crs, "EPSG:4326"), geom)
        status = status_of(res.status, of_key.get(job.key, []))
        r = res.record or {}
        rules = r.get("rules", {})
        rows.append(BlockRow(job.name, job.key, job.folder, status, shapely.to_wkb(geom), float(r.get("area_ha", 0.0)),
                             int(r.get("photos", 0)), float(r.get("time_min", 0.0)), float(r.get("distance_km", 0.0)),
                             int(r.get("sorties", 0)), float(r.get("gsd_cm", 0.0)), int(rules.get("evaluated", 0)),
                             int(rules.get("passed", 0)), ", ".join(rules.get("failing", [])), res.message))
    return rows, events


#: the events `campaign record` records by hand (planned, failed and flown come from plan and ingest)
RECORDED = ("uploaded", "compliance", "re-fly", "qa", "accepted")


def now_utc() -> str:
    """The time an event is recorded at: UTC, ISO 8601, whole seconds."""
    import datetime as dt

    return dt.datetime.now(dt.UTC).isoformat(timespec="seconds").replace("+00:00", "Z")


@contextmanager
def locked(campaign: Path) -> Iterator[None]:
    """The campaign's register lock (an exclusive fcntl.flock on CAMPAIGN/register.lock), held around every
    read-modify-write of the register; released when the lock file is closed."""
    import fcntl

    with open(campaign / LOCK, "ab") as f:
        fcntl.flock(f.fileno(), fcntl.LOCK_EX)
        yield


Change = Callable[[list[BlockRow], list[Event]], tuple[list[BlockRow], list[Event]]]


def update_register(campaign: Path, change: Change, *, new: bool = False) -> tuple[list[BlockRow], list[Event]]:
    """Under the lock: read the register (none yet is empty when `new`), apply `change` to its rows and events,
    write it; the rows and events written. Every writer of the register goes through here."""
    with locked(campaign):
        rows, events = read_register(campaign) if not new or (campaign / FILE).exists() else ([], [])
        rows, events = change(rows, events)
        write_register(campaign, rows, events)
    return rows, events


def block_of(plan_dir: Path) -> Path | None:
    """The campaign a plan folder is a block folder of, CAMPAIGN/blocks/NAME.KEY/ with CAMPAIGN/register.gpkg; None
    for any other folder. Reads no register: `record` finds the folder's row under the register's lock."""
    folder = plan_dir.resolve()
    campaign = folder.parent.parent
    if folder.parent.name != BLOCKS_DIR or not (campaign / FILE).is_file():
        return None
    return campaign


def _row_of_folder(rows: Sequence[BlockRow], folder: str) -> BlockRow | None:
    return next((r for r in rows if r.folder == folder and folder.endswith(f".{r.key}")), None)


class NotRecorded(Exception):
    """A command's event for a block folder that the register holds no longer, or holds as not planned."""


def record(campaign: Path, block: str | None, event: str, detail: str, now: str, *, folder: str | None = None,
           file: Callable[[BlockRow], None] | None = None) -> BlockRow:
    """Add an event for a block, by its name or (`folder`) by its folder, under the register's lock; `file`, when
    given, is called with the block's row before the register is written (a QA verdict filed). The block's row
    after it. For a folder the register no longer holds, or a block not planned: NotRecorded, nothing written."""
    out: list[BlockRow] = []

    def change(rows: list[BlockRow], events: list[Event]) -> tuple[list[BlockRow], list[Event]]:
        name = block
        if folder is not None:
            row = _row_of_folder(rows, folder)
            if row is None:
                raise NotRecorded(f"the campaign's register holds no block of folder {folder!r} (planned again "
                                  "since, under a new key)")
            if row.status in ("failed", "rules-fail"):
                raise NotRecorded(f"block {row.name!r} is {row.status} in the campaign's register")
            name = row.name
        if name is None:
            raise ValueError("record: give the block's name or its folder")  # a caller's bug
        rows, events = with_event(rows, events, name, event, now, detail)
        out.append(next(r for r in rows if r.name == name))
        if file is not None:
            file(out[0])
        return rows, events

    update_register(campaign, change)
    return out[0]


def with_event(rows: Sequence[BlockRow], events: Sequence[Event], block: str, event: str, now: str,
               detail: str) -> tuple[list[BlockRow], list[Event]]:
    """The register with one more event for a block (by name), its status updated; an InputError for a
    block the register does not hold, an event not in RECORDED, or a block not planned."""
    from dataclasses import replace

    if event not in RECORDED:
        raise InputError(f"event = {event!r} is not allowed: one of {', '.join(RECORDED)}")
    found = [r for r in rows if r.name == block]
    if not found:
        raise InputError(f"block = {block!r} is not in the campaign's register ({len(rows)} blocks)")
    row = found[0]
    if row.status in ("failed", "rules-fail"):
        raise InputError(f"block {block!r} is {row.status}: plan it first (`campaign plan`)")
    new = Event(row.name, row.key, event, now, detail)
    events = [*events, new]
    status = status_of(row.status, [e for e in events if e.key == row.key])
    return [replace(r, status=status) if r.name == block else r for r in rows], events
