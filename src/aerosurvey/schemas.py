"""The JSON Schemas of the formats aerosurvey owns (data/*.schema.json), checked with jsonschema.

One place loads a schema, checks a document against it and turns the first violation
into one line (`where: path: message`), and renders a schema's table for the docs.

Large tables (a manifest's `stations`, thousands of rows of a dozen numbers) are checked
column by column when their row schema uses only simple keywords (type, pattern, minimum,
required, additionalProperties: false); jsonschema itself then runs only on a table the
column check does not pass, to name the first error. Measured on the Obratan example
(1756 stations) by benchmarks/manifest_bench.py: see the numbers there; jsonschema alone
takes a large part of a second, which every plan, check and ingest would pay.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable, Iterable
from functools import cache
from importlib import resources
from typing import Any

#: Python types a JSON type name stands for, for the column check (bool is no number here;
#: a float like 1.0 that JSON Schema counts as an integer falls back to jsonschema).
_PY_TYPES: dict[str, tuple[type, ...]] = {
    "number": (int, float), "integer": (int,), "string": (str,), "null": (type(None),), "boolean": (bool,),
}
_SIMPLE_KEYS = {"type", "pattern", "minimum", "exclusiveMinimum", "description"}


def _is_array(checker: Any, instance: Any) -> bool:
    return isinstance(instance, list | tuple)


@cache
def schema(name: str) -> dict[str, Any]:
    """The schema `data/<name>.schema.json` shipped with the package."""
    text = resources.files("aerosurvey").joinpath(f"data/{name}.schema.json").read_text(encoding="utf-8")
    out: dict[str, Any] = json.loads(text)
    return out


@cache
def validator(name: str) -> Any:
    # jsonschema takes 0.1-0.3 s to import and this module is on the CLI's start-up path (rules -> manifest)
    from jsonschema import Draft202012Validator
    from jsonschema.validators import extend

    cls = extend(Draft202012Validator,  # type: ignore[no-untyped-call]
                 type_checker=Draft202012Validator.TYPE_CHECKER.redefine("array", _is_array))
    return cls(schema(name))  # the schemas themselves are checked by the tests (check_schema)


def _resolve(sub: dict[str, Any], defs: dict[str, Any]) -> dict[str, Any]:
    while "$ref" in sub and len(sub) == 1 and sub["$ref"].startswith("#/$defs/"):
        sub = defs[sub["$ref"].rsplit("/", 1)[1]]
    return sub


ColumnCheck = Callable[[list[Any]], bool]


def _column_check(sub: dict[str, Any]) -> ColumnCheck | None:
    """A check of one column's values that is at least as strict as `sub`, or None."""
    if not set(sub) <= _SIMPLE_KEYS or "type" not in sub:
        return None
    names = sub["type"] if isinstance(sub["type"], list) else [sub["type"]]
    if not all(n in _PY_TYPES for n in names):
        return None
    allowed = {t for n in names for t in _PY_TYPES[n]}
    numeric = bool({"number", "integer"} & set(names))
    pattern = re.compile(sub["pattern"]) if "pattern" in sub else None
    lo, lo_open = (sub["minimum"], False) if "minimum" in sub else (sub.get("exclusiveMinimum"), True)

    def check(values: list[Any]) -> bool:
        if not {type(v) for v in values} <= allowed:
            return False
        if pattern is not None and not all(pattern.search(v) for v in values if isinstance(v, str)):
            return False
        if lo is not None and numeric:
            nums = [v for v in values if isinstance(v, int | float)]
            if nums and (min(nums) <= lo if lo_open else min(nums) < lo):
                return False
        return True

    return check


@cache
def _table_checks(name: str) -> dict[str, tuple[frozenset[str], frozenset[str], dict[str, ColumnCheck]]]:
    """Top-level arrays of objects whose rows can be checked by column: (required, allowed keys, checks)."""
    s = schema(name)
    defs = s.get("$defs", {})
    out = {}
    for key, prop in s.get("properties", {}).items():
        items = prop.get("items") if prop.get("type") == "array" else None
        if not isinstance(items, dict) or items.get("additionalProperties") is not False or set(prop) - {"type", "items", "description"}:
            continue
        if set(items) - {"type", "additionalProperties", "required", "properties"}:
            continue
        checks = {k: _column_check(_resolve(v, defs)) for k, v in items.get("properties", {}).items()}
        if all(c is not None for c in checks.values()):
            out[key] = (frozenset(items.get("required", [])), frozenset(checks), {k: c for k, c in checks.items() if c})
    return out


def _rows_pass(rows: Any, required: frozenset[str], allowed: frozenset[str], checks: dict[str, ColumnCheck]) -> bool:
    if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
        return False
    for keys in {frozenset(r) for r in rows}:
        if not required <= keys <= allowed:
            return False
    return all(check([r[k] for r in rows if k in r]) for k, check in checks.items())


def _path(parts: Iterable[Any]) -> str:
    return "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in parts).lstrip(".") or "(top level)"


def first_error(name: str, doc: Any) -> str | None:
    """`path: message` of the first violation of schema `name` by `doc`, or None when it conforms."""
    v = validator(name)
    tables = _table_checks(name) if isinstance(doc, dict) else {}
    fast = {k: t for k, t in tables.items() if k in doc and _rows_pass(doc[k], *t)}
    rest = {**doc, **{k: [] for k in fast}} if fast else doc
    err = next(iter(sorted(v.iter_errors(rest), key=lambda e: (len(e.absolute_path), list(map(str, e.absolute_path))))), None)
    if err is None:
        return None
    msg = err.message if len(err.message) <= 200 else err.message[:197] + "..."
    return f"{_path(err.absolute_path)}: {msg}"


def check_version(where: str, label: str, version: Any, current: int, redo: str, wrote: str | None = None) -> None:
    """Refuse a document of another version than `current` in one line that says what to do:
    `redo` for an older one (e.g. "re-plan it with ..."), an upgrade for a newer one."""
    from aerosurvey import __version__
    from aerosurvey.errors import InputError

    by = f" by aerosurvey {wrote}" if wrote else ""
    if not isinstance(version, int) or isinstance(version, bool):
        raise InputError(f"{where}: {label} schema version {version!r} is not allowed: an integer ({current} here)")
    if version < current:
        raise InputError(f"{where} was written{by} with {label} schema {version}; this aerosurvey {__version__} reads "
                         f"schema {current}: {redo}")
    if version > current:
        raise InputError(f"{where} was written{by} with {label} schema {version}, newer than the schema {current} this "
                         f"aerosurvey {__version__} reads: upgrade aerosurvey")


def check(name: str, doc: Any, where: str, label: str, current: int) -> None:
    """Refuse a document that breaks schema `name`, naming the first error's path."""
    from aerosurvey.errors import InputError

    err = first_error(name, doc)
    if err is not None:
        raise InputError(f"{where} does not match the {label} schema {current}: {err}")


def markdown_table(name: str) -> str:
    """The schema's top-level keys and their descriptions as a Markdown table (docs are generated from it)."""
    s = schema(name)
    req = set(s.get("required", []))
    rows = ["| key | content |", "| --- | --- |"]
    for key, prop in s.get("properties", {}).items():
        desc = " ".join(str(prop.get("description", "")).split())
        opt = "" if key in req else " (optional)"
        rows.append(f"| `{key}`{opt} | {desc} |")
    return "\n".join(rows) + "\n"


def markdown_columns(name: str, table: str) -> str:
    """The columns of the table `table` (a top-level array of objects) as a Markdown table, in order."""
    items = schema(name)["properties"][table]["items"]
    rows = ["| column | type | content |", "| --- | --- | --- |"]
    for key, prop in items["properties"].items():
        kind = prop.get("type", "")
        kinds = [k for k in (kind if isinstance(kind, list) else [kind]) if k != "null"]
        empty = ", may be empty" if "null" in (kind if isinstance(kind, list) else [kind]) else ""
        rows.append(f"| `{key}` | {'/'.join(kinds)}{empty} | {' '.join(str(prop.get('description', '')).split())} |")
    return "\n".join(rows) + "\n"


if __name__ == "__main__":  # pragma: no cover - prints the docs tables
    import sys

    if len(sys.argv) == 3 and sys.argv[1] == "--table":  # docs/*.md tables: python -m aerosurvey.schemas --table manifest
        print(markdown_table(sys.argv[2]), end="")
    elif len(sys.argv) == 4 and sys.argv[1] == "--columns":  # python -m aerosurvey.schemas --columns events rows
        print(markdown_columns(sys.argv[2], sys.argv[3]), end="")
