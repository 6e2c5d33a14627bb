"""`make handoff-demo`: every hand-off format from the fixed-wing example and its SITL flight
(683 camera events), each read back by its client's reader or its transcribed rules."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pyogrio
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "missions" / "tools"))
sys.path.insert(0, str(ROOT / "tests" / "flight"))
import handoff_example  # noqa: E402
from test_handoff import odm_filtered_gcp, odm_geo_entries  # noqa: E402


@pytest.fixture(scope="module")
def out(tmp_path_factory):
    o = tmp_path_factory.mktemp("handoff")
    handoff_example.main(o)
    return o


def test_every_format_is_written_and_reads_back(out: Path) -> None:
    images = sorted(p.name for p in (out / "images").iterdir())
    assert len(images) == 683
    geo = odm_geo_entries((out / "flight" / "geo.txt").read_text())
    assert list(geo) == images  # every image, in flight order, by file name
    assert all(e[4] == (2.0, 4.0) for e in geo.values())  # the accuracy columns (the defaults)
    pix4d = (out / "flight" / "pix4d_geolocation.csv").read_text().splitlines()
    meta = (out / "flight" / "metashape_reference.csv").read_text().splitlines()
    assert len(pix4d) == len(meta) == 1 + 683
    kept = odm_filtered_gcp((out / "flight" / "gcp_list.txt").read_text(), set(images))
    predictions = (out / "flight" / "gcp_predictions.csv").read_text().splitlines()
    assert kept is not None and len(kept) == len(predictions) - 1
    layers = dict(pyogrio.list_layers(out / "plan" / "plan.gpkg"))
    assert {"route", "stations", "gcps", "layer_styles"} <= set(layers)
    stations = json.loads((out / "plan" / "manifest.json").read_text())["stations"]
    assert pyogrio.read_info(out / "plan" / "plan.gpkg", layer="stations")["features"] == len(stations)
    plan = json.loads((out / "plan" / "mission.plan").read_text())
    assert len(plan["rallyPoints"]["points"]) == 1
    # the DJI block: WPML waylines per flight that lxml parses, and Survey items in its .plan files
    import zipfile

    from lxml import etree

    dji = out / "dji"
    for kmz in ["mission.kmz", *sorted(p.name for p in dji.glob("sortie-*.kmz"))]:
        with zipfile.ZipFile(dji / kmz) as z:
            assert {"wpmz/template.kml", "wpmz/waylines.wpml"} <= set(z.namelist())
            etree.fromstring(z.read("wpmz/waylines.wpml"))
    assert len(list(dji.glob("sortie-*.kmz"))) == len(list(dji.glob("sortie-*.waypoints"))) >= 1
    items = json.loads((dji / "mission.plan").read_text())["mission"]["items"]
    assert any(it.get("complexItemType") == "survey" for it in items)
