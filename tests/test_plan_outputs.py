"""Outputs of `aerosurvey plan`: determinism, loaders, ids that join, summary."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from click.testing import CliRunner
from pymavlink import mavwp

from aerosurvey.cli import main
from aerosurvey.mission.formats.qgc_plan import loads_plan
from aerosurvey.mission.formats.wpl import loads_wpl
from conftest import REPO

FILES = ["manifest.json", "mission.plan", "mission.waypoints", "plan.geojson", "plan.kml", "preview.svg"]


def _plan(spec: Path, out: Path) -> str:
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)])
    assert res.exit_code == 0, res.output
    return res.output


@pytest.mark.parametrize("name", ["obratan-72ha", "kubad-abad-fixed-wing", "forest-dem"])
def test_same_spec_gives_byte_identical_outputs(name, tmp_path):
    spec = REPO / "missions" / f"{name}.toml"
    _plan(spec, tmp_path / "a")
    _plan(spec, tmp_path / "b")
    for f in FILES:
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes(), f


def test_outputs_load_and_join(tmp_path):
    out = tmp_path / "o"
    text = _plan(REPO / "missions" / "obratan-72ha.toml", out)
    for needle in ("height AGL", "GSD", "line spacing", "trigger distance", "max speed", "limited by", "photos", "min estimated"):
        assert needle in text
    manifest = json.loads((out / "manifest.json").read_text())
    # pymavlink's loader reads our waypoints; every item matches the plan file
    wp = mavwp.MAVWPLoader()
    n = wp.load(str(out / "mission.waypoints"))
    plan = loads_plan((out / "mission.plan").read_text(), "mission.plan")
    assert n == len(plan.items) + 1 == manifest["mission_items"] + 1
    for seq, it in enumerate(plan.items, start=1):
        w = wp.wp(seq)
        assert (w.command, w.frame) == (it.command, it.frame)
        assert w.x == pytest.approx(it.x, abs=1e-7) and w.y == pytest.approx(it.y, abs=1e-7)
        assert w.z == pytest.approx(it.z, abs=1e-3)
        assert w.param1 == pytest.approx(it.param1, abs=1e-5)
    # the waypoints file round-trips through our reader
    again = loads_wpl((out / "mission.waypoints").read_text(), "mission.waypoints")
    assert [(i.command, i.frame, i.params, i.x, i.y, i.z) for i in again.items] == \
           [(i.command, i.frame, i.params, i.x, i.y, i.z) for i in plan.items]
    # QGroundControl fields
    doc = json.loads((out / "mission.plan").read_text())
    assert doc["fileType"] == "Plan" and doc["version"] == 1 and doc["mission"]["version"] == 2
    assert doc["mission"]["firmwareType"] == 3 and doc["mission"]["vehicleType"] == 2
    assert len(doc["mission"]["plannedHomePosition"]) == 3
    # each photo pass is a QGroundControl Survey item (tests/mission/test_qgc_survey.py checks them)
    assert {i["type"] for i in doc["mission"]["items"]} == {"SimpleItem", "ComplexItem"}
    assert all(len(i["params"]) == 7 for i in doc["mission"]["items"] if i["type"] == "SimpleItem")
    # GeoJSON roles and ids join the manifest
    fc = json.loads((out / "plan.geojson").read_text())
    roles = {f["properties"]["role"] for f in fc["features"]}
    assert {"area", "line", "station", "footprint"} <= roles
    station_ids = {f["properties"]["id"] for f in fc["features"] if f["properties"]["role"] == "station"}
    assert station_ids == {s["id"] for s in manifest["stations"]}
    line_ids = {f["properties"]["id"] for f in fc["features"] if f["properties"]["role"] == "line"}
    assert line_ids == {line["id"] for line in manifest["lines"]}
    # KML and the SVG preview are well-formed XML
    kml = ET.parse(out / "plan.kml").getroot()
    folders = [f.find("{http://www.opengis.net/kml/2.2}name").text for f in kml.iter("{http://www.opengis.net/kml/2.2}Folder")]
    assert folders[:5] == ["area", "zones", "strips", "route", "stations"] and "footprints" not in folders
    svg = ET.parse(out / "preview.svg").getroot()
    assert svg.tag.endswith("svg")
    # inputs are recorded with their hashes, outputs too
    assert manifest["inputs"]["area"]["path"] == "areas/obratan-72ha.geojson" and len(manifest["inputs"]["area"]["sha256"]) == 64
    assert set(FILES) - {"manifest.json"} <= set(manifest["outputs"])
    assert {f for f in manifest["outputs"] if f.startswith("sortie-")} == {f for s in manifest["sorties"] for f in s["files"]}
    assert [r["rule"] for r in manifest["rules"]][0] == "cz-camera-sensor"


def test_manifest_hashes_every_file_written_and_rendered_texts_are_the_files(tmp_path):
    """Each output is encoded once, for its hash and its file (outputs.Rendered): the manifest lists
    every file written but itself, by the SHA-256 of the bytes on disk, and `Rendered.files` reads
    back each text file exactly as written."""
    import hashlib

    from aerosurvey.inputs import plan_from_files
    from aerosurvey.outputs import write_outputs
    from aerosurvey.spec import load_spec

    spec = load_spec(REPO / "missions" / "kubad-abad-fixed-wing.toml")  # sorties: more files
    out = tmp_path / "o"
    rendered = write_outputs(plan_from_files(spec), spec, out)
    written = {p.name: p.read_bytes() for p in out.iterdir() if not p.name.startswith(".")}
    listed = json.loads(written["manifest.json"])["outputs"]
    assert set(listed) == set(written) - {"manifest.json"} and any(n.startswith("sortie-") for n in listed)
    assert listed == {n: hashlib.sha256(b).hexdigest() for n, b in written.items() if n != "manifest.json"}
    assert set(rendered.files) | set(rendered.binary) == set(written)
    for name, text in rendered.files.items():
        assert text == written[name].decode("utf-8"), name


def test_exclusions_in_geojson(tmp_path):
    from conftest import make_spec, write_geojson

    zone = [[15.0025, 49.4012], [15.0035, 49.4012], [15.0035, 49.4022], [15.0025, 49.4022], [15.0025, 49.4012]]
    write_geojson(tmp_path / "zone.geojson", [zone])
    spec = make_spec(tmp_path, {"area": {"exclusions": ["zone.geojson"]}})
    _plan(spec, tmp_path / "o")
    fc = json.loads((tmp_path / "o" / "plan.geojson").read_text())
    assert sum(f["properties"]["role"] == "exclusion" for f in fc["features"]) == 1


def test_failed_plan_keeps_an_existing_output_folder(tmp_path):
    out = tmp_path / "o"
    _plan(REPO / "missions" / "obratan-72ha.toml", out)
    before = {f: (out / f).read_bytes() for f in FILES}
    bad = tmp_path / "bad.toml"
    bad.write_text((REPO / "missions" / "obratan-72ha.toml").read_text().replace("gsd_cm = 2.5", "gsd_cm = 9.0")
                   .replace('file = "areas/', f'file = "{REPO}/missions/areas/'))
    res = CliRunner().invoke(main, ["plan", str(bad), "-o", str(out)])
    assert res.exit_code == 2
    assert {f: (out / f).read_bytes() for f in FILES} == before
