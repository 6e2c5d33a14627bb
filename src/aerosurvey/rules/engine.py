"""Evaluate rule profiles on a plan view and collect the results."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import TypedDict

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.rules import footprints as fpm
from aerosurvey.rules.checks import CHECKS, Outcome, Params, Where, asprs_required, evaluate_formula
from aerosurvey.rules.control_points import ControlPoint, Role, propose_check_points, propose_gcps, ring_order, seen_by
from aerosurvey.rules.planview import PlanView
from aerosurvey.rules.profile import Profile


@dataclass(frozen=True)
class LayoutSettings:
    """How control points are laid out when no layout is given; filled from the profiles."""

    gcp_count: int = 4
    gcp_min_images: int = 6
    gcp_offset_m: float = 10.0
    gcp_max_spacing_m: float = 400.0
    cp_ha_per_point: float = 3.0
    cp_minimum: int = 0
    cp_edge_margin_m: float = 15.0
    cp_gcp_clearance_m: float = 50.0
    nogo: BaseGeometry | None = None


def layout_settings(view: PlanView, profiles: list[Profile], nogo: BaseGeometry | None = None,
                    gcp_offset_m: float | None = None) -> LayoutSettings:
    """Counts and visibility the chosen profiles ask for (the strictest of them); no point goes
    into the plan's exclusion zones nor into `nogo`."""
    if view.exclusions is not None and not view.exclusions.is_empty:
        nogo = view.exclusions if nogo is None else shapely.union(nogo, view.exclusions)
    base = LayoutSettings()
    gcp_count, gcp_min_images = base.gcp_count, base.gcp_min_images
    cp_ha_per_point, cp_minimum = base.cp_ha_per_point, base.cp_minimum
    area_km2 = view.area_ha / 100
    for p in profiles:
        for r in p.rules:
            params = Params(r.params)
            if r.check == "gcp_count":
                need = math.ceil(evaluate_formula(params.text("formula"), n_images=len(view.station_ids),
                                                  area_ha=view.area_ha, area_km2=area_km2))
                gcp_count = max(gcp_count, need)
            elif r.check == "gcp_visibility":
                gcp_min_images = max(gcp_min_images, params.whole("min_images"))
            elif r.check == "check_point_density":
                cp_ha_per_point = min(cp_ha_per_point, params.num("ha_per_point"))
            elif r.check == "asprs_check_points":
                cp_minimum = max(cp_minimum, max(asprs_required(params.text("edition"), area_km2)))
    return LayoutSettings(gcp_count=gcp_count, gcp_min_images=gcp_min_images,
                          gcp_offset_m=base.gcp_offset_m if gcp_offset_m is None else gcp_offset_m,
                          cp_ha_per_point=cp_ha_per_point, cp_minimum=cp_minimum, nogo=nogo)


@dataclass(frozen=True)
class Evidence:
    """Measurements shared by the checks, computed once and only when a check needs them."""

    view: PlanView
    settings: LayoutSettings
    layout: list[ControlPoint] | None = None
    #: the layout's points were placed on another view of the plan: their photos are counted on this one
    count_layout: bool = False
    _crossings: dict[int, list[fpm.Crossing]] = field(default_factory=dict)

    @cached_property
    def footprints(self) -> fpm.Footprints:
        return fpm.footprints(self.view)

    @cached_property
    def forward_overlaps(self) -> list[tuple[str, float]]:
        return fpm.forward_overlaps(self.view, self.footprints)

    @cached_property
    def side_overlaps(self) -> list[tuple[str, str, float]]:
        return fpm.side_overlaps(self.view, self.footprints)

    def crossings(self, min_outside: int) -> list[fpm.Crossing]:
        if min_outside not in self._crossings:
            self._crossings[min_outside] = fpm.boundary_crossings(self.view, min_outside)
        return self._crossings[min_outside]

    @cached_property
    def grid_counts(self) -> tuple[fpm.IntArray, fpm.FloatArray, fpm.FloatArray]:
        region = self.view.area
        if self.view.exclusions is not None:
            # ground under a zone and next to it cannot be photographed from above it
            reach = float(np.hypot(self.footprints.across, self.footprints.along).max(initial=0.0)) / 2
            margin = float(self.view.manifest.get("derived", {}).get("exclusion_margin_m", 10.0))
            region = shapely.difference(region, shapely.buffer(self.view.exclusions, reach + margin))
        gx, gy = fpm.sample_grid(region)
        return self.footprints.count_at(gx, gy), gx, gy

    @cached_property
    def points(self) -> list[ControlPoint]:
        if self.layout is not None:
            return seen_by(self.footprints, self.layout) if self.count_layout else self.layout
        s = self.settings
        gcps = propose_gcps(self.view.area, self.footprints, s.gcp_count, s.gcp_min_images, s.gcp_offset_m,
                            s.gcp_max_spacing_m, s.nogo)
        cps = propose_check_points(self.view.area, self.footprints, s.cp_ha_per_point, s.cp_minimum,
                                   s.cp_edge_margin_m, gcps, s.cp_gcp_clearance_m, s.nogo)
        return gcps + cps

    def control_points(self, role: Role) -> list[ControlPoint]:
        return [p for p in self.points if p.role == role]

    def ring_order(self, gcps: list[ControlPoint]) -> list[ControlPoint]:
        return ring_order(gcps, self.view.area)


class RuleRecord(TypedDict):
    """A rule result as JSON (manifest.json "rules", `check --json`)."""

    profile: str
    rule: str
    status: str
    severity: str
    statement: str
    measured: str
    required: str
    evidence: list[str]
    where: list[Where]
    source: str


@dataclass(frozen=True)
class RuleResult:
    """One rule of one profile evaluated on a plan: the rule's words and its check's outcome."""

    profile: str
    rule: str
    statement: str
    severity: str
    source: str
    outcome: Outcome

    @property
    def status(self) -> str:
        """What the user sees: a failed warning-level rule is a warning."""
        if self.outcome.status == "fail" and self.severity != "error":
            return "warning"
        return self.outcome.status

    def as_dict(self) -> RuleRecord:
        return {"profile": self.profile, "rule": self.rule, "status": self.status, "severity": self.severity,
                "statement": self.statement, "measured": self.outcome.measured, "required": self.outcome.required,
                "evidence": list(self.outcome.evidence), "where": list(self.outcome.where), "source": self.source}


def evaluate(profiles: list[Profile], evidence: Evidence) -> list[RuleResult]:
    out = []
    for p in profiles:
        for r in p.rules:
            params = Params({**CHECKS[r.check].defaults, **r.params})
            outcome = CHECKS[r.check].run(evidence.view, params, evidence)
            out.append(RuleResult(p.id, r.id, r.statement, r.severity, r.source, outcome))
    return out


def failed_errors(results: list[RuleResult]) -> list[RuleResult]:
    return [r for r in results if r.outcome.status == "fail" and r.severity == "error"]
