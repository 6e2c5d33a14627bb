"""Areas, zones and launch points where the spec's CRS is meant to be used: one line naming the
place, its bounds and the CRS's; a hint when the axes look swapped; exit 2 and nothing written."""

from __future__ import annotations

import json
from pathlib import Path

import pyproj
import pytest
import shapely
from click.testing import CliRunner
from hypothesis import given
from hypothesis import strategies as st

from aerosurvey.area import check_area_of_use
from aerosurvey.cli import main
from aerosurvey.errors import InputError
from conftest import make_spec, write_geojson

REPO = Path(__file__).resolve().parents[1]
OBRATAN = REPO / "missions" / "obratan-72ha.toml"


def _swap(c):
    return [c[1], c[0]] if isinstance(c[0], (int, float)) else [_swap(x) for x in c]


def _refused(spec: Path, tmp_path: Path) -> str:
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)])
    assert res.exit_code == 2, res.output
    assert not out.exists()
    assert res.stdout == ""
    assert len(res.stderr.strip().splitlines()) == 1, res.stderr
    return res.stderr


def _obratan(tmp_path: Path, swap: bool = False, replace: dict[str, str] | None = None) -> Path:
    doc = json.loads((REPO / "missions" / "areas" / "obratan-72ha.geojson").read_text())
    if swap:
        for f in doc["features"]:
            f["geometry"]["coordinates"] = _swap(f["geometry"]["coordinates"])
    (tmp_path / "areas").mkdir(exist_ok=True)
    (tmp_path / "areas" / "obratan-72ha.geojson").write_text(json.dumps(doc))
    text = OBRATAN.read_text()
    for old, new in (replace or {}).items():
        assert old in text, old
        text = text.replace(old, new)
    p = tmp_path / "obratan.toml"
    p.write_text(text)
    return p


def test_swapped_obratan_in_krovak_is_refused_with_the_hint(tmp_path):
    msg = _refused(_obratan(tmp_path, swap=True), tmp_path)
    assert msg.startswith("Error: area at longitude 49.4")
    assert "mission.crs = 'EPSG:5514'" in msg and "longitude 12.09..22.56, latitude 47.73..51.06" in msg
    assert "look swapped" in msg


def test_an_area_elsewhere_is_refused_without_the_hint(tmp_path):
    # the spec's own little area near 49.4 N 15 E, planned in the Turkish CRS of the Kubad example
    msg = _refused(make_spec(tmp_path, {"mission": {"crs": "EPSG:5255"}}), tmp_path)
    assert "area at longitude 15.00000..15.00600" in msg and "EPSG:5255" in msg and "31.5..34.5" in msg
    assert "swapped" not in msg


def test_launch_points_and_zones_are_checked_too(tmp_path):
    msg = _refused(_obratan(tmp_path, replace={"reserve = 0.25": "reserve = 0.25\nlaunch_points = [[14.95, 49.43], [49.43, 14.95]]"}),
                   tmp_path)
    assert "battery.launch_points[1] at longitude 49.43000..49.43000" in msg and "look swapped" in msg
    write_geojson(tmp_path / "zone.geojson", [[[16.0, 49.0], [16.001, 49.0], [16.001, 49.001], [16.0, 49.0]]])
    spec = make_spec(tmp_path, {"mission": {"crs": "EPSG:5514"}, "area": {"exclusions": ["zone.geojson"]}})
    assert _plan_ok(spec, tmp_path)  # the zone (and the area) in Czechia
    write_geojson(tmp_path / "zone.geojson", [[[26.0, 49.0], [26.001, 49.0], [26.001, 49.001], [26.0, 49.0]]])
    msg = _refused(spec, tmp_path)
    assert "exclusion zone zone.geojson at longitude 26.00000..26.00100" in msg and "swapped" not in msg


def _plan_ok(spec: Path, tmp_path: Path) -> bool:
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(tmp_path / "ok")])
    return res.exit_code == 0


def test_auto_crs_plans_where_the_area_is(tmp_path):
    # "auto" is the UTM zone of the area's centre: the swapped outline is another place, planned there
    res = CliRunner().invoke(main, ["plan", str(_obratan(tmp_path, swap=True, replace={'crs = "EPSG:5514"': 'crs = "auto"'})),
                                    "-o", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output


@pytest.mark.parametrize("ring,needle", [
    ([[15.0, 95.0], [15.01, 95.0], [15.01, 95.01], [15.0, 95.0]], "coordinate (15.01, 95.01)"),
    ([[195.0, 49.0], [195.01, 49.0], [195.01, 49.01], [195.0, 49.0]], "coordinate (195.01, 49.0)"),
])
def test_coordinates_off_the_earth_are_refused(tmp_path, ring, needle):
    msg = _refused(make_spec(tmp_path, area=ring), tmp_path)
    assert needle in msg and "longitude [-180, 180] / latitude [-90, 90]" in msg


def test_launch_point_off_the_earth_is_refused(tmp_path):
    msg = _refused(make_spec(tmp_path, {"area": {"launch": [15.0, 91.0]}}), tmp_path)
    assert "area.launch = [15.0, 91.0]" in msg and "latitude in [-90, 90]" in msg


# a CRS whose area of use crosses the antimeridian: EPSG:3832 (PDC Mercator), longitude 98.69..-68
PACIFIC = pyproj.CRS.from_epsg(3832)


@given(st.floats(-180, 180), st.floats(-60, 66.67))
def test_area_of_use_across_the_antimeridian(lon, lat):
    inside = lon >= 98.69 or lon <= -68.0
    point = [("p", shapely.Point(lon, lat))]
    if inside:
        check_area_of_use(PACIFIC, "mission.crs", point)
    else:
        with pytest.raises(InputError, match="outside the area of use"):
            check_area_of_use(PACIFIC, "mission.crs", point)
