"""Survey photos for tests, written byte by byte: a JPEG with an EXIF APP1 segment (TIFF IFD0,
the Exif IFD and the GPS IFD, packed here with struct from the EXIF 2.32 tag list) and an XMP
APP1 packet with DJI's drone-dji fields (as DJI's user manuals list them: Mavic 3E/3T, Zenmuse
P1, Matrice 4 "XMP data list"), then a tiny baseline image (8 × 8 grey, every coefficient
zero) that any JPEG decoder reads. Nothing here comes from aerosurvey's readers or writers.

The XMP packet is laid out as DJI's cameras write it: one rdf:Description whose attributes are
the fields, each value signed ("+121.668"). `elements=True` writes them as child elements
instead (the other RDF form some firmware uses).
"""

from __future__ import annotations

import datetime as dt
import struct
from collections.abc import Mapping
from dataclasses import dataclass, field

DJI_NS = "http://www.dji.com/drone-dji/1.0/"

# TIFF field types
BYTE, ASCII, SHORT, LONG, RATIONAL = 1, 2, 3, 4, 5
_SIZE = {BYTE: 1, ASCII: 1, SHORT: 2, LONG: 4, RATIONAL: 8}


def _pack_values(order: str, typ: int, values: object) -> tuple[int, bytes]:
    """(count, bytes) of a field's values."""
    if typ == ASCII:
        raw = str(values).encode("ascii") + b"\0"
        return len(raw), raw
    seq = list(values) if isinstance(values, (list, tuple)) else [values]
    if typ == BYTE:
        return len(seq), bytes(int(v) for v in seq)
    if typ == SHORT:
        return len(seq), b"".join(struct.pack(order + "H", int(v)) for v in seq)
    if typ == LONG:
        return len(seq), b"".join(struct.pack(order + "I", int(v)) for v in seq)
    if typ == RATIONAL:  # each value a (numerator, denominator) pair
        return len(seq), b"".join(struct.pack(order + "II", int(n), int(d)) for n, d in seq)
    raise ValueError(typ)


def _ifd(order: str, start: int, entries: list[tuple[int, int, object]]) -> tuple[bytes, bytes]:
    """(the IFD, its out-of-line data placed right after it) at TIFF offset `start`."""
    entries = sorted(entries, key=lambda e: e[0])
    table_len = 2 + 12 * len(entries) + 4
    data = bytearray()
    table = bytearray(struct.pack(order + "H", len(entries)))
    for tag, typ, values in entries:
        count, raw = _pack_values(order, typ, values)
        if len(raw) <= 4:
            table += struct.pack(order + "HHI", tag, typ, count) + raw.ljust(4, b"\0")
        else:
            if len(data) % 2:
                data += b"\0"
            table += struct.pack(order + "HHII", tag, typ, count, start + table_len + len(data))
            data += raw
    table += struct.pack(order + "I", 0)  # no next IFD
    return bytes(table), bytes(data)


def tiff(ifd0: list[tuple[int, int, object]], exif: list[tuple[int, int, object]] | None,
         gps: list[tuple[int, int, object]] | None, big_endian: bool = False) -> bytes:
    """A TIFF structure (as EXIF's APP1 holds it): IFD0 with pointers to the Exif and GPS IFDs."""
    order = ">" if big_endian else "<"
    head = (b"MM" if big_endian else b"II") + struct.pack(order + "HI", 42, 8)

    # the pointers' values depend on where the sub-IFDs land: lay IFD0 out with placeholders first
    def layout(exif_at: int, gps_at: int) -> tuple[bytes, int]:
        entries = list(ifd0)
        if exif is not None:
            entries.append((0x8769, LONG, exif_at))
        if gps is not None:
            entries.append((0x8825, LONG, gps_at))
        table, data = _ifd(order, 8, entries)
        return table + data, 8 + len(table) + len(data)

    first, end = layout(0, 0)
    out_sub = bytearray()
    exif_at = gps_at = 0
    pos = end
    if exif is not None:
        exif_at = pos
        t, d = _ifd(order, pos, exif)
        out_sub += t + d
        pos += len(t) + len(d)
    if gps is not None:
        gps_at = pos
        t, d = _ifd(order, pos, gps)
        out_sub += t + d
    first, _ = layout(exif_at, gps_at)
    return head + first + bytes(out_sub)


def dms(value: float, seconds_denominator: int = 10_000) -> list[tuple[int, int]]:
    """Degrees, minutes, seconds of |value| as EXIF rationals (DJI writes the seconds to 1e-4)."""
    v = abs(value)
    d = int(v)
    m = int((v - d) * 60)
    s = (v - d - m / 60) * 3600
    return [(d, 1), (m, 1), (round(s * seconds_denominator), seconds_denominator)]


def _segment(marker: int, payload: bytes) -> bytes:
    assert len(payload) + 2 <= 0xFFFF, len(payload)
    return struct.pack(">HH", marker, len(payload) + 2) + payload


#: a baseline 8 × 8 grey image, every coefficient zero: a quantisation table of ones, one-code
#: Huffman tables (DC category 0, AC end-of-block), two bits of entropy-coded data padded with ones
_DQT = _segment(0xFFDB, b"\x00" + b"\x01" * 64)
_SOF0 = _segment(0xFFC0, struct.pack(">BHHB", 8, 8, 8, 1) + b"\x01\x11\x00")
_DHT = _segment(0xFFC4, b"\x00" + b"\x01" + b"\x00" * 15 + b"\x00") + _segment(0xFFC4, b"\x10" + b"\x01" + b"\x00" * 15 + b"\x00")
_SOS = _segment(0xFFDA, b"\x01\x01\x00\x00\x3f\x00")
TINY_IMAGE = _DQT + _SOF0 + _DHT + _SOS + b"\x3f" + b"\xff\xd9"


def jpeg(exif_tiff: bytes | None, xmp: str | bytes | None, extra: bytes = b"") -> bytes:
    """SOI, APP1 Exif, APP1 XMP, `extra` (more segments), the tiny image and EOI."""
    out = bytearray(b"\xff\xd8")
    if exif_tiff is not None:
        out += _segment(0xFFE1, b"Exif\0\0" + exif_tiff)
    if xmp is not None:
        packet = xmp.encode("utf-8") if isinstance(xmp, str) else xmp
        out += _segment(0xFFE1, b"http://ns.adobe.com/xap/1.0/\0" + packet)
    out += extra
    out += TINY_IMAGE
    return bytes(out)


def xmp_packet(fields: Mapping[str, str], elements: bool = False, make: str = "DJI", model: str = "M3E") -> str:
    """An XMP packet with the drone-dji fields (name → text as written, e.g. "+12.30")."""
    ns = (' xmlns:tiff="http://ns.adobe.com/tiff/1.0/" xmlns:xmp="http://ns.adobe.com/xap/1.0/"'
          f' xmlns:drone-dji="{DJI_NS}"')
    if elements:
        body = "".join(f"<drone-dji:{k}>{v}</drone-dji:{k}>" for k, v in fields.items())
        desc = f'<rdf:Description rdf:about="DJI Meta Data"{ns} tiff:Make="{make}" tiff:Model="{model}">{body}</rdf:Description>'
    else:
        attrs = "".join(f'\n   drone-dji:{k}="{v}"' for k, v in fields.items())
        desc = (f'<rdf:Description rdf:about="DJI Meta Data"{ns}\n   tiff:Make="{make}"\n   tiff:Model="{model}"'
                f'{attrs}>\n  </rdf:Description>')
    return ('<?xpacket begin="\ufeff" id="W5M0MpCehiHzreSzNTczkc9d"?>\n<x:xmpmeta xmlns:x="adobe:ns:meta/">\n'
            ' <rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#">\n  ' + desc +
            '\n </rdf:RDF>\n</x:xmpmeta>\n<?xpacket end="w"?>')


def signed(v: float, decimals: int = 2) -> str:
    return f"{v:+.{decimals}f}"


@dataclass
class Shot:
    """One photo as the aircraft took it (the truth the tests compare with)."""

    lat: float
    lon: float
    abs_alt: float  # AMSL, m
    rel_alt: float  # above take-off, m
    when: dt.datetime  # capture time (UTC; DJI's camera clock set to UTC here)
    gimbal_yaw: float = 0.0  # degrees from true north, -180..180 as DJI writes it
    gimbal_pitch: float = -90.0
    gimbal_roll: float = 0.0
    flight_yaw: float | None = None  # default: the gimbal's
    flight_pitch: float = 0.0
    flight_roll: float = 0.0
    rtk_flag: int | None = 50
    rtk_std: tuple[float, float, float] | None = (0.012, 0.010, 0.021)  # lon, lat, height (m)
    make: str = "DJI"
    model: str = "M3E"
    xmp_position: bool = False  # also write drone-dji:GpsLatitude/GpsLongitude (some models do)
    extra_fields: dict[str, str] = field(default_factory=dict)


def dji_fields(s: Shot) -> dict[str, str]:
    fy = s.gimbal_yaw if s.flight_yaw is None else s.flight_yaw
    f = {"GpsStatus": "RTK" if s.rtk_flag else "Normal", "AltitudeType": "RtkAlt" if s.rtk_flag else "GpsFusionAlt",
         "AbsoluteAltitude": signed(s.abs_alt, 3), "RelativeAltitude": signed(s.rel_alt, 3),
         "GimbalRollDegree": signed(s.gimbal_roll), "GimbalYawDegree": signed(s.gimbal_yaw),
         "GimbalPitchDegree": signed(s.gimbal_pitch), "FlightRollDegree": signed(s.flight_roll),
         "FlightYawDegree": signed(fy), "FlightPitchDegree": signed(s.flight_pitch),
         "FlightXSpeed": "+0.00", "FlightYSpeed": "+0.00", "FlightZSpeed": "+0.00", "CamReverse": "0", "GimbalReverse": "0"}
    if s.xmp_position:
        f["GpsLatitude"] = f"{s.lat:+.10f}"
        f["GpsLongitude"] = f"{s.lon:+.10f}"
    if s.rtk_flag is not None:
        f["RtkFlag"] = str(s.rtk_flag)
    if s.rtk_std is not None:
        f["RtkStdLon"], f["RtkStdLat"], f["RtkStdHgt"] = (f"{v:.5f}" for v in s.rtk_std)
        f["RtkDiffAge"] = "1.00000"
    f.update(s.extra_fields)
    return f


def exif_fields(s: Shot, gps_time: bool = True, subsec: bool = True) -> tuple[list, list, list]:
    """(IFD0, Exif IFD, GPS IFD) entries of a photo."""
    ifd0 = [(0x010F, ASCII, s.make), (0x0110, ASCII, s.model)]
    exif = [(0x9003, ASCII, s.when.strftime("%Y:%m:%d %H:%M:%S"))]
    if subsec:
        exif.append((0x9291, ASCII, f"{s.when.microsecond // 1000:03d}"))
    gps = [(0x0000, BYTE, [2, 3, 0, 0]),
           (0x0001, ASCII, "N" if s.lat >= 0 else "S"), (0x0002, RATIONAL, dms(s.lat)),
           (0x0003, ASCII, "E" if s.lon >= 0 else "W"), (0x0004, RATIONAL, dms(s.lon)),
           (0x0005, BYTE, [0 if s.abs_alt >= 0 else 1]), (0x0006, RATIONAL, [(round(abs(s.abs_alt) * 1000), 1000)])]
    if gps_time:
        t = s.when
        gps += [(0x0007, RATIONAL, [(t.hour, 1), (t.minute, 1), (t.second * 1000 + t.microsecond // 1000, 1000)]),
                (0x001D, ASCII, t.strftime("%Y:%m:%d"))]
    return ifd0, exif, gps


def dji_jpeg(s: Shot, elements: bool = False) -> bytes:
    """A DJI photo: EXIF with the GPS IFD (little-endian, as DJI writes it) and the drone-dji XMP."""
    ifd0, exif, gps = exif_fields(s)
    return jpeg(tiff(ifd0, exif, gps), xmp_packet(dji_fields(s), elements, s.make, s.model))


def plain_jpeg(s: Shot, direction: float | None = None, big_endian: bool = True) -> bytes:
    """Another maker's photo: EXIF only (big-endian, as e.g. Nikon writes it), GPS IFD with the
    altitude and, when given, GPSImgDirection (true north); no XMP, no attitude."""
    ifd0, exif, gps = exif_fields(s, gps_time=False)
    if direction is not None:
        gps += [(0x0010, ASCII, "T"), (0x0011, RATIONAL, [(round(direction * 100), 100)])]
    return jpeg(tiff(ifd0, exif, gps, big_endian=big_endian), None)
