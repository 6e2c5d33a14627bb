"""Point layers (mission/formats/points.py) written a column at a time give the text json writes
for their features, for ordinary stations and for every odd value a feature can hold, whether
their columns are plain tuples, jsontext.Columns, or Columns made from arrays and codes."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aerosurvey.jsontext import Column
from aerosurvey.mission.formats.points import PointLayer

number = st.floats(-200, 200, allow_nan=False) | st.builds(round, st.floats(-200, 200), st.integers(0, 9)) \
    | st.sampled_from([1e-5, -0.0, 3.0, 1e16, 2.5e-7])
value = (st.none() | st.booleans() | st.integers(-10**6, 10**6) | number | st.sampled_from([math.nan, math.inf])
         | st.text(alphabet=st.sampled_from('aZ-&<>"\' ž%\u2028'), max_size=6) | st.lists(st.integers(), max_size=2))


@st.composite
def layers(draw: st.DrawFn) -> PointLayer:
    n = draw(st.integers(0, 10))
    names = draw(st.lists(st.sampled_from(["id", "seq", "alt_rel_m", "note", "%s"]), unique=True, max_size=4))
    roles = draw(st.lists(st.sampled_from(["station", "gcp", "bogus"]), min_size=1, max_size=2))
    props = (("role", tuple(draw(st.sampled_from(roles)) for _ in range(n))),) \
        + tuple((k, tuple(draw(value) for _ in range(n))) for k in names)
    return PointLayer(tuple(f"S{i}" for i in range(n)), props, tuple(draw(number) for _ in range(n)),
                      tuple(draw(number) for _ in range(n)))


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
def test_a_layer_is_written_as_json_writes_its_features(layer: PointLayer) -> None:
    columns = PointLayer(Column(layer.ids), tuple((k, Column(v)) for k, v in layer.properties), Column(layer.lon),
                         Column(layer.lat))
    fast = _from_arrays(layer)
    assert fast.features() == columns.features() == layer.features()
    try:
        text = json.dumps(layer.features(), separators=(",", ":"), ensure_ascii=False, allow_nan=False)[1:-1]
    except ValueError:  # a NaN: plan.geojson refuses it as json did
        for each in (layer, columns, fast):
            with pytest.raises(ValueError):
                each.geojson()
        return
    assert layer.geojson() == columns.geojson() == fast.geojson() == text


def test_a_layer_needs_a_value_for_every_feature() -> None:
    with pytest.raises(ValueError, match="one value per feature"):
        PointLayer(("a", "b"), (("seq", (1,)),), (1.0, 2.0), (3.0, 4.0))
