"""mission.plan with QGroundControl Survey items (`aerosurvey plan --qgc survey`, the default):
QGroundControl's loader rules hold, the stored Items are the items `--qgc items` writes, our
reader reads both alike, and QGroundControl's generator (ported in tests/independent_qgc.py)
regenerates our lines from the settings written: same lines, same order and directions, same
ends, same photo count, within 1 cm (positions are written to 1e-8°, about 1 mm).
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st
from mission_strategies import canon

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import independent_qgc as qgc  # noqa: E402
from aerosurvey import ids  # noqa: E402
from aerosurvey.cli import main  # noqa: E402
from aerosurvey.mission import mavlink_ids as mav  # noqa: E402
from aerosurvey.mission.formats.qgc_plan import loads_plan  # noqa: E402
from aerosurvey.mission.formats.qgc_survey import survey_blocks, survey_geometry, survey_shapes  # noqa: E402
from aerosurvey.mission.items import Mission, MissionItem  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ["obratan-72ha", "kubad-abad-fixed-wing", "forest-dem", "oblique-block", "road-corridor"]
CORRIDOR_VERTEX_M = 12.0  # QGC's corridor transects' vertices from our runs (measured 8.8 m on the road example)
TOL_M = 0.01


@pytest.fixture(scope="module")
def planned(tmp_path_factory: pytest.TempPathFactory) -> dict[str, dict[str, Path]]:
    """Each example planned with both layouts."""
    out: dict[str, dict[str, Path]] = {}
    for ex in EXAMPLES:
        out[ex] = {}
        for layout in ("survey", "items"):
            folder = tmp_path_factory.mktemp(f"{ex}-{layout}")
            res = CliRunner().invoke(main, ["plan", str(ROOT / "missions" / f"{ex}.toml"), "-o", str(folder), "--qgc", layout])
            assert res.exit_code == 0, res.output
            out[ex][layout] = folder
    return out


def _plans(folder: Path) -> list[Path]:
    return sorted(folder.glob("*.plan"))


def _doc(path: Path) -> dict:
    return json.loads(path.read_text(encoding="utf-8"))


def _surveys(doc: dict) -> list[dict]:
    return [it for it in doc["mission"]["items"] if it["type"] == "ComplexItem"]


@pytest.mark.parametrize("example", EXAMPLES)
def test_every_plan_keeps_qgroundcontrols_loader_rules(planned, example: str) -> None:
    for layout, folder in planned[example].items():
        for path in _plans(folder):
            doc = _doc(path)
            assert qgc.plan_problems(doc) == [], f"{layout}/{path.name}"
            assert bool(_surveys(doc)) == (layout == "survey"), f"{layout}/{path.name}"


@pytest.mark.parametrize("example", EXAMPLES)
def test_survey_items_store_the_items_written_otherwise(planned, example: str) -> None:
    for path in _plans(planned[example]["survey"]):
        got = qgc.uploaded_items(_doc(path))
        want = _doc(planned[example]["items"] / path.name)["mission"]["items"]
        assert len(got) == len(want), path.name
        for k, (a, b) in enumerate(zip(got, want, strict=True), start=1):
            where = f"{path.name} item {k}"
            for key in ("type", "command", "frame", "autoContinue", "doJumpId", "aerosurveyTag"):
                assert a.get(key) == b.get(key), f"{where} {key}"
            for x, y in zip(a["params"], b["params"], strict=True):
                assert (x is None and y is None) or math.isclose(x, y, rel_tol=0, abs_tol=1e-9), f"{where} params"
        # and the reader takes both files to the same mission
        assert canon(loads_plan(path.read_text(), path.name)) == \
            canon(loads_plan((planned[example]["items"] / path.name).read_text(), path.name))


@pytest.mark.parametrize("example", EXAMPLES)
def test_qgroundcontrol_regenerates_our_lines(planned, example: str) -> None:
    doc = _doc(planned[example]["survey"] / "mission.plan")
    for survey in _surveys(doc):
        if survey["complexItemType"] == "CorridorScan":
            paths = qgc.flown_paths(survey["TransectStyleComplexItem"]["Items"])
            lines = len({it["aerosurveyTag"][:7] for it in survey["TransectStyleComplexItem"]["Items"]})
            got = qgc.compare_corridor(survey, paths, lines)
            assert got["qgc_transects"] == lines, got
            # QGC's transects bend where ours do; ours run on past sharp bends and the ends, so QGC takes fewer photos
            assert got["max_qgc_vertex_from_ours_m"] <= CORRIDOR_VERTEX_M, got
            assert got["qgc_shots"] <= got["written_shots"], got
            continue
        got = qgc.compare(survey, qgc.flown_lines(survey["TransectStyleComplexItem"]["Items"]))
        assert got["qgc_transects"] == got["our_lines"] == got["our_runs"], got
        assert got["qgc_spacing_m"] == pytest.approx(got["our_spacing_m"], abs=TOL_M)
        assert got["max_across_m"] <= TOL_M and got["max_end_m"] <= TOL_M, got
        assert got["same_order_m"] <= TOL_M, got  # flown in the same order, each the same way
        assert got["qgc_shots"] == got["written_shots"], got


@pytest.mark.parametrize("example", EXAMPLES)
def test_a_sorties_survey_regenerates_its_whole_pass(planned, example: str) -> None:
    """A sortie's Survey holds the sortie's items and the whole pass's settings: an edit rebuilds the whole pass."""
    whole = {s["TransectStyleComplexItem"]["Items"][0]["aerosurveyTag"][:2]: s
             for s in _surveys(_doc(planned[example]["survey"] / "mission.plan"))}
    shots: dict[str, int] = {}
    for path in sorted(planned[example]["survey"].glob("sortie-*.plan")):
        for s in _surveys(_doc(path)):
            key = s["TransectStyleComplexItem"]["Items"][0]["aerosurveyTag"][:2]
            for field in set(s) - {"TransectStyleComplexItem"}:
                assert s[field] == whole[key][field], f"{path.name} {field}"
            shots[key] = shots.get(key, 0) + s["TransectStyleComplexItem"]["CameraShots"]
    if shots:  # the sorties' photos add up to the pass's
        assert shots == {k: s["TransectStyleComplexItem"]["CameraShots"] for k, s in whole.items()}


def test_items_layout_is_chosen_on_the_command_line(planned) -> None:
    res = CliRunner().invoke(main, ["plan", str(ROOT / "missions" / "forest-dem.toml"), "-o", "x", "--qgc", "flat"])
    assert res.exit_code == 2 and "'flat' is not one of 'survey', 'items'" in res.output


def test_survey_blocks_hold_a_pass_with_the_detours_between_its_lines() -> None:
    def wp(tag: str) -> MissionItem:
        return MissionItem(mav.NAV_WAYPOINT, 3, 0, 0, 0, 0, 1.0, 1.0, 50.0, tag=tag)

    tags = ["takeoff", "speed", "transit", "P1-L001-R1:lead-in", "P1-L001-S0001", "P1-L001-R1:camera-on", "P1-L001-R1:end",
            "detour", "detour", "P1-L002-R1:lead-in", "P1-L002-R1:end", "detour", "P2-L001-R1:lead-in", "P2-L001-R1:end",
            "transit", "rtl"]
    m = Mission("copter", "ardupilot", (1.0, 1.0, 0.0), tuple(wp(t) for t in tags), 5.0, 5.0)
    assert survey_blocks(m) == [(1, 3, 10), (2, 12, 13)]
    assert [ids.pass_of(t) for t in ("P12-L003-S0042", "P1-L003", "detour", "P1-Lx", "sortie")] == [12, 1, None, None, None]


# ---------------------------------------------------------------- geometry over random passes


class _Pass:
    """A stand-in for a Plan (hashable by identity, as Plan is): its route's runs, waypoints and spacing, one pass of lines in a frame."""

    def __init__(self, runs: list[SimpleNamespace], waypoints: list[SimpleNamespace], spacing: float) -> None:
        self.route = SimpleNamespace(runs=runs)
        self.waypoints = waypoints
        self.sensor = SimpleNamespace(spacing_m=spacing)
        self.layout = SimpleNamespace(passes=[SimpleNamespace(index=1, frame=object())])  # parallel lines in a frame


def _synthetic_plan(lat: float, lon: float, bearing: float, spacing: float, starts: list[float], lengths: list[float],
                    first_at_end: bool, first_reversed: bool, offsets: list[float] | None = None) -> _Pass:
    """A stand-in for a Plan: one pass of lines at `bearing`, `spacing` apart (or at `offsets`
    across), flown as a lawnmower, positions made with the port's projection on a plane at (lat, lon)."""
    a = math.radians(bearing)
    along, across = np.array([math.sin(a), math.cos(a)]), np.array([math.cos(a), -math.sin(a)])
    n = len(starts)
    order = list(range(n))[::-1] if first_at_end else list(range(n))
    runs, wps = [], []
    for k, line in enumerate(order):
        ends = [starts[line], starts[line] + lengths[line]]
        if (k % 2 == 1) != first_reversed:
            ends = ends[::-1]
        runs.append(SimpleNamespace(pass_index=1, line=line))
        for kind, u in zip(("line_start", "line_end"), ends, strict=True):
            e, nn = u * along + (line * spacing if offsets is None else offsets[line]) * across
            la, lo = qgc.from_plane(float(e), float(nn), lat, lon)
            wps.append(SimpleNamespace(kind=kind, run=k, lon=lo, lat=la))
    return _Pass(runs, wps, spacing)


@settings(max_examples=60, deadline=None)
@given(lat=st.floats(-60, 60), lon=st.floats(-179, 179), bearing=st.floats(0, 360, exclude_max=True),
       spacing=st.floats(8, 150), n=st.integers(1, 25), data=st.data(),
       first_at_end=st.booleans(), first_reversed=st.booleans())
def test_qgroundcontrol_regenerates_any_lawnmower(lat, lon, bearing, spacing, n, data, first_at_end, first_reversed) -> None:
    starts = data.draw(st.lists(st.floats(-300, 0), min_size=n, max_size=n))
    lengths = data.draw(st.lists(st.floats(30, 1500), min_size=n, max_size=n))
    plan = _synthetic_plan(lat, lon, bearing, spacing, starts, lengths, first_at_end, first_reversed)
    ring, strips = survey_geometry(plan, 1)
    entry = 2 * strips.reverse_points + strips.reverse_lines
    survey = {"polygon": [[la, lo] for lo, la in ring], "angle": strips.angle, "entryLocation": entry,
              "flyAlternateTransects": False,
              "TransectStyleComplexItem": {"CameraCalc": {"AdjustedFootprintSide": strips.spacing,
                                                          "AdjustedFootprintFrontal": 10.0}}}
    gen = qgc.regenerate(survey)
    ours = [[(w0.lat, w0.lon), (w1.lat, w1.lon)] for w0, w1 in zip(plan.waypoints[::2], plan.waypoints[1::2], strict=True)]
    assert len(gen.transects) == n
    origin = survey["polygon"][0]
    for q_line, o_line in zip(gen.transects, ours, strict=True):
        q_xy = qgc.to_plane(np.array([p[0] for p in q_line]), np.array([p[1] for p in q_line]), *origin)
        o_xy = qgc.to_plane(np.array([p[0] for p in o_line]), np.array([p[1] for p in o_line]), *origin)
        # each QGC line where our run is, end for end: same place, same direction, same order
        assert float(np.abs(q_xy - o_xy).max()) <= TOL_M


def test_a_pass_of_unevenly_spaced_lines_stays_plain_items() -> None:
    """Two bands of lines flown as one pass (an oblique grid's), the second band's lines 0.6 of a
    spacing on from the first's: QGroundControl's generator lays lines evenly, so an edit would
    move them; the pass gets no Survey item. The same lines evenly spaced get one."""
    starts, lengths = [0.0] * 5, [400.0] * 5
    even = _synthetic_plan(49.4, 15.0, 30.0, 40.0, starts, lengths, False, False)
    banded = _synthetic_plan(49.4, 15.0, 30.0, 40.0, starts, lengths, False, False, offsets=[0.0, 40.0, 80.0, 104.0, 144.0])
    assert survey_shapes(even, [1])[1] is not None
    assert survey_shapes(banded, [1])[1] is None
