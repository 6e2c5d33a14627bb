"""Reproducibility QA: planted truth, the window correlation against numpy, pairs, Dask, bad input."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner, Result
from hypothesis import given, settings
from hypothesis import strategies as st
from rasterio.transform import from_origin
from scipy import ndimage

from aerosurvey.cli import main
from aerosurvey.qa.repro_core import NODATA, correlation

W, H = 200, 160


def _write(path: Path, data: np.ndarray, crs: str | None = "EPSG:32633", nodata: float | None = None) -> Path:
    prof = dict(driver="GTiff", width=data.shape[2], height=data.shape[1], count=data.shape[0], dtype="uint8",
                transform=from_origin(500000, 5470000, 0.05, 0.05), nodata=nodata)
    if crs:
        prof["crs"] = crs
    with rasterio.open(path, "w", **prof) as ds:
        ds.write(data)
    return path


def _base(seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 256, (3, H, W), dtype=np.uint8)


NOISE = (slice(40, 70), slice(30, 80))
SHIFT = (slice(100, 140), slice(110, 170))


def _planted(tmp: Path) -> tuple[Path, Path]:
    a = _base()
    b = a.copy()
    b[:, NOISE[0], NOISE[1]] = np.random.default_rng(9).integers(0, 256, (3, 30, 50), dtype=np.uint8)
    shifted = np.roll(a, 2, axis=2)
    b[:, SHIFT[0], SHIFT[1]] = shifted[:, SHIFT[0], SHIFT[1]]
    return _write(tmp / "a.tif", a), _write(tmp / "b.tif", b)


def _run(args: list[str]) -> Result:
    return CliRunner().invoke(main, ["qa", "reproducibility", *args])


def test_planted_noise_and_shift_are_found(tmp_path: Path) -> None:
    a, b = _planted(tmp_path)
    res = _run([str(a), str(b), "-o", str(tmp_path / "out"), "--block", "64", "--statistic", "window"])
    assert res.exit_code == 0, res.output
    with rasterio.open(tmp_path / "out" / "reproducibility.tif") as ds:
        layer = ds.read(1)
        assert ds.tags(ns="IMAGE_STRUCTURE").get("LAYOUT") == "COG"
        assert ds.crs.to_epsg() == 32633
    planted = np.zeros((H, W), bool)
    planted[NOISE] = True
    planted[SHIFT] = True
    reach = 2  # window 5
    square = np.ones((3, 3), bool)  # a window reaches diagonally too
    near = ndimage.binary_dilation(planted, structure=square, iterations=reach)
    core = ndimage.binary_erosion(planted, structure=square, iterations=reach)
    judged = layer != NODATA
    assert np.all(layer[core & judged] == 0), "planted regions must be non-reproducible"
    assert np.all(layer[~near & judged] == 1), "everything else must be reproducible"
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    lo = 1 - near[judged].mean()
    hi = 1 - core[judged].mean()
    assert lo <= summary["reproducible_share"] <= hi


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 10_000), st.integers(0, 19), st.integers(0, 24), st.sampled_from([3, 5, 7]), st.booleans())
def test_window_correlation_equals_numpy_corrcoef(seed: Any, i: Any, j: Any, w: Any, holes: Any) -> None:
    rng = np.random.default_rng(seed)
    a = rng.normal(100, 20, (3, 20, 25))
    b = 0.7 * a + rng.normal(0, 10, (3, 20, 25))
    valid = np.ones((20, 25), bool)
    if holes:
        valid[rng.random((20, 25)) < 0.15] = False
    r, judged, _ = correlation(a, b, valid, w)
    h = w // 2
    rows = slice(max(i - h, 0), i + h + 1)
    cols = slice(max(j - h, 0), j + h + 1)
    m = valid[rows, cols]
    xa = a[:, rows, cols][:, m].ravel()
    xb = b[:, rows, cols][:, m].ravel()
    if not judged[i, j]:
        assert not valid[i, j] or len(xa) < 0.5 * 3 * w * w
        return
    assert r[i, j] == pytest.approx(np.corrcoef(xa, xb)[0, 1], abs=1e-9)


def test_flat_windows_are_explicit() -> None:
    a = np.full((3, 9, 9), 50.0)
    valid = np.ones((9, 9), bool)
    r, judged, flat_equal = correlation(a, a.copy(), valid, 3)
    assert np.isnan(r).all() and flat_equal.all()
    r2, _, flat2 = correlation(a, a + 1, valid, 3)
    assert not flat2.any()


def test_three_inputs_give_three_pairs_and_bounded_sum(tmp_path: Path) -> None:
    a, b = _planted(tmp_path)
    c = _write(tmp_path / "c.tif", _base())
    res = _run([str(a), str(b), str(c), "-o", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["pairs"] == 3 and len(summary["per_pair"]) == 3
    with rasterio.open(tmp_path / "out" / "reproducibility.tif") as ds:
        layer = ds.read(1)
    assert layer[layer != NODATA].max() <= 3
    # a and c are identical: that pair is fully reproducible
    ac = next(p for p in summary["per_pair"] if p["pair"] == ["a.tif", "c.tif"])
    assert ac["reproducible_share"] == 1.0


def test_dask_cluster_gives_the_same_layer(tmp_path: Path) -> None:
    a, b = _planted(tmp_path)
    assert _run([str(a), str(b), "-o", str(tmp_path / "t"), "--block", "64"]).exit_code == 0
    res = _run([str(a), str(b), "-o", str(tmp_path / "d"), "--block", "64", "--scheduler", "local"])
    assert res.exit_code == 0, res.output
    with rasterio.open(tmp_path / "t" / "reproducibility.tif") as x, rasterio.open(tmp_path / "d" / "reproducibility.tif") as y:
        assert np.array_equal(x.read(1), y.read(1))


def test_nodata_and_auto_crop(tmp_path: Path) -> None:
    a = _base()
    a[:, :, :20] = 0
    pa = _write(tmp_path / "a.tif", a, nodata=0)
    pb = _write(tmp_path / "b.tif", a.copy(), nodata=0)
    res = _run([str(pa), str(pb), "-o", str(tmp_path / "out"), "--crop", "auto", "--crop-margin", "10"])
    assert res.exit_code == 0, res.output
    with rasterio.open(tmp_path / "out" / "reproducibility.tif") as ds:
        layer = ds.read(1)
    assert (layer[:, :30] == NODATA).all() and (layer[:10, :] == NODATA).all()
    assert (layer[20:-20, 40:-20] == 1).all()


@pytest.mark.parametrize("case,needle", [
    ("text", "not a raster"), ("bands", "mismatched band counts"), ("crs", "no CRS"),
    ("window", "--window = 4"), ("small", "--window = 1"), ("threshold", "--threshold = 1.5"),
    ("pixel-window", "--window = 5 is not allowed with --statistic pixel"),
])
def test_bad_input(tmp_path: Path, case: Any, needle: Any) -> None:
    a = _write(tmp_path / "a.tif", _base())
    b = _write(tmp_path / "b.tif", _base(1))
    args = [str(a), str(b)]
    if case == "text":
        (tmp_path / "x.tif").write_text("not a raster")
        args = [str(a), str(tmp_path / "x.tif")]
    elif case == "bands":
        args = [str(a), str(_write(tmp_path / "four.tif", np.zeros((4, H, W), np.uint8)))]
    elif case == "crs":
        args = [str(a), str(_write(tmp_path / "nocrs.tif", _base(), crs=None))]
    elif case == "window":
        args += ["--statistic", "window", "--window", "4"]
    elif case == "small":
        args += ["--statistic", "window", "--window", "1"]
    elif case == "pixel-window":  # the default statistic has no window: the option is not silently ignored
        args += ["--window", "5"]
    elif case == "threshold":
        args += ["--threshold", "1.5"]
    out = tmp_path / "out"
    res = _run([*args, "-o", str(out)])
    assert res.exit_code == 2, res.output
    assert needle in res.output
    assert not out.exists() or not any(out.iterdir())
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out.")]


def test_timeseries_and_shift(tmp_path: Path) -> None:
    a, b = _planted(tmp_path)
    c = _write(tmp_path / "c.tif", _base())
    assert _run([str(a), str(b), "-o", str(tmp_path / "d1")]).exit_code == 0
    assert _run([str(a), str(c), "-o", str(tmp_path / "d2")]).exit_code == 0
    res = CliRunner().invoke(main, ["qa", "timeseries", "--masks", str(tmp_path / "d1"), "--masks", str(tmp_path / "d2"),
                                    "-o", str(tmp_path / "ts")])
    assert res.exit_code == 0, res.output
    with rasterio.open(tmp_path / "ts" / "quality_mask.tif") as ds, rasterio.open(tmp_path / "d1" / "reproducibility.tif") as d1:
        assert np.array_equal(ds.read(1) == 1, d1.read(1) == 1)
    def feats(dx: float) -> dict[str, Any]:
        return {"type": "FeatureCollection", "features": [
            {"type": "Feature", "properties": {"id": f"T{k}"},
             "geometry": {"type": "Polygon", "coordinates": [[[k * 10 + dx, 0], [k * 10 + 1 + dx, 0],
                                                              [k * 10 + 1 + dx, 1], [k * 10 + dx, 0]]]}}
            for k in range(3)]}
    (tmp_path / "t1.geojson").write_text(json.dumps(feats(0.0)))
    (tmp_path / "t2.geojson").write_text(json.dumps(feats(0.07)))
    res = CliRunner().invoke(main, ["qa", "shift", str(tmp_path / "t1.geojson"), str(tmp_path / "t2.geojson"), "-o", str(tmp_path / "sh")])
    assert res.exit_code == 0, res.output
    out = json.loads((tmp_path / "sh" / "shift.json").read_text())
    # GeoJSON is longitude/latitude: 0.07 degrees of longitude near the equator, in metres on WGS84
    # (a = 6378137 m; the centroids lie at latitude 1/3 degree)
    expected = math.radians(0.07) * 6378137.0 * math.cos(math.radians(1 / 3))
    assert out["unit"] == "m"
    assert out["per_date"][0]["centroid_shift_mean_m"] == pytest.approx(expected, rel=1e-4)
    assert "(m)" in res.output and "0.000" not in res.output


# --- issue 15: the source study's statistic, grids, Dask, a fresh process ----------------------------------------


def _pattern() -> tuple[np.ndarray, np.ndarray]:
    """3 x 3 pixels, every pixel (10, 20, 30) in A; B = A + c with c = 90 at the four corners, 0 elsewhere."""
    a = np.empty((3, 3, 3), np.uint8)
    for k in range(3):
        a[k] = 10 * (k + 1)
    c = np.zeros((3, 3), np.uint8)
    c[0, 0] = c[0, 2] = c[2, 0] = c[2, 2] = 90
    return a, a + c


def test_pixel_and_window_statistics_differ_as_computed_by_hand() -> None:
    from aerosurvey.qa.repro_core import correlation, pixel_correlation, reproducible

    a, b = _pattern()
    # per pixel: B's band vector is A's plus a constant, so r = 1 at every pixel
    r_pix, flat = pixel_correlation(a, b)
    assert not flat.any() and np.allclose(r_pix, 1.0)
    # window 3 x 3 at the centre, bands pooled (27 pairs): var(a) = 200/3, cov(a, b) = var(a) (c does not depend
    # on the band), var(b) = var(a) + var(c) = 200/3 + 90^2 (4/9)(5/9) = 200/3 + 2000, so
    # r = sqrt((200/3) / (200/3 + 2000)) = sqrt(1/31) = 0.1796
    r_win, judged, _ = correlation(a, b, np.ones((3, 3), bool), 3)
    assert judged[1, 1] and r_win[1, 1] == pytest.approx(math.sqrt(1 / 31), abs=1e-12)
    valid = np.ones((3, 3), bool)
    assert (reproducible(a, b, valid, 3, 0.95, "pixel")[0] == 1).all()
    assert reproducible(a, b, valid, 3, 0.95, "window")[0][1, 1] == 0


def test_pixel_statistic_end_to_end_and_flat_pixels(tmp_path: Path) -> None:
    a = _base()
    b = a.copy()
    b[:, 10:20, 10:30] = a[:, 10:20, 10:30][::-1]  # bands reversed: r = -1 unless the pixel is grey
    a[:, 50, 50] = 77  # a grey pixel: no variance across the bands, NA in R, not judged
    pa, pb = _write(tmp_path / "a.tif", a), _write(tmp_path / "b.tif", b)
    res = _run([str(pa), str(pb), "-o", str(tmp_path / "out"), "--block", "64"])
    assert res.exit_code == 0, res.output
    with rasterio.open(tmp_path / "out" / "reproducibility.tif") as ds:
        layer = ds.read(1)
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["statistic"] == "pixel" and "band values" in summary["definition"]
    assert layer[50, 50] == NODATA and summary["per_pair"][0]["flat_pixels"] >= 1
    # expected by direct numpy: r across the bands of each pixel of the reversed block
    block = a[:, 10:20, 10:30].reshape(3, -1).astype(float)
    rev = block[::-1]
    r = np.array([np.corrcoef(block[:, k], rev[:, k])[0, 1] if block[:, k].std() > 0 else np.nan
                  for k in range(block.shape[1])])
    want = np.where(np.isnan(r), NODATA, r > 0.95).reshape(10, 20)
    assert np.array_equal(layer[10:20, 10:30], want)


def _shifted_grid(path: Path, data: np.ndarray, x0: float) -> Path:
    prof = dict(driver="GTiff", width=data.shape[2], height=data.shape[1], count=3, dtype="uint8",
                transform=from_origin(x0, 5470000, 0.05, 0.05), crs="EPSG:32633")
    with rasterio.open(path, "w", **prof) as ds:
        ds.write(data)
    return path


def test_other_grid_is_refused_unless_resample_and_only_the_overlap_is_judged(tmp_path: Path) -> None:
    a = _base()
    pa = _write(tmp_path / "a.tif", a)
    pb = _shifted_grid(tmp_path / "b.tif", a[:, :, :100].copy(), 500000)  # the western half only, no nodata
    out = tmp_path / "out"
    res = _run([str(pa), str(pb), "-o", str(out)])
    assert res.exit_code == 2 and "another grid" in res.output and "--resample" in res.output
    assert "size 100 x 160 vs 200 x 160" in res.output and "transform" not in res.output and "CRS" not in res.output
    assert not out.exists()
    res = _run([str(pa), str(pb), "-o", str(out), "--resample", "--block", "64"])
    assert res.exit_code == 0, res.output
    with rasterio.open(out / "reproducibility.tif") as ds:
        layer = ds.read(1)
    assert (layer[:, 100:] == NODATA).all()  # outside b: not judged (no longer counted as not reproducible)
    inner = layer[:, :99]
    assert (inner[inner != NODATA] == 1).all() and (inner != NODATA).mean() > 0.99


def test_unreachable_dask_scheduler_fails_fast_with_one_line(tmp_path: Path) -> None:
    a, b = _planted(tmp_path)
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["qa", "reproducibility", str(a), str(b), "-o", str(out), "--scheduler",
                                    "tcp://127.0.0.1:9"])
    assert res.exit_code == 2 and "127.0.0.1:9" in res.stderr and res.stderr.count("\n") == 1
    assert not out.exists()
    bad = CliRunner().invoke(main, ["qa", "reproducibility", str(a), str(b), "-o", str(out), "--scheduler", "nonsense"])
    assert bad.exit_code == 2 and "tcp://host:8786" in bad.stderr


def test_timeseries_runs_in_a_fresh_process(tmp_path: Path) -> None:
    a, b = _planted(tmp_path)
    assert _run([str(a), str(b), "-o", str(tmp_path / "d1")]).exit_code == 0
    assert _run([str(a), str(a), "-o", str(tmp_path / "d2")]).exit_code == 0
    src = Path(__file__).resolve().parents[2] / "src"
    p = subprocess.run([sys.executable, "-m", "aerosurvey.cli", "qa", "timeseries", "--masks", str(tmp_path / "d1"),
                        "--masks", str(tmp_path / "d2"), "-o", str(tmp_path / "ts")], capture_output=True, text=True,
                       env={"PATH": "/usr/bin:/bin", "PYTHONPATH": str(src)}, timeout=300)
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "ts" / "quality_mask.tif").exists() and "reproducible at every date" in p.stdout


def test_the_layer_reports_progress_block_by_block(tmp_path: Path) -> None:
    from aerosurvey.qa import reproducibility as rp

    a, b = _planted(tmp_path)
    seen: list[tuple[str, float]] = []
    s = rp.Settings(block=64)
    (tmp_path / "stage").mkdir()
    rp.run([a, b], tmp_path / "stage", s, progress=lambda stage, done: seen.append((stage, done)))
    blocks = len(rp.block_windows(rp.inspect([a, b]), 64))
    assert blocks > 1 and len(seen) == blocks
    assert [d for _, d in seen] == sorted(d for _, d in seen) and seen[-1] == ("blocks", 1.0)


def test_grid_refusal_names_the_transforms_and_crs_that_differ(tmp_path: Path) -> None:
    a = _base()
    pa = _write(tmp_path / "a.tif", a)
    moved = _shifted_grid(tmp_path / "moved.tif", a, 500000.5)  # same size, origin half a metre east
    res = _run([str(pa), str(moved), "-o", str(tmp_path / "out")])
    assert res.exit_code == 2, res.output
    assert "transform (0.05, 0, 500000.5, 0, -0.05, 5470000) vs (0.05, 0, 500000, 0, -0.05, 5470000)" in res.output
    assert "size" not in res.output.split("(", 1)[1].split(";")[0]
    other = _write(tmp_path / "utm34.tif", a, crs="EPSG:32634")
    res = _run([str(pa), str(other), "-o", str(tmp_path / "out")])
    assert res.exit_code == 2 and "CRS EPSG:32634 vs EPSG:32633" in res.output, res.output


def test_chance_level_is_the_null_distribution_of_r(tmp_path: Path) -> None:
    """Two unrelated RGB pixels pass r > 0.95 about 10 % of the time (n = 3); the report says so."""
    rng = np.random.default_rng(11)
    a, b = rng.normal(size=(2, 200_000, 3))
    a -= a.mean(axis=1, keepdims=True)
    b -= b.mean(axis=1, keepdims=True)
    r = (a * b).sum(axis=1) / np.sqrt((a * a).sum(axis=1) * (b * b).sum(axis=1))
    share = float(np.mean(r > 0.95))
    assert share == pytest.approx(math.acos(0.95) / math.pi, abs=3 * math.sqrt(0.1 * 0.9 / 200_000))
    pa, pb = _write(tmp_path / "a.tif", _base(1)), _write(tmp_path / "b.tif", _base(2))  # unrelated images
    res = _run([str(pa), str(pb), "-o", str(tmp_path / "out"), "--block", "64"])
    assert res.exit_code == 0, res.output
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    chance = summary["chance_level"]
    assert chance["values"] == 3 and chance["probability"] == pytest.approx(math.acos(0.95) / math.pi, rel=1e-9)
    assert "chance level: 10.1 %" in res.output
    assert "chance level 10.1 %" in (tmp_path / "out" / "summary.txt").read_text()
    # uniform 8-bit values are not normal, yet unrelated images pass near the chance level
    assert abs(summary["reproducible_share"] - chance["probability"]) < 0.02
    win = _run([str(pa), str(pb), "-o", str(tmp_path / "w"), "--statistic", "window", "--window", "3"])
    assert win.exit_code == 0 and "n = 27 values" in win.output, win.output
