"""The page's spec as files: the TOML (validated as `aerosurvey plan` reads it, paths as a person
writes them) and the geometry drawn on the page, saved as GeoJSON files beside it."""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import shapely.geometry
from shapely.geometry.base import BaseGeometry

from aerosurvey.errors import AerosurveyError
from aerosurvey.fileio import atomic_write_text
from aerosurvey.web import service


def validated_toml(ws: service.Workspace, spec: dict[str, Any], zones: list[str] | None = None) -> str:
    """The spec as TOML, after the same checks a plan makes (InputError naming the key when one fails)."""
    from aerosurvey.spec import parse_spec

    ws.check_paths(spec)
    parse_spec(spec, base=ws.base, path=None)
    if zones:
        service.drawn_zones(zones)  # checked, though a TOML alone cannot hold them
    return service.spec_to_toml(relative_paths(ws, spec))


def relative_paths(ws: service.Workspace, spec: dict[str, Any]) -> dict[str, Any]:
    """Paths inside the spec's folder are written relative to it, as a hand-written spec has them."""
    out = copy.deepcopy(spec)
    for table, key in service.PATH_KEYS:
        v = (out.get(table) or {}).get(key)
        if isinstance(v, str):
            out[table][key] = _relative(ws, v)
    ex = (out.get("area") or {}).get("exclusions")
    if isinstance(ex, list):
        out["area"]["exclusions"] = [_relative(ws, v) if isinstance(v, str) else v for v in ex]
    return out


def _relative(ws: service.Workspace, value: str) -> str:
    p = ws.resolve(value).resolve()
    try:
        return p.relative_to(ws.base.resolve()).as_posix()
    except ValueError:
        return str(p)


def geometry_preview(ws: service.Workspace, spec_data: dict[str, Any]) -> dict[str, Any] | None:
    """The spec's area and exclusion zones as exact WKT in WGS84, for the page to draw (and edit)
    before the first plan arrives; None when the spec cannot be read yet (its plan will say why)."""
    from aerosurvey.inputs import load_geometry
    from aerosurvey.spec import parse_spec

    if not spec_data:
        return None
    try:
        ws.check_paths(spec_data)
        area, zones = load_geometry(parse_spec(spec_data, base=ws.base, path=None))
    except AerosurveyError:
        return None
    return {"area": service.exact_wkt(area), "zones": [service.exact_wkt(z) for z in zones]}


def with_geometry_files(spec: dict[str, Any], zones: list[str] | None, stem: str,
                        area_too: bool) -> tuple[dict[str, Any], dict[str, str]]:
    """The spec pointing at GeoJSON files of its drawn zones (`STEM.zones.geojson`) and, with
    `area_too`, of its inline area (`STEM.area.geojson`), and those files' texts by name."""
    from aerosurvey.area import read_area

    out = copy.deepcopy(spec)
    area = out.setdefault("area", {})
    files: dict[str, str] = {}
    if area_too and isinstance(area.get("wkt"), str):
        geom = read_area(None, area.pop("wkt"), area.pop("wkt_crs", "EPSG:4326"), "area")
        area["file"] = f"{stem}.area.geojson"
        files[area["file"]] = _feature_collection([geom], "area")
    if zones is not None:
        area.pop("exclusions", None)
        if zones:
            area["exclusions"] = [f"{stem}.zones.geojson"]
            files[area["exclusions"][0]] = _feature_collection(list(service.drawn_zones(zones)), "exclusion")
    return out, files


def save_with_geometry(ws: service.Workspace, spec_path: Path, spec: dict[str, Any],
                       zones: list[str] | None) -> tuple[dict[str, Any], list[str]]:
    """Write the spec over `spec_path`, with an inline (drawn or uploaded) area and drawn zones as
    GeoJSON files beside it (`STEM.area.geojson`, `STEM.zones.geojson`), each written atomically,
    the spec last. Returns the spec as written (paths to those files) and the files' names.

    Everything is checked before anything is written.
    """
    validated_toml(ws, spec, zones)
    out, files = with_geometry_files(spec, zones, spec_path.stem, area_too=True)
    for name, text in files.items():
        atomic_write_text(spec_path.parent / name, text)
    atomic_write_text(spec_path, validated_toml(ws, out))
    return out, sorted(files)


def spec_download(ws: service.Workspace, spec: dict[str, Any], zones: list[str] | None, name: str) -> dict[str, str]:
    """The files of *Spec as TOML*: `NAME.toml` (the area inline), and `NAME.zones.geojson` beside it when
    zones are drawn. Checked as a plan checks them."""
    validated_toml(ws, spec, zones)
    out, files = with_geometry_files(spec, zones or None, name, area_too=False)
    return {f"{name}.toml": service.spec_to_toml(relative_paths(ws, out)), **files}


def _feature_collection(geoms: list[BaseGeometry], role: str) -> str:
    """GeoJSON in WGS84 whose numbers read back bit for bit (Python's float repr)."""
    feats = [{"type": "Feature", "properties": {"role": role}, "geometry": shapely.geometry.mapping(g)} for g in geoms]
    return json.dumps({"type": "FeatureCollection", "features": feats}, indent=1) + "\n"
