"""Corridors: random centrelines (straight, bent, zig-zag, near-hairpin, several pieces, with
zones across them) planned through the public entry points, and the exported files judged by
checkers that share no code with the planner.

- The corridor is rebuilt here from the centreline and the width alone: rectangles along each
  segment and discs at the bends (the ground within half the width of the line, ends square).
- Photos are where ArduPilot takes them flying the exported `.waypoints` (tests/independent_trigger.py,
  its 50 Hz straight-line distance rule): exactly as many as the manifest's stations.
- Every sampled point of the corridor outside the zones' margins is seen by two photos or more,
  or the plan reports it (tests/independent_legs.py's coverage check); without zones, none is short.
- No leg of any file enters a zone (tests/independent_legs.py's leg check).
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, Phase, event, example, given, settings
from hypothesis import strategies as hs

import independent_legs as il
import independent_trigger as it
from aerosurvey.errors import InputError
from aerosurvey.inputs import plan_from_files
from aerosurvey.outputs import write_outputs
from aerosurvey.spec import load_spec

EXAMPLES = int(os.environ.get("AEROSURVEY_CORRIDOR_EXAMPLES", "12"))
ORIGIN = (15.3, 49.5)
LOCAL = il.Local(*ORIGIN)


def _lonlat(xy: np.ndarray) -> list[list[float]]:
    lon, lat = LOCAL.inv.transform(xy[:, 0], xy[:, 1])
    return [[float(a), float(b)] for a, b in zip(lon, lat)]


def corridor_ground(pieces: list[np.ndarray], half: float) -> shapely.Geometry:
    """The ground within `half` of the centreline, square at its ends (local metres)."""
    parts = []
    for xy in pieces:
        for a, b in zip(xy[:-1], xy[1:]):
            u = (b - a) / np.hypot(*(b - a))
            n = np.array([-u[1], u[0]]) * half
            parts.append(shapely.Polygon([a + n, b + n, b - n, a - n]))
        parts += [shapely.Point(p).buffer(half, 64) for p in xy[1:-1]]
    return shapely.union_all(parts)


def _write(folder: Path, pieces: list[np.ndarray], width: float, vehicle: str, zones: list[shapely.Geometry],
           battery_min: float | None) -> Path:
    geoms = [{"type": "Feature", "properties": {}, "geometry": {"type": "LineString", "coordinates": _lonlat(p)}} for p in pieces]
    (folder / "line.geojson").write_text(json.dumps({"type": "FeatureCollection", "features": geoms}))
    for i, z in enumerate(zones):
        ll = shapely.transform(z, lambda a: np.column_stack(LOCAL.inv.transform(a[:, 0], a[:, 1])))
        (folder / f"zone{i}.geojson").write_text(shapely.to_geojson(ll))
    speed = 10.0 if vehicle == "copter" else 18.0
    text = f"""
[mission]
name = "corridor"
[area]
file = "line.geojson"
exclusions = {json.dumps([f"zone{i}.geojson" for i in range(len(zones))])}
[pattern]
kind = "corridor"
width_m = {width}
[camera]
model = "sony-a6000-16mm"
trigger = "distance"
[targets]
gsd_cm = 2.0
forward_overlap = 0.75
side_overlap = 0.6
images_beyond_boundary = 2
[vehicle]
type = "{vehicle}"
cruise_speed_ms = {speed}
[flight]
exclusion_margin_m = 10
"""
    if battery_min:  # launch points along the corridor: at each vertex of the centreline
        points = [p for xy in pieces for p in _lonlat(xy)]
        text += f"[battery]\nusable_min = {battery_min}\nreserve = 0.2\nlaunch_points = {json.dumps(points)}\n"
    spec = folder / "spec.toml"
    spec.write_text(text)
    return spec


@hs.composite
def centrelines(draw: hs.DrawFn) -> list[np.ndarray]:
    """One to three pieces of 2–7 segments, 150–900 m each, turning up to 160° at a bend."""
    pieces = []
    start = np.array([0.0, 0.0])
    for _ in range(draw(hs.integers(1, 3))):
        heading = draw(hs.floats(0, 2 * math.pi))
        pts = [start]
        for _ in range(draw(hs.integers(1, 6))):
            length = draw(hs.floats(150, 900))
            pts.append(pts[-1] + length * np.array([math.sin(heading), math.cos(heading)]))
            heading += math.radians(draw(hs.floats(-160, 160)))
        pieces.append(np.array(pts))
        start = pts[-1] + np.array([draw(hs.floats(-2000, 2000)), draw(hs.floats(300, 2000))])
    return pieces


def _judge(out: Path, pieces: list[np.ndarray], width: float, zones: list[shapely.Geometry]) -> list[str]:
    problems = []
    manifest = json.loads((out / "manifest.json").read_text())
    files = sorted(out.glob("sortie-*.waypoints")) or [out / "mission.waypoints"]
    flown = sum(len(it.replay(f)) for f in files)
    if flown != len(manifest["stations"]):
        problems.append(f"ArduPilot takes {flown} photos, the manifest lists {len(manifest['stations'])}")
    local = LOCAL
    ground = corridor_ground(pieces, width / 2.0)
    ground_ll = shapely.transform(ground, lambda a: np.column_stack(LOCAL.inv.transform(a[:, 0], a[:, 1])))
    zones_ll = [shapely.transform(z, lambda a: np.column_stack(LOCAL.inv.transform(a[:, 0], a[:, 1]))) for z in zones]
    cov = il.coverage_gaps(out, ground_ll, zones_ll, 10.0, local)
    if cov.unreported_count:
        problems.append(f"{cov.unreported_count} of {cov.samples} sampled points seen by fewer than two photos and not reported, "
                        f"first at {cov.unreported[0].tolist()}")
    if not zones and len(cov.gap_samples):
        problems.append(f"{len(cov.gap_samples)} sampled points seen by fewer than two photos without any zone")
    for f in il.check_legs(out, zones_ll, local, "copter", margin_m=10.0):
        problems += [f"{f.file}: leg to item {leg.item} enters a zone" for leg in f.violations]
    return problems


@pytest.mark.slow
@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
          phases=[Phase.explicit, Phase.reuse, Phase.generate])
@given(pieces=centrelines(), width=hs.sampled_from([40.0, 150.0, 320.0]), vehicle=hs.sampled_from(["copter", "plane"]),
       zone=hs.booleans(), battery=hs.sampled_from([None, 12.0]))
# a centreline that loops back (west, south-east, then north, over a 151 m step): made one corner there, it cut the
# loop off its corridor (121 points seen by fewer than two photos); a loop is the centreline's own shape, kept
@example(pieces=[np.array([[0.0, 0.0], [9.67234134e-21, 250.0], [-270.637865, 483.62836], [301.82172, 552.214692]]),
                 np.array([[137.43304148, 1612.99875477], [288.58039368, 1376.74483817], [741.92200594, 1393.96234805],
                           [1048.86519533, 1405.61977648], [880.95023461, 1053.64388544]]),
                 np.array([[880.95023461, 2111.34521251], [880.95023461, 2807.27111023], [161.70457713, 2829.0874841],
                           [-460.37437371, 2847.95823873], [-350.24256553, 2744.6529396], [-397.91520384, 2979.87051166],
                           [-447.50331383, 3224.53905207]])],
         width=320.0, vehicle="plane", zone=False, battery=None)
def test_random_corridors_are_covered_and_counted(tmp_path_factory: pytest.TempPathFactory, pieces: list[np.ndarray],
                                                  width: float, vehicle: str, zone: bool, battery: float | None) -> None:
    folder = tmp_path_factory.mktemp("corridor")
    zones = []
    if zone:  # a square across the first piece's middle
        a, b = pieces[0][0], pieces[0][1]
        zones = [shapely.Point((a + b) / 2).buffer(40.0, cap_style="square")]
    spec = _write(folder, pieces, width, vehicle, zones, battery)
    try:
        loaded = load_spec(spec)
        write_outputs(plan_from_files(loaded), loaded, folder / "out")
    except InputError as exc:
        assert zone, f"refused without a zone: {exc}"
        event("refused: a zone across the corridor")
        return
    event(f"{vehicle}, {len(pieces)} piece(s), {'a zone' if zone else 'no zone'}, {'sorties' if battery else 'one flight'}")
    problems = _judge(folder / "out", pieces, width, zones)
    assert not problems, f"files in {folder}:\n" + "\n".join(problems[:20])


def test_a_narrow_corridor_is_one_strip_down_the_middle(tmp_path: Path) -> None:
    pieces = [np.array([[0.0, 0.0], [600.0, 0.0], [900.0, 400.0]])]
    spec = _write(tmp_path, pieces, 40.0, "copter", [], None)
    loaded = load_spec(spec)
    write_outputs(plan_from_files(loaded), loaded, tmp_path / "out")
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert {line["line"] for line in manifest["lines"]} == {"P1-L001"}  # one strip (split at the 53° bend)
    assert not _judge(tmp_path / "out", pieces, 40.0, [])


def test_asymmetric_widths_cover_each_side(tmp_path: Path) -> None:
    """left_m and right_m: the strips reach 120 m to the left and 10 m to the right of the line."""
    xy = np.array([[0.0, 0.0], [0.0, 800.0]])  # northwards: left is west (−x)
    _write(tmp_path, [xy], 10.0, "copter", [], None)
    spec = tmp_path / "spec.toml"
    spec.write_text(spec.read_text().replace("width_m = 10.0", "left_m = 120\nright_m = 10"))
    loaded = load_spec(spec)
    write_outputs(plan_from_files(loaded), loaded, tmp_path / "out")
    ground = shapely.box(-120.0, 0.0, 10.0, 800.0)
    cov = il.coverage_gaps(tmp_path / "out", shapely.transform(ground, lambda a: np.column_stack(LOCAL.inv.transform(a[:, 0], a[:, 1]))),
                           [], 10.0, LOCAL)
    assert not len(cov.gap_samples)
