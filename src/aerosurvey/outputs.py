"""Write every output of `aerosurvey plan` into a folder, all or nothing."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from aerosurvey import manifest as mf
from aerosurvey.fileio import atomic_write_text, staged_directory
from aerosurvey.mission.builder import build_mission
from aerosurvey.mission.formats.kml import feature_collection_to_kml
from aerosurvey.mission.formats.qgc_plan import dumps_plan
from aerosurvey.mission.formats.wpl import dumps_wpl
from aerosurvey.plan.planner import PlanResult
from aerosurvey.report.features import plan_features
from aerosurvey.report.preview import render_svg


def render_outputs(plan: PlanResult) -> dict[str, str]:
    """File name → text of every output (the manifest last, since it lists the others' hashes)."""
    mission = build_mission(plan, name=plan.spec.name)
    fc = plan_features(plan)
    files = {
        "mission.plan": dumps_plan(mission),
        "mission.waypoints": dumps_wpl(mission),
        "plan.geojson": json.dumps(fc, separators=(",", ":"), ensure_ascii=False, allow_nan=False) + "\n",
        "plan.kml": feature_collection_to_kml(fc, plan.spec.name),
        "preview.svg": render_svg(plan),
    }
    hashes = {name: hashlib.sha256(text.encode("utf-8")).hexdigest() for name, text in files.items()}
    files["manifest.json"] = mf.dumps(mf.build_manifest(plan, len(mission.items), hashes))
    return files


def write_outputs(plan: PlanResult, outdir: Path) -> dict[str, str]:
    """Render everything first, then move it into `outdir`; an error leaves `outdir` untouched."""
    files = render_outputs(plan)
    with staged_directory(outdir) as stage:
        for name, text in files.items():
            atomic_write_text(stage / name, text)
    return files
