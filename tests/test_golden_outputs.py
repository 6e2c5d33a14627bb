"""The examples plan what was recorded (tests/golden.py): mission items, lines, sorties, derived
values, estimates and rule verdicts compared by meaning, within stated tolerances."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest

from golden import EXAMPLES, RECORDING, differences, plan_example, read_plan

RECORDED = json.loads(RECORDING.read_text(encoding="utf-8"))


@pytest.mark.parametrize("example", EXAMPLES)
def test_example_plans_what_was_recorded(example: str, tmp_path: Path) -> None:
    got = read_plan(plan_example(example, tmp_path / example))
    diff = differences(got, RECORDED[example])
    assert not diff, f"{example}: {len(diff)} difference(s) from tests/data/golden_examples.json:\n" + "\n".join(diff[:30])


def test_the_comparison_sees_a_moved_waypoint_and_a_changed_count() -> None:
    want = RECORDED["obratan-72ha"]
    got = copy.deepcopy(want)
    name = sorted(got["waypoints"])[0]
    got["waypoints"][name][5][8] += 3e-7  # ~3 cm north
    got["estimates"]["photos"] += 1
    diff = differences(got, want)
    assert any(d.startswith(f"{name} item 5:") for d in diff) and any("estimates.photos" in d for d in diff), diff
    same = copy.deepcopy(want)
    same["waypoints"][name][5][8] += 5e-8  # within the tolerance
    assert differences(same, want) == []
