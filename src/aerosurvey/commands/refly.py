"""`aerosurvey refly`: a mission over the gaps the flown coverage left."""

from __future__ import annotations

import json
from pathlib import Path

import click

from aerosurvey.errors import InputError
from aerosurvey.fileio import atomic_write_text


@click.command()
@click.argument("log_dir", type=click.Path(file_okay=False, exists=True, path_type=Path))
@click.option("--plan", "plan_dir", required=True, type=click.Path(file_okay=False, exists=True, path_type=Path),
              help="The plan folder the flight flew.")
@click.option("--spec", "spec_path", required=True, type=click.Path(dir_okay=False, exists=True, path_type=Path),
              help="The mission spec of that plan (camera, vehicle, targets are reused).")
@click.option("--min-gap-m2", type=click.FloatRange(min=0), default=25.0, show_default=True, help="Ignore smaller gaps.")
@click.option("-o", "--output", "outdir", required=True, type=click.Path(file_okay=False, path_type=Path))
def refly(log_dir: Path, plan_dir: Path, spec_path: Path, min_gap_m2: float, outdir: Path) -> None:
    """Plan a re-fly over the cells of LOG_DIR/coverage.tif seen by too few photos."""
    import numpy as np  # not at the top: `aerosurvey --help` imports this module to list the command
    import shapely
    import shapely.geometry

    from aerosurvey.flight.refly import gap_area, needed_images, refly_spec
    from aerosurvey.inputs import plan_from_files
    from aerosurvey.outputs import write_outputs
    from aerosurvey.rules.planview import PlanView
    from aerosurvey.spec import parse_spec

    cov = log_dir / "coverage.tif"
    if not cov.exists():
        raise InputError(f"{log_dir}: coverage.tif is missing; run `aerosurvey log ingest LOG --plan PLAN -o {log_dir}` first")
    view = PlanView.from_outdir(plan_dir)
    need = needed_images(view.manifest)
    gaps = gap_area(cov, need, view.area, min_gap_m2)
    if gaps.is_empty:
        click.echo(f"no gaps: every cell of the area is seen by at least {need} flown photos; nothing to re-fly")
        return
    data = refly_spec(spec_path, gaps, view.crs)
    spec = parse_spec(data, base=spec_path.parent, path=None)
    plan = plan_from_files(spec)
    rendered = write_outputs(plan, outdir)
    click.echo(f"{shapely.area(gaps) / 1e4:.3f} ha in {len(shapely.get_parts(gaps))} gap(s) seen by fewer than {need} photos; "
               f"re-fly: {len(plan.route.runs)} runs, {len(plan.stations.ids)} photos, "
               f"{plan.estimates['total_time_s'] / 60:.1f} min; wrote {', '.join(sorted(rendered.files))} to {outdir}")
    gaps_ll = shapely.transform(gaps, lambda xy: np.column_stack(view.to_wgs84.transform(xy[:, 0], xy[:, 1])))
    atomic_write_text(outdir / "gaps.geojson", json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"role": "gap", "needed_images": need},
         "geometry": shapely.geometry.mapping(gaps_ll)}]}) + "\n")
