"""`aerosurvey resume`: the rest of a flight cut short, from the station after its last photo.

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
    from aerosurvey.manifest import Manifest
    from aerosurvey.plan.planner import Plan

#: re-planned stations must lie this close to the plan folder's (degrees; ~1 cm) and metres of altitude
SAME_DEG = 1e-7
SAME_ALT_M = 0.01


def last_photographed(log_dir: Path, doc: Manifest) -> str:
    """The station of the last photo of a `log ingest` folder of this plan (log order)."""
    from aerosurvey.flight import records
    from aerosurvey.flight.refly import read_log_of_plan

    read_log_of_plan(log_dir, doc)
    events_path = log_dir / "events.csv"
    if not events_path.is_file():
        raise InputError(f"--log {str(log_dir)!r} has no events.csv: give the folder "
                         "`aerosurvey log ingest LOG --plan PLAN -o FOLDER` wrote", key="--log")
    matched = [s for s in records.read_events_csv(events_path).station if s]
    if not matched:
        raise InputError(f"--log {str(log_dir)!r}: no camera event was matched to a station of the plan; "
                         "give --after STATION_ID", key="--log")
    return matched[-1]


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


def resumed_text(plan: Plan, station: str) -> str:
    """One line: the station resumed after, the photos left and the sorties they take."""
    left = sum(s.last - s.first + 1 for s, _ in plan.sorties)
    return (f"resume after {station}: {left} of {len(plan.stations.ids)} photos left, from "
            f"{plan.stations.ids[plan.sorties[0].sortie.first]}, in {len(plan.sorties)} sortie(s)")


@click.command()
@click.argument("plan_dir", type=click.Path(file_okay=False, exists=True, path_type=Path))
@click.option("--spec", "spec_path", required=True, type=click.Path(dir_okay=False, exists=True, path_type=Path),
              help="The mission spec PLAN_DIR was planned from.")
@click.option("--after", "after", default=None, metavar="STATION_ID",
              help="The station of the last photo taken, e.g. P1-L004-S0023.")
@click.option("--log", "log_dir", default=None, type=click.Path(file_okay=False, exists=True, path_type=Path),
              help="A `log ingest` folder of the flight: resume after its last matched photo.")
@click.option("-o", "--output", "outdir", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for the resumed sorties' mission files and resume.json.")
def resume(plan_dir: Path, spec_path: Path, after: str | None, log_dir: Path | None, outdir: Path) -> None:
    """Missions for the rest of a flight of PLAN_DIR cut short, from the station after its last photo.

    The station is --after's, or the last photo of the --log folder. The first sortie flies the
    rest of that photo's line with a lead-in and the camera switched on again, then the remaining
    plan follows, split into sorties by the battery and the autopilot's item limit, with the
    plan's station ids. Exit code 0 when written, 2 for bad input.
    """
    if (after is None) == (log_dir is None):
        raise InputError("give one of --after STATION_ID or --log FLIGHT_FOLDER", key="--after")
    from aerosurvey.fileio import atomic_write_text, staged_directory
    from aerosurvey.inputs import load_inputs
    from aerosurvey.manifest import read_manifest
    from aerosurvey.outputs import render_resume
    from aerosurvey.plan.planner import resume_mission
    from aerosurvey.spec import load_spec

    doc = read_manifest(plan_dir, "PLAN_DIR")
    station = after if after is not None else last_photographed(log_dir, doc)  # type: ignore[arg-type]
    spec = load_spec(spec_path)
    if spec.name != doc.mission.name:
        raise InputError(f"--spec {str(spec_path)!r} is mission {spec.name!r}, but {plan_dir} is mission "
                         f"{doc.mission.name!r}", key="--spec")
    plan = resume_mission(spec, load_inputs(spec), station)
    same_plan(plan, doc)
    files = render_resume(plan, station, str(plan_dir))
    with staged_directory(outdir) as stage:
        for name, text in files.items():
            atomic_write_text(stage / name, text)
    st = plan.stations
    console.echo(resumed_text(plan, station))
    for k, (s, _) in enumerate(plan.sorties, start=1):
        console.echo(f"  resume-{k:02d}  {s.last - s.first + 1:5d} photos  {(s.horizontal_s + s.vertical_s) / 60:6.1f} min  "
                   f"{st.ids[s.first]} -> {st.ids[s.last]}")
    console.echo(f"wrote {', '.join(sorted(files))} to {outdir}")
