"""KML export: folders and styles per role, geometry, ExtendedData, escaping, determinism, errors."""

from __future__ import annotations

import copy
import xml.etree.ElementTree as ET

import pytest

from aerosurvey.errors import InputError
from aerosurvey.mission.formats.kml import ROLE_ORDER, STYLES, feature_collection_to_kml

NS = {"k": "http://www.opengis.net/kml/2.2"}
SQUARE = [[15.0, 49.4], [15.01, 49.4], [15.01, 49.41], [15.0, 49.41], [15.0, 49.4]]
HOLE = [[15.002, 49.402], [15.004, 49.402], [15.004, 49.404], [15.002, 49.402]]


def feature(role: str | None, geometry: dict | None, fid: str | None = None, **props) -> dict:
    p = dict(props)
    if role is not None:
        p["role"] = role
    f = {"type": "Feature", "properties": p, "geometry": geometry}
    if fid is not None:
        f["id"] = fid
    return f


def collection() -> dict:
    return {"type": "FeatureCollection", "features": [
        feature("station", {"type": "Point", "coordinates": [15.001, 49.401, 80.5]}, "P1-L001-0001", id="P1-L001-0001",
                seq=1, agl_m=80.5, line="P1-L001"),
        feature("area", {"type": "Polygon", "coordinates": [SQUARE, HOLE]}, "area", id="area", area_ha=72.1),
        feature("line", {"type": "LineString", "coordinates": [[15.001, 49.401], [15.009, 49.401]]}, "P1-L001",
                id="P1-L001", photos=12, ok=True, tags=["a", "b"], note=None),
        feature("exclusion", {"type": "MultiPolygon", "coordinates": [[SQUARE], [SQUARE, HOLE]]}, "exclusion-1"),
        feature("station", {"type": "Point", "coordinates": [15.002, 49.401]}, "P1-L001-0002", id="P1-L001-0002"),
        feature("gcp", {"type": "Point", "coordinates": [15.005, 49.405]}, "GCP-1", id="GCP-1"),
        feature("check", {"type": "MultiPoint", "coordinates": [[15.006, 49.406, 2.0], [15.007, 49.407]]}, "CHK-1"),
        feature("sortie", {"type": "MultiLineString", "coordinates": [[[15.0, 49.4], [15.01, 49.41]]]}, "sortie-01"),
        feature("footprint", {"type": "Polygon", "coordinates": [SQUARE]}, "P1-L001-0001-fp"),
        feature("balloon", {"type": "GeometryCollection", "geometries": [
            {"type": "Point", "coordinates": [15.0, 49.4]}, {"type": "LineString", "coordinates": SQUARE[:2]}]}, "odd-1"),
        feature(None, None, "nothing-1", comment="no geometry"),
    ]}


def parse(text: str) -> ET.Element:
    return ET.fromstring(text.encode("utf-8"))


def folders(root: ET.Element) -> dict[str, list[ET.Element]]:
    return {f.find("k:name", NS).text: f.findall("k:Placemark", NS) for f in root.iter(f"{{{NS['k']}}}Folder")}


def data(pm: ET.Element) -> dict[str, str]:
    return {d.get("name"): (d.find("k:value", NS).text or "") for d in pm.findall("k:ExtendedData/k:Data", NS)}


def test_one_folder_per_role_in_fixed_order_with_its_placemarks() -> None:
    root = parse(feature_collection_to_kml(collection(), "Obratan 72 ha"))
    assert root.tag == f"{{{NS['k']}}}kml"
    assert root.find("k:Document/k:name", NS).text == "Obratan 72 ha"
    f = folders(root)
    assert list(f) == ["area", "exclusion", "line", "station", "footprint", "gcp", "check", "sortie", "other"]
    assert [pm.find("k:name", NS).text for pm in f["station"]] == ["P1-L001-0001", "P1-L001-0002"]
    assert [pm.find("k:name", NS).text for pm in f["other"]] == ["odd-1", "nothing-1"]
    for role, marks in f.items():
        assert all(pm.find("k:styleUrl", NS).text == f"#{role}" for pm in marks)


def test_a_distinct_style_for_every_role() -> None:
    root = parse(feature_collection_to_kml(collection(), "x"))
    styles = {s.get("id"): s for s in root.findall("k:Document/k:Style", NS)}
    assert list(styles) == list(ROLE_ORDER) and set(STYLES) == set(ROLE_ORDER)
    looks = {(s.find("k:LineStyle/k:color", NS).text, s.find("k:PolyStyle/k:color", NS).text,
              s.find("k:IconStyle/k:color", NS).text) for s in styles.values()}
    assert len(looks) == len(styles)


def test_geometry_altitude_modes_holes_and_multi_parts() -> None:
    f = folders(parse(feature_collection_to_kml(collection(), "x")))
    high, ground = (pm.find("k:Point", NS) for pm in f["station"])
    assert high.find("k:altitudeMode", NS).text == "relativeToGround"
    assert high.find("k:coordinates", NS).text == "15.001,49.401,80.5"
    assert ground.find("k:altitudeMode", NS) is None and ground.find("k:coordinates", NS).text == "15.002,49.401"
    poly = f["area"][0].find("k:Polygon", NS)
    outer = poly.find("k:outerBoundaryIs/k:LinearRing/k:coordinates", NS).text.split()
    assert outer[0] == "15,49.4" and outer[0] == outer[-1] and len(outer) == 5
    inner = poly.findall("k:innerBoundaryIs/k:LinearRing/k:coordinates", NS)
    assert len(inner) == 1 and inner[0].text.split() == ["15.002,49.402", "15.004,49.402", "15.004,49.404", "15.002,49.402"]
    multi = f["exclusion"][0].find("k:MultiGeometry", NS)
    assert [len(p.findall("k:innerBoundaryIs", NS)) for p in multi.findall("k:Polygon", NS)] == [0, 1]
    points = f["check"][0].findall("k:MultiGeometry/k:Point", NS)
    assert [p.find("k:altitudeMode", NS) is not None for p in points] == [True, False]
    line = f["line"][0].find("k:LineString", NS)
    assert line.find("k:coordinates", NS).text == "15.001,49.401 15.009,49.401"
    assert f["sortie"][0].find("k:MultiGeometry/k:LineString", NS) is not None
    mixed = f["other"][0].find("k:MultiGeometry", NS)
    assert [c.tag.split("}")[1] for c in mixed] == ["Point", "LineString"]
    assert f["other"][1].find("k:Point", NS) is None  # a feature without geometry keeps its data


def test_unclosed_ring_is_closed() -> None:
    fc = {"type": "FeatureCollection", "features": [feature("area", {"type": "Polygon", "coordinates": [SQUARE[:4]]})]}
    ring = folders(parse(feature_collection_to_kml(fc, "x")))["area"][0].find(".//k:coordinates", NS).text.split()
    assert ring == ["15,49.4", "15.01,49.4", "15.01,49.41", "15,49.41", "15,49.4"]


def test_feature_id_and_properties_in_extended_data() -> None:
    f = folders(parse(feature_collection_to_kml(collection(), "x")))
    line = data(f["line"][0])
    assert list(line) == ["id", "note", "ok", "photos", "role", "tags"]
    assert line == {"id": "P1-L001", "note": "", "ok": "true", "photos": "12", "role": "line", "tags": '["a","b"]'}
    assert data(f["exclusion"][0]) == {"id": "exclusion-1", "role": "exclusion"}  # the feature id when no property has one
    assert data(f["other"][0])["role"] == "balloon"  # unknown role: kept in the data, placed in "other"
    assert data(f["station"][0])["agl_m"] == "80.5"


def test_text_is_escaped_and_reads_back_unchanged() -> None:
    nasty = 'A&B <c> "d" \'e\' ž'
    fc = {"type": "FeatureCollection", "features": [
        feature("gcp", {"type": "Point", "coordinates": [15.0, 49.4]}, nasty, note=nasty, **{"odd <key>": "x"})]}
    text = feature_collection_to_kml(fc, nasty)
    assert "&amp;" in text and "&lt;c&gt;" in text
    root = parse(text)
    assert root.find("k:Document/k:name", NS).text == nasty
    pm = folders(root)["gcp"][0]
    assert pm.find("k:name", NS).text == nasty
    assert data(pm) == {"id": nasty, "note": nasty, "odd <key>": "x", "role": "gcp"}


def test_deterministic_and_independent_of_property_order() -> None:
    fc = collection()
    reordered = copy.deepcopy(fc)
    for f in reordered["features"]:
        f["properties"] = dict(reversed(list(f["properties"].items())))
    text = feature_collection_to_kml(fc, "x")
    assert text == feature_collection_to_kml(copy.deepcopy(fc), "x") == feature_collection_to_kml(reordered, "x")
    assert text.startswith('<?xml version="1.0" encoding="UTF-8"?>\n') and text.endswith("</kml>\n")


def test_empty_collection_has_styles_and_no_folders() -> None:
    root = parse(feature_collection_to_kml({"type": "FeatureCollection", "features": []}, "empty"))
    assert folders(root) == {} and len(root.findall("k:Document/k:Style", NS)) == len(ROLE_ORDER)


@pytest.mark.parametrize("fc, message", [
    ({"type": "Feature"}, r"not a GeoJSON FeatureCollection with a 'features' list"),
    ({"features": [feature("area", {"type": "Circle", "coordinates": [15.0, 49.4]}, "c1")]},
     r"feature 1 \(id 'c1'\) geometry type = 'Circle' is not allowed: Point, LineString, Polygon"),
    ({"features": [feature("station", {"type": "Point", "coordinates": [15.0, float("nan")]}, "s1")]},
     r"feature 1 \(id 's1'\) Point = nan is not allowed: a finite number"),
    ({"features": [feature("station", {"type": "Point", "coordinates": [15.0]}, "s1")]},
     r"feature 1 \(id 's1'\) Point = \[15.0\] is not allowed: \[longitude, latitude\]"),
    ({"features": [feature("line", {"type": "LineString", "coordinates": [[15.0, 49.4]]}, "l1")]},
     r"LineString = \[\[15.0, 49.4\]\] is not allowed: at least 2 positions"),
    ({"features": [feature("area", {"type": "Polygon", "coordinates": [[[15.0, 49.4], [15.1, 49.4], [15.0, 49.4]]]}, "a1")]},
     r"Polygon outer ring has 2 distinct positions; a polygon ring needs at least 3"),
    ({"features": [feature("area", {"type": "Polygon"}, "a1")]}, r"feature 1 \(id 'a1'\) geometry Polygon has no 'coordinates'"),
    ({"features": [feature("gcp", {"type": "Point", "coordinates": [15.0, 49.4]}, "g1", note="bell\x07")]},
     r"feature 1 \(id 'g1'\) property 'note' = 'bell\\x07' is not allowed: text without control characters \(found U\+0007\)"),
    ({"features": ["not a feature"]}, r"feature 1 = 'not a feature' is not allowed: a GeoJSON Feature object"),
    ({"features": [feature("exclusion", {"type": "MultiPolygon", "coordinates": [[SQUARE], [SQUARE[:2]]]}, "e1")]},
     r"feature 1 \(id 'e1'\) MultiPolygon part 2 \(Polygon\) outer ring = .* is not allowed: at least 3 positions"),
])
def test_bad_input_is_refused_naming_the_feature(fc: dict, message: str) -> None:
    with pytest.raises(InputError, match=message):
        feature_collection_to_kml(fc, "x")


@pytest.mark.parametrize("where, bad", [("note", "\x00"), ("note", "\ud800"), ("note", "\ufffe"), ("note", "\uffff"),
                                        ("tags", ["ok", "\udfff"]), ("id", "s\x1f"), ("key", "\x0b")])
def test_a_character_xml_cannot_hold_is_found_anywhere_after_many_good_features(where: str, bad: object) -> None:
    """The document is checked once as a whole; the error still names the feature and the text."""
    good = [feature("station", {"type": "Point", "coordinates": [15.0 + k * 1e-5, 49.4, 80.0]}, f"s{k}", id=f"s{k}",
                    note="ž \ufffd ok", seq=k) for k in range(1, 200)]
    odd = feature("station", {"type": "Point", "coordinates": [15.0, 49.4]}, "odd")
    if where == "key":
        odd["properties"][f"k{bad}"] = 1
    else:
        odd["properties"][where] = bad
    fc = {"type": "FeatureCollection", "features": [*good[:150], odd, *good[150:]]}
    with pytest.raises(InputError, match=r"feature 151 .*is not allowed: text without control characters \(found U\+"):
        feature_collection_to_kml(fc, "x")
    fc["features"].pop(150)
    assert "ž \ufffd ok" in feature_collection_to_kml(fc, "x")
    with pytest.raises(InputError, match=r"document name = .* \(found U\+FFFF\)"):
        feature_collection_to_kml(fc, "name\uffff")
