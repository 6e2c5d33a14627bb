"""JSON text fast: compact documents, flat rows and numbers, written by orjson's encoder.

Why: a 1,000 ha plan writes about 200,000 numbers (footprint corners, station positions and
heights) into plan.geojson and manifest.json. CPython's `repr(float)` (which json's
C encoder calls) costs about 450 ns a number on our 2-core machine, so the numbers alone took
about 100 ms; orjson, a well-kept library, writes the same shortest round-trip digits about
ten times faster (measured in the commit that added this module).

What is the same and what is not:
- `float_texts` gives exactly `repr(v)` for every finite float (the exponent forms, which
  orjson spells differently, are made by `repr` itself), so the manifest keeps its
  bytes.
- `dumps_compact` is exactly `json.dumps(obj, separators=(",", ":"), ensure_ascii=False,
  allow_nan=False)`: orjson's text is kept unless it holds a number orjson spells its own
  way (below 1e-4 it writes `0.00005` or `1e-7` where json writes `5e-05` and `1e-07`: a
  plan within ~11 m of the Greenwich meridian or the equator has such coordinates) or a
  `null` (orjson writes NaN and infinity as null); then json writes it, or refuses a NaN.
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterable, Iterator, Sequence
from operator import itemgetter
from typing import Any, overload

import numpy as np
import orjson

# json's own string encoder (C), as json.dumps(..., ensure_ascii=False) writes a string
_encode_str = json.encoder.c_encode_basestring or json.encoder.py_encode_basestring  # type: ignore[attr-defined]


def dumps_compact(obj: Any) -> str:
    """Compact JSON text (no spaces), non-ASCII kept as it is, numpy arrays as nested lists. See the module docstring."""
    try:
        text = orjson.dumps(obj, option=orjson.OPT_SERIALIZE_NUMPY).decode("utf-8")
    except orjson.JSONEncodeError:  # what orjson cannot write (an integer beyond 64 bits …): json writes it or says why
        text = None
    if text is None or _maybe_not_as_json(text):
        return json.dumps(obj, separators=(",", ":"), ensure_ascii=False, allow_nan=False, default=_array_as_list)
    return text


def dumps_indented(obj: Any) -> str:
    """`json.dumps(obj, indent=4, sort_keys=True, ensure_ascii=False)` for data whose floats
    are all finite (the caller's promise: orjson writes NaN and infinity as null, and a null
    cannot be told from None afterwards; qgc_plan checks every number it puts in).

    orjson writes the text with an indent of 2 (json's indent falls back to its pure-Python
    encoder: measured on the 1,000 ha plan's mission.plan, 184 kB, ~5 ms against ~1.5 ms), and
    the indent is doubled; its text is kept unless a number in it may be spelled otherwise (see
    `dumps_compact`), keys are not all strings, or a string holds a control character."""
    try:
        raw = orjson.dumps(obj, option=orjson.OPT_INDENT_2 | orjson.OPT_SORT_KEYS).decode("utf-8")
        # compact, the text holds no space outside its strings
        spaced = b"  " in orjson.dumps(obj)
    except orjson.JSONEncodeError:  # non-string keys, integers beyond 64 bits, surrogates …
        raw = None
    if raw is None or _odd_numbers(raw) or _CONTROL.search(raw):
        return json.dumps(obj, indent=4, sort_keys=True, ensure_ascii=False, default=_array_as_list)
    return _double_indent(raw, spaced)


# json escapes these as \u00XX; orjson may spell some of them its own way (\b, \f): json writes those
_CONTROL = re.compile(r"\\u00[01]|\\[bf]")


def _double_indent(text: str, strings_have_double_spaces: bool) -> str:
    """JSON text indented by 2 spaces a level, indented by 4. Its strings hold no raw newline
    or tab (JSON escapes them), so a line starts with its indent. Unless a string holds two
    spaces in a row, every pair of spaces is indent, and a line's k pairs become 2k by one
    replace (measured on the 1,000 ha plan's mission.plan, 6,400 lines: 0.5 ms, against 0.8 ms
    for pairs made tabs and `expandtabs(4)`, and 1.7 ms line by line, which is the way when a
    string holds two spaces)."""
    if not strings_have_double_spaces:
        return text.replace("  ", "    ")
    return "\n".join([line[:len(line) - len(line.lstrip(" "))] + line for line in text.split("\n")])


def _maybe_not_as_json(text: str) -> bool:
    """Whether orjson's text may differ from json's: a number with an exponent (1e-7, 1e+16),
    one below 1e-4 written without (0.00005), a null (maybe a NaN or an infinity). Found in a
    string too, it merely has json write the same text. By str.find, not a regular expression
    (~70 ms a megabyte), as most of plan.geojson passes through here."""
    return "null" in text or _odd_numbers(text)


def _odd_numbers(text: str) -> bool:
    """Whether orjson's text may hold a number json spells otherwise (see `_maybe_not_as_json`)."""
    for mark, before in (("e-", "0123456789"), ("e+", "0123456789"), ("0.0000", "-[,: \n")):
        i = text.find(mark)
        while i != -1:
            if i == 0 or text[i - 1] in before:
                return True
            i = text.find(mark, i + 1)
    return False


def _array_as_list(o: Any) -> Any:
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(f"Object of type {type(o).__name__} is not JSON serializable")


class Column(Sequence[Any]):
    """A column of plain JSON values, the types of its values (`kinds`) and, for a column made
    from an array or from codes, the JSON text of each value (`texts`, made by one orjson call
    when the column is made; None otherwise, when a writer makes them). A plan's stations go
    into plan.geojson and manifest.json, the same rounded positions and heights each time.
    `one` is the name of a column of one name repeated (the role).

    A column made from an array or from codes keeps that array and reads its values off it when
    they are asked for (iterating, indexing: the rules read the station table's rows), as
    writers read only the texts. Measured on benchmarks/inprocess_bench.py's 1,000 ha case: the
    station table's 14 columns of 7,163 values held as Python objects cost ~3 ms a render (made,
    then scanned by the garbage collector)."""

    __slots__ = ("_values", "kinds", "texts", "one")
    kinds: frozenset[type]
    texts: tuple[str, ...] | None
    one: str | None

    def __init__(self, values: Iterable[Any] | np.ndarray = (), texts: Sequence[str] | None = None,
                 one: str | None = None, kinds: frozenset[type] | None = None) -> None:
        """`kinds`, when the maker knows them (an array's dtype, strings by code), else read off the values."""
        if isinstance(values, np.ndarray):
            values = values.view()
            values.flags.writeable = False  # the texts were made from these values: read-only through every view
        self._values: tuple[Any, ...] | np.ndarray = values if isinstance(values, np.ndarray) else tuple(values)
        self.kinds = frozenset(map(type, self)) if kinds is None else kinds
        self.texts = None if texts is None else tuple(texts)
        self.one = one

    def __len__(self) -> int:
        return len(self._values)

    def __iter__(self) -> Iterator[Any]:
        return iter(self._values.tolist() if isinstance(self._values, np.ndarray) else self._values)

    @overload
    def __getitem__(self, i: int) -> Any: ...

    @overload
    def __getitem__(self, i: slice) -> tuple[Any, ...]: ...

    def __getitem__(self, i: int | slice) -> Any:
        v = self._values[i]
        if isinstance(v, np.ndarray):  # a slice of the array
            return tuple(v.tolist())
        return v.item() if isinstance(v, np.generic) else v

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        """The values as an array: a column made from one gives it, read-only (numpy reads it as
        it is), or a copy of it when `copy` is asked."""
        a = self._values if isinstance(self._values, np.ndarray) else np.array(self._values, dtype=object)
        a = a if dtype is None else a.astype(dtype, copy=False)
        return a.copy() if copy else a

    def __eq__(self, other: object) -> bool:
        """Equal to a tuple, or a Column, of the same values."""
        if isinstance(other, Column):
            other = tuple(other)
        return tuple(self) == other if isinstance(other, tuple) else NotImplemented

    __hash__ = None  # type: ignore[assignment]  # equal to a tuple, but not hashed as one

    @classmethod
    def of_array(cls, a: np.ndarray) -> Column:
        """The values of a 1-D array of finite floats or of integers (ValueError otherwise), its
        texts made from the array by one orjson call. Measured on the 1,000 ha benchmark's
        station columns: ~1.2 ms a column → ~0.4 ms."""
        if a.ndim != 1 or a.dtype.kind not in "fi" or (a.dtype.kind == "f" and not np.isfinite(a).all()):
            raise ValueError(f"Column.of_array: a 1-D array of finite floats or of integers, not {a.dtype} {a.shape}")
        kind: type = float if a.dtype.kind == "f" else int
        texts = _float_texts(a) if kind is float else int_texts(a)
        return cls(a.copy(), texts, kinds=frozenset({kind}) if len(a) else frozenset())

    @classmethod
    def of_codes(cls, names: Sequence[str], codes: np.ndarray) -> Column:
        """`names[c]` for each code c (integers, each an index of `names`): a column of a few
        strings repeated (a station's line, its role), each one's JSON text made once. Measured on
        the 1,000 ha benchmark's 7,309 stations: ~1 ms → ~0.2 ms for the values and texts."""
        if not all(type(v) is str for v in names):
            raise ValueError("Column.of_codes: the names must be strings")
        values, texts = np.empty(len(names), dtype=object), np.empty(len(names), dtype=object)
        values[:], texts[:] = list(names), list(map(_encode_str, names))
        codes = np.asarray(codes, dtype=np.intp)
        return cls(values[codes], texts[codes].tolist(), names[0] if len(names) == 1 else None,
                   frozenset({str}) if len(codes) else frozenset())


def one_value(values: Sequence[Any]) -> Any:
    """The value of a column made of one name (`Column.of_codes`), else None: a writer may write its text once."""
    return values.one if type(values) is Column and len(values) else None


def _known_texts(values: Sequence[Any] | np.ndarray, kind: type) -> tuple[str, ...] | None:
    """A Column's own texts if its values are all of `kind`, else None."""
    return values.texts if type(values) is Column and values.kinds == {kind} else None


def float_texts(values: Sequence[float] | np.ndarray) -> list[str]:
    """`repr(v)` of every value, which must all be finite floats; ValueError names the first
    that is not."""
    known = _known_texts(values, float)
    return list(known) if known is not None else _float_texts(values)


def int_texts(a: np.ndarray) -> list[str]:
    """The decimal text of each value of a 1-D integer array, by one orjson call (measured on the
    1,000 ha plan's 7,163 station numbers: ~0.15 ms, against ~0.5 ms for a str() of each)."""
    if a.ndim != 1 or a.dtype.kind not in "iu":
        raise ValueError(f"int_texts: a 1-D integer array, not {a.dtype} {a.shape}")
    if not len(a):
        return []
    return orjson.dumps(np.ascontiguousarray(a), option=orjson.OPT_SERIALIZE_NUMPY).decode("ascii")[1:-1].split(",")


def exponent_form(a: np.ndarray) -> np.ndarray:
    """Where `repr` writes a float with an exponent: below 1e-4 (but not 0) and from 1e16 on.
    orjson spells those its own way, and KML's numbers are written positionally there."""
    mag = np.abs(a)
    out: np.ndarray = (mag >= 1e16) | ((mag < 1e-4) & (mag > 0))
    return out


def _finite_floats(values: Sequence[float] | np.ndarray) -> np.ndarray:
    """The values as a flat contiguous float array (what orjson writes); ValueError names the first not finite."""
    a = np.ascontiguousarray(np.asarray(values, dtype=float).ravel())
    finite = np.isfinite(a)
    if not finite.all():
        raise ValueError(f"number {a[~finite][0]!r} is not finite")
    return a


def _float_texts(values: Sequence[float] | np.ndarray) -> list[str]:
    a = _finite_floats(values)
    if not len(a):
        return []
    texts = orjson.dumps(a, option=orjson.OPT_SERIALIZE_NUMPY).decode("ascii")[1:-1].split(",")
    for i in np.flatnonzero(exponent_form(a)).tolist():
        texts[i] = repr(float(a[i]))
    return texts


def pair_texts(x: np.ndarray, y: np.ndarray) -> list[str]:
    """`float_texts(x)[i] + "," + float_texts(y)[i]` for each i: the inside of the pair
    `[x, y]` as json writes it compactly (ValueError for a value that is not finite). One
    orjson call of the pairs, split between them: measured on the 1,000 ha plan's 29,236
    footprint corners, ~4 ms against ~9 ms for two `float_texts` and a join."""
    xs, ys = _finite_floats(x), _finite_floats(y)
    if len(xs) != len(ys):
        raise ValueError(f"pair_texts: {len(xs)} x values and {len(ys)} y values")
    if not len(xs):
        return []
    if exponent_form(xs).any() or exponent_form(ys).any():  # spelled by repr (see float_texts)
        return [f"{p},{q}" for p, q in zip(_float_texts(xs), _float_texts(ys))]
    # "[x,y,x,y,…]" of the flat array (orjson writes a 2-D array's rows ~2x slower), every
    # second comma made a ";" in the bytes, split there: measured on the 1,000 ha plan's 29,236
    # footprint corners, ~4.5 ms → ~3 ms. Numbers hold no "," or ";".
    a = np.empty((len(xs), 2))
    a[:, 0], a[:, 1] = xs, ys
    text = np.frombuffer(orjson.dumps(a.ravel(), option=orjson.OPT_SERIALIZE_NUMPY), np.uint8)[1:-1].copy()
    text[np.flatnonzero(text == ord(","))[1::2]] = ord(";")
    return text.tobytes().decode("ascii").split(";")


def quoted_as_is(values: Sequence[str]) -> bool:
    """Whether JSON writes each of these strings as itself between quotes (nothing escaped), so
    a writer may put the strings themselves between quote marks. One C scan of them all."""
    joined = "".join(values)
    return len(_encode_str(joined)) == len(joined) + 2


def string_texts(values: Sequence[str]) -> list[str]:
    """Each string as a JSON string literal, exactly as json.dumps(ensure_ascii=False) writes it."""
    known = _known_texts(values, str)
    return list(known) if known is not None else list(map(_encode_str, values))


def value_texts(values: Sequence[Any]) -> list[str]:
    """JSON text of each value of one column, as json writes it: floats through `float_texts`
    (in one call), None as null; a column of one plain type is made in one pass."""
    if type(values) is Column:
        return list(values.texts) if values.texts is not None else _value_texts(values, values.kinds)
    return _value_texts(values, frozenset(map(type, values)))


def _value_texts(values: Sequence[Any], kinds: frozenset[type]) -> list[str]:
    if kinds == {float}:
        return _float_texts(values)
    if kinds == {str}:
        return list(map(_encode_str, values))
    if kinds == {int}:
        return list(map(int.__repr__, values))
    if kinds == {type(None)}:
        return ["null"] * len(values)
    at = [i for i, v in enumerate(values) if type(v) is float]
    enc = json.JSONEncoder(ensure_ascii=False, allow_nan=False, separators=(",", ":")).encode
    out = ["null" if v is None else _encode_str(v) if type(v) is str else "" if type(v) is float else enc(v)
           for v in values]
    for i, text in zip(at, float_texts([values[i] for i in at])):
        out[i] = text
    return out


_FLAT = frozenset({str, int, float, bool, type(None)})


def rows_text(rows: Sequence[dict[str, Any]], sep: str, item_sep: str = ", ", key_sep: str = ": ") -> str | None:
    """`sep`.join of each row's JSON object text, as json.JSONEncoder(separators=(item_sep,
    key_sep), ensure_ascii=False, allow_nan=False) writes it; None unless every row has the
    same keys in the same order and only numbers, strings, booleans and None as values, of
    exactly those types (the caller then encodes the rows itself). Made a column at a time, so
    the numbers go through `float_texts`, and joined by `join_rows`."""
    if not rows:
        return ""
    if set(map(type, rows)) != {dict}:
        return None
    keys = tuple(rows[0])
    if not all(type(k) is str for k in keys) or not all(map(keys.__eq__, map(tuple, rows))):
        return None
    if not keys:
        return sep.join(["{}"] * len(rows))
    # the columns, by C-level calls: each row's values in the keys' order, then transposed
    columns = list(zip(*map(itemgetter(*keys), rows))) if len(keys) > 1 else [[r[keys[0]] for r in rows]]
    if not all(_FLAT.issuperset(map(type, col)) for col in columns):
        return None
    return table_text(keys, columns, sep, item_sep, key_sep)


def table_text(keys: Sequence[str], columns: Sequence[Sequence[Any]], sep: str, item_sep: str = ", ",
               key_sep: str = ": ") -> str:
    """`rows_text` of the rows that have these columns (at least one) under these keys (plain values only)."""
    n = len(columns[0])
    texts = [value_texts(col) for col in columns]
    parts: list[str | list[str]] = []
    for i, (k, col) in enumerate(zip(keys, texts)):
        parts += [("{" if i == 0 else item_sep) + _encode_str(k) + key_sep, col]
    return join_rows([*parts, "}"], n, sep)


def join_rows(parts: Sequence[str | list[str]], n: int, sep: str) -> str:
    """`sep`.join of `n` rows, row i the concatenation of the parts: a text (the same in every
    row) or a column (a list of n texts, its i-th). One join of one list, filled a part at a
    time by slice assignment, so no Python code runs per row: measured with 51,379 rows of 12
    columns, 25-36 ms against 53-58 ms for a %-template a row.

    Texts next to each other are joined first, and a row's last text, `sep` and the next row's
    first text are one item: the join's cost is its items (measured on the 1,000 ha plan's KML
    stations, 30 → 21 items a row: ~4 → ~3 ms)."""
    if n == 0:
        return ""
    merged: list[str | list[str]] = []
    for p in parts:
        last = merged[-1] if merged else None
        if isinstance(p, str) and isinstance(last, str):
            merged[-1] = last + p
        else:
            merged.append(p)
    head = merged[0] if merged and isinstance(merged[0], str) else ""
    tail = merged[-1] if len(merged) > (head != "") and isinstance(merged[-1], str) else ""
    merged = merged[head != "":len(merged) - (tail != "")]
    # each row: its columns and the texts between them, then the joint to the next row
    stride = len(merged) + 1
    flat = [tail + sep + head] * (n * stride + 1)
    flat[0] = head
    for j, p in enumerate(merged, start=1):
        flat[j::stride] = [p] * n if isinstance(p, str) else p  # a column of another length: ValueError
    flat[-1] = tail
    return "".join(flat)
