"""Limits from the area's shape, not its size (plan/limits.py), and one planning CRS for every
part (plan/site.py): slivers, parts far apart, parts across projections."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import shapely

from aerosurvey.errors import InputError
from aerosurvey.plan.inputs import PlanInputs
from aerosurvey.plan.limits import estimate_cost
from aerosurvey.plan.pattern import kind_of
from aerosurvey.plan.planner import plan_mission
from aerosurvey.plan.sensor import solve_heights, solve_sensor, target_height
from aerosurvey.plan.site import prepare_site
from aerosurvey.spec import parse_spec

M_PER_DEG = 111_320.0


def _spec(**extra: dict[str, object]):
    data: dict[str, dict[str, object]] = {
        "area": {"wkt": "POLYGON((0 0, 1 0, 1 1, 0 0))"}, "camera": {"model": "sony-a6000-16mm"},
        "targets": {"gsd_cm": 2.5, "forward_overlap": 0.75, "side_overlap": 0.6},
        "vehicle": {"type": "copter", "cruise_speed_ms": 10.0},
    }
    for k, v in extra.items():
        data.setdefault(k, {}).update(v)
    return parse_spec(data, base=Path("."))


def _square(lon: float, lat: float, side_m: float) -> shapely.Polygon:
    d = side_m / M_PER_DEG
    return shapely.box(lon, lat, lon + d / math.cos(math.radians(lat)), lat + d)


def _estimate(spec, area):
    h, gsd, w = target_height(spec)
    site = prepare_site(spec, PlanInputs(area), h)
    heights = solve_heights(spec, h, site.ground)
    sensor = solve_sensor(spec, h, gsd, heights, w, footprint=kind_of(spec.pattern.kind).footprint(spec, heights),
                          autopilot_stretch=site.autopilot_stretch())
    return estimate_cost(spec, site, sensor), sensor


def test_a_sliver_costs_its_length_not_its_area():
    """3,000 km × 1 m (30 ha) along the central meridian of UTM zone 33: the estimate counts
    photos along its length, and the plan is refused by limits.max_photos."""
    sliver = shapely.box(15.0, 0.5, 15.0 + 1.0 / M_PER_DEG, 0.5 + 3_000_000 / 110_600)
    est, sensor = _estimate(_spec(mission={"crs": "EPSG:32633"}), sliver)
    along = 3_000_000 / sensor.base_m
    # two lines at least (60 % side overlap: every point in two strips), its width narrowing by
    # cos(latitude) to 0.89 m at its north end
    assert est.photos >= 2 * 0.9 * along
    assert est.path_km >= 2 * 0.9 * 3_000
    with pytest.raises(InputError) as e:
        plan_mission(_spec(mission={"crs": "EPSG:32633"}), PlanInputs(sliver))
    msg = str(e.value)
    assert e.value.key == "limits.max_photos" and "\n" not in msg


def test_parts_far_apart_add_the_way_between_them():
    """Two 4 ha squares 100 km apart north-south: the estimate flies between them."""
    a, b = _square(15.0, 49.0, 200.0), _square(15.0, 49.0 + 100_000 / 111_200, 200.0)
    est, _ = _estimate(_spec(), shapely.union(a, b))
    assert 99.0 < est.transit_km < 101.0
    one, _ = _estimate(_spec(), a)
    assert est.flight_hours > 2 * one.flight_hours + 99_000 / 10.0 / 3600 * 0.99


def test_parts_beyond_one_projection_are_refused():
    """4 ha at 15° E and 4 ha at 45° E: no one UTM zone holds both (its scale 0.9996 at its centre
    meridian, above 1.1 thirty degrees away); refused in one line naming mission.crs."""
    area = shapely.union(_square(15.0, 10.0, 200.0), _square(45.0, 10.0, 200.0))
    with pytest.raises(InputError) as e:
        plan_mission(_spec(), PlanInputs(area))
    msg = str(e.value)
    assert e.value.key == "mission.crs" and "\n" not in msg and "2 parts" in msg


def test_an_area_within_one_zone_is_not_refused_for_its_scale():
    est, _ = _estimate(_spec(), shapely.union(_square(15.0, 49.0, 200.0), _square(15.3, 49.2, 200.0)))
    assert est.photos > 0
