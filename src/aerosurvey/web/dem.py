"""A DEM uploaded from the page: checked as the loader opens a DEM (`inputs.open_dem`), stored in the mission's folder.

The page sets the stored file's path (relative to the spec's folder) as `terrain.dem` and plans again: the plan reads
it as `aerosurvey plan` reads the spec's DEM, and *Save* writes that path into the spec.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from aerosurvey.errors import InputError
from aerosurvey.fileio import staged_file

#: the folder, under the mission's folder, uploaded DEMs are stored in
DEM_FOLDER = "dem"
DEM_SUFFIXES = (".tif", ".tiff")
ALLOWED = "a GeoTIFF (.tif, .tiff) with a CRS"
#: the most cells an uploaded DEM may have: every block is read to check it (a 1 m DEM of 14 km × 14 km)
MAX_CELLS = 200_000_000


def store_uploaded_dem(base: Path, filename: str, data: bytes) -> dict[str, Any]:
    """Check the uploaded bytes as a GeoTIFF DEM and store them as `base/dem/NAME.tif` (atomically, replacing a DEM of
    that name); the path as the spec names it (relative to `base`) and what GDAL read. Blocking."""
    name = Path(filename).name or "dem.tif"
    suffix = Path(name).suffix.lower()
    if suffix not in DEM_SUFFIXES:
        raise InputError(f"DEM upload {name!r} is not allowed: {ALLOWED}", key="terrain.dem")
    stem = re.sub(r"[^A-Za-z0-9._-]", "_", Path(name).stem).lstrip(".") or "dem"
    rel = f"{DEM_FOLDER}/{stem}{suffix}"
    with staged_file(base / rel) as tmp:
        tmp.write_bytes(data)
        try:
            info = _checked(tmp, name)
        except InputError as exc:  # the message names the uploaded file, not the staging file
            raise InputError(f"DEM upload: {str(exc).replace(str(tmp), name).replace(tmp.name, name)}; allowed: {ALLOWED}",
                             key="terrain.dem") from None
    return {"path": rel, "bytes": len(data), **info}


def _checked(path: Path, name: str) -> dict[str, Any]:
    """What GDAL reads of the DEM: opened by the loader's `open_dem` (a raster with a CRS), a GeoTIFF of at most
    MAX_CELLS cells, every block of its first band readable (a file cut short or damaged fails there; one block held
    at a time)."""
    import rasterio.errors

    from aerosurvey.inputs import open_dem

    with open_dem(path, name) as ds:
        if ds.driver != "GTiff":
            raise InputError(f"terrain.dem: {name!r} is a {ds.driver} raster, not a GeoTIFF", key="terrain.dem")
        if ds.width * ds.height > MAX_CELLS:
            raise InputError(f"terrain.dem: {name!r} has {ds.width} × {ds.height} cells, the page takes up to {MAX_CELLS:,} "
                             "(cut it to the mission, e.g. gdal_translate -projwin)", key="terrain.dem")
        for _, window in ds.block_windows(1):
            try:
                ds.read(1, window=window)
            except rasterio.errors.RasterioError as exc:  # GDAL's own reason is the cause rasterio chains
                raise InputError(f"terrain.dem: {name!r} cannot be read at rows {window.row_off}.., columns "
                                 f"{window.col_off}..: {exc.__cause__ or exc}", key="terrain.dem") from None
        return {"crs": ds.crs.to_string(), "size": [ds.width, ds.height], "bounds": list(ds.bounds)}
