"""The area grid: parallel lines over the area at the fastest (or a fixed) heading, and a
cross-hatch pass at 90°. Its passes carry their frame and line segments, for the route step's
search of the line order and cells.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import shapely

from aerosurvey.errors import InputError
from aerosurvey.plan.frame import LineFrame
from aerosurvey.plan.heading import best_heading, candidate_headings
from aerosurvey.plan.layout import Layout
from aerosurvey.plan.lines import LineSegment, Outline, StripGeometry, build_lines, line_bounds
from aerosurvey.plan.progress import Progress
from aerosurvey.plan.route import Pass, quick_cost, quick_cost_lower_bounds
from aerosurvey.plan.sensor import SensorSolution
from aerosurvey.plan.site import Site
from aerosurvey.spec import MissionSpec

#: frames × (edges + rings + zones) a batch of the heading search's bounds may hold (a few MB a numpy array)
BOUND_BATCH_ELEMENTS = 200_000


def strip_geometry(sensor: SensorSolution, beyond: int, k: float, base_k: float) -> StripGeometry:
    """The sensor solution in planning-grid metres (ground metres × the grid scale k; the photo
    base, in the autopilot's metres, × `base_k`, the line heading's `Site.autopilot_scale`).

    Stations stay as close to a zone's margin as the flight past them allows: the line ends
    half a base after its last station (and a plane needs its turn radius there); the
    lead-in before a run is shortened by the route where a zone is in its way."""
    clearance = sensor.base_m / 2.0 + sensor.turn_radius_m + 1.0
    return StripGeometry(sensor.across_m * k, sensor.along_m * k, sensor.spacing_m * k, sensor.base_m * base_k,
                         sensor.side_images_per_point, sensor.forward_images_per_point, beyond, clearance * k)


@dataclass(frozen=True)
class AreaGrid:
    """Parallel lines over the area at the fastest (or a fixed) heading; a cross-hatch pass at 90°."""

    heading_deg: float | None  # None: the heading with the shortest estimated flight time
    cross_hatch: bool
    images_beyond_boundary: int
    coverage_margin_m: float

    @classmethod
    def from_spec(cls, spec: MissionSpec) -> AreaGrid:
        return cls(spec.flight.heading_deg, spec.flight.cross_hatch, spec.targets.images_beyond_boundary,
                   spec.targets.coverage_margin_m)

    def layout(self, site: Site, sensor: SensorSolution, report: Progress) -> Layout:
        k = site.grid_scale
        margin = self.coverage_margin_m * k
        covered = shapely.buffer(site.area, margin, quad_segs=4) if margin > 0 else site.area
        def strips(h: float) -> StripGeometry:
            return strip_geometry(sensor, self.images_beyond_boundary, k, site.autopilot_scale(h))

        # the heading search's lower bounds take the longest base of any heading (the fewest photos)
        g = max((strips(h) for h in (0.0, 90.0)), key=lambda s: s.base)
        lead = sensor.lead_in_m * k

        laid: dict[float, tuple[LineFrame, list[LineSegment]]] = {}

        def lines_for(h: float) -> tuple[LineFrame, list[LineSegment]]:
            # the heading search lays every candidate; the chosen one is not laid again
            if h not in laid:
                fr = LineFrame(h)
                zf = fr.geom_to_frame(site.zones_buffered) if site.zones_buffered is not None else None
                laid[h] = (fr, build_lines(fr.geom_to_frame(covered), zf, strips(h)))
            return laid[h]

        if self.heading_deg is None:
            n_cand = len(candidate_headings(covered)) + 10
            tried = 0

            def cost(fr: LineFrame) -> float:
                nonlocal tried
                tried += 1
                report("choosing the heading", 0.05 + 0.6 * min(1.0, tried / n_cand))
                _, segs = lines_for(fr.heading_deg)
                return quick_cost(segs, lead, sensor.kinematics) if segs else math.inf

            outline = Outline.of(covered, site.zones_buffered)
            plane = sensor.kinematics.vehicle != "copter"  # only the plane's bound asks which lines have one run

            # line_bounds holds (frames, edges) arrays: frames a batch at a time keeps them small
            per_batch = max(1, BOUND_BATCH_ELEMENTS // (len(outline.start) + len(outline.shells) + len(outline.zone_radius)))

            def bound(frames: list[LineFrame]) -> list[float]:
                out: list[float] = []
                for i in range(0, len(frames), per_batch):
                    lb = line_bounds(outline, frames[i:i + per_batch], g, single_runs=plane)
                    out += [float(b) for b in quick_cost_lower_bounds(lb, lead, g.base, sensor.kinematics)]
                return out

            heading, _ = best_heading(covered, cost, bound=bound)
            chosen = "auto: the shortest estimated flight time"
        else:
            heading, chosen = self.heading_deg, "fixed by the spec"
        headings = [heading] + ([(heading + 90.0) % 180.0] if self.cross_hatch else [])
        report("flight lines and photo stations", 0.66)
        passes = []
        for i, h in enumerate(headings, start=1):
            fr, segs = lines_for(h)
            passes.append(Pass(i, fr, tuple(segs)))
        if not any(p.segments for p in passes):
            raise InputError("no flight line fits: the area is smaller than one photo or entirely blocked by exclusion zones")
        return Layout(heading, chosen, tuple(passes), covered, self.coverage_margin_m)


__all__ = ["AreaGrid", "strip_geometry"]
