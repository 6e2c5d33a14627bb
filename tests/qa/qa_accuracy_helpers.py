"""Shared helpers for the accuracy QA tests (not a test module)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from aerosurvey.qa.accuracy_input import CheckPoints
from conftest import planned

REF = Path(__file__).resolve().parents[1] / "data" / "reference"
KUBAD = REF / "kubad_abad_gcp_residuals.csv"
OBRATAN = REF / "bayes_obratan.csv"
COUNTS_2014 = REF / "asprs2014_checkpoint_counts.csv"


def make_points(dx: Any, dy: Any, dz: Any = None, x: Any = None, y: Any = None, ids: Any = None, roles: Any = None,
                vegetated: Any = None, sigma_xy: Any = None, sigma_z: Any = None, crs: str | None = None) -> CheckPoints:
    n = len(dx)
    nan = np.full(n, np.nan)

    def arr(v: Any) -> np.ndarray:
        return nan.copy() if v is None else np.asarray(v, float)

    return CheckPoints(tuple(ids or [f"P{i + 1}" for i in range(n)]), tuple(roles or ["check"] * n),
                       np.asarray(dx, float), np.asarray(dy, float), arr(dz),
                       np.zeros(n, bool) if vegetated is None else np.asarray(vegetated, bool), arr(x), arr(y),
                       arr(sigma_xy), arr(sigma_z), "test", "m", True, crs, False)


def scaled_to(e: np.ndarray, rms: float) -> np.ndarray:
    """`e` rescaled so that sqrt(mean(e²)) = rms."""
    return e * rms / math.sqrt(float(np.mean(e**2)))


def planned_square(folder, side_m: float, name: str, profiles: tuple[str, ...] = ()):
    """`aerosurvey plan` of a side_m square at 2 cm GSD in UTM 33N (corner 500000, 5470000) into `folder`."""
    import json as _json

    import pyproj
    import tomli_w
    from click.testing import CliRunner

    from aerosurvey.cli import main

    src = folder.parent / f"{folder.name}-spec"
    src.mkdir()
    t = pyproj.Transformer.from_crs("EPSG:32633", "OGC:CRS84", always_xy=True)
    x0, y0 = 500000.0, 5470000.0
    corners = [(x0, y0), (x0 + side_m, y0), (x0 + side_m, y0 + side_m), (x0, y0 + side_m), (x0, y0)]
    ring = [[round(v, 9) for v in t.transform(a, b)] for a, b in corners]
    (src / "area.geojson").write_text(_json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {}, "geometry": {"type": "Polygon", "coordinates": [ring]}}]}))
    spec = {"mission": {"name": name, "crs": "EPSG:32633"}, "area": {"file": "area.geojson"},
            "camera": {"model": "sony-a6000-16mm"}, "targets": {"gsd_cm": 2.0}, "flight": {"heading": 0.0},
            "rules": {"profiles": list(profiles)}}
    (src / "spec.toml").write_text(tomli_w.dumps(spec))
    res = CliRunner().invoke(main, ["plan", str(src / "spec.toml"), "-o", str(folder)])
    assert planned(res.exit_code, res.output), res.output
    return folder


#: Everything a standard's statement names (qa/identity.py), for tests that want a valid test:
#: the command's options, and the same as Settings fields (CRS and survey sigmas apart).
STATEMENT_ARGS = ["--product", "orthoimagery", "--gsd-cm", "2", "--product-date", "2026-05-12", "--crs",
                  "EPSG:32633", "--vertical-datum", "EGM2008 geoid", "--ref-sigma-xy", "0.005", "--ref-sigma-z",
                  "0.008", "--survey-source", "GNSS RTK, 30 s occupations"]


def product() -> Any:
    from aerosurvey.qa.identity import Product

    return Product("orthoimagery", 2.0, "2026-05-12", "EGM2008 geoid", "GNSS RTK, 30 s occupations")
