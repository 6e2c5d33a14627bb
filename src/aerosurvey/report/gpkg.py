"""plan.gpkg: the plan as a GeoPackage of one layer per kind, with QGIS styles stored in it.

plan.geojson holds every kind of feature in one collection of mixed geometry, which GDAL
reports as "Unknown (any)" and QGIS splits on opening; the GeoPackage has one layer per kind,
each of one geometry type, in WGS84 (EPSG:4326, as plan.geojson):

=================  ===================  =====================================================
layer              geometry             features
=================  ===================  =====================================================
area               MultiPolygon         the survey area
zones              MultiPolygon         the exclusion zones
strips             LineString (Z)       each run, first to last station (flight order)
route              LineString (Z)       each sortie (or the one mission) as flown: launch
                                        point, every waypoint in order, launch point
stations           Point (Z)            the planned photo stations
footprints         Polygon              each photo's footprint on flat ground (plan.geojson's)
launch_points      Point (Z)            the home / launch sites
gcps, check_points Point                the control points the rule profiles propose
unphotographed     Polygon              required ground fewer than two planned photos see
=================  ===================  =====================================================

Z: where the plan follows the terrain (terrain mode `follow` or `terrain-frame`) the strips,
stations, launch points and, in the relative altitude frame, the route carry heights above
mean sea level on the DEM's datum: the home ground plus the height above home (relative
frame), or the station's ground plus its height above terrain (terrain frame). A
terrain-frame route is 2-D: its waypoints between stations have no ground height in the plan.

Styles: a `layer_styles` table as QGIS writes it when a style is saved into a GeoPackage
(QgsOgrProviderMetadata::saveStyle: a table without geometry, FID column `id`, the fields
f_table_catalog … update_time, one row per layer with useAsDefault true), so QGIS draws each
layer with its style when it is opened. The QML holds a single-symbol renderer; the same style
is in `styleSLD` as an OGC Styled Layer Descriptor 1.1 (Symbology Encoding 1.1, as QGIS exports
it) for the clients that read SLD rather than QML (GeoServer, MapServer, OpenLayers' readers):
colours as #rrggbb with an opacity, sizes in the standard rendering pixels of 0.28 mm.

The file is made by GDAL (pyogrio); `OGR_CURRENT_DATE` is fixed while writing, so the same
plan gives the same bytes (GDAL would otherwise stamp gpkg_contents with the time).
"""

from __future__ import annotations

import datetime as dt
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any
from xml.sax.saxutils import quoteattr

import numpy as np
import numpy.typing as npt
import shapely

from aerosurvey import ids
from aerosurvey.plan.planner import Plan

if TYPE_CHECKING:
    from aerosurvey.report.features import FootprintLonLat

#: The time written into gpkg_contents and the styles' update_time: fixed, so outputs are reproducible.
FIXED_TIME = "2000-01-01T00:00:00Z"
CRS = "EPSG:4326"
THREE_D_MODES = ("follow", "terrain-frame")


@dataclass(frozen=True)
class Style:
    """A single-symbol QGIS style: fill, line or marker, an RGBA colour, an outline colour, and a
    size in mm (a fill's outline width, a line's width, a marker's diameter)."""

    kind: str  # "fill", "line" or "marker"
    color: str  # "r,g,b,a"
    outline: str = "35,35,35,255"
    width_mm: float = 0.26


@dataclass(frozen=True)
class Layer:
    """One layer: its name, OGR geometry type, geometries (WGS84, with z when the type says Z),
    attribute columns (equal lengths) and style. A point layer's geometries are its points'
    coordinates, an (n, 2) array, (n, 3) with z: thousands of stations need no object each
    (plan.kml writes their numbers; `shapes` makes the points plan.gpkg stores)."""

    name: str
    geometry_type: str
    geometries: Sequence[shapely.Geometry] | npt.NDArray[Any]
    fields: tuple[tuple[str, np.ndarray], ...]
    style: Style

    def __post_init__(self) -> None:
        if self.is_points and np.shape(self.geometries) != (len(self.geometries), 3 if self.has_z else 2):
            raise ValueError(f"layer {self.name}: a {self.geometry_type} layer's geometries are coordinates "
                             f"({3 if self.has_z else 2} a point), not {np.shape(self.geometries)}")

    @property
    def has_z(self) -> bool:
        return self.geometry_type.endswith(" Z")

    @property
    def is_points(self) -> bool:
        return self.geometry_type in ("Point", "Point Z")

    def shapes(self) -> npt.NDArray[np.object_]:
        """The geometries as shapely objects (a point layer's points made from its coordinates)."""
        if self.is_points:
            return np.asarray(shapely.points(np.asarray(self.geometries, float)), dtype=object).reshape(-1)
        return np.asarray(self.geometries, dtype=object)


STYLES = {
    "area": Style("fill", "0,0,0,0", "31,120,180,255", 0.6),
    "zones": Style("fill", "227,26,28,80", "227,26,28,255", 0.4),
    "strips": Style("line", "51,160,44,255", width_mm=0.5),
    "route": Style("line", "255,127,0,255", width_mm=0.3),
    "stations": Style("marker", "31,120,180,255", width_mm=1.2),
    "footprints": Style("fill", "166,206,227,40", "31,120,180,120", 0.1),
    "launch_points": Style("marker", "255,255,0,255", width_mm=3.0),
    "gcps": Style("marker", "227,26,28,255", width_mm=2.5),
    "check_points": Style("marker", "31,120,180,255", width_mm=2.5),
    "unphotographed": Style("fill", "255,0,255,120", "255,0,255,255", 0.4),
}


def _text(values: Sequence[Any]) -> np.ndarray:
    return np.array([str(v) for v in values], dtype=object)


def plan_layers(plan: Plan, control_points: Sequence[Any] = ()) -> list[Layer]:
    """Every layer of plan.gpkg (see the module docstring) but the footprints
    (`footprints_layer`): what plan.kml holds; `control_points` are the rules' proposed points
    (rules.control_points.ControlPoint, planning CRS)."""
    from aerosurvey.manifest import run_stations
    from aerosurvey.mission.builder import run_id
    st = plan.stations
    z3 = plan.sensor.heights.mode in THREE_D_MODES
    home_ground = float(plan.launch.home[2])
    relative = plan.altitudes.frame == "relative"
    # heights above mean sea level: the home ground plus the height above home, or the ground plus the height above it
    st_z = home_ground + st.alt_rel_m if relative else st.ground_m + st.alt_rel_m
    zt = " Z" if z3 else ""

    def points(lon: np.ndarray, lat: np.ndarray, z: np.ndarray | None) -> np.ndarray:
        return np.column_stack([lon, lat] + ([z] if z is not None else [])).astype(float)

    def multi(g: shapely.Geometry) -> shapely.Geometry:
        return g if g.geom_type == "MultiPolygon" else shapely.MultiPolygon([g])

    layers = [Layer("area", "MultiPolygon", [multi(plan.site.area_wgs84)],
                    (("id", _text(["area"])), ("area_ha", np.array([round(plan.site.area.area / 1e4, 4)]))), STYLES["area"])]
    zones = [multi(z) for z in plan.site.exclusions_wgs84]
    layers.append(Layer("zones", "MultiPolygon", zones, (("id", _text([f"exclusion-{i}" for i in range(1, len(zones) + 1)])),),
                        STYLES["zones"]))
    strips, sid, line, first, last, photos = [], [], [], [], [], []
    for i, (r, (a, b, n)) in enumerate(zip(plan.route.runs, run_stations(plan))):
        ends = [(st.lon[j], st.lat[j]) + ((st_z[j],) if z3 else ()) for j in (a, b)]
        strips.append(shapely.LineString(ends))
        sid.append(run_id(plan, i))
        line.append(ids.line_id(r.pass_index, r.line))
        first.append(st.ids[a])
        last.append(st.ids[b])
        photos.append(n)
    layers.append(Layer("strips", "LineString" + zt, strips, (
        ("id", _text(sid)), ("line", _text(line)), ("photos", np.array(photos, np.int64)),
        ("first_station", _text(first)), ("last_station", _text(last))), STYLES["strips"]))
    layers.append(_route_layer(plan, z3 and relative))
    layers.append(Layer("stations", "Point" + zt, points(st.lon, st.lat, st_z if z3 else None), (
        ("id", _text(st.ids)), ("seq", np.arange(1, len(st.ids) + 1, dtype=np.int64)),
        ("alt_rel_m", np.round(st.alt_rel_m, 2)), ("agl_m", np.round(st.agl_m, 2)),
        ("heading_deg", np.round(st.heading_deg, 3))), STYLES["stations"]))
    sites = plan.launch.sites or ()
    if sites:
        lon, lat, g = (np.array([getattr(s, k) for s in sites], float) for k in ("lon", "lat", "ground_m"))
        names = [f"launch-{k}" for k in range(1, len(sites) + 1)]
    else:
        lon, lat, g = (np.array([v], float) for v in plan.launch.home)
        names = ["home"]
    layers.append(Layer("launch_points", "Point" + zt, points(lon, lat, g if z3 else None),
                        (("id", _text(names)), ("ground_m", np.round(g, 2))), STYLES["launch_points"]))
    for name, role in (("gcps", "gcp"), ("check_points", "check")):
        pts = [p for p in control_points if p.role == role]
        plon, plat = plan.site.planar.lonlat(np.array([p.x for p in pts], float), np.array([p.y for p in pts], float))
        layers.append(Layer(name, "Point", points(np.atleast_1d(plon), np.atleast_1d(plat), None), (
            ("id", _text([p.id for p in pts])), ("images", np.array([p.images for p in pts], np.int64)),
            ("note", _text([p.note for p in pts]))), STYLES[name]))
    parts = plan.coverage.polygons()
    layers.append(Layer("unphotographed", "Polygon", [plan.site.planar.inverse(p) for p in parts], (
        ("id", _text([f"uncovered-{i}" for i in range(1, len(parts) + 1)])),
        ("area_m2", np.array([round(p.area / plan.site.grid_scale ** 2, 2) for p in parts], float))), STYLES["unphotographed"]))
    return layers


def footprints_layer(plan: Plan, corners: FootprintLonLat | None = None) -> Layer:
    """The photos' footprints on flat ground (plan.geojson's), of the photos that have one (a
    level camera's have none: their stations are in the layer 'stations'); `corners`, their
    `report.features.footprint_lonlat`, if the caller has them."""
    from aerosurvey.report.features import footprint_lonlat

    clon, clat, bounded = corners if corners is not None else footprint_lonlat(plan)
    rings = np.stack([clon.reshape(-1, 4), clat.reshape(-1, 4)], axis=-1)
    rings = np.concatenate([rings, rings[:, :1]], axis=1) if len(rings) else rings
    return Layer("footprints", "Polygon", shapely.polygons(rings) if len(rings) else np.array([], dtype=object),
                 (("station", _text([s for s, b in zip(plan.stations.ids, bounded.tolist()) if b])),), STYLES["footprints"])


def _route_layer(plan: Plan, with_z: bool) -> Layer:
    """The route as flown, one line per sortie (or one for the whole mission): from the launch
    point on the ground through every waypoint in order and back; z above mean sea level."""
    home_ground = float(plan.launch.home[2])
    flights: list[tuple[str, tuple[float, float, float], Sequence[Any]]] = []
    if plan.sorties:
        for k, (sortie, sortie_wps) in enumerate(plan.sorties, start=1):
            s = plan.launch.sites[sortie.launch]
            flights.append((ids.sortie_id(k), (s.lon, s.lat, s.ground_m), sortie_wps))
    else:
        flights.append(("mission", (plan.launch.home[0], plan.launch.home[1], home_ground), plan.waypoints))
    lines, names, counts = [], [], []
    for name, (lon, lat, ground), wps in flights:
        coords = [(lon, lat, ground), *((w.lon, w.lat, home_ground + w.alt_m) for w in wps), (lon, lat, ground)]
        lines.append(shapely.LineString([c if with_z else c[:2] for c in coords]))
        names.append(name)
        counts.append(len(wps))
    return Layer("route", "LineString Z" if with_z else "LineString", lines,
                 (("id", _text(names)), ("waypoints", np.array(counts, np.int64))), STYLES["route"])


def _symbol_layer(style: Style) -> str:
    if style.kind == "fill":
        cls, opts = "SimpleFill", {"color": style.color, "outline_color": style.outline, "outline_style": "solid",
                                   "outline_width": f"{style.width_mm:g}", "outline_width_unit": "MM", "style": "solid"}
    elif style.kind == "line":
        cls, opts = "SimpleLine", {"line_color": style.color, "line_style": "solid", "line_width": f"{style.width_mm:g}",
                                   "line_width_unit": "MM", "capstyle": "round", "joinstyle": "round"}
    else:
        cls, opts = "SimpleMarker", {"color": style.color, "outline_color": style.outline, "outline_style": "solid",
                                     "outline_width": "0.2", "outline_width_unit": "MM", "name": "circle",
                                     "size": f"{style.width_mm:g}", "size_unit": "MM"}
    options = "".join(f'<Option type="QString" name={quoteattr(k)} value={quoteattr(v)}/>' for k, v in sorted(opts.items()))
    return f'<layer class="{cls}" enabled="1" locked="0" pass="0"><Option type="Map">{options}</Option></layer>'


def qml(style: Style) -> str:
    """A QGIS style document (.qml) of one single-symbol renderer."""
    return ("<!DOCTYPE qgis PUBLIC 'http://mrcc.com/qgis.dtd' 'SYSTEM'>\n"
            '<qgis version="3.28.0" styleCategories="Symbology">'
            '<renderer-v2 type="singleSymbol" symbollevels="0" forceraster="0" enableorderby="0"><symbols>'
            f'<symbol type="{style.kind}" name="0" alpha="1" clip_to_extent="1" force_rhr="0">{_symbol_layer(style)}</symbol>'
            "</symbols></renderer-v2></qgis>\n")


#: OGC's namespaces of an SLD 1.1 document, and its "standardized rendering pixel" (SE 1.1, 0.28 mm)
SLD_NS = "http://www.opengis.net/sld"
SE_NS = "http://www.opengis.net/se"
SE_PIXEL_MM = 0.28


def _hex_and_opacity(rgba: str) -> tuple[str, str]:
    r, g, b, a = (int(v) for v in rgba.split(","))
    return f"#{r:02x}{g:02x}{b:02x}", f"{a / 255.0:.3g}"


def sld(name: str, style: Style) -> str:
    """The style as an SLD 1.1 document (one rule, one symbolizer) for the layer `name`."""
    from lxml import etree

    def se(parent: etree._Element, tag: str, text: str | None = None, **attrs: str) -> etree._Element:
        el = etree.SubElement(parent, f"{{{SE_NS}}}{tag}", attrs)
        el.text = text
        return el

    def paint(parent: etree._Element, tag: str, rgba: str, width_mm: float | None = None) -> None:
        colour, opacity = _hex_and_opacity(rgba)
        kind = "fill" if tag == "Fill" else "stroke"
        el = se(parent, tag)
        se(el, "SvgParameter", colour, name=kind)
        se(el, "SvgParameter", opacity, name=f"{kind}-opacity")
        if width_mm is not None:
            se(el, "SvgParameter", f"{width_mm / SE_PIXEL_MM:.3g}", name="stroke-width")

    root = etree.Element(f"{{{SLD_NS}}}StyledLayerDescriptor", {"version": "1.1.0"}, nsmap={None: SLD_NS, "se": SE_NS})
    layer = etree.SubElement(root, f"{{{SLD_NS}}}NamedLayer")
    se(layer, "Name", name)
    user = etree.SubElement(layer, f"{{{SLD_NS}}}UserStyle")
    se(user, "Name", name)
    rule = se(se(user, "FeatureTypeStyle"), "Rule")
    se(rule, "Name", "Single symbol")
    if style.kind == "fill":
        sym = se(rule, "PolygonSymbolizer")
        paint(sym, "Fill", style.color)
        paint(sym, "Stroke", style.outline, style.width_mm)
    elif style.kind == "line":
        paint(se(rule, "LineSymbolizer"), "Stroke", style.color, style.width_mm)
    else:
        graphic = se(se(rule, "PointSymbolizer"), "Graphic")
        mark = se(graphic, "Mark")
        se(mark, "WellKnownName", "circle")
        paint(mark, "Fill", style.color)
        paint(mark, "Stroke", style.outline, 0.2)
        se(graphic, "Size", f"{style.width_mm / SE_PIXEL_MM:.3g}")
    return str(etree.tostring(root, encoding="unicode"))


def write_gpkg(path: Path, layers: Sequence[Layer]) -> None:
    """Write the layers and their styles into a new GeoPackage at `path` (which must not exist)."""
    import pyogrio

    # SQLite's journal and syncs off: each layer is a transaction of its own, and with them each
    # cost ~100 ms on the 72 ha example (~10 ms without); the file is written whole into a
    # temporary folder and moved into place only when complete
    options = {"OGR_CURRENT_DATE": FIXED_TIME, "OGR_SQLITE_SYNCHRONOUS": "OFF", "OGR_SQLITE_JOURNAL": "OFF"}
    previous = {k: pyogrio.get_gdal_config_option(k) for k in options}
    pyogrio.set_gdal_config_options(options)
    try:
        for layer in layers:
            geoms = np.array(shapely.to_wkb(layer.shapes(), output_dimension=3 if layer.has_z else 2),
                             dtype=object) if len(layer.geometries) else np.array([], dtype=object)
            pyogrio.raw.write(str(path), geoms, [c for _, c in layer.fields], [n for n, _ in layer.fields], layer=layer.name,
                              driver="GPKG", geometry_type=layer.geometry_type, crs=CRS, append=path.exists())
        _write_styles(path, layers)
    finally:
        pyogrio.set_gdal_config_options(previous)


def _write_styles(path: Path, layers: Sequence[Layer]) -> None:
    """The `layer_styles` table QGIS reads its default styles from (the fields, widths and types
    of QgsOgrProviderMetadata::saveStyle; GDAL declares the widths as TEXT(n))."""
    import pyogrio

    n = len(layers)
    empty = np.array([""] * n, dtype=object)
    fields = [("f_table_catalog", empty), ("f_table_schema", empty), ("f_table_name", _text([x.name for x in layers])),
              ("f_geometry_column", np.array(["geom"] * n, dtype=object)), ("styleName", _text([x.name for x in layers])),
              ("styleQML", _text([qml(x.style) for x in layers])), ("styleSLD", _text([sld(x.name, x.style) for x in layers])),
              ("useAsDefault", np.ones(n, bool)), ("description", _text([f"aerosurvey: {x.name}" for x in layers])),
              ("owner", empty), ("ui", empty),
              ("update_time", np.full(n, np.datetime64(dt.datetime.fromisoformat(FIXED_TIME.replace("Z", "")), "ms")))]
    pyogrio.raw.write(str(path), None, [c for _, c in fields], [k for k, _ in fields], layer="layer_styles", driver="GPKG",
                      geometry_type=None, append=True, layer_options={"FID": "id"})


def gpkg_bytes(layers: Sequence[Layer]) -> bytes:
    """The bytes of plan.gpkg of these layers (`plan_layers`), written in a temporary folder: GDAL writes a GeoPackage to a file."""
    import tempfile

    with tempfile.TemporaryDirectory(prefix="aerosurvey-gpkg-") as tmp:
        path = Path(tmp) / "plan.gpkg"
        write_gpkg(path, layers)
        return path.read_bytes()
