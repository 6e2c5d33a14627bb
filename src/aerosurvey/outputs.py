"""Render and write every output of `aerosurvey plan`, all or nothing."""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aerosurvey import manifest as mf
from aerosurvey.fileio import atomic_write_text, staged_directory
from aerosurvey.mission.builder import build_mission
from aerosurvey.mission.formats.kml import feature_collection_to_kml
from aerosurvey.mission.formats.qgc_plan import dumps_plan
from aerosurvey.mission.formats.wpl import dumps_wpl
from aerosurvey.mission.items import Mission
from aerosurvey.plan.planner import Plan
from aerosurvey.report.features import plan_features
from aerosurvey.report.preview import render_svg


@dataclass(frozen=True)
class Rendered:
    files: dict[str, str]
    rules: list[dict[str, Any]]
    warnings: list[str]
    evidence: Any = None  # the rules' Evidence (footprints, proposed control points) when profiles were evaluated


def item_limit_warnings(plan: Plan, mission: Mission) -> list[str]:
    """A mission longer than the autopilot holds is flagged with what to do about it."""

    limit = plan.spec.battery.max_mission_items if plan.spec.battery is not None else None
    if limit is None:
        from aerosurvey.spec import MAX_ITEMS

        limit = MAX_ITEMS[plan.spec.vehicle.firmware]
    n = len(mission.items) + 1
    if n > limit:
        msg = (f"the whole mission has {n} items, more than the {limit} a {plan.spec.vehicle.firmware} autopilot holds "
               f"by default (battery.max_mission_items)")
        if plan.sorties:
            return [msg + "; fly the sortie files, each within the limit"]
        return [msg + "; add a [battery] table so the plan is split into sorties that fit, "
                "or raise battery.max_mission_items if your board holds more"]
    return []


def _without(fc: dict[str, Any], role: str) -> dict[str, Any]:
    return {**fc, "features": [f for f in fc["features"] if f["properties"].get("role") != role]}


def _rules(plan: Plan, manifest: dict[str, Any], features: dict[str, Any]):
    """Evaluate the spec's rule profiles on the plan as later readers will see it."""
    from aerosurvey.rules.engine import Evidence, evaluate, layout_settings
    from aerosurvey.rules.planview import PlanView
    from aerosurvey.rules.profile import apply_overrides, select_profiles

    if not plan.spec.profiles:
        return [], [], None
    view = PlanView.from_documents(json.loads(json.dumps(manifest)), features, "the plan")
    profiles = apply_overrides(select_profiles(list(plan.spec.profiles)), plan.spec.rule_overrides)
    ev = Evidence(view, layout_settings(view, profiles))
    return evaluate(profiles, ev), ev.points, ev


def render_outputs(plan: Plan) -> Rendered:
    """File name → text of every output (the manifest last: it lists the others' hashes)."""
    mission = build_mission(plan, name=plan.spec.name)
    fc = plan_features(plan)
    files = {
        "mission.plan": dumps_plan(mission),
        "mission.waypoints": dumps_wpl(mission),
        "plan.geojson": json.dumps(fc, separators=(",", ":"), ensure_ascii=False, allow_nan=False) + "\n",
        # footprints stay in the GeoJSON: thousands of rectangles only clutter a pilot's Google Earth
        "plan.kml": feature_collection_to_kml(_without(fc, "footprint"), plan.spec.name),
    }
    for k, (sortie, wps) in enumerate(plan.sorties, start=1):
        site = plan.launch_sites[sortie.launch]
        sm = build_mission(plan, wps, name=f"{plan.spec.name}-sortie-{k:02d}", home=(site.lon, site.lat, site.ground_m))
        files[f"sortie-{k:02d}.plan"] = dumps_plan(sm)
        files[f"sortie-{k:02d}.waypoints"] = dumps_wpl(sm)
    warnings = list(plan.warnings) + item_limit_warnings(plan, mission)
    manifest = mf.build_manifest(plan, len(mission.items), {})
    manifest["warnings"] = list(warnings)
    results, points, evidence = _rules(plan, manifest, fc)
    for r in results:
        if r.status in ("fail", "warning"):
            warnings.append(f"rule {r.rule} ({r.profile}) fails: measured {r.outcome.measured}, required {r.outcome.required}")
    files["preview.svg"] = render_svg(plan, results, points)
    manifest["outputs"] = {name: hashlib.sha256(text.encode("utf-8")).hexdigest() for name, text in sorted(files.items())}
    manifest["rules"] = [r.as_dict() for r in results]
    manifest["warnings"] = warnings
    files["manifest.json"] = mf.dumps(manifest)
    return Rendered(files, manifest["rules"], warnings, evidence)


def write_outputs(plan: Plan, outdir: Path) -> Rendered:
    """Render everything first, then move it into `outdir`; an error leaves `outdir` untouched."""
    rendered = render_outputs(plan)
    with staged_directory(outdir) as stage:
        for name, text in rendered.files.items():
            atomic_write_text(stage / name, text)
    return rendered
