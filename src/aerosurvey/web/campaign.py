"""A campaign on the page (`serve --campaign CAMPAIGN`), read-only: register.gpkg's blocks by status, and a block's
plan from its folder (its summary, its files, its route as its mission.waypoints flies it).

The register is read through campaign/register.py's reader only; a block's folder is the one the register names.
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path
from typing import Any

from aerosurvey.errors import InputError

#: a block's status, in the order of its life: planning ended in failure or failing rules, then the register's events
STATUSES = ("failed", "rules-fail", "planned", "uploaded", "flown", "compliance", "re-fly", "qa", "accepted")


def campaign_blocks(campaign: Path) -> dict[str, Any]:
    """The campaign's blocks as GeoJSON (WGS84) with each block's status, plan summary and what it needs next, and the
    count of blocks in each status. Blocking (reads register.gpkg)."""
    import shapely

    from aerosurvey.campaign.register import NEXT, read_register, status_of

    rows, events = read_register(campaign)
    by_block: dict[str, list[Any]] = {}
    for e in events:
        by_block.setdefault(e.block, []).append(e)
    features = []
    for r in rows:
        status = status_of(r.status, [e for e in by_block.get(r.name, []) if e.key == r.key])
        features.append({"type": "Feature", "geometry": shapely.geometry.mapping(shapely.from_wkb(r.wkb)),
                         "properties": {"name": r.name, "status": status, "folder": r.folder, "area_ha": r.area_ha,
                                        "photos": r.photos, "time_min": r.time_min, "distance_km": r.distance_km,
                                        "sorties": r.sorties, "gsd_cm": r.gsd_cm, "rules_failing": r.rules_failing,
                                        "message": r.message, "next": NEXT.get(status, "").replace("{folder}", r.folder)}})
    counts = Counter(f["properties"]["status"] for f in features)
    return {"name": campaign.name, "statuses": [s for s in STATUSES if counts[s]] + sorted(set(counts) - set(STATUSES)),
            "counts": dict(counts), "blocks": {"type": "FeatureCollection", "features": features}}


def block_folder(campaign: Path, name: str) -> Path:
    """The folder of the register's block `name`; InputError when there is no such block or it has no folder."""
    from aerosurvey.campaign.job import BLOCKS_DIR
    from aerosurvey.campaign.register import read_register

    rows, _ = read_register(campaign)
    row = next((r for r in rows if r.name == name), None)
    if row is None:
        raise InputError(f"block {name!r} is not in {campaign.name}'s register")
    folder = campaign / BLOCKS_DIR / row.folder
    if not row.folder or not folder.is_dir():
        raise InputError(f"block {name!r} has no plan folder ({row.status}: {row.message or 'not planned'})")
    return folder


def block_plan(campaign: Path, name: str) -> dict[str, Any]:
    """A block's plan from its folder: its summary (block.json, as `campaign plan` wrote it), its files and its route
    (home and every positioned item of mission.waypoints, lon/lat) when it has one. Blocking."""
    from aerosurvey.campaign.job import RESULT_FILE
    from aerosurvey.mission.formats.wpl import loads_wpl

    folder = block_folder(campaign, name)
    files = sorted(p.name for p in folder.iterdir() if p.is_file() and not p.name.startswith("."))
    summary = json.loads((folder / RESULT_FILE).read_text(encoding="utf-8")) if RESULT_FILE in files else None
    route = None
    if "mission.waypoints" in files:
        mission = loads_wpl((folder / "mission.waypoints").read_text(encoding="utf-8"), f"{name}/mission.waypoints")
        points = [(mission.home[1], mission.home[0])] + [(it.y, it.x) for it in mission.items if it.x or it.y]
        route = {"type": "LineString", "coordinates": [list(p) for p in points]}
    return {"name": name, "folder": folder.name, "files": files, "summary": summary, "route": route}


def block_file(campaign: Path, name: str, file: str) -> bytes:
    """One file of a block's folder, by its name as `block_plan` lists it. Blocking."""
    folder = block_folder(campaign, name)
    path = folder / Path(file).name
    if Path(file).name != file or file.startswith(".") or not path.is_file():
        raise InputError(f"block {name!r} has no file {file!r}")
    return path.read_bytes()
