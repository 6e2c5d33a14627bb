"""`aerosurvey log ingest`: camera events of a flight log, matched to the planned stations."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import click
import numpy as np

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
@click.option("-o", "--output", "outdir", required=True, type=click.Path(file_okay=False, path_type=Path))
def ingest(flight_log: Path, plan_dir: Path | None, sortie: str | None, tolerance: float | None, images_dir: Path | None,
           accuracy_xy: float, accuracy_z: float, fixed_camera: bool, outdir: Path) -> None:
    """Extract camera events; with --plan, match them to the planned stations (events.csv, log_report.json)."""
    from aerosurvey.flight.events import match_to_stations, read_events

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
        from aerosurvey.flight.coverage import count_raster, flown_manifest
        from aerosurvey.rules.engine import Evidence, evaluate, layout_settings
        from aerosurvey.rules.planview import PlanView
        from aerosurvey.rules.profile import apply_overrides, select_profiles

        features = json.loads((plan_dir / "plan.geojson").read_text())
        flown = flown_manifest(manifest, ev, match, fixed_camera)
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
    w.writerow(["event", "time_s", "lat", "lon", "alt_m", "rel_alt_m", "roll", "pitch", "yaw", "station", "distance_m"])
    for i in range(len(ev)):
        st = match.station[i] if match else ""
        d = f"{match.distance_m[i]:.3f}" if match and st else ""
        w.writerow([i + 1, f"{ev.time_s[i]:.3f}", f"{ev.lat[i]:.8f}", f"{ev.lon[i]:.8f}", f"{ev.alt_m[i]:.2f}",
                    f"{ev.rel_alt_m[i]:.2f}", f"{ev.roll[i]:.2f}", f"{ev.pitch[i]:.2f}", f"{ev.yaw[i]:.2f}", st or "", d])
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
        atomic_write_text(stage / "log_report.json", json.dumps(report, indent=1) + "\n")
    click.echo(f"{len(ev)} camera events ({ev.source}); {info['skipped_bytes']} bytes skipped in {len(info['skipped'])} place(s)")
    if img is not None:
        click.echo(f"images: {len(img.files)} files matched by {img.method}"
                   + (f" (camera clock {img.offset_s:+.2f} s from GPS time)" if img.offset_s is not None else "")
                   + f"; {len(img.unmatched_files)} files and {len(img.unmatched_events)} events unmatched")
    if match is not None:
        click.echo(f"{report['matched']} matched to {report['planned']} planned stations, {len(match.missed)} missed, "
                   f"{len(match.extra)} extra, {len(match.far)} farther than {report['tolerance_m']:.2f} m "
                   f"(max {report['max_distance_m']:.2f} m)")
        rz = report["realized"]
        if rz["forward_overlap_min"] is not None:
            click.echo(f"realized: forward overlap >= {100 * rz['forward_overlap_min']:.1f} %, side overlap >= "
                       f"{100 * (rz['side_overlap_min'] or 0):.1f} %, GSD {rz['gsd_cm_min']:.2f}..{rz['gsd_cm_max']:.2f} cm")
        cov = report["coverage"]
        click.echo(f"flown coverage: at least {cov['min_images_in_area']} photos on every {cov['cell_m']:.1f} m cell of the "
                   f"area, {100 * cov['uncovered_share']:.2f} % uncovered (coverage.tif)")
    for r in flown_rules or []:
        click.echo(f"  {r['status'].upper():>5} {r['rule']}: measured {r['measured']}; required {r['required']}")
