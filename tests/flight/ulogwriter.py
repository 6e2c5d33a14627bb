"""A minimal PX4 ULog writer for tests (the file format of PX4's docs, dev guide "ULog File Format"):
the header, format definitions (F), subscriptions (A) and data (D) of two topics,
camera_capture and vehicle_status."""

from __future__ import annotations

import struct

MAGIC = b"ULog\x01\x12\x35"


def _message(kind: bytes, payload: bytes) -> bytes:
    return struct.pack("<HB", len(payload), kind[0]) + payload


def camera_status_log(captures: list[tuple[float, float, float, float]], states: list[tuple[float, int]]) -> bytes:
    """camera_capture (time_s, lat, lon, alt) and vehicle_status (time_s, nav_state) samples, in time order."""
    out = bytearray(MAGIC + b"\x01" + struct.pack("<Q", 0))
    out += _message(b"B", bytes(8) + bytes(8) + bytes(24))  # flag bits: no incompatible flags, no appended data
    out += _message(b"F", b"camera_capture:uint64_t timestamp;double lat;double lon;float alt;float ground_distance;"
                          b"uint32_t seq;")
    out += _message(b"F", b"vehicle_status:uint64_t timestamp;uint8_t nav_state;uint8_t[7] _padding0;")
    out += _message(b"A", struct.pack("<BH", 0, 0) + b"camera_capture")
    out += _message(b"A", struct.pack("<BH", 0, 1) + b"vehicle_status")
    rows = [(t, struct.pack("<HQddffI", 0, int(t * 1e6), lat, lon, alt, 80.0, k)) for k, (t, lat, lon, alt) in enumerate(captures)]
    rows += [(t, struct.pack("<HQB", 1, int(t * 1e6), state)) for t, state in states]  # PX4 leaves out the padding at the end
    for _, payload in sorted(rows, key=lambda r: r[0]):
        out += _message(b"D", payload)
    return bytes(out)
