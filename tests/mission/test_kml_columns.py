"""Point layers written a column at a time give the very text that writing their features one
by one gives, in KML and GeoJSON, for ordinary stations and for every odd value a feature can
hold; an odd point among many is refused naming that feature."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aerosurvey.errors import InputError
from aerosurvey.jsontext import Column
from aerosurvey.mission.formats import kml
from aerosurvey.mission.formats.points import PointLayer

number = st.floats(-200, 200, allow_nan=False) | st.builds(round, st.floats(-200, 200), st.integers(0, 9)) \
    | st.sampled_from([1e-5, -0.0, 3.0, 1e16, 2.5e-7])
value = (st.none() | st.booleans() | st.integers(-10**6, 10**6) | number | st.sampled_from([math.nan, math.inf])
         | st.text(alphabet=st.sampled_from('aZ-&<>"\' ž%\u2028'), max_size=6) | st.lists(st.integers(), max_size=2))


def stations(n: int) -> list[dict]:
    return [{"type": "Feature", "id": f"P1-L001-S{k:04d}", "properties": {
        "role": "station", "id": f"P1-L001-S{k:04d}", "seq": k, "line": "P1-L001", "alt_rel_m": 80.25 + k, "agl_m": 80.0,
        "heading_deg": 12.5}, "geometry": {"type": "Point", "coordinates": [15.0 + k * 1e-5, 49.4 + k * 1e-6]}}
        for k in range(1, n + 1)]


def test_stations_as_a_layer_and_one_by_one() -> None:
    feats = stations(500)
    names = list(feats[0]["properties"])
    layer = PointLayer(tuple(f["id"] for f in feats), tuple((k, tuple(f["properties"][k] for f in feats)) for k in names),
                       tuple(f["geometry"]["coordinates"][0] for f in feats), tuple(f["geometry"]["coordinates"][1] for f in feats))
    assert layer.features() == feats
    fc = {"type": "FeatureCollection", "features": feats}
    empty = {"type": "FeatureCollection", "features": []}
    assert kml.feature_collection_to_kml(empty, "x", [layer]) == kml._document(fc, "x", kml._escaped)


@pytest.mark.parametrize("coords, message", [([15.0, math.nan], "Point = nan is not allowed"),
                                              ([15.0, 49.4, "80"], "Point = '80' is not allowed: a finite number"),
                                              ([15.0], r"Point = \[15.0\] is not allowed")])
def test_an_odd_point_among_many_is_named(coords: list, message: str) -> None:
    feats = stations(300)
    feats[200]["geometry"]["coordinates"] = coords
    with pytest.raises(InputError, match=rf"feature 201 \(id 'P1-L001-S0201'\) {message}"):
        kml.feature_collection_to_kml({"type": "FeatureCollection", "features": feats}, "x")


@st.composite
def layers(draw: st.DrawFn) -> PointLayer:
    n = draw(st.integers(0, 10))
    names = draw(st.lists(st.sampled_from(["id", "seq", "alt_rel_m", "note", "%s"]), unique=True, max_size=4))
    roles = draw(st.lists(st.sampled_from(["station", "gcp", "bogus"]), min_size=1, max_size=2))  # two: one by one
    props = (("role", tuple(draw(st.sampled_from(roles)) for _ in range(n))),) \
        + tuple((k, tuple(draw(value) for _ in range(n))) for k in names)
    return PointLayer(tuple(f"S{i}" for i in range(n)), props, tuple(draw(number) for _ in range(n)),
                      tuple(draw(number) for _ in range(n)))


@settings(max_examples=200)
@given(layers())
def test_a_layer_is_written_as_its_features_would_be(layer: PointLayer) -> None:
    others = [{"type": "Feature", "id": "area", "properties": {"role": "area"},
               "geometry": {"type": "Point", "coordinates": [1.0, 2.0]}},
              {"type": "Feature", "id": "g0", "properties": {"role": "gcp"}, "geometry": {"type": "Point", "coordinates": [1.5, 2.5]}}]
    fc = {"type": "FeatureCollection", "features": others}
    whole = {"type": "FeatureCollection", "features": others + layer.features()}
    # the same columns as jsontext.Columns (texts made once, as the stations' shared with the manifest)
    cached = PointLayer(Column(layer.ids), tuple((k, Column(v)) for k, v in layer.properties), Column(layer.lon),
                        Column(layer.lat))
    for _ in range(2):  # the second time from the columns' texts
        assert kml.feature_collection_to_kml(fc, "x", [layer]) == kml.feature_collection_to_kml(fc, "x", [cached]) \
            == kml.feature_collection_to_kml(whole, "x")
    try:
        text = json.dumps(layer.features(), separators=(",", ":"), ensure_ascii=False, allow_nan=False)[1:-1]
    except ValueError:  # a NaN: plan.geojson refuses it as json did
        with pytest.raises(ValueError):
            layer.geojson()
        with pytest.raises(ValueError):
            cached.geojson()
        return
    assert layer.geojson() == cached.geojson() == text  # as plan.geojson was written


def test_a_layer_with_a_character_xml_cannot_hold_is_named() -> None:
    layer = PointLayer(("a", "b"), (("role", ("station", "station")), ("note", ("ok", "bell\x07"))), (1.0, 2.0), (3.0, 4.0))
    with pytest.raises(InputError, match=r"feature 2 \(id 'b'\) property 'note'"):
        kml.feature_collection_to_kml({"type": "FeatureCollection", "features": []}, "x", [layer])


def test_a_layer_needs_a_value_for_every_feature() -> None:
    with pytest.raises(ValueError, match="one value per feature"):
        PointLayer(("a", "b"), (("seq", (1,)),), (1.0, 2.0), (3.0, 4.0))


def _from_arrays(layer: PointLayer) -> PointLayer:
    """The layer's columns as the station table makes them where it can: strings by codes (a
    role of one name among them), finite floats and integers from arrays."""
    def made(col: tuple) -> tuple:
        kinds = set(map(type, col))
        if kinds == {str}:
            names = sorted(set(col))
            return Column.of_codes(names, np.array([names.index(v) for v in col], dtype=np.intp))
        if kinds == {float} and all(math.isfinite(v) for v in col):
            return Column.of_array(np.array(col, float))
        if kinds == {int} and all(abs(v) < 2**63 for v in col):
            return Column.of_array(np.array(col, dtype=np.int64))
        return col
    return PointLayer(made(layer.ids), tuple((k, made(v)) for k, v in layer.properties), made(layer.lon), made(layer.lat))


@settings(max_examples=200)
@given(layers())
def test_a_layer_of_array_and_code_columns_is_written_as_its_features_would_be(layer: PointLayer) -> None:
    fc = {"type": "FeatureCollection", "features": []}
    fast = _from_arrays(layer)
    assert fast.features() == layer.features()
    assert kml.feature_collection_to_kml(fc, "x", [fast]) == kml.feature_collection_to_kml(
        {**fc, "features": layer.features()}, "x")
    try:
        text = json.dumps(layer.features(), separators=(",", ":"), ensure_ascii=False, allow_nan=False)[1:-1]
    except ValueError:
        return
    assert fast.geojson() == text


@given(st.lists(st.text(alphabet=st.sampled_from('aZ-&<>"\' ž\t\n\r\x07\x1f\x7f\ud800\ufffe'), max_size=5), max_size=8))
def test_escaped_all_is_each_text_escaped(texts: list[str]) -> None:
    assert kml._escaped_all(texts) == [kml._escaped(t, "x") for t in texts]


@given(st.text(alphabet=st.sampled_from('aZ-&<>"\' ž\t\n\r\x00\x07\x0b\x1f\x7f\ud800\udfff\ufffe\uffff'), max_size=8))
def test_mark_is_translate(text: str) -> None:
    assert kml._mark(text) == text.translate(kml._ESC_MARK)
