"""Area uploads are read in memory by the loader's own parser: the geometry of the file, bit
for bit, for every format the page takes; nothing written to disk; a one-line error for a bad
upload; and the mission files of the file itself."""

from __future__ import annotations

import builtins
import contextlib
import copy
import io
import json
import os
import zipfile
from pathlib import Path

import numpy as np
import pyogrio
import pytest
import shapely
import tomli_w
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st
from webutil import client, run_plan

from aerosurvey.area import read_area
from aerosurvey.cli import main
from aerosurvey.errors import InputError
from aerosurvey.fileio import LISTING
from aerosurvey.web import service
from conftest import random_polygon, write_geojson

MB = 1024 * 1024


def _write(path: Path, geom: shapely.Geometry, crs: str, driver: str) -> Path:
    pyogrio.raw.write(str(path), geometry=np.array([shapely.to_wkb(geom)], dtype=object), field_data=[], fields=[], crs=crs,
                      geometry_type=geom.geom_type, driver=driver)
    return path


def _zip(folder: Path, pattern: str, prefix: str = "") -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
        for p in sorted(folder.glob(pattern)):
            zf.write(p, prefix + p.name)
    return buf.getvalue()


def _holed_utm() -> shapely.Polygon:
    """A polygon with a hole in UTM 33N metres: its WGS84 coordinates use every bit of a double."""
    outer = shapely.Point(500_000.0, 5_472_000.0).buffer(300.0, quad_segs=5)
    return shapely.Polygon(outer.exterior.coords, [shapely.Point(500_050.0, 5_472_020.0).buffer(60.0, quad_segs=3).exterior.coords])


CASES = ["geojson", "kml", "kmz", "gpkg-utm", "fgb", "gml", "wkt", "zipped-shapefile-utm"]


def _case(tmp: Path, case: str) -> tuple[Path, str, bytes]:
    """(the file the loader reads, the upload's name, the upload's bytes)."""
    rings = random_polygon("holed", 7, 250)
    ll = shapely.Polygon(rings[0], rings[1:])
    if case == "geojson":
        p = write_geojson(tmp / "field.geojson", random_polygon("concave", 3, 400))
    elif case == "kml":
        p = _write(tmp / "field.kml", ll, "EPSG:4326", "KML")
    elif case == "kmz":  # LIBKML's own KMZ: doc.kml links layers/field.kml
        p = _write(tmp / "field.kmz", ll, "EPSG:4326", "LIBKML")
    elif case == "gpkg-utm":
        p = _write(tmp / "field.gpkg", _holed_utm(), "EPSG:32633", "GPKG")
    elif case == "fgb":
        p = _write(tmp / "field.fgb", ll, "EPSG:4326", "FlatGeobuf")
    elif case == "gml":
        p = _write(tmp / "field.gml", ll, "EPSG:4326", "GML")
    elif case == "wkt":
        p = tmp / "field.wkt"
        p.write_text(ll.wkt)
    else:
        (tmp / "shp").mkdir()
        p = _write(tmp / "shp" / "field.shp", _holed_utm(), "EPSG:32633", "ESRI Shapefile")
        return p, "field.zip", _zip(tmp / "shp", "field.*", "field/")
    return p, p.name, p.read_bytes()


@pytest.mark.parametrize("case", CASES)
def test_upload_reads_the_geometry_the_file_gives(tmp_path, case):
    path, name, data = _case(tmp_path, case)
    from_file = read_area(path, None, "EPSG:4326", "area")
    got = service.read_uploaded_area(name, data, 10 * MB)
    from_upload = shapely.from_wkt(got.area["wkt"])
    assert from_upload.geom_type == from_file.geom_type
    for a, b in zip(shapely.get_parts(from_upload), shapely.get_parts(from_file), strict=True):
        rings_a = [a.exterior, *a.interiors]
        rings_b = [b.exterior, *b.interiors]
        assert len(rings_a) == len(rings_b)
        for ra, rb in zip(rings_a, rings_b, strict=True):
            assert np.array_equal(shapely.get_coordinates(ra), shapely.get_coordinates(rb))  # bit for bit
    assert got.bounds == from_file.bounds and got.vertices == shapely.get_num_coordinates(from_file)


_coord = st.floats(min_value=-179.0, max_value=179.0, allow_nan=False, allow_infinity=False)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(_coord, _coord.map(lambda v: v / 2)), min_size=3, max_size=40))
def test_exact_wkt_reads_back_bit_for_bit(points):
    hull = shapely.convex_hull(shapely.MultiPoint(points))
    if hull.geom_type != "Polygon" or hull.area <= 0:
        return
    holed = shapely.Polygon(hull.exterior.coords, [hull.centroid.buffer(1e-9 + 0.1 * np.sqrt(hull.area), 2).exterior.coords])
    for geom in (hull, shapely.MultiPolygon([hull, shapely.affinity.translate(hull, 400.0)]), holed):
        back = shapely.from_wkt(service.exact_wkt(geom))
        assert back.geom_type == geom.geom_type
        assert np.array_equal(shapely.get_coordinates(back), shapely.get_coordinates(geom))


@contextlib.contextmanager
def no_disk_writes(tried: list[str]):
    """While active, opening any file for writing (builtins.open, io.open, os.open: tempfile's
    too) raises PermissionError; the paths tried are appended to `tried`."""
    real_open, real_os_open = builtins.open, os.open

    def guarded_open(file, mode="r", *args, **kwargs):
        if any(c in mode for c in "wax+"):
            tried.append(str(file))
            raise PermissionError(f"test: no file may be written ({file})")
        return real_open(file, mode, *args, **kwargs)

    def guarded_os_open(path, flags, *args, **kwargs):
        if flags & (os.O_WRONLY | os.O_RDWR | os.O_CREAT):
            tried.append(str(path))
            raise PermissionError(f"test: no file may be written ({path})")
        return real_os_open(path, flags, *args, **kwargs)

    with pytest.MonkeyPatch.context() as m:
        m.setattr(builtins, "open", guarded_open)
        m.setattr(io, "open", guarded_open)
        m.setattr(os, "open", guarded_os_open)
        yield


def test_the_write_guard_catches_writes(tmp_path):
    import tempfile

    tried: list[str] = []
    with no_disk_writes(tried):
        with pytest.raises(PermissionError):
            (tmp_path / "a").write_bytes(b"x")
        with pytest.raises(PermissionError):
            tempfile.TemporaryFile()
        assert (tmp_path / "nothing").exists() is False
    assert tried[0] == str(tmp_path / "a") and len(tried) >= 2  # tempfile tries more than one way


def _padded_geojson(path: Path, ring: list) -> bytes:
    """A GeoJSON over 1 MB (Starlette's form parser spools larger files to disk by default)."""
    fc = {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"note": "x" * (3 * MB // 2)}, "geometry": {"type": "Polygon", "coordinates": ring}}]}
    path.write_text(json.dumps(fc))
    return path.read_bytes()


def test_upload_and_plan_write_no_file_and_give_the_files_of_the_file(tmp_path):
    ring = random_polygon("concave", 3, 400)
    data = _padded_geojson(tmp_path / "field.geojson", ring)
    assert len(data) > 1 * MB
    tried: list[str] = []
    with client(None) as c:
        with no_disk_writes(tried):
            r = c.post("/api/area", files={"file": ("field.geojson", data, "application/geo+json")})
            assert r.status_code == 200, r.text
            web_spec = r.json()["spec"]
            st_ = run_plan(c, web_spec)
            assert st_["state"] == "done", st_["error"]
            pid = st_["result"]["plan_id"]
            web = {n: c.get(f"/api/plans/{pid}/files/{n}").content for n in st_["result"]["files"]}
            toml = c.post("/api/spec/toml", json={"spec": web_spec})
        assert tried == []
        uploads = c.app.state.server.workspace.uploads
        assert list(uploads.iterdir()) == []  # nothing of the upload kept in the workspace either
    assert set(web_spec["area"]) == {"wkt"} and web_spec["mission"]["name"] == "field"

    # the CLI over the file itself: the same files, byte for byte, but for the manifest's record of the area
    file_spec = copy.deepcopy(web_spec)
    file_spec["area"] = {"file": "field.geojson"}
    (tmp_path / "field.toml").write_text(tomli_w.dumps(file_spec))
    res = CliRunner().invoke(main, ["plan", str(tmp_path / "field.toml"), "-o", str(tmp_path / "cli")])
    assert res.exit_code == 0, res.output
    cli = {p.name: p.read_bytes() for p in (tmp_path / "cli").iterdir() if p.name != LISTING}
    assert set(cli) <= set(web)
    for name in set(cli) - {"manifest.json"}:
        assert web[name] == cli[name], name
    web_m, cli_m = json.loads(web["manifest.json"]), json.loads(cli["manifest.json"])
    for key in set(cli_m) - {"inputs"}:
        assert web_m[key] == cli_m[key], key
    assert web_m["inputs"]["area"] == {"wkt": web_spec["area"]["wkt"], "crs": "EPSG:4326"}

    # the page's spec as TOML, planned by the CLI: the page's files, byte for byte
    assert toml.status_code == 200
    (tmp_path / "page.toml").write_text(toml.text)
    res = CliRunner().invoke(main, ["plan", str(tmp_path / "page.toml"), "-o", str(tmp_path / "page")])
    assert res.exit_code == 0, res.output
    again = {p.name: p.read_bytes() for p in (tmp_path / "page").iterdir() if p.name != LISTING}
    for name in set(again) - {"manifest.json"}:
        assert web[name] == again[name], name
    again_m = json.loads(again["manifest.json"])
    for key in set(again_m) - {"inputs"}:
        assert web_m[key] == again_m[key], key
    assert {k: v for k, v in again_m["inputs"].items() if k != "spec"} == {k: v for k, v in web_m["inputs"].items() if k != "spec"}


def _kmz_without_kml() -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        zf.writestr("files/photo.jpg", b"\xff\xd8")
    return buf.getvalue()


SWAPPED = json.dumps({"type": "Polygon", "coordinates": [[[49.4, 95.0], [49.41, 95.0], [49.41, 95.01], [49.4, 95.0]]]}).encode()


@pytest.mark.parametrize(("name", "data", "says"), [
    ("field.geojson", b'{"type": "FeatureCollection", "features": [', "cannot be read as a vector file"),
    ("field.geojson", json.dumps({"type": "Point", "coordinates": [15.0, 49.4]}).encode(), "holds no polygon"),
    ("field.wkt", b"POLYGON ((15 49.4, 15.01 49.41, 15.01 49.4, 15 49.41, 15 49.4))", "invalid polygon, self-intersection"),
    ("field.wkt", b"POLYGON ((15 49.4, 15.01", "not valid WKT"),
    ("field.wkt", b"\xff\xfe", "not UTF-8 text"),
    ("field.geojson", SWAPPED, "outside longitude"),
    ("field.shp", b"\x00\x00\x27\x0a", "upload them together as a .zip"),
    ("field.kmz", _kmz_without_kml(), "a KMZ must hold a .kml document"),
    ("field.zip", b"PK\x03\x04 not really", "not a valid zip archive"),
])
def test_bad_upload_is_one_line_naming_the_file(name, data, says):
    with client(None) as c:
        r = c.post("/api/area", files={"file": (name, data)})
    assert r.status_code == 400, r.text
    err = r.json()
    assert says in err["error"] and name in err["error"], err
    assert "\n" not in err["error"] and "pyogrio_" not in err["error"] and "/vsimem" not in err["error"], err
    assert err["key"] == "area.file"


def test_an_area_too_large_to_plan_from_the_page_is_refused(tmp_path):
    ring = shapely.Point(15.0, 49.4).buffer(0.01, quad_segs=4000)  # 16 001 vertices, ~600 kB of exact WKT
    with pytest.raises(InputError, match=r"16001 vertices make .* MB of WKT; the page plans areas up to 0.2 MB"):
        service.read_uploaded_area("round.wkt", ring.wkt.encode(), 200_000)
    fgb = _write(tmp_path / "round.fgb", ring, "EPSG:4326", "FlatGeobuf").read_bytes()  # ~260 kB: under the limit
    with client(None, upload_limit=400_000) as c:
        r = c.post("/api/area", files={"file": ("round.fgb", fgb)})
    assert r.status_code == 400 and "simplify the outline" in r.json()["error"] and r.json()["key"] == "area.file"
