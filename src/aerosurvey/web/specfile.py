"""The page's spec as files: the TOML (validated as `aerosurvey plan` reads it, paths as a person
writes them) and the geometry drawn on the page, saved as GeoJSON files beside it."""

from __future__ import annotations

import copy
import glob
import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import shapely.geometry
from shapely.geometry.base import BaseGeometry

from aerosurvey.errors import AerosurveyError, InputError
from aerosurvey.fileio import atomic_write_text
from aerosurvey.inputs import load_geometry
from aerosurvey.web import service

if TYPE_CHECKING:
    from aerosurvey.spec import MissionSpec


def checked_spec(ws: service.Workspace, spec: dict[str, Any], zones: list[str] | None = None
                 ) -> tuple[MissionSpec, tuple[BaseGeometry, ...] | None]:
    """The spec after the same checks a plan makes (InputError naming the key when one fails), and its
    drawn zones read (None: none sent, the spec's zone files stand)."""
    from aerosurvey.spec import parse_spec

    ws.check_paths(spec)
    parsed = parse_spec(spec, base=ws.base, path=None)
    return parsed, (service.drawn_zones(zones) if zones is not None else None)


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
    if not spec_data:
        return None
    try:
        parsed, _ = checked_spec(ws, spec_data)
        return _preview(*load_geometry(parsed))
    except AerosurveyError:
        return None


def _preview(area: BaseGeometry, zones: tuple[BaseGeometry, ...]) -> dict[str, Any]:
    return {"area": service.exact_wkt(area), "zones": [service.exact_wkt(z) for z in zones]}


def with_geometry_files(spec: dict[str, Any], area: BaseGeometry | None, zones: tuple[BaseGeometry, ...] | None,
                        stem: str) -> tuple[dict[str, Any], dict[str, str]]:
    """The spec pointing at GeoJSON files of its drawn zones (`STEM.zones.geojson`) and, given its
    inline `area` (WGS84), of that (`STEM.area.geojson`, a corridor's `STEM.centreline.geojson`),
    and those files' texts by name."""
    out = copy.deepcopy(spec)
    table = out.setdefault("area", {})
    files: dict[str, str] = {}
    if area is not None:
        role = "centreline" if area.geom_type in ("LineString", "MultiLineString") else "area"
        for key in ("wkt", "wkt_crs"):
            table.pop(key, None)
        table["file"] = f"{stem}.{role}.geojson"
        files[table["file"]] = _feature_collection([area], role)
    if zones is not None:
        table.pop("exclusions", None)
        if zones:
            table["exclusions"] = [f"{stem}.zones.geojson"]
            files[table["exclusions"][0]] = _feature_collection(list(zones), "exclusion")
    return out, files


def save_with_geometry(ws: service.Workspace, spec_path: Path, spec: dict[str, Any],
                       zones: list[str] | None) -> tuple[dict[str, Any], list[str], dict[str, Any]]:
    """Write the spec over `spec_path`, with an inline (drawn or uploaded) area or corridor centreline
    and drawn zones as GeoJSON files beside it (`STEM.area.geojson` or `STEM.centreline.geojson`,
    `STEM.zones.geojson`), each written atomically, the spec last. Returns the spec as written (paths to
    those files), the files' names and the geometry's preview (as `geometry_preview` gives it).

    Everything is checked (the spec parsed and its geometry read once) before anything is written.
    """
    parsed, drawn = checked_spec(ws, spec, zones)
    area, spec_zones = load_geometry(parsed)
    out, files = with_geometry_files(spec, area if parsed.area.wkt is not None else None, drawn, spec_path.stem)
    preview = _preview(area, drawn if drawn is not None else spec_zones)
    for name, text in files.items():
        atomic_write_text(spec_path.parent / name, text)
    atomic_write_text(spec_path, service.spec_to_toml(relative_paths(ws, out)))
    return out, sorted(files), preview


def spec_download(ws: service.Workspace, spec: dict[str, Any], zones: list[str] | None, name: str) -> dict[str, str | bytes]:
    """The files of *Spec as TOML*: `NAME.toml` (an uploaded or drawn area inline), `NAME.zones.geojson`
    beside it when zones are drawn, and the area and zone files the spec names, under the paths it names
    them by (a Shapefile with its .shx, .dbf, .prj and .cpg): the download plans as the mission folder does.
    A DEM is named, not included (a GeoTIFF may be hundreds of MB). Checked as a plan checks them."""
    parsed, drawn = checked_spec(ws, spec, zones or None)
    out, files = with_geometry_files(spec, None, drawn, name)
    named = [p for p in (parsed.area.file, *(parsed.area.exclusions if drawn is None else ())) if p is not None]
    return {f"{name}.toml": service.spec_to_toml(relative_paths(ws, out)), **files, **_named_files(ws, named)}


def _named_files(ws: service.Workspace, paths: list[Path]) -> dict[str, bytes]:
    """The bytes of the geometry files a spec names, by their path relative to its folder."""
    found = [q for p in paths for q in _dataset(p)]
    size = sum(q.stat().st_size for q in found)
    if size > service.MAX_UNPACKED:
        raise InputError(f"spec download: the area and zone files the spec names hold {size / 1048576:.0f} MB, more than "
                         f"{service.MAX_UNPACKED // 1048576} MB; copy the mission's folder instead")
    return {_relative(ws, str(q)): q.read_bytes() for q in found}


def _dataset(path: Path) -> list[Path]:
    """A geometry file and, for a Shapefile, the files of its name that GDAL reads with it."""
    if path.suffix.lower() != ".shp":
        return [path]
    return sorted(q for q in path.parent.glob(f"{glob.escape(path.stem)}.*")
                  if q.suffix.lower() in service.SHAPEFILE_PARTS and q.is_file())


def _feature_collection(geoms: list[BaseGeometry], role: str) -> str:
    """GeoJSON in WGS84 whose numbers read back bit for bit (Python's float repr)."""
    feats = [{"type": "Feature", "properties": {"role": role}, "geometry": shapely.geometry.mapping(g)} for g in geoms]
    return json.dumps({"type": "FeatureCollection", "features": feats}, indent=1) + "\n"
