"""A minimal ULog writer for tests (the format of PX4's logger, docs.px4.io "ULog File Format"):
the file header, one format ('F') and one subscription ('A') per topic, then data ('D') messages
in time order. Written field by field with struct, not with pyulog (which aerosurvey reads them with)."""

from __future__ import annotations

import struct
from typing import Any

MAGIC = b"ULog\x01\x12\x35"
_STRUCT = {"uint64_t": "Q", "uint32_t": "I", "uint16_t": "H", "uint8_t": "B", "int32_t": "i", "float": "f",
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
