"""Re-fly mission for the gaps: where the flown coverage is below what the plan needs."""

from __future__ import annotations

import json
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pyproj
import rasterio
import rasterio.features
import shapely
import shapely.geometry

from aerosurvey.errors import InputError
from aerosurvey.fileio import atomic_write_bytes, atomic_write_text, staged_directory
from aerosurvey.flight import DAY_FILE, records
from aerosurvey.inputs import plan_from_files
from aerosurvey.manifest import Manifest, sha256_file
from aerosurvey.mission.formats import DJI_TEMPLATES
from aerosurvey.outputs import render_outputs
from aerosurvey.plan.planner import Plan
from aerosurvey.rules.planview import PlanView
from aerosurvey.spec import load_spec, parse_spec


def gap_area(coverage_tif: Path, need: int, area_plan: shapely.Geometry, min_area_m2: float) -> shapely.Geometry:
    """Polygons (planning CRS) of the area's cells seen by fewer than `need` photos."""
    with rasterio.open(coverage_tif) as ds:
        counts = ds.read(1)
        transform = ds.transform
    short = (counts < need).astype(np.uint8)
    polys = [shapely.geometry.shape(g) for g, v in rasterio.features.shapes(short, mask=short == 1, transform=transform) if v == 1]
    if not polys:
        return shapely.Polygon()
    gaps = shapely.intersection(shapely.union_all(polys), area_plan)
    parts = [p for p in shapely.get_parts(gaps) if p.area >= min_area_m2]
    return shapely.union_all(parts) if parts else shapely.Polygon()


def refly_spec(spec_path: Path, gaps_plan: shapely.Geometry, crs: str) -> dict[str, Any]:
    """The original spec with the gaps (in WGS84 WKT) as its area."""
    data = tomllib.loads(spec_path.read_text(encoding="utf-8"))
    t = pyproj.Transformer.from_crs(crs, "EPSG:4326", always_xy=True)
    gaps_ll = shapely.transform(gaps_plan, lambda xy: np.column_stack(t.transform(xy[:, 0], xy[:, 1])))
    area = dict(data.get("area", {}))
    area.pop("file", None)
    area["wkt"] = gaps_ll.wkt
    area["wkt_crs"] = "EPSG:4326"
    data["area"] = area
    base = spec_path.parent
    for key in ("exclusions",):
        if key in area:
            area[key] = [str((base / p).resolve()) for p in area[key]]
    if "terrain" in data and "dem" in data["terrain"]:
        data["terrain"]["dem"] = str((base / data["terrain"]["dem"]).resolve())
    data.setdefault("mission", {})["name"] = data.get("mission", {}).get("name", spec_path.stem) + "-refly"
    return data


@dataclass(frozen=True)
class Refly:
    """A re-fly over the gaps: the gaps, the photos each point needs, the new plan and its files."""

    gaps: shapely.Geometry  # planning CRS of the flown plan
    need: int
    plan: Plan | None  # the re-fly (None when there are no gaps)
    files: dict[str, str]  # file name -> text: every output of `plan` and gaps.geojson
    notes: tuple[str, ...]
    binary: dict[str, bytes] = field(default_factory=dict)  # file name -> bytes: a DJI camera's .kmz waylines


def check_report_of_plan(report: dict[str, Any], log_dir: Path, doc: Manifest) -> None:
    """A log folder's report must name the plan's mission (a coverage of another plan is refused)."""
    flown = (report.get("plan") or {}).get("mission")
    if flown is None:
        raise InputError(f"{str(log_dir)!r} was ingested without --plan: run `aerosurvey log ingest LOG --plan PLAN -o {log_dir}`")
    if flown != doc.mission.name:
        raise InputError(f"{str(log_dir)!r} is the coverage of mission {flown!r}, but --plan {doc.where!r} is mission "
                         f"{doc.mission.name!r}: give the plan the log was ingested against")


def read_log_of_plan(log_dir: Path, doc: Manifest) -> dict[str, Any]:
    """The log folder's report (log_report.json; a day of flights' day_report.json), refused unless
    it is a flight of the plan's mission."""
    if (log_dir / DAY_FILE).is_file():
        day = records.read_day(log_dir / DAY_FILE)
        check_report_of_plan(day, log_dir, doc)
        return day
    if not (log_dir / "log_report.json").is_file():
        raise InputError(f"{str(log_dir)!r} has no log_report.json: give the folder `aerosurvey log ingest LOG --plan PLAN` wrote")
    report = records.read_report(log_dir / "log_report.json")
    check_report_of_plan(report, log_dir, doc)
    return report


def plan_refly(log_dir: Path, view: PlanView, spec_path: Path, min_gap_m2: float, dji: str = DJI_TEMPLATES[0]) -> Refly:
    """Plan a re-fly over the cells of LOG_DIR/coverage.tif seen by too few photos, with the plan's own spec;
    every output `plan` writes for it (`dji`: the DJI .kmz files' template, as `plan --dji`)."""
    doc = view.document
    spec = load_spec(spec_path)
    if spec.name != doc.mission.name:
        raise InputError(f"--spec {str(spec_path)!r} is mission {spec.name!r}, but --plan {doc.where!r} is mission "
                         f"{doc.mission.name!r}: give the spec the plan was made from", key="--spec")
    notes = []
    planned = (doc.raw.get("inputs") or {}).get("spec") or {}
    if planned.get("sha256") and planned["sha256"] != sha256_file(spec_path):
        notes.append(f"--spec {str(spec_path)!r} has changed since the plan was made; the re-fly uses it as it is now")
    read_log_of_plan(log_dir, doc)
    cov = log_dir / "coverage.tif"
    if not cov.is_file():
        raise InputError(f"{log_dir}: coverage.tif is missing; run `aerosurvey log ingest LOG --plan PLAN -o {log_dir}` first")
    need = doc.derived.images_per_point
    gaps = gap_area(cov, need, view.area, min_gap_m2)
    if gaps.is_empty:
        return Refly(gaps, need, None, {}, tuple(notes))
    data = refly_spec(spec_path, gaps, view.crs)
    spec = parse_spec(data, base=spec_path.parent, path=None)
    plan = plan_from_files(spec)
    rendered = render_outputs(plan, spec, dji=dji)
    files = dict(rendered.files)
    files["gaps.geojson"] = json.dumps(gaps_layer(gaps, view, need)) + "\n"
    return Refly(gaps, need, plan, files, tuple(notes), dict(rendered.binary))


def gaps_layer(gaps: shapely.Geometry, view: PlanView, need: int) -> dict[str, Any]:
    """gaps.geojson: the gaps (planning CRS) in WGS84, with the photos each point needs and their area."""
    if gaps.is_empty:
        return {"type": "FeatureCollection", "features": []}
    ll = shapely.transform(gaps, lambda xy: np.column_stack(view.to_wgs84.transform(xy[:, 0], xy[:, 1])))
    return {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"role": "gap", "needed_images": need, "area_m2": round(float(shapely.area(gaps)), 1)},
         "geometry": shapely.geometry.mapping(ll)}]}


def write_refly(r: Refly, outdir: Path) -> None:
    """Every file of the re-fly into `outdir`, all or nothing."""
    with staged_directory(outdir) as stage:
        for name, text in r.files.items():
            atomic_write_text(stage / name, text)
        for name, data in r.binary.items():
            atomic_write_bytes(stage / name, data)
