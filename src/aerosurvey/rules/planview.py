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

from aerosurvey import manifest as mf
from aerosurvey.area import transformer
from aerosurvey.errors import InputError
from aerosurvey.reproject import planar


@dataclass(frozen=True, eq=False)
class PlanView:
    """A plan as the rules read it, from its manifest and plan.geojson: the area and zones in the planning CRS,
    and each station's position, height above ground, heading and camera attitude. Compared by identity: it holds arrays."""

    manifest: dict[str, Any]
    crs: str
    area: BaseGeometry  # planning CRS
    exclusions: BaseGeometry | None
    station_ids: list[str]
    run_ids: list[str | None]  # the run (line id) of each station, in flight order (None: a flown photo on no planned line)
    x: np.ndarray
    y: np.ndarray
    agl: np.ndarray
    heading_deg: np.ndarray
    pitch_deg: np.ndarray  # the camera's (−90 straight down)
    camera_yaw_deg: np.ndarray  # the bearing the camera looks to
    to_plan: pyproj.Transformer
    to_wgs84: pyproj.Transformer
    document: mf.Manifest  # the typed manifest; `manifest` is its JSON data, which the checks read

    @property
    def camera(self) -> dict[str, Any]:
        camera: dict[str, Any] = self.manifest["camera"]
        return camera

    def nose_deg(self) -> np.ndarray:
        """The vehicle's planned yaw at each station, a grid bearing: along the track, or the plan's
        one fixed yaw (the manifest's `derived.fixed_yaw_deg`, a true bearing) turned into the grid there."""
        fixed = self.manifest.get("derived", {}).get("fixed_yaw_deg")
        if fixed is None:
            return np.asarray(self.heading_deg, float)
        return planar(self.crs).grid_bearing(np.full(len(self.x), float(fixed)), self.x, self.y)

    @property
    def area_ha(self) -> float:
        return float(self.area.area / 1e4)

    @classmethod
    def from_documents(cls, manifest: dict[str, Any], features: dict[str, Any], where: str, *, check: bool = True) -> PlanView:
        """From the manifest as JSON data (checked against its schema unless `check` is off:
        see `manifest.from_data`) and the plan's GeoJSON."""
        return cls.from_manifest(mf.from_data(manifest, where, check=check), features, where)

    @classmethod
    def from_manifest(cls, doc: mf.Manifest, features: dict[str, Any], where: str) -> PlanView:
        crs = doc.crs
        try:
            to_plan, to_wgs84 = transformer("EPSG:4326", crs), transformer(crs, "EPSG:4326")
        except pyproj.exceptions.CRSError:
            raise InputError(f"{where}: manifest CRS {crs!r} is not a CRS pyproj knows") from None

        def proj(g: BaseGeometry) -> BaseGeometry:
            return shapely.transform(g, lambda xy: np.column_stack(to_plan.transform(xy[:, 0], xy[:, 1])))

        areas: list[BaseGeometry] = []
        zones: list[BaseGeometry] = []
        for f in features.get("features", []):
            role = f.get("properties", {}).get("role")
            if role in ("area", "exclusion"):
                g = proj(shapely.geometry.shape(f["geometry"]))
                (areas if role == "area" else zones).append(g)
        if not areas:
            raise InputError(f"{where}: plan.geojson has no feature with role 'area'")
        st = doc.stations
        return cls(
            manifest=dict(doc.raw), crs=crs, area=shapely.union_all(areas),
            exclusions=shapely.union_all(zones) if zones else None,
            station_ids=list(st.ids), run_ids=list(st.run), x=np.array(st.x), y=np.array(st.y), agl=np.array(st.agl_m),
            heading_deg=np.array(st.heading_deg), pitch_deg=np.array(st.pitch_deg), camera_yaw_deg=np.array(st.camera_yaw_deg),
            to_plan=to_plan, to_wgs84=to_wgs84, document=doc,
        )

    @classmethod
    def from_outdir(cls, outdir: Path, option: str = "plan folder") -> PlanView:
        """From a folder written by `aerosurvey plan`; `option` names it in errors (e.g. --plan). The area and zones
        come from its plan.geojson, or, in a campaign's block folder planned without it, from outline.geojson
        (plan.geojson's area and zone features, which every block folder holds whatever `--outputs` chose)."""
        from aerosurvey.campaign.job import OUTLINE_FILE

        doc = mf.read_manifest(outdir, option)
        g = next((outdir / n for n in ("plan.geojson", OUTLINE_FILE) if (outdir / n).is_file()), None)
        if g is None:
            raise InputError(f"{outdir}: plan.geojson is missing; give a folder written by `aerosurvey plan`")
        try:
            features = json.loads(g.read_text(encoding="utf-8"))
        except (ValueError, UnicodeDecodeError) as exc:
            raise InputError(f"{g}: not valid JSON: {exc}") from None
        return cls.from_manifest(doc, features, str(outdir))
