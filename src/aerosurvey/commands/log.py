"""`aerosurvey log ingest`: camera events of a flight log, matched to the planned stations."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from aerosurvey import console


@click.group()
def log() -> None:
    """Flight logs: camera events, their match to the plan."""


@log.command("ingest")
@click.argument("flight_logs", nargs=-1, required=True, type=click.Path(path_type=Path), metavar="FLIGHT_LOG...")
@click.option("--plan", "plan_dir", type=click.Path(file_okay=False, exists=True, path_type=Path), default=None,
              help="The plan folder (manifest.json) the flight flew.")
@click.option("--sortie", default=None, help="Sortie id (S01 …) the log is of; default: the whole mission.")
@click.option("--tolerance", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Metres a trigger may lie from its station (default: a quarter of the photo base).")
@click.option("--images", "images_dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Folder of the flight's images: matched to events by EXIF time; writes the camera poses for "
                   "photogrammetry (geo.txt, pix4d_geolocation.csv, metashape_reference.csv).")
@click.option("--accuracy-xy", type=float, default=2.0, show_default=True,
              help="Camera position accuracy (m, one standard deviation) in the camera pose files; a photo that "
                   "records its own (DJI's RtkStdLon/Lat) has that.")
@click.option("--accuracy-z", type=float, default=4.0, show_default=True,
              help="Camera height accuracy (m, one standard deviation) in the camera pose files; a photo that "
                   "records its own (DJI's RtkStdHgt) has that.")
@click.option("--fixed-camera", is_flag=True, help="The camera is fixed to the body (no gimbal): apply roll and pitch to the footprints.")
@click.option("--dem", "dem_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="DEM GeoTIFF (any CRS, orthometric heights): with --plan, photo heights above ground are the "
                   "logged AMSL altitude minus the DEM under each photo (default: height above home, flat ground).")
@click.option("--geotag-copies", "geotag_dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="With --images: write a copy of each matched JPEG here with EXIF GPS tags from its event "
                   "(image data not re-encoded). Must not be the --images folder unless --geotag-in-place is given.")
@click.option("--geotag-in-place", is_flag=True,
              help="With --images: write the EXIF GPS tags into the original JPEGs themselves (each replaced atomically).")
@click.option("-o", "--output", "outdir", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for events.csv, log_report.json and, with --plan, coverage.tif; with --images, geo.txt, "
                   "pix4d_geolocation.csv and metashape_reference.csv.")
def ingest(flight_logs: tuple[Path, ...], plan_dir: Path | None, sortie: str | None, tolerance: float | None, images_dir: Path | None,
           accuracy_xy: float, accuracy_z: float, fixed_camera: bool, dem_path: Path | None, geotag_dir: Path | None,
           geotag_in_place: bool, outdir: Path) -> None:
    """Extract camera events; with --plan, match them to the planned stations (events.csv, log_report.json).

    FLIGHT_LOG is a DataFlash (.bin, .log), telemetry (.tlog) or ULog (.ulg) log, or a folder of
    the flight's photos (a DJI aircraft's, or any camera's with GPS EXIF): then each photo is a
    camera event, with its RTK solution, and the camera pose files are written for its photos.

    Several FLIGHT_LOGs (logs and photo folders of one plan: its sorties, a sortie flown again, a
    re-fly) are ingested as one day of flights, with --plan: each is recognised as its sortie,
    its outputs go to records/NN-NAME/ of the output folder, and day_report.json holds the
    coverage, figures and rules of their photos' union per sortie and for the whole, and the
    stations no record photographed (docs/flight-logs.md, "A day of flights")."""
    if len(flight_logs) > 1:
        _ingest_day(flight_logs, plan_dir, sortie, tolerance, images_dir, accuracy_xy, accuracy_z, fixed_camera, dem_path,
                    geotag_dir is not None or geotag_in_place, outdir)
        return
    flight_log = flight_logs[0]
    # the flight modules pull in rasterio, scipy and the rule engine: imported when the command runs
    from aerosurvey.errors import CheckFailed
    from aerosurvey.flight.ingest import geotag_destination, ingest, losses_beyond_share, photo_flight_options, write_ingest
    from aerosurvey.flight.mission_flown import another_mission
    from aerosurvey.rules.planview import PlanView

    if flight_log.is_dir():
        photo_flight_options(flight_log, images_dir, fixed_camera, geotag_dir is not None or geotag_in_place)
    geotag_dir = geotag_destination(images_dir, geotag_dir, geotag_in_place)
    view = PlanView.from_outdir(plan_dir, "--plan") if plan_dir is not None else None
    with console.progress(f"log ingest {flight_log.name}") as step:
        result = ingest(flight_log, view, sortie=sortie, tolerance_m=tolerance, fixed_camera=fixed_camera, dem_path=dem_path,
                        images_dir=images_dir, progress=step)
    report = write_ingest(result, outdir, accuracy_xy=accuracy_xy, accuracy_z=accuracy_z, fixed_camera=fixed_camera,
                          geotag_dir=geotag_dir, geotag_in_place=geotag_in_place)
    _echo(report)
    if result.mission is not None:
        for line in result.mission.lines():
            click.echo(line)
    lost = losses_beyond_share(flight_log.name, report["read"], report["events"])
    other = another_mission(report)
    if lost is not None or other is not None:
        raise CheckFailed("; ".join(why for why in (other, lost) if why is not None))


def _ingest_day(paths: tuple[Path, ...], plan_dir: Path | None, sortie: str | None, tolerance: float | None,
                images_dir: Path | None, accuracy_xy: float, accuracy_z: float, fixed_camera: bool, dem_path: Path | None,
                geotag: bool, outdir: Path) -> None:
    from aerosurvey.errors import InputError
    from aerosurvey.flight.day import ingest_day, write_day
    from aerosurvey.rules.planview import PlanView

    names = ", ".join(p.name for p in paths)
    if plan_dir is None:
        raise InputError(f"{len(paths)} flight records ({names}): a day of flights is of one plan; give --plan", key="--plan")
    for given, option in ((sortie, "--sortie"), (images_dir, "--images"), (geotag or None, "--geotag-copies")):
        if given is not None:
            raise InputError(f"{option}: it is of one flight record, and {len(paths)} are given ({names}); each record's "
                             "sortie is recognised, images and geotags are matched one log at a time", key=option)
    view = PlanView.from_outdir(plan_dir, "--plan")
    with console.progress(f"log ingest: a day of {len(paths)} records") as step:
        day = ingest_day(paths, view, tolerance_m=tolerance, fixed_camera=fixed_camera, dem_path=dem_path, progress=step)
    report = write_day(day, outdir, accuracy_xy=accuracy_xy, accuracy_z=accuracy_z, fixed_camera=fixed_camera)
    for line in day_lines(report):
        click.echo(line)
    click.echo(f"wrote {outdir}: day_report.json, coverage.tif and each record's outputs in records/; re-fly what is "
               f"missing with `aerosurvey refly {outdir} --plan {plan_dir} --spec SPEC`")


def day_lines(report: dict[str, Any], most: int = 10) -> list[str]:
    """What `log ingest` prints of a day: each record, each sortie and the whole day."""
    out = []
    for r in report["records"]:
        what = f"sortie {r['sortie']}" if r["kind"] == "sortie" else ("the whole mission" if r["kind"] == "whole" else "a re-fly")
        out.append(f"record {r['record']} {r['name']}: {what} ({r['recognised']}); {r['events']} photos, {r['matched']} "
                   f"matched, {r['kept']} kept in the day ({r['folder']})")

    def group(name: str, g: dict[str, Any]) -> None:
        missing = g["missing_stations"]
        more = f" and {len(missing) - most} more" if len(missing) > most else ""
        out.append(f"{name}: {g['photographed']} of {g['planned']} stations photographed ({g['photos']} photos kept, "
                   f"{len(g['repeated_stations'])} station(s) photographed again: the nearest photo kept), {len(missing)} "
                   "missing" + (f": {', '.join(missing[:most])}{more}" if missing else ""))
        out.extend(f"  {x['status'].upper():>5} {x['rule']}: measured {x['measured']}; required {x['required']}"
                   for x in g["rules_on_flown_data"])

    for g in report["sorties"]:
        group(f"sortie {g['sortie']} (record {', '.join(map(str, g['records']))})", g)
    day = report["day"]
    group(f"the day ({len(report['records'])} records)", day)
    cov = day["coverage"]
    out.append(f"flown coverage of the day: at least {cov['min_images_in_area']} photos on every {cov['cell_m']:.1f} m cell "
               f"of the area, {100 * cov['uncovered_share']:.2f} % uncovered (coverage.tif)")
    return out


def _echo(report: dict[str, Any]) -> None:
    read = report["read"]
    if "photos" in report:
        _echo_photos(report["photos"])
    else:
        click.echo(f"{report['events']} camera events ({report['source']}); {read['skipped_bytes']} bytes skipped in "
                   f"{read.get('skipped_places', len(read['skipped']))} place(s), {read.get('dropped_events', 0)} event(s) "
                   "dropped")
    from aerosurvey.flight.modes import modes_text

    click.echo(modes_text(report["modes"]))
    img = report.get("images")
    if img is not None:
        off = img["clock_offset_s"]
        click.echo(f"images: {img['files']} files matched by {img['method']}"
                   + (f" (camera clock {off:+.2f} s from GPS time)" if off is not None else "")
                   + f"; {len(img['unmatched_files'])} files and {len(img['unmatched_events'])} events unmatched")
    if "geotag" in report:
        _echo_geotag(report["geotag"])
    if "planned" in report:
        click.echo(f"{report['matched']} matched to {report['planned']} planned stations of {report['plan']['mission']!r}, "
                   f"{len(report['missed_stations'])} missed, {len(report['extra_triggers'])} extra, "
                   f"{len(report['far_triggers'])} farther than {report['tolerance_m']:.2f} m "
                   f"(max {report['max_distance_m']:.2f} m)")
        ex = report["extras"]
        if ex["count"]:
            click.echo(f"{ex['count']} extra photo(s) on no planned line ({ex['on_ground']} on the ground): in the flown "
                       "coverage, in no run (log_report.json's extras)")
        hz = report["heights"]
        if hz["source"] == "dem":
            span = f"{hz['agl_min_m']:.1f}..{hz['agl_max_m']:.1f} m" if hz["agl_min_m"] is not None else "none known"
            click.echo(f"heights above ground from {hz['dem']}: {span}; {hz['outside_dem']} photo(s) off the DEM, "
                       "on nodata or not above it use their height above home")
            if "warning" in hz:
                click.echo(f"  warning: {hz['warning']}")
        else:
            click.echo("heights above home, flat ground assumed (--dem gives heights above the terrain)")
        rz = report["realized"]
        if rz["forward_overlap_min"] is not None:
            click.echo(f"realized: forward overlap >= {100 * rz['forward_overlap_min']:.1f} %, side overlap >= "
                       f"{100 * (rz['side_overlap_min'] or 0):.1f} %, GSD {rz['gsd_cm_min']:.2f}..{rz['gsd_cm_max']:.2f} cm")
        cov = report["coverage"]
        click.echo(f"flown coverage: at least {cov['min_images_in_area']} photos on every {cov['cell_m']:.1f} m cell of the "
                   f"area, {100 * cov['uncovered_share']:.2f} % uncovered (coverage.tif)")
    for r in report.get("rules_on_flown_data", []):
        click.echo(f"  {r['status'].upper():>5} {r['rule']}: measured {r['measured']}; required {r['required']}")


def _echo_photos(p: dict[str, Any]) -> None:
    skipped = ", ".join(f"{n} {why}" for why, n in sorted(p["skipped"].items()))
    click.echo(f"{p['used']} of {p['files']} photos are camera events ({', '.join(p['cameras'])}; {p['first_capture']} to "
               f"{p['last_capture']})" + (f"; skipped: {skipped} (log_report.json's read.skipped)" if skipped else ""))
    rtk = p["rtk"]
    if rtk["fixed_share"] is None:
        click.echo("RTK: no photo records an RTK solution")
        return
    names = [f"{x['file']} ({x['solution']} {x['flag']})" for x in rtk["not_fixed"]]
    more = f" and {len(names) - 10} more (log_report.json)" if len(names) > 10 else ""
    click.echo(f"RTK: {rtk['fixed']} fixed of {p['used'] - rtk['not recorded']} photos recording it "
               f"({100 * rtk['fixed_share']:.1f} %)" + (f"; not fixed: {', '.join(names[:10])}{more}" if names else ""))


def _echo_geotag(g: dict[str, Any]) -> None:
    where = "in place in" if g["in_place"] else "to"
    click.echo(f"geotagged: {g['written']} JPEG(s) written {where} {g['folder']}; {len(g['skipped'])} skipped, "
               f"{len(g['unmatched_not_copied'])} unmatched not {'tagged' if g['in_place'] else 'copied'}")
    for s in g["skipped"]:
        click.echo(f"  skipped {s['file']}: {s['reason']}")
    for n in g["notes"]:
        click.echo(f"  note {n['file']}: {n['note']}")
    names = g["unmatched_not_copied"]
    if names:
        more = f" and {len(names) - 10} more (log_report.json)" if len(names) > 10 else ""
        click.echo(f"  unmatched: {', '.join(names[:10])}{more}")


@log.command("gcp-predict")
@click.argument("ingest_dir", type=click.Path(file_okay=False, exists=True, path_type=Path))
@click.option("--plan", "plan_dir", required=True, type=click.Path(file_okay=False, exists=True, path_type=Path),
              help="The plan folder (manifest.json: camera and CRS).")
@click.option("--points", "points_path", type=click.Path(dir_okay=False, exists=True, path_type=Path), default=None,
              help="control_points.geojson of `aerosurvey gcp` (default: the one in the plan folder).")
@click.option("--dem", "dem_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="DEM GeoTIFF (orthometric heights) for the points' ground heights (default: flat ground at home).")
@click.option("-o", "--output", "out", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="The predictions CSV to write (gcp, image, col, row).")
def gcp_predict(ingest_dir: Path, plan_dir: Path, points_path: Path | None, dem_path: Path | None, out: Path) -> None:
    """Predict where each control point appears in the flown images (for a marking tool)."""
    import numpy as np

    from aerosurvey.errors import InputError
    from aerosurvey.fileio import atomic_write_text
    from aerosurvey.flight.handoff import GroundPoint, predict_marks, predictions_csv, read_geo_txt
    from aerosurvey.flight.records import read_events_csv
    from aerosurvey.rules.cp_files import read_layout
    from aerosurvey.rules.footprints import ViewCamera
    from aerosurvey.rules.planview import PlanView

    geo = ingest_dir / "geo.txt"
    if not geo.exists():
        raise InputError(f"{ingest_dir}: no geo.txt; run `aerosurvey log ingest --images ...` into it first")
    poses = read_geo_txt(geo.read_text(encoding="utf-8"), str(geo))
    view = PlanView.from_outdir(plan_dir, "--plan")
    src = points_path or plan_dir / "control_points.geojson"
    if not src.exists():
        raise InputError(f"{src}: no control points; run `aerosurvey gcp {plan_dir}` or give --points")
    pts = read_layout(src.read_text(encoding="utf-8"), view, str(src))
    x, y = np.array([p.x for p in pts], float), np.array([p.y for p in pts], float)
    if dem_path is not None:
        from aerosurvey.flight.coverage import DemGround

        with DemGround(dem_path, view.crs) as dem:
            z = np.asarray(dem(x, y), float)
        if not np.isfinite(z).all():
            bad = [p.id for p, v in zip(pts, z) if not np.isfinite(v)]
            raise InputError(f"--dem {dem_path}: no ground height under {', '.join(bad[:5])} (off the DEM or nodata)")
    else:
        ev = read_events_csv(ingest_dir / "events.csv")
        home = ev.alt_m - ev.rel_alt_m
        if not np.isfinite(home).any():
            raise InputError(f"{ingest_dir / 'events.csv'}: no altitude above home is logged; give --dem")
        z = np.full(len(pts), float(np.nanmedian(home)))
    grid_scale = float(view.manifest.get("derived", {}).get("grid_scale", 1.0))
    marks = predict_marks(poses, [GroundPoint(p.id, p.x, p.y, float(h)) for p, h in zip(pts, z)],
                          ViewCamera.of(view).optics, view.crs, grid_scale)
    atomic_write_text(out, predictions_csv(marks))
    seen = {m.gcp for m in marks}
    click.echo(f"{len(marks)} predicted marks of {len(seen)} of {len(pts)} points in {len(poses)} images; wrote {out}")
    unseen = [p.id for p in pts if p.id not in seen]
    if unseen:
        click.echo(f"  seen by no image: {', '.join(unseen)}")


@log.command("gcp-list")
@click.argument("marks_path", type=click.Path(dir_okay=False, exists=True, path_type=Path))
@click.option("--surveyed", "surveyed_path", required=True, type=click.Path(dir_okay=False, exists=True, path_type=Path),
              help="CSV of the GCPs' surveyed coordinates: id, easting, northing, elevation, crs.")
@click.option("--images", "images_dir", type=click.Path(file_okay=False, exists=True, path_type=Path), default=None,
              help="The images folder ODM will read: every marked image must be in it.")
@click.option("-o", "--output", "out", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="The gcp_list.txt to write.")
def gcp_list(marks_path: Path, surveyed_path: Path, images_dir: Path | None, out: Path) -> None:
    """OpenDroneMap's gcp_list.txt from a marking tool's CSV (gcp id, image, pixel x, pixel y)."""
    from aerosurvey.fileio import atomic_write_text
    from aerosurvey.flight.handoff import odm_gcp_list, read_marks, read_surveyed
    from aerosurvey.flight.images import list_images

    marks = read_marks(marks_path.read_text(encoding="utf-8-sig"), marks_path.name)
    crs, surveyed = read_surveyed(surveyed_path)
    images = [p.name for p in list_images(images_dir)] if images_dir is not None else None
    atomic_write_text(out, odm_gcp_list(marks, surveyed, crs, marks_path.name, images))
    click.echo(f"{len(marks)} marks of {len({m.gcp for m in marks})} GCPs in {len({m.image for m in marks})} images; wrote {out}")
