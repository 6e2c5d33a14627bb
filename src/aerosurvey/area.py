"""Read survey areas and exclusion zones, validate them, choose and apply the planning CRS.

Readers (files) sit here at the edge; the returned geometries are plain shapely objects.
Areas are polygons or multipolygons; their holes are parts that need no photos (flying
and photographing across them is fine). Exclusion zones are separate files: the route
must never enter them.
"""

from __future__ import annotations

import functools
import io
import itertools
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pyproj
import shapely
import simdjson
from shapely.geometry.base import BaseGeometry

from aerosurvey.errors import InputError

_VECTOR_SUFFIXES = {".geojson", ".json", ".kml", ".kmz", ".shp", ".gpkg", ".fgb", ".gml"}
_WGS84 = pyproj.CRS.from_epsg(4326)


@dataclass(frozen=True)
class Planar:
    """The planning CRS and the transforms into it and back to WGS84 longitude/latitude."""

    crs: pyproj.CRS
    to_plan: pyproj.Transformer
    to_wgs84: pyproj.Transformer

    @property
    def name(self) -> str:
        auth = self.crs.to_authority()
        return f"{auth[0]}:{auth[1]}" if auth else self.crs.to_string()

    def forward(self, geom: BaseGeometry) -> BaseGeometry:
        return transformed(self.to_plan, geom)

    def inverse(self, geom: BaseGeometry) -> BaseGeometry:
        return transformed(self.to_wgs84, geom)

    def lonlat(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        lon, lat = self.to_wgs84.transform(np.asarray(x, float), np.asarray(y, float))
        return np.asarray(lon), np.asarray(lat)

    def scale_factor(self, lon: float, lat: float) -> float:
        """Grid metres per ground metre at a place (conformal CRSs: the same in every direction).

        Ground lengths (footprints, photo base, spacing) are multiplied by it before they are
        laid out in the grid, so that the stations lie as far apart on the ground as the
        autopilot's distance trigger measures.
        """
        return float(self.scale_factors(np.array([lon]), np.array([lat]))[0])

    def scale_factors(self, lon: np.ndarray, lat: np.ndarray) -> np.ndarray:
        """`scale_factor` at many places at once."""
        f = pyproj.Proj(self.crs).get_factors(np.asarray(lon, float), np.asarray(lat, float))
        scale: np.ndarray = np.sqrt(np.asarray(f.meridional_scale) * np.asarray(f.parallel_scale))
        return scale

    def xy(self, lon: np.ndarray, lat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x, y = self.to_plan.transform(np.asarray(lon, float), np.asarray(lat, float))
        return np.asarray(x), np.asarray(y)

    # Bearings cross between true north and the planning grid here, and nowhere else.
    #
    # A true bearing (autopilot and DJI yaw, gimbal yaw, MAVLink and WPML headings, EXIF
    # GPSImgDirection) is clockwise from the meridian; a grid bearing (the plan's line headings,
    # camera looks, footprints) is clockwise from the planning CRS's +y axis. They differ by the
    # meridian convergence at the place: 7.4° at Obrataň in S-JTSK (Krovak), up to about 3° at
    # the edge of a UTM zone, tens of degrees in a polar stereographic grid.

    def convergence_deg(self, x: npt.ArrayLike, y: npt.ArrayLike) -> np.ndarray:
        """The meridian convergence at planning-CRS points: the true bearing of grid north,
        degrees, positive where grid north lies east of true north (true = grid + convergence).

        Measured through this Planar's own transformer (a true-north step of 1e-6° each way), so
        it holds for the axes and the datum shift the plan's coordinates were made with; PROJ's
        `get_factors().meridian_convergence` gives the same angle on the CRS's own datum, which
        for S-JTSK misses the 5" rotation of the WGS 84 shift (0.002° at Obrataň)."""
        x, y = np.asarray(x, float), np.asarray(y, float)
        lon, lat = self.lonlat(x, y)
        step = 1e-6
        lat_n = np.minimum(lat + step, 90.0)
        lat_s = np.maximum(lat - step, -90.0)
        xn, yn = self.xy(lon, lat_n)
        xs, ys = self.xy(lon, lat_s)
        grid_of_north = np.degrees(np.arctan2(xn - xs, yn - ys))
        return np.asarray(-grid_of_north, float)

    def true_bearing(self, grid_deg: npt.ArrayLike, x: npt.ArrayLike, y: npt.ArrayLike) -> np.ndarray:
        """Grid bearings at planning-CRS points as true bearings (0..360)."""
        return np.asarray((np.asarray(grid_deg, float) + self.convergence_deg(x, y)) % 360.0, float)

    def grid_bearing(self, true_deg: npt.ArrayLike, x: npt.ArrayLike, y: npt.ArrayLike) -> np.ndarray:
        """True bearings at planning-CRS points as grid bearings (0..360)."""
        return np.asarray((np.asarray(true_deg, float) - self.convergence_deg(x, y)) % 360.0, float)


def transformed(t: pyproj.Transformer, geom: BaseGeometry) -> BaseGeometry:
    """The geometry with its x and y transformed, its coordinates held once (shapely.transform
    with a stacking function holds them four times at its peak: +6 MB on 400,000 vertices)."""
    xy = shapely.get_coordinates(geom)
    xy[:, 0], xy[:, 1] = t.transform(xy[:, 0], xy[:, 1])
    out: BaseGeometry = shapely.set_coordinates(np.array(geom, dtype=object), xy).item()
    return out


def _location(reason: str, geographic: bool) -> str:
    m = re.search(r"\[([-\d.eE+]+) ([-\d.eE+]+)\]", reason)
    if not m:
        return ""
    x, y = float(m.group(1)), float(m.group(2))
    return f" at longitude {x:.7f}, latitude {y:.7f}" if geographic else f" at x {x:.3f}, y {y:.3f}"


def validate_polygons(geom: BaseGeometry, name: str, geographic: bool) -> BaseGeometry:
    """Check polygon type, coordinate ranges and validity; the message says where it is wrong."""
    if geom.is_empty:
        raise InputError(f"{name}: no polygon in it (empty geometry)")
    if geom.geom_type not in ("Polygon", "MultiPolygon"):
        raise InputError(f"{name}: a {geom.geom_type} is not an area; give a Polygon or MultiPolygon")
    west, south, east, north = geom.bounds
    if geographic and not (-180 <= west and east <= 180 and -90 <= south and north <= 90):
        xy = shapely.get_coordinates(geom)
        lon, lat = xy[:, 0], xy[:, 1]
        if np.any(np.abs(lat) > 90) or np.any(np.abs(lon) > 180):
            looks_swapped = np.all(np.abs(lon) <= 90) and np.any(np.abs(lat) > 90) and np.all(np.abs(lat) <= 180)
            worst = int(np.argmax(np.maximum(np.abs(lat) - 90, np.abs(lon) - 180)))
            hint = (" — longitude and latitude look swapped (GeoJSON and KML put longitude first)"
                    if looks_swapped else "")
            raise InputError(
                f"{name}: coordinate ({float(lon[worst])!r}, {float(lat[worst])!r}) is outside longitude [-180, 180] / "
                f"latitude [-90, 90]{hint}"
            )
    if not shapely.is_valid(geom):
        reason = shapely.is_valid_reason(geom)
        kind = reason.split("[")[0]
        raise InputError(f"{name}: invalid polygon, {kind.lower()}{_location(reason, geographic)} "
                         "(fix the outline; it must not cross itself)")
    if geom.area <= 0:
        raise InputError(f"{name}: the polygon has zero area")
    return geom


def validate_lines(geom: BaseGeometry, name: str, geographic: bool) -> BaseGeometry:
    """Check a centreline: a (Multi)LineString of finite length whose coordinates are in range."""
    if geom.is_empty:
        raise InputError(f"{name}: no line in it (empty geometry)")
    if geom.geom_type not in ("LineString", "MultiLineString"):
        raise InputError(f"{name}: a {geom.geom_type} is not a centreline; give a LineString or MultiLineString, "
                         "or the corridor's Polygon (pattern.kind = 'corridor')")
    xy = shapely.get_coordinates(geom)
    if not np.isfinite(xy).all():
        raise InputError(f"{name}: a coordinate is not a finite number")
    if geographic and (np.any(np.abs(xy[:, 1]) > 90) or np.any(np.abs(xy[:, 0]) > 180)):
        worst = int(np.argmax(np.maximum(np.abs(xy[:, 1]) - 90, np.abs(xy[:, 0]) - 180)))
        raise InputError(f"{name}: coordinate ({float(xy[worst, 0])!r}, {float(xy[worst, 1])!r}) is outside "
                         "longitude [-180, 180] / latitude [-90, 90]")
    if shapely.length(geom) <= 0:
        raise InputError(f"{name}: the centreline has zero length")
    return geom


def _read_vector(path: Path, name: str, lines: bool = False) -> tuple[BaseGeometry, pyproj.CRS]:
    if not path.exists():
        raise InputError(f"{name}: file {str(path)!r} does not exist")
    if path.suffix.lower() not in _VECTOR_SUFFIXES | {".wkt"}:
        raise InputError(f"{name}: {str(path)!r} has an unknown extension; allowed: {', '.join(sorted(_VECTOR_SUFFIXES | {'.wkt'}))}")
    if path.suffix.lower() == ".wkt":
        return _from_wkt(path.read_text(encoding="utf-8"), name), _WGS84
    if path.suffix.lower() in (".geojson", ".json") and path.stat().st_size <= PLAIN_GEOJSON_MAX_BYTES:
        geoms = _plain_geojson(path)
        if geoms is not None:
            return _kept(geoms, _WGS84, str(path), path.name, name, lines), _WGS84
    return _parse_vector(path, str(path), path.name, name, lines)


#: above this size a GeoJSON area goes to GDAL (its json-c tree holds ~16 bytes a byte of the
#: file; simdjson's tape ~3)
PLAIN_GEOJSON_MAX_BYTES = 64_000_000

_GEOMETRY_TYPES = frozenset({"Point", "MultiPoint", "LineString", "MultiLineString", "Polygon", "MultiPolygon"})
_DEPTH = {"Point": 1, "MultiPoint": 2, "LineString": 2, "MultiLineString": 3, "Polygon": 3, "MultiPolygon": 4}


def _numbers(coords: object, depth: int) -> bool:
    """Whether `coords` are lists nested `depth` deep of JSON numbers GDAL reads as we do: not
    strings or booleans (shapely would take "14.5" and true as numbers, GDAL reads no polygon),
    no integer beyond 64 bits (GDAL clamps it; float() overflows)."""
    items = [coords]
    for _ in range(depth):
        if not all(type(c) is list for c in items):
            return False
        items = list(itertools.chain.from_iterable(items))  # type: ignore[arg-type]
    return all(type(v) is float or (type(v) is int and -(2**63) <= v < 2**63) for v in items)


def _rings_closed(g: dict[str, Any]) -> bool:
    """Whether every ring of a (Multi)Polygon ends where it starts (other types: True)."""
    polys = [g["coordinates"]] if g["type"] == "Polygon" else g["coordinates"] if g["type"] == "MultiPolygon" else []
    return all(ring and ring[0] == ring[-1] for poly in polys for ring in poly)


def _plain_geojson(path: Path) -> list[BaseGeometry | None] | None:
    """The geometries of a plain RFC 7946 GeoJSON file, read without GDAL; None for anything
    else (GDAL reads it then, and says what is wrong).

    Plain: a FeatureCollection, a Feature or a geometry of the six simple types, in WGS84 (no
    legacy `crs` member). Why: loading pyogrio and GDAL for it took ~105 ms of each `aerosurvey
    plan` start-up and ~40 ms more on the first read (-X importtime, cProfile). simdjson parses
    the file into its tape (numbers correctly rounded, as GDAL's), and a polygon's rings go from
    it straight into numpy arrays: a boundary of 400,000 vertices never becomes Python objects
    (Python lists of it took 0.35 s and ~90 MB more at their peak; benchmarks/vertices_bench.py).
    The polygons are made once the parser's tape is freed. A test compares both readers on the
    repository's areas and on random documents."""
    parts = _plain_parts(path)
    if parts is None:
        return None
    out: list[BaseGeometry | None] = []
    for part in parts:
        if isinstance(part, _Rings):
            try:
                polys = [shapely.Polygon(shell, holes) for shell, *holes in part.polygons]
            except (ValueError, shapely.errors.ShapelyError):  # a ring of fewer than 4 positions
                return None
            part = shapely.MultiPolygon(polys) if part.multi else polys[0]
        out.append(part)
    return out


@dataclass(frozen=True)
class _Rings:
    """A (Multi)Polygon read from a GeoJSON file: each polygon's [shell, *holes], (n, 2) arrays."""

    polygons: list[list[np.ndarray]]
    multi: bool


def _plain_parts(path: Path) -> list[BaseGeometry | _Rings | None] | None:
    """The geometries of a plain GeoJSON file (polygons as their rings), or None (see `_plain_geojson`)."""
    parser = simdjson.Parser()
    try:
        doc = parser.load(str(path))
    except (ValueError, RuntimeError):  # not JSON, integers beyond 64 bits, nesting too deep …: GDAL says what
        return None
    if not isinstance(doc, simdjson.Object) or "crs" in doc:
        return None
    kind = doc.get("type")
    if kind == "FeatureCollection":
        feats = doc.get("features")
        if not isinstance(feats, simdjson.Array):
            return None
        features = [f for f in feats if isinstance(f, simdjson.Object) and f.get("type") == "Feature"]
        if len(features) != len(feats):
            return None
        raw = [f.get("geometry") for f in features]
    elif kind == "Feature":
        raw = [doc.get("geometry")]
    else:
        raw = [doc]
    out: list[BaseGeometry | _Rings | None] = []
    for g in raw:
        if g is None:
            out.append(None)
            continue
        if not isinstance(g, simdjson.Object) or g.get("type") not in _GEOMETRY_TYPES:
            return None
        part = _polygon_rings(g) if g.get("type") in ("Polygon", "MultiPolygon") else _small_geometry(g.as_dict())
        if part is None:
            return None
        out.append(part)
    return out


def _polygon_rings(g: Any) -> BaseGeometry | _Rings | None:
    """A (Multi)Polygon's rings as numpy arrays; None when a ring is not a closed list of
    equally long positions of 2 or 3 numbers (GDAL decides then). An empty one is made by
    shapely, as any small geometry."""
    coords = g.get("coordinates")
    if not isinstance(coords, simdjson.Array):
        return None
    multi = g.get("type") == "MultiPolygon"
    polys: list[Any] = list(coords) if multi else [coords]
    if not polys or not all(isinstance(p, simdjson.Array) and len(p) > 0 for p in polys):
        return _small_geometry(g.as_dict())
    rings = [[_positions(r) for r in poly] for poly in polys]
    if any(r is None for poly in rings for r in poly):
        return None
    return _Rings(rings, multi)  # type: ignore[arg-type]  # no None left


def _positions(ring: Any) -> np.ndarray | None:
    """A ring's (n, 2) longitudes and latitudes (heights dropped), or None (see _polygon_geometry)."""
    if not isinstance(ring, simdjson.Array) or len(ring) == 0:
        return None
    dims = {len(p) if isinstance(p, simdjson.Array) else -1 for p in ring}
    if len(dims) != 1 or (d := dims.pop()) not in (2, 3):
        return None
    try:
        flat = np.frombuffer(ring.as_buffer(of_type="d"), float)
    except TypeError:  # strings, booleans, null: shapely would take "14.5" and true as numbers, GDAL reads no polygon
        return None
    # every position d numbers: a position holding an array of more or fewer numbers is refused
    # here; one holding an array of one number ([x, [y]], which GDAL refuses) is read as that
    # number (telling it apart would visit every number from Python: +0.2 s on 400,000 vertices)
    if flat.size != len(ring) * d:
        return None
    if not (-(2.0**63) <= flat.min() and flat.max() < 2.0**63):  # integers beyond int64 (held as uint64; GDAL clamps)
        return None
    xy = flat.reshape(-1, d)
    if not np.array_equal(xy[0], xy[-1]):  # shapely would close it quietly; GDAL refuses it
        return None
    return xy[:, :2]


def _small_geometry(g: dict[str, Any]) -> BaseGeometry | None:
    """A geometry other than a polygon (points and lines, left out of the area) from its Python
    objects, or None when GDAL would read its coordinates otherwise."""
    if not _numbers(g.get("coordinates"), _DEPTH[g["type"]]) or not _rings_closed(g):
        return None
    try:
        return shapely.force_2d(shapely.geometry.shape(g))
    except (ValueError, TypeError, IndexError, AttributeError, shapely.errors.ShapelyError):
        return None


#: pyogrio's name for bytes it hands GDAL (/vsimem/pyogrio_<hex>, under /vsizip/ for a zip)
_VSIMEM = re.compile(r"((/vsizip/)?/vsimem/)?pyogrio_[0-9a-f]{32}(\.zip)?")


def _parse_vector(source: Path | bytes, where: str, short: str, name: str,
                  lines: bool = False) -> tuple[BaseGeometry, pyproj.CRS]:
    """The polygons (`lines`: the lines) of every layer of a vector dataset (a file, or a zip held
    in memory), unioned, and its CRS. `where` and `short` name the source in messages."""
    import pyogrio

    def why(exc: Exception) -> str:  # GDAL's message, naming the upload rather than pyogrio's memory file
        return _VSIMEM.sub(short, str(exc))

    try:
        # by index: GDAL names the layer of an in-memory file after pyogrio's random file name, new on each call
        layers = [_VSIMEM.sub(short, str(row[0])) for row in pyogrio.list_layers(source)]
    except Exception as exc:  # GDAL's own error types vary between versions
        raise InputError(f"{name}: {where!r} cannot be read as a vector file: {why(exc)}") from None
    parts: list[BaseGeometry] = []
    crs: pyproj.CRS | None = None
    for index, layer in enumerate(layers):
        try:
            meta, _, wkb, _ = pyogrio.raw.read(source, layer=index, force_2d=True)
        except Exception as exc:
            raise InputError(f"{name}: layer {layer!r} of {where!r} cannot be read: {why(exc)}") from None
        if wkb is None or len(wkb) == 0:
            continue
        layer_crs = pyproj.CRS.from_user_input(meta["crs"]) if meta.get("crs") else _WGS84
        if crs is not None and not layer_crs.equals(crs):
            raise InputError(f"{name}: layers of {where!r} are in different CRSs ({crs.name}, {layer_crs.name})")
        crs = layer_crs
        try:
            geoms = shapely.from_wkb(wkb)
        except shapely.errors.GEOSException as exc:  # e.g. a ring that does not end where it starts
            raise InputError(f"{name}: layer {layer!r} of {where!r} holds a geometry that is not valid: {exc} "
                             "(close every ring: its last point must repeat its first)") from None
        for i, g in enumerate(geoms):
            if g is None or g.is_empty:
                continue
            for part in shapely.get_parts(g):
                if part.geom_type in ("Polygon", "MultiPolygon", "LineString", "MultiLineString"):
                    parts.append(part)
                elif part.geom_type not in ("Point", "MultiPoint"):
                    raise InputError(f"{name}: feature {i} of layer {layer!r} is a {part.geom_type}; only polygons are areas")
    return _kept(parts, crs or _WGS84, where, short, name, lines), crs or _WGS84


def _kept(geoms: list[BaseGeometry | None], crs: pyproj.CRS, where: str, short: str, name: str,
          lines: bool = False) -> BaseGeometry:
    """The polygons (`lines`: a corridor's lines, or else its polygons) among a dataset's geometries,
    the rest left out, each checked; polygons unioned, lines gathered into one (Multi)LineString."""
    every = [p for g in geoms if g is not None and not g.is_empty for p in shapely.get_parts(g)]
    polygons = [p for p in every if p.geom_type in ("Polygon", "MultiPolygon")]
    parts = [p for p in every if p.geom_type in ("LineString", "MultiLineString")] if lines else polygons
    if lines and parts and polygons:
        raise InputError(f"{name}: {where!r} holds {len(parts)} line(s) and {len(polygons)} polygon(s): a corridor is its "
                         "centreline (lines) or its polygon, not both")
    if lines and not parts:  # a corridor polygon: its centreline is derived (plan/centreline.py)
        parts, lines = polygons, False
    if not parts:
        raise InputError(f"{name}: {where!r} holds no {'line or polygon' if lines else 'polygon'}")
    if lines:
        return validate_lines(shapely.line_merge(shapely.multilinestrings(parts)) if len(parts) > 1 else parts[0],
                              f"{name} ({short})", crs.is_geographic)
    for i, p in enumerate(parts):
        validate_polygons(p, f"{name} ({short}, polygon {i + 1})", crs.is_geographic)
    return shapely.union_all(parts) if len(parts) > 1 else parts[0]


def _from_wkt(text: str, name: str) -> BaseGeometry:
    try:
        return shapely.from_wkt(text.strip())
    except shapely.errors.GEOSException as exc:
        raise InputError(f"{name}: not valid WKT: {exc}") from None


def read_area(path: Path | None, wkt: str | None, wkt_crs: str, name: str, lines: bool = False) -> BaseGeometry:
    """The area (or an exclusion zone) as a valid polygon geometry in WGS84 longitude/latitude;
    `lines`: a corridor's centreline, a (Multi)LineString, or its polygon."""
    if path is not None:
        geom, crs = _read_vector(path, name, lines)
    else:
        assert wkt is not None
        geom = _from_wkt(wkt, name)
        crs = _crs(wkt_crs, f"{name} wkt_crs")
    return _in_wgs84(geom, crs, name, lines)


def read_area_data(shown: str, files: Mapping[str, bytes], name: str) -> BaseGeometry:
    """`read_area` for files held in memory (a web page's upload), parsed by the same code.

    `files` is one dataset by base name: a single file (a `.wkt` one is read as WKT), the
    files of one Shapefile, or the `.kml` documents of a KMZ. They reach GDAL as a zip in
    memory, so that it picks its driver by the files' names as it does on disk. `shown`
    names the upload in messages.
    """
    names = list(files)
    bad = [n for n in names if not n or n != Path(n).name]
    if not names or bad:
        raise InputError(f"{name}: expected the files of one dataset by base name, got {names!r}")
    if len(names) == 1 and names[0].lower().endswith(".wkt"):
        try:
            text = files[names[0]].decode("utf-8")
        except UnicodeDecodeError as exc:
            raise InputError(f"{name}: {shown!r} is not UTF-8 text: {exc}") from None
        return _in_wgs84(_from_wkt(text, name), _WGS84, name)
    import zipfile  # for uploads only: not loaded by every command that reads an area (~4 ms)

    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_STORED) as zf:  # stored: a copy, no compression work
        for n in names:
            zf.writestr(n, files[n])
    geom, crs = _parse_vector(buf.getvalue(), shown, shown, name)
    return _in_wgs84(geom, crs, name)


def _in_wgs84(geom: BaseGeometry, crs: pyproj.CRS, name: str, lines: bool = False) -> BaseGeometry:
    """A parsed area (`lines`: a corridor's centreline or polygon) checked in its own CRS, then in
    WGS84 longitude/latitude."""
    validate = validate_lines if lines and geom.geom_type not in ("Polygon", "MultiPolygon") else validate_polygons
    geom = validate(geom, name, crs.is_geographic)
    if not crs.equals(_WGS84):
        geom = transformed(pyproj.Transformer.from_crs(crs, _WGS84, always_xy=True), geom)
        geom = validate(geom, f"{name} (in WGS84)", True)
    return geom


def _crs(text: str, name: str) -> pyproj.CRS:
    try:
        return pyproj.CRS.from_user_input(text)
    except pyproj.exceptions.CRSError:
        raise InputError(f"{name} = {text!r} is not a CRS pyproj knows; give e.g. EPSG:5514") from None


@functools.lru_cache(maxsize=64)
def transformer(src: str, dst: str) -> pyproj.Transformer:
    """A lon/lat-ordered transformer, made once per CRS pair.

    PROJ takes 40-70 ms to set up some transformations (S-JTSK/Krovak), as long as planning a
    small area; a page re-planning as the user types pays it once. pyproj (>= 3.1) makes a
    Transformer safe to share between threads.
    """
    return pyproj.Transformer.from_crs(src, dst, always_xy=True)


def utm_epsg(lon: float, lat: float) -> int:
    """EPSG code of the WGS84 UTM zone holding (lon, lat)."""
    zone = int(np.floor((lon + 180.0) / 6.0)) % 60 + 1
    return (32600 if lat >= 0 else 32700) + zone


def _within(west: float, east: float, south: float, north: float, lon: np.ndarray, lat: np.ndarray) -> bool:
    """Whether every point lies in the bounds (west > east: the bounds cross the antimeridian)."""
    in_lon = (lon >= west) & (lon <= east) if west <= east else (lon >= west) | (lon <= east)
    return bool(np.all(in_lon & (lat >= south) & (lat <= north)))


def check_area_of_use(crs: pyproj.CRS, option: str, places: Sequence[tuple[str, BaseGeometry]]) -> None:
    """Refuse an area, zone or launch point (WGS84 longitude/latitude) outside the area of use
    pyproj gives for `crs` (the CRS the spec names in `option`): planned there, distances and
    areas come out wrong without a word. Says so when the place with its axes swapped would fit."""
    aou = crs.area_of_use
    if aou is None:
        return
    w, s, e, n = aou.west, aou.south, aou.east, aou.north
    auth = crs.to_authority()
    shown = f"{auth[0]}:{auth[1]}" if auth else crs.name
    where = f"{crs.name}; {aou.name.rstrip('.')}" if len(aou.name) <= 60 else crs.name
    for name, geom in places:
        xy = shapely.get_coordinates(geom)
        if _within(w, e, s, n, xy[:, 0], xy[:, 1]):
            continue
        x0, y0, x1, y1 = geom.bounds
        swapped = _within(w, e, s, n, xy[:, 1], xy[:, 0])
        hint = ": longitude and latitude look swapped (GeoJSON and KML put longitude first)" if swapped else ""
        raise InputError(f"{name} at longitude {x0:.5f}..{x1:.5f}, latitude {y0:.5f}..{y1:.5f} is outside the area of "
                         f"use of {option} = {shown!r} ({where}: longitude {w:g}..{e:g}, latitude {s:g}..{n:g}){hint}")


def planning_crs(spec_crs: str, area_wgs84: BaseGeometry) -> Planar:
    """The projected CRS to plan in: the area's UTM zone for 'auto', else the one named."""
    if spec_crs == "auto":
        c = area_wgs84.centroid
        crs = pyproj.CRS.from_epsg(utm_epsg(c.x, c.y))
    else:
        crs = _crs(spec_crs, "mission.crs")
        if not crs.is_projected:
            raise InputError(f"mission.crs = {spec_crs!r} is not a projected CRS; plan in metres, e.g. a UTM zone or EPSG:5514")
        units = {ax.unit_name for ax in crs.axis_info}
        if not units <= {"metre", "meter"}:
            raise InputError(f"mission.crs = {spec_crs!r} has units {sorted(units)}; aerosurvey plans in metres")
    return Planar(
        crs=crs,
        to_plan=transformer("EPSG:4326", crs.srs),
        to_wgs84=transformer(crs.srs, "EPSG:4326"),
    )
