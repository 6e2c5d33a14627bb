"""Helpers for the web page's tests: the app over a copy of an example mission, a plan run to its end."""

from __future__ import annotations

import shutil
import socket
import threading
import time
import tomllib
import warnings
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[2]

with warnings.catch_warnings():
    warnings.simplefilter("ignore")  # Starlette's notice that its test client will move to httpx2
    from starlette.testclient import TestClient


def copy_mission(tmp: Path, name: str = "obratan-72ha") -> Path:
    """The example mission and its area in a folder of the test's own (the page may write the spec)."""
    (tmp / "areas").mkdir(parents=True, exist_ok=True)
    spec = REPO / "missions" / f"{name}.toml"
    shutil.copy(spec, tmp / spec.name)
    rel = tomllib.loads(spec.read_text(encoding="utf-8"))["area"]["file"]
    shutil.copy(REPO / "missions" / rel, tmp / rel)
    return tmp / spec.name


def client(spec: Path | None, **kw: Any) -> TestClient:
    from aerosurvey.web.app import create_app

    return TestClient(create_app(spec, **kw))


def run_plan(c: TestClient, spec: dict[str, Any], timeout: float = 120.0) -> dict[str, Any]:
    """Submit a plan and wait for its job to end; returns the final job status."""
    return wait_job(c, c.post("/api/plan", json={"spec": spec}), timeout)


def wait_job(c: TestClient, r: Any, timeout: float = 120.0) -> dict[str, Any]:
    """Wait for the job a request `r` submitted (202) to end; returns the final job status."""
    assert r.status_code == 202, r.text
    job = r.json()["job"]
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        st = c.get(f"/api/jobs/{job}?wait=2").json()
        if st["state"] not in ("queued", "running"):
            return st
    raise AssertionError(f"job {job} did not finish in {timeout} s")


def tile_png(colour: tuple[int, int, int]) -> bytes:
    """A 256 px PNG tile of one colour."""
    import io

    from PIL import Image

    buf = io.BytesIO()
    Image.new("RGB", (256, 256), colour).save(buf, format="PNG")
    return buf.getvalue()


def tiles_around(lon: float, lat: float, zooms: range) -> dict[tuple[int, int, int], bytes]:
    """XYZ tiles (y from the north) over a place, 3 × 3 a zoom, each of its own colour."""
    import math

    out = {}
    for z in zooms:
        n = 2 ** z
        cx = int((lon + 180) / 360 * n)
        cy = int((1 - math.asinh(math.tan(math.radians(lat))) / math.pi) / 2 * n)
        for x in range(max(cx - 1, 0), min(cx + 2, n)):
            for y in range(max(cy - 1, 0), min(cy + 2, n)):
                out[(z, x, y)] = tile_png(((x * 37) % 256, (y * 53) % 256, (z * 19) % 256))
    return out


def write_mbtiles(path: Path, tiles: dict[tuple[int, int, int], bytes], fmt: str = "png") -> Path:
    """An MBTiles file as its specification lays it out (rows in TMS order: y from the south)."""
    import sqlite3

    with sqlite3.connect(path) as db:
        db.execute("CREATE TABLE metadata (name TEXT, value TEXT)")
        db.execute("CREATE TABLE tiles (zoom_level INTEGER, tile_column INTEGER, tile_row INTEGER, tile_data BLOB)")
        zs = [z for z, _, _ in tiles]
        db.executemany("INSERT INTO metadata VALUES (?, ?)", [("name", "test basemap"), ("format", fmt),
                                                               ("minzoom", str(min(zs))), ("maxzoom", str(max(zs)))])
        db.executemany("INSERT INTO tiles VALUES (?, ?, ?, ?)", [(z, x, (1 << z) - 1 - y, d) for (z, x, y), d in tiles.items()])
    return path


def write_pmtiles(path: Path, tiles: dict[tuple[int, int, int], bytes], compression: str = "NONE") -> Path:
    """A PMTiles (version 3) file of PNG tiles, written by the PMTiles project's writer; `compression` names
    the tile compression its header declares."""
    from pmtiles.tile import Compression, TileType, zxy_to_tileid
    from pmtiles.writer import Writer

    zs = [z for z, _, _ in tiles]
    with open(path, "wb") as fh:
        w = Writer(fh)
        for tid, data in sorted((zxy_to_tileid(z, x, y), d) for (z, x, y), d in tiles.items()):
            w.write_tile(tid, data)
        w.finalize({"tile_type": TileType.PNG, "tile_compression": Compression[compression], "min_zoom": min(zs),
                    "max_zoom": max(zs), "min_lon_e7": -1800000000, "min_lat_e7": -850000000, "max_lon_e7": 1800000000,
                    "max_lat_e7": 850000000, "center_zoom": min(zs), "center_lon_e7": 0, "center_lat_e7": 0},
                   {"name": "test basemap", "attribution": "test tiles"})
    return path


#: What the vector basemap of the tests holds (lon/lat near the Obrataň example): class, name, geometry.
VECTOR_FEATURES = [("road", "Main road", "LINESTRING (14.94 49.425, 14.96 49.435)"),
                   ("water", "Pond", "POLYGON ((14.9485 49.4285, 14.9525 49.4285, 14.9525 49.4315, 14.9485 49.4315, 14.9485 49.4285))"),
                   ("place", "Obratan", "POINT (14.952 49.432)")]


def write_vector_tiles(path: Path) -> Path:
    """A vector tile set (Mapbox Vector Tiles, zooms 12..14) written by GDAL's MBTiles or PMTiles driver."""
    import numpy as np
    import pyogrio
    import shapely

    wkb = np.array([shapely.to_wkb(shapely.from_wkt(w)) for _, _, w in VECTOR_FEATURES], dtype=object)
    fields = [np.array([c for c, _, _ in VECTOR_FEATURES], dtype=object), np.array([n for _, n, _ in VECTOR_FEATURES], dtype=object)]
    pyogrio.raw.write(str(path), geometry=wkb, field_data=fields, fields=["class", "name"], crs="EPSG:4326",
                      geometry_type="Unknown", driver="MBTiles" if path.suffix == ".mbtiles" else "PMTiles", layer="basemap",
                      dataset_options={"MINZOOM": "12", "MAXZOOM": "14"})
    return path


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Server:
    """The real app under uvicorn on a free loopback port, in a thread of this process."""

    def __init__(self, spec: Path | None, basemap: Path | None = None, lan: bool = False, campaign: Path | None = None,
                 vehicle: str | None = None):
        import uvicorn

        from aerosurvey.web.app import create_app

        self.port = free_port()
        hosts = [f"127.0.0.1:{self.port}", f"localhost:{self.port}"]
        # with `lan`, files are shared at the loopback address itself (the test is the phone too)
        app = create_app(spec, allowed_hosts=hosts, basemap=basemap, lan=f"127.0.0.1:{self.port}" if lan else None,
                         campaign=campaign, vehicle=vehicle)
        self.server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=self.port, log_level="warning"))
        self.thread = threading.Thread(target=self.server.run, daemon=True)
        self.thread.start()
        end = time.monotonic() + 20
        while not self.server.started and time.monotonic() < end:
            time.sleep(0.05)
        assert self.server.started, "uvicorn did not start"
        self.url = f"http://127.0.0.1:{self.port}/"

    def stop(self) -> None:
        self.server.should_exit = True
        self.thread.join(timeout=10)


#: the Obrataň example lies in UTM zone 33 north
UTM = "EPSG:32633"
#: the synthetic DEM: a plane rising eastwards, BASE_M at X0, SLOPE metres a metre
BASE_M, SLOPE = 420.0, 0.02


def dem_bytes(crs: str | None = UTM, driver: str = "GTiff", size: int = 300) -> tuple[bytes, float]:
    """A DEM round the Obrataň example (a 6 km square of 20 m cells): a plane BASE_M + SLOPE · (x − x0) in UTM;
    its bytes and x0. Written by rasterio into memory."""
    import numpy as np
    import pyproj
    import rasterio
    from rasterio.io import MemoryFile
    from rasterio.transform import from_origin

    x0, y0 = pyproj.Transformer.from_crs("EPSG:4326", UTM, always_xy=True).transform(14.95, 49.43)
    left, top = x0 - 3000.0, y0 + 3000.0
    cell = 6000.0 / size
    xs = left + (np.arange(size) + 0.5) * cell  # cell centres
    z = np.tile(BASE_M + SLOPE * (xs - x0), (size, 1)).astype("float32")
    profile = {"driver": driver, "width": size, "height": size, "count": 1, "dtype": "float32",
               "transform": from_origin(left, top, cell, cell)}
    if crs is not None:
        profile["crs"] = crs
    if driver == "GTiff":
        profile |= {"tiled": True, "blockxsize": 64, "blockysize": 64, "compress": "deflate"}
    with rasterio.Env(), MemoryFile() as mem:
        with mem.open(**profile) as ds:
            ds.write(z, 1)
        return bytes(mem.read()), float(x0)
