"""The pattern registry: every `[pattern] kind`, and what each one says of itself.

    area       parallel lines over the area, optionally cross-hatched            (area_grid.py)
    corridor   strips along a centreline, bending with it                        (corridor.py)
    oblique    the area grid flown with the camera tilted (double grid, five directions) (oblique.py)
    orbit      rings round the [structure] at a stand-off, layer by layer (orbit.py)
    facade     lanes along a wall from a line and two heights, at a stand-off     (faces.py)
    faces      lanes along inclined bench faces above a toe line (quarry, pit, dam) (faces.py)
    smart-oblique  the area grid flown once, nadir and four obliques shot at rest at each station (smart_oblique.py)

A pattern is a class (`layout.PatternKind`): its kind, title and [pattern] fields, how its
options are read from the spec, how it lays its strips over a site, and what the later steps
ask of it (the ground a photo surely photographs, how many times it photographs the ground,
the manifest's parameters). Everything that depends on the kind asks the entry here: the
spec's allowed kinds and fields, the sensor's footprint, the bounds, the manifest (and the
kinds its reader accepts), the web page's fields. Adding a pattern is its module and one
entry in `PATTERNS` (docs/planning.md: "How to add a flight pattern").

An entry names where its pattern is ("module:Class"), and the module is imported when the
pattern is first asked for: a plan loads only its own pattern's module (the others' imports
and dataclasses cost ~10 ms at every `aerosurvey plan`). The kinds are known without any.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterator, MutableMapping
from typing import Any

from aerosurvey.errors import InputError
from aerosurvey.plan.area_grid import AreaGrid, strip_geometry
from aerosurvey.plan.layout import Field, Layout, Pattern, PatternKind
from aerosurvey.spec import MissionSpec


class Registry(MutableMapping[str, type[PatternKind]]):
    """`[pattern] kind` → its pattern; an entry given as "module:Class" is imported when first asked for."""

    def __init__(self, entries: dict[str, type[PatternKind] | str]) -> None:
        self._entries = dict(entries)

    def __getitem__(self, kind: str) -> type[PatternKind]:
        entry = self._entries[kind]
        if isinstance(entry, str):
            module, _, name = entry.partition(":")
            entry = self._entries[kind] = getattr(importlib.import_module(module), name)
        return entry

    def __setitem__(self, kind: str, pattern: type[PatternKind]) -> None:
        self._entries[kind] = pattern

    def __delitem__(self, kind: str) -> None:
        del self._entries[kind]

    def __iter__(self) -> Iterator[str]:
        return iter(self._entries)

    def __len__(self) -> int:
        return len(self._entries)


#: `[pattern] kind` → the pattern (each class's `kind` is its key: tests/plan/test_pattern_seam.py)
PATTERNS = Registry({"area": AreaGrid, "corridor": "aerosurvey.plan.corridor:Corridor",
                     "oblique": "aerosurvey.plan.oblique:Oblique", "smart-oblique": "aerosurvey.plan.smart_oblique:SmartOblique",
                     "orbit": "aerosurvey.plan.orbit:Orbit", "facade": "aerosurvey.plan.faces:Facade",
                     "faces": "aerosurvey.plan.faces:Faces"})


def kind_of(kind: str) -> type[PatternKind]:
    """The registry's pattern of a kind; InputError naming the kinds there are."""
    found = PATTERNS.get(kind)
    if found is None:
        raise InputError(f"pattern.kind = {kind!r} is not a pattern; allowed: {', '.join(PATTERNS)}", key="pattern.kind")
    return found


def pattern_for(spec: MissionSpec) -> Pattern:
    """The pattern a spec asks for, made from it."""
    return kind_of(spec.pattern.kind).from_spec(spec)


def field_table() -> list[dict[str, Any]]:
    """The kinds with their fields as plain data: what the web page builds its pattern box from."""
    def field(f: Field) -> dict[str, Any]:
        return {"key": f.key, "label": f.label, "type": f.type, "default": f.default, "min": f.lo, "max": f.hi,
                "choices": [list(c) for c in f.choices], "hint": f.hint}

    return [{"kind": p.kind, "title": p.title, "area_is_centreline": p.area_is_centreline,
             "fields": [field(f) for f in p.fields]} for p in PATTERNS.values()]


__all__ = ["PATTERNS", "AreaGrid", "Layout", "Pattern", "Registry", "field_table", "kind_of", "pattern_for", "strip_geometry"]
