"""Areas from every supported vector format, multipolygons with holes, and the planning CRS."""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
import pyproj
import pytest
import shapely
from pyogrio.raw import write

from aerosurvey.area import planning_crs, read_area, utm_epsg
from aerosurvey.errors import InputError

SQUARE = shapely.Polygon([(15.0, 49.4), (15.006, 49.4), (15.006, 49.4035), (15.0, 49.4035)],
                         [[(15.002, 49.401), (15.003, 49.401), (15.003, 49.402), (15.002, 49.402)]])
OTHER = shapely.box(15.01, 49.4, 15.012, 49.402)


def _write(path: Path, geoms: list, driver: str, crs: str = "EPSG:4326") -> Path:
    wkb = shapely.to_wkb(np.asarray(geoms, dtype=object))
    write(str(path), wkb, field_data=[np.arange(len(geoms))], fields=["n"], crs=crs,
          geometry_type="Polygon", driver=driver)
    return path


@pytest.mark.parametrize("suffix,driver", [(".shp", "ESRI Shapefile"), (".gpkg", "GPKG"), (".geojson", "GeoJSON"),
                                           (".kml", "KML")])
def test_vector_formats(tmp_path, suffix, driver):
    p = _write(tmp_path / f"area{suffix}", [SQUARE, OTHER], driver)
    g = read_area(p, None, "EPSG:4326", "area")
    assert g.geom_type == "MultiPolygon"
    assert g.area == pytest.approx(SQUARE.area + OTHER.area, rel=1e-6)
    assert len(shapely.get_parts(g)[0].interiors) + len(shapely.get_parts(g)[1].interiors) == 1


def test_kmz(tmp_path):
    kml = _write(tmp_path / "doc.kml", [SQUARE], "KML")
    kmz = tmp_path / "area.kmz"
    with zipfile.ZipFile(kmz, "w") as z:
        z.write(kml, "doc.kml")
    g = read_area(kmz, None, "EPSG:4326", "area")
    assert g.area == pytest.approx(SQUARE.area, rel=1e-6)


def test_projected_shapefile_is_brought_to_wgs84(tmp_path):
    t = pyproj.Transformer.from_crs(4326, 5514, always_xy=True)
    sq = shapely.transform(SQUARE, lambda xy: np.column_stack(t.transform(xy[:, 0], xy[:, 1])))
    p = _write(tmp_path / "krovak.shp", [sq], "ESRI Shapefile", crs="EPSG:5514")
    g = read_area(p, None, "EPSG:4326", "area")
    assert g.bounds == pytest.approx(SQUARE.bounds, abs=1e-7)


def test_wkt_file_and_inline(tmp_path):
    p = tmp_path / "area.wkt"
    p.write_text(SQUARE.wkt)
    assert read_area(p, None, "EPSG:4326", "area").equals_exact(SQUARE, 1e-9)
    assert read_area(None, SQUARE.wkt, "EPSG:4326", "area").equals_exact(SQUARE, 1e-9)
    with pytest.raises(InputError, match="not valid WKT"):
        read_area(None, "POLYGON((0 0, 1", "EPSG:4326", "area")


def test_points_only_file_is_refused(tmp_path):
    p = tmp_path / "pts.geojson"
    p.write_text('{"type":"FeatureCollection","features":[{"type":"Feature","properties":{},'
                 '"geometry":{"type":"Point","coordinates":[15,49]}}]}')
    with pytest.raises(InputError, match="holds no polygon"):
        read_area(p, None, "EPSG:4326", "area")


def test_unknown_extension(tmp_path):
    p = tmp_path / "area.txt"
    p.write_text("x")
    with pytest.raises(InputError, match="unknown extension"):
        read_area(p, None, "EPSG:4326", "area")


def test_planning_crs_auto_and_named():
    assert utm_epsg(15.0, 49.4) == 32633
    assert utm_epsg(-70.0, -33.0) == 32719
    assert planning_crs("auto", SQUARE).name == "EPSG:32633"
    assert planning_crs("EPSG:5514", SQUARE).name == "EPSG:5514"
    assert planning_crs("EPSG:5255", SQUARE).name == "EPSG:5255"
    with pytest.raises(InputError, match="not a CRS pyproj knows"):
        planning_crs("EPSG:999999", SQUARE)
