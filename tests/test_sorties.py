"""Battery split: sorties fit their battery, cover every station once, in order; bad batteries."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import independent_coverage as ic
from aerosurvey.cli import main
from aerosurvey.errors import InputError
from aerosurvey.inputs import plan_from_files
from aerosurvey.spec import load_spec
from conftest import make_spec, random_polygon, write_geojson


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
# a plane in a light wind (0.6 m/s across its lines) whose body-fixed camera's crab of a degree or two was refused as
# "the line heading changes each time the spacing is laid" (CI, 2026-11-28)
@example(kind="concave", seed=469, size=234.0, minutes=6.0, reserve=0.25, wind=0.625, wind_from=42.0, vehicle="plane")
@given(kind=st.sampled_from(["convex", "concave", "holed"]), seed=st.integers(0, 10_000), size=st.floats(200, 400),
       minutes=st.floats(6, 30), reserve=st.floats(0.1, 0.4), wind=st.floats(0, 5), wind_from=st.floats(0, 359.9),
       vehicle=st.sampled_from(["copter", "plane"]))
def test_sorties_fit_and_cover_every_station_once(tmp_path_factory, kind, seed, size, minutes, reserve, wind, wind_from, vehicle):
    tmp = tmp_path_factory.mktemp("sorties")
    spec = make_spec(tmp, {"battery": {"usable_min": minutes, "reserve": reserve},
                           "conditions": {"wind": {"speed_ms": wind, "from_deg": wind_from}},
                           "vehicle": {"type": vehicle, "cruise_speed_ms": 12.0 if vehicle == "copter" else 16.0,
                                       **({"max_airspeed_ms": 14.0} if vehicle == "copter" else {})}},
                     rings=random_polygon(kind, seed, size))
    try:
        plan = plan_from_files(load_spec(spec))
    except InputError as exc:
        assert "battery too small" in str(exc)
        return
    usable_s = minutes * 60 * (1 - reserve)
    covered = []
    for s, _wps in plan.sorties:
        # the model's own cost of the sortie fits the usable battery
        assert s.battery_used <= 1.0 + 1e-9
        assert s.horizontal_s + s.vertical_s <= usable_s * (1 + 1e-9)
        if vehicle == "copter":  # a copter never flies faster over the ground in wind (a plane's climb and
            # descent overlap its transits, so a downwind survey can end sooner)
            assert s.horizontal_s + s.vertical_s >= s.still_air_s * (1 - 1e-9)
        covered.extend(range(s.first, s.last + 1))
    assert covered == list(range(len(plan.stations.ids)))


def _replay(path: Path, c) -> ic.Photos:
    home, rows = ic.read_wpl(path)
    return ic.replay_triggers(rows, ic.local_projection(c[0], c[1]), None, home[2])


def test_exported_sorties_photograph_each_station_once(tmp_path):
    spec = make_spec(tmp_path, {"battery": {"usable_min": 8.0}, "flight": {"heading": 0.0}})
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)])
    assert res.exit_code == 0, res.output
    manifest = json.loads((out / "manifest.json").read_text())
    assert len(manifest["sorties"]) >= 2
    c = (15.003, 49.4017)
    whole = _replay(out / "mission.waypoints", c)
    parts = [_replay(out / f"sortie-{k:02d}.waypoints", c) for k in range(1, len(manifest["sorties"]) + 1)]
    xs = np.concatenate([p.x for p in parts])
    ys = np.concatenate([p.y for p in parts])
    # the sorties take as many photos as the whole mission and as the plan has stations
    assert len(xs) == len(whole.x) == len(manifest["stations"])
    # one to one with the planned stations, within the trigger's 50 Hz overshoot (v/50) and file rounding
    to_xy = ic.local_projection(*c)
    sx, sy = to_xy.transform([s["lon"] for s in manifest["stations"]], [s["lat"] for s in manifest["stations"]])
    d = np.hypot(xs[:, None] - np.asarray(sx)[None, :], ys[:, None] - np.asarray(sy)[None, :])
    nearest = d.argmin(axis=1)
    step = manifest["derived"]["speed_ms"] / 50.0
    assert d.min(axis=1).max() < step + 0.05
    assert len(set(nearest.tolist())) == len(xs)
    for k, s in enumerate(manifest["sorties"], start=1):
        assert s["photos"] == len(parts[k - 1].x)
        assert s["battery_used_pct"] <= 75.0 + 1e-6


def test_battery_too_short_for_takeoff_and_return(tmp_path):
    spec = make_spec(tmp_path, {"battery": {"usable_min": 1.0}})
    with pytest.raises(InputError, match="battery too small.*takes"):
        plan_from_files(load_spec(spec))


def test_launch_point_too_far(tmp_path):
    spec = make_spec(tmp_path, {"battery": {"usable_min": 10.0, "launch_points": [[15.2, 49.4]], "launch": 1}})
    with pytest.raises(InputError, match="battery too small"):
        plan_from_files(load_spec(spec))


def test_launch_point_inside_an_exclusion_zone(tmp_path):
    zone = [[15.0080, 49.4000], [15.0100, 49.4000], [15.0100, 49.4020], [15.0080, 49.4020], [15.0080, 49.4000]]
    write_geojson(tmp_path / "zone.geojson", [zone])
    spec = make_spec(tmp_path, {"area": {"exclusions": ["zone.geojson"]},
                                "battery": {"usable_min": 10.0, "launch_points": [[15.009, 49.401]]}})
    with pytest.raises(InputError, match=r"battery.launch_points\[1\].*inside an exclusion zone"):
        plan_from_files(load_spec(spec))


def test_nearest_of_several_launch_points(tmp_path):
    west, east = [14.9985, 49.4017], [15.0075, 49.4017]
    spec = make_spec(tmp_path, {"battery": {"usable_min": 7.0, "launch_points": [west, east]}, "flight": {"heading": 0.0}})
    plan = plan_from_files(load_spec(spec))
    launches = {s.launch for s, _ in plan.sorties}
    assert len(plan.sorties) >= 2 and launches == {0, 1}


def test_energy_budget(tmp_path):
    spec = make_spec(tmp_path, {"battery": {"capacity_wh": 60.0, "cruise_power_w": 400.0, "reserve": 0.2}})
    plan = plan_from_files(load_spec(spec))
    usable_j = 60 * 3600 * 0.8
    for s, _ in plan.sorties:
        used = s.horizontal_s * 400.0 + s.vertical_s * 520.0
        assert used <= usable_j * (1 + 1e-9)
        assert s.battery_used == pytest.approx(used / usable_j, rel=1e-6)


@pytest.mark.parametrize("table,needle", [
    ({"usable_min": 10.0, "capacity_wh": 50.0}, "exactly one of"),
    ({"capacity_wh": 50.0}, "needs battery.cruise_power_w"),
    ({"usable_min": 10.0, "reserve": 0.95}, "battery.reserve = 0.95"),
    ({"usable_min": 10.0, "launch": 3}, "battery.launch = 3"),
    ({"usable_min": 10.0, "wind_ms": 60.0}, "battery.wind_ms = 60"),
])
def test_bad_battery_tables(tmp_path, table, needle):
    with pytest.raises(InputError, match=needle.replace(".", r"\.").replace("(", r"\(")):
        load_spec(make_spec(tmp_path, {"battery": table}))


def test_a_wind_of_unknown_direction_is_an_allowance_and_not_given_with_a_known_one(tmp_path):
    """battery.wind_ms (the specs of before conditions.wind): every sortie's level flight costs 1 / (1 − (w/v)²) more,
    the battery share it takes recorded as the wind's; with conditions.wind too, refused in one line."""
    import json

    from click.testing import CliRunner

    from aerosurvey.cli import main

    shares = {}
    for w in (0.0, 3.0):
        (tmp_path / str(w)).mkdir()
        spec = make_spec(tmp_path / str(w), {"battery": {"usable_min": 8.0, "wind_ms": w}})
        res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(tmp_path / str(w) / "out")])
        assert res.exit_code == 0, res.output
        shares[w] = json.loads((tmp_path / str(w) / "out" / "manifest.json").read_text())["sorties"]
    assert len(shares[3.0]) >= len(shares[0.0])
    assert all(s["wind_used_pct"] > 0 for s in shares[3.0]) and all(s["wind_used_pct"] == 0 for s in shares[0.0])
    (tmp_path / "both").mkdir()
    both = make_spec(tmp_path / "both", {"battery": {"usable_min": 8.0, "wind_ms": 3.0},
                                         "conditions": {"wind": "3@270"}, "vehicle": {"max_airspeed_ms": 12.0}})
    res = CliRunner().invoke(main, ["plan", str(both), "-o", str(tmp_path / "both" / "out")])
    assert res.exit_code == 2 and "battery.wind_ms = 3 and conditions.wind = 3@270 are both given" in res.output
