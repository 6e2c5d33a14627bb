"""`aerosurvey refly`: a mission over the gaps the flown coverage left."""

from __future__ import annotations

from pathlib import Path

import click

from aerosurvey.flight import MIN_GAP_DEFAULT_M2
from aerosurvey.mission.formats import DJI_TEMPLATES


@click.command()
@click.argument("log_dir", type=click.Path(file_okay=False, exists=True, path_type=Path))
@click.option("--plan", "plan_dir", required=True, type=click.Path(file_okay=False, exists=True, path_type=Path),
              help="The plan folder the flight flew.")
@click.option("--spec", "spec_path", required=True, type=click.Path(dir_okay=False, exists=True, path_type=Path),
              help="The mission spec of that plan (camera, vehicle, targets are reused).")
@click.option("--min-gap-m2", type=click.FloatRange(min=0), default=MIN_GAP_DEFAULT_M2, show_default=True,
              help="Ignore smaller gaps.")
@click.option("--dji", type=click.Choice(DJI_TEMPLATES), default=DJI_TEMPLATES[0], show_default=True,
              help="With a DJI camera: the template of the re-fly's .kmz waylines, as `plan --dji` (docs/clients/dji.md).")
@click.option("-o", "--output", "outdir", required=True, type=click.Path(file_okay=False, path_type=Path))
def refly(log_dir: Path, plan_dir: Path, spec_path: Path, min_gap_m2: float, dji: str, outdir: Path) -> None:
    """Plan a re-fly over the cells of LOG_DIR/coverage.tif seen by too few photos.

    The re-fly is a plan of its own over the gaps, with every file `plan` writes for the spec's
    camera and vehicle: with a DJI camera, the .kmz waylines DJI Pilot 2 flies. A --plan that is a campaign
    block's folder records a "re-fly" event in the campaign's register (docs/campaign.md)."""
    # the planner and rasterio are heavy: imported when the command runs
    from aerosurvey.flight.refly import plan_refly, write_refly
    from aerosurvey.rules.planview import PlanView

    r = plan_refly(log_dir, PlanView.from_outdir(plan_dir, "--plan"), spec_path, min_gap_m2, dji)
    for note in r.notes:
        click.echo(f"note: {note}")
    if r.plan is None:
        click.echo(f"no gaps: every cell of the area is seen by at least {r.need} flown photos; nothing to re-fly")
        return
    write_refly(r, outdir)
    plan = r.plan
    import shapely  # loaded by the command, not by `aerosurvey --help`

    from aerosurvey.commands.block_events import record_block_event

    gaps = (f"{shapely.area(r.gaps) / 1e4:.3f} ha in {len(shapely.get_parts(r.gaps))} gap(s) seen by fewer than {r.need} "
            "photos")
    click.echo(f"{gaps}; re-fly: {len(plan.route.runs)} runs, {len(plan.stations.ids)} photos, "
               f"{plan.estimates['total_time_s'] / 60:.1f} min; wrote {', '.join(sorted({*r.files, *r.binary}))} to {outdir}")
    record_block_event(plan_dir, "re-fly", f"{outdir}: {len(plan.stations.ids)} photos in {len(plan.route.runs)} runs over "
                                           f"{gaps} (flight {log_dir})")
