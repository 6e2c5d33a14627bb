"""`aerosurvey gcp`: propose ground control and check points for the field crew."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import click

from aerosurvey.errors import InputError
from aerosurvey.fileio import atomic_write_text, staged_directory

if TYPE_CHECKING:
    from shapely.geometry.base import BaseGeometry

    from aerosurvey.rules.planview import PlanView


def _nogo_zones(view: PlanView, paths: tuple[Path, ...]) -> BaseGeometry | None:
    """The no-go polygons (any CRS) united, in the plan's CRS."""
    import numpy as np
    import shapely

    from aerosurvey.area import read_area

    if not paths:
        return None
    parts = [shapely.transform(read_area(p, None, "EPSG:4326", f"no-go zone {p.name}"),
                               lambda xy: np.column_stack(view.to_plan.transform(xy[:, 0], xy[:, 1])))
             for p in paths]
    return shapely.union_all(parts)


@click.command()
@click.argument("target", type=click.Path(path_type=Path))
@click.option("-o", "--output", "outdir", type=click.Path(file_okay=False, path_type=Path),
              help="Folder for the control point files (default: the plan folder given as TARGET).")
@click.option("--profile", "profiles", multiple=True, help="Rule profile ids whose counts and visibility apply.")
@click.option("--profile-dir", "profile_dirs", multiple=True, type=click.Path(file_okay=False, path_type=Path))
@click.option("--nogo", "nogo", multiple=True, type=click.Path(dir_okay=False, path_type=Path),
              help="Polygons where no point may go (water, buildings, private land); repeatable.")
@click.option("--offset", type=float, default=None, help="GCP distance outside the outline in metres (default 10).")
def gcp(target: Path, outdir: Path | None, profiles: tuple[str, ...], profile_dirs: tuple[Path, ...],
        nogo: tuple[Path, ...], offset: float | None) -> None:
    """Propose GCPs (an envelope outside the perimeter) and check points (inside)."""
    # the rule engine loads numpy, shapely and pyproj: imported when the command runs, not when help lists it
    from aerosurvey.rules.cp_files import control_point_files
    from aerosurvey.rules.engine import Evidence, layout_settings
    from aerosurvey.rules.load import open_target
    from aerosurvey.rules.profile import apply_overrides, select_profiles

    t = open_target(target)
    out = outdir or t.outdir
    if out is None:
        raise InputError("give -o OUTDIR: TARGET is a spec, not a plan folder")
    if offset is not None and not 0 < offset <= 500:
        raise InputError(f"--offset = {offset} is not allowed: a distance in metres in (0, 500]")
    ids = list(profiles) or t.profiles
    chosen = apply_overrides(select_profiles(ids, list(profile_dirs)), t.overrides) if ids else []
    zones = _nogo_zones(t.view, nogo)
    ev = Evidence(t.view, layout_settings(t.view, chosen, nogo=zones, gcp_offset_m=offset))
    pts = ev.points
    files = control_point_files(t.view, pts)
    with staged_directory(out, merge=True) as stage:  # by default `out` is the plan folder: its files stay
        for name, text in files.items():
            atomic_write_text(stage / name, text)
    gcps = [p for p in pts if p.role == "gcp"]
    cps = [p for p in pts if p.role == "check"]
    click.echo(f"{len(gcps)} GCPs outside the perimeter (fewest photos on one: {min((p.images for p in gcps), default=0)}), "
               f"{len(cps)} check points inside ({t.view.area_ha:.1f} ha)")
    for p in pts:
        if p.note:
            click.echo(f"  {p.id}: {p.note}")
    click.echo(f"wrote {', '.join(sorted(files))} to {out}")
