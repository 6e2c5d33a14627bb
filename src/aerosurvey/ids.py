"""The ids that link a plan's lines, stations and sorties to mission files, logs and QA.

The one maker and the one parser of each id format (docs/manifest.md):

- line    ``P<pass>-L<line:03d>``               ``P1-L003``
- run     ``P<pass>-L<line:03d>-R<part>``       ``P1-L003-R1`` (a line cut by an exclusion has parts)
- station ``P<pass>-L<line:03d>-S<n:04d>``      ``P1-L003-S0012`` (n counted along the line's +x)
- sortie  ``S<k:02d>``                          ``S02``, its files ``sortie-02.plan`` / ``.waypoints``
- event   ``E<i:05d>``                          ``E00007``, a flown photo in a log's order

Every number is 1-based; wider numbers than the padding are written in full.
"""

from __future__ import annotations

import re
from typing import NamedTuple

from aerosurvey.errors import InputError

#: Regular expressions of the formats (also the `pattern`s of data/manifest.schema.json).
LINE_PATTERN = r"^P([0-9]+)-L([0-9]{3,})$"
RUN_PATTERN = r"^P([0-9]+)-L([0-9]{3,})-R([0-9]+)$"
STATION_PATTERN = r"^P([0-9]+)-L([0-9]{3,})-S([0-9]{4,})$"
SORTIE_PATTERN = r"^S([0-9]{2,})$"
EVENT_PATTERN = r"^E([0-9]{5,})$"

_LINE, _RUN, _STATION, _SORTIE = (re.compile(p) for p in (LINE_PATTERN, RUN_PATTERN, STATION_PATTERN, SORTIE_PATTERN))


class LineId(NamedTuple):
    pass_index: int
    line: int


class RunId(NamedTuple):
    pass_index: int
    line: int
    part: int


class StationId(NamedTuple):
    pass_index: int
    line: int
    station: int


def _positive(**numbers: int) -> None:
    for name, v in numbers.items():
        if int(v) != v or v < 1:
            raise ValueError(f"{name} = {v!r}: ids count from 1")


def line_id(pass_index: int, line: int) -> str:
    """``P1-L003``: pass and line number, both from 1."""
    _positive(pass_index=pass_index, line=line)
    return f"P{pass_index}-L{line:03d}"


def run_id(pass_index: int, line: int, part: int) -> str:
    """``P1-L003-R1``: a photo run, the `part`-th piece of its line."""
    _positive(part=part)
    return f"{line_id(pass_index, line)}-R{part}"


def station_id(pass_index: int, line: int, station: int) -> str:
    """``P1-L003-S0012``: the `station`-th photo position along the line's +x direction."""
    _positive(station=station)
    return f"{line_id(pass_index, line)}-S{station:04d}"


def sortie_id(k: int) -> str:
    """``S02``: the k-th sortie of a plan."""
    _positive(sortie=k)
    return f"S{k:02d}"


def sortie_stem(k: int) -> str:
    """``sortie-02``: the name of the k-th sortie's mission files without the suffix."""
    _positive(sortie=k)
    return f"sortie-{k:02d}"


def event_id(i: int) -> str:
    """``E00007``: the i-th camera event of a log (flown photos in place of stations)."""
    _positive(event=i)
    return f"E{i:05d}"


def _parse(rx: re.Pattern[str], text: str, kind: str, example: str) -> tuple[int, ...]:
    m = rx.match(text) if isinstance(text, str) else None
    if m is None:
        raise InputError(f"{kind} id {text!r} is not allowed: the form is {example}")
    return tuple(int(g) for g in m.groups())


def parse_line_id(text: str) -> LineId:
    return LineId(*_parse(_LINE, text, "line", "P<pass>-L<line>, e.g. P1-L003"))


def parse_run_id(text: str) -> RunId:
    return RunId(*_parse(_RUN, text, "run", "P<pass>-L<line>-R<part>, e.g. P1-L003-R1"))


def parse_station_id(text: str) -> StationId:
    return StationId(*_parse(_STATION, text, "station", "P<pass>-L<line>-S<n>, e.g. P1-L003-S0012"))


def parse_sortie_id(text: str) -> int:
    return _parse(_SORTIE, text, "sortie", "S<k>, e.g. S02")[0]


def line_of_station(text: str) -> str:
    """The line id of a station id (``P1-L003-S0012`` → ``P1-L003``)."""
    s = parse_station_id(text)
    return line_id(s.pass_index, s.line)
