"""The offline basemap: tiles of a local MBTiles or PMTiles file served by the page's own server."""

from __future__ import annotations

import pytest
from webutil import client, copy_mission, tile_png, tiles_around, write_mbtiles, write_pmtiles, write_vector_tiles

from aerosurvey.errors import InputError
from aerosurvey.web.basemap import open_basemap

OBRATAN = (14.95, 49.43)


@pytest.mark.parametrize("kind", ["mbtiles", "pmtiles"])
def test_tiles_are_served_as_written(tmp_path, kind):
    tiles = tiles_around(*OBRATAN, range(12, 15))
    path = tmp_path / f"base.{kind}"
    (write_mbtiles if kind == "mbtiles" else write_pmtiles)(path, tiles)
    spec = copy_mission(tmp_path)
    with client(spec, basemap=path) as c:
        info = c.get("/api/state").json()["basemap"]
        assert info["url"] == "/api/basemap/{z}/{x}/{y}" and info["format"] == "png"
        assert (info["minzoom"], info["maxzoom"]) == (12, 14)
        for (z, x, y), data in tiles.items():  # XYZ rows: y from the north, as the page asks
            r = c.get(f"/api/basemap/{z}/{x}/{y}")
            assert r.status_code == 200 and r.content == data and r.headers["content-type"] == "image/png"
        z, x, y = next(iter(tiles))
        assert c.get(f"/api/basemap/{z}/{x + 5}/{y}").status_code == 404  # not in the file
        assert c.get(f"/api/basemap/{z}/{2 ** z}/{y}").status_code == 404  # off the grid
        assert c.get("/api/basemap/a/1/2").status_code == 404


def test_without_a_basemap_there_is_none(tmp_path):
    with client(copy_mission(tmp_path)) as c:
        assert c.get("/api/state").json()["basemap"] is None
        assert c.get("/api/basemap/1/0/0").status_code == 404


def test_bad_basemap_files_are_refused(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        open_basemap(tmp_path / "none.mbtiles")
    (tmp_path / "a.tif").write_bytes(b"x")
    with pytest.raises(InputError, match=r"\.mbtiles or \.pmtiles"):
        open_basemap(tmp_path / "a.tif")
    (tmp_path / "bad.mbtiles").write_bytes(b"not sqlite at all" * 10)
    with pytest.raises(InputError, match="not a readable MBTiles"):
        open_basemap(tmp_path / "bad.mbtiles")
    (tmp_path / "bad.pmtiles").write_bytes(b"")
    with pytest.raises(InputError, match="not a readable PMTiles"):
        open_basemap(tmp_path / "bad.pmtiles")
    tif = write_mbtiles(tmp_path / "tiff.mbtiles", {(0, 0, 0): b"II*\x00"}, fmt="tiff")
    with pytest.raises(InputError, match="holds tiff tiles; the page draws jpg, pbf, png, webp tiles"):
        open_basemap(tif)
    brotli = write_pmtiles(tmp_path / "br.pmtiles", {(0, 0, 0): b"x"}, compression="BROTLI")
    with pytest.raises(InputError, match="holds brotli-compressed tiles; the page serves uncompressed or gzipped"):
        open_basemap(brotli)


@pytest.mark.parametrize("kind", ["mbtiles", "pmtiles"])
def test_vector_tiles_are_served_gzipped_as_stored(tmp_path, kind):
    """GDAL's vector tile sets hold gzipped tiles: they go as stored with Content-Encoding: gzip (the
    browser unpacks them); a client that does not take gzip gets them unpacked."""
    import gzip
    import sqlite3

    path = write_vector_tiles(tmp_path / f"v.{kind}")
    if kind == "mbtiles":
        with sqlite3.connect(path) as db:
            stored = {(z, x, (1 << z) - 1 - row): bytes(d) for z, x, row, d in db.execute("SELECT * FROM tiles")}
    else:
        from pmtiles.reader import MmapSource, all_tiles

        with open(path, "rb") as fh:
            stored = {zxy: bytes(d) for zxy, d in all_tiles(MmapSource(fh))}
    assert stored and all(d[:2] == b"\x1f\x8b" for d in stored.values())
    with client(copy_mission(tmp_path), basemap=path) as c:
        info = c.get("/api/state").json()["basemap"]
        assert info["format"] == "pbf" and info["vector"] is True and (info["minzoom"], info["maxzoom"]) == (12, 14)
        for (z, x, y), data in stored.items():
            with c.stream("GET", f"/api/basemap/{z}/{x}/{y}", headers={"accept-encoding": "gzip"}) as r:
                sent = b"".join(r.iter_raw())  # the bytes on the wire, before the client unpacks them
            assert r.status_code == 200 and r.headers["content-encoding"] == "gzip" and sent == data
            assert r.headers["content-type"] == "application/vnd.mapbox-vector-tile"
            plain = c.get(f"/api/basemap/{z}/{x}/{y}", headers={"accept-encoding": "identity"})
            assert plain.status_code == 200 and "content-encoding" not in plain.headers
            assert plain.content == gzip.decompress(data)
            assert b"Pond" in plain.content or b"Main road" in plain.content or b"Obratan" in plain.content


def test_a_tile_too_large_unpacked_is_not_unpacked(tmp_path):
    """A gzipped tile that unpacks beyond MAX_TILE: sent as stored to a browser, refused to a client
    that would have the server unpack it."""
    import gzip

    from aerosurvey.web.basemap import MAX_TILE

    bomb = gzip.compress(b"\0" * (MAX_TILE + 1))
    path = write_mbtiles(tmp_path / "bomb.mbtiles", {(1, 0, 0): bomb}, fmt="pbf")
    with client(copy_mission(tmp_path), basemap=path) as c:
        with c.stream("GET", "/api/basemap/1/0/0", headers={"accept-encoding": "gzip"}) as r:
            assert r.status_code == 200 and b"".join(r.iter_raw()) == bomb
        r = c.get("/api/basemap/1/0/0", headers={"accept-encoding": "identity"})
        assert r.status_code == 404 and "unpacks to more than" in r.json()["error"]


def test_serve_takes_a_basemap_file(tmp_path, monkeypatch):
    import uvicorn
    from click.testing import CliRunner

    from aerosurvey.cli import main

    calls = []
    monkeypatch.setattr(uvicorn, "run", lambda app, host, port, log_level: calls.append(app))
    path = write_mbtiles(tmp_path / "b.mbtiles", {(1, 0, 0): tile_png((1, 2, 3))})
    res = CliRunner().invoke(main, ["serve", str(copy_mission(tmp_path)), "--basemap", str(path), "--port", "8765"])
    assert res.exit_code == 0, res.output
    from starlette.testclient import TestClient

    with TestClient(calls[-1]) as c:
        r = c.get("/api/basemap/1/0/0", headers={"host": "127.0.0.1:8765"})
        assert r.status_code == 200 and r.content == tile_png((1, 2, 3))
    res = CliRunner().invoke(main, ["serve", "--basemap", str(tmp_path / "x.geojson")])
    assert res.exit_code == 2 and "--basemap" in res.output
