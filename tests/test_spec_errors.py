"""Bad mission specs and areas: each gets a clear error naming the input, and no output is left."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from aerosurvey.cli import main
from aerosurvey.errors import InputError
from aerosurvey.inputs import plan_from_files
from aerosurvey.spec import load_spec
from conftest import write_geojson


def _plan_error(spec_path: Path, tmp_path: Path) -> str:
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["plan", str(spec_path), "-o", str(out)])
    assert res.exit_code == 2, res.output
    assert not out.exists() or not any(out.iterdir()), "a failed plan left files behind"
    leftovers = [p for p in tmp_path.iterdir() if p.name.startswith(".out.")]
    assert not leftovers, leftovers
    return res.output


@pytest.mark.parametrize("key,value,needle", [
    ("forward_overlap", 0.95, "targets.forward_overlap = 0.95"),
    ("forward_overlap", -0.1, "targets.forward_overlap = -0.1"),
    ("side_overlap", 1.2, "targets.side_overlap = 1.2"),
])
def test_overlap_outside_range(spec_factory, tmp_path, key, value, needle):
    msg = _plan_error(spec_factory({"targets": {key: value}}), tmp_path)
    assert needle in msg and "[0.0, 0.95)" in msg


def test_unknown_camera(spec_factory, tmp_path):
    msg = _plan_error(spec_factory({"camera": {"model": "nikon-d1"}}), tmp_path)
    assert "camera = 'nikon-d1'" in msg


def test_unknown_key_is_named(spec_factory, tmp_path):
    msg = _plan_error(spec_factory({"targets": {"gsd": 2.0}}), tmp_path)
    assert "unknown key(s) in [targets]: gsd" in msg


def test_gsd_unreachable_under_the_cap(spec_factory, tmp_path):
    msg = _plan_error(spec_factory({"targets": {"gsd_cm": 6.0}}), tmp_path)
    # a6000 16 mm: 6 cm needs 245 m, the cap is 120 m
    assert "245." in msg and "max_height_agl_m = 120" in msg and "plan_at_cap" in msg


def test_plan_at_cap_reports_the_achieved_gsd(spec_factory):
    spec = load_spec(spec_factory({"targets": {"gsd_cm": 6.0, "plan_at_cap": True}}))
    plan = plan_from_files(spec)
    assert plan.sensor.heights.max_agl_m == pytest.approx(120.0)
    assert any("height cap" in w for w in plan.warnings)
    assert plan.sensor.gsd_max_m == pytest.approx(120 * (23.5 / 6000) / 16.0)


def test_self_intersecting_area_says_where(spec_factory, tmp_path):
    bowtie = [[15.0, 49.4], [15.006, 49.4035], [15.006, 49.4], [15.0, 49.4035], [15.0, 49.4]]
    msg = _plan_error(spec_factory(area=bowtie), tmp_path)
    assert "self-intersection" in msg and "longitude 15.003" in msg and "latitude 49.40175" in msg


def test_zero_area(spec_factory, tmp_path):
    flat = [[15.0, 49.4], [15.006, 49.4], [15.003, 49.4], [15.0, 49.4]]
    msg = _plan_error(spec_factory(area=flat), tmp_path)
    assert "area" in msg and ("zero area" in msg or "invalid polygon" in msg)


def test_empty_area_file(spec_factory, tmp_path):
    spec = spec_factory()
    (tmp_path / "area.geojson").write_text('{"type": "FeatureCollection", "features": []}')
    msg = _plan_error(spec, tmp_path)
    assert "holds no polygon" in msg


def test_swapped_longitude_latitude(spec_factory, tmp_path):
    ring = [[49.400, 115.0], [49.400, 115.006], [49.4035, 115.006], [49.4035, 115.0], [49.400, 115.0]]
    msg = _plan_error(spec_factory(area=ring), tmp_path)
    assert "look swapped" in msg


def test_latitude_out_of_range(spec_factory, tmp_path):
    ring = [[15.0, 95.0], [15.006, 95.0], [15.006, 95.1], [15.0, 95.0]]
    msg = _plan_error(spec_factory(area=ring), tmp_path)
    assert "outside longitude [-180, 180] / latitude [-90, 90]" in msg


def test_exclusion_zone_covering_the_whole_area(spec_factory, tmp_path):
    write_geojson(tmp_path / "zone.geojson", [[[14.99, 49.39], [15.02, 49.39], [15.02, 49.42], [14.99, 49.42], [14.99, 49.39]]])
    msg = _plan_error(spec_factory({"area": {"exclusions": ["zone.geojson"]}}), tmp_path)
    assert "exclusion zones" in msg and "nothing is left to survey" in msg


def test_missing_area_file(spec_factory, tmp_path):
    msg = _plan_error(spec_factory({"area": {"file": "nope.geojson"}}), tmp_path)
    assert "nope.geojson" in msg and "does not exist" in msg


def test_geographic_planning_crs_is_refused(spec_factory, tmp_path):
    msg = _plan_error(spec_factory({"mission": {"crs": "EPSG:4326"}}), tmp_path)
    assert "mission.crs = 'EPSG:4326' is not a projected CRS" in msg


def test_heading_must_be_auto_or_number(spec_factory):
    with pytest.raises(InputError, match="flight.heading = 'north'"):
        load_spec(spec_factory({"flight": {"heading": "north"}}))


def test_time_window_must_be_ordered(spec_factory):
    with pytest.raises(InputError, match="conditions.end"):
        load_spec(spec_factory({"conditions": {"start": "2026-05-14T12:00:00+02:00", "end": "2026-05-14T09:00:00+02:00"}}))


def test_not_toml(tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text("[mission\nname=")
    with pytest.raises(InputError, match="not valid TOML"):
        load_spec(p)
