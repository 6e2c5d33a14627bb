"""End to end in ArduPilot SITL: the example missions fly as planned.

Marked `sitl`; skipped with the reason when no SITL binary is found (AEROSURVEY_SITL_BIN,
or arducopter/arduplane on PATH).
"""

from __future__ import annotations

import json
import os
import shutil

import pytest
from click.testing import CliRunner

from aerosurvey.cli import main
from conftest import REPO


def _binary(vehicle: str) -> str | None:
    name = "arduplane" if vehicle == "plane" else "arducopter"
    env = os.environ.get("AEROSURVEY_SITL_BIN")
    if env:
        path = os.path.join(env, name) if os.path.isdir(env) else env
        return path if os.access(path, os.X_OK) else None
    return shutil.which(name)


@pytest.mark.sitl
@pytest.mark.parametrize("name,vehicle", [("obratan-72ha", "copter"), ("forest-dem", "copter"),
                                          ("kubad-abad-fixed-wing", "plane")])
def test_example_flies_as_planned(name, vehicle, tmp_path):
    binary = _binary(vehicle)
    if binary is None:
        pytest.skip(f"no ArduPilot SITL {vehicle} binary: set AEROSURVEY_SITL_BIN or put it on PATH")
    out = tmp_path / name
    res = CliRunner().invoke(main, ["plan", str(REPO / "missions" / f"{name}.toml"), "-o", str(out)])
    assert res.exit_code == 0, res.output
    res = CliRunner().invoke(main, ["sitl", "fly", str(out), "--sitl-bin", binary, "--speedup", "20"])
    report = json.loads((out / "sitl" / "sitl_report.json").read_text())
    assert res.exit_code == 0, res.output
    for row in report["sorties"]:
        assert row["completed"], row
        if row["triggers_match"] is not None:
            assert row["triggers_flown"] == row["photos_planned"], row
        assert abs(row["time_ratio"] - 1.0) <= 0.10, row
        assert (out / "sitl" / row["log"]).exists()
