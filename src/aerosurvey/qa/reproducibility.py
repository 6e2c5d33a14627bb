"""Reproducibility of orthomosaics processed several times: streamed by blocks.

Every pair of inputs is compared with repro_core's correlation (per pixel across the bands
by default, the source study's statistic; a moving window as an option); the binary layers
are summed into the reproducibility layer (0 … x(x−1)/2, 255 = not judged), written as a
Cloud-Optimised GeoTIFF. Inputs are read window by window (with a halo of w//2 pixels, or
the crop margin, around each block for the window statistic), so memory follows the block
size, not the raster. Inputs on different grids (CRS, transform or size) are refused unless
`resample` is asked; then they are warped onto the first input's grid (bilinear) with
rasterio's WarpedVRT, and pixels outside an input's footprint are invalid, so only the
common valid footprint is judged. Blocks run on threads, or on a Dask cluster when asked;
either way the result is identical.
"""

from __future__ import annotations

import json
import math
import socket
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import rasterio
import rasterio.features
import rasterio.shutil
from rasterio.enums import Resampling
from rasterio.vrt import WarpedVRT
from rasterio.windows import Window
from scipy import ndimage

from aerosurvey.errors import InputError
from aerosurvey.qa.repro_core import NODATA, RGB_BANDS, STATISTICS, chance_level, pairs, reproducible, statistic_values

DASK_CONNECT_TIMEOUT_S = 5.0


@dataclass(frozen=True)
class Grid:
    crs: Any
    transform: Any
    width: int
    height: int
    bands: int


@dataclass(frozen=True)
class Settings:
    window: int = 5
    threshold: float = 0.95
    crop: str = "none"  # none, auto, or a polygon file
    crop_margin_px: int = 50
    block: int = 1024
    crop_geoms: tuple[Any, ...] = field(default=())  # polygons in the grid's CRS (for a crop file)
    statistic: str = "pixel"  # pixel (the source study's) or window
    resample: bool = False  # warp inputs on other grids onto the first input's

    @property
    def halo(self) -> int:
        w = self.window // 2 if self.statistic == "window" else 0
        return max(w, self.crop_margin_px if self.crop == "auto" else 0)


#: The window of `--statistic window` when `--window` is not given.
DEFAULT_WINDOW = 5


def validate_settings(window: int | None, threshold: float, statistic: str = "pixel") -> int:
    """Check the options and return the window size (the default when the window statistic is asked
    without one). `--window` with the per-pixel statistic is an error: it has no window."""
    if statistic not in STATISTICS:
        raise InputError(f"--statistic = {statistic!r} is not allowed: one of {', '.join(STATISTICS)}")
    if window is not None and statistic == "pixel":
        raise InputError(f"--window = {window} is not allowed with --statistic pixel (the per-pixel correlation "
                         "across the bands has no window); give --statistic window to use one")
    window = DEFAULT_WINDOW if window is None else window
    if window < 3 or window % 2 == 0:
        raise InputError(f"--window = {window} is not allowed: an odd number of pixels, 3 or more")
    if not 0 < threshold < 1:
        raise InputError(f"--threshold = {threshold} is not allowed: a correlation in (0, 1) (a pixel is "
                         "reproducible when r > threshold)")
    return window


def inspect(paths: list[Path], resample: bool = False) -> Grid:
    """Check the inputs and return the first input's grid (the one results are on)."""
    if len(paths) < 2:
        raise InputError(f"give at least two orthomosaics of the same area, got {len(paths)}")
    infos = []
    for p in paths:
        if not p.exists():
            raise InputError(f"{p}: does not exist")
        try:
            with rasterio.open(p) as ds:
                infos.append((p, ds.crs, ds.transform, ds.width, ds.height, ds.count))
        except rasterio.errors.RasterioIOError:
            raise InputError(f"{p}: not a raster GDAL can read") from None
    counts = {i[5] for i in infos}
    if len(counts) > 1:
        raise InputError("mismatched band counts: " + ", ".join(f"{i[0].name} has {i[5]}" for i in infos))
    if min(counts) < RGB_BANDS:
        raise InputError(f"{infos[0][0].name}: {min(counts)} band(s); an RGB orthomosaic has {RGB_BANDS} (or {RGB_BANDS + 1} with alpha)")
    with_crs = [i for i in infos if i[1] is not None]
    if with_crs and len(with_crs) != len(infos):
        missing = [i[0].name for i in infos if i[1] is None]
        raise InputError(f"{', '.join(missing)}: no CRS, while {with_crs[0][0].name} has one; georeference every input")
    if not with_crs and len({(i[3], i[4]) for i in infos}) > 1:
        raise InputError("inputs without a CRS must have the same size in pixels: "
                         + ", ".join(f"{i[0].name} {i[3]} x {i[4]}" for i in infos))
    p, crs, tr, w, h, n = infos[0]
    if with_crs and not resample:
        for q, c2, t2, w2, h2, _ in infos[1:]:
            diff = [f"{what} {b} vs {a}" for what, a, b in (
                ("CRS", crs, c2), ("transform", _transform_text(tr), _transform_text(t2)),
                ("size", f"{w} x {h}", f"{w2} x {h2}")) if a != b]
            if diff:
                raise InputError(f"{q.name} is on another grid than {p.name} ({'; '.join(diff)}); give --resample to "
                                 f"warp it onto {p.name}'s grid (bilinear; only the common valid footprint is judged)")
    return Grid(crs, tr, w, h, n)


def _transform_text(t: Any) -> str:
    """An affine transform as its six coefficients (a, b, c, d, e, f): pixel size, rotation and origin."""
    return "(" + ", ".join(f"{v:.10g}" for v in tuple(t)[:6]) + ")"


def _same_grid(ds: Any, grid: Grid) -> bool:
    return bool(ds.crs == grid.crs and ds.transform == grid.transform and ds.width == grid.width
                and ds.height == grid.height)


def _open(path: Path, grid: Grid) -> tuple[Any, Any]:
    ds = rasterio.open(path)
    if ds.crs is None or _same_grid(ds, grid):
        return ds, ds
    # without a nodata value or an alpha band, an alpha band marks the warped footprint, so
    # that pixels outside this input are invalid rather than black
    has_alpha = any(ci.name == "alpha" for ci in ds.colorinterp)
    vrt = WarpedVRT(ds, crs=grid.crs, transform=grid.transform, width=grid.width, height=grid.height,
                    resampling=Resampling.bilinear, add_alpha=ds.nodata is None and not has_alpha)
    return vrt, ds


def block_windows(grid: Grid, block: int) -> list[tuple[int, int, int, int]]:
    return [(r, c, min(block, grid.height - r), min(block, grid.width - c))
            for r in range(0, grid.height, block) for c in range(0, grid.width, block)]


def compute_block(paths: list[str], grid: Grid, win: tuple[int, int, int, int], s: Settings) -> dict[str, Any]:
    """The reproducibility sum and per-pair counts of one block (runs in a worker)."""
    r0, c0, h, w = win
    halo = s.halo
    rr0, cc0 = max(r0 - halo, 0), max(c0 - halo, 0)
    rr1, cc1 = min(r0 + h + halo, grid.height), min(c0 + w + halo, grid.width)
    big = Window(cc0, rr0, cc1 - cc0, rr1 - rr0)
    data, valid = [], []
    for p in paths:
        src, base = _open(Path(p), grid)
        try:
            data.append(src.read(list(range(1, RGB_BANDS + 1)), window=big))
            valid.append(src.dataset_mask(window=big) > 0)
        finally:
            if src is not base:
                src.close()
            base.close()
    inner = (slice(r0 - rr0, r0 - rr0 + h), slice(c0 - cc0, c0 - cc0 + w))
    keep = np.ones((h, w), bool)
    if s.crop == "auto":
        all_valid = np.logical_and.reduce(valid)
        # the halo holds at least the margin, so only the data footprint's edge (and the raster's) erodes
        eroded = ndimage.binary_erosion(all_valid, iterations=s.crop_margin_px, border_value=0) \
            if s.crop_margin_px > 0 else all_valid
        keep = eroded[inner]
    elif s.crop_geoms:
        tr = rasterio.windows.transform(Window(c0, r0, w, h), grid.transform)
        keep = rasterio.features.geometry_mask(list(s.crop_geoms), out_shape=(h, w), transform=tr, invert=True)
    pl = pairs(len(paths))
    total = np.zeros((h, w), np.uint16)
    judged_all = np.ones((h, w), bool)
    counts = []
    for i, j in pl:
        if s.statistic == "pixel":  # no neighbourhood: only the block itself is needed
            vi = (valid[i] & valid[j])[inner]
            layer, flat = reproducible(data[i][(slice(None), *inner)], data[j][(slice(None), *inner)], vi, s.window,
                                       s.threshold, "pixel")
            flat_n = int((vi & keep).sum()) - int(((layer != NODATA) & keep).sum())
        else:
            layer = reproducible(data[i], data[j], valid[i] & valid[j], s.window, s.threshold, "window")[0][inner]
            flat_n = 0
        judged = (layer != NODATA) & keep
        judged_all &= judged
        counts.append([int(((layer == 1) & judged).sum()), int(((layer == 0) & judged).sum()), flat_n])
        total += layer == 1
    out = np.where(judged_all, total, NODATA).astype(np.uint8)
    hist = np.bincount(out[judged_all].ravel(), minlength=len(pl) + 1)[: len(pl) + 1]
    return {"win": win, "sum": out, "pairs": counts, "hist": hist.tolist()}


Mapper = Callable[[Callable[[tuple[int, int, int, int]], dict[str, Any]], Iterable[tuple[int, int, int, int]]],
                  Iterator[dict[str, Any]]]


def _executor(scheduler: str) -> tuple[Mapper, Callable[[], object]]:
    """(map function, closer) for 'threads', 'local' (a Dask LocalCluster) or a Dask address."""
    if scheduler == "threads":
        pool = ThreadPoolExecutor(max_workers=2)
        return (lambda fn, items: pool.map(fn, items)), pool.shutdown
    # distributed is heavy and only needed here
    from distributed import Client, LocalCluster, as_completed

    if scheduler == "local":
        cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=False,  # type: ignore[no-untyped-call]
                               dashboard_address=None)
        client = Client(cluster)  # type: ignore[no-untyped-call]
        closers = [client.close, cluster.close]
    else:
        probe_scheduler(scheduler)
        try:
            client = Client(scheduler, timeout=f"{2 * DASK_CONNECT_TIMEOUT_S:g}s")  # type: ignore[no-untyped-call]
        except (OSError, TimeoutError) as exc:
            raise InputError(f"--scheduler {scheduler}: no Dask scheduler answered ({type(exc).__name__}: {exc})") \
                from None
        closers = [client.close]

    def run(fn: Callable[[tuple[int, int, int, int]], dict[str, Any]],
            items: Iterable[tuple[int, int, int, int]]) -> Iterator[dict[str, Any]]:
        futures = client.map(fn, list(items), pure=False)
        for fut in as_completed(futures):  # type: ignore[no-untyped-call]
            yield fut.result()

    return run, lambda: [c() for c in closers]


def probe_scheduler(address: str, timeout: float = DASK_CONNECT_TIMEOUT_S) -> None:
    """Fail fast, with one line naming the address, when nothing listens there."""
    from urllib.parse import urlsplit

    u = urlsplit(address if "://" in address else f"tcp://{address}")
    try:
        host, port = u.hostname, u.port
    except ValueError:
        host, port = None, None
    if u.scheme not in ("tcp", "tls") or not host or port is None:
        raise InputError(f"--scheduler = {address!r} is not allowed: threads, local, or a Dask scheduler address "
                         "such as tcp://host:8786")
    try:
        with socket.create_connection((host, port), timeout=timeout):
            pass
    except OSError as exc:
        raise InputError(f"--scheduler {address}: cannot reach a Dask scheduler at {host}:{port} within "
                         f"{timeout:g} s ({exc.strerror or type(exc).__name__}); start one or use --scheduler "
                         "threads / local") from None


def run(paths: list[Path], stage: Path, s: Settings, scheduler: str = "threads",
        progress: Callable[[str, float], None] | None = None) -> dict[str, Any]:
    """Compute the layer into `stage`/reproducibility.tif (COG) and return the summary; `progress`
    hears of each block done (stage name, share done)."""
    grid = inspect(paths, s.resample)
    pl = pairs(len(paths))
    tmp = stage / ".layer.tif"
    profile = dict(driver="GTiff", width=grid.width, height=grid.height, count=1, dtype="uint8", crs=grid.crs,
                   transform=grid.transform, nodata=NODATA, tiled=True, blockxsize=512, blockysize=512, compress="deflate")
    pair_counts = np.zeros((len(pl), 3), np.int64)
    hist = np.zeros(len(pl) + 1, np.int64)
    str_paths = [str(p) for p in paths]
    mapper, close = _executor(scheduler)
    windows = block_windows(grid, s.block)
    done = 0
    try:
        with rasterio.open(tmp, "w", **profile) as dst:
            for res in mapper(lambda win: compute_block(str_paths, grid, win, s), windows) \
                    if scheduler == "threads" else mapper(_Task(str_paths, grid, s), windows):
                r0, c0, h, w = res["win"]
                dst.write(res["sum"], 1, window=Window(c0, r0, w, h))
                pair_counts += np.asarray(res["pairs"], np.int64)
                hist += np.asarray(res["hist"], np.int64)
                done += 1
                if progress is not None:
                    progress("blocks", done / len(windows))
    finally:
        close()
    rasterio.shutil.copy(tmp, stage / "reproducibility.tif", driver="COG", compress="DEFLATE", blocksize=512,
                         overview_resampling="nearest")
    tmp.unlink()
    judged = int(hist.sum())
    summary = {
        "inputs": [p.name for p in paths], "pairs": len(pl), "statistic": s.statistic,
        "definition": DEFINITIONS[s.statistic], "window": s.window if s.statistic == "window" else None,
        "threshold": s.threshold, "rule": "reproducible when r > threshold", "resampled": s.resample,
        "crop": s.crop, "grid": {"width": grid.width, "height": grid.height, "crs": str(grid.crs)},
        "judged_pixels": judged,
        "reproducible_share": float(hist[-1] / judged) if judged else math.nan,
        "chance_level": _chance(s),
        "share_by_sum": {str(k): float(v / judged) if judged else math.nan for k, v in enumerate(hist)},
        "per_pair": [{"pair": [paths[i].name, paths[j].name],
                      "reproducible_share": float(a / (a + b)) if a + b else math.nan, "judged_pixels": int(a + b),
                      "flat_pixels": int(f)}
                     for (i, j), (a, b, f) in zip(pl, pair_counts)],
    }
    return summary


DEFINITIONS = {
    "pixel": "per pixel, the Pearson correlation between the band values of the two orthomosaics (n = 3 for RGB), "
             "as raster::corLocal on two bricks in the source study's scripts; pixels with no variance across the "
             "bands in either image are not judged (NA in R)",
    "window": "per pixel, the Pearson correlation over a w x w window with the three bands pooled (3 w^2 pairs)",
}


def _chance(s: Settings) -> dict[str, Any]:
    """The share of unrelated pixel pairs that pass the rule by chance, for the statistic's number of values."""
    n = statistic_values(s.statistic, s.window)
    return {"probability": chance_level(s.threshold, n), "values": n,
            "meaning": f"P(r > {s.threshold:g}) for two unrelated pixels (independent normal values): the null "
                       f"distribution of Pearson's r for n = {n} values; a pair's share near it says nothing"}


@dataclass(frozen=True)
class _Task:
    """A picklable block task for Dask workers."""

    paths: list[str]
    grid: Grid
    s: Settings

    def __call__(self, win: tuple[int, int, int, int]) -> dict[str, Any]:
        return compute_block(self.paths, self.grid, win, self.s)


def write_summary(stage: Path, summary: dict[str, Any]) -> None:
    from aerosurvey.fileio import atomic_write_text

    atomic_write_text(stage / "summary.json", json.dumps(summary, indent=1) + "\n")
    stat = summary["statistic"] + (f" (window {summary['window']})" if summary["window"] else "")
    chance = summary["chance_level"]
    lines = [f"{summary['pairs']} pairs of {len(summary['inputs'])} inputs, statistic {stat}: {summary['definition']}; "
             f"reproducible when r > {summary['threshold']}", f"reproducible in every pair: {100 * summary['reproducible_share']:.2f} % of "
             f"{summary['judged_pixels']} judged pixels",
             f"chance level: {100 * chance['probability']:.1f} % of unrelated pixel pairs pass in one pair "
             f"({chance['meaning']})"]
    lines += [f"  sum {k}: {100 * v:.2f} %" for k, v in summary["share_by_sum"].items()]
    lines += [f"  {p['pair'][0]} / {p['pair'][1]}: {100 * p['reproducible_share']:.2f} % of {p['judged_pixels']} judged "
              f"(chance level {100 * chance['probability']:.1f} %; {p['flat_pixels']} flat pixels not judged)"
              for p in summary["per_pair"]]
    atomic_write_text(stage / "summary.txt", "\n".join(lines) + "\n")
