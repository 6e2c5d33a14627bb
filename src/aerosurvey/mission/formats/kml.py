"""KML 2.2 from a GeoJSON FeatureCollection (WGS84): one folder and one style per role.

Why this shape: a pilot or client opens the plan in Google Earth and switches roles on and
off, so every feature goes into the folder of its `role` property (unknown or missing
roles go to "other") and every role has its own style. Folders come in the fixed order of
ROLE_ORDER and features keep their order, so equal input gives equal bytes.

Geometry: Point, LineString, Polygon (with holes), their Multi* forms and
GeometryCollection. A Point with a third coordinate is written with altitudeMode
relativeToGround, so a station shows at its flying height above the ground below it;
every other geometry is clamped to the ground (the KML default) and written with
longitude and latitude only. Unclosed polygon rings are closed, as KML requires.

Attributes: the feature `id` and every property go into ExtendedData as Data elements,
`id` first, then properties by name (a property called "id" wins over the feature id).
Strings are written as they are, other values as JSON. Text is XML-escaped; characters
XML 1.0 cannot hold (most control characters) are refused with the feature named.
"""

from __future__ import annotations

import json
import math
import re
from functools import lru_cache
from typing import Any

from aerosurvey.errors import InputError
from aerosurvey.mission.formats.wpl import format_number

ROLE_ORDER = ("area", "exclusion", "line", "station", "footprint", "home", "gcp", "check", "sortie", "gap", "uncovered", "other")
# role -> (line colour, fill colour, line width, icon colour, icon scale); KML colours are aabbggrr
STYLES: dict[str, tuple[str, str, float, str, float]] = {
    "area": ("ff2c7d3a", "4000ff00", 2.0, "ff2c7d3a", 1.0),
    "exclusion": ("ff0000bb", "660000ff", 2.0, "ff0000bb", 1.0),
    "line": ("ffbf5f1f", "00000000", 3.0, "ffbf5f1f", 0.8),
    "station": ("ff111111", "00000000", 1.0, "ff00d7ff", 0.5),
    "footprint": ("66888888", "00000000", 1.0, "66888888", 0.5),
    "home": ("ff000000", "00000000", 1.0, "ffffffff", 1.2),
    "gcp": ("ff0000ee", "00000000", 1.0, "ff0000ee", 1.0),
    "check": ("ffff8800", "00000000", 1.0, "ffff8800", 1.0),
    "sortie": ("ff00aaff", "00000000", 3.0, "ff00aaff", 1.0),
    "gap": ("ff7f00ff", "807f00ff", 2.0, "ff7f00ff", 1.0),
    "uncovered": ("ff0080ff", "990080ff", 2.0, "ff0080ff", 1.0),
    "other": ("ff555555", "33555555", 1.0, "ff555555", 1.0),
}
_ESC = str.maketrans({"&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;"})
_NOT_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")


def _text(value: str, where: str) -> str:
    """XML-escaped text; a character XML 1.0 cannot carry is an error, not silently dropped."""
    bad = _NOT_XML.search(value)
    if bad:
        raise InputError(f"{where} = {value!r} is not allowed: text without control characters "
                         f"(found U+{ord(bad.group()):04X})")
    return value.translate(_ESC)


def _value(v: Any) -> str:
    """A property value as Data text: strings as they are, everything else as compact JSON."""
    if isinstance(v, str):
        return v
    if v is None:
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int) or (isinstance(v, float) and math.isfinite(v)):
        return repr(v)
    return json.dumps(v, sort_keys=True, separators=(",", ":"), ensure_ascii=False, default=str)


@lru_cache(maxsize=4096)
def _data_open(key: str) -> str | None:
    """`<Data name="key"><value>`, cached because a few names repeat on thousands of features; None if XML cannot hold `key`."""
    if _NOT_XML.search(key):
        return None
    return f'<Data name="{key.translate(_ESC)}"><value>'


def _cell(key: Any, v: Any) -> str:
    opening = _data_open(str(key))
    if opening is None:
        _text(str(key), "property name")
    if v is None or isinstance(v, (bool, int, float)):
        return f"{opening}{_value(v)}</value></Data>"
    return f"{opening}{_text(_value(v), f'property {key!r}')}</value></Data>"


def _number(c: Any, where: str) -> str:
    if isinstance(c, bool) or not isinstance(c, (int, float)) or not math.isfinite(c):
        raise InputError(f"{where} = {c!r} is not allowed: a finite number")
    return format_number(c)


def _position(p: Any, where: str, with_z: bool) -> str:
    if not isinstance(p, (list, tuple)) or not 2 <= len(p) <= 3:
        raise InputError(f"{where} = {p!r} is not allowed: [longitude, latitude] or [longitude, latitude, height]")
    n = 3 if with_z and len(p) == 3 else 2
    return ",".join([_number(c, where) for c in p[:n]])


def _positions(seq: Any, where: str, minimum: int) -> list[Any]:
    if not isinstance(seq, (list, tuple)) or len(seq) < minimum:
        raise InputError(f"{where} = {seq!r} is not allowed: at least {minimum} positions")
    return list(seq)


def _ring(ring: Any, where: str) -> str:
    coords = [_position(p, where, False) for p in _positions(ring, where, 3)]
    if coords[0] != coords[-1]:
        coords.append(coords[0])
    if len(coords) < 4:
        raise InputError(f"{where} has {len(coords) - 1} distinct positions; a polygon ring needs at least 3")
    return f"<LinearRing><coordinates>{' '.join(coords)}</coordinates></LinearRing>"


def _geometry(g: Any, where: str = "geometry") -> str:
    """KML for one GeoJSON geometry; errors say where inside the geometry, the caller adds the feature."""
    if not isinstance(g, dict) or "type" not in g:
        raise InputError(f"{where} = {g!r} is not allowed: a GeoJSON geometry object")
    t = g["type"]
    if t == "GeometryCollection":
        parts = g.get("geometries")
        if not isinstance(parts, list):
            raise InputError(f"{where} GeometryCollection has no 'geometries' list")
        return "<MultiGeometry>" + "".join(_geometry(p, f"{where} part {k}") for k, p in enumerate(parts, 1)) + "</MultiGeometry>"
    if "coordinates" not in g:
        raise InputError(f"{where} {t} has no 'coordinates'")
    c = g["coordinates"]
    label = t if where == "geometry" else f"{where} ({t})"
    if t == "Point":
        pos = _position(c, label, True)
        mode = "<altitudeMode>relativeToGround</altitudeMode>" if pos.count(",") == 2 else ""
        return f"<Point>{mode}<coordinates>{pos}</coordinates></Point>"
    if t == "LineString":
        coords = " ".join([_position(p, label, False) for p in _positions(c, label, 2)])
        return f"<LineString><tessellate>1</tessellate><coordinates>{coords}</coordinates></LineString>"
    if t == "Polygon":
        rings = _positions(c, label, 1)
        out = [f"<outerBoundaryIs>{_ring(rings[0], f'{label} outer ring')}</outerBoundaryIs>"]
        out += [f"<innerBoundaryIs>{_ring(r, f'{label} hole {k}')}</innerBoundaryIs>" for k, r in enumerate(rings[1:], 1)]
        return "<Polygon>" + "".join(out) + "</Polygon>"
    if t in ("MultiPoint", "MultiLineString", "MultiPolygon"):
        single = t[len("Multi"):]
        parts = _positions(c, label, 1)
        inner = "".join(_geometry({"type": single, "coordinates": p}, f"{label} part {k}") for k, p in enumerate(parts, 1))
        return f"<MultiGeometry>{inner}</MultiGeometry>"
    raise InputError(f"{where} type = {t!r} is not allowed: Point, LineString, Polygon, their Multi* forms "
                     "or GeometryCollection")


def _placemark(f: dict[str, Any], props: dict[str, Any], role: str) -> str:
    """One Placemark: named by its id (else its role), the id and properties as Data, then the geometry."""
    data: dict[str, Any] = {}
    if f.get("id") is not None:
        data["id"] = f["id"]
    data.update(props)
    keys = (["id"] if "id" in data else []) + sorted((k for k in data if k != "id"), key=str)
    name = _text(_value(data.get("id", role)), "id")
    cells = "".join([_cell(k, data[k]) for k in keys])
    geom = "" if f.get("geometry") is None else _geometry(f["geometry"])
    return (f"<Placemark><name>{name}</name><styleUrl>#{role}</styleUrl>"
            f"<ExtendedData>{cells}</ExtendedData>{geom}</Placemark>")


def _style(role: str) -> str:
    """The role's Style; a fully transparent fill is switched off so lines and points stay clickable."""
    line, fill, width, icon, scale = STYLES[role]
    filled = 0 if fill.startswith("00") else 1
    return (f'<Style id="{role}"><IconStyle><color>{icon}</color><scale>{scale}</scale></IconStyle>'
            f"<LineStyle><color>{line}</color><width>{width}</width></LineStyle>"
            f"<PolyStyle><color>{fill}</color><fill>{filled}</fill><outline>1</outline></PolyStyle></Style>")


def feature_collection_to_kml(fc: dict[str, Any], name: str) -> str:
    """KML text for `fc`, one Folder per role in ROLE_ORDER (empty roles left out), named `name`."""
    if not isinstance(fc, dict) or not isinstance(fc.get("features"), list):
        raise InputError("KML export: the input is not a GeoJSON FeatureCollection with a 'features' list")
    by_role: dict[str, list[str]] = {}
    for k, f in enumerate(fc["features"], start=1):
        if not isinstance(f, dict):
            raise InputError(f"KML export: feature {k} = {f!r} is not allowed: a GeoJSON Feature object")
        props = f.get("properties") or {}
        if not isinstance(props, dict):
            raise InputError(f"KML export: feature {k} properties = {props!r} is not allowed: an object")
        role = props.get("role", "other")
        role = role if isinstance(role, str) and role in STYLES else "other"
        try:
            mark = _placemark(f, props, role)
        except InputError as exc:
            fid = f.get("id", props.get("id"))
            where = f"KML export: feature {k}" + (f" (id {fid!r})" if fid is not None else "")
            raise InputError(f"{where} {exc}") from None
        by_role.setdefault(role, []).append(mark)
    out = ['<?xml version="1.0" encoding="UTF-8"?>', '<kml xmlns="http://www.opengis.net/kml/2.2">',
           f"<Document><name>{_text(name, 'KML export: document name')}</name>"]
    out += [_style(role) for role in ROLE_ORDER]
    for role in ROLE_ORDER:
        marks = by_role.get(role)
        if marks:
            out.append(f"<Folder><name>{role}</name>")
            out.extend(marks)
            out.append("</Folder>")
    out.append("</Document></kml>")
    return "\n".join(out) + "\n"
