"""A campaign on the page (`serve --campaign`): register.gpkg's blocks on the map coloured by status with a legend
and counts, each opening its plan from its folder (summary, files, route), read-only.

The campaign is planned by `aerosurvey campaign plan` (tests/campaign/campaigncase.py) with one block that fails, and
events recorded with `campaign record`; the test reads the blocks file, the block folders and the .waypoints itself."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest
import shapely
from click.testing import CliRunner
from webutil import client

from aerosurvey.cli import main

CAMPAIGN_TESTS = Path(__file__).resolve().parents[1] / "campaign"
#: each block's status by construction: t01 asks for a GSD above the height cap, t02 and t03 get events by hand
STATUS = {"t00": "planned", "t01": "failed", "t02": "uploaded", "t03": "accepted", "t04": "planned"}
CHROMIUM = os.environ.get("AEROSURVEY_CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")
ARGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking"]


def _campaigncase():
    import sys

    if str(CAMPAIGN_TESTS) not in sys.path:
        sys.path.insert(0, str(CAMPAIGN_TESTS))
    import campaigncase

    return campaigncase


@pytest.fixture(scope="module")
def campaign(tmp_path_factory) -> tuple[Path, Path]:
    cc = _campaigncase()
    tmp = tmp_path_factory.mktemp("campaign-page")
    blocks = cc.write_blocks(tmp / "blocks.geojson", 5, props={1: {"gsd_cm": 10.0}})
    out = tmp / "campaign"
    res = CliRunner().invoke(main, ["campaign", "plan", str(blocks), "-o", str(out), "--spec", str(cc.write_template(tmp)),
                                    "--workers", "1"])
    assert res.exit_code == 1 and "1 block(s) failed (t01)" in res.output, res.output
    for name, event in (("t02", "uploaded"), ("t03", "accepted")):
        res = CliRunner().invoke(main, ["campaign", "record", str(out), name, event])
        assert res.exit_code == 0, res.output
    return out, blocks


def _folders(campaign: Path) -> dict[str, Path]:
    return {p.name.split(".")[0]: p for p in (campaign / "blocks").iterdir()}


def _route(wpl: Path) -> list[list[float]]:
    """Home and every item with a position of a QGC WPL 110 file, as [lon, lat] (columns 9 and 8)."""
    rows = [line.split("\t") for line in wpl.read_text().splitlines()[1:]]
    return [[float(r[9]), float(r[8])] for r in rows if float(r[8]) != 0 or float(r[9]) != 0]


def test_the_blocks_by_status_and_each_blocks_plan(campaign):
    out, blocks = campaign
    with client(None, campaign=out) as c:
        assert c.get("/api/state").json()["campaign"] == "campaign"
        got = c.get("/api/campaign").json()
        assert got["counts"] == {"planned": 2, "failed": 1, "uploaded": 1, "accepted": 1}
        assert got["statuses"] == ["failed", "planned", "uploaded", "accepted"]  # in the order of a block's life
        feats = {f["properties"]["name"]: f for f in got["blocks"]["features"]}
        assert {n: f["properties"]["status"] for n, f in feats.items()} == STATUS
        for f in json.loads(blocks.read_text())["features"]:  # the blocks file's polygons, as the register holds them
            drawn = shapely.geometry.shape(feats[f["properties"]["name"]]["geometry"])
            assert drawn.symmetric_difference(shapely.geometry.shape(f["geometry"])).area < 1e-16
        assert "fly it" in feats["t00"]["properties"]["next"] and "10.00 cm" in feats["t01"]["properties"]["message"]
        folders = _folders(out)
        for name in ("t00", "t02", "t03", "t04"):
            plan = c.get(f"/api/campaign/blocks/{name}").json()
            assert plan["folder"] == folders[name].name
            assert plan["files"] == sorted(p.name for p in folders[name].iterdir())
            assert plan["summary"]["name"] == name and plan["summary"]["photos"] == feats[name]["properties"]["photos"]
            assert plan["route"]["coordinates"] == _route(folders[name] / "mission.waypoints")
            for file in plan["files"]:
                r = c.get(f"/api/campaign/blocks/{name}/files/{file}")
                assert r.status_code == 200 and r.content == (folders[name] / file).read_bytes()
        r = c.get("/api/campaign/blocks/t01")  # failed: no plan folder, and the page says why
        assert r.status_code == 404 and "t01" in r.json()["error"] and "no plan folder" in r.json()["error"]
        r = c.get("/api/campaign/blocks/t00/files/..%2F..%2Fregister.gpkg")  # no route: nothing outside the folder
        assert r.status_code == 404 and r.content != (out / "register.gpkg").read_bytes()
        for url in ("/api/campaign/blocks/t99", "/api/campaign/blocks/t00/files/.hidden",
                    "/api/campaign/blocks/t00/files/nothing.txt",
                    "/api/campaign/blocks/..%20/files/block.json"):
            r = c.get(url)
            assert r.status_code == 404 and "\n" not in r.json()["error"], url
        assert c.post("/api/campaign").status_code == 405  # read-only
    with client(None) as c:
        assert c.get("/api/campaign").status_code == 404 and c.get("/api/state").json()["campaign"] is None


def test_serve_refuses_a_folder_that_is_no_campaign(tmp_path):
    res = CliRunner().invoke(main, ["serve", "--campaign", str(tmp_path), "--port", "0"])
    assert res.exit_code == 2 and "holds no register.gpkg" in res.output and len(res.output.strip().splitlines()) == 1


@pytest.mark.browser
@pytest.mark.parametrize("size", [(375, 812), (1024, 768), (1366, 768)])
def test_the_campaign_map_in_the_browser(campaign, size):
    """The blocks on the map coloured by status, the legend's counts; a block clicked on the map opens its plan (its
    route drawn, its files downloaded as they are); another chosen by keyboard; the failed one says why."""
    if CHROMIUM is None:
        if os.environ.get("AEROSURVEY_REQUIRE_BROWSER"):
            pytest.fail("AEROSURVEY_REQUIRE_BROWSER is set but no chromium binary was found")
        pytest.skip("no Chromium found (set AEROSURVEY_CHROMIUM or install Debian's chromium package)")
    from playwright.sync_api import sync_playwright
    from webutil import Server

    out, _ = campaign
    w, h = size
    folders = _folders(out)
    server = Server(None, campaign=out)
    errors: list[str] = []
    console: list[str] = []
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
            ctx = browser.new_context(viewport={"width": w, "height": h}, accept_downloads=True)
            pg = ctx.new_page()
            pg.on("pageerror", lambda e: errors.append(str(e)))
            pg.on("console", lambda m: console.append(m.text) if m.type == "error" else None)
            pg.goto(server.url)
            pg.wait_for_function("window.aerosurvey.campaign !== undefined && window.aerosurvey.layers.campaign", timeout=60000)
            assert pg.get_attribute("#tabs button[data-tab='campaign']", "aria-selected") == "true"
            drawn = pg.evaluate("""window.aerosurvey.layers.campaign.getSource().getFeatures().map(f => [f.get('name'),
                f.get('status'), window.aerosurvey.layers.campaign.getStyleFunction()(f, 1).getStroke().getColor()])""")
            assert {n: s for n, s, _ in drawn} == STATUS
            colours = {s: c for _, s, c in drawn}
            assert len(set(colours.values())) == len(colours)  # one colour a status
            legend = {li.get_attribute("data-status"): li.text_content() for li in pg.locator("#campaign-legend li").all()}
            assert legend == {"failed": "failed 1", "planned": "planned 2", "uploaded": "uploaded 1", "accepted": "accepted 1"}
            # t00 clicked on the map: its plan opens
            x, y = pg.evaluate("""() => { const m = window.aerosurvey.map, f = window.aerosurvey.layers.campaign.getSource()
                .getFeatures().find(f => f.get('name') === 't00'); const r = m.getTargetElement().getBoundingClientRect();
                const e = f.getGeometry().getExtent(), p = m.getPixelFromCoordinate([(e[0] + e[2]) / 2, (e[1] + e[3]) / 2]);
                return [p[0] + r.left, p[1] + r.top]; }""")
            pg.mouse.click(x, y)
            pg.wait_for_function("window.aerosurvey.layers.blockRoute.getSource().getFeatures().length === 1", timeout=30000)
            route = pg.evaluate("""window.aerosurvey.layers.blockRoute.getSource().getFeatures()[0].getGeometry().clone()
                .transform('EPSG:3857', 'EPSG:4326').getCoordinates()""")
            want = _route(folders["t00"] / "mission.waypoints")
            assert len(route) == len(want) and max(abs(a - b) for p, q in zip(route, want) for a, b in zip(p, q)) < 1e-9
            assert sorted(pg.eval_on_selector_all("#block-plan a[data-file]", "els => els.map(e => e.dataset.file)")) == \
                sorted(p.name for p in folders["t00"].iterdir())
            with pg.expect_download() as d:
                pg.click("#block-plan a[data-file='mission.plan']")
            assert Path(d.value.path()).read_bytes() == (folders["t00"] / "mission.plan").read_bytes()
            # by keyboard: the block list, then the failed block, which has no plan and says why
            pg.focus("#campaign-block")
            pg.keyboard.press("End")  # the last block, t04
            pg.wait_for_function("window.aerosurvey.block && window.aerosurvey.block.name === 't04' && "
                                 "window.aerosurvey.block.files !== undefined", timeout=30000)
            pg.select_option("#campaign-block", "t01")
            pg.wait_for_function("document.querySelector(\".err[data-for='campaign']\").textContent.includes('no plan folder')",
                                 timeout=30000)
            assert "above the cap" in pg.text_content("#block-plan")
            assert pg.evaluate("window.aerosurvey.layers.blockRoute.getSource().getFeatures().length") == 0
            assert pg.evaluate("document.scrollingElement.scrollWidth") <= w
            bar = pg.locator("#topbar").bounding_box()
            assert bar is not None and bar["y"] >= 0 and bar["y"] + bar["height"] <= h
            pg.screenshot(path=str(Path(__file__).resolve().parents[2] / "out" / "test-screenshots" / f"campaign-{w}x{h}.png"))
            ctx.close()
            browser.close()
    finally:
        server.stop()
    assert errors == [], errors
    # the one console error is Chromium's own line for the failed block's 404
    assert console == ["Failed to load resource: the server responded with a status of 404 (Not Found)"], console
