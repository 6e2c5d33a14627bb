"""A minimal PX4 ULog writer for tests (the format of PX4's logger, docs.px4.io "ULog File Format"):
the file header, one format ('F') and one subscription ('A') per topic, then data ('D') messages
in time order. Written field by field with struct, not with pyulog (which aerosurvey reads them with)."""

from __future__ import annotations

import struct
from typing import Any

MAGIC = b"ULog\x01\x12\x35"
_STRUCT = {"uint64_t": "Q", "uint32_t": "I", "uint16_t": "H", "uint8_t": "B", "int8_t": "b", "int32_t": "i", "float": "f",
           "double": "d", "bool": "?"}


def _message(kind: str, payload: bytes) -> bytes:
    return struct.pack("<HB", len(payload), ord(kind)) + payload


def ulog(topics: dict[str, list[tuple[str, str]]], rows: list[tuple[str, dict[str, Any]]]) -> bytes:
    """A ULog of `topics` (name -> [(type, field)], the first field `uint64_t timestamp`) holding
    `rows` (topic, {field: value}) in the order given; a field a row leaves out is 0."""
    out = bytearray(MAGIC + b"\x00" + struct.pack("<Q", 0))
    ids = {}
    for k, (name, fields) in enumerate(topics.items()):
        out += _message("F", f"{name}:{''.join(f'{t} {f};' for t, f in fields)}".encode())
        ids[name] = k
    for name, k in ids.items():
        out += _message("A", struct.pack("<BH", 0, k) + name.encode())
    for name, values in rows:
        fields = topics[name]
        body = struct.pack("<" + "".join(_STRUCT[t] for t, _ in fields), *(values.get(f, 0) for _, f in fields))
        out += _message("D", struct.pack("<H", ids[name]) + body)
    return bytes(out)


def _code(field_type: str) -> str:
    """A field's struct code: "float[4]" is four floats."""
    base, _, count = field_type.partition("[")
    return (count.rstrip("]") if count else "") + _STRUCT[base]


def ulog_of_rows(topics: dict[str, tuple[list[tuple[str, str]], list[tuple[float | int, ...]]]]) -> bytes:
    """topics: name -> ((type, name) of each field, the first "uint64_t timestamp"; rows of values in
    field order, arrays flattened), written in time order across the topics, after PX4's flag bits."""
    out = bytearray(MAGIC + bytes([1]) + struct.pack("<Q", 0))
    out += _message("B", bytes(16) + struct.pack("<3Q", 0, 0, 0))
    for name, (fields, _) in topics.items():
        out += _message("F", (name + ":" + "".join(f"{t} {n};" for t, n in fields)).encode())
    for msg_id, name in enumerate(topics):
        out += _message("A", struct.pack("<BH", 0, msg_id) + name.encode())
    data = []
    for msg_id, (fields, rows) in enumerate(topics.values()):
        code = "<" + "".join(_code(t) for t, _ in fields)
        data += [(row[0], _message("D", struct.pack("<H", msg_id) + struct.pack(code, *row))) for row in rows]
    for _, body in sorted(data, key=lambda d: d[0]):
        out += body
    return bytes(out)


def camera_status_log(captures: list[tuple[float, float, float, float]], states: list[tuple[float, int]]) -> bytes:
    """camera_capture (time_s, lat, lon, alt) and vehicle_status (time_s, nav_state) samples, in time
    order, as PX4 writes them: a flag-bits message after the header (version 1), and vehicle_status
    with its padding format declared but left out at the end of each sample."""
    out = bytearray(MAGIC + b"\x01" + struct.pack("<Q", 0))
    out += _message("B", bytes(8) + bytes(8) + bytes(24))  # flag bits: no incompatible flags, no appended data
    out += _message("F", b"camera_capture:uint64_t timestamp;double lat;double lon;float alt;float ground_distance;"
                         b"uint32_t seq;")
    out += _message("F", b"vehicle_status:uint64_t timestamp;uint8_t nav_state;uint8_t[7] _padding0;")
    out += _message("A", struct.pack("<BH", 0, 0) + b"camera_capture")
    out += _message("A", struct.pack("<BH", 0, 1) + b"vehicle_status")
    rows = [(t, struct.pack("<HQddffI", 0, int(t * 1e6), lat, lon, alt, 80.0, k)) for k, (t, lat, lon, alt) in enumerate(captures)]
    rows += [(t, struct.pack("<HQB", 1, int(t * 1e6), state)) for t, state in states]  # PX4 leaves out the padding at the end
    for _, payload in sorted(rows, key=lambda r: r[0]):
        out += _message("D", payload)
    return bytes(out)
