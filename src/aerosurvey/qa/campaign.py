"""Link an accuracy test to the plan it checks: `--campaign OUTDIR` (a folder written by
`aerosurvey plan`, with `aerosurvey gcp`'s control_points.csv when it was run).

Read here (the reader is the only part with I/O; docs/manifest.md is the contract):
manifest.json `derived.area_ha` (the project area, for the required number of check
points), `crs.planning`, `mission.name`, `estimates.photos`, `targets.gsd_cm`,
`derived.gsd_min_cm` / `gsd_max_cm`; plan.geojson's `area` polygon (longitude/latitude),
for the distribution check; control_points.csv (the GCPs and check points the layout
proposed), to tell which tested points were planned as control.
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pyproj
import shapely

from aerosurvey.errors import InputError
from aerosurvey.manifest import read_manifest
from aerosurvey.qa import validity
from aerosurvey.qa.accuracy_input import CheckPoints, geographic_offsets
from aerosurvey.rules.profile import select_profiles


@dataclass(frozen=True)
class Campaign:
    folder: str
    mission: str
    area_km2: float
    planning_crs: str
    photos: int | None
    gsd_target_cm: float | None
    gsd_range_cm: tuple[float | None, float | None]
    area_ring_lonlat: list[tuple[float, float]] | None  # outer ring of the project area
    proposed: dict[str, str] = field(default_factory=dict)  # id -> "control" / "check"
    profiles: tuple[str, ...] = ()  # the rule profiles the plan was checked against (manifest mission.profiles)

    def summary(self) -> dict[str, Any]:
        return {"folder": self.folder, "mission": self.mission, "area_km2": self.area_km2,
                "planning_crs": self.planning_crs, "photos": self.photos, "profiles": list(self.profiles),
                "gsd_target_cm": self.gsd_target_cm,
                "gsd_min_cm": self.gsd_range_cm[0], "gsd_max_cm": self.gsd_range_cm[1],
                "proposed_control": sorted(k for k, v in self.proposed.items() if v == "control"),
                "proposed_check": sorted(k for k, v in self.proposed.items() if v == "check")}


def read_campaign(folder: Path) -> Campaign:
    if not (folder / "manifest.json").is_file():
        raise InputError(f"--campaign {folder}: manifest.json is missing; give a folder written by `aerosurvey plan`")
    doc = read_manifest(folder, "--campaign")
    m = doc.raw
    area_km2 = float(doc.derived.area_ha or 0.0) / 100.0
    crs = doc.crs
    derived = m.get("derived") or {}
    ring = None
    g_path = folder / "plan.geojson"
    if g_path.is_file():
        try:
            feats = json.loads(g_path.read_text(encoding="utf-8")).get("features", [])
        except json.JSONDecodeError as exc:
            raise InputError(f"--campaign {folder}: plan.geojson is not JSON ({exc})") from None
        for f in feats:
            geom = f.get("geometry") or {}
            if (f.get("properties") or {}).get("role") == "area" and geom.get("type") in ("Polygon", "MultiPolygon"):
                coords = geom["coordinates"] if geom["type"] == "Polygon" else geom["coordinates"][0]
                ring = [(float(a), float(b)) for a, b, *_ in coords[0]]
                break
    proposed: dict[str, str] = {}
    c_path = folder / "control_points.csv"
    if c_path.is_file():
        for row in csv.DictReader(io.StringIO(c_path.read_text(encoding="utf-8"))):
            role = str(row.get("role", "")).strip().upper()
            if row.get("id") and role in ("GCP", "CP"):
                proposed[row["id"].strip()] = "control" if role == "GCP" else "check"
    photos = doc.estimates.get("photos")
    return Campaign(str(folder), doc.mission.name, area_km2, crs, None if photos is None else int(photos),
                    (m.get("targets") or {}).get("gsd_cm"), (derived.get("gsd_min_cm"), derived.get("gsd_max_cm")), ring,
                    proposed, doc.mission.profiles)


def area_bounds_local(c: Campaign, pts: CheckPoints) -> tuple[float, float, float, float] | None:
    """The project area's bounding box in the frame of `pts.local_xy()`, or None when the
    points' CRS is not stated (no safe way to put both in one frame) or has no positions."""
    if c.area_ring_lonlat is None or not pts.has_positions or pts.crs is None:
        return None
    lon = np.array([p[0] for p in c.area_ring_lonlat])
    lat = np.array([p[1] for p in c.area_ring_lonlat])
    if pts.geographic:
        lon0, lat0 = float(np.nanmean(pts.x)), float(np.nanmean(pts.y))
        ex, ny = geographic_offsets(lon, lat, np.full(len(lon), lon0), np.full(len(lat), lat0), pts.crs)
    else:
        t = pyproj.Transformer.from_crs("OGC:CRS84", pts.crs, always_xy=True)
        ax, ay = t.transform(lon, lat)
        ex, ny = np.asarray(ax) - np.nanmean(pts.x), np.asarray(ay) - np.nanmean(pts.y)
    if not (np.all(np.isfinite(ex)) and np.all(np.isfinite(ny))):
        return None
    return float(ex.min()), float(ny.min()), float(ex.max()), float(ny.max())


def campaign_roles(c: Campaign, pts: CheckPoints) -> tuple[tuple[str, ...], list[str], list[str]]:
    """Roles after the plan's proposal (a point the layout proposed as GCP is control),
    with the warnings and notes that comparing the two lists gives."""
    roles = list(pts.role)
    warnings: list[str] = []
    notes: list[str] = []
    as_gcp = sorted(i for k, i in enumerate(pts.ids) if c.proposed.get(i) == "control" and roles[k] == "check")
    for k, i in enumerate(pts.ids):
        if c.proposed.get(i) == "control":
            roles[k] = "control"
    if as_gcp:
        warnings.append(f"{len(as_gcp)} tested point(s) were proposed by the plan's layout as GCPs "
                        f"({', '.join(as_gcp[:10])}): treated as control, not as check points")
    if c.proposed:
        planned_cp = [i for i, r in c.proposed.items() if r == "check"]
        missing = sorted(set(planned_cp) - set(pts.ids))
        extra = sorted(set(pts.ids) - set(c.proposed))
        if missing:
            notes.append(f"{len(missing)} of the {len(planned_cp)} check points the plan proposed are not in the file: "
                         f"{', '.join(missing[:12])}{' ...' if len(missing) > 12 else ''}")
        if extra:
            notes.append(f"{len(extra)} tested point(s) are not in the plan's layout: "
                         f"{', '.join(extra[:12])}{' ...' if len(extra) > 12 else ''}")
    return tuple(roles), warnings, notes


def campaign_checks(c: Campaign, pts: CheckPoints, tested: CheckPoints | None,
                    v: validity.Validity) -> tuple[list[str], list[str]]:
    """The plan's own rules again at QA time: check points per area (rule `check_point_density`
    of the plan's profiles, e.g. the Czech 1 per 3 ha) as a condition of a valid test, and
    where the check points lie against the planned area (warnings)."""
    warnings: list[str] = []
    notes: list[str] = []
    n_check = tested.n if tested is not None else 0
    area_ha = c.area_km2 * 100
    for pid in c.profiles:
        try:
            profs = select_profiles([pid])
        except InputError as exc:
            notes.append(f"the plan's rule profile {pid!r} is not available here ({exc}); its rules were not re-checked")
            continue
        for prof in profs:
            for rule in prof.rules:
                if rule.check == "check_point_density":
                    per = float(rule.params["ha_per_point"])
                    need = math.ceil(area_ha / per - 1e-9)
                    validity.count(v, n_check, need, f"check points by the plan's rule {rule.id} (1 per {per:g} ha "
                                                     f"over {area_ha:.1f} ha)")
    if tested is None or c.area_ring_lonlat is None or not tested.has_positions or tested.crs is None:
        if c.area_ring_lonlat is not None and tested is not None:
            notes.append("the check points' CRS or positions are not given: their layout against the planned area "
                         "was not checked")
        return warnings, notes
    if tested.geographic:
        lon, lat = tested.x, tested.y
    else:
        t = pyproj.Transformer.from_crs(tested.crs, "OGC:CRS84", always_xy=True)
        lon, lat = (np.asarray(a) for a in t.transform(tested.x, tested.y))
    area = shapely.Polygon(c.area_ring_lonlat)
    inside = shapely.contains_xy(area, lon, lat)
    if not inside.all():
        out = [i for i, f in zip(tested.ids, inside) if not f]
        warnings.append(f"{len(out)} of {tested.n} check point(s) lie outside the planned area ({', '.join(out[:10])}"
                        f"{' ...' if len(out) > 10 else ''}): check points belong inside the perimeter, the GCP "
                        "envelope outside it")
    notes.append(f"{int(inside.sum())} of {tested.n} check points lie inside the planned area")
    return warnings, notes
