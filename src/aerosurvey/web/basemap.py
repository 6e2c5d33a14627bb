"""An offline basemap for the page: the raster tiles of a local MBTiles or PMTiles file, served by
the page's own server (`aerosurvey serve --basemap FILE`), so that a pilot who prepared the file at
the office plans in the field without a network.

MBTiles is SQLite (read with Python's sqlite3, read-only; its rows are TMS, y counted from the
south); PMTiles is read by the PMTiles project's own reader (`pmtiles` on PyPI). Only raster tiles
(PNG, JPEG, WebP) and vector tiles (Mapbox Vector Tiles, `pbf`) are served: the page draws the
first as an XYZ layer, the second as a vector tile layer with a default style by layer and class
names. Files hold vector tiles gzipped; they are served as stored, with `Content-Encoding: gzip`
(the browser unpacks them), as tile servers serve them.
"""

from __future__ import annotations

import sqlite3
import threading
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aerosurvey.errors import InputError

#: Tile formats the page can draw, by the name MBTiles' metadata uses, and their media types.
MEDIA = {"png": "image/png", "jpg": "image/jpeg", "webp": "image/webp",
         "pbf": "application/vnd.mapbox-vector-tile"}


@dataclass(frozen=True)
class BasemapInfo:
    name: str
    format: str  # png, jpg, webp or pbf (vector tiles)
    minzoom: int
    maxzoom: int
    bounds: tuple[float, float, float, float] | None  # lon/lat
    attribution: str

    def as_dict(self) -> dict[str, Any]:
        return {"url": "/api/basemap/{z}/{x}/{y}", "name": self.name, "format": self.format, "vector": self.format == "pbf",
                "minzoom": self.minzoom,
                "maxzoom": self.maxzoom, "bounds": list(self.bounds) if self.bounds else None,
                "attribution": self.attribution}


class Basemap:
    """A tile file opened read-only; `tile(z, x, y)` (XYZ, y from the north; the bytes as stored) is safe
    from any thread."""

    info: BasemapInfo

    def tile(self, z: int, x: int, y: int) -> bytes | None:
        raise NotImplementedError

    def close(self) -> None:
        raise NotImplementedError


def open_basemap(path: Path) -> Basemap:
    """The basemap file by its suffix; InputError naming the file when it cannot serve raster tiles."""
    if not path.is_file():
        raise InputError(f"--basemap {str(path)!r} does not exist: a local .mbtiles or .pmtiles file")
    suffix = path.suffix.lower()
    if suffix == ".mbtiles":
        return _MBTiles(path)
    if suffix == ".pmtiles":
        return _PMTiles(path)
    raise InputError(f"--basemap {str(path)!r} is not allowed: a .mbtiles or .pmtiles file of raster tiles")


def _format(path: Path, fmt: str) -> str:
    fmt = {"jpeg": "jpg", "mvt": "pbf"}.get(fmt.lower(), fmt.lower())
    if fmt not in MEDIA:
        raise InputError(f"--basemap {path.name!r} holds {fmt or 'unnamed'} tiles; the page draws "
                         f"{', '.join(sorted(MEDIA))} tiles")
    return fmt


#: The most a gzipped tile may unpack to (a vector tile is a few hundred kB at most).
MAX_TILE = 16 * 1024 * 1024


def is_gzipped(data: bytes) -> bool:
    """Whether a stored tile is gzipped (vector tiles are: MBTiles by custom, PMTiles by its header)."""
    return data[:2] == b"\x1f\x8b"


def gunzipped(data: bytes) -> bytes | None:
    """A gzipped tile unpacked, for a client that does not take gzip; None for one that would unpack to
    more than MAX_TILE."""
    d = zlib.decompressobj(16 + zlib.MAX_WBITS)
    try:
        out = d.decompress(data, MAX_TILE)
    except zlib.error:
        return None
    return None if d.unconsumed_tail else out


class _MBTiles(Basemap):
    def __init__(self, path: Path):
        try:
            self._db = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True, check_same_thread=False)
            meta = dict(self._db.execute("SELECT name, value FROM metadata").fetchall())
            zooms = self._db.execute("SELECT MIN(zoom_level), MAX(zoom_level) FROM tiles").fetchone()
        except sqlite3.Error as exc:
            raise InputError(f"--basemap {path.name!r} is not a readable MBTiles file: {exc}") from None
        self._lock = threading.Lock()  # one connection, used by one thread at a time
        bounds = None
        if meta.get("bounds"):
            try:
                b = [float(v) for v in str(meta["bounds"]).split(",")]
                bounds = (b[0], b[1], b[2], b[3]) if len(b) == 4 else None
            except ValueError:
                bounds = None
        if zooms is None or zooms[0] is None:
            raise InputError(f"--basemap {path.name!r} holds no tiles")
        self.info = BasemapInfo(str(meta.get("name") or path.stem), _format(path, str(meta.get("format", "png"))),
                                int(meta.get("minzoom", zooms[0])), int(meta.get("maxzoom", zooms[1])), bounds,
                                str(meta.get("attribution", "")))

    def tile(self, z: int, x: int, y: int) -> bytes | None:
        with self._lock:
            row = self._db.execute("SELECT tile_data FROM tiles WHERE zoom_level = ? AND tile_column = ? AND tile_row = ?",
                                   (z, x, (1 << z) - 1 - y)).fetchone()
        return None if row is None else bytes(row[0])

    def close(self) -> None:
        self._db.close()


class _PMTiles(Basemap):
    def __init__(self, path: Path):
        import pmtiles.reader
        from pmtiles.tile import Compression, MagicNumberNotFound, SpecVersionUnsupported, TileType

        pm: Any = pmtiles.reader  # the package has no complete type hints

        self._fh = open(path, "rb")  # noqa: SIM115 (kept open while the server runs; closed by close())
        try:
            self._reader = pm.Reader(pm.MmapSource(self._fh))
            header = self._reader.header()
            meta = self._reader.metadata()
        except (MagicNumberNotFound, SpecVersionUnsupported, ValueError, OSError) as exc:  # ValueError: an empty file
            self._fh.close()
            raise InputError(f"--basemap {path.name!r} is not a readable PMTiles (version 3) file: {exc!r}") from None
        if header["tile_compression"] not in (Compression.NONE, Compression.GZIP, Compression.UNKNOWN):
            self._fh.close()
            raise InputError(f"--basemap {path.name!r} holds {header['tile_compression'].name.lower()}-compressed tiles; "
                             "the page serves uncompressed or gzipped tiles (pmtiles convert can rewrite them)")
        names = {TileType.PNG: "png", TileType.JPEG: "jpg", TileType.WEBP: "webp", TileType.MVT: "pbf"}
        fmt = names.get(header["tile_type"], header["tile_type"].name.lower())
        self._lock = threading.Lock()
        e7 = 1e-7
        bounds = (header["min_lon_e7"] * e7, header["min_lat_e7"] * e7, header["max_lon_e7"] * e7, header["max_lat_e7"] * e7)
        self.info = BasemapInfo(str(meta.get("name") or path.stem), _format(path, fmt), int(header["min_zoom"]),
                                int(header["max_zoom"]), bounds, str(meta.get("attribution", "")))

    def tile(self, z: int, x: int, y: int) -> bytes | None:
        with self._lock:
            data = self._reader.get(z, x, y)
        return None if data is None else bytes(data)

    def close(self) -> None:
        self._fh.close()
