"""No-fly zones: no leg of any exported file enters a zone, no launch point lies in one, and
every part of the required ground left unphotographed is reported.

The property test plans random areas with zones crossing the boundary, inside and just
outside it (tests/zone_cases.py) and judges the exported files with a checker that shares
no code with the planner (tests/independent_legs.py). Its size: AEROSURVEY_SAFETY_EXAMPLES
(default 40, under a minute on two cores; benchmarks/safety_bench.py runs a thousand).
The unit tests below prove the checker itself on hand-made mission files.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, Phase, event, example, given, settings

import independent_legs as il
import zone_cases as zc

EXAMPLES = int(os.environ.get("AEROSURVEY_SAFETY_EXAMPLES", "40"))


@pytest.mark.slow
@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
          # no shrinking: a plan takes up to seconds, and the first failing case is printed with all its problems
          phases=[Phase.explicit, Phase.reuse, Phase.generate])
@given(params=zc.case_params())
# a plane over 0.5 ha with three zones: no heading had a line sure to survive the zones, and the
# plane's heading bound failed on that (IndexError) before it planned
@example(params=zc.CaseParams(kind="convex", size_ha=0.5, lat=50.0, lon=0.0, vehicle="plane",
                              zones=("crossing", "crossing", "crossing"), battery_min=None, launch="default", end="rtl",
                              margin_m=30.0, height_m=80.0, heading=None, seed=0))
def test_zones_are_never_entered_and_gaps_are_reported(tmp_path_factory: pytest.TempPathFactory, params: zc.CaseParams) -> None:
    case = zc.make_case(params)
    folder = tmp_path_factory.mktemp("zone-case")
    outcome = zc.plan_case(case, folder)
    event(f"{params.vehicle}, {'sorties' if params.battery_min else 'one flight'}, {len(case.zones)} zone(s)")
    if outcome.refused is not None:
        event("refused")
        return  # a clean refusal (InputError naming the input) is allowed: nothing is flown
    problems = outcome.problems()
    assert not problems, f"{case.describe()} (files in {folder}):\n" + "\n".join(problems[:20])


# ---------------------------------------------------------------- the checker on hand-made files

ORIGIN = (15.0, 49.4)
LOCAL = il.Local(*ORIGIN)


def _ll(x: float, y: float) -> tuple[float, float]:
    lon, lat = LOCAL.inv.transform(x, y)
    return float(lon), float(lat)


def _square(cx: float, cy: float, half: float) -> shapely.Polygon:
    """A lon/lat zone that is a square of side 2·half metres in the local projection."""
    return shapely.transform(shapely.box(cx - half, cy - half, cx + half, cy + half),
                             lambda a: np.column_stack(LOCAL.inv.transform(a[:, 0], a[:, 1])))


def _wpl(home_xy: tuple[float, float], items: list[tuple[int, tuple[float, float] | None, float, float]]) -> str:
    """QGC WPL 110 text: home, then (command, (x, y) metres or None for lat = lon = 0, param1, alt)."""
    hl = _ll(*home_xy)
    rows = ["QGC WPL 110", f"0\t1\t0\t16\t0\t0\t0\t0\t{hl[1]:.8f}\t{hl[0]:.8f}\t0\t1"]
    for k, (cmd, xy, p1, alt) in enumerate(items, start=1):
        lon, lat = _ll(*xy) if xy is not None else (0.0, 0.0)
        rows.append(f"{k}\t0\t3\t{cmd}\t{p1}\t0\t0\t0\t{lat:.8f}\t{lon:.8f}\t{alt}\t1")
    return "\n".join(rows) + "\n"


def _legs(tmp: Path, text: str, zones: list[shapely.Polygon], vehicle: str = "copter", plan: dict[str, Any] | None = None) -> il.FileReport:
    w = tmp / "mission.waypoints"
    w.write_text(text)
    p = None
    if plan is not None:
        p = tmp / "mission.plan"
        p.write_text(json.dumps(plan))
    return il.legs_inside_zones(w, zones, LOCAL, vehicle, p)


def test_a_leg_through_a_zone_is_measured(tmp_path: Path) -> None:
    zone = _square(0, 0, 50)
    text = _wpl((-300, 0), [(22, (-300, 0), 0, 50), (16, (-200, 0), 0, 50), (16, (200, 0), 0, 50), (21, (200, 0), 0, 0)])
    rep = _legs(tmp_path, text, [zone])
    crossing = [leg for leg in rep.legs if leg.worst_m > 0]
    assert len(crossing) == 1 and crossing[0].item == 3 and crossing[0].kind == "waypoint"
    assert [leg.kind for leg in rep.legs] == ["to-first", "waypoint"]
    assert crossing[0].inside_m[0] == pytest.approx(100.0, abs=0.1)
    assert rep.home_zones == []


def test_a_leg_beside_a_zone_is_not_counted(tmp_path: Path) -> None:
    text = _wpl((-300, 60), [(22, None, 0, 50), (16, (-200, 60), 0, 50), (16, (200, 60), 0, 50), (20, None, 0, 0)])
    rep = _legs(tmp_path, text, [_square(0, 0, 50)])
    assert rep.violations == [] and [leg.kind for leg in rep.legs] == ["to-first", "waypoint", "rtl"]


def test_rtl_flies_straight_home_through_the_zone(tmp_path: Path) -> None:
    text = _wpl((0, -200), [(22, None, 0, 50), (16, (300, -200), 0, 50), (16, (0, 200), 0, 50), (20, None, 0, 0)])
    rep = _legs(tmp_path, text, [_square(0, 0, 40)])
    assert [(leg.kind, round(leg.worst_m, 1)) for leg in rep.legs] == [("to-first", 0.0), ("waypoint", 0.0), ("rtl", 80.0)]


def test_rtl_goes_to_the_nearest_rally_point(tmp_path: Path) -> None:
    text = _wpl((0, -200), [(22, None, 0, 50), (16, (300, -200), 0, 50), (16, (0, 200), 0, 50), (20, None, 0, 0)])
    rally = _ll(100, 250)
    plan = {"geoFence": {"circles": [], "polygons": []}, "rallyPoints": {"points": [[rally[1], rally[0], 50.0]]}}
    rep = _legs(tmp_path, text, [_square(0, 0, 40)], plan=plan)
    assert [leg.kind for leg in rep.legs] == ["to-first", "waypoint", "rtl"]
    end = rep.legs[-1].path.coords[-1]
    assert end == pytest.approx((100, 250), abs=0.01)
    assert rep.violations == []  # the way home through the zone is not flown
    assert rep.fence_missing == [0]  # and the fence does not carry the zone


def test_zero_lat_lon_means_here(tmp_path: Path) -> None:
    # a waypoint at 0,0 holds position, a LAND at 0,0 lands where the vehicle is: no leg to (0°, 0°)
    text = _wpl((-300, 0), [(22, None, 0, 50), (16, (-200, 0), 0, 50), (16, None, 0, 50), (21, None, 0, 0)])
    rep = _legs(tmp_path, text, [_square(0, 0, 50)])
    assert [leg.kind for leg in rep.legs] == ["to-first"]
    assert rep.legs[0].path.length == pytest.approx(100.0, abs=0.01)


def test_copter_takes_off_vertically_and_lands_at_its_point(tmp_path: Path) -> None:
    # the take-off item's own lat/lon (inside the zone) are not flown to by a copter
    text = _wpl((-300, 0), [(22, (0, 0), 0, 50), (16, (-300, 100), 0, 50), (21, (100, 100), 0, 0)])
    rep = _legs(tmp_path, text, [_square(0, 0, 50)])
    assert [leg.kind for leg in rep.legs] == ["to-first", "land"]
    assert rep.violations == []
    rep = _legs(tmp_path, text, [_square(0, 100, 20)])
    assert rep.legs[-1].worst_m == pytest.approx(40.0, abs=0.1)


def test_plane_climbs_out_past_a_near_first_waypoint(tmp_path: Path) -> None:
    # 15° to 100 m: 373 m straight ahead towards the first waypoint (100 m away), then back to it
    text = _wpl((0, 0), [(22, None, 15, 100), (16, (0, 100), 0, 100), (16, (0, 50), 0, 100), (21, (0, 0), 0, 0)])
    zone = _square(0, 300, 25)
    rep = _legs(tmp_path, text, [zone], vehicle="plane")
    kinds = [leg.kind for leg in rep.legs]
    assert kinds[:3] == ["climb-out", "to-first", "waypoint"]
    assert rep.legs[0].path.length == pytest.approx(100 / np.tan(np.radians(15)), abs=0.05)
    assert rep.legs[0].worst_m == pytest.approx(50.0, abs=0.1)
    # a copter with the same items never goes there
    assert _legs(tmp_path, text, [zone], vehicle="copter").violations == []


def test_plane_loiters_over_home_after_rtl(tmp_path: Path) -> None:
    text = _wpl((0, 0), [(22, None, 15, 100), (16, (0, 600), 0, 100), (20, None, 0, 0)])
    rep = _legs(tmp_path, text, [_square(100, 0, 50)], vehicle="plane")
    assert [leg.kind for leg in rep.legs][-2:] == ["rtl", "rtl-loiter"]
    assert rep.legs[-1].worst_m > 0 and rep.legs[-2].worst_m == 0
    # a plane mission without an end command returns home too
    rep = _legs(tmp_path, _wpl((0, 0), [(22, None, 15, 100), (16, (0, 600), 0, 100)]), [_square(0, 300, 20)], vehicle="plane")
    assert rep.legs[-2].kind == "end-rtl" and rep.legs[-2].worst_m == pytest.approx(40.0, abs=0.1)


def test_do_jump_repeats_legs(tmp_path: Path) -> None:
    text = _wpl((-300, 0), [(22, None, 0, 50), (16, (-200, 0), 0, 50), (16, (200, 0), 0, 50), (177, None, 2, 0),
                            (21, None, 0, 0)])
    text = text.replace("\t177\t2\t0\t", "\t177\t2\t1\t")  # DO_JUMP to item 2, once more
    rep = _legs(tmp_path, text, [_square(0, 0, 50)])
    assert [round(leg.worst_m) for leg in rep.legs] == [0, 100, 100, 100]


def test_home_in_zone_and_fence(tmp_path: Path) -> None:
    zone = _square(0, 0, 50)
    ring = [[lat, lon] for lon, lat in list(zone.exterior.coords)[:-1]]
    plan = {"geoFence": {"circles": [], "polygons": [{"inclusion": False, "polygon": ring}]}, "rallyPoints": {"points": []}}
    rep = _legs(tmp_path, _wpl((10, 10), [(22, None, 0, 50), (16, (300, 0), 0, 50), (21, None, 0, 0)]), [zone], plan=plan)
    assert rep.home_zones == [0] and rep.fence_missing == []
    assert rep.legs[0].worst_m == pytest.approx(40.0, abs=0.1)


def test_plan_and_waypoints_must_fly_the_same_items(tmp_path: Path) -> None:
    text = _wpl((0, 0), [(22, None, 0, 50), (16, (0, 300), 0, 50), (20, None, 0, 0)])
    home, items = il.parse_wpl(text)
    plan_items: list[dict[str, Any]] = [{"type": "SimpleItem", "command": it.command, "params": [0, 0, 0, 0, it.lat, it.lon, it.alt]}
                                        for it in items]
    doc: dict[str, Any] = {"mission": {"plannedHomePosition": [home.lat, home.lon, 0], "items": plan_items}}
    assert il.plan_items_differ(doc, home, items) is None
    plan_items[1]["params"][4] += 1e-5
    assert "item 2" in (il.plan_items_differ(doc, home, items) or "")
    doc["mission"]["items"] = plan_items[:2]
    assert "2 items in the .plan" in (il.plan_items_differ(doc, home, items) or "")


def test_wpl_parser_refuses_what_it_cannot_read(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="QGC WPL 110"):
        il.parse_wpl("QGC WPL 100\n", "x")
    with pytest.raises(ValueError, match="columns"):
        il.parse_wpl("QGC WPL 110\n0\t1\t0\t16\t0\n", "x")


def _coverage_dir(tmp: Path, uncovered: shapely.Geometry | None) -> Path:
    """One photo line along y = 0 from x = -300 to 300 at 100 m (footprint 147 m across, 97.5 m along)."""
    text = _wpl((-400, 0), [(22, None, 0, 100), (178, None, 1, 0), (16, (-300, 0), 0, 100), (206, None, 20, 0),
                            (16, (300, 0), 0, 100), (206, None, 0, 0), (20, None, 0, 0)])
    text = text.replace("\t178\t1\t0\t0\t0", "\t178\t1\t10\t-1\t0").replace("\t206\t20\t0\t0\t", "\t206\t20\t0\t1\t")
    (tmp / "mission.waypoints").write_text(text)
    feats: list[dict[str, Any]] = []
    if uncovered is not None:
        feats.append({"type": "Feature", "properties": {"role": "uncovered"}, "geometry": json.loads(shapely.to_geojson(uncovered))})
    (tmp / "plan.geojson").write_text(json.dumps({"type": "FeatureCollection", "features": feats}))
    camera = {"sensor_mm": [23.5, 15.6], "image_px": [6000, 4000], "focal_mm": 16.0, "mount": "landscape"}
    manifest: dict[str, Any] = {"camera": camera, "rules": []}
    if uncovered is not None:
        manifest["coverage"] = {"uncovered_m2": 2 * 600 * 26.0}
        manifest["rules"] = [{"rule": "uncovered-ground", "status": "fail"}]
    (tmp / "manifest.json").write_text(json.dumps(manifest))
    return tmp


def test_coverage_finds_and_matches_unreported_ground(tmp_path: Path) -> None:
    # the area is 200 m deep, the strip 147 m: two 26.5 m bands along its long sides are not photographed
    area = shapely.transform(shapely.box(-280, -100, 280, 100), lambda a: np.column_stack(LOCAL.inv.transform(a[:, 0], a[:, 1])))
    (tmp_path / "a").mkdir()
    cov = il.coverage_gaps(_coverage_dir(tmp_path / "a", None), area, [], 10.0, LOCAL)
    assert cov.photos == 30  # the 600 m line measures 598.8 m to ArduPilot (east-west at 49.4° N): 20 m photos at 0 … 580 m
    assert cov.unreported_count == len(cov.gap_samples) > 100
    assert cov.measured_gap_m2 == pytest.approx(2 * 560 * 26.5, rel=0.15)
    assert np.all(np.abs(cov.gap_samples[:, 1]) > 73.4)
    # reported by the layer, the manifest and the rule: nothing left unreported
    to_ll = lambda a: np.column_stack(LOCAL.inv.transform(a[:, 0], a[:, 1]))  # noqa: E731
    bands = shapely.union_all([shapely.transform(shapely.box(-300, lo, 300, lo + 28), to_ll) for lo in (73.0, -101.0)])
    (tmp_path / "b").mkdir()
    cov = il.coverage_gaps(_coverage_dir(tmp_path / "b", bands), area, [], 10.0, LOCAL)
    assert len(cov.gap_samples) > 100 and cov.reported and cov.unreported_count == 0 and not cov.grossly_overstated
    # a zone in the middle: its margin is not required ground, the rest of the strip is covered
    cov = il.coverage_gaps(tmp_path / "b", area, [_square(0, 0, 20)], 10.0, LOCAL)
    assert cov.required_m2 == pytest.approx(560 * 200 - 40 * 40 - 4 * 40 * 10 - np.pi * 100, rel=0.01)


def test_a_plane_returns_to_its_rally_point_even_when_home_is_nearer(tmp_path: Path) -> None:
    text = _wpl((0, 0), [(22, None, 15, 100), (16, (0, 600), 0, 100), (16, (0, 100), 0, 100), (20, None, 0, 0)])
    rally = _ll(0, 400)
    plan = {"geoFence": {"circles": [], "polygons": []}, "rallyPoints": {"points": [[rally[1], rally[0], 50.0]]}}
    plane = _legs(tmp_path, text, [_square(0, 250, 20)], vehicle="plane", plan=plan)
    assert [(leg.kind, round(leg.worst_m)) for leg in plane.legs][-2:] == [("rtl", 40), ("rtl-loiter", 0)]
    copter = _legs(tmp_path, text, [_square(0, 250, 20)], vehicle="copter", plan=plan)
    assert copter.legs[-1].kind == "rtl" and copter.legs[-1].path.coords[-1] == pytest.approx((0, 0), abs=0.01)


def test_a_leg_in_the_margin_is_measured_apart(tmp_path: Path) -> None:
    text = _wpl((-300, 60), [(22, None, 0, 50), (16, (-200, 60), 0, 50), (16, (200, 60), 0, 50), (21, None, 0, 0)])
    (tmp_path / "mission.waypoints").write_text(text)
    rep = il.legs_inside_zones(tmp_path / "mission.waypoints", [_square(0, 0, 50)], LOCAL, "copter", margin_m=20.0)
    assert rep.violations == []
    # the line at 10 m from the zone crosses its 20 m margin (less 0.5 m) over 100 + 2·sqrt(19.5² - 10²) m
    assert rep.legs[1].in_margin_m == pytest.approx(100 + 2 * np.sqrt(19.5**2 - 10**2), abs=0.3)


def test_a_plane_landing_sequence_is_flown_from_the_last_point(tmp_path: Path) -> None:
    # DO_LAND_START's own position is not flown to; the approach waypoint and the touchdown are
    text = _wpl((0, 0), [(22, None, 15, 100), (16, (0, 600), 0, 100), (189, (0, 0), 0, 0), (16, (300, 300), 0, 30), (21, (0, 0), 0, 0)])
    rep = _legs(tmp_path, text, [_square(150, 450, 20)], vehicle="plane")
    assert [leg.kind for leg in rep.legs] == ["to-first", "land-approach", "land"]  # 600 m: beyond the 373 m climb-out
    assert rep.legs[1].path.coords[0] == pytest.approx((0, 600), abs=0.01)
    assert rep.legs[1].worst_m == pytest.approx(40 * np.sqrt(2), abs=0.1)
