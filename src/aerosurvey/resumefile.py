"""resume.json: what `aerosurvey resume` wrote. Its one writer (`dumps`) and its one reader (`loads`).

Schema `aerosurvey-resume`, version 2: the mission, the plan folder it resumes, the station the
resumed flight starts from (the first of the flight order not photographed as the mission
asked), the stations counted as done and what was counted and why (`counted`, one line each),
the stations left, and per sortie its files, first and last station, photos, time (s),
distance (m), mission items and launch point. (Version 1 named the station of the last photo
matched, `after_station`, and resumed after it.)
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aerosurvey.errors import InputError

SCHEMA, VERSION = "aerosurvey-resume", 2
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
    from_station: str
    stations_done: int
    counted: tuple[str, ...]
    sorties: tuple[ResumedSortie, ...]


def dumps(mission: str, plan: str, from_station: str, stations_done: int, counted: tuple[str, ...],
          sorties: list[dict[str, Any]]) -> str:
    """The text of resume.json; each sortie a dict with the keys the module docstring names."""
    doc = {"schema": SCHEMA, "schema_version": VERSION, "mission": mission, "plan": plan, "from_station": from_station,
           "stations_done": stations_done, "counted": list(counted),
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
        raise InputError(f"{where}: schema_version = {doc.get('schema_version')!r}; this aerosurvey reads version {VERSION}: "
                         "run `aerosurvey resume` again (or upgrade aerosurvey for a newer file)")
    try:
        sorties = tuple(ResumedSortie(tuple(s["files"]), str(s["first_station"]), str(s["last_station"]), int(s["photos"]),
                                      float(s["time_s"])) for s in doc["sorties"])
        counted = doc["counted"]
        if not isinstance(counted, list) or not all(isinstance(line, str) for line in counted):
            raise TypeError(f"counted = {counted!r} is not a list of texts")
        return Resume(str(doc["mission"]), str(doc["plan"]), str(doc["from_station"]), int(doc["stations_done"]),
                      tuple(counted), sorties)
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f"{where}: a key is missing or of the wrong type ({exc!r})") from None


def read(folder: Path) -> Resume:
    path = folder / FILE
    try:
        return loads(path.read_text(encoding="utf-8"), str(path))
    except OSError as exc:
        raise InputError(f"{str(folder)!r} has no readable {FILE} ({exc.strerror}): give a folder `aerosurvey resume` wrote") from None
