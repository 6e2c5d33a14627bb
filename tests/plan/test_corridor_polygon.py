"""A corridor given as a polygon (its centreline derived, plan/centreline.py), planned through the
public entry points and judged as tests/plan/test_corridor.py judges a centreline's plan: the
exported `.waypoints` replayed by ArduPilot's trigger rule (as many photos as the manifest's
stations), and every sampled point of the polygon seen by two photos or more (tests/independent_legs.py).
"""

from __future__ import annotations

import json
import math
import os
import re
from pathlib import Path

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, Phase, example, given, settings
from hypothesis import strategies as hs
from test_corridor import LOCAL
from test_corridor import _write as corridor_spec

import independent_legs as il
import independent_trigger as it
from aerosurvey.errors import InputError
from aerosurvey.inputs import plan_from_files
from aerosurvey.outputs import write_outputs
from aerosurvey.spec import load_spec

EXAMPLES = int(os.environ.get("AEROSURVEY_CORRIDOR_EXAMPLES", "8"))


def _to_lonlat(g: shapely.Geometry) -> shapely.Geometry:
    return shapely.transform(g, lambda a: np.column_stack(LOCAL.inv.transform(a[:, 0], a[:, 1])))


def _write(folder: Path, polygon: shapely.Geometry, pattern: str) -> Path:
    """test_corridor's spec (copter, distance trigger, 2 cm, 75/60 % overlaps) over the polygon (local
    metres) in place of its centreline, with `pattern`'s lines in place of its width."""
    spec = corridor_spec(folder, [np.array([[0.0, 0.0], [1.0, 0.0]])], 100.0, "copter", [], None)
    (folder / "line.geojson").write_text(shapely.to_geojson(_to_lonlat(polygon)))
    text = spec.read_text()
    assert "width_m = 100.0\n" in text
    spec.write_text(text.replace("width_m = 100.0\n", f"{pattern}\n"))
    return spec


def _plan(folder: Path, polygon: shapely.Geometry, pattern: str = "") -> tuple[dict, Path]:
    out = folder / "out"
    loaded = load_spec(_write(folder, polygon, pattern))
    write_outputs(plan_from_files(loaded), loaded, out)
    return json.loads((out / "manifest.json").read_text()), out


def _problems(out: Path, manifest: dict, polygon: shapely.Geometry) -> list[str]:
    problems = []
    flown = len(it.replay(out / "mission.waypoints"))
    if flown != len(manifest["stations"]):
        problems.append(f"ArduPilot takes {flown} photos, the manifest lists {len(manifest['stations'])}")
    cov = il.coverage_gaps(out, _to_lonlat(polygon), [], 10.0, LOCAL)
    if len(cov.gap_samples):
        problems.append(f"{len(cov.gap_samples)} of {cov.samples} sampled points of the polygon seen by fewer than two photos, "
                        f"first at {cov.gap_samples[0].tolist()}")
    return problems


@pytest.mark.slow
@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
          phases=[Phase.explicit, Phase.reuse, Phase.generate])
@given(turns=hs.lists(hs.floats(-80, 80), min_size=1, max_size=3), half=hs.floats(30, 140),
       heading=hs.floats(0, 2 * math.pi))
# a 55.5° bend the derived centreline turned in three steps of 11, 37 and 8° over 39 m, none over the 40° that
# splits the strips: flown round mitred, 4 of 7,715 points of its outside seen by one photo (a CI run, 2026-11-29)
@example(turns=[-40.260068986072596, 55.51781875842454, 58.947001703441], half=54.959654492220594, heading=3.00677092969038)
def test_a_bent_corridor_polygon_is_covered(tmp_path_factory: pytest.TempPathFactory, turns: list[float], half: float,
                                            heading: float) -> None:
    """A road's outline (a bent polyline buffered), no width given: the widths are derived, reported,
    and every point of the outline is photographed twice or more."""
    pts = [np.zeros(2)]
    for turn in [0.0, *turns]:
        heading += math.radians(turn)
        pts.append(pts[-1] + 600.0 * np.array([math.sin(heading), math.cos(heading)]))
    polygon = shapely.LineString(pts).buffer(half)
    folder = tmp_path_factory.mktemp("corridor-polygon")
    manifest, out = _plan(folder, polygon)
    note = [w for w in manifest["warnings"] if w.startswith("centreline derived from the corridor polygon")]
    assert len(note) == 1 and "cover the polygon" in note[0], manifest["warnings"]
    sides = manifest["pattern"]["parameters"]  # the derived widths, as the note gives them
    said = re.search(r"([\d.]+) m to its left and ([\d.]+) m to its right", note[0])
    assert said is not None and abs(float(said[1]) - sides["left_m"]) <= 0.051 and abs(float(said[2]) - sides["right_m"]) <= 0.051
    # the outline is `half` from the line buffered, and the derived line within its stated simplification of that
    # line (a buffered polyline's medial axis is the polyline): each side reaches at least `half` less that
    tol = re.search(r"simplified within ([\d.]+) m", note[0])
    assert tol is not None, note[0]
    assert min(sides["left_m"], sides["right_m"]) >= half - float(tol[1]) - 0.5
    problems = _problems(out, manifest, polygon)
    assert not problems, f"files in {folder}:\n" + "\n".join(problems)


def test_a_straight_polygon_with_its_width_given(tmp_path: Path) -> None:
    """A 1.2 km by 120 m strip with width_m = 124: the spec's width is flown, the note says it holds
    all of the polygon, and the polygon is covered."""
    polygon = shapely.box(0, 0, 1200, 120)
    manifest, out = _plan(tmp_path, polygon, "width_m = 124")
    note = [w for w in manifest["warnings"] if w.startswith("centreline derived from the corridor polygon")]
    assert len(note) == 1 and "holds 100.0 % of the polygon" in note[0], manifest["warnings"]
    assert manifest["pattern"]["parameters"] == {"left_m": 62.0, "right_m": 62.0}  # the spec's
    assert not _problems(out, manifest, polygon)


def test_each_part_of_a_multipolygon_is_a_pass(tmp_path: Path) -> None:
    """Two strips 1 km apart: a centreline each, flown as a pass each, both covered."""
    strips = shapely.MultiPolygon([shapely.box(0, 0, 1000, 80), shapely.box(0, 1000, 80, 2200)])
    manifest, out = _plan(tmp_path, strips)
    assert {line["pass"] for line in manifest["lines"]} == {1, 2}
    assert not _problems(out, manifest, strips)


def test_a_y_shaped_polygon_is_refused_naming_the_file(tmp_path: Path) -> None:
    arms = [shapely.LineString([(0, 0), (0, 800)]), shapely.LineString([(0, 800), (-500, 1400)]),
            shapely.LineString([(0, 800), (500, 1400)])]
    with pytest.raises(InputError, match=r"^area.file '.*line.geojson': the corridor polygon branches") as exc:
        _plan(tmp_path, shapely.union_all([a.buffer(40) for a in arms]))
    assert "\n" not in str(exc.value)


def test_a_line_without_a_width_is_refused(tmp_path: Path) -> None:
    spec = _write(tmp_path, shapely.box(0, 0, 1200, 120), "")
    (tmp_path / "line.geojson").write_text(shapely.to_geojson(_to_lonlat(shapely.LineString([(0, 0), (1200, 0)]))))
    with pytest.raises(InputError, match="holds a centreline: .* needs width_m"):
        plan_from_files(load_spec(spec))
