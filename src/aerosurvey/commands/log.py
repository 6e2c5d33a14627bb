"""`aerosurvey log ingest`: camera events of a flight log, matched to the planned stations."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import click

from aerosurvey.errors import InputError
from aerosurvey.fileio import atomic_write_text, staged_directory


@click.group()
def log() -> None:
    """Flight logs: camera events, their match to the plan."""


@log.command("ingest")
@click.argument("flight_log", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--plan", "plan_dir", type=click.Path(file_okay=False, exists=True, path_type=Path), default=None,
              help="The plan folder (manifest.json) the flight flew.")
@click.option("--sortie", default=None, help="Sortie id (S01 …) the log is of; default: the whole mission.")
@click.option("--tolerance", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Metres a trigger may lie from its station (default: a quarter of the photo base).")
@click.option("--images", "images_dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Folder of the flight's images: matched to events by EXIF time; writes geo.txt and image_reference.csv.")
@click.option("--accuracy-xy", type=float, default=2.0, show_default=True, help="Position accuracy for image_reference.csv (m).")
@click.option("--accuracy-z", type=float, default=4.0, show_default=True, help="Height accuracy for image_reference.csv (m).")
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
              help="Folder for events.csv, log_report.json and, with --plan, coverage.tif; with --images, geo.txt "
                   "and image_reference.csv.")
def ingest(flight_log: Path, plan_dir: Path | None, sortie: str | None, tolerance: float | None, images_dir: Path | None,
           accuracy_xy: float, accuracy_z: float, fixed_camera: bool, dem_path: Path | None, geotag_dir: Path | None,
           geotag_in_place: bool, outdir: Path) -> None:
    """Extract camera events; with --plan, match them to the planned stations (events.csv, log_report.json)."""
    import numpy as np  # not at the top: `aerosurvey --help` imports this module to list the command

    from aerosurvey.flight.events import match_to_stations, read_events

    geotag_dir = _geotag_destination(images_dir, geotag_dir, geotag_in_place)
    if dem_path is not None and plan_dir is None:
        raise InputError(f"--dem {str(dem_path)!r}: heights above the DEM are used for the flown footprints, "
                         "which need the plan: give --plan too", key="--dem")
    ev, info = read_events(flight_log)
    report: dict = {"log": flight_log.name, "events": len(ev), "source": ev.source, "read": info}
    stations, match = None, None
    if plan_dir is not None:
        manifest = json.loads((plan_dir / "manifest.json").read_text())
        stations = manifest["stations"]
        if sortie is not None:
            s = next((x for x in manifest.get("sorties", []) if x["id"] == sortie), None)
            if s is None:
                raise InputError(f"--sortie {sortie!r}: the plan has sorties {[x['id'] for x in manifest.get('sorties', [])]}")
            ids = [x["id"] for x in stations]
            stations = stations[ids.index(s["first_station"]): ids.index(s["last_station"]) + 1]
        tol = tolerance if tolerance is not None else manifest["derived"]["photo_base_m"] / 4
        match = match_to_stations(ev, stations, tol)
        report.update({"planned": len(stations), "matched": len(ev) - len(match.extra), "missed_stations": match.missed,
                       "extra_triggers": match.extra, "far_triggers": match.far, "tolerance_m": tol,
                       "max_distance_m": float(max((d for d in match.distance_m if d == d), default=0.0))})
    img = None
    if images_dir is not None:
        from aerosurvey.flight.images import list_images, match_images

        img = match_images(list_images(images_dir), ev)
        report["images"] = {"files": len(img.files), "method": img.method, "clock_offset_s": img.offset_s,
                            "unmatched_files": img.unmatched_files, "unmatched_events": img.unmatched_events}
    flown_rules = None
    coverage = None
    if match is not None:
        from aerosurvey.flight.coverage import DemGround, count_raster, flown_manifest, heights_summary
        from aerosurvey.rules.engine import Evidence, evaluate, layout_settings
        from aerosurvey.rules.planview import PlanView
        from aerosurvey.rules.profile import apply_overrides, select_profiles

        features = json.loads((plan_dir / "plan.geojson").read_text())
        dem = DemGround(dem_path, manifest["crs"]["planning"]) if dem_path is not None else None
        try:
            flown = flown_manifest(manifest, ev, match, fixed_camera, dem)
            report["heights"] = heights_summary(flown, ev, dem)
        finally:
            if dem is not None:
                dem.close()
        view = PlanView.from_documents(flown, features, str(plan_dir))
        from aerosurvey.rules import footprints as fpm

        fp = fpm.footprints(view)
        fwd = fpm.forward_overlaps(view, fp)
        side = fpm.side_overlaps(view, fp)
        cam = manifest["camera"]
        gsd = view.agl * cam["pixel_pitch_um"] / 1000.0 / cam["focal_mm"] * 100
        report["realized"] = {
            "forward_overlap_min": min((v for _, v in fwd), default=None),
            "side_overlap_min": min((v for _, _, v in side), default=None),
            "gsd_cm_min": float(np.nanmin(gsd)) if len(gsd) else None,
            "gsd_cm_max": float(np.nanmax(gsd)) if len(gsd) else None,
        }
        profile_ids = list(manifest["mission"].get("profiles", []))
        if profile_ids:
            profiles = apply_overrides(select_profiles(profile_ids), manifest.get("rule_overrides", {}))
            results = evaluate(profiles, Evidence(view, layout_settings(view, profiles)))
            flown_rules = [r.as_dict() for r in results]
            report["rules_on_flown_data"] = flown_rules
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["event", "time_s", "lat", "lon", "alt_m", "rel_alt_m", "roll", "pitch", "yaw", "station", "distance_m",
                "ground_m", "agl_m"])
    for i in range(len(ev)):
        st = match.station[i] if match else ""
        d = f"{match.distance_m[i]:.3f}" if match and st else ""
        # with --plan: the photo's height above ground and the ground under it (empty: flat ground, above home)
        g = flown["stations"][i]["ground_m"] if match is not None else None
        agl = f"{flown['stations'][i]['agl_m']:.2f}" if match is not None else ""
        w.writerow([i + 1, f"{ev.time_s[i]:.3f}", f"{ev.lat[i]:.8f}", f"{ev.lon[i]:.8f}", f"{ev.alt_m[i]:.2f}",
                    f"{ev.rel_alt_m[i]:.2f}", f"{ev.roll[i]:.2f}", f"{ev.pitch[i]:.2f}", f"{ev.yaw[i]:.2f}", st or "", d,
                    f"{g:.2f}" if g is not None else "", agl])
    with staged_directory(outdir) as stage:
        if match is not None:
            cell = max(manifest["derived"]["photo_base_m"] / 5, 0.5)
            coverage = count_raster(stage / "coverage.tif", view, cell)
            report["coverage"] = coverage
        atomic_write_text(stage / "events.csv", buf.getvalue())
        if img is not None:
            from aerosurvey.flight.images import geo_txt, reference_csv

            atomic_write_text(stage / "geo.txt", geo_txt(img, ev))
            atomic_write_text(stage / "image_reference.csv", reference_csv(img, ev, accuracy_xy, accuracy_z))
        if geotag_dir is not None:
            from aerosurvey.flight.images import geotag_images

            report["geotag"] = {**geotag_images(img, ev, geotag_dir), "in_place": geotag_in_place}
        atomic_write_text(stage / "log_report.json", json.dumps(report, indent=1) + "\n")
    click.echo(f"{len(ev)} camera events ({ev.source}); {info['skipped_bytes']} bytes skipped in {len(info['skipped'])} place(s)")
    if img is not None:
        click.echo(f"images: {len(img.files)} files matched by {img.method}"
                   + (f" (camera clock {img.offset_s:+.2f} s from GPS time)" if img.offset_s is not None else "")
                   + f"; {len(img.unmatched_files)} files and {len(img.unmatched_events)} events unmatched")
    if geotag_dir is not None:
        _echo_geotag(report["geotag"])
    if match is not None:
        click.echo(f"{report['matched']} matched to {report['planned']} planned stations, {len(match.missed)} missed, "
                   f"{len(match.extra)} extra, {len(match.far)} farther than {report['tolerance_m']:.2f} m "
                   f"(max {report['max_distance_m']:.2f} m)")
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
    for r in flown_rules or []:
        click.echo(f"  {r['status'].upper():>5} {r['rule']}: measured {r['measured']}; required {r['required']}")


def _geotag_destination(images_dir: Path | None, geotag_dir: Path | None, in_place: bool) -> Path | None:
    """Where geotagged JPEGs go; the originals' folder only when --geotag-in-place says so."""
    if geotag_dir is None and not in_place:
        return None
    option = "--geotag-in-place" if geotag_dir is None else f"--geotag-copies {str(geotag_dir)!r}"
    if images_dir is None:
        raise InputError(f"{option}: geotagging needs the images; give --images too", key="--images")
    if in_place:
        if geotag_dir is not None and not _same_folder(geotag_dir, images_dir):
            raise InputError(f"--geotag-copies {str(geotag_dir)!r} with --geotag-in-place: in place means into the "
                             f"--images folder {str(images_dir)!r}; give one of the two options", key="--geotag-copies")
        return images_dir
    if _same_folder(geotag_dir, images_dir):
        raise InputError(f"--geotag-copies {str(geotag_dir)!r} is the --images folder {str(images_dir)!r}: the originals are never "
                         "overwritten by copies; give another folder, or --geotag-in-place to tag the originals "
                         "themselves", key="--geotag-copies")
    return geotag_dir


def _same_folder(a: Path, b: Path) -> bool:
    if a.exists() and b.exists():
        return a.samefile(b)
    return a.resolve() == b.resolve()


def _echo_geotag(g: dict) -> None:
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
