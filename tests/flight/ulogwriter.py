"""A minimal PX4 ULog writer for tests (the file format of docs.px4.io's "ULog File Format"):
the header, flag bits, one format and one subscription per topic, and the data messages in
time order."""

from __future__ import annotations

import struct

HEADER = b"ULog\x01\x12\x35"
_CODES = {"uint64_t": "Q", "uint32_t": "I", "uint8_t": "B", "int8_t": "b", "float": "f", "double": "d"}


def _message(kind: str, body: bytes) -> bytes:
    return struct.pack("<HB", len(body), ord(kind)) + body


def _code(field_type: str) -> str:
    """A field's struct code: "float[4]" is four floats."""
    base, _, count = field_type.partition("[")
    return (count.rstrip("]") if count else "") + _CODES[base]


def ulog(topics: dict[str, tuple[list[tuple[str, str]], list[tuple[float | int, ...]]]]) -> bytes:
    """topics: name -> ((type, name) of each field, the first "uint64_t timestamp"; rows of
    values in field order, arrays flattened)."""
    out = bytearray(HEADER + bytes([1]) + struct.pack("<Q", 0))
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
