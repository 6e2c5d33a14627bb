"""How soon the page shows its map, in Debian's headless Chromium, against the library's own plan
time in the same process and run.

    python benchmarks/web_page_bench.py [--repeat 5] [--mission obratan-72ha] [--size 1366x768]

For each page load (a fresh browser context on the real server, uvicorn on loopback): the time
from navigation start to the map's first complete render (`stats.firstMapMs`: the spec's area
and zones, read by `/api/state`, drawn before the first plan arrives) and to the first plan drawn
(lines, photos, control points, summary, fly blocks). Then the median wall time of
`plan_mission` + `render_outputs` for the same spec (what `aerosurvey plan` does before writing),
and the ratios. Needs Chromium (AEROSURVEY_CHROMIUM or `chromium` on PATH) and playwright.
Not covered: a basemap (no tiles are drawn), a real tablet's GPU and network.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests" / "web"))

from webutil import Server  # noqa: E402


def _direct(spec_path: Path) -> float:
    from aerosurvey.inputs import plan_from_files
    from aerosurvey.outputs import render_outputs
    from aerosurvey.spec import load_spec

    t = time.perf_counter()
    loaded = load_spec(spec_path)
    render_outputs(plan_from_files(loaded), loaded)
    return time.perf_counter() - t


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--mission", default="obratan-72ha")
    ap.add_argument("--size", default="1366x768")
    args = ap.parse_args()
    from playwright.sync_api import sync_playwright


    chromium = os.environ.get("AEROSURVEY_CHROMIUM") or shutil.which("chromium")
    if chromium is None:
        raise SystemExit("no Chromium: install Debian's chromium or set AEROSURVEY_CHROMIUM")
    spec = REPO / "missions" / f"{args.mission}.toml"
    w, h = (int(v) for v in args.size.split("x"))
    server = Server(spec)
    first_map, first_plan = [], []
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=chromium, args=["--no-sandbox", "--disable-gpu"])
            for _ in range(args.repeat):
                ctx = browser.new_context(viewport={"width": w, "height": h})
                pg = ctx.new_page()
                pg.goto(server.url)
                pg.wait_for_function("window.aerosurvey.view !== null && window.aerosurvey.stats.firstMapMs !== null",
                                     timeout=120000)
                pg.wait_for_function("new Promise(ok => { const m = window.aerosurvey.map; "
                                     "m.once('rendercomplete', () => ok(true)); m.render(); })")
                stats = pg.evaluate("({first: window.aerosurvey.stats.firstMapMs, now: performance.now()})")
                first_map.append(stats["first"] / 1000)
                first_plan.append(stats["now"] / 1000)
                ctx.close()
            browser.close()
    finally:
        server.stop()
    direct = [_direct(spec) for _ in range(args.repeat)]
    fm, fp, d = statistics.median(first_map), statistics.median(first_plan), statistics.median(direct)
    print(f"{args.mission} at {args.size}, median of {args.repeat} page loads")
    print(f"  first map (area drawn)   {fm:6.2f} s   {fm / d:5.2f} x the library's plan")
    print(f"  first plan drawn         {fp:6.2f} s   {fp / d:5.2f} x the library's plan")
    print(f"  library plan + render    {d:6.2f} s")


if __name__ == "__main__":
    main()
