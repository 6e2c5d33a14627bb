"""`aerosurvey campaign`: many blocks planned as one campaign, and the campaign's register (docs/campaign.md)."""

from __future__ import annotations

import logging
import os
from pathlib import Path

import click

from aerosurvey import console

log = logging.getLogger(__name__)


@click.group()
def campaign() -> None:
    """Campaigns: many blocks planned in parallel (a process pool or Dask), one register of their lives."""


@campaign.command("plan")
@click.argument("blocks", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", "outdir", type=click.Path(file_okay=False, path_type=Path), required=True,
              help="The campaign folder: blocks/NAME.KEY/ per block and register.gpkg (created if missing; a rerun "
                   "plans only the blocks not done).")
@click.option("--spec", "template", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="The mission spec template (TOML) every block is planned with; [area] comes from the block.")
@click.option("--outputs", default="manifest,pilot", show_default=True,
              help="What each block writes: comma-separated groups of manifest, pilot (.plan, .waypoints, .kmz), "
                   "geojson, kml, preview, gpkg; or all.")
@click.option("--workers", type=int, default=None, help="Worker processes (default: the machine's cores).")
@click.option("--dask", type=click.Choice(["local"]), default=None,
              help="Run the blocks on Dask distributed, on a LocalCluster of --workers processes.")
@click.option("--scheduler", default=None, help="Run the blocks on the Dask scheduler at this address (tcp://HOST:PORT).")
@click.option("--overlap", is_flag=True,
              help="Grow each block into its neighbours by the overlap the guarantee needs, for blocks that abut (a grid, "
                   "parcels); `campaign split`'s blocks overlap already.")
def plan(blocks: Path, outdir: Path, template: Path, outputs: str, workers: int | None, dask: str | None,
         scheduler: str | None, overlap: bool) -> None:
    """Plan every block of BLOCKS (a GeoPackage or GeoJSON of polygons) with the --spec template into
    the campaign folder, and write its register.gpkg.

    Each block is planned by one function of its inputs and written into its own folder named
    after their hash, atomically: a rerun plans only what is not done, a crash loses nothing.
    Exit code 0 when every block is planned, 1 when some failed (rerun to try them again),
    2 for bad input.
    """
    from aerosurvey.campaign.blocks import read_blocks
    from aerosurvey.campaign.job import make_jobs, parse_outputs
    from aerosurvey.campaign.register import after_planning, now_utc, update_register
    from aerosurvey.campaign.run import executor, run_campaign
    from aerosurvey.errors import CheckFailed

    groups = parse_outputs(outputs)
    crs, found = read_blocks(blocks)
    if overlap:
        from aerosurvey.campaign.job import block_spec, read_template
        from aerosurvey.campaign.split import overlapping_blocks

        text, _ = read_template(template)
        found = overlapping_blocks(found, crs, [block_spec(text, template.resolve().parent, b, crs) for b in found])
    jobs = make_jobs(found, crs, template, groups)
    outdir.mkdir(parents=True, exist_ok=True)
    with executor(workers if workers is not None else os.cpu_count() or 1, dask, scheduler) as run, \
            console.progress(f"campaign {outdir.name}: {len(jobs)} blocks") as report:
        results, tally = run_campaign(jobs, outdir, run, report)
    now = now_utc()
    # the events as they are now, under the lock: those recorded while the blocks were planned are kept
    update_register(outdir, lambda _, events: after_planning(jobs, results, events, now), new=True)
    counts: dict[str, int] = {}
    for r in results:
        counts[r.status] = counts.get(r.status, 0) + 1
    console.echo(f"{len(jobs)} blocks: " + ", ".join(f"{n} {s}" for s, n in sorted(counts.items())) + f" ({tally.text()})")
    console.echo(f"register: {outdir / 'register.gpkg'}")
    failed = [r.name for r in results if r.status == "failed"]
    if failed:
        shown = ", ".join(failed[:5]) + (f" and {len(failed) - 5} more" if len(failed) > 5 else "")
        raise CheckFailed(f"{len(failed)} block(s) failed ({shown}): `aerosurvey campaign status {outdir}` says why; "
                          "run the same command again to plan them")


@campaign.command("status")
@click.argument("campaign_dir", type=click.Path(file_okay=False, exists=True, path_type=Path))
@click.option("--limit", type=int, default=20, show_default=True, help="Waiting blocks listed (0: all).")
def status(campaign_dir: Path, limit: int) -> None:
    """Counts of the blocks per status, and what each waiting block needs next."""
    from aerosurvey.campaign.register import NEXT, read_register

    rows, events = read_register(campaign_dir)
    counts: dict[str, int] = {}
    for r in rows:
        counts[r.status] = counts.get(r.status, 0) + 1
    console.echo(f"{len(rows)} blocks, {len(events)} events: " + ", ".join(f"{n} {s}" for s, n in sorted(counts.items())))
    waiting = [r for r in rows if r.status != "accepted"]
    for r in waiting[:limit or None]:
        why = f" ({r.message})" if r.message else (f" (failing: {r.rules_failing})" if r.rules_failing else "")
        console.echo(f"  {r.name}: {r.status}{why}; next: {NEXT[r.status].format(folder=r.folder)}")
    if limit and len(waiting) > limit:
        console.echo(f"  … and {len(waiting) - limit} more waiting (--limit 0 lists all)")


@campaign.command("ingest")
@click.argument("campaign_dir", type=click.Path(file_okay=False, exists=True, path_type=Path))
@click.argument("flights", nargs=-1, required=True, type=click.Path(path_type=Path))
def ingest(campaign_dir: Path, flights: tuple[Path, ...]) -> None:
    """File flight logs and photo folders under their blocks (a folder per flight in flights/ under its block's name,
    written as `log ingest` writes one with the block's plan), each recognised by the mission it records (else by where
    its photos are); a "flown" event each.

    Exit code 0 when every flight is filed, 1 when some is of no block (the rest are filed), 2 for bad input.
    """
    from aerosurvey.campaign.flights import ingest_flights, with_flown
    from aerosurvey.campaign.register import now_utc, read_register, update_register
    from aerosurvey.errors import CheckFailed

    rows, _ = read_register(campaign_dir)
    now = now_utc()
    with console.progress(f"campaign ingest: {len(flights)} flights"):
        filed = ingest_flights(campaign_dir, list(flights), rows)
    # the register as it is now, under the lock: events recorded while the flights were read are kept
    update_register(campaign_dir, lambda rows, events: with_flown(rows, events, filed, now))
    for f in filed:
        console.echo(f"{f.flight}: {'block ' + f.block + ': ' + f.detail if f.block else 'not filed: ' + f.detail}")
    lost = [f.flight for f in filed if f.block is None]
    if lost:
        raise CheckFailed(f"{len(lost)} of {len(filed)} flight(s) are of no block of the campaign ({', '.join(lost[:5])}); "
                          "the others are filed")


@campaign.command("record")
@click.argument("campaign_dir", type=click.Path(file_okay=False, exists=True, path_type=Path))
@click.argument("block")
@click.argument("event")
@click.option("--detail", default="", help="What the event says (who, which file, the QA figures …).")
@click.option("--accuracy", type=click.Path(path_type=Path), default=None,
              help="With qa: the accuracy.json `aerosurvey qa accuracy -o DIR` wrote for the block (or DIR): filed under "
                   "CAMPAIGN/qa/, its RMSE per axis, points and verdict in the event's detail; `campaign report` learns from it.")
def record(campaign_dir: Path, block: str, event: str, detail: str, accuracy: Path | None) -> None:
    """Record an event of BLOCK's life in the register by hand: uploaded, compliance, re-fly, qa or accepted.

    `upload`, `check FLIGHT`, `refly` and `qa accuracy` (its plan folder a block's, its verdict written with -o)
    record theirs when they work on a block's folder; `accepted` is a person's decision, recorded here only."""
    from aerosurvey.campaign.register import now_utc, read_register, record
    from aerosurvey.errors import InputError

    read_register(campaign_dir)  # a campaign folder without a register: its own error, before the lock file is made
    if accuracy is None:
        row = record(campaign_dir, block, event, detail, now_utc())
    else:
        from aerosurvey.campaign.verdicts import record_verdict

        if event != "qa":
            raise InputError(f"--accuracy is given with event = {event!r}: it files a QA verdict, give the event qa",
                             key="--accuracy")
        row = record_verdict(campaign_dir, block, accuracy, detail, now_utc())
    console.echo(f"{block}: {event} recorded; status {row.status}")


@campaign.command("report")
@click.argument("campaign_dir", type=click.Path(file_okay=False, exists=True, path_type=Path))
@click.option("--class-h", type=click.FloatRange(min=0, min_open=True), default=None,
              help="The horizontal class to compare with, cm (default: the one the blocks' accuracy tests asked).")
@click.option("--class-v", type=click.FloatRange(min=0, min_open=True), default=None,
              help="The vertical class to compare with, cm (default: the one the blocks' accuracy tests asked).")
@click.option("--json", "as_json", is_flag=True, help="Print the JSON report instead of the text.")
@click.option("-o", "--output", "out", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Also write the JSON report to this file.")
def report(campaign_dir: Path, class_h: float | None, class_v: float | None, as_json: bool, out: Path | None) -> None:
    """What the campaign learns: the accuracy its accepted blocks achieved (their QA verdicts filed by `campaign
    record` with its accuracy.json) against GSD, control density and relief, with the spread, beside the class asked,
    and the largest GSD the campaign's own spread says meets it (docs/campaign.md)."""
    import json

    from aerosurvey import __version__, schemas
    from aerosurvey.campaign.learn import SCHEMA, VERSION, asked_classes, learn, report_text
    from aerosurvey.campaign.register import read_register
    from aerosurvey.campaign.verdicts import accepted_figures
    from aerosurvey.fileio import atomic_write_text

    rows, _ = read_register(campaign_dir)
    accepted, blocks = accepted_figures(campaign_dir, rows)
    ch, cv = asked_classes(blocks, class_h, class_v)
    body = learn(blocks, ch, cv)
    doc = {"schema": SCHEMA, "schema_version": VERSION, "aerosurvey_version": __version__, "campaign": campaign_dir.name,
           "accepted": accepted, "learned": len(blocks), **body}
    err = schemas.first_error("campaign_report", doc)
    if err is not None:
        raise ValueError(f"the campaign report does not match its schema: {err}")  # a bug, found before writing
    text = json.dumps(doc, indent=1, allow_nan=False) + "\n"
    if out is not None:
        atomic_write_text(out, text)
    console.echo((text if as_json else report_text(body, accepted, len(blocks))).rstrip("\n"))


@campaign.command("split")
@click.argument("area", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", "out", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="The blocks file to write (.gpkg or .geojson): one polygon per block, with its name, heading and cut path.")
@click.option("--max-ha", type=click.FloatRange(min=0, min_open=True), default=None,
              help="The largest block, hectares, its overlaps included.")
@click.option("--max-sorties", type=click.IntRange(min=1), default=None,
              help="The most sorties a block may take (planned with the template and its heading, the template's [battery] "
                   "splitting the sorties); instead of --max-ha.")
@click.option("--spec", "template", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="The campaign's spec template: its camera, height and overlaps give the overlap at each cut.")
@click.option("--heading", type=click.FloatRange(0, 360, max_open=True), default=None,
              help="The flight lines' true bearing, degrees (default: the template's flight.heading, else along the area's length).")
@click.option("--prefix", default="b", show_default=True, help="Block names: PREFIX0001, PREFIX0002 …")
def split(area: Path, out: Path, max_ha: float | None, max_sorties: int | None, template: Path, heading: float | None,
          prefix: str) -> None:
    """Cut AREA into blocks of at most --max-ha, or each flown in at most --max-sorties sorties, along straight cuts
    aligned with the flight lines, neighbours overlapping at each cut by what neighbouring strips (or photos) of one
    area share (docs/campaign.md)."""
    import shapely

    from aerosurvey.area import read_area
    from aerosurvey.campaign.blocks import Block, write_blocks
    from aerosurvey.campaign.job import block_spec, read_template
    from aerosurvey.campaign.split import MaxSorties, blocks_of_area
    from aerosurvey.errors import InputError

    if (max_ha is None) == (max_sorties is None):
        raise InputError("give one of --max-ha and --max-sorties: the size of a block", key="--max-ha")
    region = read_area(area, None, "EPSG:4326", "area")
    text, _ = read_template(template)
    base = template.resolve().parent
    spec = block_spec(text, base, Block("area", shapely.to_wkb(region), ()), "EPSG:4326")
    by_sorties = MaxSorties(max_sorties, text, str(base)) if max_sorties is not None else None
    with console.progress(f"campaign split {area.name}"):
        polygons, headings, cuts = blocks_of_area(region, spec, heading, max_ha, by_sorties)
    names = [f"{prefix}{i:04d}" for i in range(1, len(polygons) + 1)]
    write_blocks(out, polygons, names, headings, cuts)
    size = f"at most {max_ha:g} ha" if max_ha is not None else f"each flown in at most {max_sorties} sorties"
    console.echo(f"{len(polygons)} blocks {size} written to {out}")
