"""A flight cut short, flown on: the plan made again from the first station not photographed
(flight/resume_start.py says which), checked to be the plan folder's, and its files.

`aerosurvey resume` and the web page's resume both call :func:`resume_files`; files are
written by the caller.
"""

from __future__ import annotations

import numpy as np

from aerosurvey.errors import InputError
from aerosurvey.flight.resume_start import ResumeStart
from aerosurvey.manifest import Manifest
from aerosurvey.outputs import render_resume
from aerosurvey.plan.inputs import PlanInputs
from aerosurvey.plan.planner import Plan, resume_mission
from aerosurvey.spec import MissionSpec

#: re-planned stations must lie this close to the plan folder's (degrees; ~1 cm) and metres of altitude
SAME_DEG = 1e-7
SAME_ALT_M = 0.01


def same_plan(plan: Plan, doc: Manifest) -> None:
    """The plan made now has the plan folder's stations (ids, positions, altitudes), or InputError."""
    st, was = plan.stations, doc.stations
    if tuple(st.ids) != tuple(was.ids):
        raise InputError(f"the spec now plans {len(st.ids)} stations where {doc.where} has {len(was.ids)} (or other ids): "
                         "resume needs the same plan; give the spec and inputs the plan was made from")
    moved = np.maximum(np.abs(st.lon - was.lon), np.abs(st.lat - was.lat))
    climbed = np.abs(st.alt_rel_m - was.alt_rel_m)
    if len(moved) and (moved.max() > SAME_DEG or climbed.max() > SAME_ALT_M):
        i = int(np.argmax(moved / SAME_DEG + climbed / SAME_ALT_M))
        raise InputError(f"the spec now plans station {st.ids[i]} {moved[i] * 111_320:.2f} m and {climbed[i]:.2f} m in "
                         f"altitude away from {doc.where}'s: resume needs the same plan (the same spec, inputs and "
                         "aerosurvey version)")


def resumed_text(plan: Plan, start: ResumeStart) -> str:
    """One line: the first station flown, the photos left, those counted as done and the sorties they take."""
    left = sum(s.last - s.first + 1 for s, _ in plan.sorties)
    return (f"resume from {start.first_id}: {left} of {len(plan.stations.ids)} photos left, {start.done} counted as done, "
            f"in {len(plan.sorties)} sortie(s)")


def sortie_lines(plan: Plan) -> list[str]:
    """One line per resumed sortie: its file stem, photos, minutes and first and last station."""
    st = plan.stations
    return [f"  resume-{k:02d}  {s.last - s.first + 1:5d} photos  {(s.horizontal_s + s.vertical_s) / 60:6.1f} min  "
            f"{st.ids[s.first]} -> {st.ids[s.last]}" for k, (s, _) in enumerate(plan.sorties, start=1)]


def resume_files(spec: MissionSpec, inputs: PlanInputs, start: ResumeStart, doc: Manifest,
                 plan_folder: str) -> tuple[Plan, dict[str, str]]:
    """(the resumed plan, file name → text of its files) of the plan `doc` flown on from `start`;
    InputError when the spec no longer makes the plan folder's stations (`same_plan`)."""
    plan = resume_mission(spec, inputs, start.first_id)
    same_plan(plan, doc)
    return plan, render_resume(plan, start.done, start.said, plan_folder)
