"""The reader of official UAS zone files: EUROCAE ED-269 (JSON) and ED-318 (GeoJSON), as
the EU states publish their UAS geographical zones (Regulation 2019/947 Art. 15).

The files are parsed with InterUSS's data types for both standards (the `uas-standards`
package: `eurocae_ed269.ED269Schema`, `eurocae_ed318.ED318Schema`), which check each field's
presence and vocabulary, after a normalisation of what published files do that the types
do not take (docs/airspace.md):

- a byte-order mark before the JSON;
- both spellings of the authorisation restriction (REQ_AUTHORISATION, REQ_AUTHORIZATION);
- ED-269 schedule times with or without seconds or fractions, with "Z", an offset or none
  (none: UTC);
- ED-318 geometries: read here (the ED-318 type parses every geometry as a Point and refuses a
  Polygon), with their layers (the type requires both limits; published files may state one: a
  limit left out is not stated, never 0), and feature ids (the type takes whole numbers only;
  GeoJSON allows strings; aerosurvey names zones by their identifier);
- limits read as the numbers written (the ED-269 type keeps whole numbers only).

What is then read into `Geozone` (airspace/model.py): one outline (polygon with its holes, or
a circle) and one band per feature; a feature with several geometries or layers is refused,
not merged; 99999 is no ceiling; feet become metres; coordinates are [longitude, latitude]
(GeoJSON's order, as InterUSS reads ED-269 too). Any fault refuses the whole file, in one line
naming the file, the feature and what is wrong.
"""

from __future__ import annotations

import datetime as dt
import math
import re
from pathlib import Path
from typing import Any

import shapely

from aerosurvey.airspace.model import FOOT_M, NO_CEILING, WEEKDAYS, DailyPeriod, Geozone, Limit, TimePeriod
from aerosurvey.errors import InputError

#: a zone file larger than this is refused (the national files are a few megabytes)
MAX_FILE_BYTES = 256 * 1024 * 1024
_TIME = re.compile(r"^(\d{1,2}):(\d{2})(?::(\d{2})(?:\.(\d+))?)?\s*(Z|[+-]\d{2}:?\d{2})?$")


class _Fault(Exception):
    """A fault in one feature, raised inside the reader and turned into the file's one-line InputError."""


def read_zone_file(path: Path, key: str = "airspace.zones") -> tuple[Geozone, ...]:
    """Every zone of an ED-269 or ED-318 file (the format is told by the file's structure)."""
    import orjson

    name = path.name
    try:
        size = path.stat().st_size
        if size > MAX_FILE_BYTES:
            raise InputError(f"zone file {str(path)!r} holds {size:,} bytes, more than the {MAX_FILE_BYTES:,} a zone file may", key=key)
        raw = path.read_bytes()
    except FileNotFoundError:
        raise InputError(f"zone file {str(path)!r} does not exist", key=key) from None
    except OSError as exc:
        raise InputError(f"zone file {str(path)!r} cannot be read: {exc}", key=key) from None
    if raw.startswith(b"\xef\xbb\xbf"):
        raw = raw[3:]
    try:
        data = orjson.loads(raw)
    except orjson.JSONDecodeError as exc:
        raise InputError(f"zone file {name!r} is not JSON: {exc}", key=key) from None
    return parse_zone_data(data, name, key)


def parse_zone_data(data: Any, name: str, key: str = "airspace.zones") -> tuple[Geozone, ...]:
    """The zones of parsed JSON `data` from the file `name`: ED-318 (a GeoJSON FeatureCollection) or ED-269."""
    if isinstance(data, dict) and data.get("type") == "FeatureCollection":
        fmt, read = "ED-318", _ed318
    elif isinstance(data, dict) and isinstance(data.get("features"), list):
        fmt, read = "ED-269", _ed269
    else:
        raise InputError(f"zone file {name!r} is neither ED-269 (an object with 'features', each with a 'geometry' list) "
                         "nor ED-318 (a GeoJSON FeatureCollection)", key=key)
    try:
        zones = read(data, name)
    except _Fault as exc:
        raise InputError(f"zone file {name!r} ({fmt}): {exc}", key=key) from None
    except (ValueError, TypeError) as exc:  # the types' own parse errors: "At features[3].geometry[0]...: what"
        raise InputError(f"zone file {name!r} is not valid {fmt}: {_one_line(str(exc))}", key=key) from None
    if not zones:
        raise InputError(f"zone file {name!r} ({fmt}) holds no zone", key=key)
    return zones


def _one_line(text: str) -> str:
    return " ".join(text.split()).removeprefix("At ")


def _feature_name(i: int, raw: Any) -> str:
    ident = raw.get("identifier") if isinstance(raw, dict) else None
    return f"feature {i}" + (f" ({ident})" if isinstance(ident, str) else "")


# --- ED-269 ---------------------------------------------------------------------------------

def _ed269(data: dict[str, Any], name: str) -> tuple[Geozone, ...]:
    from uas_standards.eurocae_ed269 import ED269Schema

    raw_features = data["features"]
    normalised = {**data, "features": [_ed269_normalised(i, f) for i, f in enumerate(raw_features)]}
    doc = ED269Schema.from_dict(normalised)
    out = []
    for i, (f, raw) in enumerate(zip(doc.features, raw_features)):
        where = _feature_name(i, raw)
        if len(f.geometry) != 1:
            raise _Fault(f"{where} has {len(f.geometry)} geometries (airspace volumes); one zone per feature is read, "
                         "several are refused rather than merged: split them into features of their own")
        g = f.geometry[0]
        raw_g = raw["geometry"][0]
        unit = FOOT_M if g.uomDimensions.value == "FT" else 1.0
        lower = _limit(raw_g.get("lowerLimit"), g.lowerVerticalReference.value, unit, f"{where} lowerLimit", ceiling=False)
        upper = _limit(raw_g.get("upperLimit"), g.upperVerticalReference.value, unit, f"{where} upperLimit", ceiling=True)
        hp = g.horizontalProjection
        if hp.type.value == "Circle":
            outline, radius = _circle(hp.get("center"), hp.get("radius"), unit, where)
        else:
            outline, radius = _polygon(hp.get("coordinates"), where), None
        periods, unresolved = _ed269_periods(f.applicability, where)
        out.append(Geozone(
            file=name, format="ED-269", index=i, identifier=f.identifier, name=f.get("name") or "",
            restriction=f.restriction.value, message=f.get("message") or "", outline=outline, radius_m=radius,
            lower=lower, upper=upper, periods=periods, unresolved_times=unresolved))
    return tuple(out)


def _ed269_normalised(i: int, f: Any) -> Any:
    """A feature as the ED-269 types take it: the other spelling of REQ_AUTHORISATION, schedule times canonical."""
    if not isinstance(f, dict):
        return f
    f = dict(f)
    if f.get("restriction") == "REQ_AUTHORIZATION":
        f["restriction"] = "REQ_AUTHORISATION"
    app = f.get("applicability")
    if isinstance(app, list):
        f["applicability"] = [_with_times(a, f"{_feature_name(i, f)} applicability[{k}]") for k, a in enumerate(app)]
    return f


def _with_times(a: Any, where: str) -> Any:
    if not isinstance(a, dict) or not isinstance(a.get("schedule"), list):
        return a
    schedule = []
    for k, d in enumerate(a["schedule"]):
        if isinstance(d, dict):
            d = dict(d)
            for t in ("startTime", "endTime"):
                if t in d:
                    d[t] = _canonical_time(d[t], f"{where} schedule[{k}].{t}")
        schedule.append(d)
    return {**a, "schedule": schedule}


def _canonical_time(value: Any, where: str) -> str:
    """ED-269's time as its type parses it ("HH:mm:ss.SZ"): seconds and fraction filled in, no offset read as UTC."""
    m = _TIME.match(value) if isinstance(value, str) else None
    if m is None or int(m[1]) > 24 or int(m[2]) > 59 or int(m[3] or 0) > 59:
        raise _Fault(f"{where} = {value!r} is not a time of day: HH:MM[:SS[.ff]] with Z or an offset")
    hour = int(m[1])
    if hour == 24:  # "24:00": the day's end
        if int(m[2]) or int(m[3] or 0) or int(m[4] or 0):
            raise _Fault(f"{where} = {value!r} is not a time of day: 24:00 is the latest")
        return "23:59:59.99" + _offset(m[5])
    return f"{hour:02d}:{m[2]}:{m[3] or '00'}.{(m[4] or '0')[:2]}" + _offset(m[5])


def _offset(text: str | None) -> str:
    if text is None or text == "Z":
        return "Z"
    return text.replace(":", "")


def _ed269_periods(applicability: list[Any], where: str) -> tuple[tuple[TimePeriod, ...], bool]:
    """The zone's times: () when one applicability is permanent (or there is none)."""
    periods = []
    for a in applicability:
        if a.permanent.value == "YES":
            return (), False
        schedule = tuple(DailyPeriod(_days(d.day, where), d.startTime.time, d.endTime.time) for d in (a.get("schedule") or ()))
        periods.append(_period(a.get("startDateTime"), a.get("endDateTime"), schedule, where))
    return tuple(periods), False


# --- ED-318 ---------------------------------------------------------------------------------

def _ed318(data: dict[str, Any], name: str) -> tuple[Geozone, ...]:
    from uas_standards.eurocae_ed318 import ED318Schema

    raw_features = data.get("features")
    if not isinstance(raw_features, list):
        raise _Fault("'features' is not a list")
    # geometries and layers are read here: the type takes a Point only, and requires both limits
    layers = [_layer_of(i, f) for i, f in enumerate(raw_features)]
    features = [_ed318_normalised(f) for f in raw_features]
    doc = ED318Schema.from_dict({**data, "metadata": data.get("metadata", {}), "features": features})
    out = []
    for i, (f, raw, layer) in enumerate(zip(doc.features, raw_features, layers)):
        p = f.properties
        where = _feature_name(i, raw.get("properties"))
        if p is None or not isinstance(raw.get("geometry"), dict):
            raise _Fault(f"{where} has no {'properties' if p is None else 'geometry'}")
        outline, radius = _ed318_outline(raw["geometry"], layer, where)
        unit = FOOT_M if layer is not None and layer.get("uom") == "ft" else 1.0
        lower = upper = None
        if layer is not None and layer.get("lower") is not None:
            lower = _limit(layer["lower"], _reference(layer, "lowerReference", where), unit, f"{where} layer.lower", ceiling=False)
        if layer is not None and layer.get("upper") is not None:
            upper = _limit(layer["upper"], _reference(layer, "upperReference", where), unit, f"{where} layer.upper", ceiling=True)
        kind = p.type.value
        periods, unresolved = _ed318_periods(p.get("limitedApplicability"), where)
        out.append(Geozone(
            file=name, format="ED-318", index=i, identifier=p.identifier, name=_text(p.get("name")),
            # U-space airspace needs a U-space service's authorisation to enter
            restriction="REQ_AUTHORISATION" if kind in ("REQ_AUTHORIZATION", "USPACE") else kind,
            message=_text(p.get("message")), outline=outline, radius_m=radius, lower=lower, upper=upper,
            periods=periods, unresolved_times=unresolved))
    return tuple(out)


def _layer_of(i: int, f: Any) -> dict[str, Any] | None:
    g = f.get("geometry") if isinstance(f, dict) else None
    where = _feature_name(i, f.get("properties") if isinstance(f, dict) else None)
    if isinstance(g, dict) and g.get("type") == "GeometryCollection":
        n = len(g.get("geometries") or [])
        raise _Fault(f"{where} is a GeometryCollection of {n} geometries (each with its own layer); one zone per feature "
                     "is read, several are refused rather than merged: split them into features of their own")
    layer = g.get("layer") if isinstance(g, dict) else None
    if layer is not None and not isinstance(layer, dict):
        raise _Fault(f"{where} geometry.layer = {layer!r} is not an object")
    if layer is not None and layer.get("uom", "m") not in ("m", "ft"):
        raise _Fault(f"{where} geometry.layer.uom = {layer.get('uom')!r} is not m or ft")
    return layer


def _ed318_normalised(f: Any) -> Any:
    if not isinstance(f, dict):
        return f
    f = dict(f)
    f["geometry"] = None
    f.pop("id", None)  # the type reads any id as a whole number; a GeoJSON id may be a string (and is not used)
    p = f.get("properties")
    if isinstance(p, dict) and p.get("type") == "REQ_AUTHORISATION":
        f["properties"] = {**p, "type": "REQ_AUTHORIZATION"}
    return f


def _reference(layer: dict[str, Any], key: str, where: str) -> str:
    ref = layer.get(key)
    if ref not in ("AGL", "AMSL", "WGS84"):
        raise _Fault(f"{where} layer.{key} = {ref!r} is not one of AGL, AMSL, WGS84")
    return str(ref)


def _ed318_outline(g: dict[str, Any], layer: dict[str, Any] | None, where: str) -> tuple[shapely.Geometry, float | None]:
    kind = g.get("type")
    if kind == "Polygon":
        return _polygon(g.get("coordinates"), where), None
    if kind == "MultiPolygon":
        parts = g.get("coordinates")
        if not isinstance(parts, list) or not parts:
            raise _Fault(f"{where} MultiPolygon coordinates are not a list of polygons")
        return shapely.union_all([_polygon(p, f"{where} polygon {k}") for k, p in enumerate(parts)]), None
    if kind == "Point":
        extent = g.get("extent")
        if not isinstance(extent, dict) or extent.get("subType") != "Circle":
            raise _Fault(f"{where} is a Point without a circle extent (extent.subType 'Circle' and its radius)")
        unit = FOOT_M if layer is not None and layer.get("uom") == "ft" else 1.0
        return _circle(g.get("coordinates"), extent.get("radius"), unit, where)
    raise _Fault(f"{where} geometry type {kind!r} is not a zone outline: Polygon, MultiPolygon or Point with a circle extent")


def _ed318_periods(limited: list[Any] | None, where: str) -> tuple[tuple[TimePeriod, ...], bool]:
    """The zone's times: () without limitedApplicability (ED-318: the zone always applies)."""
    if not limited:
        return (), False
    periods = []
    unresolved = False
    for a in limited:
        schedule = []
        for d in a.get("schedule") or ():
            start = _ed318_time(d.get("startTime"), f"{where} schedule startTime")
            end = _ed318_time(d.get("endTime"), f"{where} schedule endTime")
            if (start is None and d.get("startEvent")) or (end is None and d.get("endEvent")):
                unresolved = True  # sunrise, sunset, twilight: taken as the day's start or end
            elif start is None or end is None:
                raise _Fault(f"{where} schedule has no {'startTime' if start is None else 'endTime'} and no daylight event")
            schedule.append(DailyPeriod(_days(d.day, where), start, end))
        periods.append(_period(a.get("startDateTime"), a.get("endDateTime"), tuple(schedule), where))
    return tuple(periods), unresolved


def _ed318_time(value: Any, where: str) -> dt.time | None:
    if value is None:
        return None
    m = _TIME.match(value) if isinstance(value, str) else None
    if m is None or int(m[1]) > 24 or int(m[2]) > 59 or int(m[3] or 0) > 59:
        raise _Fault(f"{where} = {value!r} is not a time of day: HH:MM[:SS] with Z or an offset")
    off = m[5]
    tz = dt.UTC if off is None or off == "Z" else dt.timezone(
        (1 if off[0] == "+" else -1) * dt.timedelta(hours=int(off[1:3]), minutes=int(off[-2:])))
    if int(m[1]) == 24:
        return dt.time(23, 59, 59, 999999, tzinfo=tz)
    return dt.time(int(m[1]), int(m[2]), int(m[3] or 0), tzinfo=tz)


def _text(texts: Any) -> str:
    """An ED-318 text list's English text, else its first."""
    if not texts:
        return ""
    english = [t for t in texts if str(t.get("lang") or "").lower().startswith("en") and t.get("text")]
    first = english[0] if english else texts[0]
    return str(first.get("text") or "")


# --- shared ---------------------------------------------------------------------------------

def _days(days: list[Any], where: str) -> tuple[str, ...]:
    names = {d.value for d in days}
    if not names:
        raise _Fault(f"{where} has a schedule entry with no day")
    return WEEKDAYS if "ANY" in names else tuple(d for d in WEEKDAYS if d in names)


def _period(start: Any, end: Any, schedule: tuple[DailyPeriod, ...], where: str) -> TimePeriod:
    a = start.datetime if start is not None else None
    b = end.datetime if end is not None else None
    if a is not None and b is not None and b < a:
        raise _Fault(f"{where} applies from {start} to {end}: the end is before the start")
    return TimePeriod(a, b, schedule)


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool):
        raise _Fault(f"{where} = {value!r} is not a number")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise _Fault(f"{where} = {value!r} is not a number") from None
    if not math.isfinite(v):
        raise _Fault(f"{where} = {value!r} is not a finite number")
    return v


def _limit(value: Any, reference: str, unit: float, where: str, ceiling: bool) -> Limit | None:
    """A limit in metres; None when not stated (and an upper limit of 99999: no ceiling)."""
    if value is None:
        return None
    v = _number(value, where)
    if ceiling and v >= NO_CEILING:
        return None
    if v < -1000.0 / unit or v > 100_000.0 / unit:
        raise _Fault(f"{where} = {value!r} is not a height: from -1000 m to 100 km")
    return Limit(v * unit, reference)


def _position(p: Any, where: str) -> tuple[float, float]:
    if not isinstance(p, list) or len(p) not in (2, 3):
        raise _Fault(f"{where}: position {p!r} is not [longitude, latitude]")
    lon, lat = _number(p[0], where), _number(p[1], where)
    if not -90.0 <= lat <= 90.0 or not -180.0 <= lon <= 180.0:
        raise _Fault(f"{where}: position {p!r} is not [longitude, latitude] (longitude first, as GeoJSON and ED-269 order them; "
                     "is the file written latitude first?)")
    return lon, lat


def _polygon(rings: Any, where: str) -> shapely.Polygon:
    """A polygon from GeoJSON rings: the outline, then its holes."""
    if not isinstance(rings, list) or not rings:
        raise _Fault(f"{where} polygon coordinates are not a list of rings")
    out = []
    for k, ring in enumerate(rings):
        if not isinstance(ring, list):
            raise _Fault(f"{where} ring {k} is not a list of positions")
        pts = [_position(p, f"{where} ring {k}") for p in ring]
        if len(pts) > 1 and pts[0] == pts[-1]:
            pts = pts[:-1]
        if len(set(pts)) < 3:
            raise _Fault(f"{where} ring {k} has {len(set(pts))} distinct positions: a ring needs 3 or more")
        out.append(pts)
    poly = shapely.Polygon(out[0], out[1:])
    if not poly.is_valid:
        reason = shapely.is_valid_reason(poly)
        raise _Fault(f"{where} polygon is not valid ({reason}): its first ring is the outline, the others holes inside it")
    return poly


def _circle(center: Any, radius: Any, unit: float, where: str) -> tuple[shapely.Point, float]:
    lon, lat = _position(center, f"{where} circle centre")
    r = _number(radius, f"{where} circle radius") * unit
    if r <= 0 or r > 1_000_000:
        raise _Fault(f"{where} circle radius = {radius!r} is not a radius: more than 0 and at most 1000 km")
    return shapely.Point(lon, lat), r
