"""How QGroundControl's own Survey generator regenerates our lines from the Survey items of
mission.plan (what an edit in QGroundControl does), on the examples in missions/.

QGroundControl's generator is the port in tests/independent_qgc.py (from its sources at commit
00d5b5e018e54e303cb650790bd1b6e08f818bd0; QGroundControl itself was not run). For every Survey
item of every .plan file (the whole mission's and each sortie's) it prints: QGroundControl's
transects against our lines and runs, the spacing it lays them at and ours, how far its lines
lie from ours across and at their ends (largest), whether it flies them in our order and
directions (largest distance end for end), and its photo count (CameraShots from its
transects) against the one written. A sortie's Survey item holds the sortie's items but
regenerates the whole pass: its lines are compared with the whole pass's (mission.plan), its
written photo count is the sortie's. `--area` also regenerates each pass from the area's
outline instead of the strips polygon written (same angle, spacing and entry), to show what
the polygon choice is worth. Last, the time `aerosurvey plan` spends writing its files with
`--qgc survey` as a ratio of `--qgc items`, both in this process.

    python benchmarks/qgc_survey_bench.py [--area] [--runs 5]

Not covered: QGroundControl's terrain queries (an edit of a terrain-following Survey asks its
own elevation tiles), hover-and-capture and refly passes (not written), and anything of
QGroundControl's behaviour its port does not reproduce (the port follows the source, not a
run of the program).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))

from click.testing import CliRunner  # noqa: E402

import independent_qgc as qgc  # noqa: E402
from aerosurvey.cli import main  # noqa: E402

EXAMPLES = ["obratan-72ha", "kubad-abad-fixed-wing", "forest-dem", "oblique-block", "road-corridor"]


def area_outline(folder: Path) -> list[list[float]]:
    """The area's outer ring as [lat, lon] (plan.geojson), open."""
    fc = json.loads((folder / "plan.geojson").read_text(encoding="utf-8"))
    geom = next(f["geometry"] for f in fc["features"] if f["properties"]["role"] == "area")
    ring = geom["coordinates"][0] if geom["type"] == "Polygon" else geom["coordinates"][0][0]
    return [[lat, lon] for lon, lat in ring[:-1]]


def render_ratio(example: str, runs: int) -> float:
    """Median time to render every output with Survey items over the median with plain items."""
    from aerosurvey.inputs import plan_from_files
    from aerosurvey.outputs import render_outputs
    from aerosurvey.spec import load_spec

    times: dict[str, list[float]] = {"survey": [], "items": []}
    for _ in range(runs):
        for layout in ("items", "survey"):
            spec = load_spec(REPO / "missions" / f"{example}.toml")
            plan = plan_from_files(spec)  # a fresh plan: no cached polygon
            t0 = time.perf_counter()
            render_outputs(plan, spec, qgc=layout)
            times[layout].append(time.perf_counter() - t0)
    return statistics.median(times["survey"]) / statistics.median(times["items"])


def main_() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--area", action="store_true", help="also regenerate from the area's outline")
    ap.add_argument("--runs", type=int, default=5, help="timed runs per layout (default 5)")
    args = ap.parse_args()
    head = (f"{'example':24} {'file':16} {'pass':>4} {'QGC/ours/runs':>13} {'spacing QGC/ours m':>19} "
            f"{'across m':>9} {'ends m':>9} {'order m':>9} {'shots QGC/written':>18}")
    print(head)
    with tempfile.TemporaryDirectory() as tmp:
        for ex in EXAMPLES:
            out = Path(tmp) / ex
            res = CliRunner().invoke(main, ["-q", "plan", str(REPO / "missions" / f"{ex}.toml"), "-o", str(out)])
            if res.exit_code != 0:
                raise SystemExit(f"{ex}: plan failed: {res.output}")
            outline = area_outline(out)
            mission_doc = json.loads((out / "mission.plan").read_text(encoding="utf-8"))
            whole, whole_paths = {}, {}
            for it in (it for it in mission_doc["mission"]["items"] if it["type"] == "ComplexItem"):
                stored = it["TransectStyleComplexItem"]["Items"]
                whole[stored[0]["aerosurveyTag"][:2]] = qgc.flown_lines(stored)
                whole_paths[stored[0]["aerosurveyTag"][:2]] = (qgc.flown_paths(stored), len({i["aerosurveyTag"][:7] for i in stored}))
            for path in sorted(out.glob("*.plan")):
                doc = json.loads(path.read_text(encoding="utf-8"))
                problems = qgc.plan_problems(doc)
                if problems:
                    raise SystemExit(f"{path.name}: QGroundControl would refuse it: {problems[:3]}")
                for item in (it for it in doc["mission"]["items"] if it["type"] == "ComplexItem"):
                    items = item["TransectStyleComplexItem"]["Items"]
                    if item["complexItemType"] == "CorridorScan":  # against the whole pass, as for a survey
                        c = qgc.compare_corridor(item, *whole_paths[items[0]["aerosurveyTag"][:2]])
                        print(f"{ex:24} {path.name:16} corridor: QGC transects {c['qgc_transects']} for our {c['our_lines']} "
                              f"lines ({c['our_runs']} runs); QGC's vertices within {c['max_qgc_vertex_from_ours_m']:.3f} m of "
                              f"our runs, our runs' points within {c['max_ours_from_qgc_m']:.3f} m of its transects; "
                              f"photos {c['qgc_shots']}/{c['written_shots']}")
                        continue
                    p = items[0]["aerosurveyTag"][:2]
                    variants = [("strips", item)] + ([("area", {**item, "polygon": outline})] if args.area else [])
                    for name, survey in variants:
                        # a sortie's Survey regenerates the whole pass: against the whole pass's lines
                        c = qgc.compare(survey, whole[p])
                        label = path.name if name == "strips" else "  (area outline)"
                        print(f"{ex:24} {label:16} {p:>4} {c['qgc_transects']:>4}/{c['our_lines']:>3}/{c['our_runs']:>3} "
                              f"{c['qgc_spacing_m']:>9.3f}/{c['our_spacing_m']:<9.3f} {c['max_across_m']:>9.3f} "
                              f"{c['max_end_m']:>9.3f} {c['same_order_m']:>9.3f} {c['qgc_shots']:>8}/{c['written_shots']:<9}")
    for ex in EXAMPLES:
        print(f"{ex}: writing every output takes {render_ratio(ex, args.runs):.2f}x as long with --qgc survey "
              f"as with --qgc items (median of {args.runs})")


if __name__ == "__main__":
    main_()
