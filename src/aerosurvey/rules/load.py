"""Open what `check` and `gcp` are pointed at: a mission spec (planned in memory) or an
output folder of `aerosurvey plan`."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aerosurvey.errors import InputError
from aerosurvey.rules.planview import PlanView

if TYPE_CHECKING:
    from aerosurvey.plan.planner import Plan
    from aerosurvey.spec import MissionSpec


@dataclass(frozen=True)
class Target:
    view: PlanView
    profiles: list[str]  # the profiles the plan was checked with (the spec's [rules] profiles)
    overrides: dict[str, Any]
    outdir: Path | None
    # the rules the planner evaluated itself (uncovered-ground), as records; none known for a view made otherwise
    planner_rules: tuple[dict[str, Any], ...] = ()


def plan_documents(plan: Plan, spec: MissionSpec) -> tuple[dict[str, Any], dict[str, Any]]:
    """The manifest and GeoJSON of `plan`, planned from `spec`, in memory (no files written)."""
    from aerosurvey.manifest import build_manifest
    from aerosurvey.mission.builder import build_mission
    from aerosurvey.report.features import plan_features

    mission = build_mission(plan)
    return build_manifest(plan, spec, len(mission.items), {}), plan_features(plan, with_footprints=False)


def open_target(path: Path) -> Target:
    from aerosurvey.plan.coverage import PLANNER_PROFILE, uncovered_rule

    if path.is_dir():
        view = PlanView.from_outdir(path)
        doc = view.document
        planner = [dict(r) for r in doc.rules if r["profile"] == PLANNER_PROFILE]  # made with the plan's own data
        return Target(view, list(doc.mission.profiles), dict(doc.rule_overrides), path, tuple(planner))
    if path.suffix.lower() == ".toml":
        from aerosurvey.inputs import plan_from_files
        from aerosurvey.spec import load_spec

        spec = load_spec(path)
        plan = plan_from_files(spec)
        manifest, features = plan_documents(plan, spec)
        view = PlanView.from_documents(manifest, features, str(path), check=False)  # made here, by the writer
        return Target(view, list(spec.profiles), dict(spec.rule_overrides), None, (uncovered_rule(plan.coverage),))
    if not path.exists():
        raise InputError(f"{str(path)!r} does not exist; give a mission spec (.toml) or a folder written by `aerosurvey plan`")
    raise InputError(f"{str(path)!r} is neither a mission spec (.toml) nor a folder written by `aerosurvey plan`")
