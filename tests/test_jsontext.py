"""jsontext writes numbers and rows exactly as Python's json and repr do (the manifest and the
KML keep their bytes), and compact documents that read back to the same data."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from aerosurvey.jsontext import (
    Column,
    dumps_compact,
    dumps_indented,
    float_texts,
    int_texts,
    join_rows,
    one_value,
    pair_texts,
    quoted_as_is,
    rows_text,
    string_texts,
    value_texts,
)

finite = st.floats(allow_nan=False, allow_infinity=False)
# the numbers plans write: coordinates and heights rounded to a few decimals
rounded = st.builds(round, st.floats(-1e5, 1e5, allow_nan=False), st.integers(0, 9))


@given(st.lists(finite | rounded, max_size=60))
def test_float_texts_is_repr(xs: list[float]) -> None:
    assert float_texts(xs) == [repr(x) for x in xs]


@pytest.mark.parametrize("x", [0.0, -0.0, 1e-4, 9.99e-5, 1e-5, 5e-324, 1e16, 9999999999999998.0, 1.7976931348623157e308,
                               -1e22, 0.1, 14.12345678, 1.0, 100.0])
def test_float_texts_edges(x: float) -> None:
    assert float_texts([x, x]) == [repr(x)] * 2
    assert float_texts(np.array([[x, 1.5], [x, 2.5]])[:, 0]) == [repr(x)] * 2  # a strided view


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_float_texts_refuses_what_json_refuses(bad: float) -> None:
    with pytest.raises(ValueError, match="not finite"):
        float_texts([1.0, bad])
    with pytest.raises(ValueError):
        json.dumps(bad, allow_nan=False)


scalar = st.none() | st.booleans() | st.integers(-10**20, 10**20) | finite | st.text(max_size=8)


@given(st.lists(scalar, max_size=30))
def test_value_texts_is_json(values: list[object]) -> None:
    assert value_texts(values) == [json.dumps(v, ensure_ascii=False, separators=(",", ":")) for v in values]


@given(st.integers(0, 5).flatmap(lambda n: st.lists(
    st.fixed_dictionaries({f"k{i}": scalar for i in range(n)}), min_size=1, max_size=20)))
def test_rows_text_is_the_json_encoder(rows: list[dict[str, object]]) -> None:
    enc = json.JSONEncoder(ensure_ascii=False, allow_nan=False, separators=(", ", ": "))
    if all(tuple(r) == tuple(rows[0]) for r in rows):
        assert rows_text(rows, ",\n ") == ",\n ".join(enc.encode(r) for r in rows)
    else:  # the same keys in another order: the caller encodes them
        assert rows_text(rows, ",") is None


def test_rows_text_leaves_unlike_rows_to_the_caller() -> None:
    assert rows_text([{"a": 1}, {"b": 1}], ",") is None  # other keys
    assert rows_text([{"a": 1, "b": 2}, {"b": 2, "a": 1}], ",") is None  # other order
    assert rows_text([{"a": 1}, {"a": 1, "b": 2}], ",") is None  # more keys
    assert rows_text([{"a": [1, 2]}], ",") is None  # not flat
    assert rows_text([{"a": np.float64(1.5)}], ",") is None  # not a plain float
    assert rows_text([{"%s": "50%", "b": "%d"}], ",") == '{"%s": "50%", "b": "%d"}'  # % in keys and values
    assert rows_text([], ",") == ""
    with pytest.raises(ValueError):
        rows_text([{"a": math.nan}], ",")


@given(st.lists(st.lists(st.text(max_size=3), min_size=3, max_size=3), max_size=20), st.text(max_size=2))
def test_join_rows_is_a_join_of_rows(rows: list[list[str]], sep: str) -> None:
    cols = [list(c) for c in zip(*rows)] or [[], [], []]
    assert join_rows(["<", cols[0], "|", cols[1], cols[2], ">"], len(rows), sep) == sep.join(
        f"<{a}|{b}{c}>" for a, b, c in rows)


def test_join_rows_refuses_a_short_column() -> None:
    with pytest.raises(ValueError):
        join_rows(["a", ["1", "2"]], 3, ",")


json_data = st.recursive(scalar, lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=5), inner, max_size=4),
                         max_leaves=25)


@given(json_data)
def test_dumps_compact_reads_back_the_same(data: object) -> None:
    text = dumps_compact(data)
    assert json.loads(text) == data
    assert text == json.dumps(data, separators=(",", ":"), ensure_ascii=False)  # the very text json writes


@pytest.mark.parametrize("x", [5e-05, -5e-05, 1e-07, 1.23e-08, 5e-324, 1e16, -2.5e22, 1.7976931348623157e308])
def test_dumps_compact_spells_exponents_as_json(x: float) -> None:
    # coordinates within ~11 m of the Greenwich meridian or the equator are such numbers
    data = [x, {"c": [14.5, x]}, "0.00005 1e-7"]
    assert dumps_compact(data) == json.dumps(data, separators=(",", ":"), ensure_ascii=False)
    a = np.array([[x, 51.5], [0.0001, -0.0]])
    assert dumps_compact(a) == json.dumps(a.tolist(), separators=(",", ":"))


@pytest.mark.parametrize("bad", [math.nan, math.inf, np.array([1.0, math.nan])])
def test_dumps_compact_refuses_what_json_refuses(bad: object) -> None:
    # orjson writes a NaN or an infinity as null: that would be a value silently lost
    with pytest.raises(ValueError):
        dumps_compact({"a": [1, None, bad]})


def test_dumps_compact_numpy_arrays_as_lists() -> None:
    a = np.round(np.random.default_rng(1).uniform(-180, 180, (50, 5, 2)), 8)
    assert dumps_compact(a) == json.dumps(a.tolist(), separators=(",", ":"))


finite_data = st.recursive(st.none() | st.booleans() | st.integers(-10**20, 10**20) | finite | rounded | st.text(max_size=8),
                           lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=5), inner, max_size=4),
                           max_leaves=30)


@given(finite_data)
def test_dumps_indented_is_json_indent_4_sorted(data: object) -> None:
    assert dumps_indented(data) == json.dumps(data, indent=4, sort_keys=True, ensure_ascii=False)


@pytest.mark.parametrize("data", [
    {}, [], {"a": [], "b": {}, "c": [[], [{}]]},  # empty containers stay on their line
    {"b": [1, {"d": [2.5, None, "x  y"], "c": True}], "a": "\n\t\b\f\x01\x7f\u2028é"},  # escapes, spaces in strings
    {"z": 5e-05, "y": [1e-07, -2.5e22, 1e16, 0.0001, -0.0]},  # numbers orjson spells its own way
    {"n": 10**30}, {1: "non-string key"},  # what orjson refuses
    {"deep": [[[[[[[[1.5]]]]]]]]},
])
def test_dumps_indented_edges(data: object) -> None:
    assert dumps_indented(data) == json.dumps(data, indent=4, sort_keys=True, ensure_ascii=False)


@given(st.lists(scalar, max_size=30))
def test_a_column_writes_as_its_values(values: list[object]) -> None:
    col = Column(values)
    assert col == tuple(values)
    assert value_texts(col) == value_texts(values) == value_texts(col)  # made once, the same each time
    if all(type(v) is float for v in values):
        assert float_texts(col) == float_texts(values)
    if all(type(v) is str for v in values):
        assert string_texts(col) == string_texts(values)


def test_a_column_refuses_what_json_refuses_each_time() -> None:
    col = Column([1.0, math.nan])
    for _ in range(2):
        with pytest.raises(ValueError, match="not finite"):
            float_texts(col)
    two = Column([1.5, 2.5])
    texts = value_texts(two)
    texts[0] = "changed"  # a copy: the column's texts stay
    assert value_texts(two) == float_texts(two) == ["1.5", "2.5"]


@given(st.lists(st.tuples(finite | rounded, finite | rounded), max_size=40))
def test_pair_texts_is_the_inside_of_json_pairs(pairs: list[tuple[float, float]]) -> None:
    x = np.array([p[0] for p in pairs], float)
    y = np.array([p[1] for p in pairs], float)
    assert pair_texts(x, y) == [json.dumps([p, q], separators=(",", ":"))[1:-1] for p, q in pairs]


@pytest.mark.parametrize("odd", [5e-05, -1e-07, 1e16, 0.0, -0.0, 1e-4])
def test_pair_texts_spells_every_number_as_json(odd: float) -> None:
    x, y = np.array([14.5, odd, 1.0]), np.array([odd, 49.25, -2.5])
    assert pair_texts(x, y) == [json.dumps([p, q], separators=(",", ":"))[1:-1] for p, q in zip(x.tolist(), y.tolist())]
    with pytest.raises(ValueError, match="not finite"):
        pair_texts(x, np.array([1.0, math.nan, 2.0]))


@given(st.lists(st.text(max_size=6), max_size=8))
def test_quoted_as_is_says_when_json_escapes_nothing(values: list[str]) -> None:
    assert quoted_as_is(values) == all(json.dumps(v, ensure_ascii=False) == f'"{v}"' for v in values)


@given(st.lists(rounded | st.sampled_from([0.0, -0.0, 1e-4, 123456789.12345678]), max_size=40),
       st.lists(rounded | st.just(-0.0), max_size=40))
def test_pair_texts_without_exponents_is_json(xs: list[float], ys: list[float]) -> None:
    """The orjson path (no value written with an exponent), against json's own pairs."""
    n = min(len(xs), len(ys))
    x, y = np.array(xs[:n], float), np.array(ys[:n], float)
    assert pair_texts(x, y) == [json.dumps([p, q], separators=(",", ":"))[1:-1] for p, q in zip(xs[:n], ys[:n])]


@given(st.lists(finite | rounded | st.just(-0.0), max_size=40))
def test_a_column_of_a_float_array_writes_as_json(values: list[float]) -> None:
    a = np.array(values, float)
    col = Column.of_array(a)
    assert col == tuple(values)
    assert col.kinds == frozenset(map(type, values))
    assert value_texts(col) == float_texts(col) == [json.dumps(v) for v in values]
    assert value_texts(Column.of_array(np.array([values, values]).T[:, 0])) == [json.dumps(v) for v in values]  # strided


@given(st.lists(st.integers(-2**63, 2**63 - 1), max_size=40))
def test_a_column_of_an_int_array_writes_as_json(values: list[int]) -> None:
    col = Column.of_array(np.array(values, dtype=np.int64))
    assert col == tuple(values)
    assert all(type(v) is int for v in col)
    assert col.kinds == frozenset(map(type, col))
    assert value_texts(col) == [json.dumps(v) for v in values]


def test_a_column_of_an_array_reads_as_its_values() -> None:
    a = np.array([1.5, -0.0, 2.0])
    col = Column.of_array(a)
    a[0] = 9.0  # the column keeps its own copy
    assert col == (1.5, -0.0, 2.0) and list(col) == [1.5, -0.0, 2.0] and len(col) == 3
    assert type(col[0]) is float and col[-1] == 2.0 and col[1:] == (-0.0, 2.0)
    ints = Column.of_array(np.arange(3))
    assert type(ints[2]) is int and tuple(ints) == (0, 1, 2)
    codes = Column.of_codes(["a", "b"], np.array([1, 0, 1]))
    assert codes == ("b", "a", "b") and codes[0] == "b" and codes == Column(["b", "a", "b"])
    assert col != [1.5, -0.0, 2.0]  # equal to a tuple of its values, as a tuple is


@given(st.lists(finite | rounded, max_size=30))
def test_a_column_of_an_array_without_texts_writes_as_json(values: list[float]) -> None:
    a = np.array(values, float)
    col = Column(a, kinds=frozenset({float}) if values else frozenset())
    assert col.texts is None and np.array_equal(np.asarray(col), a)
    assert not len(a) or np.shares_memory(np.asarray(col), a)  # the array itself (a read-only view), not a copy
    assert value_texts(col) == float_texts(col) == [json.dumps(v) for v in values]


@pytest.mark.parametrize("dtype", [np.int8, np.uint8, np.int32, np.uint32, np.int64, np.uint64])
def test_int_texts_is_str_of_each_value(dtype: type) -> None:
    info = np.iinfo(dtype)
    a = np.array([info.min, info.max, 0, 1, info.max // 3, info.min // 7], dtype=dtype)
    assert int_texts(a) == [str(v) for v in a.tolist()]
    assert int_texts(a[::2]) == [str(v) for v in a[::2].tolist()]  # strided
    assert int_texts(np.array([], dtype=dtype)) == []
    with pytest.raises(ValueError):
        int_texts(np.array([1.0]))


@pytest.mark.parametrize("a", [np.array([1.0, math.nan]), np.array([math.inf]), np.array([[1.0]]), np.array(["a"])])
def test_a_column_of_an_array_refuses_what_it_cannot_write(a: np.ndarray) -> None:
    with pytest.raises(ValueError):
        Column.of_array(a)


@given(st.lists(st.text(max_size=6), min_size=1, max_size=5).flatmap(
    lambda names: st.tuples(st.just(names), st.lists(st.integers(0, len(names) - 1), max_size=30))))
def test_a_column_of_codes_writes_its_names_as_json(case: tuple[list[str], list[int]]) -> None:
    names, codes = case
    col = Column.of_codes(names, np.array(codes, dtype=np.int64))
    assert col == tuple(names[c] for c in codes)
    assert col.kinds == frozenset(map(type, col))
    assert value_texts(col) == string_texts(col) == [json.dumps(names[c], ensure_ascii=False) for c in codes]
    assert one_value(col) == (names[0] if len(names) == 1 and codes else None)


def test_one_value_is_only_for_a_column_of_one_name() -> None:
    assert one_value(Column.of_codes(["ž"], np.zeros(3, int))) == "ž"
    assert one_value(Column(["a", "a"])) is None  # not known without reading every value
    assert one_value(["a"]) is None
    with pytest.raises(ValueError):
        Column.of_codes([1], np.zeros(1, int))  # type: ignore[list-item]


@given(st.lists(st.lists(st.text(max_size=3), min_size=2, max_size=2), max_size=12), st.text(max_size=2),
       st.lists(st.sampled_from(["c0", "c1", "a", "b", ""]), max_size=7))
def test_join_rows_with_texts_side_by_side(rows: list[list[str]], sep: str, layout: list[str]) -> None:
    """Texts next to each other, at the ends or alone (joined before the rows are): the plain join of rows."""
    cols = [list(c) for c in zip(*rows)] or [[], []]
    parts: list[str | list[str]] = [cols[int(p[1])] if p in ("c0", "c1") else p for p in layout]
    expected = sep.join("".join(p if isinstance(p, str) else p[i] for p in parts) for i in range(len(rows)))
    assert join_rows(parts, len(rows), sep) == expected


def test_a_columns_array_is_read_only_and_copies_when_asked():
    """Its texts were made from its values: no view of them may change them."""
    import numpy as np
    import pytest

    from aerosurvey.jsontext import Column

    col = Column.of_array(np.array([1.5, 2.5]))
    with pytest.raises(ValueError):
        np.asarray(col)[0] = 9.0
    copied = np.array(col, copy=True)
    copied[0] = 9.0
    assert tuple(col) == (1.5, 2.5) and col.texts == ("1.5", "2.5")
