"""The page's spec as a TOML file: validated as `aerosurvey plan` reads it, paths as a person writes them."""

from __future__ import annotations

import copy
from typing import Any

from aerosurvey.web import service


def validated_toml(ws: service.Workspace, spec: dict[str, Any]) -> str:
    """The spec as TOML, after the same checks a plan makes (InputError naming the key when one fails)."""
    from aerosurvey.spec import parse_spec

    ws.check_paths(spec)
    parse_spec(spec, base=ws.base, path=None)
    return service.spec_to_toml(relative_paths(ws, spec))


def relative_paths(ws: service.Workspace, spec: dict[str, Any]) -> dict[str, Any]:
    """Paths inside the spec's folder are written relative to it, as a hand-written spec has them."""
    out = copy.deepcopy(spec)
    for table, key in service.PATH_KEYS:
        v = (out.get(table) or {}).get(key)
        if isinstance(v, str):
            out[table][key] = _relative(ws, v)
    ex = (out.get("area") or {}).get("exclusions")
    if isinstance(ex, list):
        out["area"]["exclusions"] = [_relative(ws, v) if isinstance(v, str) else v for v in ex]
    return out


def _relative(ws: service.Workspace, value: str) -> str:
    p = ws.resolve(value).resolve()
    try:
        return p.relative_to(ws.base.resolve()).as_posix()
    except ValueError:
        return str(p)
