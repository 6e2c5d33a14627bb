"""The examples' .plan files as Mission Planner reads them: MissionFile.cs (ArduPilot/MissionPlanner,
ExtLibs/Utilities) deserialises a .plan with Newtonsoft.Json into classes whose members are C#
ints, doubles and lists of doubles; a JSON number with a fraction where an int is declared, or a
null in a list of doubles, does not fit. The member types are transcribed here from that file
(read, not run: Mission Planner is a .NET desktop program)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from aerosurvey.inputs import plan_from_files
from aerosurvey.outputs import render_outputs
from aerosurvey.spec import load_spec

ROOT = Path(__file__).resolve().parents[2]

# MissionFile.RootObject / Mission / Item / RallyPoints members and their C# types
ROOT_INTS = ("version",)
MISSION_INTS = ("cruiseSpeed", "firmwareType", "hoverSpeed", "vehicleType", "version")
ITEM_INTS = ("command", "doJumpId", "frame")


def _is_int(v: object) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _is_double(v: object) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


@pytest.fixture(scope="module", params=["obratan-72ha", "forest-dem", "kubad-abad-fixed-wing"])
def plan_files(request) -> dict[str, dict]:
    loaded = load_spec(ROOT / "missions" / f"{request.param}.toml")
    files = render_outputs(plan_from_files(loaded), loaded).files
    return {name: json.loads(text) for name, text in files.items() if name.endswith(".plan")}


def test_members_mission_planner_declares_int_are_whole_numbers(plan_files) -> None:
    for name, doc in plan_files.items():
        assert all(_is_int(doc[k]) for k in ROOT_INTS), name
        mis = doc["mission"]
        for k in MISSION_INTS:
            assert _is_int(mis[k]), f"{name}: mission.{k} = {mis[k]!r}"
        for i, it in enumerate(mis["items"], start=1):
            if it["type"] == "ComplexItem":
                # a Survey item: the members of Item it has fit (version int, polygon List<List<double?>>);
                # ConvertToLocationwps skips ComplexItems: Mission Planner users take the .waypoints
                # or plan with --qgc items (docs/clients/mission-planner.md)
                assert _is_int(it["version"]) and all(_is_double(v) for p in it["polygon"] for v in p), f"{name}: item {i}"
                assert not set(it) & {"command", "doJumpId", "frame", "params", "grid", "camera"}, f"{name}: item {i}"
                continue
            for k in ITEM_INTS:
                assert _is_int(it[k]), f"{name}: item {i} {k} = {it[k]!r}"
            # List<double> params: no null
            assert all(_is_double(v) for v in it["params"]), f"{name}: item {i} params {it['params']}"
        assert all(_is_double(v) for v in mis["plannedHomePosition"])


def test_rally_points_are_lists_of_three_numbers_at_the_launch_sites(plan_files) -> None:
    for name, doc in plan_files.items():
        rally = doc["rallyPoints"]
        assert _is_int(rally["version"]) and rally["version"] == 2
        assert rally["points"], f"{name}: the examples have launch sites, so rally points"
        for p in rally["points"]:
            assert len(p) == 3 and all(_is_double(v) for v in p)
        home = doc["mission"]["plannedHomePosition"]
        # a sortie starts at a launch site: one of the rally points is above its home
        assert any(abs(p[0] - home[0]) < 1e-7 and abs(p[1] - home[1]) < 1e-7 and p[2] > 0 for p in rally["points"]), name
