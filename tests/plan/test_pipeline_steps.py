"""Each planning step called alone with plain data (no file), and plan_mission with every
file access forbidden."""

from __future__ import annotations

import builtins
import io
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import shapely

from aerosurvey.errors import InputError
from aerosurvey.inputs import load_inputs
from aerosurvey.plan.altitudes import assign_altitudes
from aerosurvey.plan.estimates import estimate
from aerosurvey.plan.inputs import PlanInputs
from aerosurvey.plan.pattern import AreaGrid, kind_of, pattern_for
from aerosurvey.plan.planner import plan_mission
from aerosurvey.plan.routing import plan_route
from aerosurvey.plan.sensor import nadir_footprint, solve_heights, solve_sensor, target_height
from aerosurvey.plan.site import prepare_site
from aerosurvey.spec import load_spec, parse_spec

REPO = Path(__file__).resolve().parents[2]
# about 17 ha near 49.4 N 15.0 E, given as WKT: no area file
AREA = shapely.box(15.000, 49.400, 15.006, 49.4035)


def spec_of(**tables: dict[str, Any]):
    data: dict[str, Any] = {
        "mission": {"name": "steps"},
        "area": {"wkt": AREA.wkt},
        "camera": {"model": "sony-a6000-16mm"},
        "targets": {"gsd_cm": 2.5, "forward_overlap": 0.75, "side_overlap": 0.6},
        "vehicle": {"type": "copter", "cruise_speed_ms": 10.0},
    }
    for k, v in tables.items():
        data.setdefault(k, {}).update(v)
    return parse_spec(data, base=Path("."))


def test_steps_one_by_one_with_plain_data():
    spec = spec_of(flight={"heading": 0.0})
    h, gsd, warnings = target_height(spec)
    site = prepare_site(spec, PlanInputs(AREA), h)
    assert site.zones is None and site.dem is None and site.ground is None
    assert 0.99 < site.grid_scale < 1.01
    assert gsd == pytest.approx(0.025) and warnings == ()
    heights = solve_heights(spec, h, None)
    sensor = solve_sensor(spec, h, gsd, heights, footprint=kind_of(spec.pattern.kind).footprint(spec, heights),
                          autopilot_stretch=site.autopilot_stretch())
    # a6000 16 mm: landscape footprint 6000 px × 2.5 cm across, spacing 40 % of it (less the safety)
    assert sensor.across_m == pytest.approx(min(6000 * 0.025, 23.5 * h / 16), rel=1e-9)
    assert sensor.spacing_m == pytest.approx(sensor.across_m * 0.4 * 0.999, rel=1e-9)
    layout = next(AreaGrid(0.0, False, 0, 0.0).layouts(site, sensor, lambda s, f: None))
    assert layout.heading_deg == 0.0 and len(layout.passes) == 1 and layout.passes[0].segments
    routed = plan_route(spec, site, sensor, layout)
    assert routed.transit_out == () and routed.transit_back == ()
    assert shapely.Point(routed.home_xy).distance(site.area.exterior) < 1e-6
    alts = assign_altitudes(routed.route, sensor.heights, None, 0.0, site.planar, spec.terrain.tolerance_m)
    assert len(alts.stations.ids) == sum(len(r.station_xy) for r in routed.route.runs)
    assert np.allclose(alts.stations.alt_rel_m, sensor.heights.nominal_agl_m)
    est = estimate(spec, routed.route, alts.waypoints, alts.stations, sensor.kinematics, routed.home_xy, routed.end_xy,
                   sensor.heights, sensor.base_m, sensor.lead_in_m, site.grid_scale)
    assert est["photos"] == len(alts.stations.ids) and est["total_time_s"] > est["survey_time_s"] > 0


def test_a_pattern_is_replaceable():
    """The pipeline asks pattern_for(spec) for an object with layout(); the area grid is one."""
    spec = spec_of(flight={"heading": 30.0, "cross_hatch": True})
    grid = pattern_for(spec)
    assert isinstance(grid, AreaGrid) and grid.heading_deg == 30.0 and grid.cross_hatch


def _forbid_files(monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(*a: object, **k: object) -> None:
        raise AssertionError(f"planning opened a file: {a[:1]}")

    monkeypatch.setattr(builtins, "open", refuse)
    monkeypatch.setattr(io, "open", refuse)
    monkeypatch.setattr(Path, "open", refuse)
    monkeypatch.setattr(Path, "read_text", refuse)
    monkeypatch.setattr(Path, "read_bytes", refuse)
    import rasterio

    monkeypatch.setattr(rasterio, "open", refuse)


@pytest.mark.parametrize("example", ["obratan-72ha", "forest-dem", "kubad-abad-fixed-wing"])
def test_plan_mission_opens_no_file(example: str, monkeypatch: pytest.MonkeyPatch):
    spec = load_spec(REPO / "missions" / f"{example}.toml")
    inputs = load_inputs(spec)
    _forbid_files(monkeypatch)
    plan = plan_mission(spec, inputs)
    assert len(plan.stations.ids) > 100


def test_absurd_gsd_is_refused_before_any_work():
    with pytest.raises(InputError) as e:
        plan_mission(spec_of(targets={"gsd_cm": 0.01}), PlanInputs(AREA))
    assert "limits.max_photos" in str(e.value) and e.value.key == "limits.max_photos"


def test_a_large_job_is_possible_when_the_limit_is_raised():
    with pytest.raises(InputError, match="limits.max_photos = 1,000"):
        plan_mission(spec_of(targets={"gsd_cm": 0.5}, limits={"max_photos": 1000}), PlanInputs(AREA))
    plan = plan_mission(spec_of(targets={"gsd_cm": 0.5}, limits={"max_photos": 10_000}), PlanInputs(AREA))
    assert 1000 < len(plan.stations.ids) <= 10_000


def test_huge_area_refused_by_flight_hours():
    big = shapely.box(15.0, 49.0, 15.6, 49.4)  # about 1,900 km²
    spec = parse_spec({"area": {"wkt": big.wkt}, "camera": {"model": "sony-a6000-16mm"},
                       "targets": {"gsd_cm": 2.9}, "limits": {"max_photos": 10_000_000}}, base=Path("."))
    with pytest.raises(InputError) as e:
        plan_mission(spec, PlanInputs(big))
    assert "limits.max_flight_hours" in str(e.value)


def test_overlaps_without_stereo_warn():
    plan = plan_mission(spec_of(targets={"forward_overlap": 0.0, "side_overlap": 0.1}, flight={"heading": 0.0}), PlanInputs(AREA))
    text = " ".join(plan.warnings)
    assert "forward_overlap = 0 is under 0.5" in text and "side_overlap = 0.1 is under 0.2" in text


@pytest.mark.parametrize("above", [0.0, 0.5, None])
def test_wind_at_or_above_the_survey_speed_is_refused(above: float | None):
    """A plane's wind at its survey air speed, above it, and above it but below cruise (9 m/s; cruise 10): all refused."""
    # motion blur limits this camera's survey speed to 3.125 m/s at 2.5 cm (exposure 1/250 s, half a
    # pixel), flown in whole cm/s (the mission's DO_CHANGE_SPEED): 3.12 m/s
    probe = spec_of(camera={"exposure_s": 0.004}, vehicle={"type": "plane", "cruise_speed_ms": 10.0})
    h, gsd, _ = target_height(probe)
    probe_heights = solve_heights(probe, h, None)
    speed = solve_sensor(probe, h, gsd, probe_heights, footprint=nadir_footprint(probe, probe_heights),
                         autopilot_stretch=1.0).speed.speed_ms  # the speed alone
    assert speed == pytest.approx(3.12)
    wind = 9.0 if above is None else speed + above
    spec = spec_of(battery={"usable_min": 27.7}, camera={"exposure_s": 0.004}, vehicle={"type": "plane", "cruise_speed_ms": 10.0},
                   conditions={"wind": {"speed_ms": wind, "from_deg": 200.0}})
    with pytest.raises(InputError) as e:
        plan_mission(spec, PlanInputs(AREA))
    assert e.value.key == "conditions.wind" and f"survey air speed {speed:.2f} m/s" in str(e.value)
