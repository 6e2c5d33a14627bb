"""Correlation of two RGB(A) orthomosaics, pixel by pixel (pure numpy).

Two statistics, documented in docs/qa-reproducibility.md:

- **pixel** (the default, the source study's): for each pixel, the Pearson correlation r
  between the vector of band values in image A and the vector in image B (n = number of
  bands, 3 for RGB). This is what the study's public scripts compute: envima/
  UASreproducibility, src/004_reproducibility_canopy_sample.R, calls
  `raster::corLocal(ortho_i, ortho_j)` on RGB bricks, and raster's documentation says that
  for two RasterStack/Brick objects the correlation is computed for each cell across the
  layers (no neighbourhood). Its published figures (99 % grassland, 75 % forest) are
  shares of this statistic above the threshold.
- **window** (an option): r over a w × w window with the bands pooled (3 w² pairs of
  values), from box sums of a, b, a², b² and ab in float64. Masked pixels (nodata,
  alpha = 0) are left out of the sums.

Rules:
- reproducible when r > threshold, strictly, as the study's `cors > 0.95`
  (src/005_plot_reproducibility_canopy_sample.R);
- pixel statistic: a pixel is judged when it is valid in both images; when the band values
  of either image have zero variance (a grey pixel) R's `cor` gives NA, the study's sum
  of the binary layers is NA there, and so the pixel is not judged here (NODATA), and
  counted apart as "flat";
- window statistic: judged when the pixel is valid in both images and at least half of its
  window's pairs are valid; a flat window counts as reproducible when both windows are flat
  with equal means (the same constant patch), as not reproducible otherwise.
No NaN reaches the layers.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage, stats

NODATA = 255
RGB_BANDS = 3  # the bands compared (red, green, blue; a fourth, alpha, is a mask)
_FLAT = 1e-9  # relative variance below which a window is flat
STATISTICS = ("pixel", "window")


def _accumulator(a: np.ndarray, b: np.ndarray) -> type[np.generic]:
    """int32 for 8-bit imagery, int64 for 16-bit (exact sums for up to 4 bands), float64 otherwise."""
    if a.dtype == np.uint8 and b.dtype == np.uint8:
        return np.int32
    if all(x.dtype.kind in "ui" and x.dtype.itemsize <= 2 for x in (a, b)):
        return np.int64
    return np.float64


def pixel_sums(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(n·Σab − ΣaΣb, n·Σa² − (Σa)², n·Σb² − (Σb)², n·Σa² + n·Σb²) over the bands of each pixel.

    Accumulated band by band in integers for integer imagery (exact, and about twice as
    fast as float64 here), so memory is a few (rows, cols) arrays whatever the band count."""
    n = a.shape[0]
    acc = _accumulator(a, b)
    sa: np.ndarray = np.zeros(a.shape[1:], acc)
    sb = np.zeros_like(sa)
    saa = np.zeros_like(sa)
    sbb = np.zeros_like(sa)
    sab = np.zeros_like(sa)
    for k in range(n):
        x = a[k].astype(acc)
        y = b[k].astype(acc)
        sa += x
        sb += y
        sab += x * y
        x *= x
        y *= y
        saa += x
        sbb += y
    sab *= n
    sab -= sa * sb  # the covariance term
    saa *= n
    sbb *= n
    scale = saa + sbb
    saa -= sa * sa
    sbb -= sb * sb
    return sab, saa, sbb, scale


def _flat(va: np.ndarray, vb: np.ndarray, scale: np.ndarray) -> np.ndarray:
    if va.dtype.kind == "i":
        return (va <= 0) | (vb <= 0)
    return (va <= 1e-12 * scale) | (vb <= 1e-12 * scale)


def pixel_correlation(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(r, flat): r across the bands of each pixel (NaN where flat), and where either
    image's band values have zero variance (relative 1e-12, exact 0 for integer data)."""
    cov, va, vb, scale = pixel_sums(a, b)
    flat = _flat(va, vb, scale)
    with np.errstate(invalid="ignore", divide="ignore"):
        r = cov / np.sqrt(np.maximum(va, 0).astype(np.float64) * np.maximum(vb, 0))
    r = np.where(flat, np.nan, np.clip(r, -1.0, 1.0))
    return r, flat


def pixel_reproducible(a: np.ndarray, b: np.ndarray, threshold: float) -> tuple[np.ndarray, np.ndarray]:
    """(r > threshold, flat) without forming r: r > t ⇔ cov > 0 and cov² > t² va vb
    (float64 holds these products exactly for 8- and 16-bit imagery)."""
    cov, va, vb, scale = pixel_sums(a, b)
    flat = _flat(va, vb, scale)
    c = cov.astype(np.float64)
    ok = c > 0
    c *= c
    v = va.astype(np.float64)
    v *= vb
    v *= threshold * threshold
    ok &= c > v
    ok &= ~flat
    return ok, flat


def window_sums(a: np.ndarray, b: np.ndarray, valid: np.ndarray, w: int) -> dict[str, np.ndarray]:
    """Box sums over bands and window: a and b are (bands, rows, cols); valid (rows, cols).

    The box filter is linear, so the bands are summed first (band by band, in integers for
    integer imagery) and each of the six quantities is filtered once, plane by plane, which
    keeps the memory to a few (rows, cols) arrays.
    """
    acc = _accumulator(a, b)
    planes = [np.zeros(a.shape[1:], acc) for _ in range(5)]
    sa, sb, saa, sbb, sab = planes
    zero = np.zeros((), acc)
    for k in range(a.shape[0]):
        x = np.where(valid, a[k], zero).astype(acc, copy=False)
        y = np.where(valid, b[k], zero).astype(acc, copy=False)
        sa += x
        sb += y
        sab += x * y
        saa += x * x
        sbb += y * y
    out: dict[str, np.ndarray] = {}
    for name, plane in zip(("sa", "sb", "saa", "sbb", "sab"), planes):
        out[name] = ndimage.uniform_filter(plane.astype(np.float64), size=w, mode="constant", cval=0.0) * (w * w)
    out["n"] = ndimage.uniform_filter(valid.astype(np.float64) * a.shape[0], size=w, mode="constant",
                                      cval=0.0) * (w * w)
    return out


def correlation(a: np.ndarray, b: np.ndarray, valid: np.ndarray, w: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Window statistic: (r, judged, flat_equal): r where defined (NaN elsewhere), which
    pixels are judged, and where both windows are flat with equal means.

    Computed in place on the six box sums (memory: about eight (rows, cols) arrays)."""
    s = window_sums(a, b, valid, w)
    n, sa, sb, saa, sbb, sab = s["n"], s["sa"], s["sb"], s["saa"], s["sbb"], s["sab"]
    judged = valid & (n >= 0.5 * a.shape[0] * w * w)
    with np.errstate(invalid="ignore", divide="ignore"):
        saa *= n  # n Σa², the scale of the variance
        sbb *= n
        sab *= n
        va = sa * sa
        np.subtract(saa, va, out=va)  # n Σa² − (Σa)²
        flat_a = va <= _FLAT * np.maximum(saa, 1e-300)
        vb = sb * sb
        np.subtract(sbb, vb, out=vb)
        flat_b = vb <= _FLAT * np.maximum(sbb, 1e-300)
        del saa, sbb, s
        sab -= sa * sb  # n Σab − ΣaΣb
        np.maximum(va, 0, out=va)
        np.maximum(vb, 0, out=vb)
        va *= vb
        np.sqrt(va, out=va)
        r = np.divide(sab, va, out=sab)
        nn = np.maximum(n, 1)
        sa /= nn  # the means
        sb /= nn
    flat = flat_a | flat_b
    flat_equal = flat_a & flat_b & np.isclose(sa, sb, rtol=1e-9, atol=1e-9)
    np.clip(r, -1.0, 1.0, out=r)
    r[flat] = np.nan
    return r, judged, flat_equal


def reproducible(a: np.ndarray, b: np.ndarray, valid: np.ndarray, w: int, threshold: float,
                 statistic: str = "pixel") -> tuple[np.ndarray, int]:
    """(uint8 layer: 1 reproducible (r > threshold), 0 not, NODATA not judged; number of
    valid pixels left unjudged because they are flat — pixel statistic only)."""
    if statistic == "pixel":
        ok, flat = pixel_reproducible(a, b, threshold)
        out = ok.astype(np.uint8)
        judged = valid & ~flat
        out[~judged] = NODATA
        return out, int((valid & flat).sum())
    r, judged, flat_equal = correlation(a, b, valid, w)
    ok = np.where(np.isnan(r), flat_equal, r > threshold)
    out = ok.astype(np.uint8)
    out[~judged] = NODATA
    return out, 0


def chance_level(threshold: float, values: int) -> float:
    """P(r > threshold) for two unrelated pixels: Pearson's r of `values` independent normal
    pairs has the null distribution (r + 1) / 2 ~ Beta(n/2 − 1, n/2 − 1) (n ≥ 3). For RGB
    (n = 3) r is spread like the arcsine law and P(r > 0.95) = arccos(0.95) / π = 10.1 %."""
    if values < 3:
        raise ValueError(f"the chance level of r needs 3 or more values, got {values}")
    a = values / 2 - 1
    return float(stats.beta.sf((threshold + 1) / 2, a, a))


def statistic_values(statistic: str, window: int) -> int:
    """How many pairs of values one r is computed from: the RGB bands (pixel), or the bands over a w × w window."""
    return RGB_BANDS if statistic == "pixel" else RGB_BANDS * window * window


def pairs(x: int) -> list[tuple[int, int]]:
    """All x(x−1)/2 pairs of x inputs."""
    return [(i, j) for i in range(x) for j in range(i + 1, x)]
