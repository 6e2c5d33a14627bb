"""`aerosurvey upload` reads a plan's rally points and says they are not uploaded (not silently dropped)."""

from __future__ import annotations

import json
from pathlib import Path

from aerosurvey.commands.upload import read_mission
from aerosurvey.inputs import plan_from_files
from aerosurvey.outputs import render_outputs
from aerosurvey.spec import load_spec

ROOT = Path(__file__).resolve().parents[1]


def test_rally_points_are_read_and_named(tmp_path: Path, capsys) -> None:
    files = render_outputs(plan_from_files(load_spec(ROOT / "missions" / "obratan-72ha.toml"))).files
    p = tmp_path / "sortie-01.plan"
    p.write_text(files["sortie-01.plan"])
    m = read_mission(p)
    assert len(m.rally) == len(json.loads(files["sortie-01.plan"])["rallyPoints"]["points"]) == 1
    assert "1 rally point(s) are not uploaded" in capsys.readouterr().err
