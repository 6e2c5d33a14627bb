"""A minimal DataFlash writer for tests: FMT messages, camera events (CAM), mount angles (MNT), servo
outputs (RCOU), parameters (PARM), flight modes (MODE), the firmware line (MSG), mission items (CMD),
and a flight's GPS fixes, attitude (ATT) and camera events in the layouts ArduPilot 4.x logs them."""

from __future__ import annotations

import struct

HEAD = b"\xa3\x95"


#: DataFlash format characters as struct characters (c, C, e, L are scaled integers)
_STRUCT = {"Q": "Q", "L": "i", "f": "f", "B": "B", "M": "B", "H": "H", "I": "I", "c": "h", "C": "H", "e": "i",
           "n": "4s", "N": "16s", "Z": "64s"}


def _fmt(typ: int, name: str, fmt: str, cols: str) -> bytes:
    length = 3 + struct.calcsize("<" + "".join(_STRUCT[c] for c in fmt))
    return HEAD + bytes([128]) + struct.pack("<BB4s16s64s", typ, length, name.encode(), fmt.encode(), cols.encode())


def camera_log(events: list[tuple[float, float, float, float, float]], yaw: list[float] | None = None) -> bytes:
    """(time_s, lat, lon, alt_amsl, rel_alt) per event, level; the vehicle's yaw (degrees from
    true north, as ArduPilot logs it) per event, or 0."""
    out = bytearray(_fmt(128, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns"))
    out += _fmt(200, "CAM", "QLLfffff", "TimeUS,Lat,Lng,Alt,RelAlt,R,P,Y")
    for i, (t, lat, lon, alt, rel) in enumerate(events):
        out += HEAD + bytes([200]) + struct.pack("<Qiifffff", int(t * 1e6), round(lat * 1e7), round(lon * 1e7),
                                                 alt, rel, 0.0, 0.0, yaw[i] if yaw is not None else 0.0)
    return bytes(out)


def mount_log(cams: list[tuple[float, float, float, float]], mounts: list[tuple[float, float, float, float]],
              outputs: list[tuple[float, dict[int, int], tuple[float, float, float] | None]] = (),
              params: dict[str, float] | None = None) -> bytes:
    """CAM messages (time_s, vehicle roll, pitch, yaw), MNT messages (time_s, roll, pitch, yaw
    relative to the body, as its Roll, Pitch and YawB), RCOU messages (time_s, {channel: PWM}; the
    other channels 0), each with the ATT message of the same loop (the vehicle's roll, pitch, yaw
    then; none for None), and PARM messages (name: value, before everything else), in time order,
    as ArduPilot writes them (degrees)."""
    out = bytearray(_fmt(128, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns"))
    out += _fmt(200, "CAM", "QLLfffff", "TimeUS,Lat,Lng,Alt,RelAlt,R,P,Y")
    out += _fmt(201, "MNT", "QBfffffff", "TimeUS,I,DRoll,Roll,DPitch,Pitch,DYawB,YawB,DYawE")
    out += _fmt(204, "RCOU", "Q" + "H" * 14, "TimeUS," + ",".join(f"C{c}" for c in range(1, 15)))
    out += _fmt(205, "PARM", "QNff", "TimeUS,Name,Value,Default")
    out += _fmt(206, "ATT", "Qffffff", "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw")
    for name, value in (params or {}).items():
        out += HEAD + bytes([205]) + struct.pack("<Q16sff", 0, name.encode(), value, value)
    rows = [(t, 200, struct.pack("<Qiifffff", int(t * 1e6), 495000000, 153000000, 80.0, 80.0, r, p, y)) for t, r, p, y in cams]
    rows += [(t, 201, struct.pack("<QBfffffff", int(t * 1e6), 0, 0.0, r, -45.0, p, 0.0, y, 0.0)) for t, r, p, y in mounts]
    rows += [(t, 204, struct.pack("<Q" + "H" * 14, int(t * 1e6), *(pwm.get(c, 0) for c in range(1, 15)))) for t, pwm, _ in outputs]
    rows += [(t, 206, struct.pack("<Qffffff", int(t * 1e6), *(v for v in a for _ in range(2)))) for t, _, a in outputs
             if a is not None]
    for _, typ, body in sorted(rows, key=lambda row: row[0]):
        out += HEAD + bytes([typ]) + body
    return bytes(out)


def survey_log(events: list[tuple[float, float, float, float, float]], modes: list[tuple[float, int, int]],
               firmware: str | None = "ArduCopter V4.5.7 (2a3dc4b7)") -> bytes:
    """CAM messages (time_s, lat, lon, alt_amsl, rel_alt; nadir), MODE messages (time_s, mode
    number, reason) and, unless None, the firmware line ArduPilot writes first (MSG), in time
    order, with ArduPilot 4's layouts."""
    out = bytearray(_fmt(128, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns"))
    out += _fmt(200, "CAM", "QLLfffff", "TimeUS,Lat,Lng,Alt,RelAlt,R,P,Y")
    out += _fmt(202, "MODE", "QMBB", "TimeUS,Mode,ModeNum,Rsn")
    out += _fmt(203, "MSG", "QZ", "TimeUS,Message")
    rows = [(0.0, 203, struct.pack("<Q64s", 0, firmware.encode()))] if firmware is not None else []
    rows += [(t, 200, struct.pack("<Qiifffff", int(t * 1e6), round(lat * 1e7), round(lon * 1e7), alt, rel, 0.0, 0.0, 0.0))
             for t, lat, lon, alt, rel in events]
    rows += [(t, 202, struct.pack("<QBBB", int(t * 1e6), mode, mode, reason)) for t, mode, reason in modes]
    for _, typ, body in sorted(rows, key=lambda row: row[0]):
        out += HEAD + bytes([typ]) + body
    return bytes(out)


#: one mission item as ArduPilot's CMD message logs it: command, frame, param1-4, latitude, longitude, altitude
Cmd = tuple[int, int, float, float, float, float, float, float, float]


def mission_log(writes: list[tuple[float, list[Cmd]]], events: list[tuple[float, float, float, float, float]]) -> bytes:
    """CMD messages and CAM events in time order: each write (time_s, items) numbers its items from 0
    under one CTot, as ArduPilot writes its whole mission (item 0 home); each event (time_s, lat,
    lon, alt_amsl, rel_alt), nadir."""
    out = bytearray(_fmt(128, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns"))
    out += _fmt(200, "CAM", "QLLfffff", "TimeUS,Lat,Lng,Alt,RelAlt,R,P,Y")
    out += _fmt(202, "CMD", "QHHHffffLLfB", "TimeUS,CTot,CNum,CId,Prm1,Prm2,Prm3,Prm4,Lat,Lng,Alt,Frame")
    rows = []
    for t, items in writes:
        for k, (cmd, frame, p1, p2, p3, p4, lat, lon, alt) in enumerate(items):
            rows.append((t, 202, struct.pack("<QHHHffffiifB", int(t * 1e6), len(items), k, cmd, p1, p2, p3, p4,
                                             round(lat * 1e7), round(lon * 1e7), alt, frame)))
    rows += [(t, 200, struct.pack("<Qiifffff", int(t * 1e6), round(lat * 1e7), round(lon * 1e7), alt, rel, 0.0, 0.0, 0.0))
             for t, lat, lon, alt, rel in events]
    for _, typ, body in sorted(rows, key=lambda row: row[0]):
        out += HEAD + bytes([typ]) + body
    return bytes(out)


#: the layouts of ArduPilot 4.x (as in tests/data's SITL logs)
GPS = (201, "GPS", "QBBIHBcLLeffffB", "TimeUS,I,Status,GMS,GWk,NSats,HDop,Lat,Lng,Alt,Spd,GCrs,VZ,Yaw,U")
ATT = (202, "ATT", "QffffffB", "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,AEKF")
CAM = (200, "CAM", "QBHIHLLeeeccC", "TimeUS,I,Img,GPSTime,GPSWeek,Lat,Lng,Alt,RelAlt,GPSAlt,R,P,Y")


def _message(layout: tuple[int, str, str, str], *values: float | int) -> bytes:
    typ, _, fmt, _ = layout
    return HEAD + bytes([typ]) + struct.pack("<" + "".join(_STRUCT[c] for c in fmt), *values)


def flight_log(fixes: list[tuple[float, int, int, float, float, float]],
               attitudes: list[tuple[float, float, float, float]],
               cams: list[tuple[float, int, int, float, float, float, float, float, float, float]]) -> bytes:
    """A flight as ArduPilot logs it, in time order:
    fixes (log time s, GPS week, GPS ms of week, lat, lon, alt AMSL m),
    attitudes (time s, roll, pitch, yaw degrees),
    cams (time s, GPS week, GPS ms of the last fix, lat, lon, alt AMSL, rel alt, roll, pitch, yaw 0..360)."""
    out = bytearray(_fmt(128, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns"))
    for layout in (GPS, ATT, CAM):
        out += _fmt(*layout)
    rows = [(t, _message(GPS, round(t * 1e6), 0, 6, ms, week, 12, 70, round(lat * 1e7), round(lon * 1e7), round(alt * 100),
                         0.0, 0.0, 0.0, 0.0, 1)) for t, week, ms, lat, lon, alt in fixes]
    rows += [(t, _message(ATT, round(t * 1e6), r, r, p, p, y, y, 3)) for t, r, p, y in attitudes]
    rows += [(t, _message(CAM, round(t * 1e6), 0, n + 1, ms, week, round(lat * 1e7), round(lon * 1e7), round(alt * 100),
                          round(rel * 100), round(alt * 100), round(r * 100), round(p * 100), round(y * 100)))
             for n, (t, week, ms, lat, lon, alt, rel, r, p, y) in enumerate(cams)]
    for _, body in sorted(rows, key=lambda row: row[0]):
        out += body
    return bytes(out)
