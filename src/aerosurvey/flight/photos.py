"""A flight recorded by its photos: `aerosurvey log ingest FOLDER` with a folder of images.

A DJI aircraft leaves no flight log of ours, only its photos; any camera with a GPS receiver
leaves at least a position in each. Each photo is one camera event, read from its metadata
(never its pixels):

- position: DJI's XMP ``drone-dji:GpsLatitude``/``GpsLongitude`` (``GpsLongtitude``, as some
  firmware spells it) where written, else EXIF's GPS IFD (GPSLatitude/Ref, GPSLongitude/Ref).
  Where both are written they must agree within POSITION_AGREEMENT_M.
- altitude above mean sea level: ``drone-dji:AbsoluteAltitude``, else EXIF GPSAltitude/Ref;
  height above the take-off point: ``drone-dji:RelativeAltitude`` (other cameras: none; with a
  plan, `log ingest` takes the plan's home ground, see `heights_above_home`).
- the camera's attitude, not the vehicle's (Events.camera_attitude): yaw ``GimbalYawDegree``
  (a true bearing: DJI writes the gimbal's angles in the NED frame), else ``FlightYawDegree``
  (the gimbal follows the nose), else EXIF GPSImgDirection when its reference is true north,
  else the direction of flight (`track_yaw`: the camera taken as looking down with the image's
  top to the nose); pitch ``GimbalPitchDegree`` (0 level, −90 straight down), else straight
  down assumed; roll ``GimbalRollDegree``, else 0. OpenDroneMap reads a DJI photo's yaw from
  FlightYawDegree; the gimbal's is the camera's own, which matters where the gimbal turns
  against the nose (DJI's oblique captures).
- RTK: ``RtkFlag`` (DJI: 0 no position, 16 single point, 32–49 float, 50 fixed; other codes
  below 32, which DJI's Onboard SDK lists for its non-RTK solutions, count as single) and the
  standard deviations ``RtkStdLon``, ``RtkStdLat``, ``RtkStdHgt`` (metres).
- capture time: EXIF DateTimeOriginal + SubSecTimeOriginal (+ OffsetTimeOriginal where
  written), the camera's clock; a photo without it takes its GPS time (GPSDateStamp +
  GPSTimeStamp) moved onto the camera clock by the median offset of the photos that have both.
  The photos are the flight's events in capture time order.

Field names and meanings: DJI's user manuals, "XMP data list" (Mavic 3E/3T, Zenmuse P1,
Matrice 4); EXIF 2.32 for the GPS and Exif IFDs.

The library: Pillow (`Image.open` reads a file's markers up to the image data; `getexif()` and
its GPS and Exif IFDs; the XMP packet Pillow keeps from its APP1 segment, parsed here with lxml,
no entities, no network). Chosen by measurement against exifread, pyexiv2, piexif and Pillow's
own getxmp (benchmarks/photo_bench.py, docs/flight-logs.md): as correct as any on DJI's layouts
and another maker's, within the speed target with a wide margin, and already a dependency.

A photo is skipped, with its reason in the report, when it cannot be read (not an image, cut
off: a JPEG without its end-of-image marker), when it has no position or capture time, when a
field is not a number or impossible, when its EXIF and XMP positions disagree, when it repeats
another photo (the same capture time and place: a copy, or another lens of the same capture), or
when the flight around it disagrees (`_off_the_flight`, `_off_the_take_off`).
"""

from __future__ import annotations

import datetime as dt
import math
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aerosurvey.errors import InputError
from aerosurvey.flight.events import Events, ReadInfo, SkipInfo
from aerosurvey.plan.progress import Progress, no_progress

DJI_NS = "http://www.dji.com/drone-dji/1.0/"
_RDF_DESCRIPTION = "{http://www.w3.org/1999/02/22-rdf-syntax-ns#}Description"
_TIFF_NS = "http://ns.adobe.com/tiff/1.0/"
PHOTO_SUFFIXES = (".jpg", ".jpeg", ".tif", ".tiff")
SOURCE = "photo EXIF/XMP"

#: EXIF and XMP positions of one photo further apart than this are not both the photo's
POSITION_AGREEMENT_M = 1.0
#: a photo's capture time, place and altitude against its NEIGHBOURS photos before and after in
#: time: a neighbour agrees when the vehicle can fly from one to the other in the time between
#: them (across at the flight's own speed: SPEED_FACTOR times the 75th percentile of its speeds
#: between consecutive photos, which a few damaged photos do not move, within
#: MIN_SPEED_MS..MAX_SPEED_MS; MAX_SPEED_MS with fewer than
#: MIN_LEGS of them; up or down at MAX_CLIMB_MS; plus REACH_SLACK_M for the GNSS's noise); a
#: photo that fewer than half its neighbours agree with has a time or place that is not the one
#: it was taken with. MAX_SPEED_MS and MAX_CLIMB_MS lie beyond any survey multicopter (15-23 m/s)
#: and survey fixed wing (16-30 m/s, climbing at most 10 m/s).
NEIGHBOURS = 10
SPEED_FACTOR = 2.0
MIN_SPEED_MS = 5.0
MAX_SPEED_MS = 50.0
MIN_LEGS = 10
MAX_CLIMB_MS = 20.0
REACH_SLACK_M = 10.0
#: the take-off point's altitude (AMSL altitude minus height above take-off) of a photo against
#: the median of its stretch of the flight (photos less than STRETCH_GAP_S apart: one take-off);
#: the two heights come from RTK/GNSS and the barometer, which drift apart by a few metres at most
TAKE_OFF_AGREEMENT_M = 20.0
STRETCH_GAP_S = 60.0
#: photos closer in time and place than these are one capture (a copy, or another lens of it):
#: a survey camera takes at most a photo each 0.7 s
SAME_CAPTURE_S = 0.1
SAME_CAPTURE_M = 1.0
#: bounds of a plausible value (beyond them a field is damaged): metres, degrees
ALT_RANGE_M = (-500.0, 10_000.0)
REL_ALT_RANGE_M = (-2_000.0, 5_000.0)
STD_MAX_M = 1_000.0
MAX_RTK_FLAG = 50
#: the end of a JPEG file searched for its end-of-image marker (a file may carry a trailer)
EOI_SEARCH_BYTES = 65_536
#: how many skipped photos the report names (all are counted)
MAX_NAMED = 50

# skip categories (the report counts photos per category) and the read-report kind of each
CUT_OFF, UNREADABLE, NO_POSITION, NO_TIME, BAD_FIELD, NO_XMP, DISAGREE, REPEAT, OFF_FLIGHT, OFF_TAKE_OFF = (
    "cut off", "unreadable", "no position", "no capture time", "bad field", "DJI XMP missing", "EXIF and XMP disagree",
    "repeat", "off the flight", "off the take-off height")
_KIND = {CUT_OFF: "damage", UNREADABLE: "damage", NO_POSITION: "event", NO_TIME: "event", BAD_FIELD: "event",
         NO_XMP: "event", DISAGREE: "event", REPEAT: "repeat", OFF_FLIGHT: "event", OFF_TAKE_OFF: "event"}


class _Skip(Exception):
    def __init__(self, category: str, reason: str) -> None:
        super().__init__(reason)
        self.category = category


@dataclass
class _Photo:
    """One photo's fields as read (NaN: not recorded)."""

    file: Path
    size: int
    camera: str
    clock_s: float  # DateTimeOriginal (+ sub-seconds), seconds since 1970 on the camera's clock
    gps_s: float  # GPS date and time, UTC
    lat: float
    lon: float
    alt: float
    rel_alt: float
    yaw: float
    pitch: float
    roll: float
    yaw_source: str  # "gimbal", "flight", "exif direction" or "" (none: the track's)
    dji: bool  # it has drone-dji XMP fields
    rtk_flag: float
    std: tuple[float, float, float]  # lon, lat, height (m)
    capture_s: float = math.nan


@dataclass(frozen=True)
class PhotoFlight:
    """The photos of a folder as camera events, in capture time order, with what each recorded."""

    events: Events  # camera_attitude: roll, pitch, yaw are the camera's (see the module docstring)
    files: tuple[Path, ...]  # each event's image
    capture_s: np.ndarray  # capture time, seconds since 1970 on the camera's clock
    rtk_flag: np.ndarray  # DJI's RtkFlag, NaN where not recorded
    std_lon_m: np.ndarray  # DJI's RtkStdLon, RtkStdLat, RtkStdHgt (one standard deviation), NaN where not recorded
    std_lat_m: np.ndarray
    std_hgt_m: np.ndarray
    read: ReadInfo  # log_report.json's "read": each skipped photo a place (offset 0, its size)
    report: dict[str, Any]  # log_report.json's "photos"

    def __len__(self) -> int:
        return len(self.files)


def rtk_solution(flag: float) -> str:
    """DJI's RtkFlag as a solution: "fixed", "float", "single", "none" or "not recorded"."""
    if not math.isfinite(flag):
        return "not recorded"
    if flag >= 50:
        return "fixed"
    if flag >= 32:
        return "float"
    return "single" if flag > 0 else "none"


def _number(value: Any, what: str) -> float:
    """A field's value (XMP text, an EXIF rational) as a finite number."""
    try:
        v = float(value.strip() if isinstance(value, str) else value)
    except (TypeError, ValueError, ZeroDivisionError):
        raise _Skip(BAD_FIELD, f"{what} {str(value)[:40]!r} is not a number") from None
    if not math.isfinite(v):
        raise _Skip(BAD_FIELD, f"{what} {str(value)[:40]!r} is not a number")
    return v


def _within(v: float, lo: float, hi: float, what: str) -> float:
    if not lo <= v <= hi:
        raise _Skip(BAD_FIELD, f"{what} {v:g} is impossible (allowed {lo:g} to {hi:g})")
    return v


def _dji_fields(packet: bytes | None) -> dict[str, str]:
    """The drone-dji fields (and tiff:Make/Model) of an XMP packet, by local name: as attributes
    of rdf:Description (DJI's form) or as its child elements."""
    if not packet:
        return {}
    from lxml import etree

    parser = etree.XMLParser(resolve_entities=False, no_network=True, huge_tree=False)
    try:
        root = etree.fromstring(packet.strip(b"\0 \t\r\n"), parser)
    except etree.XMLSyntaxError as exc:
        raise _Skip(BAD_FIELD, f"its XMP packet is not XML ({exc})") from None
    out: dict[str, str] = {}
    for ns in (_TIFF_NS, DJI_NS):
        prefix = "{" + ns + "}"
        for el in root.iter(_RDF_DESCRIPTION):
            for k, v in el.attrib.items():
                if k.startswith(prefix):
                    out[k[len(prefix):]] = v
            for child in el:
                if isinstance(child.tag, str) and child.tag.startswith(prefix) and len(child) == 0:
                    out[child.tag[len(prefix):]] = (child.text or "").strip()
    return out


def _degrees(parts: Any, ref: Any, refs: str, what: str) -> float:
    if not isinstance(parts, tuple) or len(parts) != 3:
        raise _Skip(BAD_FIELD, f"EXIF {what} {parts!r} is not degrees, minutes, seconds")
    d, m, s = (_number(p, f"EXIF {what}") for p in parts)
    r = (ref.decode("ascii", "replace") if isinstance(ref, bytes) else str(ref or "")).strip("\0 ").upper()
    if r not in refs:
        raise _Skip(BAD_FIELD, f"EXIF {what}Ref {r!r} is not one of {', '.join(refs)}")
    if not (d >= 0 and 0 <= m <= 60 and 0 <= s <= 60):  # 60: a writer's rounding of 59.99995, harmless
        raise _Skip(BAD_FIELD, f"EXIF {what} {d:g}° {m:g}' {s:g}\" is impossible")
    return (-1.0 if r in "SW" else 1.0) * (d + m / 60.0 + s / 3600.0)


def _exif_time(text: Any, sub: Any, offset: Any) -> float:
    """DateTimeOriginal (+ SubSecTimeOriginal, OffsetTimeOriginal) as seconds; NaN when absent or unreadable."""
    try:
        t = dt.datetime.strptime(str(text).strip("\0 "), "%Y:%m:%d %H:%M:%S").replace(tzinfo=dt.UTC).timestamp()
    except ValueError:
        return math.nan
    frac = str(sub or "").strip("\0 ")
    t += float("0." + frac) if frac.isdigit() else 0.0
    off = str(offset or "").strip("\0 ")
    if len(off) == 6 and off[0] in "+-" and off[1:3].isdigit() and off[4:6].isdigit() and off[3] == ":":
        t -= (1 if off[0] == "+" else -1) * (int(off[1:3]) * 3600 + int(off[4:6]) * 60)
    return t


def _gps_time(date: Any, hms: Any) -> float:
    if not (isinstance(hms, tuple) and len(hms) == 3) or not date:
        return math.nan
    try:
        day = dt.datetime.strptime(str(date).strip("\0 "), "%Y:%m:%d").replace(tzinfo=dt.UTC).timestamp()
        h, m, s = (float(v) for v in hms)
    except (ValueError, TypeError, ZeroDivisionError):
        return math.nan
    if not (0 <= h < 24 and 0 <= m < 60 and 0 <= s < 61):
        return math.nan
    return day + h * 3600 + m * 60 + s


def _cut_off(path: Path, size: int) -> bool:
    """A JPEG whose end holds no end-of-image marker (FF D9): its image data is cut off."""
    with open(path, "rb") as f:
        f.seek(max(size - 2, 0))
        if f.read(2) == b"\xff\xd9":
            return False
        f.seek(max(size - EOI_SEARCH_BYTES, 0))
        return b"\xff\xd9" not in f.read(EOI_SEARCH_BYTES)


def _local_m(lat: np.ndarray, lon: np.ndarray, lat0: float, lon0: float) -> tuple[np.ndarray, np.ndarray]:
    """East and north metres from (lat0, lon0) on a sphere: enough for distances of a flight's neighbours."""
    k = math.pi / 180.0 * 6_371_000.0
    return (lon - lon0) * k * math.cos(math.radians(lat0)), (lat - lat0) * k


def read_photo(path: Path) -> _Photo:
    """One photo's fields, or `_Skip` with the category and the reason."""
    from PIL import Image

    size = path.stat().st_size
    try:
        with warnings.catch_warnings():
            # pixels are never decoded: Pillow's warning about large images, and its notes on EXIF
            # fields it cannot read (what is needed and missing is a reason below), do not apply
            warnings.simplefilter("ignore")
            with Image.open(path) as im:
                fmt = im.format
                exif = im.getexif()
                gps = dict(exif.get_ifd(0x8825))
                sub = dict(exif.get_ifd(0x8769))
                packet = im.info.get("xmp")
                make, model = exif.get(0x010F), exif.get(0x0110)
    except Exception as exc:  # Pillow raises many kinds (OSError, SyntaxError, struct.error, ...) on damaged files
        raise _Skip(UNREADABLE, f"not a readable image ({type(exc).__name__}: {str(exc).replace(str(path), path.name)})") from None
    if fmt == "JPEG" and _cut_off(path, size):
        raise _Skip(CUT_OFF, "the image data is cut off (no end-of-image marker)")
    x = _dji_fields(packet if isinstance(packet, bytes) else None)

    def xmp(*names: str) -> float:
        name = next((n for n in names if n in x), None)
        return _number(x[name], f"XMP drone-dji:{name}") if name is not None else math.nan

    lat, lon = xmp("GpsLatitude"), xmp("GpsLongitude", "GpsLongtitude")
    has_exif_pos = 2 in gps and 4 in gps
    if has_exif_pos:
        elat = _degrees(gps.get(2), gps.get(1), "NS", "GPSLatitude")
        elon = _degrees(gps.get(4), gps.get(3), "EW", "GPSLongitude")
        if math.isfinite(lat) and math.isfinite(lon):
            ex, ey = _local_m(np.array([elat]), np.array([elon]), lat, lon)
            gap = float(np.hypot(ex[0], ey[0]))
            if gap > POSITION_AGREEMENT_M:
                raise _Skip(DISAGREE, f"its EXIF and XMP positions lie {gap:.1f} m apart (allowed {POSITION_AGREEMENT_M:g} m)")
        else:
            lat, lon = elat, elon
    if not (math.isfinite(lat) and math.isfinite(lon)):
        raise _Skip(NO_POSITION, "no GPS position (EXIF GPS IFD or DJI XMP)")
    _within(lat, -90.0, 90.0, "latitude")
    _within(lon, -180.0, 180.0, "longitude")
    if lat == 0.0 and lon == 0.0:
        raise _Skip(NO_POSITION, "its GPS position is 0, 0 (no fix)")
    alt = xmp("AbsoluteAltitude")
    if not math.isfinite(alt) and 6 in gps:
        below = gps.get(5, 0)
        below = below[0] if isinstance(below, bytes) and below else below
        alt = _number(gps[6], "EXIF GPSAltitude") * (-1.0 if below == 1 else 1.0)
    if math.isfinite(alt):
        _within(alt, *ALT_RANGE_M, "altitude (m)")
    rel = xmp("RelativeAltitude")
    if math.isfinite(rel):
        _within(rel, *REL_ALT_RANGE_M, "height above take-off (m)")
    if not (math.isfinite(alt) or math.isfinite(rel)):
        raise _Skip(NO_POSITION, "no altitude (EXIF GPSAltitude, DJI XMP AbsoluteAltitude or RelativeAltitude)")
    yaw, source = xmp("GimbalYawDegree"), "gimbal"
    if not math.isfinite(yaw):
        yaw, source = xmp("FlightYawDegree"), "flight"
    if not math.isfinite(yaw) and 17 in gps and str(gps.get(16, "")).strip("\0 ").upper() == "T":
        yaw, source = _number(gps[17], "EXIF GPSImgDirection"), "exif direction"
    if math.isfinite(yaw):
        yaw = _within(yaw, -360.0, 360.0, "yaw (°)") % 360.0
    else:
        source = ""
    pitch, roll = xmp("GimbalPitchDegree"), xmp("GimbalRollDegree")
    for v, what in ((pitch, "gimbal pitch (°)"), (roll, "gimbal roll (°)")):
        if math.isfinite(v):
            _within(v, -180.0, 180.0, what)
    flag = xmp("RtkFlag")
    if math.isfinite(flag) and not (flag == int(flag) and 0 <= flag <= MAX_RTK_FLAG):
        raise _Skip(BAD_FIELD, f"XMP drone-dji:RtkFlag {flag:g} is not one DJI writes (0 to {MAX_RTK_FLAG})")
    std = (xmp("RtkStdLon"), xmp("RtkStdLat"), xmp("RtkStdHgt"))
    for v, what in zip(std, ("RtkStdLon", "RtkStdLat", "RtkStdHgt")):
        if math.isfinite(v):
            _within(v, 0.0, STD_MAX_M, f"XMP drone-dji:{what} (m)")
    clock = _exif_time(sub.get(0x9003), sub.get(0x9291), sub.get(0x9011))
    camera = " ".join(str(v).strip("\0 ") for v in (make or x.get("Make"), model or x.get("Model")) if v) or "unknown"
    return _Photo(path, size, camera, clock, _gps_time(gps.get(29), gps.get(7)), lat, lon, alt, rel, yaw,
                  pitch, roll, source, any(k not in ("Make", "Model") for k in x), flag, std)


def track_yaw(lat: np.ndarray, lon: np.ndarray) -> np.ndarray:
    """Each photo's direction of flight (a true bearing, degrees) from its neighbours in time: the
    bearing of the shorter of its two legs (to the photo before, from it to the photo after), so
    that the first and last photos of a line take the line's direction, not the turn's. NaN for
    a lone photo."""
    n = len(lat)
    if n < 2:
        return np.full(n, np.nan)
    import pyproj

    course, _, leg = pyproj.Geod(ellps="WGS84").inv(lon[:-1], lat[:-1], lon[1:], lat[1:])  # leg k: photo k -> k + 1
    course, leg = np.asarray(course, float) % 360.0, np.asarray(leg, float)
    before, after = np.r_[np.inf, leg], np.r_[leg, np.inf]
    k = np.where(after <= before, np.arange(n), np.arange(n) - 1)
    return np.where(leg[k] > 0, course[k], np.nan)


def _off_the_flight(t: np.ndarray, lat: np.ndarray, lon: np.ndarray, alt: np.ndarray) -> tuple[np.ndarray, float]:
    """(mask of the photos (in time order) that fewer than half of their NEIGHBOURS before and
    after agree with, the speed across used: see NEIGHBOURS): a damaged time, place or altitude.
    Where a photo has no altitude, its place alone is judged. With fewer than 3 photos nothing is
    judged (a disagreement of two photos names neither)."""
    n = len(t)
    if n < 3:
        return np.zeros(n, bool), MAX_SPEED_MS
    x, y = _local_m(lat, lon, float(np.median(lat)), float(np.median(lon)))
    legs = np.hypot(np.diff(x), np.diff(y)) / np.maximum(np.diff(t), 1e-3)
    speed = MAX_SPEED_MS if len(legs) < MIN_LEGS else \
        float(np.clip(SPEED_FACTOR * np.percentile(legs, 75), MIN_SPEED_MS, MAX_SPEED_MS))
    agree, seen = np.zeros(n, int), np.zeros(n, int)
    for k in range(1, min(NEIGHBOURS, n - 1) + 1):
        dt_ = np.abs(t[k:] - t[:-k])
        across = np.hypot(x[k:] - x[:-k], y[k:] - y[:-k]) <= speed * dt_ + REACH_SLACK_M
        up = ~(np.abs(alt[k:] - alt[:-k]) > MAX_CLIMB_MS * dt_ + REACH_SLACK_M)  # NaN: not judged
        ok = (across & up).astype(int)
        agree[k:] += ok
        agree[:-k] += ok
        seen[k:] += 1
        seen[:-k] += 1
    return np.asarray(2 * agree < seen, bool), speed


def _off_the_take_off(t: np.ndarray, alt: np.ndarray, rel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(mask, metres off) of photos whose take-off altitude (AMSL altitude minus height above
    take-off) lies more than TAKE_OFF_AGREEMENT_M from the median of its stretch of the flight
    (photos less than STRETCH_GAP_S apart: one take-off; stretches of fewer than 3 photos with
    both heights are not judged): a damaged altitude or height."""
    home = alt - rel
    off = np.zeros(len(t))
    starts = np.r_[0, np.flatnonzero(np.diff(t) > STRETCH_GAP_S) + 1, len(t)]
    for a, b in zip(starts[:-1], starts[1:]):
        h = home[a:b]
        ok = np.isfinite(h)
        if ok.sum() >= 3:
            off[a:b] = np.where(ok, h - np.median(h[ok]), 0.0)
    return np.abs(off) > TAKE_OFF_AGREEMENT_M, off


def list_photos(folder: Path) -> tuple[list[Path], int]:
    """(the photos of a folder in name order, how many other files it holds)."""
    if not folder.exists():
        raise InputError(f"flight record {str(folder)!r} does not exist")
    if not folder.is_dir():
        raise InputError(f"flight record {str(folder)!r} is not a folder of photos")
    files = sorted(p for p in folder.iterdir() if p.is_file())
    photos = [p for p in files if p.suffix.lower() in PHOTO_SUFFIXES]
    if not photos:
        raise InputError(f"flight record {str(folder)!r}: no photos in it ({', '.join(PHOTO_SUFFIXES)}), "
                         f"{len(files)} other file(s)")
    return photos, len(files) - len(photos)


def read_photo_flight(folder: Path, progress: Progress | None = None) -> PhotoFlight:
    """The folder's photos as camera events, in capture time order, each checked (module docstring).
    A folder without one usable photo is an InputError naming the commonest reason."""
    report_progress = progress or no_progress
    paths, others = list_photos(folder)
    photos: list[_Photo] = []
    skipped: list[tuple[Path, int, str, str]] = []  # file, size, category, reason
    for i, p in enumerate(paths):
        if i % 100 == 0:
            report_progress(f"photo {i + 1} of {len(paths)}", i / len(paths))
        try:
            photos.append(read_photo(p))
        except _Skip as s:
            skipped.append((p, p.stat().st_size, s.category, str(s)))
    with_xmp = {c: sum(ph.dji for ph in photos if ph.camera == c) / sum(ph.camera == c for ph in photos)
                for c in {ph.camera for ph in photos}}
    photos = _drop(photos, skipped, {i: "" for i, ph in enumerate(photos) if not ph.dji and with_xmp[ph.camera] > 0.5},
                   NO_XMP, lambda ph, _: f"it has no drone-dji XMP fields while most photos of its camera ({ph.camera}) "
                                         "have them: its XMP segment is damaged")
    photos = _on_one_clock(photos, skipped)
    # capture time order; of one capture's images a JPEG first, then by name
    photos.sort(key=lambda ph: (ph.capture_s, ph.file.suffix.lower() not in (".jpg", ".jpeg"), ph.file.name))
    photos = _drop(photos, skipped, _repeats(photos), REPEAT,
                   lambda ph, j: f"another image of the capture of {j} (same time and place): a copy or another lens")
    if photos:
        t = np.array([ph.capture_s for ph in photos])
        lat, lon = np.array([ph.lat for ph in photos]), np.array([ph.lon for ph in photos])
        off, speed = _off_the_flight(t, lat, lon, np.array([ph.alt for ph in photos]))
        photos = _drop(photos, skipped, {i: "" for i in np.flatnonzero(off).tolist()}, OFF_FLIGHT,
                       lambda ph, _: f"its capture time, place or altitude is not the flight's: most of the {NEIGHBOURS} "
                                     f"photos before and after it lie beyond {speed:.1f} m/s across (the flight's own "
                                     f"speed) or {MAX_CLIMB_MS:g} m/s up or down from it")
    if photos:
        t = np.array([ph.capture_s for ph in photos])
        far, by = _off_the_take_off(t, np.array([ph.alt for ph in photos]), np.array([ph.rel_alt for ph in photos]))
        photos = _drop(photos, skipped, {i: f"{by[i]:+.1f}" for i in np.flatnonzero(far).tolist()}, OFF_TAKE_OFF,
                       lambda ph, d: f"its altitude minus its height above take-off lies {d} m from the flight's "
                                     f"(allowed {TAKE_OFF_AGREEMENT_M:g} m): one of the two is damaged")
    report_progress("photos read", 1.0)
    read = _read_info(paths, photos, skipped)
    if not photos:
        counts = _counts(skipped)
        commonest = max(counts, key=lambda c: counts[c])
        first = next(r for _, _, c, r in skipped if c == commonest)
        raise InputError(f"flight record {str(folder)!r}: none of its {len(paths)} photos is usable ({counts[commonest]} "
                         f"{commonest}, e.g. {next(p.name for p, _, c, _ in skipped if c == commonest)}: {first})")
    return _flight(folder, photos, skipped, others, read)


def _on_one_clock(photos: list[_Photo], skipped: list[tuple[Path, int, str, str]]) -> list[_Photo]:
    """Each photo's capture time on the camera's clock: its own, or its GPS time moved by the
    median offset of the photos that have both; a photo with neither is skipped."""
    both = [ph.clock_s - ph.gps_s for ph in photos if math.isfinite(ph.clock_s) and math.isfinite(ph.gps_s)]
    offset = float(np.median(both)) if both else (0.0 if not any(math.isfinite(ph.clock_s) for ph in photos) else math.nan)
    out = []
    for ph in photos:
        ph.capture_s = ph.clock_s if math.isfinite(ph.clock_s) else ph.gps_s + offset
        if math.isfinite(ph.capture_s):
            out.append(ph)
        else:
            why = ("no capture time (EXIF DateTimeOriginal or GPS time)" if not math.isfinite(ph.gps_s) else
                   "no camera capture time (DateTimeOriginal), and no photo has both it and a GPS time to place its "
                   "GPS time on the camera's clock")
            skipped.append((ph.file, ph.size, NO_TIME, why))
    return out


def _repeats(photos: list[_Photo]) -> dict[int, str]:
    """Photos (time order) of a capture already taken by an earlier one: index → the earlier's name."""
    out: dict[int, str] = {}
    last = 0
    for i in range(1, len(photos)):
        a, b = photos[last], photos[i]
        x, y = _local_m(np.array([b.lat]), np.array([b.lon]), a.lat, a.lon)
        if b.capture_s - a.capture_s < SAME_CAPTURE_S and float(np.hypot(x[0], y[0])) < SAME_CAPTURE_M:
            out[i] = a.file.name
        else:
            last = i
    return out


def _drop(photos: list[_Photo], skipped: list[tuple[Path, int, str, str]], which: dict[int, str], category: str,
          why: Any) -> list[_Photo]:
    for i, detail in which.items():
        ph = photos[i]
        skipped.append((ph.file, ph.size, category, why(ph, detail)))
    return [ph for i, ph in enumerate(photos) if i not in which]


def _counts(skipped: list[tuple[Path, int, str, str]]) -> dict[str, int]:
    out: dict[str, int] = {}
    for _, _, c, _ in skipped:
        out[c] = out.get(c, 0) + 1
    return out


def _read_info(paths: list[Path], photos: list[_Photo], skipped: list[tuple[Path, int, str, str]]) -> ReadInfo:
    """log_report.json's "read" of a photo flight: each photo a message, each skipped photo a place."""
    order = {p: i for i, p in enumerate(paths)}
    places: list[SkipInfo] = [{"offset": 0, "length": size, "kind": _KIND[c], "reason": f"{p.name}: {r}"}
                              for p, size, c, r in sorted(skipped, key=lambda s: order[s[0]])]
    return {"bytes": sum(ph.size for ph in photos) + sum(s[1] for s in skipped), "messages": len(paths),
            "skipped_bytes": sum(s["length"] for s in places), "skipped": places[:MAX_NAMED],
            "skipped_places": len(places), "dropped_events": len(places),
            "implausible_events": sum(s["kind"] == "event" for s in places),
            "lost_bytes": sum(s["length"] for s in places if s["kind"] == "damage"),
            "checks": "photo fields, EXIF and XMP position agreement, capture time and place against the photos "
                      "before and after, take-off height"}


def _flight(folder: Path, photos: list[_Photo], skipped: list[tuple[Path, int, str, str]], others: int,
            read: ReadInfo) -> PhotoFlight:
    def col(name: str) -> np.ndarray:
        return np.array([getattr(ph, name) for ph in photos], float)

    lat, lon, yaw = col("lat"), col("lon"), col("yaw")
    unknown = ~np.isfinite(yaw)
    yaw = np.where(unknown, track_yaw(lat, lon), yaw)
    pitch, roll = col("pitch"), col("roll")
    nadir = ~np.isfinite(pitch)
    std = np.array([ph.std for ph in photos], float).reshape(-1, 3)
    events = Events(np.full(len(photos), np.nan), lat, lon, col("alt"), col("rel_alt"), np.where(np.isfinite(roll), roll, 0.0),
                    np.where(nadir, -90.0, pitch), yaw, SOURCE, camera_attitude=True)
    capture = col("capture_s")
    sources = [ph.yaw_source or "track" for ph in photos]
    files = tuple(ph.file for ph in photos)
    flags = col("rtk_flag")
    report: dict[str, Any] = {
        "folder": str(folder), "files": len(photos) + len(skipped), "other_files": others, "used": len(photos),
        "skipped": _counts(skipped),
        "cameras": sorted({ph.camera for ph in photos}),
        "first_capture": _iso(float(capture[0])), "last_capture": _iso(float(capture[-1])),
        "attitude": {"yaw": {s: sources.count(s) for s in sorted(set(sources))},
                     "pitch": {"gimbal": int((~nadir).sum()), "straight down assumed": int(nadir.sum())}},
        "event_files": [f.name for f in files],
        "rtk": rtk_report(files, flags, std),
    }
    return PhotoFlight(events, files, capture, flags, std[:, 0], std[:, 1], std[:, 2], read, report)


def _iso(t: float) -> str:
    return dt.datetime.fromtimestamp(t, dt.UTC).strftime("%Y-%m-%dT%H:%M:%S.%f")[:-3]


def rtk_report(files: tuple[Path, ...], flags: np.ndarray, std: np.ndarray) -> dict[str, Any]:
    """The RTK solution of a flight's photos (`std`: rows of RtkStdLon, RtkStdLat, RtkStdHgt):
    counts per solution, the fixed share of the photos that record one (null when none does),
    each photo without a fixed solution (file, event number, RtkFlag, solution), and the largest
    standard deviations recorded."""
    sol = [rtk_solution(float(f)) for f in flags]
    recorded = [s for s in sol if s != "not recorded"]
    counts = {s: sol.count(s) for s in ("fixed", "float", "single", "none", "not recorded")}
    not_fixed = [{"file": f.name, "event": i + 1, "flag": int(flags[i]), "solution": s}
                 for i, (f, s) in enumerate(zip(files, sol)) if s not in ("fixed", "not recorded")]

    def worst(a: np.ndarray) -> float | None:
        return round(float(np.nanmax(a)), 4) if np.isfinite(a).any() else None

    return {**counts, "fixed_share": round(counts["fixed"] / len(recorded), 6) if recorded else None,
            "not_fixed": not_fixed,
            "std_max_m": {"lon": worst(std[:, 0]), "lat": worst(std[:, 1]), "hgt": worst(std[:, 2])}}
