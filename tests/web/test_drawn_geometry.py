"""Geometry drawn on the page: handed to the planner in PlanInputs, saved beside the spec bit for bit."""

from __future__ import annotations

import io
import tomllib
import zipfile

import numpy as np
import shapely
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st
from webutil import client, copy_mission, run_plan

from aerosurvey.area import read_area
from aerosurvey.cli import main
from aerosurvey.inputs import load_geometry
from aerosurvey.spec import load_spec
from aerosurvey.web import service
from aerosurvey.web.specfile import save_with_geometry
from conftest import planned, random_polygon


def _polygon(kind: str, seed: int, size_m: float, dx: float, dy: float) -> shapely.Polygon:
    rings = random_polygon(kind, seed, size_m)
    return shapely.Polygon(np.array(rings[0]) + (dx, dy), [np.array(r) + (dx, dy) for r in rings[1:]])


@settings(max_examples=25, deadline=None)
@given(kind=st.sampled_from(["convex", "concave", "holed"]), seed=st.integers(0, 10_000),
       dx=st.floats(-1e-3, 1e-3), dy=st.floats(-1e-3, 1e-3), zones=st.integers(0, 3))
def test_saved_geometry_reads_back_bit_for_bit(tmp_path_factory, kind, seed, dx, dy, zones):
    tmp = tmp_path_factory.mktemp("save")
    spec_path = copy_mission(tmp)
    area = _polygon(kind, seed, 400, dx, dy)
    drawn = [shapely.Point(area.centroid.x + 0.001 * (k - 1), area.centroid.y).buffer(2e-4, quad_segs=2 + k)
             for k in range(zones)]
    spec = service.read_spec_file(spec_path)
    spec["area"] = {"wkt": service.exact_wkt(area)}
    ws = service.Workspace(base=tmp, uploads=tmp, roots=[tmp])
    saved, files, preview = save_with_geometry(ws, spec_path, spec, [service.exact_wkt(z) for z in drawn])
    assert files == sorted(["obratan-72ha.area.geojson"] + (["obratan-72ha.zones.geojson"] if zones else []))
    read_area_back, read_zones = load_geometry(load_spec(spec_path))
    want = read_area(None, service.exact_wkt(area), "EPSG:4326", "area")  # as the page's plan read it
    assert shapely.equals_exact(read_area_back, want, tolerance=0.0)
    got = sorted(shapely.normalize(p).wkb for z in read_zones for p in shapely.get_parts(z))
    assert got == sorted(shapely.normalize(p).wkb for p in service.drawn_zones([service.exact_wkt(z) for z in drawn]))
    on_disk = tomllib.loads(spec_path.read_text())["area"]
    assert "wkt" not in on_disk and on_disk["file"] == "obratan-72ha.area.geojson"
    assert saved["area"] == on_disk
    # the preview the page gets back is the saved files' geometry, read back
    assert shapely.equals_exact(shapely.from_wkt(preview["area"]), read_area_back, tolerance=0.0)
    assert sorted(shapely.normalize(shapely.from_wkt(z)).wkb for z in preview["zones"]) == got


def test_drawn_zones_reach_the_plan(tmp_path):
    spec_path = copy_mission(tmp_path)
    with client(spec_path) as c:
        state = c.get("/api/state").json()
        area = shapely.from_wkt(state["preview"]["area"])
        assert shapely.equals_exact(area, read_area(spec_path.parent / "areas" / "obratan-72ha.geojson", None, "EPSG:4326",
                                                    "area"), tolerance=0.0)
        zone = shapely.Point(area.centroid.x, area.centroid.y).buffer(8e-4, quad_segs=3)
        st_ = run_plan(c, state["spec"])
        runs0 = st_["result"]["summary"]["runs"]
        r = c.post("/api/plan", json={"spec": state["spec"], "zones": [zone.wkt]})
        assert r.status_code == 202
        job = r.json()["job"]
        done = c.get(f"/api/jobs/{job}?wait=10").json()
        while done["state"] in ("queued", "running"):
            done = c.get(f"/api/jobs/{job}?wait=10").json()
        assert done["state"] == "done", done
        assert done["result"]["summary"]["runs"] > runs0
        fc = c.get(f"/api/plans/{done['result']['plan_id']}/files/plan.geojson").json()
        ex = [shapely.geometry.shape(f["geometry"]) for f in fc["features"] if f["properties"]["role"] == "exclusion"]
        assert len(ex) == 1 and ex[0].hausdorff_distance(zone) < 1e-7  # plan.geojson rounds to 1e-8 degrees
        # a bad zone: one line naming it; zones and zone files together: refused
        bad = c.post("/api/plan", json={"spec": state["spec"], "zones": ["POLYGON ((0 0, 1 1, 1 0, 0 1, 0 0))"]}).json()
        st_bad = c.get(f"/api/jobs/{bad['job']}?wait=10").json()
        assert st_bad["state"] == "error" and st_bad["error"]["key"] == "zones" and "\n" not in st_bad["error"]["message"]
        assert "exclusion zone 1 (drawn)" in st_bad["error"]["message"]
        both = state["spec"] | {"area": state["spec"]["area"] | {"exclusions": ["areas/obratan-72ha.geojson"]}}
        r = c.post("/api/plan", json={"spec": both, "zones": []})
        st_both = c.get(f"/api/jobs/{r.json()['job']}?wait=10").json()
        assert st_both["state"] == "error" and st_both["error"]["key"] == "zones"
        r = c.post("/api/plan", json={"spec": state["spec"], "zones": "POLYGON"})
        assert r.status_code == 400 and r.json()["key"] == "zones"
        # Spec as TOML with drawn zones: a zip of the TOML, the zones' GeoJSON and the area file the spec names, which
        # plans the page's mission
        r = c.post("/api/spec/toml", json={"spec": state["spec"], "zones": [zone.wkt]})
        assert r.status_code == 200 and r.headers["content-type"] == "application/zip"
        with zipfile.ZipFile(io.BytesIO(r.content)) as zf:
            assert sorted(zf.namelist()) == ["areas/obratan-72ha.geojson", "obratan-72ha.toml", "obratan-72ha.zones.geojson"]
            zf.extractall(tmp_path / "download")
        res = CliRunner().invoke(main, ["plan", str(tmp_path / "download" / "obratan-72ha.toml"), "-o", str(tmp_path / "cli")])
        assert planned(res.exit_code, res.output), res.output
        page = c.get(f"/api/plans/{done['result']['plan_id']}/files/mission.waypoints").text
        assert (tmp_path / "cli" / "mission.waypoints").read_text() == page


_lonlat = st.tuples(st.floats(14.9, 15.0), st.floats(49.4, 49.5))


@settings(max_examples=25, deadline=None)
@given(lines=st.lists(st.lists(_lonlat, min_size=2, max_size=8, unique=True), min_size=1, max_size=3))
def test_saved_centreline_reads_back_bit_for_bit(tmp_path_factory, lines):
    """A corridor's drawn centreline (WKT in the spec) saved as GeoJSON beside the spec, with [pattern]: the file
    holds the same numbers, the spec names it, and the preview the page gets back is that line."""
    import json

    tmp = tmp_path_factory.mktemp("corridor")
    spec_path = copy_mission(tmp)
    geom = shapely.LineString(lines[0]) if len(lines) == 1 else shapely.MultiLineString(lines)
    spec = service.read_spec_file(spec_path)
    spec["area"] = {"wkt": service.exact_wkt(geom)}
    spec["pattern"] = {"kind": "corridor", "width_m": 60.0}
    spec["flight"].pop("cross_hatch", None)
    ws = service.Workspace(base=tmp, uploads=tmp, roots=[tmp])
    saved, files, preview = save_with_geometry(ws, spec_path, spec, None)
    assert files == ["obratan-72ha.centreline.geojson"]
    on_disk = tomllib.loads(spec_path.read_text())
    assert on_disk["pattern"] == {"kind": "corridor", "width_m": 60.0}
    assert on_disk["area"]["file"] == "obratan-72ha.centreline.geojson" and "wkt" not in on_disk["area"]
    feats = json.loads((tmp / "obratan-72ha.centreline.geojson").read_text())["features"]
    back = [shapely.geometry.shape(f["geometry"]) for f in feats]
    assert len(back) == 1 and shapely.equals_exact(back[0], geom, tolerance=0.0)
    assert shapely.equals_exact(shapely.from_wkt(preview["area"]), geom, tolerance=0.0)
    assert load_spec(spec_path).pattern.kind == "corridor"


def test_bad_centrelines_are_refused_before_anything_is_written(tmp_path):
    import pytest

    from aerosurvey.errors import InputError

    spec_path = copy_mission(tmp_path)
    before = spec_path.read_text()
    ws = service.Workspace(base=tmp_path, uploads=tmp_path, roots=[tmp_path])
    spec = service.read_spec_file(spec_path)
    spec["pattern"] = {"kind": "corridor", "width_m": 60.0}
    spec["flight"].pop("cross_hatch", None)
    for wkt, message in [("POINT (14.9 49.4)", "a Point is not a centreline"),  # a polygon is a corridor polygon
                         ("LINESTRING (14.9 49.4, 14.9 49.4)", "zero length"),
                         ("LINESTRING (14.9 49.4, 14.9 95.0)", "outside longitude"),
                         ("LINESTRING (14.9 49.4", "not valid WKT")]:
        with pytest.raises(InputError, match=message) as exc:
            save_with_geometry(ws, spec_path, {**spec, "area": {"wkt": wkt}}, None)
        assert "\n" not in str(exc.value)
    assert spec_path.read_text() == before and not list(tmp_path.glob("*.centreline.geojson"))


def test_a_corridor_spec_on_the_page(tmp_path):
    """The corridor example: its centreline is the page's editable geometry before the first plan, and the plan's
    lines reach the page with every bend, as plan.geojson has them."""
    spec_path = copy_mission(tmp_path, "road-corridor")
    with client(spec_path) as c:
        state = c.get("/api/state").json()
        line = shapely.from_wkt(state["preview"]["area"])
        assert line.geom_type in ("LineString", "MultiLineString")
        want = read_area(spec_path.parent / "areas" / "road-corridor.geojson", None, "EPSG:4326", "centreline", lines=True)
        assert shapely.equals_exact(line, want, tolerance=0.0)
        done = run_plan(c, state["spec"])
        assert done["state"] == "done", done
        view = done["result"]
        assert view["pattern"] == "corridor"
        fc = c.get(f"/api/plans/{view['plan_id']}/files/plan.geojson").json()
        bends = {f["properties"]["id"]: len(f["geometry"]["coordinates"]) for f in fc["features"]
                 if f["properties"]["role"] == "line"}
        assert {ln["id"]: len(ln["xy"]) for ln in view["layers"]["lines"]} == bends
        assert max(bends.values()) > 2  # the example's strips bend
        assert len(view["layers"]["area"]) >= 1  # the band the strips photograph, which the page draws


def test_an_uploaded_area_replaces_a_corridor_but_not_an_oblique_pattern():
    area = {"wkt": "POLYGON ((14.9 49.4, 14.91 49.4, 14.91 49.41, 14.9 49.4))"}
    corridor = {"mission": {"name": "c"}, "area": {"wkt": "LINESTRING (14.9 49.4, 14.91 49.41)"},
                "pattern": {"kind": "corridor", "width_m": 80.0}}
    out = service.with_new_area(corridor, area, "field")
    assert "pattern" not in out and out["area"] == area and corridor["pattern"]["kind"] == "corridor"  # the input kept
    oblique = {**corridor, "pattern": {"kind": "oblique", "scheme": "five-direction"}}
    assert service.with_new_area(oblique, area, "field")["pattern"] == oblique["pattern"]
