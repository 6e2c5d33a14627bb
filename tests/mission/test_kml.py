"""plan.kml read back by GDAL (pyogrio, its LIBKML driver): the layers of plan.gpkg but the
footprints, each feature with its name, fields and geometry (3-D where the plan follows the
terrain, altitudeMode absolute); a style for every placemark, one colour per sortie; text
escaped, and a character XML cannot hold refused naming where it is."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pyogrio
import pytest
import shapely

from aerosurvey.errors import InputError
from aerosurvey.inputs import plan_from_files
from aerosurvey.mission.formats.kml import layers_to_kml
from aerosurvey.outputs import write_outputs
from aerosurvey.report.gpkg import STYLES, Layer
from aerosurvey.spec import load_spec
from conftest import make_spec, random_polygon, write_geojson

ROOT = Path(__file__).resolve().parents[2]
K = "{http://www.opengis.net/kml/2.2}"


def _read(path: Path, layer: str) -> tuple[list[shapely.Geometry], dict[str, np.ndarray]]:
    meta, _, geoms, fields = pyogrio.raw.read(path, layer=layer)
    return [shapely.from_wkb(g) for g in geoms], dict(zip(meta["fields"], fields))


def test_the_kml_has_the_packages_layers_but_the_footprints(written) -> None:
    _, _, out = written
    kml, gpkg = out / "plan.kml", out / "plan.gpkg"
    package = [n for n, _ in pyogrio.list_layers(gpkg) if n not in ("layer_styles", "footprints")]
    assert [n for n, _ in pyogrio.list_layers(kml)] == package
    for layer in package:
        info = pyogrio.read_info(kml, layer=layer)
        assert info["crs"] == "EPSG:4326"
        assert info["features"] == pyogrio.read_info(gpkg, layer=layer)["features"], layer


def _same_features_as_the_package(out: Path, three_d: frozenset[str]) -> int:
    """Every KML layer's features: names and fields as the GeoPackage's (as text), each geometry of
    the package layer's type, equal to its feature's to 1e-8°, heights to 5 mm, z only in the
    layers of `three_d`. Returns how many features were compared."""
    compared = 0
    for layer in [n for n, _ in pyogrio.list_layers(out / "plan.kml")]:
        kml_geoms, kml_fields = _read(out / "plan.kml", layer)
        gpkg_geoms, gpkg_fields = _read(out / "plan.gpkg", layer)
        assert list(kml_fields["Name"]) == [str(v) for v in gpkg_fields["id"]], layer
        for field, values in gpkg_fields.items():
            if field != "id" and len(values):  # (an empty Folder has no fields to read)
                got = kml_fields[field]
                if values.dtype.kind == "f":
                    np.testing.assert_allclose(got.astype(float), values, rtol=1e-12, err_msg=f"{layer}.{field}")
                else:
                    assert [str(v) for v in got] == [str(v) for v in values], f"{layer}.{field}"
        kind = pyogrio.read_info(out / "plan.gpkg", layer=layer)["geometry_type"]
        for a, b in zip(kml_geoms, gpkg_geoms, strict=True):
            assert a.geom_type + (" Z" if a.has_z else "") == kind, layer
            assert a.has_z == b.has_z == (layer in three_d)
            assert shapely.equals_exact(shapely.force_2d(a), shapely.force_2d(b), tolerance=1e-8), layer
            if b.has_z:
                np.testing.assert_allclose(shapely.get_coordinates(a, include_z=True)[:, 2],
                                           shapely.get_coordinates(b, include_z=True)[:, 2], atol=0.005)
            compared += 1
    return compared


def test_every_feature_has_the_packages_name_fields_and_geometry(written) -> None:
    """The forest plan (terrain following) in 3-D, the flat one 2-D."""
    name, plan, out = written
    three_d = frozenset({"strips", "route", "stations", "launch_points"} if name == "forest-dem" else ())
    assert _same_features_as_the_package(out, three_d) > len(plan.stations.ids)


def test_an_area_with_holes_and_a_zone(tmp_path) -> None:
    """Polygons with holes and a zone, as the package has them."""
    zone = [[15.0020, 49.4012], [15.0040, 49.4012], [15.0040, 49.4024], [15.0020, 49.4024], [15.0020, 49.4012]]
    write_geojson(tmp_path / "zone.geojson", [zone])
    spec = make_spec(tmp_path, {"area": {"exclusions": ["zone.geojson"]}, "flight": {"exclusion_margin_m": 30.0}},
                     rings=random_polygon("holed", 7, 400.0))
    loaded = load_spec(spec)
    write_outputs(plan_from_files(loaded), loaded, tmp_path / "o", gpkg=True)
    counts = {n: pyogrio.read_info(tmp_path / "o" / "plan.kml", layer=n)["features"]
              for n, _ in pyogrio.list_layers(tmp_path / "o" / "plan.kml")}
    assert counts["zones"] == 1, counts
    assert len(shapely.from_wkb(pyogrio.raw.read(tmp_path / "o" / "plan.kml", layer="area")[2][0]).geoms[0].interiors) >= 1
    assert _same_features_as_the_package(tmp_path / "o", frozenset()) > 0


def test_heights_are_absolute_in_3d_and_clamped_in_2d(written) -> None:
    name, _, out = written
    root = ET.parse(out / "plan.kml").getroot()
    modes = {f.find(f"{K}name").text: {m.text for m in f.iter(f"{K}altitudeMode")} for f in root.iter(f"{K}Folder")}
    if name == "forest-dem":
        assert modes["stations"] == modes["strips"] == {"absolute"}
    else:
        assert all(not m for m in modes.values())
        assert all(t.text == "1" for t in root.iter(f"{K}tessellate"))


def test_every_placemark_has_a_style_and_each_sortie_its_colour(written) -> None:
    _, plan, out = written
    root = ET.parse(out / "plan.kml").getroot()
    styles = {s.get("id"): s for s in root.iter(f"{K}Style")}
    for pm in root.iter(f"{K}Placemark"):
        assert pm.find(f"{K}styleUrl").text[1:] in styles
    route = next(f for f in root.iter(f"{K}Folder") if f.find(f"{K}name").text == "route")
    colours = [styles[pm.find(f"{K}styleUrl").text[1:]].find(f"{K}LineStyle/{K}color").text
               for pm in route.iter(f"{K}Placemark")]
    assert len(colours) == max(1, len(plan.sorties))
    assert len(set(colours)) == min(len(colours), 7)
    # the stations' icon colour is the package's marker colour, in KML's aabbggrr order
    r, g, b, a = (int(v) for v in STYLES["stations"].color.split(","))
    assert styles["stations"].find(f"{K}IconStyle/{K}color").text == f"{a:02x}{b:02x}{g:02x}{r:02x}"


def _layer(ids: list[str], note: list[str]) -> Layer:
    pts = shapely.points(np.column_stack([np.linspace(15.0, 15.001, len(ids)), np.full(len(ids), 49.4)]))
    return Layer("gcps", "Point", pts, (("id", np.array(ids, dtype=object)), ("note", np.array(note, dtype=object)),
                                       ("images", np.arange(len(ids), dtype=np.int64))), STYLES["gcps"])


def test_text_is_escaped_and_reads_back_unchanged(tmp_path) -> None:
    nasty = 'A&B <c> "d" \'e\' ž'
    path = tmp_path / "x.kml"
    path.write_text(layers_to_kml([_layer(["g1", nasty], [nasty, "ok"])], nasty), encoding="utf-8")
    root = ET.parse(path).getroot()
    assert root.find(f"{K}Document/{K}name").text == nasty
    _, fields = _read(path, "gcps")
    assert list(fields["Name"]) == ["g1", nasty] and list(fields["note"]) == [nasty, "ok"]
    assert list(fields["images"]) == ["0", "1"]


@pytest.mark.parametrize("bad", ["\x00", "bell\x07", "\ud800", "\ufffe", "\uffff"])
def test_a_character_xml_cannot_hold_is_refused_naming_where(bad: str) -> None:
    notes = ["ok"] * 300
    notes[201] = bad
    with pytest.raises(InputError, match=r"plan.kml: layer gcps field note = .* is not allowed: text without control "
                                         r"characters \(found U\+"):
        layers_to_kml([_layer([f"g{k}" for k in range(300)], notes)], "x")
    with pytest.raises(InputError, match=r"plan.kml: document name = .* is not allowed"):
        layers_to_kml([], f"name{bad}")


def test_a_near_zero_coordinate_is_written_without_an_exponent() -> None:
    pts = shapely.points([[0.00001, -0.000002], [1e-9, 0.0]])
    text = layers_to_kml([Layer("gcps", "Point", pts, (("id", np.array(["a", "b"], dtype=object)),), STYLES["gcps"])], "x")
    coords = [c.text for c in ET.fromstring(text).iter(f"{K}coordinates")]
    assert coords[0] == "0.00001,-0.000002" and "e" not in coords[1]
    assert [float(v) for v in coords[1].split(",")] == [0.0, 0.0]  # 1e-9 rounded to 8 decimals
