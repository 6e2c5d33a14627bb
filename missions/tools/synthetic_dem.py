"""Write a synthetic, smooth, hilly DEM GeoTIFF (deterministic) for examples and benchmarks.

    python missions/tools/synthetic_dem.py OUT.tif --epsg 32632 --west 480000 --north 5633000 \
        --size 1500 1500 --res 5 --base 300 --relief 60
"""

from __future__ import annotations

import argparse

import numpy as np
import rasterio
from rasterio.transform import from_origin


def hills(width: int, height: int, res: float, base: float, relief: float, seed: int = 7) -> np.ndarray:
    """A sum of a few broad Gaussian hills and a gentle slope, float32 metres."""
    rng = np.random.default_rng(seed)
    xs = (np.arange(width) + 0.5) * res
    ys = (np.arange(height) + 0.5) * res
    gx, gy = np.meshgrid(xs, ys)
    z = np.full((height, width), base, np.float64)
    z += relief * 0.3 * gx / max(xs[-1], 1.0)
    for _ in range(6):
        cx, cy = rng.uniform(0, xs[-1]), rng.uniform(0, ys[-1])
        r = rng.uniform(0.15, 0.4) * max(xs[-1], ys[-1])
        z += relief * rng.uniform(0.3, 0.7) * np.exp(-((gx - cx) ** 2 + (gy - cy) ** 2) / (2 * r * r))
    return z.astype(np.float32)


def write_dem(path: str, epsg: int, west: float, north: float, width: int, height: int, res: float,
              base: float, relief: float, block: int = 256) -> None:
    profile = dict(driver="GTiff", width=width, height=height, count=1, dtype="float32", crs=f"EPSG:{epsg}",
                   transform=from_origin(west, north, res, res), nodata=-9999.0, compress="deflate",
                   tiled=True, blockxsize=block, blockysize=block)
    with rasterio.open(path, "w", **profile) as ds:
        ds.write(hills(width, height, res, base, relief), 1)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out")
    ap.add_argument("--epsg", type=int, required=True)
    ap.add_argument("--west", type=float, required=True)
    ap.add_argument("--north", type=float, required=True)
    ap.add_argument("--size", type=int, nargs=2, default=(1000, 1000), metavar=("W", "H"))
    ap.add_argument("--res", type=float, default=5.0)
    ap.add_argument("--base", type=float, default=300.0)
    ap.add_argument("--relief", type=float, default=60.0)
    a = ap.parse_args()
    write_dem(a.out, a.epsg, a.west, a.north, a.size[0], a.size[1], a.res, a.base, a.relief)


if __name__ == "__main__":
    main()
