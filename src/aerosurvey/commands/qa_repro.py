"""`aerosurvey qa reproducibility`, `qa timeseries`, `qa shift`."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click

from aerosurvey import console
from aerosurvey.errors import InputError
from aerosurvey.fileio import atomic_write_text, staged_directory


def _crop_geoms(path: Path, grid_crs: Any) -> tuple[Any, ...]:
    import numpy as np
    import pyproj
    import shapely

    from aerosurvey.area import read_area

    geom = read_area(path, None, "EPSG:4326", f"--crop {path.name}")
    if grid_crs is None:
        raise InputError("--crop FILE needs georeferenced inputs")
    t = pyproj.Transformer.from_crs("EPSG:4326", grid_crs.to_wkt(), always_xy=True)
    g = shapely.transform(geom, lambda xy: np.column_stack(t.transform(xy[:, 0], xy[:, 1])))
    return tuple(shapely.get_parts(g))


@click.command()
@click.argument("orthos", nargs=-1, required=True, type=click.Path(path_type=Path))
@click.option("--statistic", type=click.Choice(["pixel", "window"]), default="pixel", show_default=True,
              help="pixel: per-pixel correlation across the bands (the source study's, raster::corLocal on bricks); "
                   "window: a w x w window with the bands pooled.")
@click.option("--window", type=int, default=None,
              help="Window size in pixels for --statistic window (odd, >= 3; default 5); an error with --statistic "
                   "pixel.")
@click.option("--threshold", type=float, default=0.95, show_default=True,
              help="A pixel is reproducible when r > threshold.")
@click.option("--resample", is_flag=True,
              help="Warp inputs on another grid (CRS, transform, size) onto the first input's (bilinear); without "
                   "it such inputs are refused.")
@click.option("--crop", default="none", show_default=True, help="none, auto (data footprint shrunk by --crop-margin) or a polygon file.")
@click.option("--crop-margin", type=click.IntRange(0, 5000), default=50, show_default=True, help="Pixels removed at the data edge (auto).")
@click.option("--block", type=click.IntRange(64, 8192), default=1024, show_default=True, help="Block size in pixels.")
@click.option("--scheduler", default="threads", show_default=True,
              help="threads, local (a Dask LocalCluster) or the address of a Dask scheduler (tcp://host:8786).")
@click.option("-o", "--output", "outdir", required=True, type=click.Path(file_okay=False, path_type=Path))
def reproducibility(orthos: tuple[Path, ...], statistic: str, window: int | None, threshold: float, resample: bool, crop: str,
                    crop_margin: int, block: int, scheduler: str, outdir: Path) -> None:
    """Reproducibility layer of orthomosaics processed several times with the same settings.

    \b
    Exit codes: 0 done; 2 bad input (unreadable raster, other grid without
    --resample, unreachable Dask scheduler, bad option); nothing is written then.
    """
    from aerosurvey.qa import reproducibility as rp

    size = rp.validate_settings(window, threshold, statistic)
    paths = list(orthos)
    grid = rp.inspect(paths, resample)
    geoms: tuple[Any, ...] = ()
    if crop not in ("none", "auto"):
        geoms = _crop_geoms(Path(crop), grid.crs)
    s = rp.Settings(window=size, threshold=threshold, crop=crop if crop in ("none", "auto") else "file",
                    crop_margin_px=crop_margin, block=block, crop_geoms=geoms, statistic=statistic, resample=resample)
    with staged_directory(outdir) as stage, console.progress("reproducibility") as report:
        summary = rp.run(paths, stage, s, scheduler, progress=report)
        rp.write_summary(stage, summary)
    chance = summary["chance_level"]
    click.echo(f"{summary['pairs']} pairs ({statistic} statistic): {100 * summary['reproducible_share']:.2f} % of "
               f"{summary['judged_pixels']} judged pixels reproducible in every pair (chance level: "
               f"{100 * chance['probability']:.1f} % of unrelated pixels pass r > {threshold:g} in one pair, n = "
               f"{chance['values']} values); wrote reproducibility.tif, summary.json, summary.txt to {outdir}")


@click.command()
@click.option("--masks", "dirs", multiple=True, required=True, type=click.Path(file_okay=False, exists=True, path_type=Path),
              help="A folder written by `qa reproducibility` for one date (repeat for each date).")
@click.option("-o", "--output", "outdir", required=True, type=click.Path(file_okay=False, path_type=Path))
def timeseries(dirs: tuple[Path, ...], outdir: Path) -> None:
    """Quality mask of pixels reproducible at every date."""
    from aerosurvey.qa.timeseries import quality_mask

    if len(dirs) < 2:
        raise InputError("give --masks for at least two dates")
    with staged_directory(outdir) as stage:
        summary = quality_mask(list(dirs), stage)
        atomic_write_text(stage / "timeseries.json", json.dumps(summary, indent=1) + "\n")
    click.echo(f"{100 * summary['reproducible_in_every_date_share']:.2f} % of {summary['judged_pixels']} judged pixels "
               f"reproducible at every date; wrote quality_mask.tif to {outdir}")


@click.command()
@click.argument("objects", nargs=-1, required=True, type=click.Path(path_type=Path))
@click.option("--id-field", default="id", show_default=True, help="The field that names the same object at every date.")
@click.option("-o", "--output", "outdir", type=click.Path(file_okay=False, path_type=Path), default=None)
def shift(objects: tuple[Path, ...], id_field: str, outdir: Path | None) -> None:
    """Shift of the same objects digitised at several dates (bounding boxes and centroids)."""
    from aerosurvey.qa.timeseries import object_shift

    res = object_shift(list(objects), id_field)
    for d in res["per_date"]:
        click.echo(f"{d['date']}: {d['objects']} objects, centroid shift mean {d['centroid_shift_mean_m']:.3f}, "
                   f"median {d['centroid_shift_median_m']:.3f}, max {d['centroid_shift_max_m']:.3f} ({res['unit']})"
                   + (f"; missing {', '.join(d['missing'])}" if d["missing"] else ""))
    if outdir is not None:
        with staged_directory(outdir) as stage:
            atomic_write_text(stage / "shift.json", json.dumps(res, indent=1) + "\n")
