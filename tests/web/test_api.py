"""The web page's JSON API through Starlette's test client: every endpoint, bad input, concurrency."""

from __future__ import annotations

import hashlib
import io
import json
import re
import time
import tomllib
import urllib.parse
import zipfile
from pathlib import Path

import numpy as np
import pyproj
import pytest
import shapely
from click.testing import CliRunner
from webutil import TestClient, client, copy_mission, run_plan

from aerosurvey.cli import main
from aerosurvey.fileio import LISTING
from conftest import random_polygon, write_geojson

MB = 1024 * 1024


@pytest.fixture
def obratan(tmp_path: Path) -> Path:
    return copy_mission(tmp_path)


@pytest.fixture(scope="module")
def obratan_cli(tmp_path_factory) -> tuple[Path, Path]:
    """The example spec (copied) and what `aerosurvey plan` writes for it."""
    tmp = tmp_path_factory.mktemp("obratan")
    spec = copy_mission(tmp)
    out = tmp / "cli"
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)])
    assert res.exit_code == 0, res.output
    return spec, out


@pytest.fixture(scope="module")
def planned(obratan_cli):
    spec, out = obratan_cli
    with client(spec) as c:
        state = c.get("/api/state").json()
        st = run_plan(c, state["spec"])
        assert st["state"] == "done", st
        files = {name: c.get(f"/api/plans/{st['result']['plan_id']}/files/{name}") for name in st["result"]["files"]}
        archive = c.get(f"/api/plans/{st['result']['plan_id']}/archive.zip")
    return state, st["result"], files, archive, out


def test_state_has_the_spec_cameras_and_profiles(planned):
    state, *_ = planned
    assert state["spec"]["camera"]["model"] == "sony-a6000-16mm"
    assert state["spec"]["conditions"]["start"] == "2026-05-14T09:00:00+02:00"
    assert len(state["cameras"]) >= 25 and {"cz-land-consolidation", "asprs-2023"} <= {p["id"] for p in state["profiles"]}
    assert state["upload_limit"] == 50 * MB and state["spec_path"].endswith("obratan-72ha.toml")


def test_plan_equals_the_cli_byte_for_byte(planned):
    _, result, files, archive, out = planned
    cli_names = {p.name for p in out.iterdir()} - {LISTING}  # the CLI's folder also lists what it wrote there
    assert cli_names <= set(result["files"])
    for name in cli_names:  # the page's spec is the file's: the manifest names the spec file (inputs.spec) as the CLI's does
        assert files[name].status_code == 200
        assert files[name].content == (out / name).read_bytes(), name
    assert json.loads(files["manifest.json"].content)["inputs"]["spec"]["path"] == "obratan-72ha.toml"
    assert files["mission.waypoints"].headers["content-disposition"] == \
        "attachment; filename=\"mission.waypoints\"; filename*=UTF-8''mission.waypoints"
    with zipfile.ZipFile(io.BytesIO(archive.content)) as zf:
        assert sorted(zf.namelist()) == sorted(result["files"])
        assert zf.read("mission.waypoints") == (out / "mission.waypoints").read_bytes()
    # the control point files the field crew needs come with the plan
    assert {"control_points.geojson", "control_points.csv", "control_points.gpx"} <= set(result["files"])


def test_layers_match_the_manifest(planned):
    _, result, files, _, out = planned
    manifest = json.loads((out / "manifest.json").read_text())
    layers = result["layers"]
    assert layers["stations"]["ids"] == [s["id"] for s in manifest["stations"]]
    features = json.loads((out / "plan.geojson").read_text())["features"]
    assert [f["id"] for f in features if f["properties"]["role"] == "line"] == [ln["id"] for ln in layers["lines"]]
    assert result["summary"]["photos"] == len(manifest["stations"]) == 1593
    assert result["summary"]["lines"] == 34 and result["summary"]["sorties"] == len(manifest["sorties"]) == 5
    # every station carries the sortie that photographs it, in the manifest's ranges
    ids = layers["stations"]["ids"]
    for k, s in enumerate(manifest["sorties"], start=1):
        a, b = ids.index(s["first_station"]), ids.index(s["last_station"])
        assert set(layers["stations"]["sortie"][a:b + 1]) == {k}
    gcps = [p for p in layers["control_points"] if p["role"] == "gcp"]
    cp_file = json.loads(files["control_points.geojson"].content)
    assert len(layers["control_points"]) == len(cp_file["features"]) and len(gcps) >= 4


def test_map_frame_positions_and_cursor_crs(planned):
    """Frame coordinates go back to the stations' lon/lat, and the frame's PROJ string gives the plan CRS
    as the planner's transformation does (to a decimetre: the cursor readout)."""
    from aerosurvey.web.mapproj import inverse_mercator

    _, result, _, _, out = planned
    manifest = json.loads((out / "manifest.json").read_text())
    f = result["frame"]
    st = result["layers"]["stations"]
    lon, lat = inverse_mercator(np.array(st["x"]) + f["origin"][0], np.array(st["y"]) + f["origin"][1])
    assert np.allclose(lon, [s["lon"] for s in manifest["stations"]], atol=1e-7)
    assert np.allclose(lat, [s["lat"] for s in manifest["stations"]], atol=1e-7)
    px, py = pyproj.Transformer.from_crs("EPSG:4326", f["crs"], always_xy=True).transform(lon, lat)
    qx, qy = pyproj.Transformer.from_crs("EPSG:4326", pyproj.CRS.from_proj4(f["proj4"]), always_xy=True).transform(lon, lat)
    err = np.hypot(qx - px, qy - py)
    assert f["crs"] == "EPSG:5514" and "+towgs84=" in f["proj4"]  # S-JTSK: the datum shift is in the string
    assert err.max() < 0.1 and f["proj4_error_m"] < 0.1


def _plan_changed(spec_file: Path, table: str, key: str, value) -> dict:
    """The example spec with one value changed, planned through the API to the job's end."""
    with client(spec_file) as c:
        spec = c.get("/api/state").json()["spec"]
        spec[table][key] = value
        return run_plan(c, spec)


def test_bad_overlap_names_the_key(obratan):
    st = _plan_changed(obratan, "targets", "side_overlap", 1.2)
    assert st["state"] == "error"
    assert st["error"]["key"] == "targets.side_overlap"
    assert "1.2" in st["error"]["message"] and "[0.0, 0.95)" in st["error"]["message"]


def test_unknown_camera_names_the_key_and_suggests(obratan):
    st = _plan_changed(obratan, "camera", "model", "sony-a6000")
    assert st["state"] == "error" and st["error"]["key"] == "camera.model"
    assert "sony-a6000-16mm" in st["error"]["message"]


def test_invalid_polygon_upload_is_refused_with_where(obratan, tmp_path):
    bowtie = write_geojson(tmp_path / "bowtie.geojson", [[[15.0, 49.4], [15.01, 49.41], [15.01, 49.4], [15.0, 49.41], [15.0, 49.4]]])
    with client(obratan) as c:
        r = c.post("/api/area", files={"file": ("bowtie.geojson", bowtie.read_bytes(), "application/geo+json")})
    assert r.status_code == 400
    assert r.json()["key"] == "area.file" or "bowtie.geojson" in r.json()["error"]
    assert "self-intersection" in r.json()["error"].lower() or "invalid" in r.json()["error"].lower()


def test_area_uploads_start_a_new_plan(obratan, tmp_path):
    ring = random_polygon("concave", 3, 400)
    gj = write_geojson(tmp_path / "field.geojson", ring)
    with client(obratan) as c:
        spec = c.get("/api/state").json()["spec"]
        r = c.post("/api/area", files={"file": ("field.geojson", gj.read_bytes())}, data={"spec": json.dumps(spec)})
        assert r.status_code == 200, r.text
        new = r.json()["spec"]
        # the settings stay, what belonged to the old place goes
        assert new["camera"] == spec["camera"] and new["targets"] == spec["targets"]
        assert new["mission"]["crs"] == "auto" and new["mission"]["name"] == "field"
        assert "launch_points" not in new.get("battery", {})
        st = run_plan(c, new)
        assert st["state"] == "done", st
        assert st["result"]["summary"]["crs"] == "EPSG:32633"


def test_kml_upload(obratan, tmp_path):
    ring = random_polygon("convex", 7, 300)[0]
    coords = " ".join(f"{x},{y},0" for x, y in ring)
    kml = ('<?xml version="1.0" encoding="UTF-8"?><kml xmlns="http://www.opengis.net/kml/2.2"><Document><Placemark>'
           f"<name>field</name><Polygon><outerBoundaryIs><LinearRing><coordinates>{coords}</coordinates></LinearRing>"
           "</outerBoundaryIs></Polygon></Placemark></Document></kml>")
    with client(obratan) as c:
        r = c.post("/api/area", files={"file": ("field.kml", kml.encode())})
        assert r.status_code == 200, r.text
        st = run_plan(c, r.json()["spec"])
    assert st["state"] == "done", st
    geodesic_ha = abs(pyproj.Geod(ellps="WGS84").geometry_area_perimeter(shapely.Polygon(ring))[0]) / 1e4
    assert abs(st["result"]["summary"]["area_ha"] - geodesic_ha) < 0.01 * geodesic_ha


def _shapefile_zip(tmp: Path) -> bytes:
    import pyogrio

    poly = shapely.Polygon(random_polygon("convex", 5, 300)[0])
    pyogrio.raw.write(str(tmp / "field.shp"), geometry=np.array([shapely.to_wkb(poly)], dtype=object),
                      field_data=[], fields=[], crs="EPSG:4326", geometry_type="Polygon", driver="ESRI Shapefile")
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        for p in tmp.glob("field.*"):
            zf.write(p, f"field/{p.name}")
    return buf.getvalue()


def test_zipped_shapefile_upload(obratan, tmp_path):
    shp = tmp_path / "shp"
    shp.mkdir()
    data = _shapefile_zip(shp)
    with client(obratan) as c:
        r = c.post("/api/area", files={"file": ("field.zip", data, "application/zip")})
        assert r.status_code == 200, r.text
        area = r.json()["spec"]["area"]
        assert set(area) == {"wkt"}  # read in memory: the spec carries the area, not a path
        assert shapely.from_wkt(area["wkt"]).equals(shapely.Polygon(random_polygon("convex", 5, 300)[0]))
        st = run_plan(c, r.json()["spec"])
    assert st["state"] == "done", st


def test_zip_slip_and_unknown_types_are_refused(obratan):
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        zf.writestr("../evil.shp", b"x")
    with client(obratan) as c:
        r = c.post("/api/area", files={"file": ("evil.zip", buf.getvalue())})
        assert r.status_code == 400 and "outside the archive" in r.json()["error"]
        r = c.post("/api/area", files={"file": ("notes.docx", b"hello")})
        assert r.status_code == 400 and "notes.docx" in r.json()["error"] and r.json()["key"] == "area.file"
        r = c.post("/api/area", data={"x": "1"})
        assert r.status_code == 400 and "'file'" in r.json()["error"]


def test_upload_limit(obratan):
    with client(obratan) as c:
        # announced too large: refused before reading (the default 50 MB limit)
        r = c.post("/api/area", content=b"x" * 10, headers={"content-length": str(50 * MB + 1), "content-type": "text/plain"})
        assert r.status_code == 413 and "50 MB" in r.json()["error"]
        # a real 51 MB upload: stopped by counting, whatever the client announced
        big = b"0" * (51 * MB)
        r = c.post("/api/area", files={"file": ("huge.geojson", big)})
        assert r.status_code == 413
    with client(obratan, upload_limit=1 * MB) as c:

        def chunks():
            for _ in range(4):
                yield b"0" * (512 * 1024)

        r = c.post("/api/area", content=chunks(), headers={"content-type": "multipart/form-data; boundary=x"})
        assert r.status_code == 413 and "1 MB" in r.json()["error"]


def test_spec_paths_stay_in_the_workspace(obratan):
    with client(obratan) as c:
        spec = c.get("/api/state").json()["spec"]
        spec["area"]["file"] = "/etc/passwd"
        st = run_plan(c, spec)
        assert st["state"] == "error" and st["error"]["key"] == "area.file"
        spec["area"]["file"] = "../../outside.geojson"
        st = run_plan(c, spec)
        assert st["state"] == "error" and st["error"]["key"] == "area.file"


def test_plan_request_must_be_json(obratan):
    with client(obratan) as c:
        r = c.post("/api/plan", content=b"spec=1", headers={"content-type": "application/x-www-form-urlencoded"})
        assert r.status_code == 400 and "application/json" in r.json()["error"]
        r = c.post("/api/plan", content=b"{not json", headers={"content-type": "application/json"})
        assert r.status_code == 400 and "not valid JSON" in r.json()["error"]
        r = c.post("/api/plan", json={"spek": {}})
        assert r.status_code == 400 and r.json()["key"] == "spec"
        assert c.get("/api/jobs/j999").status_code == 404
        assert c.delete("/api/jobs/j999").status_code == 404
        assert c.get("/api/jobs/j1?wait=soon").status_code in (400, 404)
        assert c.get("/api/plans/p999/files/mission.plan").status_code == 404


def test_unknown_file_of_a_plan(planned, obratan_cli):
    spec, _ = obratan_cli
    with client(spec) as c:
        st = run_plan(c, c.get("/api/state").json()["spec"])
        r = c.get(f"/api/plans/{st['result']['plan_id']}/files/secret.txt")
        assert r.status_code == 404 and "mission.plan" in r.json()["error"]


def _big_spec(tmp: Path) -> dict:
    ring = random_polygon("holed", 11, 4000)
    write_geojson(tmp / "big.geojson", ring)
    return {"mission": {"name": "big"}, "area": {"file": "big.geojson"}, "camera": {"model": "sony-a6000-16mm"},
            "targets": {"gsd_cm": 1.2, "forward_overlap": 0.8, "side_overlap": 0.7}, "vehicle": {"type": "copter"},
            # a job this large on purpose (a long plan to cancel): above the default limits
            "limits": {"max_photos": 10_000_000, "max_flight_hours": 10_000}}


def test_progress_and_cancel(tmp_path):
    spec = _big_spec(tmp_path)
    (tmp_path / "s.toml").write_text("")
    with client(tmp_path / "s.toml") as c:
        job = c.post("/api/plan", json={"spec": spec}).json()["job"]
        seen = []
        end = time.monotonic() + 60
        while time.monotonic() < end:
            st = c.get(f"/api/jobs/{job}").json()
            seen.append(st["progress"])
            if st["progress"] > 0.06:
                break
            time.sleep(0.02)
        t0 = time.monotonic()
        assert c.delete(f"/api/jobs/{job}").status_code == 200
        st = c.get(f"/api/jobs/{job}?wait=10").json()
        stopped = time.monotonic() - t0
    assert st["state"] == "cancelled", st
    assert st["stage"] == "cancelled" and "result" not in st
    assert seen[-1] > 0.06 and seen == sorted(seen), seen
    assert stopped < 5.0  # the next heading candidate notices; a whole plan of this area takes far longer


def test_two_plans_at_once_equal_one_at_a_time(obratan, tmp_path):
    with client(obratan, workers=2) as c:
        a = c.get("/api/state").json()["spec"]
        b = json.loads(json.dumps(a))
        b["targets"]["side_overlap"] = 0.7
        b["flight"]["cross_hatch"] = False
        alone = {}
        for name, spec in (("a", a), ("b", b)):
            st = run_plan(c, spec)
            alone[name] = c.get(f"/api/plans/{st['result']['plan_id']}/files/mission.waypoints").content
        jobs = {name: c.post("/api/plan", json={"spec": spec}).json()["job"] for name, spec in (("a", a), ("b", b))}
        together = {}
        for name, job in jobs.items():
            st = c.get(f"/api/jobs/{job}?wait=10").json()
            while st["state"] in ("queued", "running"):
                st = c.get(f"/api/jobs/{job}?wait=10").json()
            assert st["state"] == "done", st
            together[name] = c.get(f"/api/plans/{st['result']['plan_id']}/files/mission.waypoints").content
    assert together == alone and alone["a"] != alone["b"]


def test_spec_as_toml_round_trips(obratan):
    """The spec's TOML comes with the area file it names, under the path it names it by."""
    with client(obratan) as c:
        spec = c.get("/api/state").json()["spec"]
        spec["targets"]["side_overlap"] = 0.65
        r = c.post("/api/spec/toml", json={"spec": spec})
        assert r.status_code == 200 and r.headers["content-type"] == "application/zip"
        assert r.headers["content-disposition"] == "attachment; filename=\"obratan-72ha.zip\"; filename*=UTF-8''obratan-72ha.zip"
        with zipfile.ZipFile(io.BytesIO(r.content)) as zf:
            assert sorted(zf.namelist()) == ["areas/obratan-72ha.geojson", "obratan-72ha.toml"]
            assert zf.read("areas/obratan-72ha.geojson") == (obratan.parent / "areas" / "obratan-72ha.geojson").read_bytes()
            back = tomllib.loads(zf.read("obratan-72ha.toml").decode())
        assert back["targets"]["side_overlap"] == 0.65 and back["area"]["file"] == "areas/obratan-72ha.geojson"
        assert back["rules"]["profiles"] == ["cz-land-consolidation"]
        # an area inline (uploaded or drawn): the TOML alone
        spec["area"] = {"wkt": shapely.box(14.95, 49.43, 14.955, 49.433).wkt}
        r = c.post("/api/spec/toml", json={"spec": spec})
        assert r.headers["content-type"] == "application/toml" and tomllib.loads(r.text)["area"] == spec["area"]
        spec["targets"]["forward_overlap"] = 2
        r = c.post("/api/spec/toml", json={"spec": spec})
        assert r.status_code == 400 and r.json()["key"] == "targets.forward_overlap"


def test_save_spec_writes_the_file_atomically(obratan):
    before = obratan.read_text()
    with client(obratan) as c:
        spec = c.get("/api/state").json()["spec"]
        spec["targets"]["side_overlap"] = 1.5
        r = c.post("/api/spec/save", json={"spec": spec})
        assert r.status_code == 400 and obratan.read_text() == before  # nothing written on bad input
        spec["targets"]["side_overlap"] = 0.7
        r = c.post("/api/spec/save", json={"spec": spec})
        assert r.status_code == 200, r.text
    saved = tomllib.loads(obratan.read_text())
    assert saved["targets"]["side_overlap"] == 0.7
    res = CliRunner().invoke(main, ["plan", str(obratan), "-o", str(obratan.parent / "again")])
    assert res.exit_code == 0, res.output
    assert not [p for p in obratan.parent.iterdir() if p.name.startswith(".") and p.name.endswith(".tmp")]


def test_save_without_a_spec_file_is_a_conflict():
    with client(None) as c:
        assert c.get("/api/state").json()["spec"] == {}
        r = c.post("/api/spec/save", json={"spec": {}})
        assert r.status_code == 409


def _filename(disposition: str) -> str:
    """The file name a Content-Disposition header gives a browser: its `filename*` (RFC 5987: charset, language,
    percent-encoded bytes), read here by the RFC's grammar."""
    m = re.search(r"filename\*=UTF-8'[^']*'([A-Za-z0-9!#$&+.^_`|~%-]+)(;|$)", disposition)
    assert m is not None, disposition
    return urllib.parse.unquote(m.group(1), encoding="utf-8", errors="strict")


def test_downloads_of_a_mission_named_in_czech(obratan):
    """A Czech mission name: every download answers, named in UTF-8 (RFC 5987) with an ASCII fallback (RFC 6266)."""
    with client(obratan) as c:
        spec = c.get("/api/state").json()["spec"]
        spec["mission"]["name"] = "Obrataň 72 ha"
        r = c.post("/api/spec/toml", json={"spec": spec})
        assert r.status_code == 200, r.text
        assert _filename(r.headers["content-disposition"]) == "Obrataň 72 ha.zip"
        assert 'filename="Obratan 72 ha.zip"' in r.headers["content-disposition"]
        with zipfile.ZipFile(io.BytesIO(r.content)) as zf:
            assert "Obrataň 72 ha.toml" in zf.namelist()
        st = run_plan(c, spec)
        assert st["state"] == "done", st
        pid = st["result"]["plan_id"]
        r = c.get(f"/api/plans/{pid}/archive.zip")
        assert r.status_code == 200 and _filename(r.headers["content-disposition"]) == "Obrataň 72 ha.zip"
        assert _filename(c.get(f"/api/plans/{pid}/files/mission.plan").headers["content-disposition"]) == "mission.plan"


def test_an_edited_spec_is_planned_without_naming_the_file(obratan):
    """The manifest names the spec file (inputs.spec) only when the page's spec is what the file holds."""
    with client(obratan) as c:
        spec = c.get("/api/state").json()["spec"]
        spec["targets"]["side_overlap"] = 0.65
        st = run_plan(c, spec)
        manifest = json.loads(c.get(f"/api/plans/{st['result']['plan_id']}/files/manifest.json").content)
        assert manifest["inputs"]["spec"] is None
        area = (obratan.parent / "areas" / "obratan-72ha.geojson").read_bytes()
        assert manifest["inputs"]["area"]["sha256"] == hashlib.sha256(area).hexdigest()


def test_host_and_origin_checks(obratan):
    with client(obratan, allowed_hosts=["127.0.0.1:8765"]) as c:
        assert c.get("/api/state").status_code == 421  # the test client's Host is 'testserver'
        ok = c.get("/api/state", headers={"host": "127.0.0.1:8765"})
        assert ok.status_code == 200
        r = c.post("/api/plan", json={"spec": ok.json()["spec"]},
                   headers={"host": "127.0.0.1:8765", "origin": "https://evil.example"})
        assert r.status_code == 403
        r = c.post("/api/plan", json={"spec": ok.json()["spec"]},
                   headers={"host": "127.0.0.1:8765", "origin": "http://127.0.0.1:8765"})
        assert r.status_code == 202


def test_origin_checked_when_any_host_is_answered(obratan):
    """`serve --host` off loopback answers any Host; a state-changing request from another origin is still refused."""
    with client(obratan, allowed_hosts=None) as c:
        spec = c.get("/api/state", headers={"host": "192.168.1.5:8765"}).json()["spec"]
        for method, url, body in (("POST", "/api/plan", {"spec": spec}), ("POST", "/api/spec/save", {"spec": spec}),
                                  ("POST", "/api/spec/toml", {"spec": spec}), ("DELETE", "/api/jobs/j1", None)):
            r = c.request(method, url, json=body, headers={"host": "192.168.1.5:8765", "origin": "https://evil.example"})
            assert r.status_code == 403 and "evil.example" in r.json()["error"], (method, url)
        r = c.post("/api/plan", json={"spec": spec}, headers={"host": "192.168.1.5:8765", "origin": "http://192.168.1.5:8765"})
        assert r.status_code == 202  # the page itself
        assert c.post("/api/plan", json={"spec": spec}).status_code == 202  # not a browser: no Origin


def test_serve_off_loopback_warns_which_check_is_off(obratan, monkeypatch, caplog):
    """The warning says the Host check is off and the Origin check on; the app it serves refuses other origins."""
    import uvicorn

    served = {}
    monkeypatch.setattr(uvicorn, "run", lambda app, **kw: served.update(app=app, **kw))
    with caplog.at_level("WARNING"):
        res = CliRunner().invoke(main, ["serve", str(obratan), "--host", "0.0.0.0", "--port", "8799"])
    assert res.exit_code == 0, res.output
    assert "Host check is off" in caplog.text and "Origin check stays on" in caplog.text
    with TestClient(served["app"]) as c:
        r = c.post("/api/plan", json={"spec": {}}, headers={"host": "10.0.0.7:8799", "origin": "https://evil.example"})
        assert r.status_code == 403


def test_queued_plans_are_capped(obratan):
    """Plans waiting for a planning thread are capped: one more is refused with 429 and the reason; a cancelled one
    frees its place."""
    import threading

    from aerosurvey.web.jobs import JobRunner

    release = threading.Event()
    with client(obratan) as c:
        spec = c.get("/api/state").json()["spec"]
        runner = c.app.state.server.runner = JobRunner(workers=1, max_waiting=2)
        try:
            runner.submit(lambda progress: release.wait(30))  # the one thread, busy
            waiting = [c.post("/api/plan", json={"spec": spec}) for _ in range(2)]
            assert [r.status_code for r in waiting] == [202, 202]
            r = c.post("/api/plan", json={"spec": spec})
            assert r.status_code == 429 and "2 plans are already waiting" in r.json()["error"]
            assert c.delete(f"/api/jobs/{waiting[0].json()['job']}").status_code == 200
            r = c.post("/api/plan", json={"spec": spec})
            assert r.status_code == 202
            release.set()
            st = c.get(f"/api/jobs/{r.json()['job']}?wait=10").json()
            assert st["state"] == "done", st
        finally:
            release.set()
            runner.shutdown()


def test_rule_failure_says_where(obratan):
    st = _plan_changed(obratan, "targets", "forward_overlap", 0.70)
    assert st["state"] == "done"
    res = st["result"]
    fwd = next(r for r in res["rules"] if r["rule"] == "cz-forward-overlap")
    assert fwd["status"] == "fail" and fwd["where"]
    line_ids = {ln["id"] for ln in res["layers"]["lines"]}
    assert all(w["run"] in line_ids for w in fwd["where"])


def test_flight_results_drawn_against_the_plan(tmp_path):
    from conftest import make_spec

    spec = make_spec(tmp_path, {"flight": {"heading": 0.0}})
    plan = tmp_path / "plan"
    assert CliRunner().invoke(main, ["plan", str(spec), "-o", str(plan)]).exit_code == 0
    log = Path(__file__).resolve().parents[1] / "data" / "sitl_copter_survey.bin"
    res = CliRunner().invoke(main, ["log", "ingest", str(log), "--plan", str(plan), "-o", str(tmp_path / "log")])
    assert res.exit_code == 0, res.output
    with client(spec) as c:
        st = run_plan(c, c.get("/api/state").json()["spec"])
        pid = st["result"]["plan_id"]
        files = [("files", (n, (tmp_path / "log" / n).read_bytes())) for n in ("events.csv", "coverage.tif", "log_report.json")]
        r = c.post(f"/api/plans/{pid}/flight", files=files)
        assert r.status_code == 200, r.text
        flown = r.json()
        r2 = c.post(f"/api/plans/{pid}/flight", files=[("files", ("log_report.json", b"{}"))])
        assert r2.status_code == 400 and "events.csv" in r2.json()["error"]
    assert len(flown["events"]["x"]) == 152 and flown["report"]["matched"] == 152
    assert flown["coverage"]["png"].startswith("data:image/png;base64,") and flown["coverage"]["max_count"] >= 8
    # the flown photos sit on their planned stations in the page's frame (within the log's 1.5 m)
    st_xy = dict(zip(st["result"]["layers"]["stations"]["ids"], zip(st["result"]["layers"]["stations"]["x"],
                                                                   st["result"]["layers"]["stations"]["y"])))
    d = [np.hypot(x - st_xy[s][0], y - st_xy[s][1]) for x, y, s in zip(flown["events"]["x"], flown["events"]["y"],
                                                                     flown["events"]["station"])]
    assert max(d) < 1.5 * 1.6  # Web Mercator metres are ground metres / cos(latitude)


def test_static_page_is_served(obratan):
    with client(obratan) as c:
        r = c.get("/")
        assert r.status_code == 200 and '<div id="map"' in r.text
        for path in ("/static/app.js", "/static/style.css", "/static/vendor/olb.js", "/static/vendor/ol.css"):
            assert c.get(path).status_code == 200, path


def test_serve_refuses_bad_options(tmp_path):
    res = CliRunner().invoke(main, ["serve", str(tmp_path / "missing.toml")])
    assert res.exit_code == 2 and "does not exist" in res.output
    res = CliRunner().invoke(main, ["serve", "--tiles", "https://tile.example/{z}/{x}.png"])
    assert res.exit_code == 2 and "{y}" in res.output and "{TileRow}" in res.output
    res = CliRunner().invoke(main, ["serve", "--tiles", "https://tile.example/{TileMatrix}/{TileCol}.png"])
    assert res.exit_code == 2


def test_serve_binds_loopback_and_warns_when_exposed(monkeypatch, obratan):
    import uvicorn

    calls = []
    monkeypatch.setattr(uvicorn, "run", lambda app, host, port, log_level: calls.append((app, host, port)))
    res = CliRunner().invoke(main, ["serve", str(obratan), "--port", "8765"])
    assert res.exit_code == 0, res.output
    app, host, port = calls[-1]
    assert (host, port) == ("127.0.0.1", 8765) and "http://127.0.0.1:8765/" in res.output and "warning" not in res.output
    from starlette.testclient import TestClient

    with TestClient(app) as c:  # only its own address answers (no DNS rebinding)
        assert c.get("/api/state").status_code == 421
        assert c.get("/api/state", headers={"host": "127.0.0.1:8765"}).status_code == 200
    res = CliRunner().invoke(main, ["serve", str(obratan), "--host", "0.0.0.0", "--port", "8766"])
    assert res.exit_code == 0 and "warning: listening on 0.0.0.0" in res.output
    assert calls[-1][1] == "0.0.0.0"


def test_unphotographed_ground_is_a_map_layer(tmp_path):
    """A plane's lines cut next to zones leave ground fewer than two photos see: the page draws it."""
    import zone_cases as zc

    p = zc.CaseParams(kind="convex", size_ha=9.23, lat=65.0, lon=-163.183, vehicle="plane", zones=("crossing", "crossing"),
                      battery_min=None, launch="default", end="rtl", margin_m=20.0, height_m=100.0, heading=None, seed=1087)
    spec_path = zc.write_case(zc.make_case(p), tmp_path)
    with client(spec_path) as c:
        st = run_plan(c, c.get("/api/state").json()["spec"])
        assert st["state"] == "done", st
        fc = c.get(f"/api/plans/{st['result']['plan_id']}/files/plan.geojson").json()
    parts = [f for f in fc["features"] if f["properties"]["role"] == "uncovered"]
    assert parts, "this case leaves ground unphotographed next to its zones"
    assert len(st["result"]["layers"]["uncovered"]) == len(parts)
    rule = next(r for r in st["result"]["rules"] if r["rule"] == "uncovered-ground")
    assert rule["status"] == "fail" and rule["where"]


def test_dji_waylines_are_offered_with_the_other_files(tmp_path):
    """With a camera a DJI aircraft flies waylines with, the plan's .kmz files (binary) are the page's downloads too,
    each the bytes `aerosurvey plan` writes, and in the archive."""
    spec_path = copy_mission(tmp_path)
    spec_path.write_text(spec_path.read_text().replace('model = "sony-a6000-16mm"', 'model = "dji-mavic-3-enterprise"'))
    assert "dji-mavic-3-enterprise" in spec_path.read_text()
    res = CliRunner().invoke(main, ["plan", str(spec_path), "-o", str(tmp_path / "cli")])
    assert res.exit_code in (0, 1), res.output  # 1: a rule fails; the files are written
    kmz = sorted(p.name for p in (tmp_path / "cli").glob("*.kmz"))
    assert "mission.kmz" in kmz and "sortie-01.kmz" in kmz
    with client(spec_path) as c:
        st = run_plan(c, c.get("/api/state").json()["spec"])
        assert st["state"] == "done", st
        pid, files = st["result"]["plan_id"], st["result"]["files"]
        assert set(kmz) <= set(files)
        for name in kmz:
            r = c.get(f"/api/plans/{pid}/files/{name}")
            assert r.status_code == 200 and r.headers["content-type"] == "application/vnd.google-earth.kmz"
            assert r.content == (tmp_path / "cli" / name).read_bytes()
        with zipfile.ZipFile(io.BytesIO(c.get(f"/api/plans/{pid}/archive.zip").content)) as zf:
            assert zf.read("sortie-01.kmz") == (tmp_path / "cli" / "sortie-01.kmz").read_bytes()
