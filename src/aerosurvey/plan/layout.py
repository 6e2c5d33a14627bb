"""What a pattern lays over a site: its passes of photo strips, for the route step to order and join.

A pattern (`Pattern`) takes the site and the sensor solution and returns a `Layout`. Patterns
are chosen by `[pattern] kind` from the registry in `plan/pattern.py`.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, Protocol

from shapely.geometry.base import BaseGeometry

from aerosurvey.plan.passes import Pass
from aerosurvey.plan.progress import Progress
from aerosurvey.plan.sensor import Footprint, SensorSolution
from aerosurvey.plan.site import Site

if TYPE_CHECKING:
    from aerosurvey.plan.bounds import GridBounds
    from aerosurvey.plan.model import Heights, Plan
    from aerosurvey.plan.surfaces import Surface
    from aerosurvey.spec import FlightSpec, MissionSpec


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
    # ground the ways from and back to the launch point go round (planning CRS): a structure the
    # pattern flies round, grown by what they keep from it (the pattern's own legs keep it by design)
    obstacle: BaseGeometry | None = None
    # faces the pattern photographs (not the ground): the structure-faces rule proves their coverage
    surface: SurfaceAsked | None = None


@dataclass(frozen=True, eq=False)
class SurfaceAsked:
    """A pattern's own surface (a `Terrace`'s faces) and what each of its points needs: `min_images`
    photos, each with a GSD on the face at most `max_gsd_m` (None: any)."""

    surface: Surface
    min_images: int
    max_gsd_m: float | None


class Pattern(Protocol):
    """One way of laying photo strips over a site."""

    def layouts(self, site: Site, sensor: SensorSolution, report: Progress) -> Iterator[Layout]:
        """The layouts it may fly, its own choice first (e.g. the shortest estimated flight), then,
        laid only when the planner asks for them, alternatives: the planner flies the first that
        leaves no required ground unseen, else the one that leaves least (`planner.flown_layout`)."""
        ...


@dataclass(frozen=True)
class Field:
    """A key of the spec's [pattern] table that a pattern takes: how the spec reads it, how the
    page shows it and the docs name it. Its value, read with the bounds given, is kept times
    `scale` (a `_cm` key kept in metres)."""

    key: str
    label: str
    type: str  # "number" or "choice"
    default: float | str | None = None  # None: absent unless given
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    choices: tuple[tuple[str, str], ...] = ()  # (value, what the page shows)
    hint: str = ""
    scale: float = 1.0


class PatternKind(Protocol):
    """A `[pattern] kind`: what the spec, the later steps and the outputs ask of a pattern. The
    registry (`plan/pattern.py`) holds one per kind; nothing else tests a kind by its name."""

    kind: ClassVar[str]
    title: ClassVar[str]  # what the page and the docs call it
    fields: ClassVar[tuple[Field, ...]]  # the [pattern] keys it takes besides `kind`
    # the area file holds a centreline (a line) rather than the area's polygons, which the
    # pattern may also take (a corridor polygon)
    area_is_centreline: ClassVar[bool]
    # the camera looks off the track at a bearing the copter's nose sets (a tilted camera panned against the
    # nose, nose along the track): each run's lead-in lasts the nose's turn onto the run (`sensor.lead_in_m`)
    nose_turns_camera: ClassVar[bool]

    @classmethod
    def centreline_sides(cls, spec: MissionSpec) -> tuple[float | None, float | None]:
        """With `area_is_centreline`: the ground asked for left and right of the centreline (None:
        derived from a corridor polygon); (None, None) for the others."""
        ...

    @classmethod
    def stands_on(cls, site: Site) -> BaseGeometry | None:
        """What the pattern's heights stand on over a DEM (terrain.mode = "fixed"): above the lowest ground under
        this (a structure's footprint, a toe line; planning CRS); None: above the area's lowest ground, as a grid's."""
        ...

    @classmethod
    def options(cls, values: Mapping[str, Any], flight: FlightSpec) -> object:
        """The pattern's own settings from its fields' values (InputError for a combination it refuses)."""
        ...

    @classmethod
    def from_spec(cls, spec: MissionSpec) -> Pattern: ...

    @classmethod
    def footprint(cls, spec: MissionSpec, heights: Heights) -> Footprint:
        """The ground each photo surely photographs, square to its line, that spacing and base are laid from."""
        ...

    @classmethod
    def bounds(cls, spec: MissionSpec, site: Site, sensor: SensorSolution, layout: Layout) -> GridBounds:
        """The fewest strips and photos any grid of parallel strips at the plan's spacing and base
        flies for the pattern's guarantee (plan/bounds.py), each time it photographs the ground."""
        ...

    @classmethod
    def parameters(cls, plan: Plan) -> dict[str, Any]:
        """The manifest's `pattern.parameters`: what the plan was laid with."""
        ...
