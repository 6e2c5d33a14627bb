"""Flight patterns, chosen by the spec's `[pattern] kind`: each lays photo strips over the site
(`Layout`) for the route step to order and join.

    area       parallel lines over the area, optionally cross-hatched            (area_grid.py)
    corridor   strips along a centreline, bending with it                        (corridor.py)
    oblique    the area grid flown with the camera tilted (double grid, five directions) (oblique.py)

A pattern is a class with `from_spec(spec)` and `layout(site, sensor, report)`; adding one is a
module and an entry in `PATTERNS` (docs/planning.md: "Adding a pattern").
"""

from __future__ import annotations

from collections.abc import Callable

from aerosurvey.errors import InputError
from aerosurvey.plan.area_grid import AreaGrid, strip_geometry
from aerosurvey.plan.corridor import Corridor
from aerosurvey.plan.layout import Layout, Pattern
from aerosurvey.plan.oblique import Oblique
from aerosurvey.spec import MissionSpec

#: `[pattern] kind` → how the pattern is made from the spec
PATTERNS: dict[str, Callable[[MissionSpec], Pattern]] = {
    "area": AreaGrid.from_spec,
    "corridor": Corridor.from_spec,
    "oblique": Oblique.from_spec,
}


def pattern_for(spec: MissionSpec) -> Pattern:
    """The pattern a spec asks for."""
    make = PATTERNS.get(spec.pattern.kind)
    if make is None:  # the spec allows only the registry's kinds: a kind without a pattern is a bug
        raise InputError(f"pattern.kind = {spec.pattern.kind!r} has no pattern; allowed: {', '.join(PATTERNS)}")
    return make(spec)


__all__ = ["PATTERNS", "AreaGrid", "Corridor", "Layout", "Oblique", "Pattern", "pattern_for", "strip_geometry"]
