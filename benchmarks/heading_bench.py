"""Speed of the automatic heading search: the bounded search against costing every candidate.

    python benchmarks/heading_bench.py [--runs 7]

For each case (inprocess_bench's three and the three example missions) the site and sensor
are solved once (not timed); then, interleaved run by run so that a busy spell of the shared
machine hits both, the search as `AreaGrid.layout` runs it (lower bounds, candidates costed
in order of them) and the exhaustive search (every candidate laid and costed), each with an
empty cache of laid lines. Prints the median times, their ratio, how many candidates each
costed, and checks that both chose the same heading and cost.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import shapely

sys.path.insert(0, str(Path(__file__).resolve().parent))
import inprocess_bench  # noqa: E402  (the benchmark next to this one: its cases)

from aerosurvey.inputs import load_inputs  # noqa: E402
from aerosurvey.plan.flight_time import quick_cost, quick_cost_lower_bounds  # noqa: E402
from aerosurvey.plan.frame import LineFrame  # noqa: E402
from aerosurvey.plan.heading import best_heading  # noqa: E402
from aerosurvey.plan.lines import Outline, StripGeometry, build_lines, line_bounds  # noqa: E402
from aerosurvey.plan.pattern import kind_of, strip_geometry  # noqa: E402
from aerosurvey.plan.sensor import solve_heights, solve_sensor, target_height  # noqa: E402
from aerosurvey.plan.site import prepare_site  # noqa: E402
from aerosurvey.spec import load_spec  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
MISSIONS = ["forest-dem", "kubad-abad-fixed-wing", "obratan-72ha"]


def search(spec_path: Path) -> Callable[[bool], tuple[float, float, int]]:
    """A function running the heading search of the spec's main pass (bounded or not) from
    scratch: (heading, cost, candidates costed)."""
    spec = load_spec(spec_path)
    h, gsd, warnings = target_height(spec)
    site = prepare_site(spec, load_inputs(spec), h)
    heights = solve_heights(spec, h, site.ground)
    sensor = solve_sensor(spec, h, gsd, heights, warnings, footprint=kind_of(spec.pattern.kind).footprint(spec, heights),
                          autopilot_stretch=site.autopilot_stretch())
    k = site.grid_scale
    margin = spec.targets.coverage_margin_m * k
    covered = shapely.buffer(site.area, margin, quad_segs=4) if margin > 0 else site.area
    def strips(h: float) -> StripGeometry:  # as AreaGrid.layout lays each heading's stations
        return strip_geometry(sensor, spec.targets.images_beyond_boundary, k, site.autopilot_scale(h))

    g = max((strips(h) for h in (0.0, 90.0)), key=lambda s: s.base)  # its bounds' base
    lead = sensor.lead_in_m * k

    def run(bounded: bool) -> tuple[float, float, int]:
        costed = 0

        def cost(fr: LineFrame) -> float:  # as AreaGrid.layout scores a heading
            nonlocal costed
            costed += 1
            zf = fr.geom_to_frame(site.zones_buffered) if site.zones_buffered is not None else None
            segs = build_lines(fr.geom_to_frame(covered), zf, strips(fr.heading_deg))
            return quick_cost(segs, lead, sensor.kinematics, fr) if segs else math.inf

        if not bounded:
            return (*best_heading(covered, cost), costed)
        outline = Outline.of(covered, site.zones_buffered)

        def bound(frames: list[LineFrame]) -> list[float]:  # as AreaGrid.layout bounds them
            lb = line_bounds(outline, frames, g, sensor.kinematics.vehicle != "copter")
            return quick_cost_lower_bounds(lb, lead, g.base, sensor.kinematics).tolist()

        return (*best_heading(covered, cost, bound=bound), costed)

    return run


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=7)
    a = ap.parse_args()
    print(f"{'case':>24} {'bounded_ms':>11} {'every_ms':>9} {'ratio':>6} {'costed':>7} {'of':>4}  same")
    with tempfile.TemporaryDirectory() as td:
        specs = [(c, inprocess_bench.make_case(c, Path(td) / c)) for c in inprocess_bench.CASES
                 if (Path(td) / c).mkdir() is None]
        specs += [(m, ROOT / "missions" / f"{m}.toml") for m in MISSIONS]
        for name, path in specs:
            run = search(path)
            new, old = run(True), run(False)  # warm-up, and the result of each
            t_new, t_old = [], []
            for _ in range(a.runs):
                for bounded, times in ((True, t_new), (False, t_old)):
                    t0 = time.perf_counter()
                    run(bounded)
                    times.append(time.perf_counter() - t0)
            bn, bo = statistics.median(t_new) * 1e3, statistics.median(t_old) * 1e3
            print(f"{name:>24} {bn:11.1f} {bo:9.1f} {bo / bn:6.2f} {new[2]:7d} {old[2]:4d}  {new[:2] == old[:2]}",
                  flush=True)


if __name__ == "__main__":
    main()
