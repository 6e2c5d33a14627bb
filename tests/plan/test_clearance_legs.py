"""Terrain clearance along every leg (mission/clearance.py), on DEMs the tests write: a narrow
ridge between two waypoints of a line, a hill under a plane's turn. The waypoints alone clear
the terrain; the legs do not, and the plan is refused naming the leg. Ground heights come from
the test's own sampler (tests/independent_terrain.py), the flown heights from the flight program."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from aerosurvey.airspace.legs import flight_legs
from aerosurvey.errors import CheckFailed
from aerosurvey.inputs import plan_from_files
from aerosurvey.outputs import mission_programs, write_outputs
from aerosurvey.spec import load_spec
from conftest import make_spec
from independent_terrain import TestDem

WEST, NORTH, CELL, SIZE = 499_300.0, 5_472_700.0, 5.0, 340
GROUND = 400.0
REFUSAL = re.compile(r"(?P<flight>[\w-]+): the leg to point (?P<seq>\d+) \((?P<what>[^)]+)\) passes (?P<clear>-?[\d.]+) m above "
                     r"the terrain (?P<along>[\d.]+) m along it \(terrain (?P<terrain>[\d.]+) m, flown at (?P<flown>[\d.]+) m")


def _flat() -> TestDem:
    return TestDem(np.full((SIZE, SIZE), GROUND), WEST, NORTH, CELL)


def _spec(tmp: Path, dem: TestDem, vehicle: str, mode: str, battery_min: float | None = None) -> Path:
    dem.write(tmp / "dem.tif")
    speed = 10.0 if vehicle == "copter" else 18.0
    battery = {"battery": {"usable_min": battery_min}} if battery_min else {}
    return make_spec(tmp, {"terrain": {"dem": "dem.tif", "mode": mode, "min_clearance_m": 20.0},
                           "vehicle": {"type": vehicle, "cruise_speed_ms": speed}, **battery})


def _legs(plan):
    s = plan.site
    return flight_legs(mission_programs(plan)["mission"], "mission", s.planar, 0.0, s.grid_scale)


def _waypoint_clearances(plan, dem: TestDem) -> np.ndarray:
    """Each waypoint's height above the test's ground: the check this module goes beyond."""
    p = mission_programs(plan)["mission"]
    x, y = plan.site.planar.xy(np.array([w.lon for w in p.waypoints]), np.array([w.lat for w in p.waypoints]))
    return np.array([w.alt_m for w in p.waypoints]) + p.home[2] - dem.ground(x, y)


def _refusal(plan, spec: Path, out: Path) -> list[dict[str, str]]:
    with pytest.raises(CheckFailed) as e:
        write_outputs(plan, load_spec(spec), out)
    assert not out.exists()
    return [m.groupdict() for m in REFUSAL.finditer(str(e.value))]


@pytest.mark.parametrize("battery_min", [None, 8.0])
def test_a_ridge_between_two_stations_of_a_line_is_refused_naming_the_leg(tmp_path: Path, battery_min: float | None) -> None:
    """Without a battery the one flight (mission) is named; with one, the whole mission and the sortie that flies the
    line, each with its own leg."""
    flat = _flat()
    plan = plan_from_files(load_spec(_spec(tmp_path, flat, "copter", "follow", battery_min)))
    legs = _legs(plan)
    # the longest leg along a line, and the middle of two of its stations
    i = max((j for j, leg in enumerate(legs) if re.search(r"-S\d+$", leg.leg.what)),
            key=lambda j: math.dist(legs[j].leg.start, legs[j].leg.end))
    leg = legs[i].leg
    st = plan.stations
    a, b = np.array(leg.start), np.array(leg.end)
    rel = np.column_stack([st.x, st.y]) - a
    on = np.flatnonzero(np.abs((b - a)[0] * rel[:, 1] - (b - a)[1] * rel[:, 0]) / np.linalg.norm(b - a) < 0.01)
    t = np.sort(((np.column_stack([st.x[on], st.y[on]]) - a) @ (b - a)) / ((b - a) @ (b - a)))
    t = t[(t > 0) & (t < 1)]
    mid = a + 0.5 * (t[len(t) // 2] + t[len(t) // 2 + 1]) * (b - a)
    row, col = flat.cell_of(*mid)
    ridge = _flat()
    ridge.heights[row, col] = GROUND + 200.0  # one cell: a mast, or the narrowest ridge the DEM can hold
    tmp2 = tmp_path / "ridge"
    tmp2.mkdir()
    spec = _spec(tmp2, ridge, "copter", "follow", battery_min)
    plan2 = plan_from_files(load_spec(spec))
    # the same stations and heights: the photo stations lie a cell and more from the ridge
    assert np.array_equal(plan2.stations.x, st.x) and np.array_equal(plan2.stations.alt_rel_m, st.alt_rel_m)
    # every waypoint clears the terrain by the minimum: a check at the waypoints passes
    assert _waypoint_clearances(plan2, ridge).min() >= 20.0 - 1e-6
    flown = GROUND + legs[i].alt_start[0]
    path = np.array([leg.start, leg.end])
    lowest = ridge.lowest_on(path, np.array([flown, flown]))
    assert lowest < 20.0
    found = _refusal(plan2, spec, tmp2 / "out")
    assert len(found) == (1 if battery_min is None else 2)
    f = found[0]
    assert (f["flight"], int(f["seq"]), f["what"]) == ("mission", leg.seq, leg.what)
    if battery_min is not None:
        assert len(plan2.sorties) > 1
        s = found[1]
        programs = mission_programs(plan2)
        assert s["flight"] != "mission" and s["flight"] in programs
        sortie_legs = flight_legs(programs[s["flight"]], s["flight"], plan2.site.planar, 0.0, plan2.site.grid_scale)
        named = sortie_legs[[j for j, x in enumerate(sortie_legs) if x.leg.seq == int(s["seq"])][0]].leg
        assert named.what == leg.what and np.allclose(named.end, leg.end)
        assert (s["clear"], s["terrain"]) == (f["clear"], f["terrain"])
    assert float(f["clear"]) == pytest.approx(lowest, abs=0.06)
    assert float(f["flown"]) == pytest.approx(flown, abs=0.06)
    assert float(f["terrain"]) == pytest.approx(flown - lowest, abs=0.06)
    cx, cy = ridge.centre(row, col)
    assert float(f["along"]) == pytest.approx(float((np.array([cx, cy]) - a) @ (b - a) / np.linalg.norm(b - a)),
                                              abs=CELL / 2 + 0.5)


def test_a_hill_under_a_planes_turn_is_refused_naming_the_turn(tmp_path: Path) -> None:
    flat = _flat()
    plan = plan_from_files(load_spec(_spec(tmp_path, flat, "plane", "fixed")))
    legs = _legs(plan)
    # the leg from a line's lead-in onto the line: the plane comes from the line before, and turns round here
    i = next(j for j in range(2, len(legs)) if legs[j - 1].leg.what.endswith(":lead-in")
             and legs[j - 2].leg.what.endswith(":end"))
    before, turn = legs[i - 1].leg, legs[i].leg
    p0, p1 = np.array(turn.start), np.array(turn.end)
    v = np.array(before.end) - np.array(before.start)
    v /= np.linalg.norm(v)
    assert v @ (p1 - p0) < 0  # more than a quarter turn
    side = math.copysign(1.0, v[0] * (p1 - p0)[1] - v[1] * (p1 - p0)[0])
    n = side * np.array([-v[1], v[0]])
    r = plan.sensor.turn_radius_m * plan.site.grid_scale
    # a plane turning more than a quarter turn at radius r from the lead-in passes here
    apex = p0 + r * v + r * n
    hill = _flat()
    flown = GROUND + legs[i].alt_start[0]
    # the four cells round the apex: the ground is flat at their height in the square between their centres
    row, col = hill.cell_of(*apex)
    r0 = row if hill.centre(row, col)[1] >= apex[1] else row - 1
    c0 = col if hill.centre(row, col)[0] <= apex[0] else col - 1
    hill.heights[r0:r0 + 2, c0:c0 + 2] = flown - 10.0
    assert hill.ground(np.array([apex[0]]), np.array([apex[1]]))[0] == pytest.approx(flown - 10.0)
    # the straight legs clear it: a check along the legs' chords passes
    assert hill.lowest_on(np.array([p0, p1]), np.array([flown, flown])) >= 20.0
    assert hill.lowest_on(np.array([before.start, before.end]), np.array([flown, flown])) >= 20.0
    tmp2 = tmp_path / "hill"
    tmp2.mkdir()
    spec = _spec(tmp2, hill, "plane", "fixed")
    plan2 = plan_from_files(load_spec(spec))
    assert np.array_equal(plan2.stations.alt_rel_m, plan.stations.alt_rel_m)
    assert _waypoint_clearances(plan2, hill).min() >= 20.0 - 1e-6
    found = _refusal(plan2, spec, tmp2 / "out")
    assert [(f["flight"], int(f["seq"]), f["what"]) for f in found] == [("mission", turn.seq, turn.what)]
    assert float(found[0]["terrain"]) == pytest.approx(flown - 10.0, abs=0.06)
    assert float(found[0]["clear"]) == pytest.approx(10.0, abs=0.06)


@pytest.mark.parametrize("vehicle,mode", [("copter", "follow"), ("plane", "fixed"), ("copter", "terrain-frame")])
def test_the_lowest_clearance_of_each_flight_is_recorded(tmp_path: Path, vehicle: str, mode: str) -> None:
    """On flat ground every leg off the take-off and landing flies the survey's height (or more) above it."""
    spec = _spec(tmp_path, _flat(), vehicle, mode)
    plan = plan_from_files(load_spec(spec))
    write_outputs(plan, load_spec(spec), tmp_path / "out")
    m = json.loads((tmp_path / "out" / "manifest.json").read_text())
    rec = m["clearance"]
    assert rec["min_clearance_m"] == 20.0 and rec["below"] == [] and rec["dem"] == "dem.tif"
    [low] = rec["flights"]
    assert low["flight"] == "mission"
    assert low["ground_m"] == pytest.approx(GROUND, abs=1e-3)
    lowest_flown = min(min(leg.alt_start[0], leg.alt_end[0]) for leg in _legs(plan)
                       if leg.leg.what not in ("takeoff", "climb-out", "land", "descent", "rtl-descent"))
    assert low["clearance_m"] == pytest.approx(lowest_flown, abs=0.01)
    [rule] = [r for r in m["rules"] if r["rule"] == "terrain-clearance"]
    assert rule["status"] == "pass" and rule["profile"] == "plan"


@pytest.mark.parametrize("keep", [0.2, 0.5])
def test_a_truncated_dem_is_a_one_line_error(tmp_path: Path, keep: float) -> None:
    """A DEM cut short (a copy stopped part way) through the rows round the area: its header may still open, its
    cells there do not read."""
    from aerosurvey.errors import InputError
    from aerosurvey.inputs import load_inputs

    spec = load_spec(_spec(tmp_path, TestDem(np.random.default_rng(1).normal(400.0, 30.0, (SIZE, SIZE)), WEST, NORTH,
                                             CELL), "copter", "follow"))
    data = (tmp_path / "dem.tif").read_bytes()
    (tmp_path / "dem.tif").write_bytes(data[:int(len(data) * keep)])
    with pytest.raises(InputError, match=r"^terrain.dem: '.*dem.tif' cannot be (opened as a raster|read): ") as e:
        load_inputs(spec)
    assert "\n" not in str(e.value)
