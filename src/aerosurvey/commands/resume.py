"""`aerosurvey resume`: the rest of a flight cut short, from the first station it did not photograph
as the mission asked (flight/resume_start.py says what counts).

Exit codes: 0 written, 2 bad input (a station the plan does not have, a spec or planner that no
longer makes the same plan, a log folder of another plan, nothing left to fly).
"""

from __future__ import annotations

from pathlib import Path

import click

from aerosurvey import console
from aerosurvey.errors import InputError


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
    from aerosurvey.flight.resume import resume_files, resumed_text, sortie_lines
    from aerosurvey.flight.resume_start import start_after, start_from_log
    from aerosurvey.inputs import load_inputs
    from aerosurvey.manifest import read_manifest
    from aerosurvey.spec import load_spec

    doc = read_manifest(plan_dir, "PLAN_DIR")
    start = start_after(doc.stations.ids, after) if after is not None else start_from_log(log_dir, doc)  # type: ignore[arg-type]
    spec = load_spec(spec_path)
    if spec.name != doc.mission.name:
        raise InputError(f"--spec {str(spec_path)!r} is mission {spec.name!r}, but {plan_dir} is mission "
                         f"{doc.mission.name!r}", key="--spec")
    plan, files = resume_files(spec, load_inputs(spec), start, doc, str(plan_dir))
    with staged_directory(outdir) as stage:
        for name, text in files.items():
            atomic_write_text(stage / name, text)
    for line in [*start.said, resumed_text(plan, start), *sortie_lines(plan)]:  # what was counted as done and why
        console.echo(line)
    console.echo(f"wrote {', '.join(sorted(files))} to {outdir}")
