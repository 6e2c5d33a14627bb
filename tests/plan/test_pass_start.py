"""flight.pass_start: the pilot chooses where a pass starts; its first run starts at the line end nearest to it."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import pytest
import tomli_w
from click.testing import CliRunner

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_zone_gate import LOCAL, box_ring, lonlat, write_fc  # noqa: E402

from aerosurvey.cli import main  # noqa: E402


def _plan(tmp_path: Path, flight: dict) -> tuple[int, str, Path]:
    write_fc(tmp_path / "area.geojson", box_ring(0, 0, 600, 400))
    spec = {"mission": {"name": "start"}, "area": {"file": "area.geojson", "launch": lonlat(-100, -100)},
            "camera": {"model": "ricoh-gr"}, "targets": {"gsd_cm": 3.0}, "flight": {"heading": 0.0, **flight}}
    (tmp_path / "s.toml").write_text(tomli_w.dumps(spec))
    res = CliRunner().invoke(main, ["plan", str(tmp_path / "s.toml"), "-o", str(tmp_path / "out")])
    return res.exit_code, res.output, tmp_path / "out"


@pytest.mark.parametrize("corner", [(0, 0), (600, 0), (0, 400), (600, 400)])
def test_each_corner_chosen_is_where_the_pass_starts(tmp_path: Path, corner: tuple[float, float]) -> None:
    code, output, out = _plan(tmp_path, {"pass_start": {"1": lonlat(*corner)}})
    assert code == 0, output
    first = json.loads((out / "manifest.json").read_text())["stations"][0]
    x, y = LOCAL.transform(first["lon"], first["lat"], direction="INVERSE")
    ends = [(x0, y0) for x0 in (0, 600) for y0 in (0, 400)]
    # the first station is nearer the chosen corner than any other corner (lines run north-south, photos
    # reach beyond the area's edge): the pass starts at the chosen end of the chosen outer line
    assert min(ends, key=lambda c: math.dist(c, (x, y))) == corner


def test_a_pass_the_plan_does_not_have_is_refused(tmp_path: Path) -> None:
    code, output, out = _plan(tmp_path, {"pass_start": {"2": lonlat(0, 0)}})
    assert code == 2 and "flight.pass_start.2" in output and "the plan has pass 1" in output
    assert not out.exists()
    code, output, _ = _plan(tmp_path, {"pass_start": {"main": lonlat(0, 0)}})
    assert code == 2 and "flight.pass_start key = 'main' is not allowed" in output.replace("\n", " ")
