"""QGC WPL 110 text missions (MAVProxy, Mission Planner, QGroundControl): write and read.

Line 1 is the header; line 2 is home (sequence 0, current 1, frame 0, command 16, altitude
AMSL); then one line per item 1..n. Fields are tab-separated: seq, current, frame, command,
param1-4, latitude, longitude, altitude, autocontinue.

Numbers are written as the shortest decimal that reads back to the same double, without
an exponent ("49.40012345", "80", "0.00001"): exact, so a file round-trips bit for bit, and
never fewer digits than the mission holds. (pymavlink's `mavwp.save` writes "%f", six
decimals; Mission Planner writes eight decimals for params and lat/lon, six for altitude.)
An unset parameter (NaN) is written as "nan", as pymavlink's "%f" writes it.

The format has no geofence, speeds or names: those are in the .plan file only.
"""

from __future__ import annotations

import math

from aerosurvey.errors import InputError
from aerosurvey.mission import mavlink_ids as mav
from aerosurvey.mission.items import Mission, MissionItem

HEADER = "QGC WPL 110"
VEHICLES = ("copter", "plane")
FIRMWARES = ("ardupilot", "px4")
_FIELDS = ("seq", "current", "frame", "command", "param1", "param2", "param3", "param4",
           "latitude", "longitude", "altitude", "autocontinue")
_WHOLE = {"seq": 2**31 - 1, "current": 1, "frame": 255, "command": 65535, "autocontinue": 1}


def format_number(v: float) -> str:
    """The shortest positional decimal that parses back to `v` ("nan" for NaN; infinity is refused by callers)."""
    text = repr(float(v))
    if text[-2:] == ".0":  # whole numbers, both zeros included ("-0.0" is "0")
        return "0" if text == "-0.0" else text[:-2]
    if "e" in text:
        from decimal import Decimal  # for the rare exponent forms only: not loaded by every plan

        text = format(Decimal(text), "f")
        return text[:-2] if text.endswith(".0") else text
    return text  # "nan" and "inf" as repr writes them


def _num(v: float, where: str, *, nan_ok: bool) -> str:
    if math.isinf(v) or (math.isnan(v) and not nan_ok):
        allowed = "a finite number (or NaN for 'unset')" if nan_ok else "a finite number"
        raise InputError(f"{where} = {v!r} is not allowed: {allowed}")
    return format_number(v)


def _row(seq: int, current: int, it: MissionItem) -> str:
    where = f"mission item {seq}" if seq else "home"
    if isinstance(it.command, bool) or not isinstance(it.command, int) or not 0 <= it.command <= 65535:
        raise InputError(f"{where} command = {it.command!r} is not allowed: a MAV_CMD number 0-65535")
    if isinstance(it.frame, bool) or not isinstance(it.frame, int) or not 0 <= it.frame <= 255:
        raise InputError(f"{where} frame = {it.frame!r} is not allowed: a MAV_FRAME number 0-255")
    pos_ok = not (it.has_position or seq == 0)
    fields = [str(seq), str(current), str(it.frame), str(it.command),
              *(_num(p, f"{where} param{k}", nan_ok=True) for k, p in enumerate(it.params, start=1)),
              _num(it.x, f"{where} latitude", nan_ok=pos_ok), _num(it.y, f"{where} longitude", nan_ok=pos_ok),
              _num(it.z, f"{where} altitude", nan_ok=pos_ok), "1" if it.autocontinue else "0"]
    return "\t".join(fields)


def dumps_wpl(m: Mission) -> str:
    """QGC WPL 110 text: header, home line, one line per item, LF line ends (deterministic)."""
    if len(m.home) != 3:
        raise InputError(f"mission home = {m.home!r} is not allowed: (latitude, longitude, altitude AMSL)")
    lat, lon, alt = m.home
    home = MissionItem(mav.NAV_WAYPOINT, mav.FRAME_GLOBAL, x=lat, y=lon, z=alt)
    rows = [HEADER, _row(0, 1, home)]
    rows += [_row(seq, 0, it) for seq, it in enumerate(m.items, start=1)]
    return "\n".join(rows) + "\n"


def _fields(line: str) -> list[str]:
    """Tab-separated fields as QGroundControl splits them; whitespace-separated as pymavlink does when there is no tab."""
    line = line.strip()
    return line.split("\t") if "\t" in line else line.split()


def _parse_row(fields: list[str], where: str) -> dict[str, float]:
    row: dict[str, float] = {}
    for name, text in zip(_FIELDS, fields):
        text = text.strip()
        if name in _WHOLE:
            try:
                value = int(text)
            except ValueError:
                raise InputError(f"{where} field '{name}' = {text!r} is not allowed: a whole number") from None
            if not 0 <= value <= _WHOLE[name]:
                raise InputError(f"{where} field '{name}' = {value} is not allowed: 0-{_WHOLE[name]}")
            row[name] = value
        else:
            try:
                number = float(text)
            except ValueError:
                raise InputError(f"{where} field '{name}' = {text!r} is not allowed: a number") from None
            if math.isinf(number):
                raise InputError(f"{where} field '{name}' = {text!r} is not allowed: a finite number (or nan)")
            row[name] = number
    return row


def loads_wpl(text: str, source: str = "<string>", vehicle: str = "copter", firmware: str = "ardupilot") -> Mission:
    """A Mission from QGC WPL 110 text; line 2 is home. Errors name `source`, the line number and the field.

    The file says nothing of the vehicle, firmware or speeds: `vehicle` and `firmware` come
    from the caller, speeds are 0.0 and there is no fence. Blank lines and pymavlink's
    '#' comment lines are skipped; CRLF line ends and a UTF-8 byte order mark are accepted.
    """
    if vehicle not in VEHICLES:
        raise InputError(f"vehicle = {vehicle!r} is not allowed: one of {', '.join(VEHICLES)}")
    if firmware not in FIRMWARES:
        raise InputError(f"firmware = {firmware!r} is not allowed: one of {', '.join(FIRMWARES)}")
    lines = text.lstrip("\ufeff").replace("\r\n", "\n").replace("\r", "\n").split("\n")
    header = lines[0].strip()
    if header != HEADER:
        if header.startswith("QGC WPL"):
            raise InputError(f"{source}: line 1 is {header!r}; only '{HEADER}' files (home on line 2) are read")
        raise InputError(f"{source}: line 1 is {header[:40]!r}; a waypoint file starts with '{HEADER}'")
    rows: list[tuple[int, dict[str, float]]] = []
    for n, line in enumerate(lines[1:], start=2):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        where = f"{source}: line {n}"
        fields = _fields(line)
        if len(fields) != len(_FIELDS):
            raise InputError(f"{where} has {len(fields)} fields; {HEADER} lines have {len(_FIELDS)} "
                             "(seq, current, frame, command, param1-4, latitude, longitude, altitude, autocontinue)")
        row = _parse_row(fields, where)
        if row["seq"] != len(rows):
            raise InputError(f"{where} has sequence number {row['seq']}, expected {len(rows)}: "
                             "lines must be numbered 0 (home), 1, 2, ... without gaps")
        rows.append((n, row))
    if not rows:
        raise InputError(f"{source}: no home line; line 2 of a {HEADER} file is home (sequence 0)")
    n, home = rows[0]
    for name in ("latitude", "longitude", "altitude"):
        if math.isnan(home[name]):
            raise InputError(f"{source}: line {n} (home) field '{name}' = nan is not allowed: a finite number")
    items = []
    for n, r in rows[1:]:
        it = MissionItem(int(r["command"]), int(r["frame"]), r["param1"], r["param2"], r["param3"], r["param4"],
                         r["latitude"], r["longitude"], r["altitude"], bool(r["autocontinue"]))
        if it.has_position:
            for name in ("latitude", "longitude", "altitude"):
                if math.isnan(r[name]):
                    raise InputError(f"{source}: line {n} field '{name}' = nan is not allowed: "
                                     f"command {it.command} needs a position")
        items.append(it)
    return Mission(vehicle=vehicle, firmware=firmware, home=(home["latitude"], home["longitude"], home["altitude"]),
                   items=tuple(items), cruise_speed=0.0, hover_speed=0.0)
