"""`aerosurvey plan`: from a mission spec to mission files, manifest and preview."""

from __future__ import annotations

import logging
import shlex
import time
from pathlib import Path

import click

from aerosurvey import console
from aerosurvey.mission.formats import DJI_TEMPLATES, QGC_LAYOUTS

log = logging.getLogger(__name__)


@click.command()
@click.argument("spec", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", "outdir", type=click.Path(file_okay=False, path_type=Path), required=True,
              help="Folder for the mission files, manifest and preview (created if missing).")
@click.option("--gpkg", is_flag=True, help="Also write plan.gpkg: the plan as a GeoPackage, one styled layer per kind "
                                           "(docs/clients/qgis.md).")
@click.option("--qgc", type=click.Choice(QGC_LAYOUTS), default=QGC_LAYOUTS[0], show_default=True,
              help="How the .plan files hold each photo pass: a QGroundControl Survey item the pilot can edit "
                   "(flown as planned until edited), laid for QGroundControl 5.1 and later ('survey') or 4.x to 5.0 "
                   "('survey-5.0': they regenerate an edited item on another plane), or plain waypoint items "
                   "(docs/clients/qgroundcontrol.md).")
@click.option("--dji", type=click.Choice(DJI_TEMPLATES), default=DJI_TEMPLATES[0], show_default=True,
              help="What template.kml of each DJI .kmz holds: a mapping template (mapping2d, mappingStrip) where one "
                   "expresses the flight, else waypoints; or always waypoints. The route flown is the same "
                   "(docs/clients/dji.md).")
@click.option("--zones", "zone_files", multiple=True, type=click.Path(dir_okay=False, path_type=Path),
              help="An official UAS zone file (ED-269 or ED-318; repeatable) to check every leg against in four dimensions, "
                   "besides the spec's [airspace] zones (docs/airspace.md).")
@click.option("--wind", default=None, metavar="SPEED@FROM[GGUST]",
              help="The wind to plan in, over the spec's conditions.wind: m/s and the true bearing it blows from, "
                   "e.g. 6@240 or 6@240G9 (gusts).")
def plan(spec: Path, outdir: Path, gpkg: bool, qgc: str, dji: str, zone_files: tuple[Path, ...], wind: str | None) -> None:
    """Plan a survey mission from a mission spec (TOML) and write its files into the -o folder.

    Prints the plan's summary and the `aerosurvey check` command that shows the evidence of
    its rules (nothing with -q). Exit codes (docs/planning.md): 0 written and every
    error-severity rule passes; 1 either written for inspection only because an error-severity
    rule fails (the last line names them; `aerosurvey upload` then refuses it unless the pilot
    names each), or nothing written because the final safety gate refused a leg (in an
    exclusion zone, or in an official zone that blocks it: docs/airspace.md); 2 bad input
    (nothing written).
    """
    # imported here, not at the top: listing this command in `aerosurvey --help` must not load the planner
    from aerosurvey.inputs import plan_from_files
    from aerosurvey.outputs import write_outputs
    from aerosurvey.report.summary import summary_text
    from aerosurvey.spec import load_spec, with_wind, with_zone_files

    t0 = time.perf_counter()
    mission_spec = with_wind(with_zone_files(load_spec(spec), zone_files), wind)
    with console.progress(f"planning {mission_spec.name}") as report:
        result = plan_from_files(mission_spec, console.part(report, 0.0, 0.85))
        t1 = time.perf_counter()
        report("mission files, rules and preview", 0.85)
        rendered = write_outputs(result, mission_spec, outdir, gpkg, qgc, dji)
    log.info("planned in %.2f s, files written in %.2f s", t1 - t0, time.perf_counter() - t1)
    for line in summary_text(rendered.summary, f"aerosurvey check {shlex.quote(str(outdir))}"):
        console.echo(line)
    for w in rendered.warnings:
        console.echo(f"  warning: {w}")
    console.echo(f"wrote {', '.join(sorted([*rendered.files, *rendered.binary]))} to {outdir}")
    failing = rendered.summary.rules.failed
    if failing:  # written so that it can be inspected, but not a plan to fly as it is
        from aerosurvey.errors import CheckFailed

        raise CheckFailed(f"{len(failing)} error-severity rule(s) fail ({', '.join(failing)}): the plan is written to "
                          f"{outdir} for inspection only (`aerosurvey check {shlex.quote(str(outdir))}` for the evidence)")
