"""events.csv and log_report.json, the outputs of `aerosurvey log ingest`: one writer and
one reader of each, versioned, with schemas shipped in the package (data/events.schema.json,
data/log_report.schema.json; docs/flight-logs.md is checked against them).

events.csv starts with the line ``# aerosurvey-events 2`` (schema name and version), then
the CSV header and one row per camera event. Spreadsheets show that first line as a row
of its own; pandas reads the file with ``read_csv(path, comment="#")``.
"""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aerosurvey import __version__, schemas
from aerosurvey.errors import InputError
from aerosurvey.flight import DAY_FILE

EVENTS_SCHEMA = "aerosurvey-events"
EVENTS_VERSION = 2
REPORT_SCHEMA = "aerosurvey-log-report"
REPORT_VERSION = 2  # 2: a folder of photos as the flight record (`photos`), the flight modes (`modes`)
DAY_SCHEMA = "aerosurvey-day-report"
DAY_VERSION = 1

#: The columns in file order, from the schema; the decimals each number is written with.
COLUMNS: tuple[str, ...] = tuple(schemas.schema("events")["properties"]["rows"]["items"]["properties"])
_DECIMALS = {"time_s": 3, "lat": 8, "lon": 8, "alt_m": 2, "rel_alt_m": 2, "roll": 2, "pitch": 2, "yaw": 2,
             "distance_m": 3, "ground_m": 2, "agl_m": 2}
_FIRST_LINE = f"# {EVENTS_SCHEMA} {EVENTS_VERSION}"
_REDO = "run `aerosurvey log ingest` again"


@dataclass(frozen=True)
class EventRows:
    """events.csv as columns: numbers are NaN and texts None where a cell is empty."""

    event: np.ndarray
    time_s: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    alt_m: np.ndarray
    rel_alt_m: np.ndarray
    roll: np.ndarray
    pitch: np.ndarray
    yaw: np.ndarray
    mode: tuple[str | None, ...]  # the flight mode at the event (flight/modes.py)
    station: tuple[str | None, ...]
    distance_m: np.ndarray
    ground_m: np.ndarray
    agl_m: np.ndarray

    def __len__(self) -> int:
        return len(self.event)


def _cell(key: str, v: Any) -> str:
    if v is None:
        return ""
    if key in _DECIMALS:
        f = float(v)
        return f"{f:.{_DECIMALS[key]}f}" if math.isfinite(f) else ""
    return str(v)


def dumps_events(columns: Mapping[str, Sequence[Any] | np.ndarray]) -> str:
    """The text of events.csv from its columns (every column of COLUMNS, equal lengths; None/NaN: empty)."""
    missing = [c for c in COLUMNS if c not in columns]
    if missing or set(columns) - set(COLUMNS):
        raise ValueError(f"events.csv columns {sorted(columns)}; expected {list(COLUMNS)}")
    n = len(columns["event"])
    buf = io.StringIO()
    buf.write(_FIRST_LINE + "\n")
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(COLUMNS)
    cols = [columns[c] for c in COLUMNS]
    for i in range(n):
        w.writerow([_cell(c, col[i]) for c, col in zip(COLUMNS, cols)])
    return buf.getvalue()


def loads_events(text: str, where: str = "events.csv") -> EventRows:
    """Read events.csv text written by :func:`dumps_events`; a one-line error for anything else."""
    first, _, rest = text.partition("\n")
    parts = first.strip().lstrip("#").split()
    if not first.startswith("#") or len(parts) != 2 or parts[0] != EVENTS_SCHEMA:
        raise InputError(f"{where} does not start with {_FIRST_LINE!r}: not an events.csv of `aerosurvey log ingest` "
                         "(an older aerosurvey wrote none: run `aerosurvey log ingest` again)")
    schemas.check_version(where, "events", int(parts[1]) if parts[1].isdigit() else parts[1], EVENTS_VERSION, _REDO)
    reader = csv.reader(io.StringIO(rest))
    header = next(reader, None)
    if header is None or tuple(header) != COLUMNS:
        raise InputError(f"{where}: columns {header} are not allowed: events schema {EVENTS_VERSION} has {list(COLUMNS)}")
    props = schemas.schema("events")["properties"]["rows"]["items"]["properties"]
    rows = []
    for k, rec in enumerate(reader, start=3):
        if len(rec) != len(COLUMNS):
            raise InputError(f"{where} line {k}: {len(rec)} cells, the header has {len(COLUMNS)}")
        row: dict[str, Any] = {}
        for c, v in zip(COLUMNS, rec):
            kind = props[c]["type"]
            kinds = kind if isinstance(kind, list) else [kind]
            if v == "":
                row[c] = None
            elif "string" in kinds:
                row[c] = v
            else:
                try:
                    row[c] = int(v) if "integer" in kinds else float(v)
                except ValueError:
                    raise InputError(f"{where} line {k}: {c} = {v!r} is not a number") from None
        rows.append(row)
    err = schemas.first_error("events", {"schema": EVENTS_SCHEMA, "schema_version": EVENTS_VERSION, "rows": rows})
    if err is not None:
        raise InputError(f"{where} does not match events schema {EVENTS_VERSION}: {err.replace('rows[', 'row [')}")

    def num(c: str) -> np.ndarray:
        return np.array([np.nan if r[c] is None else r[c] for r in rows], float)

    return EventRows(np.array([r["event"] for r in rows], int), num("time_s"), num("lat"), num("lon"), num("alt_m"),
                     num("rel_alt_m"), num("roll"), num("pitch"), num("yaw"), tuple(r["mode"] for r in rows),
                     tuple(r["station"] for r in rows),
                     num("distance_m"), num("ground_m"), num("agl_m"))


def read_events_csv(path: Path) -> EventRows:
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"{path.name} is not text: {exc}") from None
    except OSError as exc:
        raise InputError(f"{str(path)!r} cannot be read: {exc.strerror}") from None
    return loads_events(text, path.name)


#: the JSON reports: schema name -> (schema id, version, file name, what it is called)
_REPORTS = {"log_report": (REPORT_SCHEMA, REPORT_VERSION, "log_report.json", "log report"),
            "day_report": (DAY_SCHEMA, DAY_VERSION, DAY_FILE, "day report")}


def _document(name: str, body: Mapping[str, Any]) -> dict[str, Any]:
    schema_id, version, file, _ = _REPORTS[name]
    doc = {"schema": schema_id, "schema_version": version, "aerosurvey_version": __version__, **body}
    err = schemas.first_error(name, doc)
    if err is not None:
        raise ValueError(f"{file} does not match its schema: {err}")
    return doc


def _loads(name: str, text: str | bytes, where: str) -> dict[str, Any]:
    schema_id, version, _, label = _REPORTS[name]
    try:
        doc = json.loads(text)
    except (ValueError, UnicodeDecodeError) as exc:
        raise InputError(f"{where} is not valid JSON: {exc}") from None
    if not isinstance(doc, dict) or doc.get("schema") != schema_id:
        got = doc.get("schema") if isinstance(doc, dict) else type(doc).__name__
        raise InputError(f"{where} is not a {label} of `aerosurvey log ingest` (schema = {got!r}): run it again")
    schemas.check_version(where, label, doc.get("schema_version"), version, _REDO, str(doc.get("aerosurvey_version", "?")))
    schemas.check(name, doc, where, label, version)
    return doc


def _read(name: str, path: Path) -> dict[str, Any]:
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise InputError(f"{str(path)!r} cannot be read: {exc.strerror}") from None
    return _loads(name, data, path.name)


def report_document(body: Mapping[str, Any]) -> dict[str, Any]:
    """A log report with its schema header, checked against the schema (a failure is a bug: ValueError)."""
    return _document("log_report", body)


def dumps_report(body: Mapping[str, Any]) -> str:
    """The text of log_report.json."""
    return json.dumps(report_document(body), indent=1, allow_nan=False) + "\n"


def loads_report(text: str | bytes, where: str = "log_report.json") -> dict[str, Any]:
    """A log report's data, checked against its schema and version."""
    return _loads("log_report", text, where)


def read_report(path: Path) -> dict[str, Any]:
    return _read("log_report", path)


def day_document(body: Mapping[str, Any]) -> dict[str, Any]:
    """A day report (day_report.json: a day of flights, flight/day.py) with its schema header,
    checked against the schema (a failure is a bug: ValueError)."""
    return _document("day_report", body)


def dumps_day(body: Mapping[str, Any]) -> str:
    """The text of day_report.json."""
    return json.dumps(day_document(body), indent=1, allow_nan=False) + "\n"


def read_day(path: Path) -> dict[str, Any]:
    """A day report's data, checked against its schema and version."""
    return _read("day_report", path)
