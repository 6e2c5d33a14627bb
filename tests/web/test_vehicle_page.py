"""Upload from the map (`aerosurvey serve --connect URL`) in a real headless Chromium, as a pilot does it with the
keyboard alone, at 1366×768 and on a phone (375×812): the vehicle checked (each check listed, the vehicle and its
home on the map), then the upload on the pilot's key press, its progress, the read-back's verdict, and the file of
what the vehicle holds downloaded and read back by the project's reader. Against the fake vehicle behind a link
that drops 10 % of the datagrams each way as an ArduPilot copter, and on a clean link as a PX4 copter (MAVSDK's
transfers at 10 % loss take over a minute, from the CLI too); 0 page or console errors."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
from test_page_e2e import ARGS, CHROMIUM, _need_browser, _tab_to
from webutil import Server

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "link"))
from fake_vehicle import FakeVehicle, LossyRelay, VehicleModel  # noqa: E402

from aerosurvey.mission.formats.wpl import loads_wpl  # noqa: E402
from conftest import make_spec  # noqa: E402

pytestmark = pytest.mark.browser

SIZES = {"desktop": (1366, 768), "phone": (375, 812)}


@pytest.fixture(scope="module")
def browser():
    _need_browser()
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        try:
            yield b
        finally:
            b.close()


@pytest.mark.parametrize("firmware", ["ardupilot", "px4"])
@pytest.mark.parametrize("size", list(SIZES))
def test_check_and_upload_from_the_map_by_keyboard(browser, tmp_path, firmware, size):
    if firmware == "px4":  # the small test mission: the 50 ha one has 2,093 items as PX4 flies them, and PX4 stores 2,000
        spec = make_spec(tmp_path, {"vehicle": {"firmware": "px4"}})
    else:  # a 1 cm GSD over 50 ha: a mission of 114 items, whose upload at 10 % loss lasts long enough to be watched
        spec = make_spec(tmp_path, {"targets": {"gsd_cm": 1.0}},
                         area=[[15.000, 49.400], [15.012, 49.400], [15.012, 49.4045], [15.000, 49.4045], [15.000, 49.400]])
    model = VehicleModel(px4=True) if firmware == "px4" else VehicleModel(storage="ardupilot")
    width, height = SIZES[size]
    # ArduPilot's transfers (aerosurvey's protocol) at 10 % loss each way; PX4's go through MAVSDK, which at 10 % loss
    # takes over a minute for a mission of 178 items from the CLI as well: its page test runs on a clean link
    drop = 0.1 if firmware == "ardupilot" else 0.0
    with FakeVehicle(model, "udp") as fv, LossyRelay(fv.port, drop=drop, seed=7) as relay:
        server = Server(spec, vehicle=relay.url)
        ctx = browser.new_context(viewport={"width": width, "height": height}, accept_downloads=True,
                                  is_mobile=size == "phone", has_touch=size == "phone")
        errors: list[str] = []
        try:
            pg = ctx.new_page()
            pg.on("pageerror", lambda e: errors.append(str(e)))
            pg.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            pg.goto(server.url)
            pg.wait_for_function("window.aerosurvey.view !== null", timeout=60000)
            plan = loads_wpl(pg.request.get(server.url + f"api/plans/{pg.evaluate('window.aerosurvey.view.plan_id')}"
                                            "/files/mission.waypoints").text(), "mission.waypoints")
            model.home = plan.home
            assert pg.is_visible("#vehicle-box") and relay.url in pg.text_content("#vehicle-url")
            assert pg.eval_on_selector("#vehicle-file", "s => [...s.options].map(o => o.value)")[0] == "mission.plan"
            assert pg.is_disabled("#vehicle-upload")  # nothing to upload before a check passes
            # the check, by keyboard: nothing is sent
            _tab_to(pg, "#vehicle-check")
            pg.keyboard.press("Enter")
            pg.wait_for_function("!document.querySelector('#vehicle-check').disabled", timeout=120000)
            checks = pg.eval_on_selector_all("#vehicle-checks li", "els => els.map(e => e.textContent)")
            assert pg.text_content("#vehicle-verdict").startswith("GO"), (pg.text_content("#vehicle-verdict"), checks)
            assert any(c.startswith("launch point: the vehicle is 0 m from") for c in checks), checks
            assert any(c.startswith("battery-failsafe") for c in checks) and any(c.startswith("camera") for c in checks)
            assert sum(v for k, v in model.log.items() if k.startswith("got MISSION_")) == 0
            assert pg.evaluate("window.aerosurvey.layers.vehicle.getSource().getFeatures().map(f => f.get('role')).sort()") \
                == ["home", "vehicle"]
            # the upload, by keyboard: progress shown while it runs, then the read-back's verdict
            pg.evaluate("""() => { window.stages = []; new MutationObserver(() => window.stages.push(
                document.querySelector('#vehicle-stage').textContent)).observe(document.querySelector('#vehicle-stage'),
                { childList: true, characterData: true, subtree: true }); }""")
            _tab_to(pg, "#vehicle-upload")
            pg.keyboard.press("Enter")
            pg.wait_for_function("!document.querySelector('#vehicle-check').disabled", timeout=120000)
            assert pg.text_content("#vehicle-verdict").startswith("VERIFIED"), (
                pg.text_content("#vehicle-verdict"), pg.text_content(".err[data-for='vehicle']"))
            stages = pg.evaluate("window.stages")
            if firmware == "ardupilot":  # MAVSDK reports a transfer's start and end only, too quick to be seen here
                assert any(" upload " in s and s.endswith("%") for s in stages), stages[-8:]
            assert any(li.startswith("verified:") for li in
                       pg.eval_on_selector_all("#vehicle-checks li", "els => els.map(e => e.textContent)"))
            assert len(model.stored[0]) > 0
            # what the vehicle holds, downloaded by keyboard
            _tab_to(pg, "#vehicle-held")
            with pg.expect_download() as dl:
                pg.keyboard.press("Enter")
            held = loads_wpl(Path(dl.value.path()).read_text(), "held.waypoints")
            assert [it.command for it in held.items] == [it.command for it in plan.items]
            if size == "phone":
                assert pg.evaluate("document.scrollingElement.scrollWidth") <= width
        finally:
            ctx.close()
            server.stop()
        assert relay.counts["dropped"] > 0 or drop == 0
    assert errors == [], errors
