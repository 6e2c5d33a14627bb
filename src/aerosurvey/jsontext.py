"""JSON text fast: compact documents, flat rows and numbers, written by orjson's encoder.

Why: a 1,000 ha plan writes about 200,000 numbers (footprint corners, station positions and
heights) into plan.geojson, plan.kml and manifest.json. CPython's `repr(float)` (which json's
C encoder calls) costs about 450 ns a number on our 2-core machine, so the numbers alone took
about 100 ms; orjson, a well-kept library, writes the same shortest round-trip digits about
ten times faster (measured in the commit that added this module).

What is the same and what is not:
- `float_texts` gives exactly `repr(v)` for every finite float (the exponent forms, which
  orjson spells differently, are made by `repr` itself), so KML and the manifest keep their
  bytes.
- `dumps_compact` is `json.dumps(obj, separators=(",", ":"), ensure_ascii=False,
  allow_nan=False)` but for the spelling of numbers that need an exponent: orjson writes
  `5e-5` and `1e16` where json writes `5e-05` and `1e+16`; every JSON reader reads both as
  the same number. It checks no number: a NaN would become `null`, so callers pass only
  finite numbers (the GeoJSON builder checks its arrays).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any

import numpy as np
import orjson

# json's own string encoder (C), as json.dumps(..., ensure_ascii=False) writes a string
_encode_str = json.encoder.c_encode_basestring or json.encoder.py_encode_basestring  # type: ignore[attr-defined]


def dumps_compact(obj: Any) -> str:
    """Compact JSON text (no spaces), non-ASCII kept as it is, numpy arrays as nested lists. See the module docstring."""
    try:
        return orjson.dumps(obj, option=orjson.OPT_SERIALIZE_NUMPY).decode("utf-8")
    except orjson.JSONEncodeError:  # what orjson cannot write (an integer beyond 64 bits …): json writes it or says why
        return json.dumps(obj, separators=(",", ":"), ensure_ascii=False, allow_nan=False, default=_array_as_list)


def _array_as_list(o: Any) -> Any:
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(f"Object of type {type(o).__name__} is not JSON serializable")


def float_texts(values: Sequence[float] | np.ndarray) -> list[str]:
    """`repr(v)` of every value, which must all be finite floats; ValueError names the first that is not."""
    a = np.asarray(values, dtype=float)
    if a.ndim != 1:
        a = a.ravel()
    if not len(a):
        return []
    finite = np.isfinite(a)
    if not finite.all():
        raise ValueError(f"number {a[~finite][0]!r} is not finite")
    texts = orjson.dumps(a, option=orjson.OPT_SERIALIZE_NUMPY).decode("ascii")[1:-1].split(",")
    mag = np.abs(a)
    # Python writes an exponent below 1e-4 and from 1e16 on; orjson spells those its own way
    for i in np.flatnonzero((mag >= 1e16) | ((mag < 1e-4) & (mag > 0))).tolist():
        texts[i] = repr(float(a[i]))
    return texts


def string_texts(values: Sequence[str]) -> list[str]:
    """Each string as a JSON string literal, exactly as json.dumps(ensure_ascii=False) writes it."""
    return list(map(_encode_str, values))


def value_texts(values: Sequence[Any]) -> list[str]:
    """JSON text of each value of one column, as json writes it: floats through `float_texts`
    (in one call), None as null; a column of one plain type is made in one pass."""
    kinds = set(map(type, values))
    if kinds == {float}:
        return float_texts(values)
    if kinds == {str}:
        return list(map(_encode_str, values))
    if kinds == {int}:
        return list(map(int.__repr__, values))
    at = [i for i, v in enumerate(values) if type(v) is float]
    enc = json.JSONEncoder(ensure_ascii=False, allow_nan=False, separators=(",", ":")).encode
    out = ["null" if v is None else _encode_str(v) if type(v) is str else "" if type(v) is float else enc(v)
           for v in values]
    for i, text in zip(at, float_texts([values[i] for i in at])):
        out[i] = text
    return out


_FLAT = frozenset({str, int, float, bool, type(None)})


def rows_text(rows: Sequence[dict[str, Any]], item_sep: str = ", ", key_sep: str = ": ") -> list[str] | None:
    """One JSON object text per row, as json.JSONEncoder(separators=(item_sep, key_sep),
    ensure_ascii=False, allow_nan=False) writes it; None unless every row has the same keys in
    the same order and only numbers, strings, booleans and None as values (their exact types, no subclasses) (the caller then
    encodes the rows itself). Made a column at a time, so the numbers go through `float_texts`."""
    if not rows:
        return []
    keys = tuple(rows[0])
    columns: list[list[str]] = []
    for k in keys:
        try:
            col = [r[k] for r in rows]
        except KeyError:
            return None
        if not _FLAT.issuperset(map(type, col)):
            return None
        columns.append(value_texts(col))
    if not all(type(k) is str for k in keys) or any(len(r) != len(keys) or tuple(r) != keys for r in rows):
        return None
    if not keys:
        return ["{}"] * len(rows)
    lit = (item_sep.replace("%", "%%"), key_sep.replace("%", "%%"))
    template = "{" + lit[0].join(_encode_str(k).replace("%", "%%") + lit[1] + "%s" for k in keys) + "}"
    return list(map(template.__mod__, zip(*columns)))
