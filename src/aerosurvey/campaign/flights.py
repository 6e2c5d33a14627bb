"""`campaign ingest`: a day's flight logs and photo folders filed under their blocks.

Each flight is read once (`flight.ingest.read_record`: its camera events and modes;
`logged_mission`: the mission it records), and what was read is passed along: the
blocks nearest its events are its candidates, the one most events lie nearest first. A log that
records its mission is its block's when `flight.ingest.compare_mission` recognises the block's
mission, whole or a sortie, in it (changed or not); a flight that records no mission (a folder
of photos) is the block's its events lie nearest to. The flight is then matched to the
block's plan as `log ingest --plan` matches it (`flight.ingest.against_plan`; the sortie recognised there) into
CAMPAIGN/flights/BLOCK/FLIGHT/, and a "flown" event names it. A flight of no block is reported,
nothing filed.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

from aerosurvey.campaign.job import BLOCKS_DIR, RESULT_FILE
from aerosurvey.campaign.register import BlockRow, Event, status_of
from aerosurvey.errors import AerosurveyError, InputError

if TYPE_CHECKING:
    from aerosurvey.rules.planview import PlanView

FLIGHTS_DIR = "flights"
#: blocks whose missions a log is compared with, nearest first
CANDIDATES = 3


@dataclass(frozen=True)
class Filed:
    """Where a flight went: `block` None when it is of no block (`detail` says why); `key` the key of the block's
    plan it was matched to."""

    flight: str
    block: str | None
    detail: str
    folder: Path | None = None
    key: str = ""


def candidates(rows: Sequence[BlockRow], lon: Sequence[float], lat: Sequence[float]) -> list[BlockRow]:
    """The planned blocks the events lie nearest to, the most events first (at most CANDIDATES)."""
    import numpy as np
    import shapely

    planned = [r for r in rows if r.status not in ("failed",)]
    if not planned or not len(lon):
        return []
    tree = shapely.STRtree(shapely.from_wkb([r.wkb for r in planned]))
    nearest = tree.query_nearest(shapely.points(np.asarray(lon), np.asarray(lat)), all_matches=False)[1]
    votes = np.bincount(nearest, minlength=len(planned))
    order = np.argsort(-votes, kind="stable")
    return [planned[i] for i in order[:CANDIDATES] if votes[i] > 0]


def file_flight(campaign: Path, flight: Path, rows: Sequence[BlockRow], vehicle: str | None) -> Filed:
    """Find the block of one flight and ingest it there (see the module's doc). The flight is read once
    (its camera events and modes, its mission): what is read is compared with each candidate block's
    missions and matched to the chosen block's stations; `vehicle` (the campaign's, `campaign_vehicle`)
    names the modes of a log that does not say its vehicle."""
    from aerosurvey.flight.ingest import against_plan, compare_mission, logged_mission, read_record, write_ingest
    from aerosurvey.flight.mission_flown import CHANGED, NOT_COMPARED, NOT_RECORDED, PLAN

    if not flight.exists():
        raise InputError(f"flight {str(flight)!r} does not exist")
    read = read_record(flight, vehicle)
    logged = logged_mission(flight)
    events = read.events
    near = candidates(rows, events.lon.tolist(), events.lat.tolist())
    if not near:
        return Filed(flight.name, None, f"none of its {len(events)} camera events lies near a planned block")
    chosen = None
    tried = []
    for row in near:
        view = block_view(campaign, row)
        check = compare_mission(logged, view.document)
        if check.names_sortie or check.verdict in (NOT_RECORDED, NOT_COMPARED):
            chosen = (row, view, check)
            break
        tried.append(f"{row.name} ({check.verdict})")
    if chosen is None:
        return Filed(flight.name, None, f"its mission is none of the nearest blocks' ({', '.join(tried)})")
    row, view, check = chosen
    result = against_plan(flight, read, view, check)
    out = campaign / FLIGHTS_DIR / row.name / flight.name
    report = write_ingest(result, out)
    sortie = report.get("plan", {}).get("sortie")
    how = "by its mission" if result.mission is not None and result.mission.verdict in (PLAN, CHANGED) else "by its photos' places"
    detail = (f"{flight.name}: {'sortie ' + sortie if sortie else 'the whole mission'}, recognised {how}; "
              f"{report.get('matched', 0)} of {report.get('planned', 0)} stations photographed")
    return Filed(flight.name, row.name, detail, out, row.key)


def block_view(campaign: Path, row: BlockRow) -> PlanView:
    """What `log ingest --plan` reads of a block's plan: its manifest.json and its area and zones (PlanView.from_outdir:
    plan.geojson, or the outline.geojson every block folder has)."""
    from aerosurvey.rules.planview import PlanView

    folder = campaign / BLOCKS_DIR / row.folder
    if not (folder / "manifest.json").is_file():
        raise InputError(f"block {row.name}: {folder / 'manifest.json'} is missing; `campaign ingest` needs each block's "
                         "manifest: plan the campaign with manifest among --outputs (as the default is)")
    return PlanView.from_outdir(folder, f"block {row.name}")


def campaign_vehicle(campaign: Path, rows: Sequence[BlockRow]) -> str | None:
    """The vehicle the campaign's blocks are planned for (one template: one vehicle), from the first planned
    block's block.json; None when no block says (every block failed, or block folders of the first layout)."""
    import json

    for row in rows:
        result = campaign / BLOCKS_DIR / row.folder / RESULT_FILE
        if row.status != "failed" and result.is_file():
            vehicle = json.loads(result.read_text(encoding="utf-8")).get("vehicle")
            return str(vehicle) if vehicle else None
    return None


def ingest_flights(campaign: Path, flights: Sequence[Path], rows: Sequence[BlockRow]) -> list[Filed]:
    """File each flight under its block of the register's `rows` (what was filed, or why not)."""
    filed = []
    vehicle = campaign_vehicle(campaign, rows)
    for flight in flights:
        try:
            f = file_flight(campaign, flight, rows, vehicle)
        except AerosurveyError as exc:
            f = Filed(flight.name, None, str(exc))
        filed.append(f)
    return filed


def with_flown(rows: Sequence[BlockRow], events: Sequence[Event], filed: Sequence[Filed],
               now: str) -> tuple[list[BlockRow], list[Event]]:
    """The register (as it is when it is written) with a "flown" event per flight filed, under the key of the plan
    it was matched to (a block planned again meanwhile keeps its new status), none again for a flight filed before
    under the same block and key, and its blocks' statuses."""
    events = list(events)
    for f in filed:
        if f.block is None:
            continue
        again = any(e.key == f.key and e.event == "flown" and e.detail.startswith(f"{f.flight}:") for e in events)
        if not again:
            events.append(Event(f.block, f.key, "flown", now, f.detail))
    of_key: dict[str, list[Event]] = {}
    for e in events:
        of_key.setdefault(e.key, []).append(e)
    out_rows = [replace(r, status=status_of(r.status, of_key.get(r.key, []))) for r in rows]
    return out_rows, events
