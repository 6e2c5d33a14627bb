"""What the rules see of a plan: the manifest and the plan's GeoJSON, nothing else.

The rule engine reads the same files a later user has (manifest.json, plan.geojson), so
a check of an output folder and the check `plan` runs in memory give the same results.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyproj
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.area import transformer
from aerosurvey.errors import InputError


@dataclass(frozen=True)
class PlanView:
    manifest: dict[str, Any]
    crs: str
    area: BaseGeometry  # planning CRS
    exclusions: BaseGeometry | None
    station_ids: list[str]
    run_ids: list[str]  # the run (line id) of each station, in flight order
    x: np.ndarray
    y: np.ndarray
    agl: np.ndarray
    heading_deg: np.ndarray
    to_plan: pyproj.Transformer
    to_wgs84: pyproj.Transformer

    @property
    def camera(self) -> dict[str, Any]:
        return self.manifest["camera"]

    @property
    def area_ha(self) -> float:
        return float(self.area.area / 1e4)

    @classmethod
    def from_documents(cls, manifest: dict[str, Any], features: dict[str, Any], where: str) -> PlanView:
        try:
            if manifest.get("schema") != "aerosurvey-manifest":
                raise InputError(f"{where}: not an aerosurvey manifest (schema = {manifest.get('schema')!r})")
            if manifest.get("schema_version") != 1:
                raise InputError(f"{where}: manifest schema_version = {manifest.get('schema_version')!r}; this aerosurvey reads version 1")
            crs = manifest["crs"]["planning"]
            stations = manifest["stations"]
        except (KeyError, TypeError) as exc:
            raise InputError(f"{where}: manifest lacks {exc}") from None
        try:
            to_plan, to_wgs84 = transformer("EPSG:4326", crs), transformer(crs, "EPSG:4326")
        except pyproj.exceptions.CRSError:
            raise InputError(f"{where}: manifest CRS {crs!r} is not a CRS pyproj knows") from None

        def proj(g: BaseGeometry) -> BaseGeometry:
            return shapely.transform(g, lambda xy: np.column_stack(to_plan.transform(xy[:, 0], xy[:, 1])))

        areas, zones = [], []
        for f in features.get("features", []):
            role = f.get("properties", {}).get("role")
            if role in ("area", "exclusion"):
                g = proj(shapely.geometry.shape(f["geometry"]))
                (areas if role == "area" else zones).append(g)
        if not areas:
            raise InputError(f"{where}: plan.geojson has no feature with role 'area'")
        return cls(
            manifest=manifest, crs=crs, area=shapely.union_all(areas),
            exclusions=shapely.union_all(zones) if zones else None,
            station_ids=[s["id"] for s in stations], run_ids=[s["line"] for s in stations],
            x=np.asarray([s["x"] for s in stations], float), y=np.asarray([s["y"] for s in stations], float),
            agl=np.asarray([s["agl_m"] for s in stations], float),
            heading_deg=np.asarray([s["heading_deg"] for s in stations], float),
            to_plan=to_plan, to_wgs84=to_wgs84,
        )

    @classmethod
    def from_outdir(cls, outdir: Path) -> PlanView:
        m, g = outdir / "manifest.json", outdir / "plan.geojson"
        for p in (m, g):
            if not p.exists():
                raise InputError(f"{outdir}: {p.name} is missing; give a folder written by `aerosurvey plan`")
        try:
            return cls.from_documents(json.loads(m.read_text()), json.loads(g.read_text()), str(outdir))
        except json.JSONDecodeError as exc:
            raise InputError(f"{outdir}: {exc.doc[:0]}a file is not valid JSON: {exc}") from None
