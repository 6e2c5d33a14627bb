"""The page in a real headless Chromium (Debian's package, driven by Playwright).

Skipped with the reason when no Chromium is found, unless AEROSURVEY_REQUIRE_BROWSER is
set (`.ci/run` sets it after installing Chromium, so CI cannot skip them silently).
Screenshots of the main states go to out/test-screenshots/.
"""

from __future__ import annotations

import contextlib
import http.server
import json
import math
import os
import re
import shutil
import threading
import time
import tomllib
import zipfile
from pathlib import Path

import pyproj
import pytest
import shapely
from click.testing import CliRunner
from webutil import REPO, Server, copy_mission, free_port, tile_png, tiles_around, write_mbtiles, write_pmtiles, write_vector_tiles

from aerosurvey.cli import main
from conftest import planned, random_polygon, write_geojson

pytestmark = pytest.mark.browser

SHOTS = REPO / "out" / "test-screenshots"
#: What the page writes in WGS84 is rounded to 1e-8 degrees: the map's own coordinates (Web Mercator) are within
#: half of that of what the spec and the saved files hold.
DEGREE_STEP = 1e-8
CHROMIUM = os.environ.get("AEROSURVEY_CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")
ARGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
        "--disable-component-update", "--disable-sync"]


def _need_browser() -> None:
    if CHROMIUM is None:
        if os.environ.get("AEROSURVEY_REQUIRE_BROWSER"):
            pytest.fail("AEROSURVEY_REQUIRE_BROWSER is set but no chromium binary was found (install Debian's chromium)")
        pytest.skip("no Chromium found (set AEROSURVEY_CHROMIUM or install Debian's chromium package)")


class _Tiles(http.server.BaseHTTPRequestHandler):
    """A stand-in tile server: one grey PNG for any z/x/y, and a log of what was asked."""

    asked: list[str] = []
    png: bytes = b""

    def do_GET(self) -> None:  # noqa: N802 (http.server's name)
        _Tiles.asked.append(self.path)
        self.send_response(200)
        self.send_header("Content-Type", "image/png")
        self.send_header("Access-Control-Allow-Origin", "*")  # as public tile servers send it (the page asks with CORS)
        self.send_header("Content-Length", str(len(self.png)))
        self.end_headers()
        self.wfile.write(self.png)

    def log_message(self, *args) -> None:
        return None


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    _need_browser()
    from playwright.sync_api import sync_playwright

    tmp = tmp_path_factory.mktemp("page")
    spec = copy_mission(tmp)
    cli = tmp / "cli"
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(cli)])
    assert res.exit_code == 0, res.output
    server = Server(spec)
    SHOTS.mkdir(parents=True, exist_ok=True)
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        try:
            yield {"browser": browser, "server": server, "spec": spec, "cli": cli, "tmp": tmp}
        finally:
            browser.close()
            server.stop()


@pytest.fixture
def page(site):
    ctx = site["browser"].new_context(viewport={"width": 1400, "height": 900}, accept_downloads=True)
    pg = ctx.new_page()
    pg.requests = []  # every URL the page asked for
    pg.errors = []
    pg.on("request", lambda r: pg.requests.append(r.url))
    pg.on("pageerror", lambda e: pg.errors.append(str(e)))
    pg.console = _console_errors(pg)
    pg.goto(site["server"].url)
    pg.wait_for_function("window.aerosurvey.view !== null", timeout=60000)
    yield pg
    assert pg.errors == [], pg.errors
    _only_refusals(pg.console)
    ctx.close()


#: Chromium's own console line for a request answered with an HTTP error (a refused upload, a tile the file has not):
#: the page reports those itself; any other console error is a defect
REFUSED = re.compile(r"Failed to load resource: the server responded with a status of (4\d\d) \(")


def _console_errors(pg) -> list[str]:
    """The console's error lines from now on."""
    lines: list[str] = []
    pg.on("console", lambda m: lines.append(m.text) if m.type == "error" else None)
    return lines


def _only_refusals(lines: list[str]) -> None:
    assert all(REFUSED.match(t) for t in lines), [t for t in lines if not REFUSED.match(t)]


def _count(pg, selector: str) -> int:
    return pg.eval_on_selector_all(selector, "els => els.length")


def _features(pg, layer: str) -> int:
    """Features on one of the map's vector layers (the page's OpenLayers layers, window.aerosurvey.layers)."""
    return pg.evaluate("n => window.aerosurvey.layers[n].getSource().getFeatures().length", layer)


def _replan_and_wait(pg, action) -> None:
    """Do something that re-plans, then wait until the page has drawn a new plan."""
    before = pg.evaluate("window.aerosurvey.stats.plans")
    action()
    pg.wait_for_function(f"window.aerosurvey.stats.plans > {before}", timeout=60000)


def _tab(pg, name: str) -> None:
    pg.click(f"#tabs button[data-tab='{name}']")


def _only_our_server(pg, site_url: str) -> None:
    assert all(u.startswith(site_url) or u.startswith("data:") or u.startswith("blob:") for u in pg.requests), \
        [u for u in pg.requests if not u.startswith(site_url)]


def test_page_draws_the_plan_of_the_manifest(page, site):
    manifest = json.loads((site["cli"] / "manifest.json").read_text())
    features = json.loads((site["cli"] / "plan.geojson").read_text())["features"]
    lines = [f for f in features if f["properties"]["role"] == "line"]
    assert _features(page, "lines") == len(lines) == 34
    assert _features(page, "stations") == len(manifest["stations"]) == 1593
    assert _features(page, "gcps") >= 4 and _features(page, "checks") >= 24
    assert _count(page, "#sortie-legend span") == len(manifest["sorties"]) == 5
    assert page.text_content("[data-summary='photos']").startswith("1593")
    # the cursor readout: WGS84 and the plan's CRS (proj4 with the server's definition)
    box = page.locator("#map").bounding_box()
    page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
    text = page.text_content("#cursor")
    assert "WGS84" in text and "EPSG:5514" in text and "N" in text
    x, y = (float(v) for v in text.split(" x ")[1].split(" y "))
    assert -800_000 < x < -600_000 and -1_200_000 < y < -1_000_000  # Krovak East North over Bohemia
    # proj4js in the page converts the stations as PROJ does with the server's string (and so as the planner, test_api)
    stations = [(s["lon"], s["lat"]) for s in manifest["stations"][::50]]
    got = page.evaluate("pts => pts.map(p => olb.proj4(window.aerosurvey.view.frame.crs, p))", stations)
    t = pyproj.Transformer.from_crs("EPSG:4326", pyproj.CRS.from_proj4(page.evaluate("window.aerosurvey.view.frame.proj4")),
                                    always_xy=True)
    want = [t.transform(lon, lat) for lon, lat in stations]
    assert max(math.hypot(a[0] - b[0], a[1] - b[1]) for a, b in zip(got, want)) < 0.01
    assert page.text_content(".ol-scale-line-inner").endswith("m")
    page.screenshot(path=str(SHOTS / "01-obratan-plan.png"))
    # no tile server, no other host: everything came from our server
    _only_our_server(page, site["server"].url)


def test_side_overlap_changes_the_line_count(page):
    lines_before = _features(page, "lines")
    _tab(page, "setup")
    _replan_and_wait(page, lambda: page.fill("[data-key='targets.side_overlap']", "0.75"))
    lines_after = _features(page, "lines")
    assert lines_after > lines_before
    assert page.text_content("[data-summary='lines']").startswith(f"{lines_after} ")
    page.screenshot(path=str(SHOTS / "02-side-overlap-75.png"))


def test_rule_failure_listed_highlighted_and_cleared_on_replan(page):
    _tab(page, "setup")
    _replan_and_wait(page, lambda: page.fill("[data-key='targets.forward_overlap']", "0.70"))
    assert "fail" in page.text_content("[data-summary='rules']")  # in the summary bar, whatever the tab
    _tab(page, "rules")
    fail = page.locator("#rule-list li.fail[data-rule='cz-forward-overlap']")
    assert fail.count() == 1
    assert "70." in fail.text_content()
    assert _features(page, "highlight") == 0
    fail.click()
    assert _features(page, "highlight") > 0
    assert "selected" in fail.get_attribute("class")
    page.screenshot(path=str(SHOTS / "03-rule-failure-highlighted.png"))
    _tab(page, "setup")
    _replan_and_wait(page, lambda: page.fill("[data-key='targets.forward_overlap']", "0.71"))
    assert _features(page, "highlight") == 0


def _refused(pg, key: str, value: str):
    """Type a value the planner refuses into the field of spec key `key` (on *Setup*); its error box, once shown."""
    _tab(pg, "setup")
    pg.fill(f"[data-key='{key}']", value)
    box = pg.locator(f".err[data-for~='{key}']")
    box.wait_for(state="visible", timeout=30000)
    return box


def test_bad_value_shown_next_to_its_field_and_kept(page):
    lines = _features(page, "lines")
    field = "[data-key='targets.side_overlap']"
    box = _refused(page, "targets.side_overlap", "1.2")
    assert "targets.side_overlap = 1.2 is not allowed" in box.text_content()
    assert page.input_value(field) == "1.2"  # what the user typed stays
    assert _features(page, "lines") == lines  # the previous plan stays on the map
    page.screenshot(path=str(SHOTS / "04-bad-value.png"))
    _replan_and_wait(page, lambda: page.fill(field, "0.6"))
    assert box.text_content() == ""


def test_fly_blocks_in_flight_order_and_downloads_equal_the_cli(page, site):
    manifest = json.loads((site["cli"] / "manifest.json").read_text())
    blocks = page.locator("#fly-blocks .fly")
    assert blocks.count() == 5
    for k, s in enumerate(manifest["sorties"]):
        block = blocks.nth(k)
        assert block.get_attribute("data-sortie") == s["id"]
        text = block.text_content()
        assert f"{s['usable_used_pct']:.1f} % of the usable charge" in text  # the battery figure in text, not a tooltip
        assert f"launch point {s['launch']['index']}" in text
    with page.expect_download() as d:
        page.locator("#file-groups a[data-file='mission.waypoints']").click()
    assert Path(d.value.path()).read_bytes() == (site["cli"] / "mission.waypoints").read_bytes()
    with page.expect_download() as d:
        blocks.nth(2).locator("a[data-file='sortie-03.waypoints']").click()
    assert Path(d.value.path()).read_bytes() == (site["cli"] / "sortie-03.waypoints").read_bytes()
    with page.expect_download() as d:  # the spec as the file holds it: the manifest names it as the CLI's does
        page.locator("#file-groups a[data-file='manifest.json']").click()
    assert Path(d.value.path()).read_bytes() == (site["cli"] / "manifest.json").read_bytes()


def test_fly_blocks_offer_dji_waylines(site):
    """With a DJI camera each sortie's block offers its .kmz waylines beside its .plan and .waypoints: `aerosurvey plan`'s bytes."""
    tmp = site["tmp"] / "dji"
    tmp.mkdir()
    spec = copy_mission(tmp)
    spec.write_text(spec.read_text().replace('model = "sony-a6000-16mm"', 'model = "dji-mavic-3-enterprise"'))
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(tmp / "cli")])
    assert planned(res.exit_code, res.output), res.output
    with _own_server_page(site, spec) as (pg, server):
        _tab(pg, "fly")
        first = pg.locator("#fly-blocks .fly").first
        assert [a.get_attribute("data-file") for a in first.locator("a").all()] == \
            ["sortie-01.kmz", "sortie-01.plan", "sortie-01.waypoints"]
        with pg.expect_download() as d:
            first.locator("a[data-file='sortie-01.kmz']").click()
        assert Path(d.value.path()).read_bytes() == (tmp / "cli" / "sortie-01.kmz").read_bytes()
        assert pg.locator("#file-groups a[data-file='mission.kmz']").count() == 1
        _only_our_server(pg, server.url)


def test_layers_toggle(page):
    page.click("#layer-box summary")
    page.uncheck("#layer-toggles input[data-layer='stations']")
    assert page.evaluate("window.aerosurvey.layers.stations.getVisible()") is False
    page.check("#layer-toggles input[data-layer='stations']")
    assert page.evaluate("window.aerosurvey.layers.stations.getVisible()") is True


def test_dropped_area_starts_a_new_plan(page, site):
    gj = write_geojson(site["tmp"] / "new-field.geojson", random_polygon("concave", 4, 350))
    _tab(page, "setup")
    _replan_and_wait(page, lambda: page.set_input_files("#area-file", str(gj)))
    assert page.input_value("[data-key='mission.name']") == "new-field"
    assert "EPSG:326" in page.text_content("[data-summary='area']")
    assert _features(page, "stations") == int(page.text_content("[data-summary='photos']"))
    assert _features(page, "area") == 1  # the uploaded outline, editable
    page.screenshot(path=str(SHOTS / "05-new-area.png"))


def test_basemap_only_when_configured(page, site):
    _Tiles.png, _Tiles.asked = tile_png((200, 200, 200)), []
    port = free_port()
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", port), _Tiles)
    t = threading.Thread(target=httpd.serve_forever, daemon=True)
    t.start()
    try:
        assert page.evaluate("window.aerosurvey.layers.basemap.getSource()") is None
        _tab(page, "setup")
        page.fill("#tile-url", f"http://127.0.0.1:{port}/{{z}}/{{x}}/{{y}}.png")
        page.dispatch_event("#tile-url", "change")
        end = time.monotonic() + 10
        while not _Tiles.asked and time.monotonic() < end:
            page.wait_for_timeout(50)
        assert _Tiles.asked and all(p.endswith(".png") and p.count("/") == 3 for p in _Tiles.asked)
        page.screenshot(path=str(SHOTS / "06-basemap.png"))
        # the same view through a WMTS REST template (Web Mercator): the same tiles, asked by row and column
        _rendered(page)  # every XYZ tile of the view asked and drawn
        xyz = {tuple(int(v) for v in p[1:-4].split("/")) for p in _Tiles.asked}
        _Tiles.asked = []
        page.fill("#tile-url", f"http://127.0.0.1:{port}/wmts/{{TileMatrix}}/{{TileRow}}/{{TileCol}}.png")
        page.dispatch_event("#tile-url", "change")
        _rendered(page)
        wmts = {tuple(int(v) for v in p[len("/wmts/"):-4].split("/")) for p in _Tiles.asked if p.startswith("/wmts/")}
        assert {(z, col, row) for z, row, col in wmts} == xyz
    finally:
        page.evaluate("localStorage.removeItem('aerosurvey.tileUrl')")
        httpd.shutdown()


def test_flight_results_on_the_map(site):
    """A plan, its SITL flight log ingested, the result folder loaded into the page."""
    from conftest import make_spec

    tmp = site["tmp"] / "flight"
    tmp.mkdir()
    spec = make_spec(tmp, {"flight": {"heading": 0.0}})
    plan = tmp / "plan"
    assert CliRunner().invoke(main, ["plan", str(spec), "-o", str(plan)]).exit_code == 0
    log = REPO / "tests" / "data" / "sitl_copter_survey.bin"
    assert CliRunner().invoke(main, ["log", "ingest", str(log), "--plan", str(plan), "-o", str(tmp / "log")]).exit_code == 0
    CliRunner().invoke(main, ["check", str(tmp / "log"), "--profile", "cz-land-consolidation"])  # failing_places.geojson
    places = json.loads((tmp / "log" / "failing_places.geojson").read_text())["features"]
    with _opened(site, spec) as pg:
        _tab(pg, "flight")
        pg.set_input_files("#flight-files", str(tmp / "log"))  # the folder, as a user picks it
        pg.wait_for_function("window.aerosurvey.layers.flown.getSource().getFeatures().length > 0", timeout=30000)
        assert _features(pg, "flown") == 152
        assert pg.evaluate("window.aerosurvey.layers.coverage.getSource() !== null")
        assert "152 of 152 stations matched" in pg.text_content("#flight-summary")
        assert _features(pg, "failing") == len([f for f in places if f["geometry"]])
        assert pg.locator("#flown-rules li").count() >= 1
        pg.locator("#flown-rules li.fail").first.click()  # its places drawn in red
        assert 0 < _features(pg, "highlight") <= _features(pg, "failing")
        pg.click("#make-refly")  # one button: `aerosurvey refly` on the loaded folder
        pg.wait_for_function("document.querySelector('#refly-files p') !== null", timeout=60000)
        text = pg.text_content("#refly-files")
        assert "gap(s)" in text or "nothing to re-fly" in text
        pg.click("#make-resume")  # one button: `aerosurvey resume --log`; this flight took every photo
        pg.locator(".err[data-for='refly resume']").wait_for(state="visible", timeout=60000)
        assert "nothing" in pg.text_content(".err[data-for='refly resume']")
        pg.screenshot(path=str(SHOTS / "07-flown.png"))


@contextlib.contextmanager
def _opened(site, spec: Path):
    """A page (1400 × 900) on a server of `spec` of its own, its first plan shown."""
    server = Server(spec)
    ctx = site["browser"].new_context(viewport={"width": 1400, "height": 900})
    try:
        pg = ctx.new_page()
        pg.goto(server.url)
        pg.wait_for_function("window.aerosurvey.view !== null", timeout=60000)
        yield pg
    finally:
        ctx.close()
        server.stop()


def _page_px(pg, lon: float, lat: float) -> tuple[float, float]:
    """Where a place is on the page (CSS pixels), through the map's own view."""
    return tuple(pg.evaluate("""([lon, lat]) => {
        const p = window.aerosurvey.map.getPixelFromCoordinate(olb.fromLonLat([lon, lat]));
        const r = document.querySelector('#map').getBoundingClientRect();
        return [p[0] + r.left, p[1] + r.top]; }""", [lon, lat]))


def _drawn(pg, role: str) -> list[list[list[float]]]:
    """The drawn features of a role as lon/lat coordinates (rings of polygons, or [lon, lat] of points)."""
    return pg.evaluate("""role => window.aerosurvey.layers.area.getSource().getFeatures()
        .filter(f => f.get('role') === role)
        .map(f => f.getGeometry().clone().transform('EPSG:3857', 'EPSG:4326').getCoordinates())""", role)


def _click_polygon(pg, pts) -> None:
    """Click the corners, then the first one again to close the ring (as a user draws)."""
    for x, y in pts:
        pg.mouse.click(x, y)
        pg.wait_for_timeout(300)  # not a double click
    pg.mouse.click(*pts[0])


def _zone_square(pg, half_px: float) -> list[tuple[float, float]]:
    box = pg.locator("#map").bounding_box()
    cx, cy = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    return [(cx - half_px, cy - half_px), (cx + half_px, cy - half_px), (cx + half_px, cy + half_px), (cx - half_px, cy + half_px)]


@contextlib.contextmanager
def _own_server_page(site, spec: Path | None, ready: str = "window.aerosurvey.view !== null", basemap: Path | None = None):
    """A server of the test's own and a 1366×768 page on it, once `ready` holds; `pg.requests` lists
    every URL asked, `pg.served` the (URL, status) of the basemap's tiles."""
    server = Server(spec, basemap=basemap)
    ctx = site["browser"].new_context(viewport={"width": 1366, "height": 768}, accept_downloads=True)
    try:
        pg = ctx.new_page()
        pg.requests, pg.served = [], []
        pg.on("request", lambda r: pg.requests.append(r.url))
        pg.on("response", lambda r: pg.served.append((r.url, r.status)) if "/api/basemap/" in r.url else None)
        pg.console = _console_errors(pg)
        pg.goto(server.url)
        pg.wait_for_function(ready, timeout=60000)
        yield pg, server
        _only_refusals(pg.console)
    finally:
        ctx.close()
        server.stop()


def _rendered(pg) -> None:
    """Wait until the map has drawn everything it has (tiles included)."""
    pg.wait_for_function("new Promise(ok => { const m = window.aerosurvey.map; m.once('rendercomplete', () => ok(true)); "
                         "m.render(); })", timeout=30000)


def test_draw_an_area_by_clicks_and_see_its_plan(site):
    with _own_server_page(site, None, "document.querySelector('#status').textContent.startsWith('draw')") as (pg, server):
        res = pg.evaluate("""() => { const v = window.aerosurvey.map.getView();
            v.setCenter(olb.fromLonLat([14.95, 49.43])); v.setZoom(16); return v.getResolution(); }""")
        pg.click("#tools [data-tool='area']")
        box = pg.locator("#map").bounding_box()
        cx, cy = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
        pts = [(cx - 150, cy - 100), (cx + 150, cy - 120), (cx + 170, cy + 110), (cx - 140, cy + 100)]
        _replan_and_wait(pg, lambda: _click_polygon(pg, pts))
        assert _features(pg, "lines") > 0 and _features(pg, "stations") > 0
        assert pg.evaluate("window.aerosurvey.spec.area.wkt").startswith("POLYGON")
        # the planned area is the clicked one: shoelace in pixels × (Web Mercator metres per pixel × cos latitude)²
        px = sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in zip(pts, pts[1:] + pts[:1])) / 2
        ground = abs(px) * (res * math.cos(math.radians(49.43))) ** 2
        planned_ha = float(pg.text_content("[data-summary='area']").split(" ha")[0])
        assert planned_ha == pytest.approx(ground / 1e4, rel=0.02)
        pg.screenshot(path=str(SHOTS / "09-drawn-area.png"))
        pg.click("#undo")  # the first drawing undone: nothing to plan
        assert _features(pg, "area") == 0 and "draw an area" in pg.text_content("#status")
        assert _features(pg, "lines") == _features(pg, "stations") == 0  # no plan of an area that is gone
        _only_our_server(pg, server.url)


def test_drag_a_vertex_changes_the_line_count(page):
    lines0 = _features(page, "lines")
    area0 = float(page.text_content("[data-summary='area']").split(" ha")[0])
    ring = _drawn(page, "area")[0][0]
    lon, lat = min(ring, key=lambda c: c[0])  # the westmost corner, pulled further west
    x, y = _page_px(page, lon, lat)
    page.mouse.move(x, y)
    page.wait_for_timeout(200)

    def drag():
        page.mouse.down()
        page.mouse.move(x - 160, y + 20, steps=10)
        page.mouse.up()

    _replan_and_wait(page, drag)
    assert float(page.text_content("[data-summary='area']").split(" ha")[0]) > area0 * 1.05
    assert _features(page, "lines") != lines0
    assert min(c[0] for c in _drawn(page, "area")[0][0]) < lon
    page.screenshot(path=str(SHOTS / "10-dragged-vertex.png"))


def test_drawn_zone_is_avoided_and_undone(page, site):
    from independent_legs import Local, legs_inside_zones

    runs0 = page.evaluate("window.aerosurvey.view.summary.runs")
    page.click("#tools [data-tool='zone']")
    _replan_and_wait(page, lambda: _click_polygon(page, _zone_square(page, 60)))
    assert page.evaluate("window.aerosurvey.view.layers.exclusions.length") == 1
    assert page.evaluate("window.aerosurvey.view.summary.runs") > runs0  # lines cut at the zone
    zone = shapely.Polygon(_drawn(page, "zone")[0][0])
    # the exported route, rebuilt by the independent checker, flies no metre inside the zone
    pid = page.evaluate("window.aerosurvey.view.plan_id")
    wpl = site["tmp"] / "drawn-zone.waypoints"
    wpl.write_text(page.evaluate(f"fetch('/api/plans/{pid}/files/mission.waypoints').then(r => r.text())"))
    c = zone.centroid
    report = legs_inside_zones(wpl, [zone], Local(c.x, c.y), "copter")
    assert report.legs and report.violations == []
    page.screenshot(path=str(SHOTS / "11-drawn-zone.png"))
    _replan_and_wait(page, lambda: page.click("#undo"))
    assert page.evaluate("window.aerosurvey.view.layers.exclusions.length") == 0
    assert page.evaluate("window.aerosurvey.view.summary.runs") == runs0
    _replan_and_wait(page, lambda: page.click("#redo"))
    assert page.evaluate("window.aerosurvey.view.layers.exclusions.length") == 1


def test_hole_launch_point_delete_and_measure(page):
    photos0 = page.evaluate("window.aerosurvey.view.summary.photos")
    page.click("#tools [data-tool='hole']")
    _replan_and_wait(page, lambda: _click_polygon(page, _zone_square(page, 50)))
    assert len(_drawn(page, "area")[0]) == 2  # the outline and its hole
    assert page.evaluate("window.aerosurvey.spec.area.wkt").count("(") == 3  # POLYGON ((outline), (hole))
    assert page.evaluate("window.aerosurvey.view.layers.area[0].length") == 2
    # a launch point: the sorties now start from it (the spec has a battery: battery.launch_points)
    box = page.locator("#map").bounding_box()
    page.click("#tools [data-tool='launch']")
    _replan_and_wait(page, lambda: page.mouse.click(box["x"] + 60, box["y"] + box["height"] - 80))
    (lon, lat), = _drawn(page, "launch")
    (point,) = page.evaluate("window.aerosurvey.spec.battery.launch_points")
    assert point == pytest.approx([lon, lat], abs=DEGREE_STEP) and all(round(v, 8) == v for v in point)
    first = page.locator("#fly-blocks .fly").first.text_content()
    assert f"{lat:.6f}° N {lon:.6f}° E" in first
    # delete: a click in the hole takes the hole out
    page.click("#tools [data-tool='delete']")
    cx, cy = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    _replan_and_wait(page, lambda: page.mouse.click(cx, cy))
    assert len(_drawn(page, "area")[0]) == 1
    assert page.evaluate("window.aerosurvey.view.summary.photos") >= photos0
    # measure a distance: two clicks and a double click to end
    page.click("#tools [data-tool='measure']")
    res = page.evaluate("window.aerosurvey.map.getView().getResolution()")
    page.mouse.click(cx - 100, cy)
    page.wait_for_timeout(300)
    page.mouse.dblclick(cx + 100, cy)
    text = page.text_content("#measure-out")
    metres = float(text.split()[0]) * (1000 if text.split()[1] == "km" else 1)
    lat0 = _drawn(page, "area")[0][0][0][1]
    assert metres == pytest.approx(200 * res * math.cos(math.radians(lat0)), rel=0.01)
    page.screenshot(path=str(SHOTS / "13-hole-launch-measure.png"))


def test_move_a_zone_and_read_labels(page):
    page.click("#tools [data-tool='zone']")
    square = _zone_square(page, 40)
    _replan_and_wait(page, lambda: _click_polygon(page, square))
    before = shapely.Polygon(_drawn(page, "zone")[0][0]).centroid
    page.click("#tools [data-tool='move']")
    cx, cy = square[0][0] + 40, square[0][1] + 40
    page.mouse.move(cx, cy)
    page.wait_for_timeout(200)

    def drag():
        page.mouse.down()
        page.mouse.move(cx + 120, cy, steps=8)
        page.mouse.up()

    _replan_and_wait(page, drag)
    after = shapely.Polygon(_drawn(page, "zone")[0][0]).centroid
    assert after.x > before.x and abs(after.y - before.y) < 1e-6
    zone = shapely.from_wkt(page.evaluate("window.aerosurvey.zones[0]"))
    assert zone.centroid.distance(after) < DEGREE_STEP  # what is planned is what was moved
    # zoomed in, the control points carry their ids
    page.evaluate("window.aerosurvey.map.getView().setResolution(0.5)")
    page.wait_for_timeout(300)
    page.screenshot(path=str(SHOTS / "14-moved-zone-labels.png"))


def test_spec_with_a_bad_value_gets_its_area_on_the_map_once_fixed(site):
    tmp = site["tmp"] / "bad-start"
    tmp.mkdir()
    spec = copy_mission(tmp)
    spec.write_text(spec.read_text().replace("side_overlap = 0.60", "side_overlap = 1.2"))
    with _own_server_page(site, spec, "document.querySelector('#general-error').textContent !== ''") as (pg, _):
        assert "targets.side_overlap = 1.2" in pg.text_content("#general-error")  # seen from the Fly tab too
        assert _features(pg, "area") == 0  # the spec could not be read: nothing to draw yet
        _tab(pg, "setup")
        _replan_and_wait(pg, lambda: pg.fill("[data-key='targets.side_overlap']", "0.6"))
        assert _features(pg, "area") == 1 and _features(pg, "lines") == 34


def test_save_the_drawn_zone_with_the_spec_and_reload(site):
    tmp = site["tmp"] / "save"
    tmp.mkdir()
    spec = copy_mission(tmp)
    with _own_server_page(site, spec) as (pg, _):
        pg.click("#tools [data-tool='zone']")
        _replan_and_wait(pg, lambda: _click_polygon(pg, _zone_square(pg, 50)))
        drawn = _drawn(pg, "zone")[0][0]
        page_wpl = pg.evaluate(f"fetch('/api/plans/{pg.evaluate('window.aerosurvey.view.plan_id')}/files/mission.waypoints')"
                               ".then(r => r.text())")
        _tab(pg, "setup")
        pg.click("#save-spec")
        pg.wait_for_function("document.querySelector('#save-status').textContent.startsWith('saved')", timeout=30000)
        saved = tomllib.loads(spec.read_text())
        assert saved["area"]["exclusions"] == ["obratan-72ha.zones.geojson"]
        assert saved["area"]["file"] == "areas/obratan-72ha.geojson"  # the area was not edited: its file stays
        zones = json.loads((tmp / "obratan-72ha.zones.geojson").read_text())["features"]
        assert len(zones) == 1
        assert shapely.Polygon(zones[0]["geometry"]["coordinates"][0]).hausdorff_distance(shapely.Polygon(drawn)) < DEGREE_STEP
        # the saved spec plans, with `aerosurvey plan`, the mission the page planned
        res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(tmp / "cli")])
        assert planned(res.exit_code, res.output), res.output
        assert (tmp / "cli" / "mission.waypoints").read_text() == page_wpl
        with pg.expect_download() as d:
            pg.click("#download-drawn")
        feats = json.loads(Path(d.value.path()).read_text())["features"]
        assert sorted(f["properties"]["role"] for f in feats) == ["area", "zone"]
        pg.reload()
        pg.wait_for_function("window.aerosurvey.view !== null", timeout=60000)
        assert len(_drawn(pg, "zone")) == 1 and pg.evaluate("window.aerosurvey.view.layers.exclusions.length") == 1
        # the area edited after the reload: the zone file stays in the spec
        ring = _drawn(pg, "area")[0][0]
        x, y = _page_px(pg, *min(ring, key=lambda c: c[0]))
        pg.mouse.move(x, y)
        pg.wait_for_timeout(200)

        def drag():
            pg.mouse.down()
            pg.mouse.move(x - 60, y, steps=6)
            pg.mouse.up()

        _replan_and_wait(pg, drag)
        assert pg.evaluate("window.aerosurvey.spec.area.exclusions") == ["obratan-72ha.zones.geojson"]
        assert pg.evaluate("window.aerosurvey.view.layers.exclusions.length") == 1


def _lonlat(pg, x: float, y: float) -> list[float]:
    """The place under a page pixel, through the map's own view."""
    return pg.evaluate("""([x, y]) => { const r = document.querySelector('#map').getBoundingClientRect();
        return olb.toLonLat(window.aerosurvey.map.getCoordinateFromPixel([x - r.left, y - r.top])); }""", [x, y])


def _corridor_lines(pg, centreline: list[list[float]]) -> int:
    """The page's plan's lines (its plan.geojson) run along the centreline: each bends where it bends, and beside the
    centreline, from one end of it to the other, it keeps its distance from it (within the stretch of a mitred corner)."""
    pid = pg.evaluate("window.aerosurvey.view.plan_id")
    fc = json.loads(pg.evaluate(f"fetch('/api/plans/{pid}/files/plan.geojson').then(r => r.text())"))
    utm = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:32633", always_xy=True)  # metres, independent of the plan's CRS

    def metres(g):
        return shapely.transform(g, lambda xy: list(zip(*utm.transform(xy[:, 0], xy[:, 1]), strict=True)))

    c = metres(shapely.LineString(centreline))
    lines = [metres(shapely.geometry.shape(f["geometry"])) for f in fc["features"] if f["properties"]["role"] == "line"]
    assert lines
    for ln in lines:
        assert len(ln.coords) >= len(c.coords), ln  # it bends with the centreline
        pts = [ln.interpolate(k / 200, normalized=True) for k in range(201)]
        along = [(c.project(p), c.distance(p)) for p in pts]
        beside = [d for t, d in along if 1.0 < t < c.length - 1.0]  # not past the centreline's ends
        assert min(t for t, _ in along) < 0.02 * c.length and max(t for t, _ in along) > 0.98 * c.length
        assert max(beside) - min(beside) <= 0.06 * max(beside) + 1.0, (min(beside), max(beside))
    assert _features(pg, "lines") == len(lines)
    band = [shapely.geometry.shape(f["geometry"]) for f in fc["features"] if f["properties"]["role"] == "area"]
    assert _features(pg, "corridor") == len(band) == 1  # the planned band drawn around the centreline
    return len(lines)


def test_draw_a_corridor_centreline_plan_edit_and_save(site):
    """A centreline drawn by clicks (snapped to a vertex it starts near) makes the plan a corridor along it: its lines
    bend with it and lie in it; its width is set, a vertex dragged, undone and redone, each re-planned; saved, the spec
    has [pattern] kind = "corridor" and the centreline as GeoJSON beside it, which `aerosurvey plan` plans into the
    page's mission, which reloads onto the map and can be deleted."""
    tmp = site["tmp"] / "corridor"
    tmp.mkdir()
    spec = copy_mission(tmp)
    with _own_server_page(site, spec) as (pg, server):
        corner = min(_drawn(pg, "area")[0][0], key=lambda c: c[0])  # the area's westmost vertex
        x0, y0 = _page_px(pg, *corner)
        pts = [(x0 + 5, y0 - 4), (x0 + 170, y0 - 40), (x0 + 340, y0 - 30)]  # a bend gentle enough to be flown through
        clicked = [_lonlat(pg, x, y) for x, y in pts]
        pg.click("#tools [data-tool='centreline']")
        for x, y in pts:
            pg.mouse.click(x, y)
            pg.wait_for_timeout(300)  # not a double click
        _replan_and_wait(pg, lambda: pg.mouse.click(*pts[-1]))  # a click on the last point again finishes the line
        (line,) = _drawn(pg, "centreline")
        assert len(line) == 3
        assert line[0] == pytest.approx(corner, abs=1e-12)  # snapped onto the area's vertex
        for (lon, lat), want in zip(line[1:], clicked[1:]):
            assert (lon, lat) == pytest.approx(want, abs=1e-6)
        assert pg.evaluate("window.aerosurvey.spec.pattern") == {"kind": "corridor", "width_m": 50}
        assert shapely.from_wkt(pg.evaluate("window.aerosurvey.spec.area.wkt")).equals_exact(shapely.LineString(line), DEGREE_STEP)
        assert pg.text_content("#general-error") == ""
        _corridor_lines(pg, line)
        _tab(pg, "setup")
        assert pg.input_value("#pattern-kind") == "corridor" and pg.input_value("[data-key='pattern.width_m']") == "50"
        _replan_and_wait(pg, lambda: pg.fill("[data-key='pattern.width_m']", "200"))
        assert pg.evaluate("window.aerosurvey.spec.pattern") == {"kind": "corridor", "width_m": 200}
        assert _corridor_lines(pg, line) >= 2  # a wider corridor: more strips
        # a vertex dragged, re-planned along the moved line; undo and redo
        pg.click("#tools [data-tool='edit']")
        mx, my = _page_px(pg, *line[1])
        pg.mouse.move(mx, my)
        pg.wait_for_timeout(200)

        def drag():
            pg.mouse.down()
            pg.mouse.move(mx, my + 70, steps=8)
            pg.mouse.up()

        _replan_and_wait(pg, drag)
        moved = _drawn(pg, "centreline")[0]
        assert moved[1][1] < line[1][1] and moved[0] == line[0] and moved[2] == line[2]  # dragged south
        _corridor_lines(pg, moved)
        _replan_and_wait(pg, lambda: pg.click("#undo"))
        assert _drawn(pg, "centreline")[0] == line
        assert shapely.from_wkt(pg.evaluate("window.aerosurvey.spec.area.wkt")).equals_exact(shapely.LineString(line), DEGREE_STEP)
        _corridor_lines(pg, line)
        _replan_and_wait(pg, lambda: pg.click("#redo"))
        assert _drawn(pg, "centreline")[0] == moved
        pg.screenshot(path=str(SHOTS / "16-corridor-centreline.png"))
        page_wpl = pg.evaluate(f"fetch('/api/plans/{pg.evaluate('window.aerosurvey.view.plan_id')}/files/mission.waypoints')"
                               ".then(r => r.text())")
        # saved: [pattern] and the centreline's GeoJSON beside the spec, written whole
        pg.click("#save-spec")
        pg.wait_for_function("document.querySelector('#save-status').textContent.startsWith('saved')", timeout=30000)
        saved = tomllib.loads(spec.read_text())
        assert saved["pattern"] == {"kind": "corridor", "width_m": 200}
        assert saved["area"]["file"] == "obratan-72ha.centreline.geojson" and "wkt" not in saved["area"]
        (feat,) = json.loads((tmp / "obratan-72ha.centreline.geojson").read_text())["features"]
        assert feat["properties"]["role"] == "centreline" and feat["geometry"]["type"] == "LineString"
        assert shapely.LineString(feat["geometry"]["coordinates"]).equals_exact(shapely.LineString(moved), DEGREE_STEP)
        assert not list(tmp.glob(".*.tmp"))  # no temporary file left
        # the saved spec plans, with `aerosurvey plan`, the mission the page planned
        res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(tmp / "cli")])
        assert planned(res.exit_code, res.output), res.output
        assert (tmp / "cli" / "mission.waypoints").read_text() == page_wpl
        # reloaded: the centreline on the map from the saved file, the form a corridor of 200 m
        pg.reload()
        pg.wait_for_function("window.aerosurvey.view !== null", timeout=60000)
        assert shapely.LineString(_drawn(pg, "centreline")[0]).equals_exact(shapely.LineString(moved), DEGREE_STEP)
        _corridor_lines(pg, moved)
        _tab(pg, "setup")
        assert pg.input_value("#pattern-kind") == "corridor" and pg.input_value("[data-key='pattern.width_m']") == "200"
        # deleted: nothing left to plan
        pg.click("#tools [data-tool='delete']")
        dx, dy = _page_px(pg, *moved[0])
        ex, ey = _page_px(pg, *moved[1])
        pg.mouse.click((dx + ex) / 2, (dy + ey) / 2)
        pg.wait_for_function("window.aerosurvey.spec.area === undefined", timeout=30000)
        assert _drawn(pg, "centreline") == [] and _features(pg, "lines") == 0
        _only_our_server(pg, server.url)


def test_oblique_and_hover_planned_from_the_form_and_saved(site):
    """Oblique (scheme, pitch, far-edge GSD limit) and hover (settle time) chosen in the form reach the spec and are
    planned: a pitch whose image reaches the horizon is refused with the planner's message, a double grid flies two
    passes, hovering takes longer than flying through; saved, `aerosurvey plan` plans the page's mission; back to an
    area grid, the oblique keys go."""
    tmp = site["tmp"] / "oblique"
    tmp.mkdir()
    spec = copy_mission(tmp)
    with _own_server_page(site, spec) as (pg, server):
        _tab(pg, "setup")
        grid = pg.evaluate("window.aerosurvey.view.summary")
        assert not pg.is_visible("[data-key='pattern.pitch_deg']") and not pg.is_visible("[data-key='camera.settle_s']")
        _replan_and_wait(pg, lambda: pg.select_option("#pattern-kind", "oblique"))
        assert pg.is_visible("[data-key='pattern.pitch_deg']") and not pg.is_visible("[data-key='pattern.width_m']")
        assert pg.evaluate("window.aerosurvey.view.pattern") == "oblique"
        pg.fill("[data-key='pattern.pitch_deg']", "-25")  # the image's far corners above the horizon
        pg.wait_for_function("document.querySelector(\".err[data-for~='pattern.pitch_deg']\").textContent.includes('horizon')",
                             timeout=60000)  # next to its field
        _replan_and_wait(pg, lambda: pg.fill("[data-key='pattern.pitch_deg']", "-40"))
        assert pg.evaluate("[...document.querySelectorAll('.err')].map(e => e.textContent).join('')") == ""
        oblique = pg.evaluate("window.aerosurvey.view.summary")
        assert pg.evaluate("window.aerosurvey.spec.pattern") == {"kind": "oblique", "pitch_deg": -40}
        _replan_and_wait(pg, lambda: pg.select_option("[data-key='camera.trigger']", "hover"))
        assert pg.is_visible("[data-key='camera.settle_s']")
        _replan_and_wait(pg, lambda: pg.fill("[data-key='camera.settle_s']", "2.5"))
        hover = pg.evaluate("window.aerosurvey.view.summary")
        camera = pg.evaluate("window.aerosurvey.spec.camera")
        assert camera["trigger"] == "hover" and camera["settle_s"] == 2.5
        # about as many photos (within 2 %: the base is no longer snapped to whole 50 Hz trigger checks, and the
        # heading search weighs the stops), and hovering takes far longer
        assert hover["photos"] == pytest.approx(oblique["photos"], rel=0.02) and hover["time_min"] > 1.5 * oblique["time_min"]
        assert oblique["lines"] != grid["lines"]
        page_wpl = pg.evaluate(f"fetch('/api/plans/{pg.evaluate('window.aerosurvey.view.plan_id')}/files/mission.waypoints')"
                               ".then(r => r.text())")
        pg.click("#save-spec")
        pg.wait_for_function("document.querySelector('#save-status').textContent.startsWith('saved')", timeout=30000)
        saved = tomllib.loads(spec.read_text())
        assert saved["pattern"] == {"kind": "oblique", "pitch_deg": -40}
        assert saved["camera"]["trigger"] == "hover" and saved["camera"]["settle_s"] == 2.5
        assert saved["area"]["file"] == "areas/obratan-72ha.geojson"  # the area was not edited: its file stays
        res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(tmp / "cli")])
        assert planned(res.exit_code, res.output), res.output
        assert (tmp / "cli" / "mission.waypoints").read_text() == page_wpl
        # five directions and a far-edge GSD limit: the form's keys reach the spec
        pg.select_option("[data-key='pattern.scheme']", "five-direction")
        pg.fill("[data-key='pattern.max_far_gsd_cm']", "9")
        assert pg.evaluate("window.aerosurvey.spec.pattern") == {"kind": "oblique", "pitch_deg": -40, "scheme": "five-direction",
                                                                  "max_far_gsd_cm": 9}
        # an area grid again: the oblique keys go, the spec plans the grid
        pg.select_option("[data-key='camera.trigger']", "distance")
        _replan_and_wait(pg, lambda: pg.select_option("#pattern-kind", "area"))
        assert pg.evaluate("window.aerosurvey.spec.pattern") == {"kind": "area"}
        assert not pg.is_visible("[data-key='pattern.pitch_deg']") and not pg.is_visible("[data-key='camera.settle_s']")
        pg.wait_for_function(f"window.aerosurvey.view.summary.lines === {grid['lines']} && "
                             f"window.aerosurvey.view.pattern === 'area'", timeout=60000)
        _only_our_server(pg, server.url)


@pytest.mark.parametrize("kind", ["mbtiles", "pmtiles"])
def test_offline_basemap_from_a_local_file(site, kind):
    tmp = site["tmp"] / f"basemap-{kind}"
    tmp.mkdir()
    spec = copy_mission(tmp)
    tiles = tiles_around(14.951, 49.431, range(14, 19))
    path = (write_mbtiles if kind == "mbtiles" else write_pmtiles)(tmp / f"base.{kind}", tiles)
    with _own_server_page(site, spec, basemap=path) as (pg, server):
        _rendered(pg)
        ok = [u for u, status in pg.served if status == 200]
        assert ok, pg.served
        for u in ok:
            z, x, y = (int(v) for v in u.rsplit("/", 3)[1:])
            assert (z, x, y) in tiles
        assert kind in pg.text_content("#basemap-note") or "offline basemap" in pg.text_content("#basemap-note")
        pg.screenshot(path=str(SHOTS / f"12-basemap-{kind}.png"))
        _only_our_server(pg, server.url)


@pytest.mark.parametrize("kind", ["mbtiles", "pmtiles"])
def test_offline_vector_basemap(site, kind):
    """A vector tile set made by GDAL: the pond is drawn where it is, its name written, nothing asked elsewhere."""
    tmp = site["tmp"] / f"vector-{kind}"
    tmp.mkdir()
    spec = copy_mission(tmp)
    with _own_server_page(site, spec, basemap=write_vector_tiles(tmp / f"base.{kind}")) as (pg, server):
        pg.evaluate("window.aerosurvey.map.getView().setZoom(14)")
        _rendered(pg)
        x, y = _page_px(pg, 14.9505, 49.430)  # inside the pond
        px, py = _page_px(pg, 14.945, 49.4275)  # on the road, away from the pond
        box = pg.locator("#map").bounding_box()
        found = pg.evaluate("""async ([x, y]) => (await window.aerosurvey.layers.vbasemap.getFeatures([x, y]))
            .map(f => f.get('class'))""", [x - box["x"], y - box["y"]])
        assert "water" in found
        # the default style: the pond filled blue and named, the road cased and named along its line
        styled = pg.evaluate("""async (pts) => {
            const layer = window.aerosurvey.layers.vbasemap, style = layer.getStyleFunction();
            const res = window.aerosurvey.map.getView().getResolution(), out = {};
            for (const [x, y] of pts) for (const f of await layer.getFeatures([x, y])) {
              const s = [style(f, res)].flat().filter(Boolean);
              out[f.get('class')] = { fills: s.filter(t => t.getFill()).map(t => t.getFill().getColor()),
                strokes: s.filter(t => t.getStroke()).length, texts: s.filter(t => t.getText()).map(t => t.getText().getText()),
                placement: s.filter(t => t.getText()).map(t => t.getText().getPlacement()) };
            }
            return out; }""", [[x - box["x"], y - box["y"]], [px - box["x"], py - box["y"]]])
        assert styled["water"]["fills"] == ["#aad3df"] and styled["water"]["texts"] == ["Pond"]
        assert styled["road"]["strokes"] == 2 and styled["road"]["texts"] == ["Main road"]  # casing and fill
        assert styled["road"]["placement"] == ["line"]
        assert pg.evaluate("window.aerosurvey.layers.basemap.getSource()") is None
        pg.screenshot(path=str(SHOTS / f"15-vector-basemap-{kind}.png"))
        _only_our_server(pg, server.url)


@pytest.mark.parametrize("size", [(1366, 768), (1024, 768)])
def test_layout_in_the_field(site, size):
    """On a laptop and a tablet the summary, the first sortie's fly block and the drawing tools are in view."""
    w, h = size
    ctx = site["browser"].new_context(viewport={"width": w, "height": h})
    try:
        pg = ctx.new_page()
        pg.goto(site["server"].url)
        pg.wait_for_function("window.aerosurvey.view !== null", timeout=60000)
        pg.wait_for_timeout(300)

        def inside(sel: str) -> dict:
            b = pg.locator(sel).first.bounding_box()
            assert b is not None and b["x"] >= 0 and b["y"] >= 0 and b["x"] + b["width"] <= w and b["y"] + b["height"] <= h, (sel, b)
            return b

        for key in ("height AGL", "GSD", "photos", "time", "sorties", "rules"):
            inside(f"#summary dd[data-summary='{key}']")
        first = inside("#fly-blocks .fly")
        assert "battery:" in pg.locator("#fly-blocks .fly").first.text_content()
        tools, layers = inside("#tools"), inside("#layer-box")
        assert tools["x"] + tools["width"] <= layers["x"] or tools["y"] + tools["height"] <= layers["y"]  # no overlap
        assert first["x"] + first["width"] <= pg.locator("#map").bounding_box()["x"] + 1  # beside the map, not over it
        assert pg.evaluate("document.scrollingElement.scrollHeight") <= h
        pg.screenshot(path=str(SHOTS / f"layout-{w}x{h}.png"))

        def whole(sel: str) -> None:  # in view and not cut: nothing of its text overflows its box
            inside(sel)
            assert pg.evaluate("s => { const e = document.querySelector(s); "
                               "return e.scrollWidth <= e.clientWidth && e.scrollHeight <= e.clientHeight; }", sel), \
                (sel, pg.text_content(sel))

        assert pg.text_content("#status").startswith("planned in")
        whole("#status")
        _tab(pg, "setup")  # the page's longest status: a change that cannot be planned
        pg.fill("[data-key='targets.side_overlap']", "1.2")
        pg.wait_for_function("document.querySelector('#status').textContent.startsWith('the last change')", timeout=30000)
        whole("#status")
        for key in ("height AGL", "GSD", "photos", "time", "sorties", "rules"):
            inside(f"#summary dd[data-summary='{key}']")
        assert pg.evaluate("document.scrollingElement.scrollHeight") <= h
    finally:
        ctx.close()


def test_phone_in_the_field_with_qr_codes(site):
    """On a phone (375×812, below 768 px) the page scrolls down, never sideways: the summary stays
    in view at the top, every tab is usable at the full width, each sortie's fly block has its
    files, and with `serve --lan` a QR button shows a code of the file's network address."""
    from webutil import Server

    server = Server(site["spec"], lan=True)
    ctx = site["browser"].new_context(viewport={"width": 375, "height": 812}, is_mobile=True, has_touch=True)
    errors: list[str] = []
    try:
        pg = ctx.new_page()
        pg.on("pageerror", lambda e: errors.append(str(e)))
        pg.goto(server.url)
        pg.wait_for_function("window.aerosurvey.view !== null", timeout=60000)

        def no_sideways_scroll() -> None:
            assert pg.evaluate("document.scrollingElement.scrollWidth") <= 375

        def summary_in_view() -> None:
            for key in ("photos", "time", "sorties", "rules"):
                b = pg.locator(f"#summary dd[data-summary='{key}']").bounding_box()
                assert b is not None and 0 <= b["y"] and b["y"] + b["height"] <= 812 and b["x"] + b["width"] <= 375, key

        for tab in ("setup", "fly", "rules", "flight"):
            _tab(pg, tab)
            no_sideways_scroll()
            summary_in_view()
        _tab(pg, "fly")
        blocks = pg.locator("#fly-blocks .fly")
        assert blocks.count() == 5
        first = blocks.first.bounding_box()
        assert first["x"] >= 0 and first["x"] + first["width"] <= 375
        assert {"sortie-01.plan", "sortie-01.waypoints"} <= set(pg.eval_on_selector_all(
            "#fly-blocks .fly:first-child a[data-file]", "els => els.map(e => e.dataset.file)"))
        # scrolled to the last block, the summary is still at the top
        blocks.last.scroll_into_view_if_needed()
        summary_in_view()
        # a QR code of the first sortie's .plan, and the phone downloads the file from its address
        blocks.first.locator("button[data-share='sortie-01.plan']").click()
        pg.wait_for_selector("#fly-blocks .fly:first-child .qr img")
        url = pg.text_content("#fly-blocks .fly:first-child .qr .hint").split(": ", 1)[1]
        assert url.startswith(server.url + "lan/")
        img = pg.locator("#fly-blocks .fly:first-child .qr img").bounding_box()
        assert img["x"] >= 0 and img["x"] + img["width"] <= 375
        no_sideways_scroll()
        got = pg.request.get(url)
        assert got.status == 200 and got.body() == (site["cli"] / "sortie-01.plan").read_bytes()
        _tab(pg, "flight")
        b = pg.locator("#pick-flight").bounding_box()
        assert b is not None and b["x"] + b["width"] <= 375
        pg.screenshot(path=str(SHOTS / "layout-375x812.png"), full_page=True)
        assert errors == []
    finally:
        ctx.close()
        server.stop()


def test_long_plan_shows_progress_and_cancels(site):
    tmp = site["tmp"] / "big"
    tmp.mkdir()
    write_geojson(tmp / "big.geojson", random_polygon("holed", 11, 4000))
    (tmp / "big.toml").write_text('[mission]\nname = "big"\n[area]\nfile = "big.geojson"\n[camera]\nmodel = "sony-a6000-16mm"\n'
                                  '[targets]\ngsd_cm = 1.2\nforward_overlap = 0.8\nside_overlap = 0.7\n'
                                  # a job this large on purpose (a long plan to cancel): above the default limits
                                  '[limits]\nmax_photos = 10000000\nmax_flight_hours = 10000\n')
    server = Server(tmp / "big.toml")
    ctx = site["browser"].new_context(viewport={"width": 1400, "height": 900})
    try:
        pg = ctx.new_page()
        pg.goto(server.url)
        pg.locator("#progress").wait_for(state="visible", timeout=30000)
        pg.wait_for_function("document.querySelector('#progress-bar').value > 0.05", timeout=30000)
        box = pg.locator("#progress").bounding_box()  # in sight, over the map
        assert box is not None and box["y"] >= 0 and box["y"] + box["height"] <= 900 and box["x"] > 340
        assert pg.locator("#cancel").is_visible()
        pg.screenshot(path=str(SHOTS / "08-progress.png"))
        pg.click("#cancel")
        pg.wait_for_function("document.querySelector('#status').textContent.startsWith('cancelled')", timeout=15000)
        assert pg.evaluate("window.aerosurvey.view") is None
        assert pg.locator("#progress").is_hidden()
        assert pg.locator("[data-key='targets.side_overlap']").input_value() == "0.7"
    finally:
        ctx.close()
        server.stop()


# ---- issue 37: the pilot's workflow at the keyboard, in Czech, offline and after a flight ----------------------------

def _unzipped(path: Path) -> dict[str, bytes]:
    with zipfile.ZipFile(path) as zf:
        return {n: zf.read(n) for n in zf.namelist()}


def test_czech_mission_name_downloads(page, site):
    """A mission named in Czech (the project's own example is Czech): *Spec as TOML* and the zip of all files download
    under that name (RFC 6266 / 5987 headers), with its files in them."""
    _tab(page, "setup")
    _replan_and_wait(page, lambda: page.fill("[data-key='mission.name']", "Obrataň 72 ha"))
    assert page.evaluate("window.aerosurvey.view.name") == "Obrataň 72 ha"
    with page.expect_download() as d:
        page.click("#download-toml")
    assert d.value.suggested_filename == "Obrataň 72 ha.zip"  # the TOML and the area file it names
    files = _unzipped(Path(d.value.path()))
    assert tomllib.loads(files["Obrataň 72 ha.toml"].decode())["mission"]["name"] == "Obrataň 72 ha"
    _tab(page, "fly")
    with page.expect_download() as d:
        page.click("#file-groups a[href$='archive.zip']")
    assert d.value.suggested_filename == "Obrataň 72 ha.zip"
    files = _unzipped(Path(d.value.path()))
    assert json.loads(files["manifest.json"])["mission"]["name"] == "Obrataň 72 ha"
    assert sorted(files) == sorted(page.evaluate("window.aerosurvey.view.files"))
    with page.expect_download() as d:
        page.locator("#file-groups a[data-file='mission.waypoints']").click()
    assert d.value.suggested_filename == "mission.waypoints"
    assert page.text_content("#general-error") == ""


def test_spec_as_toml_of_the_unchanged_spec_plans_anywhere(page, site, tmp_path):
    """*Spec as TOML* of the spec the page started with carries the area file it names: unpacked in an empty folder,
    `aerosurvey plan` plans the page's mission from it."""
    _tab(page, "setup")
    with page.expect_download() as d:
        page.click("#download-toml")
    files = _unzipped(Path(d.value.path()))
    assert sorted(files) == ["areas/obratan-72ha.geojson", "obratan-72ha.toml"]
    assert files["areas/obratan-72ha.geojson"] == (site["spec"].parent / "areas" / "obratan-72ha.geojson").read_bytes()
    for name, data in files.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_bytes(data)
    res = CliRunner().invoke(main, ["plan", str(tmp_path / "obratan-72ha.toml"), "-o", str(tmp_path / "cli")])
    assert planned(res.exit_code, res.output), res.output
    pid = page.evaluate("window.aerosurvey.view.plan_id")
    assert (tmp_path / "cli" / "mission.waypoints").read_text() == \
        page.evaluate(f"fetch('/api/plans/{pid}/files/mission.waypoints').then(r => r.text())")


def test_battery_toggle_after_a_field_error_keeps_planning(page):
    """A battery field refused by the planner, then the battery split switched off and on: no script error (the error
    box is not read as a field), and the next change plans."""
    assert "battery.usable_min = -5" in _refused(page, "battery.usable_min", "-5").text_content()
    page.uncheck("#battery-on")
    page.check("#battery-on")
    assert page.errors == []
    _replan_and_wait(page, lambda: page.fill("[data-key='battery.usable_min']", "25"))
    assert page.evaluate("window.aerosurvey.view.summary.sorties") > 1 and page.errors == []


def _focused(pg) -> str:
    """The focused element, as `#id`, `tab:NAME`, `tool:NAME`, `rule:ID` or its tag."""
    return pg.evaluate("""() => { const e = document.activeElement;
        if (e.id) return '#' + e.id;
        if (e.dataset.tab) return 'tab:' + e.dataset.tab;
        if (e.dataset.tool) return 'tool:' + e.dataset.tool;
        if (e.dataset.rule) return 'rule:' + e.dataset.rule;
        return e.tagName.toLowerCase(); }""")


def _tab_to(pg, target: str, limit: int = 150) -> list[str]:
    """Press Tab until `target` (as `_focused` names it) has the focus; the names passed on the way."""
    seen = []
    for _ in range(limit):
        pg.keyboard.press("Tab")
        seen.append(_focused(pg))
        if seen[-1] == target:
            return seen
    raise AssertionError(f"{target} not reached by Tab; reached {seen}")


def test_every_control_reached_and_used_by_keyboard(site):
    """Only the keyboard: the area file picked from the drop zone (Enter) and from its button, the tabs and tools
    (with aria-selected, aria-pressed), a failing rule shown (Enter), the flight folder's picker."""
    tmp = site["tmp"] / "keyboard"
    tmp.mkdir()
    spec = copy_mission(tmp)
    spec.write_text(spec.read_text().replace("forward_overlap = 0.75", "forward_overlap = 0.70"))  # a rule fails
    gj = write_geojson(tmp / "field.geojson", random_polygon("convex", 7, 300))
    with _own_server_page(site, spec) as (pg, _):
        # file choosers intercepted from now on: Playwright turns interception on without waiting for Chromium, so a
        # chooser opened right after the first listener may escape it on a busy machine
        pg.on("filechooser", lambda chooser: None)
        pg.evaluate("1")
        tabs = {t: pg.locator(f"#tabs button[data-tab='{t}']") for t in ("setup", "fly", "rules", "flight")}
        assert [tabs[t].get_attribute("aria-selected") for t in tabs] == ["false", "true", "false", "false"]
        seen = _tab_to(pg, "tool:zone")
        assert {"tab:setup", "tab:fly", "tab:rules", "tab:flight", "tool:edit", "tool:area"} <= set(seen)
        pg.keyboard.press("Enter")
        assert pg.get_attribute("#tools [data-tool='zone']", "aria-pressed") == "true"
        assert pg.get_attribute("#tools [data-tool='edit']", "aria-pressed") == "false"
        # a failing rule: Tab to the Rules tab, Enter, Tab to the rule, Enter: its places drawn
        _open_tab_by_keyboard(pg, "rules")
        assert tabs["rules"].get_attribute("aria-selected") == "true" and tabs["fly"].get_attribute("aria-selected") == "false"
        _tab_to(pg, "rule:cz-forward-overlap")
        assert _features(pg, "highlight") == 0
        pg.keyboard.press("Enter")
        assert _features(pg, "highlight") > 0
        # the flight folder's picker
        _open_tab_by_keyboard(pg, "flight")
        assert _chooser_by_key(pg, "#pick-flight", "Enter").is_multiple()
        # the area file: the drop zone itself (Enter), and its button (Space)
        _open_tab_by_keyboard(pg, "setup")
        chooser = _chooser_by_key(pg, "#drop", "Enter")
        _replan_and_wait(pg, lambda: chooser.set_files(str(gj)))
        assert pg.evaluate("window.aerosurvey.spec.mission.name") == "field"
        assert not _chooser_by_key(pg, "#pick-area", " ").is_multiple()


def _open_tab_by_keyboard(pg, name: str) -> None:
    _tab_to(pg, f"tab:{name}")
    pg.keyboard.press("Enter")


def _chooser_by_key(pg, target: str, key: str):
    """Tab to `target`, press `key`: the file chooser it opens."""
    _tab_to(pg, target)
    with pg.expect_file_chooser() as fc:
        pg.keyboard.press(key)
    return fc.value


def _waypoint_route(path: Path) -> list[tuple[float, float]]:
    """The NAV_WAYPOINT items (command 16) of a QGC WPL 110 file after its home line, as (lon, lat): read here, by the
    format's columns (index, current, frame, command, p1-p4, lat, lon, alt, autocontinue)."""
    rows = [line.split("\t") for line in path.read_text().splitlines()[2:]]
    return [(float(r[9]), float(r[8])) for r in rows if int(r[3]) == 16]


def test_resumed_flight_drawn_and_a_cleared_flight_says_why(site):
    """A flight cut half way: *Resume the flight* draws each resumed sortie's route (the command's waypoints); an edit
    then re-plans, and the loaded flight is cleared with the reason and a button that loads it on the new plan."""
    from conftest import make_spec

    tmp = site["tmp"] / "resume"
    tmp.mkdir()
    spec = make_spec(tmp, {"flight": {"heading": 0.0}})
    plan = tmp / "plan"
    assert CliRunner().invoke(main, ["plan", str(spec), "-o", str(plan)]).exit_code == 0
    data = (REPO / "tests" / "data" / "sitl_copter_survey.bin").read_bytes()
    (tmp / "cut.bin").write_bytes(data[: len(data) // 2])
    res = CliRunner().invoke(main, ["log", "ingest", str(tmp / "cut.bin"), "--plan", str(plan), "-o", str(tmp / "log")])
    assert res.exit_code == 0, res.output
    res = CliRunner().invoke(main, ["resume", str(plan), "--spec", str(spec), "--log", str(tmp / "log"), "-o", str(tmp / "r")])
    assert res.exit_code == 0, res.output
    with _own_server_page(site, spec) as (pg, _):
        _tab(pg, "flight")
        pg.set_input_files("#flight-files", str(tmp / "log"))
        pg.wait_for_function("window.aerosurvey.layers.flown.getSource().getFeatures().length > 0", timeout=30000)
        flown = _features(pg, "flown")
        pg.click("#make-resume")
        pg.wait_for_function("window.aerosurvey.layers.refly.getSource().getFeatures().length > 0", timeout=60000)
        drawn = pg.evaluate("""window.aerosurvey.layers.refly.getSource().getFeatures().map(f => [f.get('id'),
            f.getGeometry().clone().transform('EPSG:3857', 'EPSG:4326').getCoordinates()])""")
        sorties = sorted(p.stem for p in (tmp / "r").glob("resume-*.waypoints"))
        assert sorted(i for i, _ in drawn) == sorties
        for sid, coords in drawn:
            want = _waypoint_route(tmp / "r" / f"{sid}.waypoints")
            assert len(coords) == len(want) >= 2
            assert max(max(abs(a - c), abs(b - d)) for (a, b), (c, d) in zip(coords, want)) < 1e-7
        # an edit: a new plan; the flight of the last one is cleared, and says so
        _tab(pg, "setup")
        _replan_and_wait(pg, lambda: pg.fill("[data-key='targets.side_overlap']", "0.72"))
        assert _features(pg, "flown") == 0
        assert "flight loaded on the last plan was cleared" in pg.text_content("#status")
        _tab(pg, "flight")
        assert "the plan changed" in pg.text_content("#flight-summary")
        pg.click("#reload-flight")
        pg.wait_for_function("window.aerosurvey.layers.flown.getSource().getFeatures().length > 0", timeout=30000)
        assert _features(pg, "flown") == flown


def test_launch_points_without_a_dem_say_so(page, site):
    """Without a DEM a launch point has no ground height: "no DEM", not the manifest's 0 m; with the forest example's
    DEM, the ground height of the manifest."""
    for block in page.locator("#fly-blocks .fly .launch").all():
        assert "no DEM" in block.text_content() and "AMSL" not in block.text_content()
    tmp = site["tmp"] / "dem"
    (tmp / "areas").mkdir(parents=True)
    for name in ("forest-dem.toml", "areas/forest-block.geojson", "areas/forest-block-dem.tif"):
        shutil.copy(REPO / "missions" / name, tmp / name)
    res = CliRunner().invoke(main, ["plan", str(tmp / "forest-dem.toml"), "-o", str(tmp / "cli")])
    assert planned(res.exit_code, res.output), res.output
    sorties = json.loads((tmp / "cli" / "manifest.json").read_text())["sorties"]
    with _own_server_page(site, tmp / "forest-dem.toml") as (pg, _):
        _tab(pg, "fly")
        texts = [b.text_content() for b in pg.locator("#fly-blocks .fly .launch").all()]
        assert len(texts) == len(sorties)
        for text, s in zip(texts, sorties):
            assert f"ground {s['launch']['ground_amsl_m']} m AMSL" in text and s["launch"]["ground_amsl_m"] > 0


def test_cancel_goes_back_to_the_plan_shown_and_save_writes_it(site):
    """A change whose plan is cancelled: the form shows again the value of the plan on the map, and Save writes that."""
    tmp = site["tmp"] / "cancel-back"
    tmp.mkdir()
    spec = copy_mission(tmp)
    # no battery split: a GSD of 0.5 cm plans for seconds (long enough to cancel) instead of being refused
    spec.write_text(re.sub(r"\[battery\][^\[]*", "[limits]\nmax_photos = 10000000\nmax_flight_hours = 10000\n\n", spec.read_text()))
    with _own_server_page(site, spec) as (pg, _):
        lines = _features(pg, "lines")
        _tab(pg, "setup")
        pg.fill("#target-value", "0.5")
        pg.locator("#progress").wait_for(state="visible", timeout=30000)
        pg.click("#cancel")
        pg.wait_for_function("document.querySelector('#status').textContent.startsWith('cancelled')", timeout=30000)
        assert pg.input_value("#target-value") == "2.5" and pg.evaluate("window.aerosurvey.spec.targets.gsd_cm") == 2.5
        assert "back to the plan shown" in pg.text_content("#status")
        assert _features(pg, "lines") == lines
        pg.click("#save-spec")
        pg.wait_for_function("document.querySelector('#save-status').textContent.startsWith('saved')", timeout=30000)
        assert tomllib.loads(spec.read_text())["targets"]["gsd_cm"] == 2.5


def test_escape_abandons_a_drawing_and_backspace_removes_its_last_corner(page):
    zones = len(_drawn(page, "zone"))
    page.click("#tools [data-tool='zone']")
    sq = _zone_square(page, 60)
    for x, y in sq[:3]:
        page.mouse.click(x, y)
        page.wait_for_timeout(300)
    page.keyboard.press("Escape")  # abandoned: nothing drawn, nothing planned
    page.wait_for_timeout(500)
    assert len(_drawn(page, "zone")) == zones
    far = (sq[2][0] + 40, sq[2][1] + 40)  # a corner clicked by mistake, then removed
    for x, y in [*sq[:2], far]:
        page.mouse.click(x, y)
        page.wait_for_timeout(300)
    page.keyboard.press("Backspace")

    def finish():  # the last two corners, then the first again to close the ring
        for x, y in sq[2:]:
            page.mouse.click(x, y)
            page.wait_for_timeout(300)
        page.mouse.click(*sq[0])

    _replan_and_wait(page, finish)
    (rings,) = _drawn(page, "zone")[zones:]
    corners = [_page_px(page, lon, lat) for lon, lat in rings[0][:-1]]
    assert len(corners) == 4  # the square: the three corners abandoned, the mistaken one removed
    for (x, y), (wx, wy) in zip(sorted(corners), sorted(sq)):
        assert abs(x - wx) < 2 and abs(y - wy) < 2


def test_drawn_geometry_is_rounded_to_1e8_degrees(page, site):
    """The drawn GeoJSON and the spec's drawn zones hold no Web Mercator round-trip noise: degrees to 1e-8, and the
    untouched area's corners are the area file's own numbers."""
    page.click("#tools [data-tool='zone']")
    _replan_and_wait(page, lambda: _click_polygon(page, _zone_square(page, 50)))
    _tab(page, "setup")
    with page.expect_download() as d:
        page.click("#download-drawn")
    feats = json.loads(Path(d.value.path()).read_text())["features"]
    area_file = json.loads((site["spec"].parent / "areas" / "obratan-72ha.geojson").read_text())["features"][0]
    (area,) = [f for f in feats if f["properties"]["role"] == "area"]
    assert area["geometry"]["coordinates"] == area_file["geometry"]["coordinates"]
    numbers = [v for f in feats for ring in f["geometry"]["coordinates"] for xy in ring for v in xy]
    numbers += [float(v) for z in page.evaluate("window.aerosurvey.zones") for v in re.findall(r"-?\d+\.\d+", z)]
    assert numbers and all(round(v, 8) == v for v in numbers)


def test_rally_point_placed_checked_fenced_and_saved(site):
    """A rally point placed on the map: RTL may go there (the .plan's rally points), the geofence
    grows to hold it (drawn on the map), it is saved in the spec; placed in a zone, it is refused
    next to the map, as a launch point is."""
    tmp = site["tmp"] / "rally"
    tmp.mkdir()
    spec = copy_mission(tmp)
    with _own_server_page(site, spec) as (pg, _):
        assert pg.evaluate("window.aerosurvey.layers.fence.getSource().getFeatures().length") == 1
        box = pg.locator("#map").bounding_box()
        pg.click("#tools [data-tool='rally']")
        _replan_and_wait(pg, lambda: pg.mouse.click(box["x"] + box["width"] - 120, box["y"] + 90))
        (lon, lat), = _drawn(pg, "rally")
        (point,) = pg.evaluate("window.aerosurvey.spec.flight.rally_points")
        assert point == pytest.approx([lon, lat], abs=DEGREE_STEP)
        assert pg.evaluate("window.aerosurvey.view.layers.rally.length") == 1
        fence = pg.evaluate("""() => window.aerosurvey.layers.fence.getSource().getFeatures()[0].getGeometry().clone()
            .transform('EPSG:3857', 'EPSG:4326').getCoordinates()""")
        assert shapely.Polygon(fence[0]).contains(shapely.Point(lon, lat))
        plan_id = pg.evaluate("window.aerosurvey.view.plan_id")
        doc = json.loads(pg.evaluate(f"fetch('/api/plans/{plan_id}/files/mission.plan').then(r => r.text())"))
        assert any(abs(p[0] - lat) < 1e-7 and abs(p[1] - lon) < 1e-7 for p in doc["rallyPoints"]["points"])
        _tab(pg, "setup")
        pg.click("#save-spec")
        pg.wait_for_function("document.querySelector('#save-status').textContent.startsWith('saved')", timeout=30000)
        assert tomllib.loads(spec.read_text())["flight"]["rally_points"] == [pytest.approx([lon, lat], abs=DEGREE_STEP)]
        # a zone over the rally point: refused by the gate launch points pass, the message next to the map
        pg.click("#tools [data-tool='zone']")
        x, y = box["x"] + box["width"] - 120, box["y"] + 90
        _click_polygon(pg, [(x - 30, y - 30), (x + 30, y - 30), (x + 30, y + 30), (x - 30, y + 30)])
        pg.wait_for_function("document.querySelector('#draw-error').textContent.includes('flight.rally_points[1]')",
                             timeout=60000)
        assert "inside an exclusion zone" in pg.text_content("#draw-error")
        pg.screenshot(path=str(SHOTS / "17-rally-point-in-a-zone.png"))


def test_start_of_a_pass_chosen_on_the_map(page):
    """The start tool: a click near a line's end makes its pass start there; the plan's first run
    of that pass then starts at that end, and the triangle marking the pass's start moves to it."""
    def first_run(pass_no: int) -> list[list[float]]:
        return page.evaluate(f"window.aerosurvey.view.layers.lines.find(l => l.pass === {pass_no}).xy")

    before = first_run(1)
    last = page.evaluate("(() => { const ls = window.aerosurvey.view.layers.lines.filter(l => l.pass === 1); "
                         "return ls[ls.length - 1].xy; })()")
    # the end of pass 1's last run that is farthest from where the pass starts now
    target = max((last[0], last[-1]), key=lambda xy: math.dist(xy, before[0]))
    px = page.evaluate("xy => { const [ox, oy] = window.aerosurvey.view.frame.origin; "
                       "return window.aerosurvey.map.getPixelFromCoordinate([xy[0] + ox, xy[1] + oy]); }", target)
    box = page.locator("#map").bounding_box()
    page.click("#tools [data-tool='start']")
    _replan_and_wait(page, lambda: page.mouse.click(box["x"] + px[0] + 5, box["y"] + px[1] + 5))
    after = first_run(1)
    assert math.dist(after[0], target) < 1.0 and math.dist(before[0], target) > 100.0
    lon, lat = page.evaluate("window.aerosurvey.spec.flight.pass_start['1']")
    got = page.evaluate("xy => { const [ox, oy] = window.aerosurvey.view.frame.origin; "
                        "return window.olb.toLonLat([xy[0] + ox, xy[1] + oy]); }", after[0])
    assert [lon, lat] == pytest.approx(got, abs=1e-7)
    marker = page.evaluate("""window.aerosurvey.layers.starts.getSource().getFeatures()
        .find(f => f.get('pass') === 1).getGeometry().getCoordinates()""")
    origin = page.evaluate("window.aerosurvey.view.frame.origin")
    assert math.dist([marker[0] - origin[0], marker[1] - origin[1]], after[0]) < 0.01


def test_brief_for_a_time_chosen_on_the_page(page):
    """The Fly tab's brief: a time in the evening gives no-go on daylight, named in red; a morning, the others' verdicts."""
    _tab(page, "fly")
    page.fill("#brief-at", "2026-05-14T19:00")
    page.click("#make-brief")
    page.wait_for_selector("#brief-items li[data-topic='daylight']")
    # the browser's time zone is the machine's: 19:00 there is evening in Europe and later elsewhere
    assert page.get_attribute("#brief-items li[data-topic='airspace']", "class") == "advise"
    assert page.get_attribute("#brief-items li[data-topic='batteries']", "class") == "go"
    page.fill("#brief-at", "")
    page.click("#make-brief")
    page.wait_for_function("document.querySelector('[data-for=\"brief\"]').textContent.includes('choose the date')")


# ---- a DEM uploaded on the page, and the zones' height bands on the profile ---------------------------------------

@pytest.mark.parametrize("size", [(375, 812), (1024, 768), (1366, 768)])
def test_a_dem_uploaded_on_the_page_is_planned_over_with_the_zones_bands(site, size):
    """The DEM picked by keyboard from *Setup* (a GeoTIFF the test writes: a plane rising eastwards) is stored, set as
    terrain.dem and planned: the profile's ground is the plane's, an official zone over the area is drawn as a band
    on the profile; a broken file is refused next to the field, naming it. No sideways scroll, the summary in view."""
    from webutil import BASE_M, SLOPE, UTM, dem_bytes

    import independent_airspace as ia

    w, h = size
    tmp = site["tmp"] / f"dem-{w}"
    tmp.mkdir()
    spec = copy_mission(tmp)
    strip = [(14.957, 49.425), (14.959, 49.425), (14.959, 49.440), (14.957, 49.440), (14.957, 49.425)]
    ia.write_ed269(tmp / "zones.json", [ia.Zone("HIGH", "CONDITIONAL", (150.0, "m", "AGL"), (300.0, "m", "AGL"), ring=strip)])
    spec.write_text(spec.read_text() + '\n[airspace]\nzones = ["zones.json"]\n')
    data, x0 = dem_bytes()
    (tmp / "upload").mkdir()
    (tmp / "upload" / "terrain.tif").write_bytes(data)
    (tmp / "upload" / "broken.tif").write_bytes(data[: len(data) // 2])
    with _own_server_page(site, spec) as (pg, _):
        errors: list[str] = []
        pg.on("pageerror", lambda e: errors.append(str(e)))
        pg.on("filechooser", lambda chooser: None)  # file choosers intercepted from now on (see the keyboard test)
        pg.evaluate("1")
        pg.set_viewport_size({"width": w, "height": h})
        assert pg.evaluate("window.aerosurvey.view.profile") is None
        _tab(pg, "setup")
        pg.focus("[data-key='terrain.dem']")
        chooser = _chooser_by_key(pg, "#pick-dem", "Enter")
        _replan_and_wait(pg, lambda: chooser.set_files(str(tmp / "upload" / "terrain.tif")))
        pg.wait_for_function("window.aerosurvey.view.profile !== null", timeout=60000)
        assert pg.input_value("[data-key='terrain.dem']") == "dem/terrain.tif"
        assert (tmp / "dem" / "terrain.tif").read_bytes() == data
        view = pg.evaluate("window.aerosurvey.view")
        pts = _waypoint_route_text(pg.evaluate(f"fetch('/api/plans/{view['plan_id']}/files/mission.waypoints').then(r => r.text())"))
        xs, _ = pyproj.Transformer.from_crs("EPSG:4326", UTM, always_xy=True).transform(*zip(*pts))
        ground = view["profile"]["ground_m"]
        lo, hi = BASE_M + SLOPE * (min(xs) - x0), BASE_M + SLOPE * (max(xs) - x0)
        assert min(ground) == pytest.approx(lo, abs=0.05) and max(ground) == pytest.approx(hi, abs=0.05)
        assert f"ground {lo:.0f} to {hi:.0f} m AMSL" in pg.text_content("#profile-text")
        bands = view["profile"]["bands"]
        assert bands and all("zone HIGH" in b["name"] for b in bands)
        assert _count(pg, "#profile path.zone-band.official") == len(bands)
        assert f"(150 m AGL to 300 m AGL): crossed {len(bands)} time(s)" in pg.text_content("#profile-text")
        assert _count(pg, "#profile text.zone-label") == 1  # the zone named once
        # a file cut short: refused next to the field, naming it; the plan over the good DEM stays
        plans = pg.evaluate("window.aerosurvey.stats.plans")
        pg.set_input_files("#dem-file", str(tmp / "upload" / "broken.tif"))
        box = pg.locator(".err[data-for~='terrain.dem']")
        pg.wait_for_function("document.querySelector(\".err[data-for~='terrain.dem']\").textContent.includes('broken.tif')",
                             timeout=30000)
        assert "GeoTIFF (.tif, .tiff) with a CRS" in box.text_content()
        assert pg.input_value("[data-key='terrain.dem']") == "dem/terrain.tif"
        assert not (tmp / "dem" / "broken.tif").exists() and pg.evaluate("window.aerosurvey.stats.plans") == plans
        wide = pg.evaluate("w => Array.from(document.querySelectorAll('body *')).filter(e => e.getBoundingClientRect().right > w + 1)"
                           ".map(e => e.tagName + ' ' + e.textContent.slice(0, 100))", w)  # what sticks out, if anything
        assert pg.evaluate("document.scrollingElement.scrollWidth") <= w, wide
        s = pg.locator("#summary").bounding_box()
        assert s is not None and s["y"] >= 0 and s["y"] + s["height"] <= h and s["x"] >= 0
        pg.screenshot(path=str(SHOTS / f"dem-upload-{w}x{h}.png"))
        assert errors == [], errors
        # the one console error is Chromium's own line for the refusal's HTTP 400
        assert pg.console == ["Failed to load resource: the server responded with a status of 400 (Bad Request)"], pg.console


def _waypoint_route_text(text: str) -> list[tuple[float, float]]:
    """Every point of a QGC WPL 110 text with a position (home and the items not at 0, 0), as (lon, lat)."""
    rows = [line.split("\t") for line in text.splitlines()[1:]]
    return [(float(r[9]), float(r[8])) for r in rows if float(r[8]) != 0 or float(r[9]) != 0]


def test_a_wind_table_is_shown_as_the_wind_option_writes_it(page):
    """The example's conditions.wind table ({speed_ms = 3.0, from_deg = 270}) is shown as `--wind` text (not as
    "[object Object]"); typed over, the new wind is planned."""
    _tab(page, "setup")
    assert page.input_value("[data-key='conditions.wind']") == "3@270"
    _replan_and_wait(page, lambda: page.fill("[data-key='conditions.wind']", "5@90G8"))
    assert page.evaluate("window.aerosurvey.spec.conditions.wind") == "5@90G8"
    assert page.text_content("#general-error") == ""


def test_a_value_off_the_fields_step_is_not_marked_as_an_error(page):
    """The example's max_airspeed_ms = 10.4 in a field stepping by 0.5 is planned as it is: not outlined in red (the
    browser's :invalid); a value the planner refuses is."""
    _tab(page, "setup")
    field = "[data-key='vehicle.max_airspeed_ms']"
    assert page.input_value(field) == "10.4" and page.evaluate(f"document.querySelector(\"{field}\").matches(':invalid')")
    assert page.evaluate(f"getComputedStyle(document.querySelector(\"{field}\")).outlineStyle") == "none"
    _refused(page, "vehicle.max_airspeed_ms", "-3")
    assert page.evaluate(f"getComputedStyle(document.querySelector(\"{field}\")).outlineStyle") == "solid"


def test_a_copters_air_speed_off_its_nose_has_its_field_and_is_planned_as_the_cli_plans_it(page, site):
    """vehicle.max_airspeed_diagonal_ms (the copter's most air speed 45° off its nose) has a field on *Setup*: typed in,
    in a crosswind of 8 m/s, the page plans the sorties `plan` gives the same spec (each one's time), fewer than
    without it (the crosswind legs faster); a value past 2^¼ times the nose's 10.4 m/s is refused next to the field."""
    import tomli_w

    _tab(page, "setup")
    _replan_and_wait(page, lambda: page.fill("[data-key='conditions.wind']", "8@0"))
    without = page.evaluate("window.aerosurvey.view.sorties.map(s => s.time_s)")
    field = "[data-key='vehicle.max_airspeed_diagonal_ms']"
    _replan_and_wait(page, lambda: page.fill(field, "12"))
    assert page.evaluate("window.aerosurvey.spec.vehicle.max_airspeed_diagonal_ms") == 12
    shown = page.evaluate("window.aerosurvey.view.sorties.map(s => s.time_s)")
    spec = tomllib.loads(site["spec"].read_text(encoding="utf-8"))
    spec["conditions"]["wind"] = "8@0"
    spec["vehicle"]["max_airspeed_diagonal_ms"] = 12.0
    tmp = site["tmp"] / "diagonal"
    tmp.mkdir()
    (tmp / "areas").symlink_to(site["spec"].parent / "areas")
    (tmp / "spec.toml").write_text(tomli_w.dumps(spec), encoding="utf-8")
    res = CliRunner().invoke(main, ["plan", str(tmp / "spec.toml"), "-o", str(tmp / "out")])
    assert res.exit_code == 0, res.output
    planned_s = [s["time_s"] for s in json.loads((tmp / "out" / "manifest.json").read_text())["sorties"]]
    assert shown == pytest.approx(planned_s, abs=0.05)
    assert len(shown) < len(without), (shown, without)
    box = _refused(page, "vehicle.max_airspeed_diagonal_ms", "13")
    assert "vehicle.max_airspeed_diagonal_ms = 13" in box.text_content(), box.text_content()
    assert page.input_value(field) == "13"  # what the user typed stays


def test_a_facade_is_summed_up_by_its_photos_heights_and_its_faces(site):
    """The page opened on the long wall (a facade: no photo straight down) shows the heights its photos are taken at
    and the GSD on the faces, as `plan` prints them, in place of the stand-off's nadir height and GSD, and plans it
    (the control points' layout found no ground for check points: it stopped the page's plan before)."""
    tmp = site["tmp"] / "facade"
    spec = copy_mission(tmp, "long-wall")
    stdout = CliRunner().invoke(main, ["plan", str(spec), "-o", str(tmp / "cli")]).stdout
    agl = re.search(r"^  photos taken\s+([\d.]+)\.\.([\d.]+) m above", stdout, re.M)
    gsd = re.search(r"^  GSD on faces\s+([\d.]+)\.\.([\d.]+) cm", stdout, re.M)
    assert agl and gsd, stdout
    with _opened(site, spec) as pg:
        assert pg.locator("#summary dd[data-summary='height AGL']").count() == 0
        assert pg.locator("#summary dd[data-summary='GSD']").count() == 0
        shown = pg.text_content("#summary dd[data-summary='photos taken']")
        assert shown == f"{float(agl[1]):g}…{float(agl[2]):g} m AGL, none straight down", shown
        faces_gsd = pg.text_content("#summary dd[data-summary='GSD on faces']")
        assert faces_gsd == (f"{float(gsd[1]):g} cm" if gsd[1] == gsd[2] else f"{float(gsd[1]):g}…{float(gsd[2]):g} cm"), faces_gsd
        assert re.fullmatch(r"\d+ m², 0 m² short of 2 photos \(fewest \d+\)", pg.text_content("#summary dd[data-summary='faces']"))
