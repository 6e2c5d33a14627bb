"""The plan-contract rework changed how planning is wired, not what it plans: the three
examples' files are the ones recorded before it (tests/golden.py says what may differ)."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from aerosurvey.cli import main
from aerosurvey.fileio import LISTING
from golden import normalized_kml, normalized_manifest

ROOT = Path(__file__).resolve().parents[1]
RECORDED = json.loads((ROOT / "tests" / "data" / "golden_outputs.json").read_text())


@pytest.mark.parametrize("example", sorted(RECORDED))
def test_example_outputs_match_the_recording(example: str, tmp_path: Path) -> None:
    out = tmp_path / example
    res = CliRunner().invoke(main, ["plan", str(ROOT / "missions" / f"{example}.toml"), "-o", str(out)])
    assert res.exit_code == 0, res.output
    got = {}
    for f in sorted(p for p in out.iterdir() if p.name != LISTING):
        data = f.read_bytes()
        if f.name == "manifest.json":
            data = normalized_manifest(json.loads(data))
        elif f.name == "plan.kml":
            data = normalized_kml(data)
        got[f.name] = hashlib.sha256(data).hexdigest()
    expected = RECORDED[example]
    assert sorted(got) == sorted(expected)
    differ = [name for name in expected if got[name] != expected[name]]
    assert not differ, f"{example}: {differ} differ from the outputs recorded before the rework"
