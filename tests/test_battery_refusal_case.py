"""A battery refusal from random trials (issue 36): tests/data/cases/battery-refusals/corridor-0059,
a 45 ha V-shaped strip (two 2.4 km arms) that an earlier version split into sorties within the
battery and a later one refused as "battery too small". The time model was the same in both: the
later plan's lines start at the other end of the V, the launch point is the area's edge nearest the
route's start, and the far arm's end lay out of one battery's reach from there (4.3 km each way).

Planned with the command from inside its folder; the exported sortie files are judged here
without the planner: every sortie's path from its launch point through its waypoints and back,
flown at the cruise speed (no turn, no stop: less than any flight takes) with the wind allowance
and the climb, fits the usable battery, and the sorties' photos are the plan's stations.
"""

from __future__ import annotations

import json
import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import independent_coverage as ic
from aerosurvey.cli import main

CASE = Path(__file__).parent / "data" / "cases" / "battery-refusals" / "corridor-0059"


def test_the_v_shaped_strip_is_split_into_sorties_within_the_battery(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    folder = tmp_path / CASE.name
    shutil.copytree(CASE, folder)
    monkeypatch.chdir(folder)
    res = CliRunner().invoke(main, ["plan", "spec.toml", "-o", "out"])
    assert res.exit_code == 0, res.output + repr(res.exception)
    spec = tomllib.loads((folder / "spec.toml").read_text())
    battery, vehicle = spec["battery"], spec["vehicle"]
    usable_s = battery["usable_min"] * 60.0 * (1.0 - battery["reserve"])
    manifest = json.loads((folder / "out" / "manifest.json").read_text())
    sorties = manifest["sorties"]
    assert len(sorties) >= 2
    ring = json.loads((folder / "area.geojson").read_text())["features"][0]["geometry"]["coordinates"][0]
    c = np.mean(np.asarray(ring[:-1]), axis=0)
    to_xy = ic.local_projection(float(c[0]), float(c[1]))
    speed = vehicle["cruise_speed_ms"]
    allowance = 1.0 / (1.0 - (battery["wind_ms"] / speed) ** 2)  # a round trip against and with the wind
    photos = 0
    launches = set()
    for k, s in enumerate(sorties, start=1):
        home, rows = ic.read_wpl(folder / "out" / f"sortie-{k:02d}.waypoints")
        launches.add((round(home[0], 6), round(home[1], 6)))
        assert (home[0], home[1]) == pytest.approx((s["launch"]["lon"], s["launch"]["lat"]), abs=1e-6)
        nav = [r for r in rows if int(r[3]) == ic.NAV_WAYPOINT]
        lon = [home[0], *(r[9] for r in nav), home[0]]
        lat = [home[1], *(r[8] for r in nav), home[1]]
        x, y = to_xy.transform(lon, lat)
        path_m = float(np.hypot(np.diff(x), np.diff(y)).sum())
        top = max(r[10] for r in nav)
        least_s = path_m / speed * allowance + top / vehicle.get("climb_rate_ms", 2.5)
        assert least_s <= usable_s, f"sortie {k}: {path_m:.0f} m and a climb to {top:.0f} m take {least_s:.0f} s of {usable_s:.0f} s"
        assert s["usable_used_pct"] <= 100.0
        photos += len(ic.replay_triggers(rows, to_xy, None, home[2]).x)
    assert photos == len(manifest["stations"])
    # the far arm's sorties take off at its end: a second launch point, which the plan's warnings name
    assert len(launches) == 2
    assert any("sorties also take off at" in w for w in manifest["warnings"])
