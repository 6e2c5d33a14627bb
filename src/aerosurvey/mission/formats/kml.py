"""KML 2.2 from a GeoJSON FeatureCollection (WGS84): one folder and one style per role.

Points with a height are written with altitudeMode relativeToGround; everything else is
clamped to the ground. Feature ids and properties go into ExtendedData.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

_ESC = str.maketrans({"&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;"})


def escape(text: str) -> str:
    return text.translate(_ESC)


@lru_cache(maxsize=256)
def _data_open(key: str) -> str:
    return f'<Data name="{escape(key)}"><value>'

ROLE_ORDER = ("area", "exclusion", "line", "station", "footprint", "home", "gcp", "check", "sortie", "other")
# KML colours are aabbggrr
_STYLE = {
    "area": ("ff2c7d3a", "6600ff00", 2.0),
    "exclusion": ("ff0000bb", "660000ff", 2.0),
    "line": ("ffbf5f1f", "00000000", 3.0),
    "station": ("ff111111", "00000000", 1.0),
    "footprint": ("66888888", "00000000", 1.0),
    "home": ("ff000000", "00000000", 1.0),
    "gcp": ("ff0000ee", "00000000", 1.0),
    "check": ("ffff8800", "00000000", 1.0),
    "sortie": ("ff00aaff", "00000000", 3.0),
    "other": ("ff555555", "00000000", 1.0),
}


def _coords(seq: Any) -> str:
    return " ".join(",".join(map(repr, map(float, c))) for c in seq)


def _geometry(g: dict[str, Any]) -> str:
    t, c = g["type"], g["coordinates"]
    if t == "Point":
        mode = "<altitudeMode>relativeToGround</altitudeMode>" if len(c) > 2 else ""
        return f"<Point>{mode}<coordinates>{_coords([c])}</coordinates></Point>"
    if t == "LineString":
        return f"<LineString><tessellate>1</tessellate><coordinates>{_coords(c)}</coordinates></LineString>"
    if t == "Polygon":
        rings = [f"<outerBoundaryIs><LinearRing><coordinates>{_coords(c[0])}</coordinates></LinearRing></outerBoundaryIs>"]
        rings += [f"<innerBoundaryIs><LinearRing><coordinates>{_coords(r)}</coordinates></LinearRing></innerBoundaryIs>" for r in c[1:]]
        return "<Polygon>" + "".join(rings) + "</Polygon>"
    if t in ("MultiPolygon", "MultiLineString", "MultiPoint"):
        single = t[len("Multi"):]
        return "<MultiGeometry>" + "".join(_geometry({"type": single, "coordinates": part}) for part in c) + "</MultiGeometry>"
    raise ValueError(f"KML: geometry type {t!r} is not supported")


def _placemark(f: dict[str, Any], role: str) -> str:
    props = f.get("properties") or {}
    name = str(props.get("id", f.get("id", role)))
    data = "".join(f"{_data_open(str(k))}{escape(str(v))}</value></Data>" for k, v in props.items())
    return (f"<Placemark><name>{escape(name)}</name><styleUrl>#{role}</styleUrl>"
            f"<ExtendedData>{data}</ExtendedData>{_geometry(f['geometry'])}</Placemark>")


def feature_collection_to_kml(fc: dict[str, Any], name: str) -> str:
    by_role: dict[str, list[dict[str, Any]]] = {}
    for f in fc.get("features", []):
        role = (f.get("properties") or {}).get("role", "other")
        by_role.setdefault(role if role in _STYLE else "other", []).append(f)
    out = ['<?xml version="1.0" encoding="UTF-8"?>', '<kml xmlns="http://www.opengis.net/kml/2.2">',
           f"<Document><name>{escape(name)}</name>"]
    for role, (line, fill, width) in _STYLE.items():
        out.append(f'<Style id="{role}"><LineStyle><color>{line}</color><width>{width}</width></LineStyle>'
                   f'<PolyStyle><color>{fill}</color></PolyStyle></Style>')
    for role in ROLE_ORDER:
        feats = by_role.get(role)
        if not feats:
            continue
        out.append(f"<Folder><name>{role}</name>")
        out.extend(_placemark(f, role) for f in feats)
        out.append("</Folder>")
    out.append("</Document></kml>")
    return "\n".join(out) + "\n"
