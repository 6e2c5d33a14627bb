"""A DEM uploaded from the page (POST /api/dem): a GeoTIFF with a CRS is stored in the mission's folder and planned
over; every other file, damaged as real files get damaged, is refused in one line naming it and what is allowed."""

from __future__ import annotations

import io
import json

import pyproj
import pytest
from webutil import BASE_M, SLOPE, UTM, client, copy_mission, dem_bytes, run_plan


def upload(c, name: str, data: bytes):
    return c.post("/api/dem", files={"file": (name, io.BytesIO(data), "image/tiff")})


@pytest.fixture(scope="module")
def obratan(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("dem-upload")
    spec = copy_mission(tmp)
    with client(spec, upload_limit=8 * 1024 * 1024) as c:
        yield c, tmp


def test_a_geotiff_is_stored_and_planned_over(obratan):
    c, tmp = obratan
    data, x0 = dem_bytes()
    r = upload(c, "Obrataň terrain.tif", data)
    assert r.status_code == 200, r.text
    got = r.json()
    assert got["path"] == "dem/Obrata__terrain.tif" and got["bytes"] == len(data)
    assert got["size"] == [300, 300] and got["crs"] == UTM
    assert (tmp / got["path"]).read_bytes() == data
    assert not [p for p in (tmp / "dem").iterdir() if p.name.startswith(".")]  # no staging file left
    spec = c.get("/api/state").json()["spec"]
    done = run_plan(c, {**spec, "terrain": {"dem": got["path"]}})
    assert done["state"] == "done", done
    view = done["result"]
    assert view["dem"] is True
    # the ground under the route is the plane's, found independently at the route's vertices (mission.waypoints)
    rows = [line.split("\t") for line in c.get(f"/api/plans/{view['plan_id']}/files/mission.waypoints").text.splitlines()[1:]]
    pts = [(float(r[9]), float(r[8])) for r in rows if float(r[8]) != 0 or float(r[9]) != 0]
    xs, _ = pyproj.Transformer.from_crs("EPSG:4326", UTM, always_xy=True).transform(*zip(*pts))
    ground = view["profile"]["ground_m"]
    assert min(ground) == pytest.approx(BASE_M + SLOPE * (min(xs) - x0), abs=0.05)
    assert max(ground) == pytest.approx(BASE_M + SLOPE * (max(xs) - x0), abs=0.05)
    manifest = json.loads(c.get(f"/api/plans/{view['plan_id']}/files/manifest.json").text)
    assert manifest["clearance"] is not None


def _truncated() -> bytes:
    data, _ = dem_bytes()
    return data[: len(data) * 2 // 3]


def _flipped() -> bytes:  # a disk or transfer error inside the compressed tiles
    data = bytearray(dem_bytes()[0])
    for i in range(len(data) // 3, len(data) - 200, 97):
        data[i] ^= 0xFF
    return bytes(data)


DAMAGED = [
    ("notes.tif", b"elevation 420 m\n", "cannot be opened as a raster"),
    ("empty.tif", b"", "cannot be opened as a raster"),
    ("cut.tif", None, "cannot be"),
    ("flipped.tif", None, "cannot be"),
    ("nocrs.tif", None, "has no CRS"),
    ("picture.tif", None, "not a GeoTIFF"),
    ("dem.png", b"\x89PNG\r\n\x1a\n", "is not allowed"),
    ("dem", b"II*\x00", "is not allowed"),
]


@pytest.mark.parametrize(("name", "data", "says"), DAMAGED, ids=[d[0] for d in DAMAGED])
def test_a_damaged_or_wrong_file_is_refused_in_one_line(obratan, name, data, says):
    c, tmp = obratan
    if data is None:
        data = {"cut.tif": _truncated, "flipped.tif": _flipped, "nocrs.tif": lambda: dem_bytes(crs=None)[0],
                "picture.tif": lambda: dem_bytes(driver="HFA", size=64)[0]}[name]()
    before = sorted(p.name for p in (tmp / "dem").iterdir()) if (tmp / "dem").is_dir() else []
    r = upload(c, name, data)
    assert r.status_code == 400, r.text
    err = r.json()
    assert err["key"] == "terrain.dem"
    msg = err["error"]
    assert "\n" not in msg and repr(name) in msg and says in msg, msg
    assert "GeoTIFF (.tif, .tiff) with a CRS" in msg
    assert str(tmp) not in msg and f".{name.split('.')[0]}." not in msg  # the staging file is not named
    after = sorted(p.name for p in (tmp / "dem").iterdir()) if (tmp / "dem").is_dir() else []
    assert after == before  # nothing stored, nothing left behind


def test_a_dem_over_the_upload_limit_is_refused(obratan):
    c, tmp = obratan
    r = upload(c, "huge.tif", b"II*\x00" + bytes(9 * 1024 * 1024))
    assert r.status_code == 413
    assert not (tmp / "dem" / "huge.tif").exists()


def test_not_a_form_is_refused(obratan):
    c, _ = obratan
    r = c.post("/api/dem", content=b"II*\x00", headers={"Content-Type": "image/tiff"})
    assert r.status_code == 400 and r.json()["key"] == "terrain.dem"
