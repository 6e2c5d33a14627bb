"""QGC WPL 110 text missions (MAVProxy, Mission Planner): write and read.

Line 0 is home (current = 1, frame 0, alt AMSL); then one line per item, tab-separated:
seq, current, frame, command, param1-4, latitude, longitude, altitude, autocontinue.
"""

from __future__ import annotations

from aerosurvey.errors import InputError
from aerosurvey.mission import mavlink_ids as mav
from aerosurvey.mission.items import Mission, MissionItem

HEADER = "QGC WPL 110"


def _g(v: float, digits: int) -> str:
    text = f"{v:.{digits}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def dumps_wpl(m: Mission) -> str:
    lat, lon, alt = m.home
    rows = [HEADER, "\t".join(["0", "1", str(mav.FRAME_GLOBAL), str(mav.NAV_WAYPOINT), "0", "0", "0", "0",
                               _g(lat, 8), _g(lon, 8), _g(alt, 3), "1"])]
    for seq, it in enumerate(m.items, start=1):
        rows.append("\t".join([str(seq), "0", str(it.frame), str(it.command), *(_g(p, 6) for p in it.params),
                               _g(it.x, 8), _g(it.y, 8), _g(it.z, 3), "1" if it.autocontinue else "0"]))
    return "\n".join(rows) + "\n"


def loads_wpl(text: str, source: str = "<string>", vehicle: str = "copter", firmware: str = "ardupilot") -> Mission:
    lines = [ln for ln in text.replace("\r\n", "\n").split("\n")]
    while lines and not lines[-1].strip():
        lines.pop()
    if not lines or not lines[0].strip().startswith("QGC WPL 110"):
        raise InputError(f"{source}: line 1 is {lines[0][:40]!r}; a waypoint file starts with 'QGC WPL 110'" if lines else f"{source}: empty file")
    rows = []
    for n, ln in enumerate(lines[1:], start=2):
        fields = ln.split("\t") if "\t" in ln else ln.split()
        if len(fields) != 12:
            raise InputError(f"{source}: line {n} has {len(fields)} fields; QGC WPL 110 lines have 12")
        try:
            vals = [float(f) for f in fields]
        except ValueError:
            bad = next(f for f in fields if not _is_number(f))
            raise InputError(f"{source}: line {n}: {bad!r} is not a number") from None
        if int(vals[0]) != n - 2:
            raise InputError(f"{source}: line {n} has sequence number {int(vals[0])}, expected {n - 2}")
        rows.append(vals)
    if not rows:
        raise InputError(f"{source}: no home line")
    home = rows[0]
    items = tuple(MissionItem(int(r[3]), int(r[2]), r[4], r[5], r[6], r[7], r[8], r[9], r[10], bool(int(r[11])))
                  for r in rows[1:])
    return Mission(vehicle=vehicle, firmware=firmware, home=(home[8], home[9], home[10]), items=items,
                   cruise_speed=0.0, hover_speed=0.0)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
