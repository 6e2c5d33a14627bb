"""resume.json: what `aerosurvey resume` wrote. Its one writer (`dumps`) and its one reader (`loads`).

Schema `aerosurvey-resume`, version 1: the mission, the plan folder it resumes, the station of
the last photo taken, the stations left, and per sortie its files, first and last station,
photos, time (s), distance (m), mission items and launch point.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aerosurvey.errors import InputError

SCHEMA, VERSION = "aerosurvey-resume", 1
FILE = "resume.json"


@dataclass(frozen=True)
class ResumedSortie:
    files: tuple[str, ...]  # .plan first, then .waypoints
    first_station: str
    last_station: str
    photos: int
    time_s: float


@dataclass(frozen=True)
class Resume:
    mission: str
    plan: str
    after_station: str
    sorties: tuple[ResumedSortie, ...]


def dumps(mission: str, plan: str, after_station: str, sorties: list[dict[str, Any]]) -> str:
    """The text of resume.json; each sortie a dict with the keys the module docstring names."""
    doc = {"schema": SCHEMA, "schema_version": VERSION, "mission": mission, "plan": plan, "after_station": after_station,
           "stations_left": sum(int(s["photos"]) for s in sorties), "sorties": sorties}
    return json.dumps(doc, indent=1, ensure_ascii=False) + "\n"


def loads(text: str, where: str = FILE) -> Resume:
    """resume.json read and checked; InputError in one line naming what is wrong."""
    try:
        doc = json.loads(text)
    except ValueError as exc:
        raise InputError(f"{where}: not valid JSON: {exc}") from None
    if not isinstance(doc, dict) or doc.get("schema") != SCHEMA:
        raise InputError(f"{where} is not a resume.json of `aerosurvey resume` (schema = "
                         f"{doc.get('schema') if isinstance(doc, dict) else None!r})")
    if doc.get("schema_version") != VERSION:
        raise InputError(f"{where}: schema_version = {doc.get('schema_version')!r}; this aerosurvey reads version {VERSION}")
    try:
        sorties = tuple(ResumedSortie(tuple(s["files"]), str(s["first_station"]), str(s["last_station"]), int(s["photos"]),
                                      float(s["time_s"])) for s in doc["sorties"])
        return Resume(str(doc["mission"]), str(doc["plan"]), str(doc["after_station"]), sorties)
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f"{where}: a key is missing or of the wrong type ({exc!r})") from None


def read(folder: Path) -> Resume:
    path = folder / FILE
    try:
        return loads(path.read_text(encoding="utf-8"), str(path))
    except OSError as exc:
        raise InputError(f"{str(folder)!r} has no readable {FILE} ({exc.strerror}): give a folder `aerosurvey resume` wrote") from None
