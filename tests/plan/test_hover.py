"""Hover-and-capture: the copter stops at every station, rests, takes the photo and goes on.

Judged from the exported `.waypoints` files as ArduPilot reads them (tests/independent_legs.py's
parser, no planner code): every station of the manifest is a waypoint with a hold (param1) of
at least camera.settle_s, followed by one DO_DIGICAM_CONTROL shot, each sortie within the
autopilot's item limit; and the time estimate grows over the same plan flown through by the
stops, worked out here from the kinematics (braking and accelerating at the vehicle's
acceleration, the rests).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import independent_legs as il
from aerosurvey.errors import InputError
from aerosurvey.inputs import plan_from_files
from aerosurvey.outputs import write_outputs
from aerosurvey.spec import load_spec
from independent_motion import stop_to_stop_time

NAV_WAYPOINT, DO_DIGICAM_CONTROL = 16, 203
AREA = {"type": "Polygon", "coordinates": [[[15.300, 49.500], [15.306, 49.500], [15.306, 49.503], [15.300, 49.503], [15.300, 49.500]]]}


def _spec(folder: Path, trigger: str, battery: bool) -> Path:
    (folder / "area.geojson").write_text(json.dumps(AREA))
    text = f"""
[mission]
name = "hover-{trigger}"
[area]
file = "area.geojson"
[camera]
model = "sony-a6000-16mm"
trigger = "{trigger}"
settle_s = 1.5
[targets]
gsd_cm = 2.0
[vehicle]
type = "copter"
cruise_speed_ms = 8.0
acceleration_ms2 = 2.0
[flight]
heading = 90
"""
    if battery:
        text += "[battery]\nusable_min = 8\nreserve = 0.2\n"
    spec = folder / f"{trigger}.toml"
    spec.write_text(text)
    return spec


@pytest.mark.parametrize("battery", [False, True])
def test_every_station_is_a_stop_with_one_shot(tmp_path: Path, battery: bool) -> None:
    out = tmp_path / "out"
    loaded = load_spec(_spec(tmp_path, "hover", battery))
    write_outputs(plan_from_files(loaded), loaded, out)
    manifest = json.loads((out / "manifest.json").read_text())
    stations = {(round(s["lat"], 7), round(s["lon"], 7)) for s in manifest["stations"]}
    files = sorted(out.glob("sortie-*.waypoints")) if battery else [out / "mission.waypoints"]
    assert len(files) > (1 if battery else 0)
    shots = []
    for f in files:
        _, items = il.parse_wpl(f.read_text(), str(f))
        assert len(items) + 1 <= 650
        for prev, it in zip(items, items[1:]):
            if it.command == DO_DIGICAM_CONTROL:
                assert prev.command == NAV_WAYPOINT and prev.params[0] >= 1.5, f"{f.name}: a shot not after a hold"
                shots.append((round(prev.lat, 7), round(prev.lon, 7)))
    assert len(shots) == len(manifest["stations"])
    assert set(shots) == stations


def test_the_stops_cost_their_time(tmp_path: Path) -> None:
    """Hover time − flown-through time = n·(settle + cycle) + (n − runs)·(stop-to-stop leg − cruise)."""
    (tmp_path / "h").mkdir()
    (tmp_path / "d").mkdir()
    hover = plan_from_files(load_spec(_spec(tmp_path / "h", "hover", False)))
    # the same stations flown through by distance: the same base, as the a6000's base is whole trigger steps at 8 m/s
    through = plan_from_files(load_spec(_spec(tmp_path / "d", "distance", False)))
    assert len(hover.stations.ids) == len(through.stations.ids)
    n, runs = len(hover.stations.ids), len(hover.route.runs)
    v, a, jerk = 8.0, 2.0, 1.0
    b = hover.sensor.base_m
    cycle = hover.camera.min_cycle_s
    leg = stop_to_stop_time(b, v, a, jerk)
    extra = n * (1.5 + cycle) + (n - runs) * (leg - b / v)
    got = hover.estimates["survey_time_s"] - through.estimates["survey_time_s"]
    assert got == pytest.approx(extra, rel=0.02, abs=1.0)


def test_a_plane_cannot_hover(tmp_path: Path) -> None:
    spec = _spec(tmp_path, "hover", False)
    spec.write_text(spec.read_text().replace('type = "copter"', 'type = "plane"'))
    with pytest.raises(InputError, match="camera.trigger = 'hover' is for copters"):
        load_spec(spec)
