"""The blocks file of a campaign: its one reader.

A GeoPackage or GeoJSON (any vector file GDAL reads) of polygons, one block a feature. A
feature's attributes may override keys of the campaign's spec template (docs/campaign.md):

    name                   the block's name (mission.name; default block-0001 … in feature order)
    gsd_cm                 targets.gsd_cm (the template's targets.height_m is then dropped)
    height_m               targets.height_m (the template's targets.gsd_cm is then dropped)
    heading                flight.heading in degrees (`campaign split` writes it: the lines along the cuts)
    launch_lon, launch_lat area.launch (both or neither)
    profiles               rules.profiles, comma-separated rule profile ids

An attribute left empty (null) keeps the template's value; other attributes are not read.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aerosurvey.errors import InputError

#: the attributes read, and the type each must have
ATTRIBUTES: dict[str, type] = {"name": str, "gsd_cm": float, "height_m": float, "heading": float,
                               "launch_lon": float, "launch_lat": float, "profiles": str}
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")


@dataclass(frozen=True)
class Block:
    """One feature of the blocks file: its name, its polygon as WKB (in the file's CRS) and the
    attributes that override the template, as (attribute, value) pairs in ATTRIBUTES' order."""

    name: str
    wkb: bytes
    overrides: tuple[tuple[str, Any], ...]


def read_blocks(path: Path) -> tuple[str, list[Block]]:
    """The CRS (as text pyproj reads) and the blocks of a blocks file; a one-line InputError for
    a file that cannot be read, a feature that is not a polygon, an attribute of the wrong type,
    a name used twice."""
    import pyogrio
    import shapely

    if not path.exists():
        raise InputError(f"blocks file {str(path)!r} does not exist")
    try:
        meta, _, wkb, values = pyogrio.raw.read(path, force_2d=True)
    except Exception as exc:  # GDAL's error types vary between versions
        raise InputError(f"blocks file {str(path)!r} cannot be read as a vector file: {exc}") from None
    if wkb is None or len(wkb) == 0:
        raise InputError(f"blocks file {str(path)!r} holds no feature: give one polygon per block")
    crs = meta.get("crs") or "EPSG:4326"
    columns = {str(f): v for f, v in zip(meta["fields"], values)}
    blocks: list[Block] = []
    seen: set[str] = set()
    for i, data in enumerate(wkb):
        where = f"blocks file {path.name!r}, feature {i + 1}"
        geom = shapely.from_wkb(data) if data is not None else None
        if geom is None or geom.is_empty or geom.geom_type not in ("Polygon", "MultiPolygon"):
            kind = "no geometry" if geom is None or geom.is_empty else f"a {geom.geom_type}"
            raise InputError(f"{where} has {kind}: each block is a polygon")
        found = {k: _value(columns[k][i], k, t, where) for k, t in ATTRIBUTES.items() if k in columns}
        name = found.pop("name", None) or f"block-{i + 1:04d}"
        if not _NAME.match(name):
            raise InputError(f"{where}: name = {name!r} is not allowed: 1 to 64 letters, digits, '_', '-' or '.', "
                             "starting with a letter or digit (it names the block's folder)")
        if name in seen:
            raise InputError(f"{where}: name = {name!r} is used by an earlier feature; each block needs its own name")
        seen.add(name)
        if ("launch_lon" in found) != ("launch_lat" in found):
            raise InputError(f"{where} ({name}): launch_lon and launch_lat are given together or not at all")
        overrides = tuple((k, found[k]) for k in ATTRIBUTES if k in found and found[k] is not None)
        blocks.append(Block(name, bytes(data), overrides))
    return crs, blocks


def _value(raw: Any, key: str, kind: type, where: str) -> Any:
    """An attribute's value as `kind`, None when it is empty."""
    raw = raw.item() if hasattr(raw, "item") else raw  # numpy's scalars as Python's
    if raw is None or (isinstance(raw, float) and math.isnan(raw)) or (isinstance(raw, str) and not raw.strip()):
        return None
    if kind is str:
        return str(raw).strip()
    if isinstance(raw, bool) or not isinstance(raw, (int, float)):
        raise InputError(f"{where}: {key} = {raw!r} is not allowed: a number")
    value = float(raw)
    if not math.isfinite(value):
        raise InputError(f"{where}: {key} = {raw!r} is not allowed: a finite number")
    return value


def write_blocks(path: Path, polygons_wgs84: list[Any], names: list[str], headings: list[float], cuts: list[str]) -> None:
    """Write a blocks file (GeoPackage for .gpkg, else GeoJSON) in WGS84 with the attributes name,
    heading and cut (`split.cut_area`'s path; not read back), whole: into a temporary file renamed into place."""
    import numpy as np
    import pyogrio
    import shapely

    from aerosurvey.fileio import staged_file

    driver = "GPKG" if path.suffix.lower() == ".gpkg" else "GeoJSON"
    if driver == "GeoJSON" and path.suffix.lower() not in (".geojson", ".json"):
        raise InputError(f"blocks file {str(path)!r}: give a .gpkg or .geojson name")
    with staged_file(path) as tmp:
        pyogrio.raw.write(tmp, np.array(shapely.to_wkb(polygons_wgs84), dtype=object),
                          [np.array(names, dtype=object), np.array(headings, dtype=float), np.array(cuts, dtype=object)],
                          ["name", "heading", "cut"],
                          layer="blocks", driver=driver, geometry_type="Polygon", crs="EPSG:4326")
