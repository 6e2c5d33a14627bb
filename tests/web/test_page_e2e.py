"""The page in a real headless Chromium (Debian's package, driven by Playwright).

Skipped with the reason when no Chromium is found, unless AEROSURVEY_REQUIRE_BROWSER is
set (`.ci/run` sets it after installing Chromium, so CI cannot skip them silently).
Screenshots of the main states go to out/test-screenshots/.
"""

from __future__ import annotations

import http.server
import json
import os
import shutil
import socket
import threading
import time
from pathlib import Path

import pytest
from click.testing import CliRunner
from webutil import REPO, copy_mission

from aerosurvey.cli import main
from conftest import random_polygon, write_geojson

pytestmark = pytest.mark.browser

SHOTS = REPO / "out" / "test-screenshots"
CHROMIUM = os.environ.get("AEROSURVEY_CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")
ARGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
        "--disable-component-update", "--disable-sync"]


def _need_browser() -> None:
    if CHROMIUM is None:
        if os.environ.get("AEROSURVEY_REQUIRE_BROWSER"):
            pytest.fail("AEROSURVEY_REQUIRE_BROWSER is set but no chromium binary was found (install Debian's chromium)")
        pytest.skip("no Chromium found (set AEROSURVEY_CHROMIUM or install Debian's chromium package)")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class _Server:
    """The real app under uvicorn on a free loopback port, in a thread of the test process."""

    def __init__(self, spec: Path):
        import uvicorn

        from aerosurvey.web.app import create_app

        self.port = _free_port()
        hosts = [f"127.0.0.1:{self.port}", f"localhost:{self.port}"]
        config = uvicorn.Config(create_app(spec, allowed_hosts=hosts), host="127.0.0.1", port=self.port, log_level="warning")
        self.server = uvicorn.Server(config)
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


class _Tiles(http.server.BaseHTTPRequestHandler):
    """A stand-in tile server: one grey PNG for any z/x/y, and a log of what was asked."""

    asked: list[str] = []
    png: bytes = b""

    def do_GET(self) -> None:  # noqa: N802 (http.server's name)
        _Tiles.asked.append(self.path)
        self.send_response(200)
        self.send_header("Content-Type", "image/png")
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
    server = _Server(spec)
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
    pg.goto(site["server"].url)
    pg.wait_for_function("window.aerosurvey.view !== null", timeout=60000)
    yield pg
    assert pg.errors == [], pg.errors
    ctx.close()


def _count(pg, selector: str) -> int:
    return pg.eval_on_selector_all(selector, "els => els.length")


def _replan_and_wait(pg, action) -> None:
    """Do something that re-plans, then wait until the page has drawn a new plan."""
    before = pg.evaluate("window.aerosurvey.stats.plans")
    action()
    pg.wait_for_function(f"window.aerosurvey.stats.plans > {before}", timeout=60000)


def test_page_draws_the_plan_of_the_manifest(page, site):
    manifest = json.loads((site["cli"] / "manifest.json").read_text())
    features = json.loads((site["cli"] / "plan.geojson").read_text())["features"]
    lines = [f for f in features if f["properties"]["role"] == "line"]
    assert _count(page, "#layer-lines line") == len(lines) == 34
    assert _count(page, "#layer-stations circle") == len(manifest["stations"]) == 1756
    assert _count(page, "#layer-gcps circle") >= 4 and _count(page, "#layer-checks circle") >= 24
    assert _count(page, "#sortie-legend span") == len(manifest["sorties"]) == 6
    assert page.text_content("[data-summary='photos']").startswith("1756")
    # the cursor readout: WGS84 and the plan's CRS
    box = page.locator("#map").bounding_box()
    page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
    text = page.text_content("#cursor")
    assert "WGS84" in text and "EPSG:5514" in text and "N" in text
    assert page.text_content("#scale-label").endswith("m")
    page.screenshot(path=str(SHOTS / "01-obratan-plan.png"))
    # no tile server, no other host: everything came from our server
    assert all(u.startswith(site["server"].url) or u.startswith("data:") for u in page.requests), page.requests


def test_side_overlap_changes_the_line_count(page):
    lines_before = _count(page, "#layer-lines line")
    _replan_and_wait(page, lambda: page.fill("[data-key='targets.side_overlap']", "0.75"))
    lines_after = _count(page, "#layer-lines line")
    assert lines_after > lines_before
    assert page.text_content("[data-summary='lines']").startswith(f"{lines_after} ")
    page.screenshot(path=str(SHOTS / "02-side-overlap-75.png"))


def test_rule_failure_listed_and_highlighted(page):
    _replan_and_wait(page, lambda: page.fill("[data-key='targets.forward_overlap']", "0.70"))
    fail = page.locator("#rule-list li.fail[data-rule='cz-forward-overlap']")
    assert fail.count() == 1
    assert "70." in fail.text_content()
    assert _count(page, "#layer-highlight line") == 0
    fail.click()
    n = _count(page, "#layer-highlight line")
    assert n > 0
    assert "selected" in fail.get_attribute("class")
    page.screenshot(path=str(SHOTS / "03-rule-failure-highlighted.png"))


def test_bad_value_shown_next_to_its_field_and_kept(page):
    lines = _count(page, "#layer-lines line")
    field = "[data-key='targets.side_overlap']"
    page.fill(field, "1.2")
    box = page.locator(".err[data-for='targets.side_overlap']")
    box.wait_for(state="visible", timeout=30000)
    assert "targets.side_overlap = 1.2 is not allowed" in box.text_content()
    assert page.input_value(field) == "1.2"  # what the user typed stays
    assert _count(page, "#layer-lines line") == lines  # the previous plan stays on the map
    page.screenshot(path=str(SHOTS / "04-bad-value.png"))
    _replan_and_wait(page, lambda: page.fill(field, "0.6"))
    assert box.text_content() == ""


def test_downloaded_waypoints_equal_the_cli(page, site):
    link = page.locator("#file-list a", has_text="mission.waypoints").first
    with page.expect_download() as d:
        link.click()
    path = d.value.path()
    assert Path(path).read_bytes() == (site["cli"] / "mission.waypoints").read_bytes()
    sortie = page.locator("#file-list a", has_text="sortie-03.waypoints").first
    with page.expect_download() as d:
        sortie.click()
    assert Path(d.value.path()).read_bytes() == (site["cli"] / "sortie-03.waypoints").read_bytes()


def test_layers_toggle(page):
    page.uncheck("#layer-toggles input[data-layer='stations']")
    assert page.locator("#layer-stations").evaluate("g => getComputedStyle(g).display") == "none"
    page.check("#layer-toggles input[data-layer='stations']")
    assert page.locator("#layer-stations").evaluate("g => getComputedStyle(g).display") != "none"


def test_dropped_area_starts_a_new_plan(page, site):
    gj = write_geojson(site["tmp"] / "new-field.geojson", random_polygon("concave", 4, 350))
    _replan_and_wait(page, lambda: page.set_input_files("#area-file", str(gj)))
    assert page.input_value("[data-key='mission.name']") == "new-field"
    assert "EPSG:326" in page.text_content("[data-summary='area']")
    assert _count(page, "#layer-stations circle") == int(page.text_content("[data-summary='photos']").split(",")[0])
    page.screenshot(path=str(SHOTS / "05-new-area.png"))


def test_basemap_only_when_configured(page, site):
    import io

    from PIL import Image

    buf = io.BytesIO()
    Image.new("RGB", (256, 256), (200, 200, 200)).save(buf, format="PNG")
    _Tiles.png, _Tiles.asked = buf.getvalue(), []
    port = _free_port()
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", port), _Tiles)
    t = threading.Thread(target=httpd.serve_forever, daemon=True)
    t.start()
    try:
        assert _count(page, "#layer-tiles image") == 0
        page.fill("#tile-url", f"http://127.0.0.1:{port}/{{z}}/{{x}}/{{y}}.png")
        page.dispatch_event("#tile-url", "change")
        page.wait_for_function("document.querySelectorAll('#layer-tiles image').length > 0")
        end = time.monotonic() + 10
        while not _Tiles.asked and time.monotonic() < end:
            time.sleep(0.05)
        assert _Tiles.asked and all(p.endswith(".png") and p.count("/") == 3 for p in _Tiles.asked)
        page.screenshot(path=str(SHOTS / "06-basemap.png"))
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
    server = _Server(spec)
    ctx = site["browser"].new_context(viewport={"width": 1400, "height": 900})
    try:
        pg = ctx.new_page()
        pg.goto(server.url)
        pg.wait_for_function("window.aerosurvey.view !== null", timeout=60000)
        pg.set_input_files("#flight-files", str(tmp / "log"))  # the folder, as a user picks it
        pg.wait_for_function("document.querySelectorAll('#layer-flown circle').length > 0", timeout=30000)
        assert _count(pg, "#layer-flown circle") == 152
        assert _count(pg, "#layer-coverage image") == 1
        assert "152 of 152 stations matched" in pg.text_content("#flight-summary")
        pg.screenshot(path=str(SHOTS / "07-flown.png"))
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
    server = _Server(tmp / "big.toml")
    ctx = site["browser"].new_context(viewport={"width": 1400, "height": 900})
    try:
        pg = ctx.new_page()
        pg.goto(server.url)
        pg.locator("#progress").wait_for(state="visible", timeout=30000)
        pg.wait_for_function("document.querySelector('#progress-bar').value > 0.05", timeout=30000)
        box = pg.locator("#progress").bounding_box()  # in sight, over the map
        assert box is not None and box["y"] >= 0 and box["y"] + box["height"] <= 900 and box["x"] > 360
        assert pg.locator("#cancel").is_visible()
        pg.screenshot(path=str(SHOTS / "08-progress.png"))
        pg.click("#cancel")
        pg.wait_for_function("document.querySelector('#status').textContent.startsWith('cancelled')", timeout=15000)
        assert pg.evaluate("window.aerosurvey.view") is None
        assert pg.locator("#progress").is_hidden()
        assert pg.input_value("[data-key='targets.side_overlap']") == "0.7"
    finally:
        ctx.close()
        server.stop()
