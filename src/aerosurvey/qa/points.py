"""Check point input: CSV or GeoJSON with product and reference coordinates, or residuals.

Columns (case-insensitive; a unit suffix _m, _cm or _mm may follow any length column):
- `id` (or `label`, `name`), optional `role` (control / check), optional `landcover`
  (vegetated / non-vegetated), optional `sigma_h`, `sigma_v` (reference survey standard
  deviations per point);
- either product and reference coordinates `x, y, z, x_ref, y_ref, z_ref`, or residuals
  `dx, dy, dz` (product − reference). z/dz may be missing for horizontal-only tests.
Everything is converted to metres. A column in another unit than the others of its kind
is refused (mixed units), as are missing columns, non-numbers and duplicate ids.
"""

from __future__ import annotations

import csv
import io
import json
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aerosurvey.errors import InputError

_UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}


@dataclass(frozen=True)
class CheckPoints:
    ids: list[str]
    role: list[str]  # "check" or "control"
    dx: np.ndarray  # metres, product − reference; NaN where not given
    dy: np.ndarray
    dz: np.ndarray
    vegetated: np.ndarray  # bool
    x: np.ndarray  # reference position (for maps and distribution); NaN when only residuals are given
    y: np.ndarray
    sigma_h: np.ndarray  # reference survey standard deviation per point (m), NaN when unknown
    sigma_v: np.ndarray
    source: str

    def select(self, mask: np.ndarray) -> "CheckPoints":
        idx = np.flatnonzero(mask)
        return CheckPoints([self.ids[i] for i in idx], [self.role[i] for i in idx], self.dx[idx], self.dy[idx],
                           self.dz[idx], self.vegetated[idx], self.x[idx], self.y[idx], self.sigma_h[idx],
                           self.sigma_v[idx], self.source)

    @property
    def n(self) -> int:
        return len(self.ids)


def _split(name: str) -> tuple[str, str | None]:
    m = re.fullmatch(r"(.+?)_(m|cm|mm)", name)
    return (m.group(1), m.group(2)) if m else (name, None)


def _rows_from_csv(text: str, where: str) -> list[dict[str, str]]:
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise InputError(f"{where}: no rows")
    return [dict(r) for r in csv.DictReader(io.StringIO("\n".join(lines)))]


def _rows_from_geojson(text: str, where: str) -> list[dict[str, object]]:
    try:
        fc = json.loads(text)
        feats = fc["features"]
    except (json.JSONDecodeError, KeyError, TypeError) as exc:
        raise InputError(f"{where}: not a GeoJSON FeatureCollection ({exc})") from None
    rows = []
    for f in feats:
        row = dict(f.get("properties") or {})
        geom = f.get("geometry") or {}
        if geom.get("type") == "Point" and "x_ref" not in row and "dx" not in row:
            c = geom["coordinates"]
            row.setdefault("x_ref", c[0])
            row.setdefault("y_ref", c[1])
            if len(c) > 2:
                row.setdefault("z_ref", c[2])
        rows.append(row)
    return rows


def read_points(path: Path, units: str | None = None, default_role: str = "check") -> CheckPoints:
    """Read check points; `units` applies to columns without a unit suffix (default metres)."""
    if not path.exists():
        raise InputError(f"check points: {str(path)!r} does not exist")
    text = path.read_text(encoding="utf-8-sig")
    where = path.name
    rows = _rows_from_geojson(text, where) if path.suffix.lower() in (".geojson", ".json") else _rows_from_csv(text, where)
    if not rows:
        raise InputError(f"{where}: no points")
    if units is not None and units not in _UNITS:
        raise InputError(f"--units = {units!r} is not allowed: m, cm or mm")
    cols: dict[str, tuple[str, str | None]] = {}
    for raw in rows[0]:
        base, unit = _split(str(raw).strip().lower())
        cols[base] = (raw, unit)
    id_col = next((cols[c][0] for c in ("id", "label", "name", "point") if c in cols), None)
    if id_col is None:
        raise InputError(f"{where}: no id column (id, label, name or point); columns: {', '.join(map(str, rows[0]))}")
    have_res = {"dx", "dy"} <= set(cols)
    have_xy = {"x", "y", "x_ref", "y_ref"} <= set(cols)
    if not (have_res or have_xy):
        raise InputError(f"{where}: needs residual columns dx, dy (dz) or coordinates x, y (z) with x_ref, y_ref (z_ref); "
                         f"columns: {', '.join(map(str, rows[0]))}")
    length_cols = [c for c in ("dx", "dy", "dz", "x", "y", "z", "x_ref", "y_ref", "z_ref", "sigma_h", "sigma_v") if c in cols]
    found_units = {cols[c][1] or units or "m" for c in length_cols if c in ("dx", "dy", "dz", "sigma_h", "sigma_v")}
    if len(found_units) > 1:
        raise InputError(f"{where}: mixed units in the residual columns ({', '.join(sorted(found_units))}); use one unit")

    def num(row: dict, c: str, i: int) -> float:
        raw, unit = cols[c]
        v = row.get(raw, "")
        if v is None or (isinstance(v, str) and v.strip() == ""):
            return math.nan
        try:
            val = float(v)
        except (TypeError, ValueError):
            raise InputError(f"{where}: row {i + 1} ({row.get(id_col)!r}), column {raw!r}: {v!r} is not a number") from None
        if not math.isfinite(val):
            raise InputError(f"{where}: row {i + 1}, column {raw!r}: {v!r} is not a finite number")
        return val * _UNITS[unit or units or "m"]

    ids, roles, veg = [], [], []
    arr = {k: [] for k in ("dx", "dy", "dz", "x", "y", "sh", "sv")}
    for i, row in enumerate(rows):
        pid = str(row.get(id_col, "")).strip()
        if not pid:
            raise InputError(f"{where}: row {i + 1} has no id")
        ids.append(pid)
        role = str(row.get(cols["role"][0], default_role) if "role" in cols else default_role).strip().lower()
        role = {"gcp": "control", "cp": "check", "checkpoint": "check", "ground control": "control"}.get(role, role)
        if role not in ("check", "control"):
            raise InputError(f"{where}: row {i + 1} ({pid}): role {role!r}; allowed: check, control (or CP, GCP)")
        roles.append(role)
        lc = str(row.get(cols["landcover"][0], "non-vegetated") if "landcover" in cols else "non-vegetated").strip().lower()
        if lc not in ("vegetated", "non-vegetated", "nonvegetated", "open", "veg", ""):
            raise InputError(f"{where}: row {i + 1} ({pid}): landcover {lc!r}; allowed: vegetated, non-vegetated")
        veg.append(lc in ("vegetated", "veg"))
        if have_res:
            arr["dx"].append(num(row, "dx", i))
            arr["dy"].append(num(row, "dy", i))
            arr["dz"].append(num(row, "dz", i) if "dz" in cols else math.nan)
            arr["x"].append(num(row, "x_ref", i) if "x_ref" in cols else math.nan)
            arr["y"].append(num(row, "y_ref", i) if "y_ref" in cols else math.nan)
        else:
            xr, yr = num(row, "x_ref", i), num(row, "y_ref", i)
            arr["dx"].append(num(row, "x", i) - xr)
            arr["dy"].append(num(row, "y", i) - yr)
            arr["dz"].append(num(row, "z", i) - num(row, "z_ref", i) if {"z", "z_ref"} <= set(cols) else math.nan)
            arr["x"].append(xr)
            arr["y"].append(yr)
        arr["sh"].append(num(row, "sigma_h", i) if "sigma_h" in cols else math.nan)
        arr["sv"].append(num(row, "sigma_v", i) if "sigma_v" in cols else math.nan)
        if math.isnan(arr["dx"][-1]) or math.isnan(arr["dy"][-1]):
            raise InputError(f"{where}: row {i + 1} ({pid}) has no horizontal residual")
    dup = sorted({p for p in ids if ids.count(p) > 1})
    if dup:
        raise InputError(f"{where}: duplicate id(s) {', '.join(dup)}")
    a = {k: np.asarray(v, float) for k, v in arr.items()}
    return CheckPoints(ids, roles, a["dx"], a["dy"], a["dz"], np.asarray(veg, bool), a["x"], a["y"], a["sh"], a["sv"], where)
