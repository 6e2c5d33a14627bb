"""EXIF GPS tags written into a JPEG without re-encoding it.

Photogrammetry software reads a photo's position from its EXIF GPS tags; cameras on a
survey drone mostly have no GPS of their own, so the autopilot's camera event is the
best position there is. Only the APP1 "Exif" segment of the file changes: every other
segment (quantisation and Huffman tables, ICC profile, XMP) and the compressed scan data
from the SOS marker on are copied byte for byte.

The EXIF block (a small TIFF file) is edited by appending, never by rewriting: a new GPS
IFD goes at the end of the block and IFD0's GPS pointer is set to it (IFD0 is copied to
the end when it has no GPS pointer to set). Everything else stays at its offset, so tags
this module does not know (maker notes with absolute offsets, the thumbnail IFD) keep
working. A GPS IFD the camera wrote is replaced as a whole: its time stamp or DOP would
not belong to the autopilot's position.

Why not piexif: its last release is from 2019 and it re-serialises the whole block
(which moves maker notes); Pillow, already a dependency, drops the thumbnail IFD when it
writes EXIF. The parts here are small and tested against Pillow's reader.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from typing import Any

EXIF_HEADER = b"Exif\x00\x00"
APP1, SOS, EOI, APP0 = 0xE1, 0xDA, 0xD9, 0xE0
MAX_SEGMENT_PAYLOAD = 65533  # a JPEG segment's 16-bit length counts itself too
GPS_IFD_TAG = 0x8825
_BYTE, _ASCII, _LONG, _RATIONAL, _IFD = 1, 2, 4, 5, 13  # TIFF field types
_SECONDS_DENOMINATOR = 1_000_000  # 1e-6 arc second: 0.03 mm on the ground
_ALTITUDE_DENOMINATOR = 1000  # millimetres
_DIRECTION_DENOMINATOR = 100


class GeotagError(ValueError):
    """The file cannot be geotagged as it is (not a JPEG, damaged headers, no room for the tags)."""


@dataclass(frozen=True)
class GpsFix:
    """Where a photo was taken: WGS84 degrees, metres above mean sea level, compass degrees."""

    lat: float
    lon: float
    alt_amsl_m: float | None = None
    direction_deg: float | None = None


def dms_rationals(deg: float) -> tuple[tuple[int, int], tuple[int, int], tuple[int, int]]:
    """|deg| as (degrees, minutes, seconds) rationals; seconds to 1e-6 arc second.

    Rounded once on the whole value, so 59.9999999 seconds carry into the minute instead
    of being written as an invalid 60 seconds.
    """
    total = round(abs(deg) * 3600 * _SECONDS_DENOMINATOR)
    per_deg, per_min = 3600 * _SECONDS_DENOMINATOR, 60 * _SECONDS_DENOMINATOR
    d, rest = divmod(total, per_deg)
    m, s = divmod(rest, per_min)
    return (d, 1), (m, 1), (s, _SECONDS_DENOMINATOR)


def gps_entries(fix: GpsFix) -> list[tuple[int, int, list[Any]]]:
    """(tag, TIFF type, values) of the GPS IFD for a fix, in tag order."""
    if not (math.isfinite(fix.lat) and math.isfinite(fix.lon)) or abs(fix.lat) > 90 or abs(fix.lon) > 180:
        raise GeotagError(f"position lat {fix.lat!r}, lon {fix.lon!r} is not a WGS84 position "
                          "(latitude -90..90, longitude -180..180)")
    out: list[tuple[int, int, list[Any]]] = [
        (0x0000, _BYTE, [2, 3, 0, 0]),  # GPSVersionID 2.3.0.0
        (0x0001, _ASCII, ["N" if fix.lat >= 0 else "S"]),
        (0x0002, _RATIONAL, list(dms_rationals(fix.lat))),
        (0x0003, _ASCII, ["E" if fix.lon >= 0 else "W"]),
        (0x0004, _RATIONAL, list(dms_rationals(fix.lon))),
    ]
    if fix.alt_amsl_m is not None and math.isfinite(fix.alt_amsl_m):
        out.append((0x0005, _BYTE, [0 if fix.alt_amsl_m >= 0 else 1]))  # 1: below sea level
        out.append((0x0006, _RATIONAL, [(round(abs(fix.alt_amsl_m) * _ALTITUDE_DENOMINATOR), _ALTITUDE_DENOMINATOR)]))
    if fix.direction_deg is not None and math.isfinite(fix.direction_deg):
        hundredths = round((fix.direction_deg % 360.0) * _DIRECTION_DENOMINATOR) % (360 * _DIRECTION_DENOMINATOR)
        out.append((0x0010, _ASCII, ["T"]))  # true north
        out.append((0x0011, _RATIONAL, [(hundredths, _DIRECTION_DENOMINATOR)]))
    out.append((0x0012, _ASCII, ["WGS-84"]))  # GPSMapDatum
    return out


def _pack_values(typ: int, values: list[Any], bo: str) -> tuple[int, bytes]:
    """(count, bytes) of one entry's values in byte order `bo` ('<' or '>')."""
    if typ == _ASCII:
        raw = values[0].encode("ascii") + b"\x00"
        return len(raw), raw
    if typ == _BYTE:
        return len(values), bytes(values)
    if typ == _RATIONAL:
        return len(values), b"".join(struct.pack(bo + "II", n, d) for n, d in values)
    raise ValueError(f"TIFF type {typ} is not written here")


def _ifd_bytes(entries: list[tuple[int, int, list[Any]]], at: int, bo: str) -> bytes:
    """A TIFF IFD placed at offset `at` of the TIFF block, its long values right after it."""
    n = len(entries)
    data_at = at + 2 + 12 * n + 4
    table, extra = bytearray(struct.pack(bo + "H", n)), bytearray()
    for tag, typ, values in entries:
        count, raw = _pack_values(typ, values, bo)
        if len(raw) <= 4:
            field = raw.ljust(4, b"\x00")
        else:
            field = struct.pack(bo + "I", data_at + len(extra))
            extra += raw + (b"\x00" if len(raw) % 2 else b"")  # values start on a word boundary
        table += struct.pack(bo + "HHI", tag, typ, count) + field
    table += struct.pack(bo + "I", 0)  # no next IFD
    return bytes(table + extra)


def _read_ifd0(tiff: bytes) -> tuple[str, int, list[bytes], bytes]:
    """Byte order, IFD0 offset, IFD0's raw 12-byte entries and its raw next-IFD pointer."""
    if len(tiff) < 8 or tiff[:2] not in (b"II", b"MM"):
        raise GeotagError("the EXIF block is not a TIFF structure (no II/MM byte order mark)")
    bo = "<" if tiff[:2] == b"II" else ">"
    magic, ifd0 = struct.unpack(bo + "HI", tiff[2:8])
    if magic != 42:
        raise GeotagError(f"the EXIF block has TIFF version {magic}; only classic TIFF (42) is written")
    if ifd0 < 8 or ifd0 + 2 > len(tiff):
        raise GeotagError(f"the EXIF block's first IFD offset {ifd0} lies outside the {len(tiff)}-byte block")
    (n,) = struct.unpack(bo + "H", tiff[ifd0:ifd0 + 2])
    end = ifd0 + 2 + 12 * n
    if end + 4 > len(tiff):
        raise GeotagError(f"the EXIF block's first IFD ({n} entries) runs past the end of the block")
    entries = [tiff[ifd0 + 2 + 12 * k: ifd0 + 14 + 12 * k] for k in range(n)]
    return bo, ifd0, entries, tiff[end:end + 4]


def _with_gps(tiff: bytes, fix: GpsFix) -> bytes:
    """The TIFF block with a new GPS IFD appended and IFD0 pointing at it."""
    bo, ifd0, entries, next_ifd = _read_ifd0(tiff)
    out = bytearray(tiff)
    if len(out) % 2:
        out += b"\x00"
    gps = gps_entries(fix)
    for k, e in enumerate(entries):
        tag, typ, count = struct.unpack(bo + "HHI", e[:8])
        if tag == GPS_IFD_TAG and typ in (_LONG, _IFD) and count == 1:
            # set the existing pointer: IFD0 stays where it is
            struct.pack_into(bo + "I", out, ifd0 + 2 + 12 * k + 8, len(out))
            return bytes(out + _ifd_bytes(gps, len(out), bo))
    # no pointer to set: IFD0 (its entries verbatim plus the GPS pointer) moves to the end
    kept = [e for e in entries if struct.unpack(bo + "H", e[:2])[0] != GPS_IFD_TAG]
    new_at = len(out)
    gps_at = new_at + 2 + 12 * (len(kept) + 1) + 4
    pointer = struct.pack(bo + "HHII", GPS_IFD_TAG, _LONG, 1, gps_at)
    table = sorted(kept + [pointer], key=lambda e: struct.unpack(bo + "H", e[:2])[0])
    out += struct.pack(bo + "H", len(table)) + b"".join(table) + next_ifd
    struct.pack_into(bo + "I", out, 4, new_at)
    return bytes(out + _ifd_bytes(gps, gps_at, bo))


def _new_tiff(fix: GpsFix) -> bytes:
    """A TIFF block of its own: IFD0 holding only the GPS pointer, then the GPS IFD."""
    head = b"II" + struct.pack("<HI", 42, 8)
    gps_at = 8 + 2 + 12 + 4
    ifd0 = struct.pack("<H", 1) + struct.pack("<HHII", GPS_IFD_TAG, _LONG, 1, gps_at) + struct.pack("<I", 0)
    return head + ifd0 + _ifd_bytes(gps_entries(fix), gps_at, "<")


@dataclass(frozen=True)
class Segment:
    marker: int
    start: int  # offset of the segment's first 0xFF
    end: int  # offset just past the segment
    payload: int  # offset of the data after the length field (= end for markers without one)


def jpeg_segments(data: bytes) -> tuple[list[Segment], int]:
    """The marker segments before the first SOS, and the offset of that SOS marker."""
    n = len(data)
    if data[:2] != b"\xff\xd8":
        raise GeotagError("not a JPEG file (it does not start with the JPEG start-of-image marker FFD8)")
    pos = 2
    segments: list[Segment] = []
    while True:
        if pos >= n:
            raise GeotagError(f"the JPEG ends after {n} bytes, before its image data (no SOS marker): the file is cut off")
        if data[pos] != 0xFF:
            raise GeotagError(f"the JPEG headers are damaged: byte {pos} should start a marker (0xFF), it is 0x{data[pos]:02X}")
        start = pos
        while pos < n and data[pos] == 0xFF:  # fill bytes may precede a marker
            pos += 1
        if pos >= n:
            raise GeotagError(f"the JPEG ends after {n} bytes, before its image data (no SOS marker): the file is cut off")
        marker = data[pos]
        pos += 1
        if marker == SOS:
            return segments, start
        if marker == EOI:
            raise GeotagError(f"the JPEG ends (EOI at byte {start}) before any image data")
        if marker == 0x01 or 0xD0 <= marker <= 0xD7:  # markers without a length
            segments.append(Segment(marker, start, pos, pos))
            continue
        if pos + 2 > n:
            raise GeotagError(f"the JPEG ends inside its headers (byte {n}): the file is cut off")
        length = int.from_bytes(data[pos:pos + 2], "big")
        if length < 2 or pos + length > n:
            raise GeotagError(f"the JPEG segment 0xFF{marker:02X} at byte {start} claims {length} bytes; "
                              f"the file ends {n - pos} bytes on: it is cut off or damaged")
        segments.append(Segment(marker, start, pos + length, pos + 2))
        pos += length


def ends_with_eoi(data: bytes) -> bool:
    """Whether the file ends with the end-of-image marker (cameras may pad after it with zeros)."""
    return data.rstrip(b"\x00").endswith(b"\xff\xd9")


def geotag_jpeg(data: bytes, fix: GpsFix) -> bytes:
    """The JPEG `data` with EXIF GPS tags set from `fix`; only the APP1 Exif segment changes."""
    segments, sos = jpeg_segments(data)
    exif = next((s for s in segments if s.marker == APP1 and data[s.payload:s.payload + 6] == EXIF_HEADER), None)
    if exif is not None:
        tiff = _with_gps(data[exif.payload + 6:exif.end], fix)
        cut, resume = exif.start, exif.end
    else:
        tiff = _new_tiff(fix)
        # after SOI and any JFIF/JFXX APP0 segments, which JFIF wants first
        cut = 2
        for s in segments:
            if s.marker != APP0:
                break
            cut = s.end
        resume = cut
    payload = EXIF_HEADER + tiff
    if len(payload) > MAX_SEGMENT_PAYLOAD:
        raise GeotagError(f"the EXIF block with GPS tags would take {len(payload)} bytes; "
                          f"a JPEG segment holds at most {MAX_SEGMENT_PAYLOAD}")
    segment = b"\xff\xe1" + struct.pack(">H", len(payload) + 2) + payload
    return data[:cut] + segment + data[resume:]
