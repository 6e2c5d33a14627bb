"""Check point input for the accuracy QA: CSV or GeoJSON, coordinates or residuals.

Columns (case-insensitive; a unit suffix `_m`, `_cm`, `_mm` or `_ft` may follow any length
column, `--units` sets the unit of the others, default metres):

- `id` (or `label`, `name`, `point`); optional `role` (check / control, or CP / GCP);
  optional `landcover` (vegetated / non-vegetated); optional `sigma_xy`, `sigma_z`: the
  standard deviation of one reference coordinate (per axis) and of the reference height;
- either residuals `dx, dy[, dz]` (product − reference; optional `x_ref, y_ref` place the
  point on the map), or product coordinates `x, y[, z]` with reference coordinates
  `x_ref, y_ref[, z_ref]`. `x` is east (or longitude), `y` north (or latitude).

The CRS is stated by `--crs`, a `crs` column (one value for the file), or a GeoJSON `crs`
member; GeoJSON without one is longitude/latitude (RFC 7946). Geographic coordinates are
turned into metres on the ellipsoid at each point; projected ones use the CRS's unit.
A missing column, a non-number, a duplicate id, mixed units or mixed CRSs is an InputError.
"""

from __future__ import annotations

import csv
import io
import json
import math
import re
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyproj

from aerosurvey.errors import InputError
from aerosurvey.qa.choices import UNITS

#: Largest residual accepted (m): anything larger is a wrong point or unit, and squaring
#: values near 1e300 would overflow the statistics.
MAX_RESIDUAL_M = 1.0e5
_LENGTH_COLUMNS = ("dx", "dy", "dz", "x", "y", "z", "x_ref", "y_ref", "z_ref", "sigma_xy", "sigma_z")
_ROLES = {"check": "check", "cp": "check", "checkpoint": "check", "check point": "check", "icp": "check",
          "control": "control", "gcp": "control", "ground control": "control", "control point": "control"}
_COVER = {"vegetated": True, "veg": True, "non-vegetated": False, "nonvegetated": False, "non_vegetated": False,
          "open": False, "": False}


@dataclass(frozen=True)
class CheckPoints:
    """Residuals and positions of the tested points, all lengths in metres.

    `x`, `y` are the reference positions in the input CRS's own coordinates (degrees for a
    geographic CRS), NaN when only residuals were given; `local_xy` gives metres for maps.
    """

    ids: tuple[str, ...]
    role: tuple[str, ...]  # "check" or "control"
    dx: np.ndarray
    dy: np.ndarray
    dz: np.ndarray  # NaN where no height was tested
    vegetated: np.ndarray  # bool
    x: np.ndarray
    y: np.ndarray
    sigma_xy: np.ndarray  # reference survey σ of one coordinate, NaN when not given
    sigma_z: np.ndarray
    source: str = ""
    units: str = "m"  # the unit of the file's lengths
    units_stated: bool = True  # False when metres were assumed for columns without a unit
    crs: str | None = None  # as stated, or None
    geographic: bool = False

    @property
    def n(self) -> int:
        return len(self.ids)

    @property
    def has_positions(self) -> bool:
        return self.n > 0 and bool(np.all(np.isfinite(self.x)) and np.all(np.isfinite(self.y)))

    def select(self, mask: np.ndarray) -> CheckPoints:
        idx = np.flatnonzero(np.asarray(mask, bool))

        def pick(a: np.ndarray) -> np.ndarray:
            return a[idx]

        return CheckPoints(tuple(self.ids[i] for i in idx), tuple(self.role[i] for i in idx), pick(self.dx),
                           pick(self.dy), pick(self.dz), pick(self.vegetated), pick(self.x), pick(self.y),
                           pick(self.sigma_xy), pick(self.sigma_z), self.source, self.units, self.units_stated,
                           self.crs, self.geographic)

    def with_roles(self, roles: tuple[str, ...]) -> CheckPoints:
        return CheckPoints(self.ids, roles, self.dx, self.dy, self.dz, self.vegetated, self.x, self.y,
                           self.sigma_xy, self.sigma_z, self.source, self.units, self.units_stated, self.crs,
                           self.geographic)

    def local_xy(self) -> tuple[np.ndarray, np.ndarray]:
        """Positions in metres east/north of the points' centre (geographic CRSs unrolled on the ellipsoid)."""
        if not self.geographic:
            return self.x - np.nanmean(self.x), self.y - np.nanmean(self.y)
        lon0, lat0 = float(np.nanmean(self.x)), float(np.nanmean(self.y))
        return geographic_offsets(self.x, self.y, np.full(self.n, lon0), np.full(self.n, lat0), self.crs)


def geographic_offsets(lon: np.ndarray, lat: np.ndarray, lon_ref: np.ndarray, lat_ref: np.ndarray,
                       crs: str | None) -> tuple[np.ndarray, np.ndarray]:
    """East/north metres of (lon, lat) from (lon_ref, lat_ref) on the CRS's ellipsoid.

    Uses the radii of curvature at the reference latitude; for differences of a few metres
    the error is far below a millimetre, which is what check point residuals need.
    """
    ell = pyproj.CRS.from_user_input(crs or "OGC:CRS84").ellipsoid
    if ell is None:
        raise InputError(f"CRS {crs!r} has no ellipsoid: geographic coordinates cannot be turned into metres")
    a, inv_f = ell.semi_major_metre, ell.inverse_flattening
    e2 = 0.0 if not inv_f else (2 - 1 / inv_f) / inv_f
    phi = np.radians(lat_ref)
    w = np.sqrt(1 - e2 * np.sin(phi) ** 2)
    n_radius = a / w
    m_radius = a * (1 - e2) / w**3
    dlon = (np.asarray(lon, float) - lon_ref + 180.0) % 360.0 - 180.0
    return np.radians(dlon) * n_radius * np.cos(phi), np.radians(np.asarray(lat, float) - lat_ref) * m_radius


def _split_unit(name: str) -> tuple[str, str | None]:
    m = re.fullmatch(r"(.+?)_(m|cm|mm|ft)", name)
    return (m.group(1), m.group(2)) if m else (name, None)


def _csv_rows(text: str, where: str) -> list[dict[str, Any]]:
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise InputError(f"{where}: no header and no rows")
    delim = ";" if lines[0].count(";") > lines[0].count(",") else ","
    return [dict(r) for r in csv.DictReader(io.StringIO("\n".join(lines)), delimiter=delim)]


def _crs_from_geojson(fc: dict[str, Any], where: str) -> str | None:
    member = fc.get("crs")
    if member is None:
        return None
    try:
        return str(member["properties"]["name"])
    except (KeyError, TypeError):
        raise InputError(f"{where}: the GeoJSON 'crs' member {member!r} has no properties.name") from None


def _geojson_rows(text: str, where: str) -> tuple[list[dict[str, Any]], str | None]:
    """Rows from the features' properties; a Point geometry gives the reference x, y (z)."""
    try:
        fc = json.loads(text)
        feats = fc["features"]
    except (json.JSONDecodeError, KeyError, TypeError) as exc:
        raise InputError(f"{where}: not a GeoJSON FeatureCollection ({exc})") from None
    crs = _crs_from_geojson(fc, where)
    rows = []
    for i, f in enumerate(feats):
        row = dict(f.get("properties") or {})
        geom = f.get("geometry") or {}
        if geom and geom.get("type") != "Point":
            raise InputError(f"{where}: feature {i + 1} is a {geom.get('type')}; check points are Point features")
        if geom and "x_ref" not in row:
            c = geom["coordinates"]
            row["x_ref"], row["y_ref"] = c[0], c[1]
            if len(c) > 2 and "z_ref" not in row:
                row["z_ref"] = c[2]
        rows.append(row)
    return rows, crs


def _resolve_crs(stated: list[str], option: str | None, where: str) -> pyproj.CRS | None:
    names = sorted({s.strip() for s in stated if s and s.strip()})
    if len(names) > 1:
        raise InputError(f"{where}: mixed CRSs {', '.join(names)}; one file, one CRS")
    if option and names and not _parse_crs(names[0], f"{where}: CRS").equals(_parse_crs(option, "--crs"),
                                                                           ignore_axis_order=True):
        raise InputError(f"--crs = {option!r} contradicts the file's CRS {names[0]!r}")
    text = option or (names[0] if names else None)
    return _parse_crs(text, f"{where}: CRS") if text else None


def _parse_crs(text: str, name: str) -> pyproj.CRS:
    try:
        return pyproj.CRS.from_user_input(text)
    except pyproj.exceptions.CRSError:
        raise InputError(f"{name} = {text!r} is not a CRS pyproj knows; give e.g. EPSG:5514 or EPSG:4326") from None


def read_points(path: Path, units: str | None = None, default_role: str = "check", crs: str | None = None) -> CheckPoints:
    """Read the tested points; `units` applies to length columns without a unit suffix."""
    if not path.exists():
        raise InputError(f"check points: {str(path)!r} does not exist")
    if units is not None and units not in UNITS:
        raise InputError(f"--units = {units!r} is not allowed: one of {', '.join(UNITS)}")
    where = path.name
    if path.is_dir():
        raise InputError(f"check points: {str(path)!r} is a folder; give a CSV or GeoJSON file")
    content = path.read_bytes()
    if b"\x00" in content[:65536]:
        raise InputError(f"{where}: a binary file (NUL bytes), not a CSV or GeoJSON text file")
    try:
        text = content.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(f"{where}: not UTF-8 text (byte {exc.start}); save the check points as UTF-8 CSV or "
                         "GeoJSON") from None
    stated: list[str] = []
    is_geojson = path.suffix.lower() in (".geojson", ".json")
    if is_geojson:
        rows, gj_crs = _geojson_rows(text, where)
        stated += [gj_crs] if gj_crs else []
    else:
        rows = _csv_rows(text, where)
    if not rows:
        raise InputError(f"{where}: no points")
    header = [str(c) for c in rows[0]]
    cols: dict[str, tuple[str, str | None]] = {}
    for raw in header:
        base, unit = _split_unit(raw.strip().lower())
        if base in cols:
            raise InputError(f"{where}: column {base!r} is given twice ({cols[base][0]!r} and {raw!r})")
        cols[base] = (raw, unit)
    if "crs" in cols:
        stated += [str(r.get(cols["crs"][0]) or "") for r in rows]
    crs_obj = _resolve_crs(stated, crs, where)
    if crs_obj is None and is_geojson:
        crs_obj = pyproj.CRS.from_user_input("OGC:CRS84")  # RFC 7946: GeoJSON is longitude/latitude
    geographic = bool(crs_obj is not None and crs_obj.is_geographic)
    crs_text = crs_obj.to_string() if crs_obj is not None else None
    crs_name = crs_obj.name if crs_obj is not None else "none"

    id_col = next((cols[c][0] for c in ("id", "label", "name", "point") if c in cols), None)
    if id_col is None:
        raise InputError(f"{where}: no id column (id, label, name or point); columns: {', '.join(header)}")
    have_res = {"dx", "dy"} <= set(cols)
    have_xy = {"x", "y", "x_ref", "y_ref"} <= set(cols)
    if not (have_res or have_xy):
        raise InputError(f"{where}: needs residual columns dx, dy (dz) or coordinates x, y (z) with x_ref, y_ref "
                         f"(z_ref); columns: {', '.join(header)}")
    if have_xy and not have_res and ("z" in cols) != ("z_ref" in cols):
        raise InputError(f"{where}: heights need both z and z_ref; only {'z' if 'z' in cols else 'z_ref'} is given")
    planar = [c for c in ("x", "y", "x_ref", "y_ref") if c in cols]
    if geographic:
        suffixed = [cols[c][0] for c in planar if cols[c][1]]
        if suffixed:
            raise InputError(f"{where}: {', '.join(suffixed)} carry a length unit, but the CRS "
                             f"{crs_name} is geographic (degrees)")
    checked = [c for c in _LENGTH_COLUMNS if c in cols and not (geographic and c in planar)]
    found = {c: cols[c][1] or units or "m" for c in checked}
    if crs_obj is not None and not geographic:
        # coordinates without a suffix are in the CRS's own unit (metre, foot, US survey foot)
        axis = crs_obj.axis_info[0]
        for c in planar:
            if not cols[c][1] and not math.isclose(axis.unit_conversion_factor, UNITS[found[c]], rel_tol=1e-4):
                raise InputError(f"{where}: column {cols[c][0]!r} is in {axis.unit_name} (the unit of "
                                 f"{crs_obj.name}) but other lengths are in {found[c]}; give unit suffixes or --units")
    if len(set(found.values())) > 1:
        detail = ", ".join(f"{cols[c][0]} in {u}" for c, u in found.items())
        raise InputError(f"{where}: mixed units ({detail}); state every length in one unit")
    unit = next(iter(found.values()), units or "m")
    units_stated = units is not None or all(cols[c][1] for c in checked)

    def num(row: dict[str, Any], c: str, i: int, factor: float | None = None) -> float:
        raw, u = cols[c]
        v = row.get(raw, "")
        if v is None or (isinstance(v, str) and not v.strip()):
            return math.nan
        try:
            val = float(v)
        except (TypeError, ValueError):
            raise InputError(f"{where}: row {i + 1} ({row.get(id_col)!r}), column {raw!r}: {v!r} is not a number") from None
        if not math.isfinite(val):
            raise InputError(f"{where}: row {i + 1} ({row.get(id_col)!r}), column {raw!r}: {v!r} is not a finite number")
        return val * (factor if factor is not None else UNITS[u or units or "m"])

    ids: list[str] = []
    roles: list[str] = []
    veg: list[bool] = []
    arr: dict[str, list[float]] = {k: [] for k in ("dx", "dy", "dz", "x", "y", "sxy", "sz")}
    pf = 1.0 if geographic else None
    for i, row in enumerate(rows):
        pid = str(row.get(id_col) or "").strip()
        if not pid:
            raise InputError(f"{where}: row {i + 1} has no id")
        ids.append(pid)
        role_text = str(row.get(cols["role"][0]) or "" if "role" in cols else "").strip().lower() or default_role
        if role_text not in _ROLES:
            raise InputError(f"{where}: row {i + 1} ({pid}): role {role_text!r} is not allowed: check or control "
                             "(CP or GCP)")
        roles.append(_ROLES[role_text])
        cover = str(row.get(cols["landcover"][0]) or "" if "landcover" in cols else "").strip().lower()
        if cover not in _COVER:
            raise InputError(f"{where}: row {i + 1} ({pid}): landcover {cover!r} is not allowed: vegetated or "
                             "non-vegetated")
        veg.append(_COVER[cover])
        xr = num(row, "x_ref", i, pf) if "x_ref" in cols else math.nan
        yr = num(row, "y_ref", i, pf) if "y_ref" in cols else math.nan
        if have_res:
            dx, dy = num(row, "dx", i), num(row, "dy", i)
            dz = num(row, "dz", i) if "dz" in cols else math.nan
        else:
            xp, yp = num(row, "x", i, pf), num(row, "y", i, pf)
            if geographic:
                ex, ny = geographic_offsets(np.array([xp]), np.array([yp]), np.array([xr]), np.array([yr]),
                                            crs_text)
                dx, dy = float(ex[0]), float(ny[0])
            else:
                dx, dy = xp - xr, yp - yr
            dz = num(row, "z", i) - num(row, "z_ref", i) if "z" in cols else math.nan
        if math.isnan(dx) or math.isnan(dy):
            raise InputError(f"{where}: row {i + 1} ({pid}) has no horizontal residual (empty dx/dy or coordinates)")
        for name, val in (("dx", dx), ("dy", dy), ("dz", dz)):
            if abs(val) > MAX_RESIDUAL_M:  # NaN compares False
                raise InputError(f"{where}: row {i + 1} ({pid}): residual {name} = {val:.6g} m is not allowed: at most "
                                 f"{MAX_RESIDUAL_M:g} m (a larger difference is not the same point measured twice)")
        arr["dx"].append(dx)
        arr["dy"].append(dy)
        arr["dz"].append(dz)
        arr["x"].append(xr)
        arr["y"].append(yr)
        arr["sxy"].append(num(row, "sigma_xy", i) if "sigma_xy" in cols else math.nan)
        arr["sz"].append(num(row, "sigma_z", i) if "sigma_z" in cols else math.nan)
    dup = sorted(p for p, k in Counter(ids).items() if k > 1)
    if dup:
        raise InputError(f"{where}: duplicate id(s) {', '.join(dup)}; every point needs its own id")
    for key, name in (("sxy", "sigma_xy"), ("sz", "sigma_z")):
        if any(v < 0 for v in arr[key] if not math.isnan(v)):
            raise InputError(f"{where}: {name} has a negative value; standard deviations are >= 0")
    a = {k: np.asarray(v, float) for k, v in arr.items()}
    return CheckPoints(tuple(ids), tuple(roles), a["dx"], a["dy"], a["dz"], np.asarray(veg, bool), a["x"], a["y"],
                       a["sxy"], a["sz"], where, unit, units_stated,
                       crs_obj.to_string() if crs_obj is not None else None, geographic)
