"""Check point input: formats, units, CRS, and a clear error (exit 2) for every kind of bad file."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pyproj
import pytest
from click.testing import CliRunner
from qa_accuracy_helpers import KUBAD

from aerosurvey.cli import main
from aerosurvey.errors import InputError
from aerosurvey.qa.accuracy_input import read_points


@pytest.mark.parametrize("content,needle", [
    ("id,dx,dz\nA,1,2\n", "needs residual columns dx, dy"),
    ("id,dx,dy\nA,1,x\n", "column 'dy': 'x' is not a number"),
    ("id,dx,dy\nA,1,nan\n", "not a finite number"),
    ("id,dx,dy\nA,1,2\nB,2,3\nA,2,3\n", "duplicate id(s) A"),
    ("id,dx_cm,dy_mm\nA,1,2\n", "mixed units (dx_cm in cm, dy_mm in mm)"),
    ("pt_name,dx,dy\nA,1,2\n", "no id column"),
    ("id,role,dx,dy\nA,base,1,2\n", "role 'base' is not allowed"),
    ("id,landcover,dx,dy\nA,forest,1,2\n", "landcover 'forest' is not allowed"),
    ("id,x,y,z,x_ref,y_ref\nA,1,2,3,1,2\n", "heights need both z and z_ref"),
    ("id,dx,dy\nA,,2\n", "has no horizontal residual"),
    ("id,dx,dy,crs\nA,1,2,EPSG:5514\nB,1,2,EPSG:32633\n", "mixed CRSs"),
    ("id,dx,dy,sigma_xy\nA,1,2,-0.1\n", "negative"),
    ("id,dx_m,dx_cm,dy\nA,1,2,3\n", "column 'dx' is given twice"),
    ("# only a comment\n", "no header"),
])
def test_bad_point_files(tmp_path: Path, content: Any, needle: Any) -> None:
    p = tmp_path / "pts.csv"
    p.write_text(content)
    with pytest.raises(InputError) as exc:
        read_points(p)
    assert needle in str(exc.value)
    res = CliRunner().invoke(main, ["qa", "accuracy", str(p), "-o", str(tmp_path / "out")])
    assert res.exit_code == 2 and needle in res.output
    assert not (tmp_path / "out").exists()  # bad input leaves nothing behind


def test_missing_file_and_contradicting_crs(tmp_path: Path) -> None:
    assert CliRunner().invoke(main, ["qa", "accuracy", str(tmp_path / "nope.csv")]).exit_code == 2
    p = tmp_path / "pts.csv"
    p.write_text("id,dx,dy,crs\nA,1,2,EPSG:5514\n")
    with pytest.raises(InputError, match="contradicts"):
        read_points(p, crs="EPSG:32633")
    with pytest.raises(InputError, match="not a CRS pyproj knows"):
        read_points(p, crs="EPSG:999999")


def test_units_suffix_option_and_statement(tmp_path: Path) -> None:
    pts = read_points(KUBAD)
    assert pts.units == "cm" and pts.units_stated and pts.dx[0] == pytest.approx(0.0611981)
    p = tmp_path / "mm.csv"
    p.write_text("id,dx,dy,dz\nA,10,-20,5\n")
    assert read_points(p, units="mm").dy[0] == pytest.approx(-0.020)
    bare = read_points(p)
    assert bare.units == "m" and not bare.units_stated and bare.dx[0] == 10.0
    semi = tmp_path / "semi.csv"
    semi.write_text("id;dx_mm;dy_mm\nA;10;-20\n")
    assert read_points(semi).dx[0] == pytest.approx(0.010)


def test_coordinates_projected_and_roles(tmp_path: Path) -> None:
    p = tmp_path / "xy.csv"
    p.write_text("id,role,landcover,x,y,z,x_ref,y_ref,z_ref\n"
                 "C1,CP,open,-714000.03,-1120000.00,400.10,-714000.00,-1120000.02,400.00\n"
                 "G1,GCP,vegetated,-713900.00,-1119950.01,401.00,-713900.01,-1119950.00,401.02\n")
    pts = read_points(p, crs="EPSG:5514")
    assert pts.dx == pytest.approx([-0.03, 0.01]) and pts.dy == pytest.approx([0.02, -0.01])
    assert pts.dz == pytest.approx([0.10, -0.02])
    assert pts.role == ("check", "control") and list(pts.vegetated) == [False, True]
    assert pts.crs == "EPSG:5514" and pts.has_positions


def test_us_survey_feet_crs(tmp_path: Path) -> None:
    p = tmp_path / "ft.csv"
    p.write_text("id,x,y,z,x_ref,y_ref,z_ref\nA,1000.5,2000,10,1000,2000,9\n")
    with pytest.raises(InputError, match="US survey foot"):
        read_points(p, crs="EPSG:2263")  # NY Long Island, US survey feet
    pts = read_points(p, crs="EPSG:2263", units="ft")
    assert pts.dx[0] == pytest.approx(0.5 * 0.3048, rel=1e-5) and pts.dz[0] == pytest.approx(0.3048)


def test_geojson_is_longitude_latitude_and_converted_on_the_ellipsoid(tmp_path: Path) -> None:
    lon0, lat0 = 14.95, 49.43
    feats = []
    for i in range(4):
        dlon, dlat = 1e-6 * (i + 1), -2e-6 * i
        feats.append({"type": "Feature", "properties": {"id": f"C{i}", "x": lon0 + dlon, "y": lat0 + dlat,
                                                        "z_m": 300.05, "role": "CP"},
                      "geometry": {"type": "Point", "coordinates": [lon0, lat0, 300.0]}})
    p = tmp_path / "pts.geojson"
    p.write_text(json.dumps({"type": "FeatureCollection", "features": feats}))
    pts = read_points(p)
    assert pts.geographic and pts.crs is not None
    geod = pyproj.Geod(ellps="WGS84")
    for i in range(4):
        az, _, dist = geod.inv(lon0, lat0, lon0 + 1e-6 * (i + 1), lat0 - 2e-6 * i)
        east, north = dist * np.sin(np.radians(az)), dist * np.cos(np.radians(az))
        assert (pts.dx[i], pts.dy[i]) == pytest.approx((east, north), abs=1e-6)
    assert pts.dz == pytest.approx([0.05] * 4)
    # a GeoJSON crs member makes the coordinates projected
    fc: dict[str, Any] = {"type": "FeatureCollection", "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::5514"}},
          "features": [{"type": "Feature", "properties": {"id": "A", "x": -714000.02, "y": -1120000.0},
                        "geometry": {"type": "Point", "coordinates": [-714000.0, -1120000.0]}}]}
    p.write_text(json.dumps(fc))
    assert read_points(p).dx[0] == pytest.approx(-0.02)
    fc["features"][0]["geometry"] = {"type": "LineString", "coordinates": [[0, 0], [1, 1]]}
    p.write_text(json.dumps(fc))
    with pytest.raises(InputError, match="Point features"):
        read_points(p)
