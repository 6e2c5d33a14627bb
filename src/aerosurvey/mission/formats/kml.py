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
from collections.abc import Callable, Mapping, Sequence
from functools import lru_cache
from typing import Any

import numpy as np

from aerosurvey.errors import InputError
from aerosurvey.jsontext import Column, exponent_form, float_array, float_texts, join_rows, kinds_of, one_value
from aerosurvey.mission.formats.points import PointLayer
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
_ESCAPES = {"&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;"}
_ESC = str.maketrans(_ESCAPES)
_NOT_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")
# escapes as _ESC, and every character XML cannot hold becomes U+FFFF (itself one), so that one
# search for that character in the finished document tells whether any text held one
_NOT_XML_CODES = [*range(0x00, 0x09), 0x0B, 0x0C, *range(0x0E, 0x20), *range(0xD800, 0xE000), 0xFFFE]
_ESC_MARK = str.maketrans(_ESCAPES | dict.fromkeys(_NOT_XML_CODES, "\uffff"))
# the characters _ESC_MARK changes
_TO_MARK = re.compile('[&<>"\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe]')


def _mark(value: str) -> str:
    """`value.translate(_ESC_MARK)`, the text itself when there is nothing to change: a search
    is ~0.3 µs on an id, translate ~1.8 µs (its fast path is for one-character replacements only)."""
    return value if _TO_MARK.search(value) is None else value.translate(_ESC_MARK)


def _text(value: str, where: str) -> str:
    """XML-escaped text; a character XML 1.0 cannot carry is an error, not silently dropped."""
    if _NOT_XML.search(value):
        raise _not_xml(value, where)
    return value.translate(_ESC)


def _not_xml(value: str, where: str) -> InputError:
    bad = _NOT_XML.search(value)
    assert bad is not None
    return InputError(f"{where} = {value!r} is not allowed: text without control characters (found U+{ord(bad.group()):04X})")


def _escaped(value: str, where: str) -> str:
    """XML-escaped text, checked later: a character XML cannot carry is written as U+FFFF, the
    document is searched once for it, and only then made again with `_text` to say where it is."""
    return _mark(value)


Escape = Callable[[str, str], str]


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


def _data_text(v: Any) -> str:
    """A property value as it goes into <value>: `_value`, XML-escaped where it can hold markup."""
    if type(v) is str:
        return _mark(v)
    if type(v) is float and v - v == 0.0:  # finite
        return repr(v)
    if v is None or isinstance(v, (bool, int, float)):
        return _value(v)
    return _mark(_value(v))


@lru_cache(maxsize=256)
def _cells(keys: tuple[Any, ...]) -> tuple[tuple[Any, ...], str]:
    """The keys in their order (`id` first, then by name) and the Data elements' %-template; cached
    because thousands of features share a few key sets. A name XML cannot hold is an error."""
    order = (("id",) if "id" in keys else ()) + tuple(sorted((k for k in keys if k != "id"), key=str))
    cells = []
    for k in order:
        opening = _data_open(str(k))
        if opening is None:
            raise _not_xml(str(k), "property name")
        cells.append(opening.replace("%", "%%") + "%s</value></Data>")
    return order, "".join(cells)


def _check_values(data: dict[str, Any], keys: tuple[Any, ...]) -> None:
    """Every text value free of characters XML cannot hold, or an error naming the property."""
    for k in keys:
        v = data[k]
        if not (v is None or isinstance(v, (bool, int, float))):
            _text(_value(v), f"property {k!r}")


def _number(c: Any, where: str) -> str:
    if type(c) is float and c - c == 0.0:  # finite: most are written as repr writes them
        text = repr(c)
        return text if text[-2:] != ".0" and "e" not in text else format_number(c)
    if type(c) is not float and (isinstance(c, bool) or not isinstance(c, (int, float))) or not math.isfinite(c):
        raise InputError(f"{where} = {c!r} is not allowed: a finite number")
    return format_number(c)


def _position(p: Any, where: str, with_z: bool) -> str:
    if type(p) is not list and not isinstance(p, (list, tuple)) or not 2 <= len(p) <= 3:
        raise InputError(f"{where} = {p!r} is not allowed: [longitude, latitude] or [longitude, latitude, height]")
    if with_z and len(p) == 3:
        return f"{_number(p[0], where)},{_number(p[1], where)},{_number(p[2], where)}"
    return f"{_number(p[0], where)},{_number(p[1], where)}"


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
    if t == "Point" and where == "geometry" and type(c := g.get("coordinates")) is list and len(c) == 2:  # most features
        return f"<Point><coordinates>{_number(c[0], t)},{_number(c[1], t)}</coordinates></Point>"
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


def _placemark(f: dict[str, Any], props: dict[str, Any], role: str, text: Escape) -> str:
    """One Placemark: named by its id (else its role), the id and properties as Data, then the geometry."""
    fid = f.get("id")
    data: dict[str, Any] = props if fid is None or "id" in props else {"id": fid, **props}
    name = text(_value(data.get("id", role)), "id")
    keys, template = _cells(tuple(data))
    if text is _text:
        _check_values(data, keys)
    # the common values (text, finite floats, whole numbers) inline: this runs for every property of thousands of stations
    cells = template % tuple([_mark(v) if type(v) is str
                              else repr(v) if type(v) is int or type(v) is float and v - v == 0.0
                              else _data_text(v) for v in map(data.__getitem__, keys)])
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


def feature_collection_to_kml(fc: dict[str, Any], name: str, layers: Sequence[PointLayer] = ()) -> str:
    """KML text for `fc`, one Folder per role in ROLE_ORDER (empty roles left out), named
    `name`; each of `layers` (points held as columns) goes after `fc`'s features of its role."""
    out = _document(fc, name, _escaped, layers)
    if not out.isascii() and "\uffff" in out:  # rare: made again, checking every text, to name where
        return _document(_with_features(fc, layers), name, _text)
    return out


def _with_features(fc: dict[str, Any], layers: Sequence[PointLayer]) -> dict[str, Any]:
    """`fc` with the layers' points as features after its own (each then written one by one)."""
    return {**fc, "features": [*fc["features"], *(f for layer in layers for f in layer.features())]}


def _document(fc: dict[str, Any], name: str, text: Escape, layers: Sequence[PointLayer] = ()) -> str:
    """The document; the layers' points a column at a time (`_layer_parts`), the same text as
    one by one, faster. A layer holding a value KML refuses is written one by one, which names it."""
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
            mark = _placemark(f, props, role, text)
        except InputError as exc:
            fid = f.get("id", props.get("id"))
            where = f"KML export: feature {k}" + (f" (id {fid!r})" if fid is not None else "")
            raise InputError(f"{where} {exc}") from None
        by_role.setdefault(role, []).append(mark)
    for layer in layers:
        if len(layer):
            made = _layer_parts(layer)
            if made is None:
                return _document(_with_features(fc, layers), name, text)
            role, parts = made
            by_role.setdefault(role, []).append(join_rows(parts, len(layer), "\n"))
    out = ['<?xml version="1.0" encoding="UTF-8"?>', '<kml xmlns="http://www.opengis.net/kml/2.2">',
           f"<Document><name>{text(name, 'KML export: document name')}</name>"]
    out += [_style(role) for role in ROLE_ORDER]
    for role in ROLE_ORDER:
        if by_role.get(role):
            out.append(f"<Folder><name>{role}</name>")
            out.extend(by_role[role])
            out.append("</Folder>")
    out += ["</Document></kml>", ""]  # the last: the newline at the end, without another copy of the text
    return "\n".join(out)


def _escaped_all(texts: Sequence[str]) -> list[str]:
    """`_escaped` of each text; one search of them all first, as most (ids) need nothing done."""
    joined = "".join(texts)
    # printable ASCII (no control character) without a character to escape; by str methods in C,
    # not a regular expression: measured on the 1,000 ha plan's 7,309 stations, ~2 ms → ~0.2 ms a KML
    if joined.isascii() and joined.isprintable() and not any(c in joined for c in _TO_ESCAPE):
        return list(texts)
    return [_mark(v) for v in texts]


_TO_ESCAPE = tuple(_ESCAPES)


def _cell_texts(col: Sequence[Any]) -> str | list[str]:
    """A property column as `_placemark` writes its values (escaped as `_escaped` does); a
    column of one string (`jsontext.one_value`, the role) as its one text."""
    one = one_value(col)
    if one is not None:
        return _escaped_all([one])[0]
    kinds = kinds_of(col)
    if kinds == {str}:
        return _escaped_all(col)
    if kinds == {int}:  # JSON writes an int as repr does: a Column's texts serve
        return list(col.texts) if type(col) is Column else list(map(int.__repr__, col))
    if kinds == {float}:
        try:
            return float_texts(col)
        except ValueError:  # a NaN or infinity: written as the rows below write it
            pass
    return [_mark(v) if type(v) is str
            else repr(v) if type(v) is int or type(v) is float and v - v == 0.0
            else _data_text(v) for v in col]


def _layer_parts(layer: PointLayer) -> tuple[str, list[str | list[str]]] | None:
    """The role and `_point_parts` of a PointLayer; None if it holds a name or value
    `_placemark` would refuse (or points of several roles)."""
    props = dict(layer.properties)
    roles = set(props.get("role", ("other",)))
    if len(roles) != 1:
        return None
    role = roles.pop()
    role = role if isinstance(role, str) and role in STYLES else "other"
    data = props if "id" in props else {"id": layer.ids, **props}
    parts = _point_parts(role, data, [layer.lon, layer.lat])
    return None if parts is None else (role, parts)


def _point_parts(role: str, data: Mapping[str, Sequence[Any]], coords: list[Sequence[Any]]) -> list[str | list[str]] | None:
    """`join_rows` parts of the placemarks of points with these property columns (in the
    features' order, `id` among them if they have one) and coordinate columns, as
    `_placemark` writes each (thousands of stations: their numbers through `float_texts`);
    None if a name or value is one `_placemark` would refuse."""
    try:
        order, _ = _cells(tuple(data))  # and the names checked
    except InputError:
        return None
    columns = [_cell_texts(data[k]) for k in order]
    positions = []
    for col in coords:
        if kinds_of(col) != {float}:
            return None
        try:
            texts = float_texts(col)
        except ValueError:
            return None
        # repr ends in ".0" for a whole number, or has an exponent: those are written by
        # format_number, as `_placemark` writes them
        a = float_array(col)
        for i in np.flatnonzero((a == np.floor(a)) | exponent_form(a)).tolist():
            texts[i] = format_number(col[i])
        positions.append(texts)
    n = len(coords[0])
    if "id" in data:
        ids = data["id"]
        names = (_escaped_all(ids) if kinds_of(ids) == {str}
                 else [_mark(_value(v)) for v in ids])
    else:
        names = [_mark(role)] * n
    mode = "<altitudeMode>relativeToGround</altitudeMode>" if len(positions) == 3 else ""
    parts: list[str | list[str]] = ["<Placemark><name>", names, f"</name><styleUrl>#{role}</styleUrl><ExtendedData>"]
    for k, col in zip(order, columns):
        parts += [_data_open(str(k)) or "", col, "</value></Data>"]
    parts += [f"</ExtendedData><Point>{mode}<coordinates>", positions[0]]
    for more in positions[1:]:
        parts += [",", more]
    parts.append("</coordinates></Point></Placemark>")
    return parts
