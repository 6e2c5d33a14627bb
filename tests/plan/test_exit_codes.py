"""`aerosurvey plan` exits 1 when a rule of error severity fails, with the plan written for
inspection and the reason on its last line; 0 when every such rule passes."""

from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner

from aerosurvey.cli import main

REPO = Path(__file__).resolve().parents[2]


def _spec(tmp_path: Path, side_overlap: str) -> Path:
    text = (REPO / "missions" / "obratan-72ha.toml").read_text(encoding="utf-8")
    area = (REPO / "missions" / "areas" / "obratan-72ha.geojson").as_posix()
    text = text.replace('"areas/obratan-72ha.geojson"', json.dumps(area)).replace("side_overlap = 0.60", f"side_overlap = {side_overlap}")
    p = tmp_path / "spec.toml"
    p.write_text(text, encoding="utf-8")
    return p


def test_a_failing_error_rule_writes_the_plan_and_exits_1(tmp_path: Path):
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["plan", str(_spec(tmp_path, "0.50")), "-o", str(out)])
    assert res.exit_code == 1, res.output
    manifest = json.loads((out / "manifest.json").read_text(encoding="utf-8"))
    failing = [r["rule"] for r in manifest["rules"] if r["status"] == "fail" and r["severity"] == "error"]
    assert "cz-side-overlap" in failing
    last = res.stderr.strip().splitlines()[-1]
    assert last.startswith("Error: ") and "cz-side-overlap" in last and "for inspection" in last
    assert (out / "mission.waypoints").exists()


def test_a_plan_whose_error_rules_pass_exits_0(tmp_path: Path):
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["plan", str(_spec(tmp_path, "0.60")), "-o", str(out)])
    assert res.exit_code == 0, res.output
    manifest = json.loads((out / "manifest.json").read_text(encoding="utf-8"))
    assert not [r for r in manifest["rules"] if r["status"] == "fail" and r["severity"] == "error"]
