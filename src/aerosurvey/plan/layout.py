"""What a pattern lays over a site: its passes of photo strips, for the route step to order and join.

A pattern (`Pattern`) takes the site and the sensor solution and returns a `Layout`. Patterns
are chosen by `[pattern] kind` from the registry in `plan/pattern.py`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from shapely.geometry.base import BaseGeometry

from aerosurvey.plan.progress import Progress
from aerosurvey.plan.route import Pass
from aerosurvey.plan.sensor import SensorSolution
from aerosurvey.plan.site import Site


@dataclass(frozen=True, eq=False)
class Layout:
    heading_deg: float  # the main direction of the lines (an area grid's heading; a corridor's first bearing)
    heading_chosen: str  # why: "auto: …", "fixed by the spec", "along the corridor's centreline"
    passes: tuple[Pass, ...]
    covered: BaseGeometry  # what the strips photograph: the area grown by targets.coverage_margin_m
    margin_m: float  # targets.coverage_margin_m: how far beyond the area the photos reach (ground metres)
    # ground where the pattern's own rule does not prove the overlaps (a corridor's bends): the
    # coverage step checks the footprints there exactly, as it does next to the zones
    check_exactly: BaseGeometry | None = None


class Pattern(Protocol):
    """One way of laying photo strips over a site."""

    def layout(self, site: Site, sensor: SensorSolution, report: Progress) -> Layout: ...
