"""Pixel-wise local correlation of two RGB(A) orthomosaics in a moving window (pure numpy).

For each pixel, the Pearson correlation r of the band values of the two images over a
w × w window (all bands pooled: 3 w² pairs of values), computed from box sums of a, b,
a², b² and ab in float64. Masked pixels (nodata, alpha = 0) are left out of the sums.

Rules, documented in docs/qa-reproducibility.md:
- a pixel is only judged when it is valid in both images and at least half of its
  window's pairs are valid; otherwise the pair's result there is NODATA;
- a flat window (zero variance in either image) has no correlation: it counts as
  reproducible when both windows are flat with equal means (the same constant patch),
  and as not reproducible otherwise. No NaN reaches the layers.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

NODATA = 255
_FLAT = 1e-9  # relative variance below which a window is flat


def window_sums(a: np.ndarray, b: np.ndarray, valid: np.ndarray, w: int) -> dict[str, np.ndarray]:
    """Box sums over bands and window: a and b are (bands, rows, cols); valid (rows, cols).

    The box filter is linear, so the bands are summed first and each quantity needs one
    filter (all six in one call on a stacked array).
    """
    v = valid.astype(np.float64)
    x = a.astype(np.float64) * v
    y = b.astype(np.float64) * v
    stack = np.stack([x.sum(0), y.sum(0), (x * x).sum(0), (y * y).sum(0), (x * y).sum(0), v * a.shape[0]])
    sums = ndimage.uniform_filter(stack, size=(1, w, w), mode="constant", cval=0.0) * (w * w)
    return dict(zip(("sa", "sb", "saa", "sbb", "sab", "n"), sums))


def correlation(a: np.ndarray, b: np.ndarray, valid: np.ndarray, w: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(r, judged, flat_equal): r where defined (NaN elsewhere), which pixels are judged,
    and where both windows are flat with equal means."""
    s = window_sums(a, b, valid, w)
    n = s["n"]
    full = a.shape[0] * w * w
    with np.errstate(invalid="ignore", divide="ignore"):
        va = n * s["saa"] - s["sa"] ** 2
        vb = n * s["sbb"] - s["sb"] ** 2
        cov = n * s["sab"] - s["sa"] * s["sb"]
        scale_a = np.maximum(s["saa"] * n, 1e-300)
        scale_b = np.maximum(s["sbb"] * n, 1e-300)
        flat_a = va <= _FLAT * scale_a
        flat_b = vb <= _FLAT * scale_b
        r = cov / np.sqrt(np.maximum(va, 0) * np.maximum(vb, 0))
        mean_a = s["sa"] / np.maximum(n, 1)
        mean_b = s["sb"] / np.maximum(n, 1)
    judged = valid & (n >= 0.5 * full)
    flat = flat_a | flat_b
    flat_equal = flat_a & flat_b & np.isclose(mean_a, mean_b, rtol=1e-9, atol=1e-9)
    r = np.where(flat, np.nan, np.clip(r, -1.0, 1.0))
    return r, judged, flat_equal


def reproducible(a: np.ndarray, b: np.ndarray, valid: np.ndarray, w: int, threshold: float) -> np.ndarray:
    """uint8 layer: 1 reproducible (r ≥ threshold), 0 not, NODATA not judged."""
    r, judged, flat_equal = correlation(a, b, valid, w)
    ok = np.where(np.isnan(r), flat_equal, r >= threshold)
    out = ok.astype(np.uint8)
    out[~judged] = NODATA
    return out


def pairs(x: int) -> list[tuple[int, int]]:
    """All x(x−1)/2 pairs of x inputs."""
    return [(i, j) for i in range(x) for j in range(i + 1, x)]
