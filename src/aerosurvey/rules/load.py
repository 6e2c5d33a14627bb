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


def airspace_check(plan: Plan, spec: MissionSpec) -> tuple[dict[str, Any] | None, tuple[dict[str, Any], ...]]:
    """The manifest's airspace record and the planner's airspace rule of `plan` (every flight's legs against the
    official zones in four dimensions), or (None, ()) without official zones."""
    if plan.airspace is None:
        return None, ()
    from aerosurvey.airspace.check import check_airspace
    from aerosurvey.manifest import airspace_record
    from aerosurvey.outputs import mission_programs

    report = check_airspace(plan, mission_programs(plan))
    if report is None:
        return None, ()
    return airspace_record(report, spec), (report.rule_record(),)


def open_target(path: Path, zones: tuple[Path, ...] = (), wind: str | None = None) -> Target:
    """What `check` and `gcp` read: a plan folder, or a mission spec planned in memory (with `zones`, official
    zone files besides its [airspace] zones: `check --zones`; with `wind` over its conditions.wind: `check --wind`)."""
    from aerosurvey.plan.coverage import PLANNER_PROFILE, planner_rules

    if path.is_dir():
        if wind is not None:
            raise InputError(f"--wind is for a mission spec: {str(path)!r} is a plan folder, planned in the wind it was "
                             "planned in (re-plan it with `aerosurvey plan SPEC --wind SPEED@FROM`)", key="--wind")
        if zones:
            raise InputError(f"--zones is for a mission spec: {str(path)!r} is a plan folder, planned with the zones it was "
                             "planned with (re-plan it with `aerosurvey plan SPEC --zones FILE`)", key="--zones")
        view = PlanView.from_outdir(path)
        doc = view.document
        planner = [dict(r) for r in doc.rules if r["profile"] == PLANNER_PROFILE]  # made with the plan's own data
        return Target(view, list(doc.mission.profiles), dict(doc.rule_overrides), path, tuple(planner))
    if path.suffix.lower() == ".toml":
        from aerosurvey.inputs import plan_from_files
        from aerosurvey.spec import load_spec, with_wind, with_zone_files

        spec = with_wind(with_zone_files(load_spec(path), zones), wind)
        plan = plan_from_files(spec)
        manifest, features = plan_documents(plan, spec)
        airspace, airspace_rule = airspace_check(plan, spec)
        if airspace is not None:
            manifest["airspace"] = airspace
        view = PlanView.from_documents(manifest, features, str(path), check=False)  # made here, by the writer
        return Target(view, list(spec.profiles), dict(spec.rule_overrides), None, (*planner_rules(plan), *airspace_rule))
    if not path.exists():
        raise InputError(f"{str(path)!r} does not exist; give a mission spec (.toml) or a folder written by `aerosurvey plan`")
    raise InputError(f"{str(path)!r} is neither a mission spec (.toml) nor a folder written by `aerosurvey plan`")
