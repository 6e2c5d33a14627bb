"""`aerosurvey resume`: the rest of a flight cut short, from the first station it did not photograph
as the mission asked (flight/resume_start.py says what counts).

Exit codes: 0 written, 2 bad input (a station the plan does not have, a spec or planner that no
longer makes the same plan, a log folder of another plan, nothing left to fly).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import click

from aerosurvey import console
from aerosurvey.errors import InputError

if TYPE_CHECKING:
    from aerosurvey.flight.resume_start import ResumeStart
    from aerosurvey.manifest import Manifest
    from aerosurvey.plan.planner import Plan

#: re-planned stations must lie this close to the plan folder's (degrees; ~1 cm) and metres of altitude
SAME_DEG = 1e-7
SAME_ALT_M = 0.01


def same_plan(plan: Plan, doc: Manifest) -> None:
    """The plan made now has the plan folder's stations (ids, positions, altitudes), or InputError."""
    import numpy as np

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


@click.command()
@click.argument("plan_dir", type=click.Path(file_okay=False, exists=True, path_type=Path))
@click.option("--spec", "spec_path", required=True, type=click.Path(dir_okay=False, exists=True, path_type=Path),
              help="The mission spec PLAN_DIR was planned from.")
@click.option("--after", "after", default=None, metavar="STATION_ID",
              help="The stations up to this one (flight order) are done, e.g. P1-L004-S0023: resume after it.")
@click.option("--log", "log_dir", default=None, type=click.Path(file_okay=False, exists=True, path_type=Path),
              help="The folder `log ingest` wrote for the flight, with the plan: resume from the first station without a photo taken in "
                   "the mission's mode (AUTO) within the tolerance of its station.")
@click.option("-o", "--output", "outdir", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for the resumed sorties' mission files and resume.json.")
def resume(plan_dir: Path, spec_path: Path, after: str | None, log_dir: Path | None, outdir: Path) -> None:
    """Missions for the rest of a flight of PLAN_DIR cut short, from its first station not photographed.

    With --log, a photo counts as done when it was taken in the mission's mode (AUTO; not in a
    return to launch, which keeps triggering) within the tolerance of its station, and the flight
    resumes at the first station of the flight order no such photo took; with --after, at the
    station after the one given. The first sortie flies from there with a lead-in, the gimbal set
    and the camera switched on again, then the remaining plan follows, split into sorties by the
    battery and the autopilot's item limit, with the plan's station ids. Exit code 0 when written,
    2 for bad input.
    """
    if (after is None) == (log_dir is None):
        raise InputError("give one of --after STATION_ID or --log FLIGHT_FOLDER", key="--after")
    from aerosurvey.fileio import atomic_write_text, staged_directory
    from aerosurvey.flight.resume_start import start_after, start_from_log
    from aerosurvey.inputs import load_inputs
    from aerosurvey.manifest import read_manifest
    from aerosurvey.outputs import render_resume
    from aerosurvey.plan.planner import resume_mission
    from aerosurvey.spec import load_spec

    doc = read_manifest(plan_dir, "PLAN_DIR")
    start = start_after(doc.stations.ids, after) if after is not None else start_from_log(log_dir, doc)  # type: ignore[arg-type]
    spec = load_spec(spec_path)
    if spec.name != doc.mission.name:
        raise InputError(f"--spec {str(spec_path)!r} is mission {spec.name!r}, but {plan_dir} is mission "
                         f"{doc.mission.name!r}", key="--spec")
    plan = resume_mission(spec, load_inputs(spec), start.first_id)
    same_plan(plan, doc)
    files = render_resume(plan, start.done, start.said, str(plan_dir))
    with staged_directory(outdir) as stage:
        for name, text in files.items():
            atomic_write_text(stage / name, text)
    st = plan.stations
    for line in start.said:  # what was counted as done and why
        console.echo(line)
    console.echo(resumed_text(plan, start))
    for k, (s, _) in enumerate(plan.sorties, start=1):
        console.echo(f"  resume-{k:02d}  {s.last - s.first + 1:5d} photos  {(s.horizontal_s + s.vertical_s) / 60:6.1f} min  "
                   f"{st.ids[s.first]} -> {st.ids[s.last]}")
    console.echo(f"wrote {', '.join(sorted(files))} to {outdir}")
