"""Ids of lines, runs, stations and sorties: made and parsed here and nowhere else.

- line    ``P1-L003``       pass 1, the third line of that pass (by ordinate)
- run     ``P1-L003-R2``    the second photo run on that line (a line cut by a notch or a zone)
- station ``P1-L003-S0042`` the 42nd station along that line (by +x of the line frame)
- sortie  ``S01``           the first battery's flight
- event   ``E00007``        the seventh camera event of a flight log (flown photos in place of stations)
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from typing import NamedTuple

from aerosurvey.errors import InputError

_STATION = re.compile(r"^P(\d+)-L(\d{3,})-S(\d{4,})$")
_PASS = re.compile(r"^P(\d+)-L\d{3,}(?:$|-)")


class StationRef(NamedTuple):
    pass_index: int  # 1-based
    line: int  # 0-based, as the planner counts
    station: int  # 0-based


def line_id(pass_index: int, line: int) -> str:
    """`line` counts from 0."""
    return f"P{pass_index}-L{line + 1:03d}"


def run_id(pass_index: int, line: int, part: int) -> str:
    """`line` and `part` count from 0."""
    return f"{line_id(pass_index, line)}-R{part + 1}"


def station_id(pass_index: int, line: int, station: int) -> str:
    """`line` and `station` count from 0."""
    return f"{line_id(pass_index, line)}-S{station + 1:04d}"


def look_pass_index(pass_index: int, look: int, passes: int) -> int:
    """The pass number of a pass's `look` (0 its first aim, `Pass.looks` from 1) in a plan whose
    highest pass number is `passes`: the first aim keeps its pass's, the others follow every pass
    (one pass of five looks: P1 … P5, the numbers five passes would have)."""
    if not 0 < pass_index <= passes or look < 0:
        raise ValueError(f"look ids: pass {pass_index} of {passes}, look {look}")
    return pass_index + look * passes


def station_ids_of_lines(lines: Iterable[tuple[int, int, list[int]]]) -> list[str]:
    """`station_id` of each station of many (pass, line, stations), one after another: each
    station number's text is made once (a plan has thousands of stations, but only as many
    numbers as its longest line has stations), then only joined to its line's part. Stations
    count from 0 (ValueError for a negative one)."""
    lines = list(lines)
    used = [st for _, _, st in lines if st]
    if any(min(st) < 0 for st in used):
        raise ValueError(f"station ids: station numbers count from 0, got {min(min(st) for st in used)}")
    texts = [f"{s + 1:04d}" for s in range(1 + max((max(st) for st in used), default=-1))]
    out: list[str] = []
    for p, line, stations in lines:
        prefix = f"{line_id(p, line)}-S"
        out += [prefix + texts[s] for s in stations]
    return out


def parse_station_id(text: str) -> StationRef:
    """The parts of a station id; ValueError for text that is not one."""
    m = _STATION.match(text)
    if m is None:
        raise ValueError(f"{text!r} is not a station id (P<pass>-L<line>-S<station>, e.g. P1-L003-S0042)")
    return StationRef(int(m.group(1)), int(m.group(2)) - 1, int(m.group(3)) - 1)


def station_index(station_ids: Sequence[str], station: str) -> int:
    """The index of `station` among a plan's stations (flight order); InputError naming the
    plan's first and last station when it has no such station."""
    try:
        return list(station_ids).index(station)
    except ValueError:
        first, last = (station_ids[0], station_ids[-1]) if station_ids else ("-", "-")
        raise InputError(f"station {station!r} is not a station of this plan ({len(station_ids)} stations, "
                         f"{first} to {last})") from None


def pass_of(text: str) -> int | None:
    """The pass of a line, run or station id, or of a mission item's tag that starts with one
    (``P1-L003-R2:lead-in``); None for any other text (``takeoff``, ``detour`` …)."""
    m = _PASS.match(text)
    return int(m.group(1)) if m else None


def sortie_id(number: int) -> str:
    """`number` counts from 1."""
    return f"S{number:02d}"


def sortie_file_stem(number: int) -> str:
    return f"sortie-{number:02d}"


def resume_file_stem(number: int) -> str:
    """The mission files of a resumed flight's sorties (`aerosurvey resume`)."""
    return f"resume-{number:02d}"


def event_id(number: int) -> str:
    """``E00007``: a flown photo of a log (camera events in the log's order), in place of a station;
    `number` counts from 1."""
    return f"E{number:05d}"


def day_photo_id(record: int, photo: str) -> str:
    """``R02-E00007``: photo `photo` (an :func:`event_id`) of record `record` (from 1) of a day of flights."""
    return f"R{record:02d}-{photo}"


#: The formats as patterns (the `pattern`s of data/manifest.schema.json; a test holds them equal).
LINE_PATTERN = r"^P([0-9]+)-L([0-9]{3,})$"
RUN_PATTERN = r"^P([0-9]+)-L([0-9]{3,})-R([0-9]+)$"
STATION_PATTERN = _STATION.pattern
SORTIE_PATTERN = r"^S([0-9]{2,})$"
