"""plan.kml: the GeoPackage's layers (report/gpkg.py `plan_layers`) as KML 2.2 for Google Earth.

One Folder per layer, in `plan_layers`' order, each feature a Placemark named by its `id`,
its fields as ExtendedData `Data` elements (`id` first, then in the layer's order), its
geometry as the layer holds it. `plan_layers` has no footprints: thousands of rectangles
only clutter a pilot's Google Earth (they are in plan.geojson and plan.gpkg).

Styles: each layer's colours are the GeoPackage's QGIS style (`gpkg.STYLES`) in KML's
aabbggrr order; each sortie of the route layer has its own line colour (`ROUTE_COLOURS`,
repeated after the last), so the sorties can be told apart.

Heights: a layer with z (the plan follows the terrain, see gpkg.py) is written with
altitudeMode `absolute`, its z metres above mean sea level, as GDAL's LIBKML driver writes
it for that mode (its other modes, clampToGround and relativeToGround, would need heights
above the ground under each vertex, which the route's waypoints between stations do not
have); a 2-D layer is clamped to the ground (KML's default), its lines tessellated to
follow it.

Why our own writer and not GDAL's (the installed pyogrio's GDAL 3.12 has both the KML and
the LIBKML driver): measured on the 1,000 ha benchmark case (7,309 stations,
benchmarks/inprocess_bench.py --case 1000ha-2h1z, with `kml_ms`), LIBKML wrote the same
layers in ~140 ms (~45 ms with only the stations' names and no fields), this writer in
a few ms, while planning and every other output together take ~65 ms (target 100 ms).

Text is XML-escaped; a character XML 1.0 cannot hold (most control characters) is refused,
naming the layer, the field and the value.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from xml.sax.saxutils import escape

import numpy as np
import shapely

from aerosurvey.errors import InputError
from aerosurvey.jsontext import exponent_form, float_texts, int_texts, join_rows
from aerosurvey.mission.formats.wpl import format_number
from aerosurvey.report.gpkg import STYLES, Layer, Style

#: the sorties' line colours (r,g,b), one each, repeated after the last (ColorBrewer Dark2)
ROUTE_COLOURS = ("217,95,2", "117,112,179", "231,41,138", "102,166,30", "230,171,2", "166,118,29", "27,158,119")
#: decimals written: longitude and latitude (~1 mm), heights (1 cm)
LONLAT_DECIMALS, Z_DECIMALS = 8, 2
_NOT_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")
_QUOTES = {'"': "&quot;"}


def _xml_texts(values: Sequence[str], where: str) -> list[str]:
    """The texts XML-escaped; a character XML 1.0 cannot carry is an InputError naming where
    and the value. One search of them all first: most (ids) need nothing done."""
    joined = "".join(values)
    if _NOT_XML.search(joined):
        bad = next(v for v in values if _NOT_XML.search(v))
        found = _NOT_XML.search(bad)
        assert found is not None
        raise InputError(f"plan.kml: {where} = {bad!r} is not allowed: text without control characters "
                         f"(found U+{ord(found.group()):04X})")
    if any(c in joined for c in '&<>"'):
        return [escape(v, _QUOTES) for v in values]
    return list(values)


def _numbers(a: np.ndarray, decimals: int | None = None) -> list[str]:
    """Each value (rounded to `decimals` if given) as its shortest decimal, written positionally
    (KML's coordinates have no exponent form); "nan" for NaN."""
    r = np.asarray(a, float) if decimals is None else np.round(np.asarray(a, float), decimals)
    if not np.isfinite(r).all():
        return [format_number(v) for v in r.tolist()]
    texts = float_texts(r)  # repr's digits, fast; the rare exponent forms (below 1e-4) written out
    for i in np.flatnonzero(exponent_form(r)).tolist():
        texts[i] = format_number(float(r[i]))
    return texts


def _field_texts(values: np.ndarray, where: str) -> list[str]:
    """A field's values as Data text: strings escaped, numbers as their shortest decimal, booleans true/false."""
    if values.dtype.kind == "b":
        return ["true" if v else "false" for v in values.tolist()]
    if values.dtype.kind in "iu":
        return int_texts(values)
    if values.dtype.kind == "f":
        return _numbers(values)
    return _xml_texts([str(v) for v in values.tolist()], where)


def _kml_colour(rgba: str) -> str:
    """QGIS's "r,g,b,a" (0-255) as KML's aabbggrr."""
    r, g, b, a = (int(v) for v in rgba.split(","))
    return f"{a:02x}{b:02x}{g:02x}{r:02x}"


def _style(style_id: str, style: Style) -> str:
    """A KML Style from the layer's QGIS style: its fill, outline or line colour, a marker's colour and size."""
    line = style.outline if style.kind in ("fill", "marker") else style.color
    fill = style.color if style.kind == "fill" else "0,0,0,0"
    width = max(1.0, round(style.width_mm * 4, 1))  # mm at ~96 dpi, as pixels
    scale = round(max(0.4, min(1.2, style.width_mm / 2.5)), 2)
    filled = 0 if fill.endswith(",0") else 1
    return (f'<Style id="{style_id}"><IconStyle><color>{_kml_colour(style.color)}</color><scale>{scale:g}</scale></IconStyle>'
            f"<LineStyle><color>{_kml_colour(line)}</color><width>{width:g}</width></LineStyle>"
            f"<PolyStyle><color>{_kml_colour(fill)}</color><fill>{filled}</fill><outline>1</outline></PolyStyle></Style>")


def _route_style_id(k: int) -> str:
    return f"route-{k % len(ROUTE_COLOURS) + 1}"


def _styles() -> list[str]:
    out = [_style(name, style) for name, style in STYLES.items() if name not in ("footprints", "route")]
    route = STYLES["route"]
    out += [_style(_route_style_id(k), Style(route.kind, f"{rgb},255", route.outline, route.width_mm))
            for k, rgb in enumerate(ROUTE_COLOURS)]
    return out


def _position_columns(coords: np.ndarray) -> list[list[str]]:
    """The texts of the rows' longitudes and latitudes (to LONLAT_DECIMALS) and heights (to Z_DECIMALS)."""
    columns = [_numbers(coords[:, 0], LONLAT_DECIMALS), _numbers(coords[:, 1], LONLAT_DECIMALS)]
    if coords.shape[1] == 3:
        columns.append(_numbers(coords[:, 2], Z_DECIMALS))
    return columns


def _mode(has_z: bool) -> str:
    return "<altitudeMode>absolute</altitudeMode>" if has_z else ""


def _geometries(layer: Layer) -> list[str | list[str]]:
    """`join_rows` parts of the KML of each point, line, polygon or multi-polygon: the positions of
    them all made in one go (a layer's geometries give them in order: each polygon's outer ring,
    then its holes); points (thousands of stations) as the columns of their numbers."""
    has_z = layer.has_z
    if layer.is_points:
        numbers: list[str | list[str]] = []
        for c in _position_columns(np.asarray(layer.geometries, float)):
            numbers += [",", c] if numbers else [c]
        return [f"<Point>{_mode(has_z)}<coordinates>", *numbers, "</coordinates></Point>"]
    geoms = np.asarray(layer.geometries, dtype=object)
    columns = _position_columns(shapely.get_coordinates(geoms, include_z=has_z))
    positions = [",".join(row) for row in zip(*columns)]
    taken = 0

    def coordinates(n: int) -> str:  # the next n positions
        nonlocal taken
        taken += n
        return f"<coordinates>{' '.join(positions[taken - n:taken])}</coordinates>"

    def polygon(p: shapely.Polygon) -> str:
        rings = [("outerBoundaryIs", p.exterior), *(("innerBoundaryIs", r) for r in p.interiors)]
        body = "".join(f"<{tag}><LinearRing>{coordinates(len(r.coords))}</LinearRing></{tag}>" for tag, r in rings)
        return f"<Polygon>{_mode(has_z)}{body}</Polygon>"

    out = []
    for g in geoms:
        if g.geom_type == "LineString":
            follow = _mode(True) if has_z else "<tessellate>1</tessellate>"
            out.append(f"<LineString>{follow}{coordinates(len(g.coords))}</LineString>")
        elif g.geom_type == "Polygon":
            out.append(polygon(g))
        elif g.geom_type == "MultiPolygon":
            out.append("<MultiGeometry>" + "".join(polygon(p) for p in g.geoms) + "</MultiGeometry>")
        else:
            raise ValueError(f"plan.kml: a {g.geom_type} is not one of the plan's layer geometries")
    return [out]


def _placemarks(layer: Layer) -> str:
    """The layer's Placemarks, a column at a time (`join_rows`): thousands of stations."""
    n = len(layer.geometries)
    fields = dict(layer.fields)
    order = ["id", *(k for k in fields if k != "id")] if "id" in fields else list(fields)
    texts = {k: _field_texts(fields[k], f"layer {layer.name} field {k}") for k in order}
    names = texts["id"] if "id" in texts else [f"{layer.name}-{k}" for k in range(1, n + 1)]
    style: str | list[str] = ([f"#{_route_style_id(k)}" for k in range(n)] if layer.name == "route" else f"#{layer.name}")
    data: list[str | list[str]] = []
    for k in order:
        data += [f'<Data name="{escape(k, _QUOTES)}"><value>', texts[k], "</value></Data>"]
    geometries = _geometries(layer)
    return join_rows(["<Placemark><name>", names, "</name><styleUrl>", style, "</styleUrl><ExtendedData>", *data,
                      "</ExtendedData>", *geometries, "</Placemark>"], n, "\n")


def layers_to_kml(layers: Sequence[Layer], name: str) -> str:
    """KML text of the layers, one Folder each (an empty layer an empty Folder), the document named `name`."""
    out = ['<?xml version="1.0" encoding="UTF-8"?>', '<kml xmlns="http://www.opengis.net/kml/2.2">',
           f"<Document><name>{_xml_texts([name], 'document name')[0]}</name>", *_styles()]
    for layer in layers:
        out += [f"<Folder><name>{layer.name}</name>", _placemarks(layer), "</Folder>"]
    out += ["</Document></kml>", ""]
    return "\n".join(out)
