"""The screenshots of docs/web.md, made in Debian's headless Chromium:

    python tests/web/docs_screenshots.py   # writes docs/img/serve-1366.png, serve-1024.png, serve-corridor-1366.png

1366×768 (a laptop): the Obrataň example with an exclusion zone drawn on the map, the Fly tab.
1024×768 (a tablet): the same mission with the forward overlap lowered to 70 %, the failing rule
clicked (its runs in red). 1366×768 again: the road corridor example (its centreline, the planned
band, the strips bending with it). Not a test: run it when the page's look changes, and look at the images.
"""

from __future__ import annotations

import shutil
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from webutil import REPO, Server, copy_mission  # noqa: E402

OUT = REPO / "docs" / "img"


def main() -> None:
    from playwright.sync_api import sync_playwright

    tmp = Path(tempfile.mkdtemp())
    server = Server(copy_mission(tmp))
    url = server.url
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=shutil.which("chromium"), args=["--no-sandbox", "--disable-gpu"])
            pg = browser.new_page(viewport={"width": 1366, "height": 768})
            pg.goto(url)
            pg.wait_for_function("window.aerosurvey.view !== null", timeout=60000)
            box = pg.locator("#map").bounding_box()
            cx, cy = box["x"] + box["width"] / 2 + 40, box["y"] + box["height"] / 2
            pg.click("#tools [data-tool='zone']")
            n = pg.evaluate("window.aerosurvey.stats.plans")
            for x, y in [(cx - 50, cy - 40), (cx + 60, cy - 55), (cx + 45, cy + 50), (cx - 55, cy + 40), (cx - 50, cy - 40)]:
                pg.mouse.click(x, y)
                pg.wait_for_timeout(300)
            pg.wait_for_function(f"window.aerosurvey.stats.plans > {n}", timeout=60000)
            pg.click("#tools [data-tool='edit']")
            pg.mouse.move(cx, cy + 150)
            pg.wait_for_timeout(300)
            pg.screenshot(path=str(OUT / "serve-1366.png"))
            pg.close()
            pg = browser.new_page(viewport={"width": 1024, "height": 768})
            pg.goto(url)
            pg.wait_for_function("window.aerosurvey.view !== null", timeout=60000)
            pg.click("#tabs button[data-tab='setup']")
            n = pg.evaluate("window.aerosurvey.stats.plans")
            pg.fill("[data-key='targets.forward_overlap']", "0.70")
            pg.wait_for_function(f"window.aerosurvey.stats.plans > {n}", timeout=60000)
            pg.click("#tabs button[data-tab='rules']")
            pg.click("#rule-list li.fail")
            pg.wait_for_timeout(600)
            pg.screenshot(path=str(OUT / "serve-1024.png"))
            pg.close()
            corridor = Server(copy_mission(tmp / "corridor", "road-corridor"))
            try:
                pg = browser.new_page(viewport={"width": 1366, "height": 768})
                pg.goto(corridor.url)
                pg.wait_for_function("window.aerosurvey.view !== null", timeout=60000)
                pg.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
                pg.wait_for_timeout(300)
                pg.screenshot(path=str(OUT / "serve-corridor-1366.png"))
            finally:
                corridor.stop()
            browser.close()
    finally:
        server.stop()
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"wrote serve-1366.png, serve-1024.png and serve-corridor-1366.png in {OUT}")


if __name__ == "__main__":
    main()
