"""Reproducibility QA speed and memory against a plain numpy reference pass (same run).

    python benchmarks/repro_bench.py --size 4096          # two 4096 x 4096 RGB rasters
    python benchmarks/repro_bench.py --size 20000 --block 2048

The reference pass reads both rasters (all bands) block by block and computes one box
filter: a plain numpy pass over the same data. Our passes compute the layer with the
per-pixel statistic (the default, the source study's) and with the windowed one, and
write the COG. Each runs in its own process, so its peak memory (max RSS) is its own.
Prints Mpx/s, the time ratio and the memory ratio against the reference, same run.
Goals (issue 15): time within 4x and memory within 2x of the reference.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import rasterio
from rasterio.transform import from_origin
from rasterio.windows import Window
from scipy import ndimage


def make(path: Path, size: int, seed: int, block: int) -> None:
    prof = dict(driver="GTiff", width=size, height=size, count=3, dtype="uint8", crs="EPSG:32633",
                transform=from_origin(500000, 5470000, 0.05, 0.05), tiled=True, blockxsize=512, blockysize=512)
    rng = np.random.default_rng(seed)
    with rasterio.open(path, "w", **prof) as ds:
        for r in range(0, size, block):
            h = min(block, size - r)
            ds.write(rng.integers(0, 256, (3, h, size), dtype=np.uint8), window=Window(0, r, size, h))


def reference(paths: list[str], block: int, window: int) -> None:
    for p in paths:
        with rasterio.open(p) as ds:
            for r in range(0, ds.height, block):
                for c in range(0, ds.width, block):
                    a = ds.read(window=Window(c, r, min(block, ds.width - c), min(block, ds.height - r))).astype(np.float64)
                    ndimage.uniform_filter(a[0], size=window)


def ours(paths: list[str], block: int, window: int, out: str, statistic: str) -> None:
    from aerosurvey.qa import reproducibility as rp

    rp.run([Path(p) for p in paths], Path(out), rp.Settings(window=window, block=block, statistic=statistic))


def child(kind: str, paths: list[str], block: int, window: int, out: str) -> None:
    t = time.perf_counter()
    if kind == "reference":
        reference(paths, block, window)
    else:
        ours(paths, block, window, out, kind)
    dt = time.perf_counter() - t
    print(json.dumps({"seconds": dt, "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=4096)
    ap.add_argument("--block", type=int, default=1024)
    ap.add_argument("--window", type=int, default=5)
    ap.add_argument("--child", choices=["reference", "pixel", "window"])
    ap.add_argument("paths", nargs="*")
    ap.add_argument("--out")
    a = ap.parse_args()
    if a.child:
        child(a.child, a.paths, a.block, a.window, a.out)
        return
    with tempfile.TemporaryDirectory() as td:
        tmp = Path(td)
        paths = [str(tmp / "a.tif"), str(tmp / "b.tif")]
        t = time.perf_counter()
        make(Path(paths[0]), a.size, 1, a.block)
        make(Path(paths[1]), a.size, 2, a.block)
        print(f"generated two {a.size} x {a.size} x 3 rasters in {time.perf_counter() - t:.1f} s")
        res = {}
        for kind in ("reference", "pixel", "window"):
            out = tmp / "out"
            out.mkdir(exist_ok=True)
            p = subprocess.run([sys.executable, __file__, "--child", kind, "--block", str(a.block), "--window",
                                str(a.window), "--out", str(out), *paths], capture_output=True, text=True, check=True)
            res[kind] = json.loads(p.stdout.strip().splitlines()[-1])
        mpx = a.size * a.size / 1e6
        ref = res["reference"]
        for kind, r in res.items():
            print(f"{kind:>9}: {r['seconds']:.2f} s, {mpx / r['seconds']:.2f} Mpx/s, peak RSS {r['peak_rss_mb']:.0f} MB"
                  + ("" if kind == "reference" else f"; time x{r['seconds'] / ref['seconds']:.2f}, memory "
                                                     f"x{r['peak_rss_mb'] / ref['peak_rss_mb']:.2f} of the reference"))


if __name__ == "__main__":
    main()
